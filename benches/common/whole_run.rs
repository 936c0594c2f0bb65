//! One whole run of a train scene from its start, timed: the protocol of the contact-loss
//! rows of `exact_chain` and `scaling` (issue 20, acceptance 1). A train with contact loss
//! meets new contact combinations for thousands of periods, so its cost per period is that of
//! a whole run of a given length (2000 mesh periods for the exact propagator, 400 for the RK
//! methods), mode creation included, not of a settled window.

use std::time::Instant;

use geardyn::model::train::TrainSimulation;
use geardyn::scene::MethodChoice;
use geardyn::scene::Scene;
use geardyn::solve::rk::Method as Rk;

/// µs per mesh period of `periods` mesh periods of `scene` from its start with `method` (the
/// RK method `rk` when `method` is [`MethodChoice::Rk`]), rtol 1e-9, atol 1e-15, one
/// `advance_to` per mesh period, and the finished simulation (its counters); `None` (and the
/// error printed) if the run fails.
pub fn micros_per_period(
    scene: &Scene,
    method: MethodChoice,
    rk: Rk,
    composites: bool,
    periods: f64,
) -> Option<(f64, TrainSimulation)> {
    let mut scene = scene.clone();
    scene.solver.method = method;
    scene.solver.rtol = 1e-9;
    scene.solver.atol = 1e-15;
    scene.solver.rk_method = rk;
    let f1 = scene.mesh_frequency(0, scene.operating.input_speed);
    let t_end = periods / f1;
    let mut sim = TrainSimulation::new(&scene).unwrap();
    sim.use_composites(composites);
    let start = Instant::now();
    let steps = periods as usize;
    for k in 1..=steps {
        if let Err(e) = sim.advance_to(k as f64 * t_end / steps as f64) {
            eprintln!("{}: {e}", scene.name);
            return None;
        }
    }
    Some((start.elapsed().as_secs_f64() / periods * 1e6, sim))
}
