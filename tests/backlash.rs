//! Issue 2, acceptance 3, 5 and 6: the backlash scene `spur_pair` (repeated contact loss,
//! back-side impacts) with the RK path against the exact propagator, tolerance
//! proportionality, and energy conservation of an undamped backlash oscillator.

mod common;

use geardyn::model::ContactState;
use geardyn::scene::{MethodChoice, PairScene};
use geardyn::simulation::{output_grid, Simulation};
use geardyn::solve::rk::Method;

struct Run {
    dte: Vec<f64>,
    events: Vec<(f64, ContactState)>,
    mesh_periods: f64,
    static_deflection: f64,
}

fn run(scene: &PairScene, method: MethodChoice, rk: Method, rtol: f64, atol: f64) -> Run {
    let mut s = scene.clone();
    s.solver.method = method;
    s.solver.rk_method = rk;
    s.solver.rtol = rtol;
    s.solver.atol = atol;
    let mut sim = Simulation::new(&s).expect("simulation");
    sim.model_mut().record_events();
    let grid = output_grid(s.solver.stop_time, s.solver.output_interval);
    let dte = grid
        .iter()
        .map(|&t| {
            sim.advance_to(t).expect("advance");
            sim.state()[0]
        })
        .collect();
    Run {
        dte,
        events: sim.model().events().to_vec(),
        mesh_periods: s.solver.stop_time / sim.model().mesh_period(),
        static_deflection: sim.model().static_deflection(),
    }
}

fn spur_pair() -> PairScene {
    PairScene::example("spur_pair").expect("built-in scene")
}

/// `spur_pair` with a smaller clearance and a larger STE: drive-side and back-side impacts.
fn double_sided() -> PairScene {
    let text = include_str!("../fmu/spur_pair/scene.toml")
        .replacen("backlash = 1.0e-4", "backlash = 1.0e-5", 1)
        .replacen("cos = [1.0e-6]", "cos = [3.0e-6]", 1);
    PairScene::from_toml_str(&text, "double_sided").expect("scene")
}

#[test]
fn rk_and_exact_agree_with_identical_event_sequences() {
    agree_with_identical_event_sequences(&spur_pair(), false);
    agree_with_identical_event_sequences(&double_sided(), true);
}

fn agree_with_identical_event_sequences(scene: &PairScene, back_side: bool) {
    let scene = scene.clone();
    let exact = run(&scene, MethodChoice::Exact, Method::Dop853, 0.0, 0.0);
    let separations = exact
        .events
        .iter()
        .filter(|(_, s)| *s == ContactState::Separated)
        .count();
    let back_hits = exact
        .events
        .iter()
        .filter(|(_, s)| *s == ContactState::Back)
        .count();
    println!(
        "exact: {} events ({separations} separations, {back_hits} back-side contacts) over {:.1} mesh periods",
        exact.events.len(),
        exact.mesh_periods
    );
    assert!(exact.mesh_periods >= 50.0);
    assert!(separations >= 50, "repeated contact loss expected");
    assert_eq!(back_hits > 0, back_side, "back-side contacts");
    for rk in [Method::Dop853, Method::Dp5] {
        let r = run(&scene, MethodChoice::Rk, rk, 1e-10, 1e-16);
        let err = common::max_abs_diff(&r.dte, &exact.dte) / exact.static_deflection;
        let states: Vec<_> = r.events.iter().map(|e| e.1).collect();
        let exact_states: Vec<_> = exact.events.iter().map(|e| e.1).collect();
        assert_eq!(states, exact_states, "{rk}: event sequences differ");
        let dt = r
            .events
            .iter()
            .zip(&exact.events)
            .map(|(a, b)| (a.0 - b.0).abs())
            .fold(0.0, f64::max);
        println!("{rk} rtol 1e-10: max |ΔDTE| = {err:.2e} static deflections, max |Δt_event| = {dt:.2e} s");
        assert!(
            err <= 1e-8,
            "{rk}: DTE differs by {err:e} static deflections"
        );
    }
}

#[test]
fn rk_error_falls_with_rtol() {
    // A coarse output grid, so that output stops do not cap the step size and the error is the
    // integrator's (the stiffness switches, two per mesh period, remain stops).
    let mut scene = spur_pair();
    scene.solver.output_interval = 1e-3;
    let exact = run(&scene, MethodChoice::Exact, Method::Dop853, 0.0, 0.0);
    for rk in [Method::Dp5, Method::Dop853] {
        println!("{rk}: rtol  →  max |ΔDTE| / static deflection   events");
        let mut last = f64::INFINITY;
        for e in 3..=10 {
            let rtol = 10f64.powi(-e);
            // Absolute tolerance on the scale of the DTE (~1e-5 m).
            let r = run(&scene, MethodChoice::Rk, rk, rtol, rtol * 1e-5);
            let err = common::max_abs_diff(&r.dte, &exact.dte) / exact.static_deflection;
            println!("  {rtol:.0e}  {err:.3e}  {}", r.events.len());
            assert!(
                err < last,
                "{rk}: error {err:e} at rtol {rtol:e} did not fall (was {last:e})"
            );
            last = err;
        }
    }
}

/// Energy of the undamped, unforced pair: ½ m v² + ½ k δ_c² with δ_c the compression of the
/// side in contact.
fn energy(m: f64, k: f64, clearance: f64, x: f64, v: f64, state: f64) -> f64 {
    let compression = match state as i32 {
        1 => x,
        -1 => x + clearance,
        _ => 0.0,
    };
    0.5 * m * v * v + 0.5 * k * compression * compression
}

#[test]
fn undamped_backlash_oscillator_conserves_energy() {
    let (k, clearance, x0) = (2.0e8, 1.0e-4, 2.0e-6);
    let scene = common::scene(
        &format!(
            "contact = \"backlash\"\nbacklash = {clearance:e}\n\
             [mesh.stiffness]\nkind = \"constant\"\nvalue = {k:e}"
        ),
        "pinion_speed = 100.0\ninput_torque = 0.0",
        &format!("[initial]\ndte = {x0:e}\n[solver]\nmethod = \"exact\""),
    );
    let m = common::M_E;
    let e0 = 0.5 * k * x0 * x0;
    // One oscillation: two contact half-periods and two flights across the clearance.
    let v_free = (2.0 * e0 / m).sqrt();
    let period = 2.0 * std::f64::consts::PI / (k / m).sqrt() + 2.0 * clearance / v_free;
    let oscillations = 1.0e5;
    let mut sim = Simulation::new(&scene).expect("simulation");
    let mut worst: f64 = 0.0;
    let samples = 1000;
    for i in 1..=samples {
        sim.advance_to(i as f64 * oscillations * period / samples as f64)
            .expect("advance");
        let [x, v] = sim.state();
        let state = sim.outputs()[3];
        worst = worst.max((energy(m, k, clearance, x, v, state) - e0).abs() / e0);
    }
    let events = sim.stats().events;
    println!("{events} events over {oscillations:e} oscillations: max |ΔE|/E0 = {worst:.2e}");
    assert!(
        events as f64 >= 3.9 * oscillations,
        "expected 4 contact changes per oscillation"
    );
    assert!(worst <= 1e-9, "energy drifted by {worst:e}");
}
