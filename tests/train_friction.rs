//! Tooth friction in the drivetrain graph (issue 6, part B; Liu 2007 Ch. 5): with μ = β = 0 the
//! friction mesh equals the frictionless pair (acceptance 5); the static mesh force follows
//! the closed form (4.40); the friction-bending stiffness reproduces the notes' harmonic table
//! |Θ_s| (§4.2 [C]); bad friction input is rejected naming field and value (acceptance 6).
//! The time-domain oracle (an independent scipy implementation of eq. 4.44) is
//! `tests/python/test_friction_reference.py`.

use std::f64::consts::{PI, TAU};

use geardyn::model::train::mesh::CycleTable;
use geardyn::model::train::{run_train, GearTrain, TrainSimulation};
use geardyn::scene::train::{PairGap, PairStiffness};
use geardyn::scene::Scene;

const FRICTION_PAIR: &str = include_str!("../examples/friction_pair.toml");
const FRICTION_BLOCK: &str =
    "[mesh.friction]\ncoefficient = 0.1\nbending_factor = 0.5\npitch_point = 0.72\n";

fn scene(text: &str) -> Scene {
    Scene::from_toml_str(text, "test").unwrap()
}

fn with_friction(block: &str) -> String {
    assert!(FRICTION_PAIR.contains(FRICTION_BLOCK));
    FRICTION_PAIR.replace(FRICTION_BLOCK, block)
}

/// Largest difference of `names` between two runs, relative to the largest |value| of each.
fn max_relative(
    a: &geardyn::model::train::TrainTrajectory,
    b: &geardyn::model::train::TrainTrajectory,
    names: &[&str],
) -> f64 {
    names
        .iter()
        .map(|name| {
            let (ia, ib) = (a.column(name).unwrap(), b.column(name).unwrap());
            let scale = a.rows.iter().map(|r| r[ia].abs()).fold(0.0, f64::max);
            let diff = a
                .rows
                .iter()
                .zip(&b.rows)
                .map(|(ra, rb)| (ra[ia] - rb[ib]).abs())
                .fold(0.0, f64::max);
            println!(
                "  {name}: max |Δ| = {diff:.3e}, relative {:.3e}",
                diff / scale
            );
            diff / scale
        })
        .fold(0.0, f64::max)
}

#[test]
fn zero_friction_equals_frictionless_pair() {
    let tight = |t: String| t.replace("rtol = 1e-10", "rtol = 1e-13");
    let zero = scene(&tight(with_friction(
        "[mesh.friction]\ncoefficient = 0.0\nbending_factor = 0.0\npitch_point = 0.72\n",
    )));
    let plain = scene(&tight(with_friction("")));
    assert!(plain.meshes[0].friction.is_none() && zero.meshes[0].friction.is_some());
    let f_m = zero.mesh_frequency(0, zero.operating.input_speed);
    let (stop, dt) = (200.0 / f_m, 0.1 / f_m);
    let a = run_train(&zero, stop, dt).unwrap();
    let b = run_train(&plain, stop, dt).unwrap();
    // The friction mesh keeps the off-line-of-action translations (x) as DOFs.
    assert!(a.column("pinion.y").is_some() && b.column("pinion.y").is_none());
    println!("μ = 0, β = 0 vs no [mesh.friction], 200 mesh periods:");
    let rel = max_relative(
        &a,
        &b,
        &[
            "mesh1.dte",
            "mesh1.dte_rate",
            "mesh1.force",
            "pinion.x",
            "gear.x",
        ],
    );
    let iy = a.column("pinion.y").unwrap();
    // Only round-off reaches the off-line-of-action DOF (through the reduced mass matrix).
    assert!(
        a.rows.iter().all(|r| r[iy].abs() < 1e-18),
        "y must stay at rest without friction"
    );
    assert!(rel <= 1e-10, "relative difference {rel:e}");
}

/// The example with the gear held by a torsional ground spring (Liu's eq. 4.40 holds it
/// fixed) at mesh phase `phase`, nominal speed `speed`.
fn grounded(phase: f64, speed: f64, zeta: f64) -> Scene {
    let text = FRICTION_PAIR
        .replace(
            "bearing_stiffness = [1.4732e8, 1.4732e8]",
            "bearing_stiffness = [1.4732e8, 1.4732e8]\nground_stiffness = 2.0e5",
        )
        .replace("initial_phase = 0.0", &format!("initial_phase = {phase}"))
        .replace(
            "modal_damping_ratio = 0.02",
            &format!("modal_damping_ratio = {zeta}"),
        );
    let text: Vec<String> = text
        .lines()
        .map(|l| {
            if l.starts_with("input_speed") {
                format!("input_speed = {speed}")
            } else {
                l.to_owned()
            }
        })
        .collect();
    scene(&text.join("\n"))
}

#[test]
fn static_mesh_force_follows_eq_4_40() {
    let (t1, r1, mu) = (100.0, 0.04535, 0.1);
    let rho0 = r1 * 20f64.to_radians().tan();
    let pb = TAU * r1 / 38.0;
    // Slot 0 holds the pair at ξ = s + c − 1 (c = 1.4); the pitch point is ξ_p = 0.72. Single
    // contact for s ∈ [0, 0.6): approach before s = 0.32, recess after.
    for (s, sign) in [
        (0.05, 1.0),
        (0.2, 1.0),
        (0.31, 1.0),
        (0.33, -1.0),
        (0.45, -1.0),
        (0.59, -1.0),
    ] {
        let train = GearTrain::new(&grounded(s, 100.0, 0.0)).unwrap();
        let st = train.frozen_equilibrium(0.0).unwrap();
        let l = rho0 + pb * (s + 0.4 - 0.72);
        let closed = t1 / (r1 - sign * mu * l);
        let rel = (st.mesh_force[0] - closed).abs() / closed;
        println!(
            "s = {s}: N = {:.6} N, eq. (4.40) {closed:.6} N (T_1/r_1 = {:.6}), rel {rel:.1e}; f = {:.6} N",
            st.mesh_force[0],
            t1 / r1,
            st.friction_force[0]
        );
        assert!(rel < 1e-12, "s = {s}: {rel:e}");
        assert!((st.friction_force[0] - sign * mu * closed).abs() < 1e-9 * closed);
    }
    // Double contact (s ∈ [0.6, 1)): eq. (4.40) with the load shares α_i = N_i/N_1 of the
    // solution, N_1 = T_1/(r_1 − Σ sgn(v_i) μ l_i α_i).
    let s = 0.8;
    let train = GearTrain::new(&grounded(s, 100.0, 0.0)).unwrap();
    let st = train.frozen_equilibrium(0.0).unwrap();
    let n = st.mesh_force[0];
    // Both pairs: slot 0 at ξ = 1.2 (recess), slot 1 at ξ = 0.2 (approach); the friction force
    // f = μ(N_approach − N_recess) gives the shares.
    let n_app = 0.5 * (n + st.friction_force[0] / mu);
    let n_rec = n - n_app;
    let (l_rec, l_app) = (rho0 + pb * (1.2 - 0.72), rho0 + pb * (0.2 - 0.72));
    let closed = t1 / (r1 - mu * (l_app * n_app / n - l_rec * n_rec / n));
    println!(
        "double contact s = {s}: N = {n:.6} N (shares {:.4}/{:.4}), eq. (4.40) {closed:.6} N",
        n_app / n,
        n_rec / n
    );
    assert!((n - closed).abs() < 1e-12 * closed);
}

#[test]
fn dynamics_settle_on_the_frictional_statics() {
    // At zero speed the phase is frozen: the damped motion must come to rest on the static
    // state of eq. (4.40), through the friction forces of the right-hand side.
    for (s, sign) in [(0.2, 1.0), (0.45, -1.0)] {
        let sc = grounded(s, 0.0, 0.3);
        let train = GearTrain::new(&sc).unwrap();
        let st = train.frozen_equilibrium(0.0).unwrap();
        let mut sim = TrainSimulation::new(&sc).unwrap();
        sim.advance_to(0.2).unwrap();
        let mut out = Vec::new();
        sim.outputs(&mut out);
        let col = |n: &str| sim.output_names().iter().position(|x| x == n).unwrap();
        let (force, friction) = (out[col("mesh1.force")], out[col("mesh1.friction_force")]);
        println!(
            "s = {s}: settled N = {force:.9} N, statics {:.9} N",
            st.mesh_force[0]
        );
        assert!((force - st.mesh_force[0]).abs() < 1e-8 * force);
        assert!((friction - sign * 0.1 * force).abs() < 1e-12 * force);
        // Not the frictionless T_1/r_1.
        assert!((force - 100.0 / 0.04535).abs() > 10.0);
    }
}

/// |Θ_s|/(k̄ε), s = 1..6, of the total mesh stiffness of the friction-bending pairs
/// (complex Fourier coefficient of the mesh cycle).
fn harmonics(pair: &PairStiffness, mean: f64, eps: f64) -> Vec<f64> {
    let table = CycleTable::pairs(pair, &PairGap::default());
    let n = 400_000;
    (1..=6)
        .map(|h| {
            let (mut re, mut im) = (0.0, 0.0);
            for i in 0..n {
                let s = (i as f64 + 0.5) / n as f64;
                let iv = &table.intervals[table.interval_at(s)];
                let k: f64 = iv.laws.iter().flatten().map(|l| l.k(s - iv.start)).sum();
                let (sn, cs) = (TAU * h as f64 * s).sin_cos();
                re += k * cs;
                im -= k * sn;
            }
            (re.hypot(im) / n as f64) / (mean * eps)
        })
        .collect()
}

#[test]
#[allow(clippy::approx_constant)] // 0.3183 is the notes' printed 1/π, kept as printed
fn friction_bending_harmonics_match_notes_table() {
    // Notes §4.2 [C]: ε = 0.3, c = 1.5, α = 0.6, γ = 0.28 (pitch point ξ_p = 1 − γ), the
    // "physical" variant (eq. 4.42 applied pair by pair).
    let (mean, eps, c) = (1.0e8, 0.3, 1.5);
    let base = PairStiffness::rectangular_shared(mean, eps, c, 0.6);
    let table = [
        (0.0, [0.3183, 0.0, 0.1061, 0.0, 0.0637, 0.0]),
        (0.05, [0.3309, 0.0383, 0.0988, 0.0077, 0.0712, 0.0110]),
        (0.1, [0.3510, 0.0766, 0.0931, 0.0154, 0.0791, 0.0221]),
    ];
    for (beta, printed) in table {
        let got = harmonics(&base.with_friction_bending(0.72, beta), mean, eps);
        println!("β = {beta}: {got:.4?}");
        for (g, p) in got.iter().zip(printed) {
            assert!((g - p).abs() < 6e-5, "β = {beta}: {got:?} vs {printed:?}");
        }
    }
    // β = 0: the closed form (4.85) |sin sπ(c−1)|/(sπ).
    let got = harmonics(&base, mean, eps);
    for (s, g) in got.iter().enumerate() {
        let h = (s + 1) as f64;
        assert!((g - (h * PI * (c - 1.0)).sin().abs() / (h * PI)).abs() < 1e-9);
    }
}

fn rejects(block: &str, needles: &[&str]) {
    let msg = Scene::from_toml_str(&with_friction(block), "test")
        .expect_err("scene must be rejected")
        .0;
    for n in needles {
        assert!(msg.contains(n), "message {msg:?} lacks {n:?}");
    }
}

#[test]
fn bad_friction_input_is_rejected() {
    let f = |body: &str| format!("[mesh.friction]\n{body}\n");
    rejects(
        &f("coefficient = -0.1"),
        &["mesh[0].friction.coefficient = -0.1", ">= 0"],
    );
    rejects(
        &f("coefficient = nan"),
        &["mesh[0].friction.coefficient = NaN"],
    );
    rejects(
        &f("coefficient = inf"),
        &["mesh[0].friction.coefficient = inf"],
    );
    rejects(
        &f("coefficient = 0.1\nbending_factor = 12.0"),
        &["mesh[0].friction.bending_factor = 12", "1.2"],
    );
    rejects(
        &f("coefficient = 0.1\nbending_factor = nan"),
        &["mesh[0].friction.bending_factor = NaN"],
    );
    rejects(
        &f("coefficient = 0.1\npitch_point = 1.4"),
        &["mesh[0].friction.pitch_point = 1.4", "(0, 1.4)"],
    );
    rejects(
        &f("coefficient = 0.1\npitch_point = -0.2"),
        &["mesh[0].friction.pitch_point = -0.2"],
    );
    assert!(
        Scene::from_toml_str(&with_friction(&f("coefficient = 0.1\nvelocity = 2.0")), "t").is_err()
    );
    // The contact path must stay between the base tangent points: a small pressure angle
    // (5°) puts the pitch point r_b1 tan α = 4.0 mm from T_1, less than the 5.4 mm before it
    // in the window.
    let text = with_friction(&f("coefficient = 0.1\npitch_point = 0.72"))
        .replace("pressure_angle = 20.0 ", "pressure_angle = 5.0 ");
    let msg = Scene::from_toml_str(&text, "t").unwrap_err().0;
    assert!(
        msg.contains("mesh[0].friction.pitch_point = 0.72") && msg.contains("line of action"),
        "{msg}"
    );
    // Friction needs Model-1 pairs, and the drive flanks only.
    let text = FRICTION_PAIR.replace("model = \"pairs\"", "model = \"nlte\"");
    let msg = Scene::from_toml_str(&text, "t").unwrap_err().0;
    assert!(
        msg.contains("mesh[0].friction") && msg.contains("\"nlte\""),
        "{msg}"
    );
    let text = FRICTION_PAIR.replace(
        "contact = \"contact_loss\"",
        "contact = \"backlash\"\nbacklash = 1e-4",
    );
    let msg = Scene::from_toml_str(&text, "t").unwrap_err().0;
    assert!(
        msg.contains("mesh[0].friction") && msg.contains("backlash"),
        "{msg}"
    );
    let text = FRICTION_PAIR.replace("load_share = 0.6", "load_share = 1.5");
    let msg = Scene::from_toml_str(&text, "t").unwrap_err().0;
    assert!(msg.contains("mesh[0].pairs.load_share = 1.5"), "{msg}");
}

#[test]
fn default_pitch_point_from_standard_addenda() {
    // Table 5.1 gears (m = 2.54 mm, 20°): the approach and recess lengths of the path of
    // contact with standard addenda, scaled to the window of c = 1.4.
    let s = scene(&with_friction("[mesh.friction]\ncoefficient = 0.1\n"));
    let fr = s.meshes[0].friction.unwrap();
    // Tip radii from the module of Table 5.1: r_t = m z/2 + m.
    let (module, tan_phi) = (2.54e-3, 20f64.to_radians().tan());
    let beyond = |rb: f64, z: f64| {
        let r_t = module * z / 2.0 + module;
        (r_t * r_t - rb * rb).sqrt() - rb * tan_phi
    };
    let (app, rec) = (beyond(0.06564, 55.0), beyond(0.04535, 38.0));
    let expected = 1.4 * app / (app + rec);
    println!(
        "approach {app:e} m, recess {rec:e} m: ξ_p = {expected}, scene {}",
        fr.pitch_point
    );
    assert!((fr.pitch_point - expected).abs() < 1e-3);
    assert_eq!(fr.bending_factor, 0.0);
}
