//! Drivetrain elements in a native scene (`docs/ports.md`, "Elements in the scene"): the
//! monolithic drivetrain `examples/drivetrain_monolithic.toml` (e-motor → shaft → spur stage
//! → shaft → vehicle load). Each test has its own oracle:
//!
//! - power balance: every term by its own quadrature from the recorded columns and the scene's
//!   numbers (the motor torque, the load's resistance, the shaft and mesh energies and
//!   dissipation formed here from docs/elements.md and docs/model.md, not read from the model);
//! - speed ratio: the tooth ratio z1/z2;
//! - scene checks: the messages name the keys.
//!
//! The independent dynamic oracle (scipy) is `tests/python/test_drivetrain_monolithic.py`.

use std::f64::consts::TAU;
use std::path::PathBuf;

use geardyn::model::train::{run_train, TrainTrajectory};
use geardyn::scene::Scene;

fn text() -> String {
    let path =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples/drivetrain_monolithic.toml");
    std::fs::read_to_string(path).unwrap()
}

fn scene(text: &str) -> Scene {
    Scene::from_toml_str(text, "test").unwrap()
}

fn refused(text: &str) -> String {
    Scene::from_toml_str(text, "test")
        .map(|_| ())
        .unwrap_err()
        .to_string()
}

fn col<'a>(run: &'a TrainTrajectory, name: &str) -> impl Fn(usize) -> f64 + 'a {
    let c = run
        .column(name)
        .unwrap_or_else(|| panic!("no column {name}"));
    move |i| run.rows[i][c]
}

/// The example's numbers, as written in the file (docs/elements.md symbols).
const J_M: f64 = 0.01;
const D_M: f64 = 1.0e-4;
const KP: f64 = 5.0;
const OMEGA_REF: f64 = 324.20821204830196;
const RIPPLE: [(f64, f64, f64); 2] = [(6.0, 3.0, 0.0), (12.0, 1.5, 0.5)];
const J_L: f64 = 0.5;
const T0: f64 = 10.0;
const C_V: f64 = 0.05;
const C_D: f64 = 1.1e-3;
const K1: f64 = 2.0e4;
const C1: f64 = 1.0;
const K2: f64 = 5.0e4;
const C2: f64 = 2.0;

/// T_max(ω) of the example's curve, piecewise linear, constant beyond the ends.
fn t_max(w: f64) -> f64 {
    let s = [0.0, 400.0, 500.0, 600.0, 800.0, 1000.0];
    let t = [150.0, 150.0, 120.0, 100.0, 75.0, 60.0];
    if w <= s[0] {
        return t[0];
    }
    for i in 1..s.len() {
        if w <= s[i] {
            return t[i - 1] + (t[i] - t[i - 1]) * (w - s[i - 1]) / (s[i] - s[i - 1]);
        }
    }
    t[s.len() - 1]
}

/// The example moved to the first version's operating point, 4500 rpm (the same road load):
/// the mesh frequency 2850 Hz lies near the mesh mode and the teeth rattle (contact loss and
/// back-side impacts every mesh period). Returns the text and its motor speed reference.
fn rattling_text() -> (String, f64) {
    let omega_ref = 490.9923008760553;
    let mut t = text();
    for (key, value) in [
        ("pinion_speed", "471.238898038469"),
        ("input_torque", "98.71989029812774"),
        ("load_torque", "142.88405174729016"),
    ] {
        let start = t.find(&format!("\n{key} = ")).unwrap() + 1;
        let end = start + t[start..].find('\n').unwrap();
        t.replace_range(start..end, &format!("{key} = {value}"));
    }
    let t = t.replace(
        &format!("speed_reference = {OMEGA_REF}"),
        &format!("speed_reference = {omega_ref}"),
    );
    assert!(t.contains("speed_reference = 490.99"));
    (t, omega_ref)
}

#[test]
fn power_balance_of_the_whole_drivetrain_at_cruise() {
    power_balance(&text(), OMEGA_REF, false);
}

#[test]
fn power_balance_of_the_whole_drivetrain_when_it_rattles() {
    let (t, omega_ref) = rattling_text();
    power_balance(&t, omega_ref, true);
}

fn power_balance(text: &str, omega_ref: f64, rattles: bool) {
    // Motor source work − load work − dissipated energy − Δ stored energy + parametric work
    // = 0 to 1e-6 of the source work, over 5 ms, each term by its own trapezoid on a 5e-8 s
    // grid:
    // - source work ∫(T_e + T_r) ω_m dt, T_e = k_p(ω_ref − ω_m) (P control, inside T_max),
    //   T_r = Σ a cos(oθ_m + φ);
    // - load work ∫(T0 + c_v ω_L + c_d ω_L|ω_L|) ω_L dt;
    // - dissipated: ∫d_m ω_m² + ∫c_1(ω_m − ω_1)² + ∫c_2(ω_2 − ω_L)² + ∫c(Ṡ − ė)² (contact);
    // - stored: ½Jω² of the four bodies, ½k(Δθ)² of the two shafts, ½k_mesh(S − e + o)²;
    // - parametric work of the mesh as in tests/ports.rs (the STE moving the spring's seat,
    //   and the stiffness jumps).
    let sc = scene(text);
    let (p, g) = (&sc.gears[0], &sc.gears[1]);
    let (r1, r2, j1, j2, z1) = (
        p.base_radius,
        g.base_radius,
        p.inertia,
        g.inertia,
        f64::from(p.teeth),
    );
    let (k_mean, zeta, two_b, ste) = (2.9831e8, 0.05, 1.0e-4, 1.0e-6);
    let m_e = 1.0 / (r1 * r1 / j1 + r2 * r2 / j2);
    let c = 2.0 * zeta * (k_mean * m_e).sqrt();
    let h = 5e-8;
    let run = run_train(&sc, 0.005, h).unwrap();
    let n = run.times.len();
    let (w1, w2) = (col(&run, "pinion.speed"), col(&run, "gear.speed"));
    let (a1, a2) = (col(&run, "pinion.angle"), col(&run, "gear.angle"));
    let (am, wm) = (col(&run, "motor.angle"), col(&run, "motor.speed"));
    let (al, wl) = (col(&run, "load.angle"), col(&run, "load.speed"));
    let drive_col = col(&run, "motor.drive_torque");
    let (s, sd) = (col(&run, "mesh1.deflection"), col(&run, "mesh1.dte_rate"));
    let (force, k) = (col(&run, "mesh1.force"), col(&run, "mesh1.stiffness"));
    let (contact, phase) = (col(&run, "mesh1.contact_state"), col(&run, "mesh1.phase"));
    let drive = |i: usize| {
        let te = KP * (omega_ref - wm(i));
        assert!(
            te.abs() < t_max(wm(i)),
            "the P controller stays inside T_max"
        );
        let tr: f64 = RIPPLE
            .iter()
            .map(|&(o, a, ph)| a * (o * am(i) + ph).cos())
            .sum();
        te + tr
    };
    let resist = |i: usize| T0 + C_V * wl(i) + C_D * wl(i) * wl(i).abs();
    let e = |i: usize| ste * (TAU * phase(i)).cos();
    let e_rate = |i: usize| -ste * TAU * (TAU * phase(i)).sin() * z1 * w1(i) / TAU;
    let offset = |i: usize| match contact(i) {
        x if x > 0.5 => Some(0.0),
        x if x < -0.5 => Some(two_b),
        _ => None,
    };
    let stored = |i: usize| {
        let kin = 0.5
            * (J_M * wm(i).powi(2) + j1 * w1(i).powi(2) + j2 * w2(i).powi(2) + J_L * wl(i).powi(2));
        let shafts = 0.5 * K1 * (am(i) - a1(i)).powi(2) + 0.5 * K2 * (a2(i) - al(i)).powi(2);
        let mesh = offset(i).map_or(0.0, |o| 0.5 * k(i) * (s(i) - e(i) + o).powi(2));
        kin + shafts + mesh
    };
    let dissipation = |i: usize| {
        let mesh = offset(i).map_or(0.0, |_| c * (sd(i) - e_rate(i)).powi(2));
        D_M * wm(i).powi(2) + C1 * (wm(i) - w1(i)).powi(2) + C2 * (w2(i) - wl(i)).powi(2) + mesh
    };
    let (mut w_src, mut w_load, mut diss, mut param, mut jumps) = (0.0, 0.0, 0.0, 0.0, 0);
    let mut drive_err: f64 = 0.0;
    for i in 1..n {
        let dt = run.times[i] - run.times[i - 1];
        let trap = |f: &dyn Fn(usize) -> f64| 0.5 * dt * (f(i - 1) + f(i));
        w_src += trap(&|j| drive(j) * wm(j));
        w_load += trap(&|j| resist(j) * wl(j));
        diss += trap(&dissipation);
        param -= trap(&|j| force(j) * e_rate(j));
        drive_err = drive_err.max((drive_col(i) - drive(i)).abs());
        if k(i) != k(i - 1) {
            jumps += 1;
            if let Some(o) = offset(i) {
                let d = s(i) - e(i) + o;
                param += 0.5 * (k(i) - k(i - 1)) * d * d;
            }
        }
    }
    let delta_e = stored(n - 1) - stored(0);
    let residual = w_src - w_load - diss - delta_e + param;
    println!(
        "W_source {w_src:.9e} J, W_load {w_load:.9e} J, dissipated {diss:.6e} J, ΔE \
         {delta_e:.6e} J, parametric {param:.6e} J ({jumps} stiffness jumps); residual \
         {residual:.3e} J = {:.3e} of W_source; drive torque column within {drive_err:.1e} N·m",
        residual / w_src
    );
    assert!(drive_err <= 1e-9, "motor.drive_torque column {drive_err:e}");
    // two stiffness knots per mesh period: 19 in 5 ms at 3000 rpm, 28 at 4500 rpm
    assert!(jumps > 15, "{jumps} stiffness jumps");
    let lost = (0..n).filter(|&i| contact(i) != 1.0).count();
    assert_eq!(
        lost > 0,
        rattles,
        "{lost} of {n} samples out of drive contact"
    );
    assert!(
        diss > 0.0 && param.abs() > 1e-6 * w_src,
        "terms that matter"
    );
    assert!(
        residual.abs() <= 1e-6 * w_src,
        "power balance residual {residual:e} J"
    );
}

#[test]
fn speed_ratio_after_the_transient_is_the_tooth_ratio() {
    // 3 s at 4500 rpm (the rattling point): after 0.05 s, mean(ω_gear)/mean(ω_pinion) =
    // z1/z2 − ΔS/(r_b2 Δθ1) within 1e-6 relative (the rattling moves the mean deflection S
    // within the backlash, 2b = 1e-4 m, over Δθ1 ≈ 1390 rad: ≤ 1.1e-6 at worst); the motor and
    // the load follow their gears on average (the shafts only twist): mean speeds within 1e-6 too.
    let sc = scene(&rattling_text().0);
    let ratio = f64::from(sc.gears[0].teeth) / f64::from(sc.gears[1].teeth);
    let run = run_train(&sc, 3.0, 1e-5).unwrap();
    // The exact mean speed over [t_a, t_end] is the angle travelled over the time (a
    // trapezoid of the sampled speeds would add its own error at the mesh vibration).
    let mean = |name: &str| {
        let a = col(&run, name);
        let t = &run.times;
        let first = t.iter().position(|&x| x >= 0.05).unwrap();
        let last = t.len() - 1;
        (a(last) - a(first)) / (t[last] - t[first])
    };
    let (w1, w2, wm, wl) = (
        mean("pinion.angle"),
        mean("gear.angle"),
        mean("motor.angle"),
        mean("load.angle"),
    );
    let err = (w2 / w1) / ratio - 1.0;
    println!(
        "mean speeds after 0.05 s: motor {wm:.9} pinion {w1:.9} gear {w2:.9} load {wl:.9} \
         rad/s; mean(ω2)/mean(ω1)/(z1/z2) − 1 = {err:.3e}, motor/pinion − 1 = {:.3e}, \
         load/gear − 1 = {:.3e}",
        wm / w1 - 1.0,
        wl / w2 - 1.0
    );
    assert!(err.abs() <= 1e-6, "speed ratio error {err:e}");
    assert!((wm / w1 - 1.0).abs() <= 1e-6);
    assert!((wl / w2 - 1.0).abs() <= 1e-6);
}

#[test]
fn scene_checks_name_the_keys() {
    let base = text();
    let msg = refused(&base.replace("damping = 1.0e-4\n", "damping = 1.0e-4\nspeed = 3.0\n"));
    assert!(msg.contains("speed"), "{msg}");
    let msg = refused(&base.replace("inertia = 0.5\n", "inertia = -0.5\n"));
    assert!(
        msg.contains("load[0].inertia") && msg.contains("-0.5"),
        "{msg}"
    );
    let msg = refused(&base.replace(
        "gears = [\"motor\", \"pinion\"]",
        "gears = [\"motor\", \"rotor\"]",
    ));
    assert!(
        msg.contains("shaft[0].gears[1]") && msg.contains("rotor"),
        "{msg}"
    );
    let msg = refused(&base.replace(
        "gears = [\"motor\", \"pinion\"]\nstiffness = 2.0e4\ndamping = 1.0",
        "gears = [\"motor\", \"pinion\"]\nrigid = true",
    ));
    assert!(msg.contains("shaft[0].rigid"), "{msg}");
    let msg = refused(&base.replace("name = \"load\"", "name = \"pinion\""));
    assert!(
        msg.contains("load[0].name") && msg.contains("pinion"),
        "{msg}"
    );
    let msg = refused(&base.replace(
        "[[load]]",
        "[[inertia]]\nname = \"flywheel\"\ninertia = 1.0\n\n[[load]]",
    ));
    assert!(
        msg.contains("flywheel") && msg.contains("not coupled"),
        "{msg}"
    );
    let msg = refused(&format!(
        "{base}\n[[port]]\nname = \"input\"\ngear = \"pinion\"\n"
    ));
    assert!(msg.contains("port[0]"), "{msg}");
    let msg = refused(&base.replace("name = \"shaft2\"", "name = \"shaft1\""));
    assert!(
        msg.contains("shaft[1].name") && msg.contains("shaft1"),
        "{msg}"
    );
    let exact = scene(&base.replace("method = \"auto\"", "method = \"exact\""));
    let msg = run_train(&exact, 0.001, 1e-4)
        .err()
        .expect("exact is refused");
    assert!(msg.contains("exact") && msg.contains("[[motor]]"), "{msg}");
}

#[test]
fn an_intermediate_inertia_carries_the_chain() {
    // motor → shaft → flywheel → shaft → pinion: the start pre-twists follow the chain (the
    // flywheel leads the pinion by T_in/k_b, the motor the flywheel by T_in/k_a).
    let t = text().replace(
        "[[shaft]]\nname = \"shaft1\"\ngears = [\"motor\", \"pinion\"]",
        "[[inertia]]\nname = \"flywheel\"\ninertia = 0.02\n\n[[shaft]]\nname = \"shaft0\"\n\
         gears = [\"motor\", \"flywheel\"]\nstiffness = 1.0e4\n\n[[shaft]]\nname = \"shaft1\"\n\
         gears = [\"flywheel\", \"pinion\"]",
    );
    let sc = scene(&t);
    let run = run_train(&sc, 1e-4, 1e-5).unwrap();
    let t_in = sc.operating.input_torque;
    let (af, am) = (col(&run, "flywheel.angle"), col(&run, "motor.angle"));
    assert!((af(0) - t_in / 2.0e4).abs() <= 1e-15, "{}", af(0));
    assert!((am(0) - af(0) - t_in / 1.0e4).abs() <= 1e-15, "{}", am(0));
    assert!((col(&run, "shaft0.torque")(0) - t_in).abs() <= 1e-9);
}
