//! Issue 18 acceptance 1 on the shipped multi-mesh stages with torque ports, `fmu/idler_stage`
//! (compliant bearings, Model-1 tooth pairs with tip relief) and `fmu/countershaft_stage`
//! (two stages on a rigid middle shaft), `fmu/geometry_stage` (stiffness from the gear
//! geometry: sloped table pieces whose knots follow the pinion angle). Each test has its own oracle:
//!
//! - speed ratio: the tooth ratio, from the tooth counts of the scene file;
//! - power balance: every term by its own quadrature from the recorded columns and the
//!   scene's numbers: port work `∫T ω dt`, the work done on each mesh `∫F dS` (a Stieltjes
//!   sum over the recorded deflection, so the stiffness jumps, tip relief and contact loss
//!   need no model of their own), kinetic energy of every rotation and translation, bearing
//!   energy `½k x²`.
//!
//! The planetary stage `fmu/planetary_stage` (issue 33 acceptance 5) gets the same balance in
//! two arrangements: sun in, carrier out, ring held (the shipped one) and sun in, ring out,
//! carrier held. Its energy adds the planets' pin bearings and the planets' orbit (their
//! tangential translation in the carrier frame moves with the carrier, Lin & Parker 1999).

mod common;

use common::ports::{col, integral, ratio_errors, scene, stage_text, stieltjes};
use geardyn::model::train::{run_train, TrainTrajectory};
use geardyn::scene::Scene;

/// The tooth ratio ω_out/ω_in of a chain of meshes, each `(driver, driven)` by gear name.
fn tooth_ratio(sc: &Scene, chain: &[(&str, &str)]) -> f64 {
    let z = |g: &str| f64::from(sc.gears[sc.gear_index(g).unwrap()].teeth);
    chain.iter().map(|(a, b)| z(a) / z(b)).product()
}

/// Mean speed ratio of the shipped stage over `[t_a, stop]` against the tooth ratio: ≤ 1e-6
/// relative (acceptance 1). The stage starts at its static state under balanced torques, so
/// the transient is the settling of that start; `t_a` leaves it out.
fn speed_ratio(name: &str, chain: &[(&str, &str)], stop: f64, t_a: f64) {
    let sc = scene(&stage_text(name));
    let ratio = tooth_ratio(&sc, chain);
    let run = run_train(&sc, stop, 1e-5).unwrap();
    let (means, pointwise) = ratio_errors(&run, "input.speed", "output.speed", ratio, t_a);
    println!(
        "{name}: {stop} s, mean(ω_out)/mean(ω_in)/ratio − 1 = {means:.3e}, \
         mean(ω_out/ω_in)/ratio − 1 = {pointwise:.3e} (ratio {ratio:.9})"
    );
    assert!(means.abs() <= 1e-6, "{name}: speed ratio error {means:e}");
    assert!(pointwise.abs() <= 1e-4, "{name}: pointwise {pointwise:e}");
}

#[test]
fn idler_stage_speed_ratio_is_the_tooth_ratio() {
    speed_ratio(
        "idler_stage",
        &[("pinion", "idler"), ("idler", "follower")],
        0.2,
        0.02,
    );
}

#[test]
fn countershaft_stage_speed_ratio_is_the_tooth_ratio() {
    speed_ratio(
        "countershaft_stage",
        &[("pinion", "middle1"), ("middle2", "wheel")],
        0.2,
        0.02,
    );
}

/// Kinetic and bearing energy at sample `i` (1 ≤ i ≤ n − 2): ½Jω² of each gear from the speed
/// column of its body (`speeds`: gear → column), ½m v² + ½k x² of every translation, v by the
/// central difference of the recorded position.
fn stored(run: &TrainTrajectory, sc: &Scene, speeds: &[(&str, &str)], i: usize) -> f64 {
    let mut e = 0.0;
    for (gear, column) in speeds {
        let g = &sc.gears[sc.gear_index(gear).unwrap()];
        e += 0.5 * g.inertia * col(run, column)(i).powi(2);
    }
    for g in &sc.gears {
        let Some(b) = &g.bearing else { continue };
        for (axis, k) in ["x", "y"].iter().zip(b.stiffness) {
            let Some(c) = run.column(&format!("{}.{axis}", g.name)) else {
                continue;
            };
            let x = |j: usize| run.rows[j][c];
            let v = (x(i + 1) - x(i - 1)) / (run.times[i + 1] - run.times[i - 1]);
            e += 0.5 * g.mass.unwrap() * v * v + 0.5 * k * x(i).powi(2);
        }
    }
    e
}

/// Power balance over a run of the stage with its damping set to zero (the dissipation of
/// modal damping is not a function of the recorded columns): W_in − W_out − ΣW_mesh − ΔE = 0
/// to 1e-6 of W_in, where W_mesh = ∫F dS is the work the gears do on mesh n (its stored
/// energy, the parametric work of its stiffness and gaps, its impacts).
fn power_balance(
    name: &str,
    edit: &dyn Fn(String) -> String,
    meshes: &[&str],
    speeds: &[(&str, &str)],
) {
    let text = edit(stage_text(name));
    let damping = ["modal_damping_ratio", "damping_ratio"]
        .into_iter()
        .find_map(|key| text.find(&format!("\n{key} = ")).map(|i| (key, i + 1)))
        .expect("a damping ratio to switch off");
    let text = text.replace(
        text[damping.1..].lines().next().unwrap(),
        &format!("{} = 0.0", damping.0),
    );
    let sc = scene(&text);
    let (t_in, t_out) = (sc.ports[0].torque, sc.ports[1].torque);
    let mut sub = run_train(&sc, 0.005, 5e-8).unwrap();
    let n = sub.times.len();
    let delta_e = stored(&sub, &sc, speeds, n - 2) - stored(&sub, &sc, speeds, 1);
    // Samples 0 and n − 1 are left out: the central differences of the translations at the
    // ends of the balance need a neighbour on each side.
    sub.times = sub.times[1..n - 1].to_vec();
    sub.rows = sub.rows[1..n - 1].to_vec();
    let (w_in_speed, w_out_speed) = (col(&sub, "input.speed"), col(&sub, "output.speed"));
    let w_in = integral(&sub, &|i| t_in * w_in_speed(i));
    let w_out = integral(&sub, &|i| -t_out * w_out_speed(i));
    let mut w_mesh = 0.0;
    for m in meshes {
        let (f, s) = (
            col(&sub, &format!("{m}.force")),
            col(&sub, &format!("{m}.deflection")),
        );
        w_mesh += stieltjes(sub.times.len(), &f, &s);
    }
    let residual = w_in - w_out - w_mesh - delta_e;
    println!(
        "{name}: W_in {w_in:.9e} J, W_out {w_out:.9e} J, mesh work {w_mesh:.6e} J, \
         ΔE {delta_e:.6e} J; residual {residual:.3e} J = {:.3e} of W_in",
        residual / w_in
    );
    assert!(
        w_mesh.abs() > 1e-6 * w_in && delta_e.abs() > 1e-6 * w_in,
        "terms that matter"
    );
    assert!(
        residual.abs() <= 1e-6 * w_in,
        "{name}: power balance residual {residual:e} J"
    );
}

#[test]
fn idler_stage_power_balance() {
    power_balance(
        "idler_stage",
        &|t| t,
        &["mesh1", "mesh2"],
        &[
            ("pinion", "pinion.speed"),
            ("idler", "idler.speed"),
            ("follower", "follower.speed"),
        ],
    );
}

#[test]
fn countershaft_stage_power_balance() {
    // middle2 sits on middle1's rigid shaft: one body, whose speed column is middle1's.
    power_balance(
        "countershaft_stage",
        &|t| t,
        &["mesh1", "mesh2"],
        &[
            ("pinion", "pinion.speed"),
            ("middle1", "middle1.speed"),
            ("middle2", "middle1.speed"),
            ("wheel", "wheel.speed"),
        ],
    );
}

#[test]
fn geometry_stage_speed_ratio_is_the_tooth_ratio() {
    speed_ratio("geometry_stage", &[("pinion", "gear")], 0.2, 0.02);
}

#[test]
fn geometry_stage_power_balance() {
    // The mesh work ∫F dS carries the parametric work of the sloped stiffness pieces too. The
    // shipped torques are balanced and the stage starts in its static state, so its kinetic
    // energy hardly changes: a 10 % weaker load accelerates it, so that ΔE matters.
    power_balance(
        "geometry_stage",
        &|t| t.replace("torque = -100.0", "torque = -90.0"),
        &["mesh1"],
        &[("pinion", "pinion.speed"), ("gear", "gear.speed")],
    );
}

#[test]
fn an_unbalanced_torque_beyond_the_run_limits_is_refused_before_the_run() {
    // A port torque of 9e15 N·m (a fuzzed value) accelerates the carried rotation so fast that
    // 1 ms spans ~1e16 mesh periods: the run limits refuse it at once, naming the numbers,
    // instead of letting the integrator work through a million steps.
    let text = stage_text("idler_stage").replace(
        "torque = -247.3684210526316",
        "torque = 9.007199254740993e15",
    );
    let dir = std::env::temp_dir().join(format!("geardyn-ports-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    let scene = geardyn::scene::Scene::from_path(&path).unwrap();
    let options = geardyn::commands::simulate::SimulateOptions {
        stop_time: Some(1e-3),
        ..Default::default()
    };
    let start = std::time::Instant::now();
    let e = geardyn::commands::simulate::simulate(scene, &options, &dir.join("out.csv"))
        .err()
        .unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(
        e.contains("mesh periods") && e.contains("Hz/s under the port torques"),
        "{e}"
    );
    assert!(start.elapsed().as_secs_f64() < 1.0, "{e}");
}

/// The planetary stage's energy at sample `i` beyond [`stored`] (rotations and the central
/// members' translations and bearings): the torsional supports `½ k_g θ²` and, per planet,
/// `½ m (ζ'² + η'²) + ½ k_ζ δ_ζ² + ½ k_η δ_η²` with the pin deflections of docs/planetary.md
/// (eq. P6, P7). The recorded `radial`/`tangential` columns are the elastic part of the
/// planet's translation; its rigid-body part is the carrier's tangential motion `r_c θ̃_c` of
/// the stage's rigid rotation. That rotation is a motion `θ_b = w_b φ` with Willis' ratios from
/// the tooth counts (eq. P1, P2; the held member at 0), and its amplitude φ is the
/// mass-orthogonal projection of the recorded motion (the elastic part is M-orthogonal to it):
/// `φ Σ I_b w_b² = Σ I_b w_b θ_b + Σ_n m_n v_n η_n` over the bodies and planets,
/// `v_n = g r_c w_c` the planet's tangential share of the rigid motion (`g = σ ρ_c`).
fn planetary_stored(run: &TrainTrajectory, sc: &Scene, i: usize) -> f64 {
    let st = &sc.planetary[0];
    let z = |g: usize| f64::from(sc.gears[g].teeth);
    let (zs, zr) = (z(st.sun), z(st.ring));
    // Willis' rigid motion per unit sun angle, the held member still (eq. P1, P2).
    let (w_sun, w_ring, w_carrier) = if st.fixed == st.ring {
        (1.0, 0.0, zs / (zs + zr))
    } else {
        (1.0, zs / zr, 0.0)
    };
    let w_planet = |p: usize| (zs / z(p) * (w_sun - w_carrier) - w_carrier).abs();
    let r_c = sc.gears[st.carrier].base_radius;
    let g = st.sense * sc.rotation[st.carrier];
    let name = |b: usize| sc.gears[b].name.clone();
    let mut bodies = vec![(st.sun, w_sun), (st.ring, w_ring), (st.carrier, w_carrier)];
    bodies.extend(st.planets.iter().map(|p| (p.gear, w_planet(p.gear))));
    let phi = |j: usize| {
        let (mut num, mut den) = (0.0, 0.0);
        for &(b, w) in &bodies {
            let inertia = sc.gears[b].inertia;
            num += inertia * w * col(run, &format!("{}.angle", name(b)))(j);
            den += inertia * w * w;
        }
        for p in &st.planets {
            let m = sc.gears[p.gear].mass.unwrap();
            num += m * g * r_c * w_carrier * col(run, &format!("{}.tangential", name(p.gear)))(j);
        }
        num / den
    };
    let (x_c, y_c) = (
        col(run, &format!("{}.x", name(st.carrier))),
        col(run, &format!("{}.y", name(st.carrier))),
    );
    let theta_c = col(run, &format!("{}.angle", name(st.carrier)));
    let dt = run.times[i + 1] - run.times[i - 1];
    let mut e = 0.0;
    for b in [st.sun, st.ring, st.carrier] {
        let k = sc.gears[b].ground_stiffness;
        e += 0.5 * k * col(run, &format!("{}.angle", name(b)))(i).powi(2);
    }
    for p in &st.planets {
        let gear = &sc.gears[p.gear];
        let bearing = gear.bearing.unwrap();
        let (zeta, eta) = (
            col(run, &format!("{}.radial", gear.name)),
            col(run, &format!("{}.tangential", gear.name)),
        );
        // The planet's whole tangential translation: elastic part + rigid part.
        let eta_total = |j: usize| eta(j) + g * r_c * w_carrier * phi(j);
        let (s, c) = p.angle.sin_cos();
        let d_zeta = x_c(i) * c + y_c(i) * s - zeta(i) + p.pin_error[0];
        let theta_c_elastic = theta_c(i) - w_carrier * phi(i);
        let d_eta = st.sense * (-x_c(i) * s + y_c(i) * c) + g * r_c * theta_c_elastic - eta(i)
            + p.pin_error[1];
        let v_zeta = (zeta(i + 1) - zeta(i - 1)) / dt;
        let v_eta = (eta_total(i + 1) - eta_total(i - 1)) / dt;
        e += 0.5 * gear.mass.unwrap() * (v_zeta * v_zeta + v_eta * v_eta)
            + 0.5 * bearing.stiffness[0] * d_zeta * d_zeta
            + 0.5 * bearing.stiffness[1] * d_eta * d_eta;
    }
    let speeds: Vec<(String, String)> = bodies
        .iter()
        .map(|&(b, _)| (name(b), format!("{}.speed", name(b))))
        .collect();
    let speeds: Vec<(&str, &str)> = speeds
        .iter()
        .map(|(a, b)| (a.as_str(), b.as_str()))
        .collect();
    e + stored(run, sc, &speeds, i)
}

/// Power balance of the planetary stage over 4 ms with its bearing and support damping set to
/// zero (the mesh damping stays: its work is in `∫F dS`), the load 10 % below balance so that
/// the stage accelerates: `W_in − W_out − ΣW_mesh − ΔE = 0` to 1e-6 of W_in.
fn planetary_power_balance(label: &str, text: &str) {
    let text = text
        .replace(
            "bearing_damping = [800.0, 800.0]",
            "bearing_damping = [0.0, 0.0]",
        )
        .replace("ground_damping = 50.0", "ground_damping = 0.0");
    let balanced = scene(&text).ports[1].torque;
    let text = text.replace(
        &format!("torque = {balanced:?}"),
        &format!("torque = {:?}", 0.9 * balanced),
    );
    let sc = scene(&text);
    let (t_in, t_out) = (sc.ports[0].torque, sc.ports[1].torque);
    assert_eq!(t_out, 0.9 * balanced);
    let mut sub = run_train(&sc, 0.004, 5e-8).unwrap();
    let n = sub.times.len();
    let delta_e = planetary_stored(&sub, &sc, n - 2) - planetary_stored(&sub, &sc, 1);
    sub.times = sub.times[1..n - 1].to_vec();
    sub.rows = sub.rows[1..n - 1].to_vec();
    let (w_in_speed, w_out_speed) = (col(&sub, "input.speed"), col(&sub, "output.speed"));
    let w_in = integral(&sub, &|i| t_in * w_in_speed(i));
    let w_out = integral(&sub, &|i| -t_out * w_out_speed(i));
    let mut w_mesh = 0.0;
    for m in &sc.meshes {
        let (f, s) = (
            col(&sub, &format!("{}.force", m.name)),
            col(&sub, &format!("{}.deflection", m.name)),
        );
        w_mesh += stieltjes(sub.times.len(), &f, &s);
    }
    let residual = w_in - w_out - w_mesh - delta_e;
    println!(
        "{label}: W_in {w_in:.9e} J, W_out {w_out:.9e} J, mesh work {w_mesh:.6e} J, \
         ΔE {delta_e:.6e} J; residual {residual:.3e} J = {:.3e} of W_in",
        residual / w_in
    );
    assert!(
        w_mesh.abs() > 1e-6 * w_in && delta_e.abs() > 1e-3 * w_in,
        "terms that matter"
    );
    assert!(
        residual.abs() <= 1e-6 * w_in,
        "{label}: power balance residual {residual:e} J"
    );
}

#[test]
fn planetary_stage_power_balance_ring_held() {
    planetary_power_balance(
        "planetary_stage (sun in, carrier out)",
        &stage_text("planetary_stage"),
    );
}

#[test]
fn planetary_stage_power_balance_carrier_held() {
    // The star arrangement: the carrier on a torsional support, the ring free and the output,
    // turning against the sun at Z_s/Z_r; the balanced load −150·73/23 N·m.
    let text = stage_text("planetary_stage")
        .replace(
            "ground_stiffness = 5000000.0   # N·m/rad: the ring's torsional support (held)\n\
             ground_damping = 50.0\n",
            "",
        )
        .replace(
            "fixed = \"ring\"",
            "fixed = \"carrier\"\nground_stiffness = 5000000.0\nground_damping = 50.0",
        )
        .replace("output_gear = \"carrier\"", "output_gear = \"ring\"")
        .replace(
            "gear = \"carrier\"\ncausality = \"torque\"\ntorque = -626.0869565217391",
            "gear = \"ring\"\ncausality = \"torque\"\ntorque = -476.0869565217391",
        );
    assert!(text.contains("fixed = \"carrier\"") && text.contains("torque = -476.08"));
    planetary_power_balance("planetary_stage (sun in, ring out, carrier held)", &text);
}
