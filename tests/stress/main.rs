//! Issue 9, acceptance 4: the numerical stress suite. One concept per module; each has a
//! short variant that runs in CI in seconds and, where a long run adds something, a long
//! variant marked `#[ignore]` (run them all with `bash scripts/stress.sh`, see README).
//!
//! Every check compares against an expectation computed independently of the solver: closed
//! forms (free and forced linear responses, ballistic flight, grazing geometry), energy
//! bookkeeping written here (stiffness-jump work ½Δk δ², Boole quadrature of the damping
//! dissipation), the closed-form Meissner monodromy, or the other propagator (exact vs RK).

#[path = "../common/mod.rs"]
mod common;

mod backlash_limit;
mod energy;
mod fmu_steps;
mod grazing;
mod long_run;
mod parametric;
mod random;
mod rattle;
mod stiff;

use geardyn::model::ContactState;
use geardyn::scene::{MethodChoice, PairScene};
use geardyn::simulation::Simulation;
use geardyn::solve::rk::Method;

/// A scene with two equal 20-tooth gears of base radius 0.05 m and the inertia that gives the
/// equivalent mass `m_e` (`m_e = I/(2 r²)`); `mesh`, `operating`, `extra` as in
/// [`common::scene`].
pub fn scene_with_mass(m_e: f64, mesh: &str, operating: &str, extra: &str) -> PairScene {
    let inertia = 2.0 * m_e * 0.05 * 0.05;
    let text = common::scene_text(mesh, operating, extra)
        .replace("inertia = 0.0025", &format!("inertia = {inertia:e}"));
    PairScene::from_toml_str(&text, "stress scene").unwrap_or_else(|e| panic!("{e}\n{text}"))
}

/// The propagators compared by the suite.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Propagator {
    Exact,
    Rk(Method, f64),
}

impl Propagator {
    /// `scene` switched to this propagator (RK: `rtol`, and `atol` = `rtol` × `scale`).
    pub fn apply(self, scene: &PairScene, scale: f64) -> PairScene {
        let mut s = scene.clone();
        match self {
            Propagator::Exact => s.solver.method = MethodChoice::Exact,
            Propagator::Rk(m, rtol) => {
                s.solver.method = MethodChoice::Rk;
                s.solver.rk_method = m;
                s.solver.rtol = rtol;
                s.solver.atol = rtol * scale;
            }
        }
        s
    }
}

/// A simulation of `scene` by `prop` that records its contact events.
pub fn simulation(scene: &PairScene, prop: Propagator, scale: f64) -> Simulation {
    let mut sim = Simulation::new(&prop.apply(scene, scale)).expect("simulation");
    sim.model_mut().record_events();
    sim
}

/// The contact states of an event list.
pub fn states(events: &[(f64, ContactState)]) -> Vec<ContactState> {
    events.iter().map(|e| e.1).collect()
}

/// Largest |Δt| between two event lists of equal length.
pub fn max_time_difference(a: &[(f64, ContactState)], b: &[(f64, ContactState)]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x.0 - y.0).abs())
        .fold(0.0, f64::max)
}

/// `sim.advance_to(stop)` in 1000 pieces: one call is limited to `max_steps` step attempts,
/// and a long run without output stops exceeds it.
pub fn advance_in_pieces(sim: &mut Simulation, stop: f64) {
    let t0 = sim.t();
    for i in 1..=1000 {
        let t = if i == 1000 {
            stop
        } else {
            t0 + (stop - t0) * i as f64 / 1000.0
        };
        sim.advance_to(t).expect("advance");
    }
}
