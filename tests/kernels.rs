//! "Pay only for what you use": the specialised right-hand-side kernels give bit-identical
//! results to the generic kernel that evaluates every term (the oracle: the same equations
//! with the absent terms evaluated at zero coefficients), and a scene without contact loss
//! does no event work (zero root-function evaluations) with either propagator. Not timed:
//! the speed is shown by `cargo bench --bench features`.

mod common;

use geardyn::scene::{MethodChoice, PairScene};
use geardyn::simulation::Simulation;
use geardyn::solve::rk::Method;

const SPUR_PAIR: &str = include_str!("../fmu/spur_pair/scene.toml");

/// The test pair with `mesh` lines, `[mesh.*]` tables and `operating` lines added.
fn scene(mesh: &str, tables: &str, operating: &str, method: MethodChoice) -> PairScene {
    let torque = if operating.contains("input_torque") {
        ""
    } else {
        "input_torque = 50.0"
    };
    let operating = format!("{torque}\n{operating}");
    let mut s = common::scene(
        &format!(
            "{mesh}\ndamping = 200.0\n{tables}\n[mesh.stiffness]\nkind = \"rectangular\"\n\
             mean = 2.0e8\npeak_to_peak_ratio = 0.3\ncontact_ratio = 1.6"
        ),
        &format!(
            "pinion_speed = {}\n{operating}",
            common::pinion_speed_for_mesh_frequency(900.0)
        ),
        "",
    );
    s.solver.method = method;
    s.solver.rk_method = Method::Dop853;
    s
}

/// States on a grid with the kernel the scene selects and with the generic kernel.
fn both_kernels(scene: &PairScene) -> (Vec<[f64; 2]>, Vec<[f64; 2]>, &'static str) {
    let run = |generic: bool| {
        let mut sim = Simulation::new(scene).expect("simulation");
        if generic {
            sim.model_mut().use_generic_kernel();
        }
        let name = sim.model().kernel_name();
        let states: Vec<[f64; 2]> = (1..=200)
            .map(|k| {
                sim.advance_to(k as f64 * 1e-4).expect("advance");
                sim.state()
            })
            .collect();
        (states, name)
    };
    let (special, name) = run(false);
    let (generic, generic_name) = run(true);
    assert_eq!(generic_name, "generic");
    (special, generic, name)
}

#[test]
fn specialised_kernels_equal_the_generic_kernel_bit_for_bit() {
    let cases = [
        ("contact = \"linear\"", "", "", "linear"),
        (
            "contact = \"linear\"",
            "[mesh.ste]\ncos = [2.0e-6, 5.0e-7]\nsin = [1.0e-6]",
            "",
            "ste",
        ),
        (
            "contact = \"linear\"\ndamping_variation = 50.0",
            "",
            "",
            "dvar",
        ),
        (
            "contact = \"linear\"",
            "[mesh.cubic]\nstiffness_factor = 1.0e9\nspring = 1.0e15",
            "",
            "cubic",
        ),
        ("contact = \"linear\"", "", "torque_ripple = 5.0", "ripple"),
        (
            "contact = \"backlash\"\nbacklash = 1.0e-5",
            "[mesh.ste]\ncos = [3.0e-6]",
            "input_torque = 5.0",
            "ste",
        ),
        (
            "contact = \"linear\"\ndamping_variation = 50.0",
            "[mesh.cubic]\nspring = 1.0e15\n[mesh.ste]\ncos = [2.0e-6]",
            "torque_ripple = 5.0",
            "generic",
        ),
    ];
    for (mesh, tables, operating, expected) in cases {
        let s = scene(mesh, tables, operating, MethodChoice::Rk);
        let (special, generic, name) = both_kernels(&s);
        assert_eq!(
            name, expected,
            "kernel picked for {mesh} {tables} {operating}"
        );
        assert_eq!(
            special, generic,
            "kernel {name} differs from the generic kernel"
        );
        // The check can fail: a different scene gives different states.
        assert_ne!(
            special[199],
            both_kernels(&scene(mesh, tables, "input_torque = 7.0", MethodChoice::Rk)).0[199]
        );
    }
}

#[test]
fn generic_kernel_differs_when_a_term_is_present() {
    // The oracle is not vacuous: the generic kernel with a ripple really evaluates it.
    let with = scene(
        "contact = \"linear\"",
        "",
        "torque_ripple = 5.0",
        MethodChoice::Rk,
    );
    let without = scene("contact = \"linear\"", "", "", MethodChoice::Rk);
    assert_ne!(both_kernels(&with).1[199], both_kernels(&without).1[199]);
}

#[test]
fn scenes_without_contact_loss_evaluate_no_root_function() {
    // Linear contact law: no guards at all, with either propagator.
    for method in [MethodChoice::Rk, MethodChoice::Exact] {
        let s = scene(
            "contact = \"linear\"",
            "[mesh.ste]\ncos = [2.0e-6]",
            "",
            method,
        );
        let mut sim = Simulation::new(&s).expect("simulation");
        sim.advance_to(0.05).expect("advance");
        let st = sim.stats();
        assert_eq!((st.guard_evals, st.events), (0, 0), "{method:?}");
    }
    // Backlash that stays in contact (spur_pair off resonance): the exact propagator proves
    // every segment free of crossings with the energy bound, so it evaluates no guard.
    let text = SPUR_PAIR.replace("pinion_speed = 471.238898038469", "pinion_speed = 300.0");
    let mut s = PairScene::from_toml_str(&text, "in contact").expect("scene");
    s.solver.method = MethodChoice::Exact;
    let mut sim = Simulation::new(&s).expect("simulation");
    sim.advance_to(0.2).expect("advance");
    let st = sim.stats();
    assert_eq!((st.guard_evals, st.events), (0, 0));
    assert_eq!(
        st.guard_exclusions, st.steps,
        "every segment excluded by the bound"
    );
    // The same scene with RK and its root finding (an independent check): no contact loss.
    s.solver.method = MethodChoice::Rk;
    let mut rk = Simulation::new(&s).expect("simulation");
    rk.advance_to(0.2).expect("advance");
    assert_eq!(rk.stats().events, 0);
    assert!(rk.stats().guard_evals > 0);
}

#[test]
fn guard_bound_hides_no_event() {
    // spur_pair at resonance separates every period: the bound must not exclude those
    // segments, so the exact propagator finds the events the RK root finding finds.
    let mut s = PairScene::from_toml_str(SPUR_PAIR, "spur_pair").expect("scene");
    let mut count = |method| {
        s.solver.method = method;
        s.solver.rtol = 1e-10;
        let mut sim = Simulation::new(&s).expect("simulation");
        sim.model_mut().record_events();
        sim.advance_to(0.02).expect("advance");
        sim.model().events().to_vec()
    };
    let exact = count(MethodChoice::Exact);
    let rk = count(MethodChoice::Rk);
    assert!(exact.len() > 100, "{} events", exact.len());
    assert_eq!(exact.len(), rk.len());
    for (a, b) in exact.iter().zip(&rk) {
        assert_eq!(a.1, b.1);
        assert!((a.0 - b.0).abs() < 1e-9, "event times {} vs {}", a.0, b.0);
    }
}
