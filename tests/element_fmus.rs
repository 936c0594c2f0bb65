//! The element FMUs (`docs/elements.md`) against closed forms, through the same factory
//! `fmi2Instantiate` uses: an inertia under constant and ramped torques (with and without
//! `fmi2SetRealInputDerivatives`), the shaft's static torque, a load coasting down against pure
//! quadratic drag, a motor on the constant-torque plateau; output derivatives; bad parameters;
//! and the shipped element scenes' `reference.csv` (written by this test with
//! `GEARDYN_WRITE_REFERENCE=1`, for a change meant to move results).

use geardyn::fmi::model::{Causality, CoSimModel, LoadedModel};
use geardyn::fmu::entry::load_scene;

/// Loads an element scene from text (in a temporary folder) and initializes it at `t = 0`.
fn model(text: &str) -> LoadedModel {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, text).unwrap();
    load_scene(&path).unwrap()
}

fn vr(m: &dyn CoSimModel, name: &str) -> u32 {
    m.variables()
        .iter()
        .find(|v| v.name == name)
        .unwrap_or_else(|| panic!("no variable {name}"))
        .value_reference
}

fn get(m: &dyn CoSimModel, name: &str) -> f64 {
    m.get_real(vr(m, name)).unwrap()
}

fn set(m: &mut dyn CoSimModel, name: &str, x: f64) {
    let r = vr(m, name);
    m.set_real(r, x).unwrap();
}

fn init(m: &mut dyn CoSimModel) {
    m.setup_experiment(0.0, None, None).unwrap();
    m.exit_initialization().unwrap();
}

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * b.abs().max(1e-300)
}

const INERTIA: &str = r#"
[element]
kind = "inertia"
name = "wheel"
inertia = 0.25
[initial]
angle = 0.3
speed = 12.0
"#;

/// J ω' = T_a + T_b: θ = θ0 + ω0 t + ½ a t², over uneven steps.
#[test]
fn inertia_under_constant_torques_is_a_parabola() {
    let mut m = model(INERTIA).model;
    let m = m.as_mut();
    set(m, "flange_a.torque", 5.0);
    set(m, "flange_b.torque", -2.0);
    init(m);
    let a = 3.0 / 0.25;
    let mut t = 0.0;
    for h in [1e-3, 0.37, 0.05, 1.2] {
        m.do_step(t, h).unwrap();
        t += h;
        let theta = 0.3 + 12.0 * t + 0.5 * a * t * t;
        assert!(close(get(m, "flange_a.angle"), theta, 1e-13), "t = {t}");
        assert!(close(get(m, "flange_b.speed"), 12.0 + a * t, 1e-13));
        assert_eq!(get(m, "flange_b.acceleration"), a);
    }
}

/// With damping: ω = ω∞ + (ω0 − ω∞) e^{−d t/J}, ω∞ = T/d.
#[test]
fn damped_inertia_relaxes_exponentially() {
    let mut m = model(&INERTIA.replace("inertia = 0.25", "inertia = 0.25\ndamping = 0.1")).model;
    let m = m.as_mut();
    set(m, "flange_a.torque", 4.0);
    init(m);
    let w_inf = 4.0 / 0.1;
    let mut t = 0.0;
    for _ in 0..20 {
        m.do_step(t, 0.25).unwrap();
        t += 0.25;
        let w = w_inf + (12.0 - w_inf) * (-0.1 * t / 0.25f64).exp();
        // DOP853 at rtol 1e-10 (the scene default).
        assert!(close(get(m, "flange_a.speed"), w, 1e-9), "t = {t}");
    }
}

/// One big step with T(t) = T0 + T1 t: with `fmi2SetRealInputDerivatives` the answer is the
/// exact cubic θ = θ0 + ω0 t + (T0 t²/2 + T1 t³/6)/J; without, the zero-order-hold parabola.
/// At the end of the step the input holds T0 + T1 h and its rate is 0 again.
#[test]
fn input_derivatives_give_the_ramp_exactly() {
    let (j, t0, t1, h) = (0.25, 2.0, 8.0, 0.75);
    for ramp in [true, false] {
        let mut loaded = model(INERTIA);
        let m = loaded.model.as_mut();
        assert!(m.capabilities().can_interpolate_inputs);
        set(m, "flange_a.torque", t0);
        init(m);
        if ramp {
            m.set_input_derivative(vr(m, "flange_a.torque"), 1, t1)
                .unwrap();
        }
        m.do_step(0.0, h).unwrap();
        let (w, theta) = if ramp {
            (
                12.0 + (t0 * h + t1 * h * h / 2.0) / j,
                0.3 + 12.0 * h + (t0 * h * h / 2.0 + t1 * h.powi(3) / 6.0) / j,
            )
        } else {
            (12.0 + t0 * h / j, 0.3 + 12.0 * h + t0 * h * h / 2.0 / j)
        };
        assert!(close(get(m, "flange_a.speed"), w, 1e-14), "ramp {ramp}");
        assert!(close(get(m, "flange_a.angle"), theta, 1e-14), "ramp {ramp}");
        let u_end = if ramp { t0 + t1 * h } else { t0 };
        assert_eq!(get(m, "flange_a.torque"), u_end);
        // The next step holds the input: the rate was used for one step only.
        m.do_step(h, h).unwrap();
        let w2 = w + u_end * h / j;
        assert!(close(get(m, "flange_a.speed"), w2, 1e-14));
    }
}

/// One big step with the cubic torque T(s) = T0 + T1 s + T2 s²/2 + T3 s³/6 given as input
/// derivatives of orders 1 to 3: the speed and angle are the exact quartic and quintic
/// (DOP853 integrates a polynomial right-hand side of degree ≤ 7 exactly up to rounding), the
/// input ends at T(h) and the output derivatives at the end see the slope T'(h). An FMU state
/// taken with the derivatives set redoes the step bit for bit; order 4 is refused.
#[test]
fn input_derivatives_of_order_three_give_the_cubic_exactly() {
    let (j, h) = (0.25, 0.75);
    let [t0, t1, t2, t3] = [2.0, 8.0, -30.0, 90.0];
    let mut loaded = model(INERTIA);
    let m = loaded.model.as_mut();
    assert_eq!(m.capabilities().max_input_derivative_order, 3);
    set(m, "flange_a.torque", t0);
    init(m);
    let r = vr(m, "flange_a.torque");
    for (order, x) in [(1, t1), (2, t2), (3, t3)] {
        m.set_input_derivative(r, order, x).unwrap();
    }
    assert!(m.set_input_derivative(r, 4, 1.0).is_err());
    let saved = m.save_state();
    m.do_step(0.0, h).unwrap();
    let w =
        12.0 + (t0 * h + t1 * h.powi(2) / 2.0 + t2 * h.powi(3) / 6.0 + t3 * h.powi(4) / 24.0) / j;
    let theta = 0.3
        + 12.0 * h
        + (t0 * h.powi(2) / 2.0
            + t1 * h.powi(3) / 6.0
            + t2 * h.powi(4) / 24.0
            + t3 * h.powi(5) / 120.0)
            / j;
    assert!(
        close(get(m, "flange_a.speed"), w, 1e-14),
        "{}",
        get(m, "flange_a.speed") - w
    );
    assert!(close(get(m, "flange_a.angle"), theta, 1e-14));
    let u_end = t0 + t1 * h + t2 * h * h / 2.0 + t3 * h.powi(3) / 6.0;
    assert!(close(get(m, "flange_a.torque"), u_end, 1e-15));
    let jerk = m.output_derivative(vr(m, "flange_a.acceleration")).unwrap();
    assert!(close(jerk, (t1 + t2 * h + t3 * h * h / 2.0) / j, 1e-14));
    let first = (get(m, "flange_a.speed"), get(m, "flange_a.angle"));
    m.load_state(&saved).unwrap();
    m.do_step(0.0, h).unwrap();
    assert_eq!((get(m, "flange_a.speed"), get(m, "flange_a.angle")), first);
    // The next step holds the input: the derivatives were used for one step only.
    m.do_step(h, h).unwrap();
    assert!(close(get(m, "flange_a.speed"), w + u_end * h / j, 1e-14));
}

/// Order-1 output derivatives: d/dt angle = speed, d/dt speed = acceleration, d/dt
/// acceleration = (T_a' + T_b')/J with the rates set.
#[test]
fn output_derivatives_follow_the_equations() {
    let mut loaded = model(INERTIA);
    let m = loaded.model.as_mut();
    set(m, "flange_a.torque", 1.0);
    init(m);
    m.set_input_derivative(vr(m, "flange_b.torque"), 1, 3.0)
        .unwrap();
    let d = |m: &dyn CoSimModel, n: &str| m.output_derivative(vr(m, n)).unwrap();
    assert_eq!(d(m, "flange_a.angle"), 12.0);
    assert_eq!(d(m, "flange_b.speed"), 4.0);
    assert_eq!(d(m, "flange_a.acceleration"), 12.0);
    assert!(m.output_derivative(vr(m, "flange_a.torque")).is_err());
}

const SHAFT: &str = r#"
[element]
kind = "shaft"
name = "s"
stiffness = 2.0e4
damping = 1.5
"#;

/// τ = k (φ_a − φ_b) + c (ω_a − ω_b); the outputs act on the neighbours: (−τ, +τ).
#[test]
fn shaft_static_torque_and_its_rate() {
    let mut loaded = model(SHAFT);
    let m = loaded.model.as_mut();
    init(m);
    for (name, x) in [
        ("flange_a.angle", 0.012),
        ("flange_a.speed", 101.0),
        ("flange_b.angle", 0.002),
        ("flange_b.speed", 100.0),
    ] {
        set(m, name, x);
    }
    let tau = 2.0e4 * (0.012 - 0.002) + 1.5 * 1.0;
    assert!(close(get(m, "shaft.torque"), tau, 1e-15));
    assert_eq!(get(m, "flange_a.torque"), -get(m, "shaft.torque"));
    assert_eq!(get(m, "flange_b.torque"), get(m, "shaft.torque"));
    m.set_input_derivative(vr(m, "flange_a.speed"), 1, 50.0)
        .unwrap();
    let rate = 2.0e4 * 1.0 + 1.5 * 50.0;
    let d = m.output_derivative(vr(m, "flange_b.torque")).unwrap();
    assert!(close(d, rate, 1e-15), "{d}");
    // Over a step with the speed ramp, the shaft reads the inputs at the end of the step.
    m.do_step(0.0, 0.01).unwrap();
    assert_eq!(get(m, "flange_a.speed"), 101.5);
    // The torque's rate at the end of the step is that of the ramp which ended there:
    // k (ω_a − ω_b) + c α_a with α_a = 50, not the rate with the input rates reset to 0 (the
    // c·α term dropped, which made the drivetrain's co-simulation first order).
    let rate = 2.0e4 * 1.5 + 1.5 * 50.0;
    let d = m.output_derivative(vr(m, "flange_b.torque")).unwrap();
    assert!(close(d, rate, 1e-15), "{d}");
    // and a state saved there gives the same rate back.
    let saved = m.save_state();
    m.set_input_derivative(vr(m, "flange_a.speed"), 1, -7.0)
        .unwrap();
    m.load_state(&saved).unwrap();
    assert!(close(
        m.output_derivative(vr(m, "flange_b.torque")).unwrap(),
        rate,
        1e-15
    ));
    // A step without rates holds the inputs: the rate at its end has no c·α term.
    m.do_step(0.01, 0.01).unwrap();
    let d = m.output_derivative(vr(m, "flange_b.torque")).unwrap();
    assert!(close(d, 2.0e4 * 1.5, 1e-15), "{d}");
}

/// Pure quadratic drag: ω(t) = ω0 / (1 + c_d ω0 t / J), θ(t) = θ0 + (J/c_d) ln(1 + c_d ω0 t / J).
#[test]
fn load_coast_down_against_quadratic_drag() {
    let text = r#"
[element]
kind = "load"
name = "l"
inertia = 0.5
drag = 2.0e-3
[initial]
speed = 300.0
[solver]
rtol = 1e-12
atol = 1e-12
"#;
    let mut loaded = model(text);
    let m = loaded.model.as_mut();
    init(m);
    let (j, cd, w0) = (0.5, 2.0e-3, 300.0);
    let mut t = 0.0;
    let mut worst: f64 = 0.0;
    for _ in 0..50 {
        m.do_step(t, 0.1).unwrap();
        t += 0.1;
        let s = 1.0 + cd * w0 * t / j;
        let (w, theta) = (w0 / s, j / cd * s.ln());
        worst = worst
            .max(((get(m, "flange.speed") - w) / w).abs())
            .max(((get(m, "flange.angle") - theta) / theta).abs());
        assert!(close(get(m, "load.resisting_torque"), cd * w * w, 1e-9));
    }
    println!("load coast-down: max relative error {worst:.2e} over 5 s");
    assert!(worst < 1e-10, "{worst}");
}

/// Open loop on the constant-torque plateau without ripple: ω = ω0 + (T_max f + T_fl)/J t.
#[test]
fn motor_on_the_plateau_accelerates_uniformly() {
    let text = r#"
[element]
kind = "motor"
name = "m"
inertia = 0.01
torque_fraction = 0.5
[element.curve]
speed = [0.0, 400.0, 1000.0]
torque = [150.0, 150.0, 60.0]
[initial]
speed = 10.0
"#;
    let mut loaded = model(text);
    let m = loaded.model.as_mut();
    set(m, "flange.torque", -25.0);
    init(m);
    let a = (0.5 * 150.0 - 25.0) / 0.01;
    let mut t = 0.0;
    for h in [1e-3, 0.02, 0.03] {
        m.do_step(t, h).unwrap();
        t += h;
        assert!(get(m, "flange.speed") < 400.0, "stays on the plateau");
        assert!(close(get(m, "flange.speed"), 10.0 + a * t, 1e-13));
        assert!(close(
            get(m, "flange.angle"),
            10.0 * t + 0.5 * a * t * t,
            1e-13
        ));
    }
    // A fraction ramp over the plateau: T_e = 150 (f0 + f' t), a cubic in the angle again.
    let w = get(m, "flange.speed");
    m.set_input_derivative(vr(m, "torque_fraction"), 1, 2.0)
        .unwrap();
    m.do_step(t, 0.02).unwrap();
    assert!(get(m, "flange.speed") < 400.0, "stays on the plateau");
    let want = w + (a * 0.02 + 150.0 * 2.0 * 0.02 * 0.02 / 2.0 / 0.01);
    assert!(close(get(m, "flange.speed"), want, 1e-13));
    // A ramp that would leave [0, 1] within the step is refused, naming the input.
    m.set_input_derivative(vr(m, "torque_fraction"), 1, 30.0)
        .unwrap();
    let e = m.do_step(t + 0.02, 0.1).unwrap_err();
    assert!(format!("{e:?}").contains("torque_fraction"), "{e:?}");
}

/// Bad values name the field and the value; nothing is clamped.
#[test]
fn bad_parameters_are_refused_naming_them() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, INERTIA.replace("inertia = 0.25", "inertia = -0.25")).unwrap();
    let e = load_scene(&path).err().unwrap();
    assert!(e.contains("element.inertia = -0.25"), "{e}");
    std::fs::write(
        &path,
        SHAFT.replace("damping = 1.5", "damping = 1.5\nmass = 2"),
    )
    .unwrap();
    let e = load_scene(&path).err().unwrap();
    assert!(e.contains("mass"), "{e}");

    let mut loaded = model(INERTIA);
    let m = loaded.model.as_mut();
    let r = vr(m, "inertia");
    let e = m.set_real(r, 0.0).unwrap_err();
    assert!(e.contains("inertia = 0") && e.contains("> 0"), "{e}");
    assert_eq!(get(m, "inertia"), 0.25, "a refused value changes nothing");
    set(m, "inertia", 0.5);
    set(m, "initial.speed", 2.0);
    assert_eq!(get(m, "flange_a.speed"), 2.0);
    init(m);
    assert!(m.set_real(r, 1.0).unwrap_err().contains("fixed"));
}

/// An FMU state taken with input rates set continues bit-identically after a restore.
#[test]
fn state_with_input_rates_restores_bit_identically() {
    let text = std::fs::read_to_string("fmu/emotor/scene.toml").unwrap();
    let mut loaded = model(&text);
    let m = loaded.model.as_mut();
    init(m);
    let (mut t, h) = (0.0, 1e-3);
    for _ in 0..40 {
        m.do_step(t, h).unwrap();
        t += h;
    }
    set(m, "flange.torque", -30.0);
    m.set_input_derivative(vr(m, "flange.torque"), 1, -500.0)
        .unwrap();
    let saved = m.save_state();
    let run = |m: &mut dyn CoSimModel| -> Vec<u64> {
        let mut tt = t;
        let mut out = Vec::new();
        for _ in 0..20 {
            m.do_step(tt, h).unwrap();
            tt += h;
            out.push(get(m, "flange.speed").to_bits());
            out.push(get(m, "flange.acceleration").to_bits());
        }
        out
    };
    let first = run(m);
    m.load_state(&saved).unwrap();
    assert_eq!(run(m), first);
    let mut bad = saved.clone();
    bad.truncate(bad.len() - 1);
    assert!(m.load_state(&bad).is_err());
}

/// The shipped element scenes reproduce `fmu/<name>/reference.csv` byte for byte: the default
/// experiment with the start inputs (motor run-up from rest, load coast-down), and for the
/// shafts end a driven at 471.24 rad/s with a 50 Hz, 0.01 rad oscillation and end b at the
/// mean speed, the inputs given with their rates (`fmi2SetRealInputDerivatives`).
#[test]
fn shipped_element_scenes_reproduce_their_references() {
    for name in ["emotor", "shaft_in", "shaft_out", "vehicle_load"] {
        let folder = std::path::Path::new("fmu").join(name);
        let loaded = load_scene(&folder.join("scene.toml")).unwrap();
        let mut model = loaded.model;
        let m = model.as_mut();
        let ex = loaded.info.default_experiment;
        let outputs: Vec<(String, u32)> = m
            .variables()
            .iter()
            .filter(|v| v.causality == Causality::Output)
            .map(|v| (v.name.clone(), v.value_reference))
            .collect();
        let shaft = name.starts_with("shaft");
        let drive = |m: &mut dyn CoSimModel, t: f64| {
            if shaft {
                let (w, a, f) = (471.238898038469, 0.01, 2.0 * std::f64::consts::PI * 50.0);
                let signals = [
                    (
                        "flange_a.angle",
                        w * t + a * (f * t).sin(),
                        w + a * f * (f * t).cos(),
                    ),
                    (
                        "flange_a.speed",
                        w + a * f * (f * t).cos(),
                        -a * f * f * (f * t).sin(),
                    ),
                    ("flange_b.angle", w * t, w),
                    ("flange_b.speed", w, 0.0),
                ];
                for (n, x, rate) in signals {
                    set(m, n, x);
                    m.set_input_derivative(vr(m, n), 1, rate).unwrap();
                }
            }
        };
        drive(m, 0.0);
        init(m);
        let mut csv = String::from("time");
        for (n, _) in &outputs {
            csv.push(',');
            csv.push_str(n);
        }
        csv.push('\n');
        let row = |m: &dyn CoSimModel, t: f64, csv: &mut String| {
            csv.push_str(&format!("{t:?}"));
            for (_, r) in &outputs {
                csv.push_str(&format!(",{:?}", m.get_real(*r).unwrap()));
            }
            csv.push('\n');
        };
        row(m, 0.0, &mut csv);
        let n = (ex.stop_time / ex.step_size).round() as usize;
        for i in 0..n {
            let t = i as f64 * ex.step_size;
            if i > 0 {
                drive(m, t);
            }
            m.do_step(t, ex.step_size).unwrap();
            row(m, (i + 1) as f64 * ex.step_size, &mut csv);
        }
        let path = folder.join("reference.csv");
        if std::env::var_os("GEARDYN_WRITE_REFERENCE").is_some() {
            std::fs::write(&path, &csv).unwrap();
        }
        let reference = std::fs::read_to_string(&path).unwrap();
        assert!(
            csv == reference,
            "{name}: output differs from {}",
            path.display()
        );
        println!("{name}: {} rows identical to the reference", n + 1);
    }
}

/// Issue 34, failing case 7: before initialization `emotor` with `initial.angle = -1e308` and
/// `vehicle_load` with `initial.speed = -9.7e215` answered NaN/±inf outputs with fmi2OK. A
/// set that would make an output non-finite is refused naming the variable; whatever is
/// accepted reads finite.
#[test]
fn unusable_start_values_are_refused_when_set() {
    for (scene, name, value) in [
        ("emotor", "initial.angle", -1e308),
        ("vehicle_load", "initial.speed", -9.7e215),
    ] {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("fmu")
            .join(scene)
            .join("scene.toml");
        let mut loaded = load_scene(&path).unwrap();
        let m = loaded.model.as_mut();
        let r = vr(m, name);
        match m.set_real(r, value) {
            Err(e) => assert!(e.contains(name), "{scene}: {e}"),
            Ok(_) => {
                let outputs: Vec<(String, u32)> = m
                    .variables()
                    .iter()
                    .map(|v| (v.name.clone(), v.value_reference))
                    .collect();
                for (n, vr) in outputs {
                    if let Ok(x) = m.get_real(vr) {
                        assert!(
                            x.is_finite(),
                            "{scene}: {name} = {value:e} accepted, {n} = {x}"
                        );
                    }
                }
            }
        }
    }
}
