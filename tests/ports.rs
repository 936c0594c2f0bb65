//! Issue 18 point 1: drivetrains with torque ports carry the rigid-body rotation
//! (`docs/ports.md`). Each test has its own oracle:
//!
//! - speed ratio: the tooth ratio z1/z2 (and the base radii checked against it first);
//! - power balance: every term by its own quadrature (trapezoid on a fine output grid) from the
//!   recorded columns and the scene's numbers, the mesh damping and STE formed here from
//!   docs/model.md, not read from the model;
//! - scene checks: the messages name the keys.
//!
//! The independent dynamic oracle (scipy) is `tests/python/test_ports_reference.py`.

mod common;

use std::f64::consts::TAU;
use std::path::PathBuf;

use common::ports::{col, ratio_errors, scene};
use geardyn::model::train::{run_train, TrainTrajectory};
use geardyn::scene::Scene;

fn stage_text() -> String {
    common::ports::stage_text("spur_stage")
}

/// Scene numbers of the stage (read from the file, so the test follows the shipped data).
struct Stage {
    z1: f64,
    z2: f64,
    r1: f64,
    r2: f64,
    j1: f64,
    j2: f64,
}

fn stage(s: &Scene) -> Stage {
    let (p, g) = (&s.gears[0], &s.gears[1]);
    Stage {
        z1: f64::from(p.teeth),
        z2: f64::from(g.teeth),
        r1: p.base_radius,
        r2: g.base_radius,
        j1: p.inertia,
        j2: g.inertia,
    }
}

#[test]
fn base_radii_follow_the_tooth_ratio() {
    // The kinematic ratio of the carried rotation is r_b1/r_b2; the mesh frequency counts teeth.
    let st = stage(&scene(&stage_text()));
    let rel = (st.r1 / st.r2 - st.z1 / st.z2).abs() / (st.z1 / st.z2);
    assert!(rel <= 1e-12, "r_b1/r_b2 differs from z1/z2 by {rel:e}");
}

#[test]
fn speed_ratio_is_the_tooth_ratio() {
    // A run-up: 100 N·m in, 143 N·m load (1.2 N·m net at the pinion, ~160 rad/s²) from
    // 1000 rpm to ~2470 rpm in 1 s, below the mesh resonance. The speed ratio must follow the
    // teeth up to the elastic DTE: after the start transient (t ≥ 0.1 s) the mean speeds give
    // mean(ω2)/mean(ω1) = z1/z2 − ΔS/(r_b2 Δθ1), ≤ 1e-6 relative. The mean of the pointwise
    // ratio ω2/ω1 carries in addition the correlation of the mesh vibration in Ṡ and ω1 (a
    // second-order term, ~1e-5 here): it is reported and bounded by 1e-4.
    let text = stage_text()
        .replace(
            "pinion_speed = 471.238898038469",
            "pinion_speed = 104.71975511965977",
        )
        .replace("torque = -144.73684210526315", "torque = -143.0");
    let sc = scene(&text);
    let st = stage(&sc);
    let run = run_train(&sc, 1.0, 1e-5).unwrap();
    let (means, pointwise) = ratio_errors(&run, "pinion.speed", "gear.speed", st.z1 / st.z2, 0.1);
    let w1 = col(&run, "pinion.speed");
    let gain = w1(run.times.len() - 1) - w1(0);
    println!(
        "run-up: ω1 rose by {gain:.3} rad/s; mean(ω2)/mean(ω1)/(z1/z2) − 1 = {means:.3e}, \
         mean(ω2/ω1)/(z1/z2) − 1 = {pointwise:.3e}"
    );
    assert!(gain > 100.0, "the train accelerated: {gain}");
    assert!(means.abs() <= 1e-6, "speed ratio error {means:e}");
    assert!(
        pointwise.abs() <= 1e-4,
        "pointwise speed ratio error {pointwise:e}"
    );
}

/// The energy terms of a run (`docs/ports.md`, "Energy bookkeeping"), each by its own
/// trapezoid quadrature over the recorded columns: the work the neighbours do, the
/// dissipation, the stored energy's change and the parametric work of the mesh.
struct Energy {
    work: f64,
    dissipated: f64,
    delta_stored: f64,
    parametric: f64,
    jumps: usize,
}

impl Energy {
    fn residual(&self) -> f64 {
        self.work - self.dissipated - self.delta_stored + self.parametric
    }
}

/// Terms of the stage of `fmu/spur_stage` (its mesh data below), plus what lies beyond the
/// gears: `port_power(i)` the power the neighbours deliver at sample i, `outer_stored(i)` and
/// `outer_dissipation(i)` the energy stored and the power dissipated outside the two gears
/// (in a speed port's coupling).
///
/// - kinetic energy ½J1ω1² + ½J2ω2² at the ends;
/// - mesh energy ½k(S − e + o)² in contact (o = 2b on the back side), 0 when separated;
/// - dissipation ∫c(Ṡ − ė)² dt in contact, c = 2ζ√(k̄ m_e) formed here;
/// - parametric work: −∫F ė dt (the STE moving the spring's seat) plus ½Δk(S − e + o)² at
///   every stiffness jump (Liu's force law has no ∂k/∂θ torque, so a jump of k changes the
///   stored energy with no work at the ports).
fn stage_energy(
    run: &TrainTrajectory,
    st: &Stage,
    port_power: &dyn Fn(usize) -> f64,
    outer_stored: &dyn Fn(usize) -> f64,
    outer_dissipation: &dyn Fn(usize) -> f64,
) -> Energy {
    let (k_mean, zeta, two_b, ste) = (2.9831e8, 0.05, 1.0e-4, 1.0e-6);
    let m_e = 1.0 / (st.r1 * st.r1 / st.j1 + st.r2 * st.r2 / st.j2);
    let c = 2.0 * zeta * (k_mean * m_e).sqrt();
    let n = run.times.len();
    let (w1, w2) = (col(run, "pinion.speed"), col(run, "gear.speed"));
    let (s, sd) = (col(run, "mesh1.deflection"), col(run, "mesh1.dte_rate"));
    let (force, k) = (col(run, "mesh1.force"), col(run, "mesh1.stiffness"));
    let (contact, phase) = (col(run, "mesh1.contact_state"), col(run, "mesh1.phase"));
    // e(p) = a cos 2πp (docs/model.md, "Static transmission error"), ė = e'(p) z1 ω1/2π.
    let e = |i: usize| ste * (TAU * phase(i)).cos();
    let e_rate = |i: usize| -ste * TAU * (TAU * phase(i)).sin() * st.z1 * w1(i) / TAU;
    let offset = |i: usize| match contact(i) {
        x if x > 0.5 => Some(0.0),
        x if x < -0.5 => Some(two_b),
        _ => None,
    };
    let stored = |i: usize| {
        let kin = 0.5 * st.j1 * w1(i).powi(2) + 0.5 * st.j2 * w2(i).powi(2);
        let mesh = offset(i).map_or(0.0, |o| 0.5 * k(i) * (s(i) - e(i) + o).powi(2));
        kin + mesh + outer_stored(i)
    };
    let dissipation = |i: usize| {
        offset(i).map_or(0.0, |_| c * (sd(i) - e_rate(i)).powi(2)) + outer_dissipation(i)
    };
    let (mut work, mut diss, mut param, mut jumps) = (0.0, 0.0, 0.0, 0);
    for i in 1..n {
        let dt = run.times[i] - run.times[i - 1];
        let trap = |f: &dyn Fn(usize) -> f64| 0.5 * dt * (f(i - 1) + f(i));
        work += trap(port_power);
        diss += trap(&dissipation);
        param -= trap(&|j| force(j) * e_rate(j));
        if k(i) != k(i - 1) {
            // A stiffness jump between the samples: the spring keeps its deflection, its
            // energy changes by ½Δk δ² (δ taken at the sample after the jump).
            jumps += 1;
            if let Some(o) = offset(i) {
                let d = s(i) - e(i) + o;
                param += 0.5 * (k(i) - k(i - 1)) * d * d;
            }
        }
    }
    Energy {
        work,
        dissipated: diss,
        delta_stored: stored(n - 1) - stored(0),
        parametric: param,
        jumps,
    }
}

#[test]
fn power_balance_over_a_run() {
    // The shipped stage at 4500 rpm near its mesh resonance (contact loss and back-side impacts
    // every mesh period): input work − output work − dissipated energy − Δ stored energy
    // + parametric work = 0 to 1e-6 of the input work (terms on a 5e-8 s grid).
    let text = stage_text();
    let sc = scene(&text);
    let st = stage(&sc);
    let (t_in, t_out) = (sc.ports[0].torque, sc.ports[1].torque);
    let run = run_train(&sc, 0.005, 5e-8).unwrap();
    let (w1, w2) = (col(&run, "pinion.speed"), col(&run, "gear.speed"));
    let work_in = stage_energy(&run, &st, &|j| t_in * w1(j), &|_| 0.0, &|_| 0.0).work;
    let en = stage_energy(
        &run,
        &st,
        &|j| t_in * w1(j) + t_out * w2(j),
        &|_| 0.0,
        &|_| 0.0,
    );
    let residual = en.residual();
    println!(
        "W_in {work_in:.9e} J, W_out {:.9e} J, dissipated {:.6e} J, ΔE {:.6e} J, \
         parametric {:.6e} J ({} stiffness jumps); residual {residual:.3e} J = {:.3e} of W_in",
        work_in - en.work,
        en.dissipated,
        en.delta_stored,
        en.parametric,
        en.jumps,
        residual / work_in
    );
    assert!(en.jumps > 20);
    assert!(
        en.dissipated > 0.0 && en.parametric.abs() > 1e-6 * work_in,
        "terms that matter"
    );
    assert!(
        residual.abs() <= 1e-6 * work_in,
        "power balance residual {residual:e} J"
    );
}

#[test]
fn scene_checks_name_the_keys() {
    let text = stage_text();
    let both = text.replace("[operating]", "[operating]\ninput_torque = 100.0");
    let e = Scene::from_toml_str(&both, "t").unwrap_err().to_string();
    assert!(
        e.contains("operating.input_torque") && e.contains("port[0]"),
        "{e}"
    );
    let both = text.replace("[operating]", "[operating]\nload_torque = 100.0");
    let e = Scene::from_toml_str(&both, "t").unwrap_err().to_string();
    assert!(
        e.contains("operating.load_torque") && e.contains("port[1]"),
        "{e}"
    );
    let other = text.replacen("causality = \"torque\"", "causality = \"force\"", 1);
    let e = Scene::from_toml_str(&other, "t").unwrap_err().to_string();
    assert!(e.contains("port[0].causality"), "{e}");
    let same = text.replace("gear = \"gear\"\ncausality", "gear = \"pinion\"\ncausality");
    let e = Scene::from_toml_str(&same, "t").unwrap_err().to_string();
    assert!(e.contains("port[1].gear"), "{e}");
    let clash = text.replace("name = \"output\"", "name = \"gear\"");
    let e = Scene::from_toml_str(&clash, "t").unwrap_err().to_string();
    assert!(
        e.contains("port[1].name") && e.contains("gear's name"),
        "{e}"
    );
    let exact = text.replace("method = \"auto\"", "method = \"exact\"");
    let e = geardyn::model::train::TrainSimulation::new(&scene(&exact))
        .err()
        .unwrap();
    assert!(e.contains("carried") && e.contains("[[port]]"), "{e}");
}

#[test]
fn without_ports_the_nominal_form_runs() {
    // Removing the ports and giving the torques as operating values returns the nominal form:
    // no rotation columns, and the same mesh columns as the pair kernel's drivetrain.
    let text = stage_text();
    let cut = text.find("[[port]]").unwrap();
    let end = text.find("[solver]").unwrap();
    let nominal = format!(
        "{}{}",
        &text[..cut].replace("[operating]", "[operating]\ninput_torque = 100.0"),
        &text[end..]
    );
    let run = run_train(&scene(&nominal), 0.001, 1e-5).unwrap();
    assert!(run.column("pinion.speed").is_none());
    assert!(run.column("mesh1.dte").is_some());
}

#[test]
fn nominal_analyses_refuse_ports_and_simulate_runs() {
    let folder = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fmu/spur_stage");
    let scene = geardyn::scene::Scene::from_path(&folder).unwrap();
    let e = scene.simulation().err().unwrap();
    assert!(
        e.contains("[[port]]") && e.contains("geardyn simulate"),
        "{e}"
    );
    assert!(scene.run().is_ok());
}

/// The stage with speed causality at the chosen ports: a coupling `(k, c)` to a neighbour
/// turning at the gear's nominal speed, pre-twisted by the port's start torque.
fn speed_port_text(input: Option<(f64, f64)>, output: Option<(f64, f64)>) -> String {
    let mut text = stage_text();
    for (coupling, start) in [
        (input, "causality = \"torque\"\ntorque = 100.0"),
        (
            output,
            "causality = \"torque\"\ntorque = -144.73684210526315",
        ),
    ] {
        if let Some((k, c)) = coupling {
            let torque = start.lines().nth(1).unwrap();
            let new =
                format!("causality = \"speed\"\n{torque}\nstiffness = {k:?}\ndamping = {c:?}");
            assert!(text.contains(start));
            text = text.replace(start, &new);
        }
    }
    text
}

#[test]
fn speed_ports_balance_power() {
    // Both ports with speed causality (the couplings of the 3-FMU drivetrain's shafts), each
    // neighbour at its nominal speed: the work the neighbours do at their flanges equals the
    // stage's dissipation, stored and parametric energy plus the couplings' spring energy
    // ½k(φ − θ)² and damping c(ω − ω_g)², to 1e-6 of the input work. The neighbours' motion is
    // formed here: φ = φ0 + ω t with φ0 = θ_g(0) + T0/k (pre-twisted by the start torque).
    let (k1, c1, k2, c2) = (2.0e4, 1.0, 5.0e4, 2.0);
    let sc = scene(&speed_port_text(Some((k1, c1)), Some((k2, c2))));
    let st = stage(&sc);
    let (t1, t2) = (sc.ports[0].torque, sc.ports[1].torque);
    let w_n1 = sc.operating.input_speed;
    let w_n2 = w_n1 * st.r1 / st.r2;
    let run = run_train(&sc, 0.005, 5e-8).unwrap();
    let (a1, a2) = (col(&run, "pinion.angle"), col(&run, "gear.angle"));
    let (w1, w2) = (col(&run, "pinion.speed"), col(&run, "gear.speed"));
    let (on_n1, on_n2) = (col(&run, "input.torque"), col(&run, "output.torque"));
    let t = |i: usize| run.times[i];
    let phi1 = |i: usize| a1(0) + t1 / k1 + w_n1 * t(i);
    let phi2 = |i: usize| a2(0) + t2 / k2 + w_n2 * t(i);
    // The neighbour drives its coupling with minus the torque the stage puts on it.
    let in_power = |i: usize| -on_n1(i) * w_n1;
    let power = |i: usize| in_power(i) - on_n2(i) * w_n2;
    let stored =
        |i: usize| 0.5 * k1 * (phi1(i) - a1(i)).powi(2) + 0.5 * k2 * (phi2(i) - a2(i)).powi(2);
    let diss = |i: usize| c1 * (w_n1 - w1(i)).powi(2) + c2 * (w_n2 - w2(i)).powi(2);
    // The outputs are the couplings' torques: check them against the motion first.
    for i in [0, run.times.len() / 2, run.times.len() - 1] {
        let tau1 = k1 * (phi1(i) - a1(i)) + c1 * (w_n1 - w1(i));
        assert!(
            (on_n1(i) + tau1).abs() <= 1e-9 * t1.abs(),
            "{} {tau1}",
            on_n1(i)
        );
    }
    assert!(
        (on_n1(0) + t1).abs() <= 1e-9 * t1.abs(),
        "start torque {}",
        on_n1(0)
    );
    assert!(
        (on_n2(0) + t2).abs() <= 1e-9 * t2.abs(),
        "start torque {}",
        on_n2(0)
    );
    let work_in = stage_energy(&run, &st, &in_power, &|_| 0.0, &|_| 0.0).work;
    let en = stage_energy(&run, &st, &power, &stored, &diss);
    let residual = en.residual();
    println!(
        "speed ports: W_in {work_in:.9e} J, W_out {:.9e} J, dissipated {:.6e} J, ΔE {:.6e} J, \
         parametric {:.6e} J; residual {residual:.3e} J = {:.3e} of W_in",
        work_in - en.work,
        en.dissipated,
        en.delta_stored,
        en.parametric,
        residual / work_in
    );
    assert!(en.jumps > 20 && en.dissipated > 0.0);
    assert!(
        residual.abs() <= 1e-6 * work_in,
        "power balance residual {residual:e} J"
    );
}

#[test]
fn a_speed_port_settles_to_the_static_twist_and_the_tooth_ratio() {
    // Closed form: the pinion driven through a coupling (k, c) by a neighbour at constant speed
    // Ω, the wheel loaded by a torque port with T_out. Started untwisted (torque = 0), the
    // coupling winds up until, in the mean, it carries the load seen at the pinion:
    // mean(φ − θ1) = |T_out| (r1/r2) / k (the static twist), and the wheel turns at
    // Ω z1/z2 (from the angle increments over the window, the elastic DTE aside).
    let (k, c) = (2.0e4, 20.0);
    let text = speed_port_text(Some((k, c)), None).replace(
        "causality = \"speed\"\ntorque = 100.0",
        "causality = \"speed\"\ntorque = 0.0",
    );
    let sc = scene(&text);
    let st = stage(&sc);
    let omega = sc.operating.input_speed;
    let t_out = sc.ports[1].torque;
    let run = run_train(&sc, 0.3, 1e-5).unwrap();
    let (a1, a2) = (col(&run, "pinion.angle"), col(&run, "gear.angle"));
    let t = &run.times;
    let first = t.iter().position(|&x| x >= 0.1).unwrap();
    let last = t.len() - 1;
    let (mut twist, mut span) = (0.0, 0.0);
    for i in first + 1..=last {
        let h = t[i] - t[i - 1];
        twist += 0.5 * h * ((omega * t[i - 1] - a1(i - 1)) + (omega * t[i] - a1(i)));
        span += h;
    }
    let twist = twist / span;
    let expected = -t_out * (st.r1 / st.r2) / k;
    let ratio = (a2(last) - a2(first)) / (omega * (t[last] - t[first]));
    let ratio_error = ratio / (st.z1 / st.z2) - 1.0;
    println!(
        "speed port: mean twist {twist:.9e} rad against |T_out| r1/(r2 k) = {expected:.9e} \
         ({:.2e} relative); wheel/neighbour speed ratio / (z1/z2) − 1 = {ratio_error:.2e}",
        twist / expected - 1.0
    );
    assert!((twist / expected - 1.0).abs() <= 1e-4, "{twist} {expected}");
    assert!(ratio_error.abs() <= 1e-6, "{ratio_error}");
}

#[test]
fn speed_port_checks_name_the_keys() {
    let base = speed_port_text(Some((2.0e4, 1.0)), None);
    assert!(Scene::from_toml_str(&base, "t").is_ok());
    let case = |from: &str, to: &str, expect: &[&str]| {
        assert!(base.contains(from), "{from}");
        let e = Scene::from_toml_str(&base.replacen(from, to, 1), "t")
            .unwrap_err()
            .to_string();
        assert!(expect.iter().all(|x| e.contains(x)), "{e}");
    };
    case(
        "stiffness = 20000.0\n",
        "",
        &["port[0].stiffness", "required"],
    );
    case("damping = 1.0\n", "", &["port[0].damping", "required"]);
    case(
        "stiffness = 20000.0",
        "stiffness = 0.0",
        &["port[0].stiffness = 0", "> 0"],
    );
    case(
        "damping = 1.0",
        "damping = -1.0",
        &["port[0].damping = -1", ">= 0"],
    );
    case(
        "damping = 1.0",
        "damping = 1.0\nspeed = nan",
        &["port[0].speed = NaN", "finite"],
    );
    // A torque port has no coupling.
    case(
        "torque = -144.73684210526315",
        "torque = -144.73684210526315\nstiffness = 1.0",
        &["port[1].stiffness", "causality = \"speed\""],
    );
}
