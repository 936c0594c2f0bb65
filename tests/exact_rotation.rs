//! Issue 18 point 1: the exact piecewise-LTI propagator on scenes with the rotation carried
//! (`docs/ports.md`, "What stays piecewise-LTI"). Oracle: DOP853 at rtol 1e-12 on the same
//! scene (an independent integration of the state-dependent right-hand side, knots and
//! contact changes as root-found state events); the scipy model of the pair is the second,
//! fully independent oracle (`tests/python/test_ports_reference.py`).

use std::path::PathBuf;

use geardyn::model::train::TrainSimulation;
use geardyn::scene::MethodChoice;
use geardyn::scene::Scene;
use geardyn::solve::rk::Method;

fn read(path: &str) -> String {
    std::fs::read_to_string(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(path)).unwrap()
}

/// `fmu/spur_stage` without its STE harmonic (an STE of the carried phase is not linear in
/// the state), contact law `contact`.
fn stage(contact: &str) -> String {
    let text = read("fmu/spur_stage/scene.toml").replace("[mesh.ste]\ncos = [1.0e-6]\n", "");
    match contact {
        "backlash" => text,
        _ => text.replace(
            "contact = \"backlash\"\nbacklash = 1.0e-4",
            &format!("contact = \"{contact}\""),
        ),
    }
}

/// The `idler_gearset` data (three gears, two meshes with tip relief and contact loss, eight
/// DOFs) turning freely, with torque ports on the pinion and the follower instead of the
/// ground springs; the load balances the input through the base radii.
fn idler_with_ports(input_torque: f64, speed: f64) -> String {
    let load = -input_torque * 0.11218 / 0.04535;
    read("fmu/idler_gearset/scene.toml")
        .replace("ground_stiffness = 3389.6\n", "")
        .replace("ground_stiffness = 11297.9\n", "")
        .replace(
            "input_speed = 330.6939635357677          # rad/s: mesh frequency 2000 Hz\ninput_torque = 100.0",
            &format!(
                "pinion_speed = {speed:?}\n\n[[port]]\nname = \"input\"\ngear = \"pinion\"\n\
                 causality = \"torque\"\ntorque = {input_torque:?}\n\n[[port]]\nname = \"output\"\n\
                 gear = \"follower\"\ncausality = \"torque\"\ntorque = {load:?}\n"
            ),
        )
}

struct Run {
    names: Vec<String>,
    rows: Vec<Vec<f64>>,
    events: Vec<(f64, usize, usize, String)>,
    /// Every state event the propagator took: contact changes and stiffness knots.
    state_events: u64,
    method: String,
}

impl Run {
    fn col(&self, name: &str) -> Vec<f64> {
        let c = (self.names.iter().position(|n| n == name)).unwrap_or_else(|| panic!("{name}"));
        self.rows.iter().map(|r| r[c]).collect()
    }
}

fn run(text: &str, exact: bool, stop: f64, dt: f64) -> Run {
    run_with_rates(text, exact, stop, dt, [0.0; 2])
}

/// [`run`] with the input and load torques ramping at `rates` (N·m/s) from t = 0, as the
/// FMU's input derivatives make them over a step.
fn run_with_rates(text: &str, exact: bool, stop: f64, dt: f64, rates: [f64; 2]) -> Run {
    run_with_derivatives(
        text,
        exact,
        stop,
        dt,
        [[rates[0], 0.0, 0.0], [rates[1], 0.0, 0.0]],
    )
}

/// [`run`] with the input and load torques following cubics of derivatives `d` (orders 1–3,
/// input then load) from t = 0, as the FMU's input derivatives of orders 1–3 make them.
fn run_with_derivatives(text: &str, exact: bool, stop: f64, dt: f64, d: [[f64; 3]; 2]) -> Run {
    let mut scene = Scene::from_toml_str(text, "test").unwrap();
    scene.solver.method = if exact {
        MethodChoice::Exact
    } else {
        MethodChoice::Rk
    };
    scene.solver.rk_method = Method::Dop853;
    scene.solver.rtol = 1e-12;
    scene.solver.atol = 1e-18;
    let mut sim = TrainSimulation::new(&scene).unwrap();
    sim.model_mut().record_events();
    if d != [[0.0; 3]; 2] {
        sim.change_model(|train, t| train.set_torque_derivatives(t, d))
            .unwrap();
    }
    let steps = (stop / dt).round() as usize;
    let mut rows = Vec::new();
    let mut out = Vec::new();
    for i in 0..=steps {
        sim.advance_to(i as f64 * dt).unwrap();
        sim.outputs(&mut out);
        rows.push(out.clone());
    }
    Run {
        names: sim.output_names().to_vec(),
        rows,
        events: (sim.model().events().iter())
            .map(|&(t, n, j, f)| (t, n, j, format!("{f:?}")))
            .collect(),
        state_events: sim.stats().events,
        method: sim.method_name(),
    }
}

/// Largest |exact − DOP853| of `column` over the run, relative to `scale`.
fn error(a: &Run, b: &Run, column: &str, scale: f64) -> f64 {
    (a.col(column).iter().zip(b.col(column)))
        .map(|(x, y)| (x - y).abs() / scale)
        .fold(0.0, f64::max)
}

/// Checks that both runs have the same contact events in the same order; returns the largest
/// difference of their times, s.
fn same_events(a: &Run, b: &Run) -> f64 {
    assert_eq!(a.events.len(), b.events.len(), "event counts");
    (a.events.iter().zip(&b.events))
        .map(|(x, y)| {
            assert_eq!(
                (x.1, x.2, &x.3),
                (y.1, y.2, &y.3),
                "events at {} / {}",
                x.0,
                y.0
            );
            (x.0 - y.0).abs()
        })
        .fold(0.0, f64::max)
}

/// Static deflection of a mesh `F/k̄` with `F = T_in / r_b,pinion`.
fn static_deflection(torque: f64, radius: f64, mean: f64) -> f64 {
    torque / radius / mean
}

#[test]
fn spur_stage_exact_matches_dop853_with_and_without_contact_loss() {
    let x0 = static_deflection(100.0, 0.04535, 2.9831e8);
    for contact in ["backlash", "linear"] {
        let text = stage(contact);
        let exact = run(&text, true, 0.01, 1e-5);
        let rk = run(&text, false, 0.01, 1e-5);
        assert_eq!(
            (exact.method.as_str(), rk.method.as_str()),
            ("exact", "dop853")
        );
        let dte = error(&exact, &rk, "mesh1.dte", x0);
        let speed =
            error(&exact, &rk, "pinion.speed", 1.0).max(error(&exact, &rk, "gear.speed", 1.0));
        let dt = same_events(&exact, &rk);
        println!(
            "spur_stage ({contact}) 10 ms: {} contact events, event times within {dt:.2e} s, \
             DTE {dte:.2e} of the static deflection, speeds {speed:.2e} rad/s",
            exact.events.len()
        );
        // 10 ms at 2850 Hz: two knots per mesh period, each a state event.
        assert!(
            exact.state_events >= exact.events.len() as u64 + 50,
            "knot events: {} state events, {} contact events",
            exact.state_events,
            exact.events.len()
        );
        if contact == "backlash" {
            assert!(exact.events.len() > 50, "the stage rattles");
        } else {
            assert!(exact.events.is_empty());
        }
        assert!(dt <= 1e-9, "event times differ by {dt:e} s");
        assert!(dte <= 1e-9, "DTE error {dte:e} of the static deflection");
        assert!(speed <= 1e-8, "speed error {speed:e} rad/s");
    }
}

#[test]
fn idler_with_ports_exact_matches_dop853() {
    let text = idler_with_ports(100.0, 330.6939635357677);
    let exact = run(&text, true, 0.005, 1e-5);
    let rk = run(&text, false, 0.005, 1e-5);
    let dt = same_events(&exact, &rk);
    let mut worst = 0.0f64;
    for (mesh, mean) in [("mesh1", 2.9831e8), ("mesh2", 3.2108e8)] {
        let dte = error(
            &exact,
            &rk,
            &format!("{mesh}.dte"),
            static_deflection(100.0, 0.04535, mean),
        );
        worst = worst.max(dte);
        println!("idler with ports 5 ms: {mesh} DTE {dte:.2e} of the static deflection");
    }
    let speed = ["pinion.speed", "idler.speed", "follower.speed"]
        .iter()
        .map(|c| error(&exact, &rk, c, 1.0))
        .fold(0.0, f64::max);
    println!(
        "idler with ports: {} contact events, times within {dt:.2e} s, speeds {speed:.2e} rad/s",
        exact.events.len()
    );
    assert!(dt <= 1e-9, "event times differ by {dt:e} s");
    assert!(worst <= 1e-9, "DTE error {worst:e}");
    assert!(speed <= 1e-8, "speed error {speed:e} rad/s");
}

#[test]
fn a_reversing_shaft_crosses_knots_backwards() {
    // Slow start and a braking input torque: the pinion stops and turns back, so the phase runs
    // backwards through stiffness knots and a cycle wrap (backward knot guards `r_n ≥ 0`).
    let text = stage("backlash")
        .replace("pinion_speed = 471.238898038469", "pinion_speed = 20.0")
        .replace("torque = 100.0", "torque = -50.0");
    // −150 N·m at the pinion on 7.8e-3 kg·m²: it stops after 1 ms, then turns back by about
    // 1.4 mesh cycles in the next 5 ms (three knots backwards).
    let exact = run(&text, true, 0.006, 1e-5);
    let rk = run(&text, false, 0.006, 1e-5);
    let w = exact.col("pinion.speed");
    assert!(
        w[0] > 0.0 && *w.last().unwrap() < -30.0,
        "the pinion turned back"
    );
    let phase = exact.col("mesh1.phase");
    assert!(
        phase.windows(2).any(|p| p[1] - p[0] > 0.5),
        "the phase wrapped backwards"
    );
    let largest = rk
        .col("mesh1.dte")
        .iter()
        .fold(0.0f64, |a, v| a.max(v.abs()));
    let dte = error(&exact, &rk, "mesh1.dte", largest);
    let speed = error(&exact, &rk, "pinion.speed", 1.0);
    let dt = same_events(&exact, &rk);
    println!(
        "reversing: {} contact events (times within {dt:.2e} s), DTE {dte:.2e} of the largest, \
         speed {speed:.2e} rad/s",
        exact.events.len()
    );
    assert!(
        exact.state_events >= 3,
        "knots crossed: {}",
        exact.state_events
    );
    assert!(dte <= 1e-9 && speed <= 1e-8 && dt <= 1e-9);
}

#[test]
fn torque_ramps_of_the_fmu_inputs_run_exact() {
    // The FMU's input derivatives (`docs/ports.md`): the port torques ramp within a step, an
    // extra lifted coordinate t − t_anchor carries them. One FMU step of 5e-4 s with the rates
    // of `tests/python/test_ports_interp.py`.
    let text = stage("backlash");
    let rates = [2e5, -1.5e5];
    let exact = run_with_rates(&text, true, 5e-4, 1e-5, rates);
    let rk = run_with_rates(&text, false, 5e-4, 1e-5, rates);
    let held = run(&text, true, 5e-4, 1e-5);
    let x0 = static_deflection(100.0, 0.04535, 2.9831e8);
    let dte = error(&exact, &rk, "mesh1.dte", x0);
    let speed = error(&exact, &rk, "pinion.speed", 1.0).max(error(&exact, &rk, "gear.speed", 1.0));
    let ramp_effect = error(&exact, &held, "mesh1.dte", x0);
    println!(
        "torque ramp: DTE {dte:.2e} of the static deflection (the ramp moves it by {ramp_effect:.2e}), \
         speeds {speed:.2e} rad/s"
    );
    assert_eq!(exact.method, "exact");
    assert!(
        ramp_effect > 0.1,
        "the ramp changes the answer: {ramp_effect:e}"
    );
    assert!(dte <= 1e-9 && speed <= 1e-8, "{dte:e} {speed:e}");
}

#[test]
fn cubic_torques_of_the_fmu_inputs_run_exact() {
    // Input derivatives of orders 1–3 (issue 32, `docs/cosimulation.md`): the exact
    // propagator carries the cubic on the nilpotent chain τ, τ²/2, τ³/6; DOP853 at rtol 1e-12
    // evaluates the cubic in the right-hand side. The elastic coordinates (the DTE) see the
    // forcing through the same rows as the rigid ones (`tests/stage_input_derivatives.rs`
    // checks those against the momentum balance).
    let text = stage("backlash");
    let d = [[2e5, -4e8, 1e12], [-1.5e5, 6e8, -2e12]];
    let exact = run_with_derivatives(&text, true, 5e-4, 1e-5, d);
    let rk = run_with_derivatives(&text, false, 5e-4, 1e-5, d);
    let ramp = run_with_rates(&text, true, 5e-4, 1e-5, [d[0][0], d[1][0]]);
    let x0 = static_deflection(100.0, 0.04535, 2.9831e8);
    let dte = error(&exact, &rk, "mesh1.dte", x0);
    let speed = error(&exact, &rk, "pinion.speed", 1.0).max(error(&exact, &rk, "gear.speed", 1.0));
    let cubic_effect = error(&exact, &ramp, "mesh1.dte", x0);
    println!(
        "cubic torques: DTE {dte:.2e} of the static deflection (orders 2–3 move it by \
         {cubic_effect:.2e}), speeds {speed:.2e} rad/s"
    );
    assert_eq!(exact.method, "exact");
    assert!(
        cubic_effect > 0.1,
        "orders 2–3 change the answer: {cubic_effect:e}"
    );
    assert!(dte <= 1e-9 && speed <= 1e-8, "{dte:e} {speed:e}");
}

#[test]
fn auto_says_why_it_chose_rk() {
    // The shipped stage has an STE harmonic: a function of the carried angle.
    let c = TrainSimulation::new(
        &Scene::from_toml_str(&read("fmu/spur_stage/scene.toml"), "t").unwrap(),
    )
    .unwrap()
    .method_choice()
    .to_owned();
    assert!(
        c.starts_with("dop853 (auto: exact refused: mesh 'mesh1' has an STE"),
        "{c}"
    );
    let c = TrainSimulation::new(&Scene::from_toml_str(&stage("backlash"), "t").unwrap())
        .unwrap()
        .method_choice()
        .to_owned();
    assert!(c.starts_with("exact (auto"), "{c}");
    // The monolithic drivetrain: its motor's curve is not linear.
    let c = TrainSimulation::new(
        &Scene::from_toml_str(&read("examples/drivetrain_monolithic.toml"), "t").unwrap(),
    )
    .unwrap()
    .method_choice()
    .to_owned();
    assert!(c.contains("auto: exact refused: [[motor]] 'motor'"), "{c}");
    // A load with drag, the motor replaced by a linear flywheel.
    let text =
        read("examples/drivetrain_monolithic.toml").replace("[mesh.ste]\ncos = [1.0e-6]\n", "");
    let (start, end) = (
        text.find("[[motor]]").unwrap(),
        text.find("[[load]]").unwrap(),
    );
    let text = format!(
        "{}[[inertia]]\nname = \"motor\"\ninertia = 0.01\n\n{}",
        &text[..start],
        &text[end..]
    );
    let c = TrainSimulation::new(&Scene::from_toml_str(&text, "t").unwrap())
        .unwrap()
        .method_choice()
        .to_owned();
    assert!(
        c.contains("auto: exact refused: [[load]] 'load': its drag"),
        "{c}"
    );
    // Speed ports: the coupling's neighbour angle integrates a speed ramp (no STE here, so the
    // port is the reason).
    let text = read("fmu/spur_stage_speed/scene.toml").replace("[mesh.ste]\ncos = [1.0e-6]\n", "");
    assert!(!text.contains("[mesh.ste]"));
    let c = TrainSimulation::new(&Scene::from_toml_str(&text, "t").unwrap())
        .unwrap()
        .method_choice()
        .to_owned();
    assert!(
        c.contains("auto: exact refused: port 'input' has speed causality"),
        "{c}"
    );
}

#[test]
fn linear_elements_run_exact() {
    // The monolithic drivetrain with its motor replaced by a flywheel (an [[inertia]] of the
    // rotor's inertia and damping) and a load without drag, the STE removed: every element is
    // linear, the pre-twisted shafts unwind while the train coasts against the load torque.
    let text = read("examples/drivetrain_monolithic.toml")
        .replace("[mesh.ste]\ncos = [1.0e-6]\n", "")
        .replace("drag = 1.1e-3", "drag = 0.0");
    let start = text.find("[[motor]]").unwrap();
    let end = text.find("[[load]]").unwrap();
    let text = format!(
        "{}[[inertia]]\nname = \"motor\"\ninertia = 0.01\ndamping = 1.0e-4\n\n{}",
        &text[..start],
        &text[end..]
    );
    let exact = run(&text, true, 0.005, 1e-5);
    let rk = run(&text, false, 0.005, 1e-5);
    assert_eq!(exact.method, "exact");
    let x0 = static_deflection(98.71989029812774, 0.04535, 2.9831e8);
    let dte = error(&exact, &rk, "mesh1.dte", x0);
    let speed = ["motor.speed", "pinion.speed", "gear.speed", "load.speed"]
        .iter()
        .map(|c| error(&exact, &rk, c, 1.0))
        .fold(0.0, f64::max);
    let torque = ["shaft1.torque", "shaft2.torque"]
        .iter()
        .map(|c| error(&exact, &rk, c, 98.7))
        .fold(0.0, f64::max);
    let dt = same_events(&exact, &rk);
    println!(
        "linear elements 5 ms: {} contact events (times within {dt:.2e} s), DTE {dte:.2e} of the \
         static deflection, speeds {speed:.2e} rad/s, shaft torques {torque:.2e} of the start torque",
        exact.events.len()
    );
    assert!(dte <= 1e-9 && speed <= 1e-8 && torque <= 1e-9 && dt <= 1e-9);
}
