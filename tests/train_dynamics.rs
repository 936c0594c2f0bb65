//! Consistency oracles of the drivetrain model (issue 5, acceptance 3): a train with one mesh
//! equals the core single-mesh pair; the idler with rigid bearings equals an independent
//! implementation of the reduced rotational model (Liu 2007 eq. 3.1–3.2); a mesh-phase shift
//! equals a time shift.

mod common;

use common::idler2::Idler2;
use geardyn::mesh::MeshStiffness;
use geardyn::model::train::TrainSimulation;
use geardyn::scene::train::MeshForceModel;
use geardyn::scene::Scene;
use geardyn::scene::{ContactLaw, MethodChoice, PairScene};
use geardyn::simulation::Simulation;
use geardyn::solve::rk::{Method, RkOptions, RkStepper};

/// Runs the core pair and the one-mesh train side by side and returns the largest DTE and
/// force differences relative to the largest |DTE| and |force|.
fn pair_vs_train(text: &str, method: MethodChoice, periods: f64) -> (f64, f64, u64) {
    let mut core_scene = PairScene::from_toml_str(text, "core").unwrap();
    // The single-mesh file's resolved scene is its one-mesh drivetrain; run it there.
    let mut train_scene = Scene::from_toml_str(text, "train")
        .unwrap()
        .on_drivetrain_kernel()
        .unwrap();
    core_scene.solver.method = method;
    train_scene.solver.method = method;
    let mut core = Simulation::new(&core_scene).unwrap();
    let mut train = TrainSimulation::new(&train_scene).unwrap();
    // The model is compared, on the pair's path: segment by segment. The train's guarded
    // products (src/solve/exact/guarded.rs, contact-loss law) are exact to rounding, not to
    // the pair's last bit, and the resonant orbit below, with contact loss on every cycle,
    // multiplies a rounding difference by about 10 every 5 periods (1e-15 to 1e-9 in 70
    // periods, the same events). The guarded path is checked against the segment-wise one
    // in tests/exact_composite.rs.
    train.use_composites(false);
    assert_eq!(train.model().elastic_dim(), 1);
    let dte = train
        .output_names()
        .iter()
        .position(|n| *n == format!("{}.dte", train_scene.meshes[0].name))
        .unwrap();
    let force = train
        .output_names()
        .iter()
        .position(|n| *n == format!("{}.force", train_scene.meshes[0].name))
        .unwrap();
    let period = core.model().mesh_period();
    let steps = (periods * 40.0) as usize;
    let (mut d_dte, mut d_f, mut max_dte, mut max_f) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    let mut out = Vec::new();
    for k in 1..=steps {
        let t = k as f64 * period / 40.0;
        core.advance_to(t).unwrap();
        train.advance_to(t).unwrap();
        let c = core.outputs();
        train.outputs(&mut out);
        // mesh.dte_rate, mesh.contact_state, mesh.phase, mesh.stiffness: the same numbers.
        for (core_index, column) in [
            (1, "dte_rate"),
            (3, "contact_state"),
            (4, "phase"),
            (5, "stiffness"),
        ] {
            let name = format!("{}.{column}", train_scene.meshes[0].name);
            let i = train
                .output_names()
                .iter()
                .position(|n| *n == name)
                .unwrap();
            assert_eq!(c[core_index], out[i], "{name} at t = {t}");
        }
        d_dte = d_dte.max((c[0] - out[dte]).abs());
        d_f = d_f.max((c[2] - out[force]).abs());
        max_dte = max_dte.max(c[0].abs());
        max_f = max_f.max(c[2].abs());
    }
    (d_dte / max_dte, d_f / max_f, core.stats().events)
}

#[test]
fn one_mesh_train_equals_core_pair() {
    // The shipped single-mesh scene: backlash, STE harmonic, rectangular stiffness, damping.
    let spur = include_str!("../fmu/spur_pair/scene.toml");
    for method in [MethodChoice::Exact, MethodChoice::Rk] {
        let (e_dte, e_f, events) = pair_vs_train(spur, method, 200.0);
        println!("spur_pair {method:?}: dte {e_dte:e}, force {e_f:e}, {events} events");
        assert!(
            e_dte <= 1e-12 && e_f <= 1e-12,
            "{method:?}: {e_dte:e} {e_f:e}"
        );
    }
    // A resonant case with contact loss on every cycle.
    let text = common::scene_text(
        "contact = \"contact_loss\"\ndamping_ratio = 0.02\n[mesh.stiffness]\nkind = \"rectangular\"\n\
         mean = 2e8\npeak_to_peak_ratio = 0.4\ncontact_ratio = 1.4\n[mesh.ste]\ncos = [3e-6]\n",
        &format!(
            "pinion_speed = {}\ninput_torque = 20.0",
            common::pinion_speed_for_mesh_frequency(3000.0)
        ),
        "",
    );
    let (e_dte, e_f, events) = pair_vs_train(&text, MethodChoice::Exact, 100.0);
    println!("contact loss: dte {e_dte:e}, force {e_f:e}, {events} events");
    assert!(
        events > 20,
        "the case must exercise contact loss ({events} events)"
    );
    assert!(e_dte <= 1e-12 && e_f <= 1e-12, "{e_dte:e} {e_f:e}");
    // Smooth (Fourier) and sloped (trapezoidal) stiffness take the RK path with stops.
    for stiffness in [
        "kind = \"fourier\"\nmean = 2e8\ncos = [3e7, 5e6]\nsin = [1e7]\nphase = 0.1",
        "kind = \"trapezoidal\"\nmean = 2e8\npeak_to_peak_ratio = 0.4\ncontact_ratio = 1.4\ntransition = 0.1",
    ] {
        let text = common::scene_text(
            &format!("contact = \"backlash\"\nbacklash = 2e-6\ndamping_ratio = 0.03\n[mesh.stiffness]\n{stiffness}\n[mesh.ste]\ncos = [1e-6]\n"),
            &format!(
                "pinion_speed = {}\ninput_torque = 5.0",
                common::pinion_speed_for_mesh_frequency(2800.0)
            ),
            "",
        );
        let (e_dte, e_f, events) = pair_vs_train(&text, MethodChoice::Rk, 100.0);
        println!("{stiffness:?}: dte {e_dte:e}, force {e_f:e}, {events} events");
        assert!(events > 10, "contact events expected ({events})");
        assert!(e_dte <= 1e-12 && e_f <= 1e-12, "{e_dte:e} {e_f:e}");
    }
}

/// The Table 2.1 idler with rigid bearings, no ground couplings, lumped rectangular meshes.
fn rotational_idler(f_mesh: f64, damping: f64, phase2: f64) -> Scene {
    let mut s = Scene::example("idler_gearset")
        .unwrap()
        .with_rigid_bearings();
    for g in &mut s.gears {
        g.ground_stiffness = 0.0;
    }
    s.modal_damping_ratio = 0.0;
    let rect = [(2.9831e8, 0.35, 1.504), (3.2108e8, 0.4, 1.510)];
    for (m, (mean, eps, c)) in s.meshes.iter_mut().zip(rect) {
        m.force = MeshForceModel::Lumped {
            stiffness: MeshStiffness::rectangular(mean, eps, c, 0.0),
            ste: Default::default(),
        };
        m.damping = damping;
        m.contact = ContactLaw::ContactLoss;
    }
    s.meshes[1].phase = phase2;
    s.operating.input_speed = std::f64::consts::TAU * f_mesh / 38.0;
    s
}

fn oracle(f_mesh: f64, damping: f64, phase2: f64) -> Idler2 {
    Idler2::new(
        [0.002621, 0.01091, 0.1193],
        [0.04535, 0.06564, 0.11218],
        100.0,
        f_mesh,
        [(2.9831e8, 0.35, 1.504), (3.2108e8, 0.4, 1.510)],
        [damping; 2],
        phase2,
    )
}

#[test]
fn rigid_bearing_idler_equals_reduced_rotational_model() {
    let (f_mesh, damping, phase2) = (3050.0, 400.0, 0.3);
    let scene = rotational_idler(f_mesh, damping, phase2);
    let mut sim = TrainSimulation::new(&scene).unwrap();
    assert_eq!(sim.method_name(), "exact");
    // The elastic coordinates are the two mesh deflections and M̂ is eq. (3.2).
    let model = sim.model();
    assert_eq!(model.elastic_dim(), 2);
    let mut sys = oracle(f_mesh, damping, phase2);
    let m_hat = model.reduced_mass();
    for i in 0..2 {
        for j in 0..2 {
            let rel = (m_hat[(i, j)] - sys.m[i][j]).abs() / sys.m[0][0];
            assert!(
                rel < 1e-13,
                "M̂[{i}{j}] = {} vs {}",
                m_hat[(i, j)],
                sys.m[i][j]
            );
        }
    }
    let y0 = sys.static_state();
    for (x, x0) in sim.state().iter().zip(&y0[..2]) {
        assert!((x - x0).abs() <= 1e-13 * x0);
    }
    let mut rk = RkStepper::new(
        RkOptions {
            rtol: 1e-13,
            atol: 1e-20,
            ..RkOptions::new(Method::Dop853)
        },
        4,
    )
    .unwrap();
    rk.set_state(0.0, &y0);
    let names = sim.output_names().to_vec();
    let col = |n: &str| names.iter().position(|x| x == n).unwrap();
    let (c1, c2) = (col("mesh1.dte"), col("mesh2.dte"));
    let mut out = Vec::new();
    let (mut err, mut scale) = (0.0f64, 0.0f64);
    let mut lost = [false; 2];
    let mut lost_samples = [0usize; 2];
    for k in 1..=60 * 20 {
        let t = k as f64 / (20.0 * f_mesh);
        sim.advance_to(t).unwrap();
        rk.advance_to(&mut sys, t).unwrap();
        sim.outputs(&mut out);
        let y = rk.y();
        err = err.max((out[c1] - y[0]).abs()).max((out[c2] - y[1]).abs());
        scale = scale.max(y[0].abs()).max(y[1].abs());
        for j in 0..2 {
            lost[j] |= !sys.contact[j];
            lost_samples[j] += usize::from(!sys.contact[j]);
        }
    }
    // The running contact-loss fraction against the oracle's share of separated samples.
    for (j, name) in ["mesh1", "mesh2"].iter().enumerate() {
        let model = out[col(&format!("{name}.contact_loss_fraction"))];
        let oracle = lost_samples[j] as f64 / 1200.0;
        println!("{name}: contact-loss fraction {model:.4} (oracle samples {oracle:.4})");
        assert!((model - oracle).abs() < 0.01, "{name}: {model} vs {oracle}");
    }
    println!(
        "rigid-bearing idler vs (3.1): {:e} relative, {} events, contact loss {lost:?}",
        err / scale,
        sim.stats().events
    );
    assert!(
        lost[0] && lost[1],
        "the case must lose contact on both meshes"
    );
    assert!(err <= 1e-9 * scale, "{:e}", err / scale);
}

#[test]
fn mesh_phase_shift_equals_time_shift() {
    // Model-1 idler with compliant bearings, tip relief, modal damping (exact propagator).
    let a_scene = Scene::example("idler_gearset").unwrap();
    let f1 = a_scene.mesh_frequency(0, a_scene.operating.input_speed);
    let shift_cycles = 0.37;
    let delta = shift_cycles / f1;
    let mut a = TrainSimulation::new(&a_scene).unwrap();
    a.advance_to(delta).unwrap();
    let y_delta = a.state().to_vec();
    let mut b_scene = a_scene.clone();
    b_scene.meshes[0].initial_phase += shift_cycles;
    let mut b = TrainSimulation::new(&b_scene).unwrap();
    b.set_state(0.0, &y_delta);
    let (mut oa, mut ob) = (Vec::new(), Vec::new());
    let (mut err, mut scale) = (0.0f64, 0.0f64);
    for k in 1..=400 {
        let t = k as f64 / (10.0 * f1);
        a.advance_to(delta + t).unwrap();
        b.advance_to(t).unwrap();
        a.outputs(&mut oa);
        b.outputs(&mut ob);
        for (name, (x, y)) in a.output_names().iter().zip(oa.iter().zip(&ob)) {
            if name.ends_with(".dte") || name.ends_with(".force") {
                err = err.max(
                    (x - y).abs()
                        / x.abs()
                            .max(1e-30)
                            .max(if name.ends_with(".dte") { 1e-5 } else { 2e3 }),
                );
            }
            if name.ends_with(".pairs_in_contact") {
                assert_eq!(x, y, "{name} at t = {t}");
            }
        }
        scale = scale.max(oa[0].abs());
    }
    println!(
        "phase shift vs time shift: {err:e} relative, {} events",
        a.stats().events
    );
    assert!(
        a.stats().events > 10,
        "tooth pairs must make and lose contact"
    );
    assert!(err <= 1e-9, "{err:e}");
    // Shifting mesh 2 alone is a different excitation: the response must change.
    let mut c_scene = a_scene.clone();
    c_scene.meshes[1].phase = 0.25;
    let mut c = TrainSimulation::new(&c_scene).unwrap();
    c.advance_to(delta + 400.0 / (10.0 * f1)).unwrap();
    let mut oc = Vec::new();
    c.outputs(&mut oc);
    let idx = a
        .output_names()
        .iter()
        .position(|n| n == "mesh2.force")
        .unwrap();
    assert!(
        (oc[idx] - oa[idx]).abs() > 1.0,
        "mesh phasing has no effect"
    );
}

/// The exact propagator's segment matrices (augmented state with STE harmonics and gap ramps)
/// and the RK right-hand side are two codings of the same equations: on the Model-1 idler with
/// tip relief (partial contact loss events) they agree to the RK tolerance.
#[test]
fn exact_and_rk_agree_on_model_1_idler() {
    let mut scene = Scene::example("idler_gearset").unwrap();
    // Near the 2530 Hz mode with light damping: pairs separate and re-engage.
    scene.operating.input_speed = std::f64::consts::TAU * 2450.0 / 38.0;
    scene.modal_damping_ratio = 0.01;
    let mut rk_scene = scene.clone();
    rk_scene.solver.method = MethodChoice::Rk;
    rk_scene.solver.rtol = 1e-12;
    rk_scene.solver.atol = 1e-18;
    let mut exact = TrainSimulation::new(&scene).unwrap();
    let mut rk = TrainSimulation::new(&rk_scene).unwrap();
    assert_eq!(exact.method_name(), "exact");
    let f1 = scene.mesh_frequency(0, scene.operating.input_speed);
    let (mut oe, mut or) = (Vec::new(), Vec::new());
    let (mut err, mut scale) = (0.0f64, 0.0f64);
    for k in 1..=30 * 16 {
        let t = k as f64 / (16.0 * f1);
        exact.advance_to(t).unwrap();
        rk.advance_to(t).unwrap();
        exact.outputs(&mut oe);
        rk.outputs(&mut or);
        for (name, (a, b)) in exact.output_names().iter().zip(oe.iter().zip(&or)) {
            if name.ends_with(".dte") {
                err = err.max((a - b).abs());
                scale = scale.max(a.abs());
            }
        }
    }
    println!(
        "Model-1 exact vs rk: {:e} relative; events {} / {}",
        err / scale,
        exact.stats().events,
        rk.stats().events
    );
    assert!(exact.stats().events > 20);
    assert_eq!(exact.stats().events, rk.stats().events);
    assert!(err <= 1e-8 * scale, "{:e}", err / scale);
}

/// Eq. (2.9): without profile modification all pairs of a mesh separate together, so Model-1
/// with the rectangular pair idealisation is the lumped rectangular mesh (same mean, p-p and
/// contact ratio), contact loss included. Two different codings: per-pair slots vs one spring.
#[test]
fn model_1_without_relief_equals_lumped_mesh() {
    let mut pairs = Scene::example("idler_gearset").unwrap();
    for m in &mut pairs.meshes {
        if let MeshForceModel::Pairs { relief, .. } = &mut m.force {
            *relief = Default::default();
        }
    }
    // Near the 2529 Hz mode with little damping: total contact loss on the meshes.
    pairs.operating.input_speed = std::f64::consts::TAU * 2450.0 / 38.0;
    pairs.modal_damping_ratio = 0.005;
    let mut lumped = pairs.clone();
    let rect = [(2.9831e8, 0.35, 1.504), (3.2108e8, 0.4, 1.510)];
    for (m, (mean, eps, c)) in lumped.meshes.iter_mut().zip(rect) {
        m.force = MeshForceModel::Lumped {
            stiffness: MeshStiffness::rectangular(mean, eps, c, 0.0),
            ste: Default::default(),
        };
    }
    let mut a = TrainSimulation::new(&pairs).unwrap();
    let mut b = TrainSimulation::new(&lumped).unwrap();
    // Same start (the pair model's "static" start sits on the loaded STE at p0, the lumped
    // one on the mean deflection).
    let y0 = b.state().to_vec();
    a.set_state(0.0, &y0);
    let f1 = pairs.mesh_frequency(0, pairs.operating.input_speed);
    let (mut oa, mut ob) = (Vec::new(), Vec::new());
    let (mut err, mut scale, mut lost) = (0.0f64, 0.0f64, 0usize);
    for k in 1..=40 * 16 {
        let t = k as f64 / (16.0 * f1);
        a.advance_to(t).unwrap();
        b.advance_to(t).unwrap();
        a.outputs(&mut oa);
        b.outputs(&mut ob);
        for name in ["mesh1.dte", "mesh2.dte", "mesh1.force", "mesh2.force"] {
            let ia = a.output_names().iter().position(|n| n == name).unwrap();
            let ib = b.output_names().iter().position(|n| n == name).unwrap();
            let s = if name.ends_with("dte") { 1e-5 } else { 2205.0 };
            err = err.max((oa[ia] - ob[ib]).abs() / s);
            scale = scale.max(oa[ia].abs() / s);
        }
        let ic = b
            .output_names()
            .iter()
            .position(|n| n == "mesh2.contact_state")
            .unwrap();
        lost += usize::from(ob[ic] == 0.0);
    }
    println!("Model-1 without relief vs lumped: {err:e} (scaled), {lost} samples with total loss");
    assert!(lost > 10, "the case must lose contact");
    assert!(err <= 1e-9 * scale, "{err:e}");
}

/// The Table 2.1 idler with rigid bearings and its ground couplings (grounded: physical
/// coordinates, no reduction) against eq. (2.7) coded independently in
/// `tests/common/idler3.rs`.
#[test]
fn rigid_bearing_idler_with_couplings_equals_eq_2_7() {
    let (f_mesh, damping, phase2) = (3050.0, 400.0, 0.3);
    let mut scene = rotational_idler(f_mesh, damping, phase2);
    let ground = [3389.6, 0.0, 11297.9];
    for (g, k) in scene.gears.iter_mut().zip(ground) {
        g.ground_stiffness = k;
    }
    let mut sim = TrainSimulation::new(&scene).unwrap();
    assert_eq!(sim.model().elastic_dim(), 3);
    let mut sys = common::idler3::Idler3::new(
        [0.002621, 0.01091, 0.1193],
        [0.04535, 0.06564, 0.11218],
        ground,
        100.0,
        f_mesh,
        [(2.9831e8, 0.35, 1.504), (3.2108e8, 0.4, 1.510)],
        damping,
        phase2,
    );
    let mut rk = RkStepper::new(
        RkOptions {
            rtol: 1e-13,
            atol: 1e-20,
            ..RkOptions::new(Method::Dop853)
        },
        6,
    )
    .unwrap();
    rk.set_state(0.0, &sys.static_state());
    let names = sim.output_names().to_vec();
    let col = |n: &str| names.iter().position(|x| x == n).unwrap();
    let (c1, c2) = (col("mesh1.dte"), col("mesh2.dte"));
    let mut out = Vec::new();
    let (mut err, mut scale, mut lost) = (0.0f64, 0.0f64, [false; 2]);
    for k in 1..=60 * 20 {
        let t = k as f64 / (20.0 * f_mesh);
        sim.advance_to(t).unwrap();
        rk.advance_to(&mut sys, t).unwrap();
        sim.outputs(&mut out);
        let z = common::idler3::Idler3::dte(rk.y());
        err = err.max((out[c1] - z[0]).abs()).max((out[c2] - z[1]).abs());
        scale = scale.max(z[0].abs()).max(z[1].abs());
        for (l, c) in lost.iter_mut().zip(sys.contact) {
            *l |= !c;
        }
    }
    println!(
        "grounded rotational idler vs (2.7): {:e} relative",
        err / scale
    );
    assert!(lost[0] && lost[1], "contact loss on both meshes");
    assert!(err <= 1e-9 * scale, "{:e}", err / scale);
}

/// The drivetrain's frozen-mode Jacobian (variational equations of `periodic` and `floquet` on
/// non-LTI trains, RODAS4) is the derivative of its right-hand side: central differences on
/// the 8-DOF idler gearset (bearings, modal damping, contact loss) and the 15-DOF 4-mesh
/// compliant benchmark chain, in every coordinate.
#[test]
fn train_jacobian_is_the_derivative_of_the_right_hand_side() {
    use geardyn::scene::train::{ChainBearings, ChainContact, ChainSpec};
    let chain = ChainSpec::new(4, ChainBearings::Compliant, ChainContact::ContactLoss);
    for scene in [
        Scene::example("idler_gearset").unwrap(),
        Scene::chain(chain).unwrap(),
    ] {
        jacobian_matches_central_differences(&scene);
    }
}

fn jacobian_matches_central_differences(scene: &Scene) {
    use geardyn::model::train::GearTrain;
    use geardyn::solve::HybridSystem;
    let mut train = GearTrain::new(scene).unwrap();
    let y0 = train.initial_state(scene).unwrap();
    let n = y0.len();
    // A state inside the mode (away from the contact surfaces): the static one, moving.
    let y: Vec<f64> = y0
        .iter()
        .enumerate()
        .map(|(i, v)| {
            if i < n / 2 {
                *v
            } else {
                1e-3 * (i as f64).sin()
            }
        })
        .collect();
    let t = 1.3e-4;
    let mut jac = vec![0.0; n * n];
    assert!(train.jacobian(t, &y, &mut jac));
    let scale = y0[..n / 2].iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let (mut fp, mut fm) = (vec![0.0; n], vec![0.0; n]);
    let mut worst: f64 = 0.0;
    let mut norm: f64 = 0.0;
    for k in 0..n {
        let h = if k < n / 2 { 1e-6 * scale } else { 1e-6 };
        let (mut yp, mut ym) = (y.clone(), y.clone());
        yp[k] += h;
        ym[k] -= h;
        train.rhs(t, &yp, &mut fp);
        train.rhs(t, &ym, &mut fm);
        for i in 0..n {
            let fd = (fp[i] - fm[i]) / (2.0 * h);
            worst = worst.max((fd - jac[i * n + k]).abs());
            norm = norm.max(jac[i * n + k].abs());
        }
    }
    println!(
        "{}: train Jacobian vs central differences: {:.3e} of its largest entry",
        scene.name,
        worst / norm
    );
    assert!(worst <= 1e-7 * norm, "{worst} vs {norm}");
}
