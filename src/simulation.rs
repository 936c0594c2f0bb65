//! One simulation of a scene: the assembled model plus the propagator chosen for it.
//!
//! Used by `geardyn simulate` and by the FMU adapter alike, so both integrate the same way.

use crate::model::{GearPair, Inputs, PairState, OUTPUT_NAMES};
use crate::scene::{MethodChoice, Scene};
use crate::solve::exact::ExactPropagator;
use crate::solve::rk::{ControllerMemory, RkOptions, RkStepper};
use crate::solve::{SolveError, SolverStats};

/// The propagator actually used.
pub enum Propagator {
    Rk(Box<RkStepper>),
    Exact(Box<ExactPropagator>),
}

/// A running simulation: model state, mode and propagator.
pub struct Simulation {
    pair: GearPair,
    propagator: Propagator,
}

impl Simulation {
    /// Assembles the model and picks the propagator (`auto`: exact when the scene is piecewise
    /// LTI). Starts at `t = 0` from the scene's initial state.
    pub fn new(scene: &Scene) -> Result<Simulation, String> {
        let mut pair = GearPair::new(scene);
        let y0 = pair.initial_state(scene);
        let settings = &scene.solver;
        let exact = match settings.method {
            MethodChoice::Exact => {
                if !pair.is_piecewise_lti() {
                    return Err(
                        "method = exact: the stiffness is not piecewise constant (use rk or auto)"
                            .into(),
                    );
                }
                true
            }
            MethodChoice::Auto => pair.is_piecewise_lti(),
            MethodChoice::Rk => false,
        };
        let propagator = if exact {
            let mut p = ExactPropagator::new(&pair);
            p.set_state(0.0, &y0);
            Propagator::Exact(Box::new(p))
        } else {
            let options = RkOptions {
                rtol: settings.rtol,
                atol: settings.atol,
                ..RkOptions::new(settings.rk_method)
            };
            let mut p = RkStepper::new(options, 2)?;
            p.set_state(0.0, &y0);
            Propagator::Rk(Box::new(p))
        };
        Ok(Simulation { pair, propagator })
    }

    /// Name of the propagator in use (`exact`, `dp5`, `dop853`).
    pub fn method_name(&self) -> String {
        match &self.propagator {
            Propagator::Exact(_) => "exact".into(),
            Propagator::Rk(p) => p.options().method.to_string(),
        }
    }

    pub fn t(&self) -> f64 {
        match &self.propagator {
            Propagator::Rk(p) => p.t(),
            Propagator::Exact(p) => p.t(),
        }
    }

    /// `[x, x']`.
    pub fn state(&self) -> [f64; 2] {
        let y = match &self.propagator {
            Propagator::Rk(p) => p.y(),
            Propagator::Exact(p) => p.y(),
        };
        [y[0], y[1]]
    }

    pub fn stats(&self) -> SolverStats {
        match &self.propagator {
            Propagator::Rk(p) => *p.stats(),
            Propagator::Exact(p) => *p.stats(),
        }
    }

    pub fn model(&self) -> &GearPair {
        &self.pair
    }

    /// Mutable access to the model for settings that do not change its equations
    /// (e.g. [`GearPair::record_events`]).
    pub fn model_mut(&mut self) -> &mut GearPair {
        &mut self.pair
    }

    /// Integrates exactly to `t_end` with the inputs held constant.
    pub fn advance_to(&mut self, t_end: f64) -> Result<(), SolveError> {
        match &mut self.propagator {
            Propagator::Rk(p) => p.advance_to(&mut self.pair, t_end),
            Propagator::Exact(p) => p.advance_to(&mut self.pair, t_end),
        }
    }

    /// New inputs from the current time on (phase continuous; cached matrices and FSAL
    /// dropped because the right-hand side changed).
    pub fn set_inputs(&mut self, inputs: Inputs) {
        if inputs == self.pair.inputs() {
            return;
        }
        let t = self.t();
        self.pair.set_inputs(t, inputs);
        match &mut self.propagator {
            Propagator::Rk(p) => p.invalidate(),
            Propagator::Exact(p) => p.invalidate(),
        }
    }

    /// Restarts from `(t, [x, x'])` with the mode re-derived from the state (FMU state restore
    /// and initial-value changes).
    pub fn set_state(&mut self, t: f64, y: [f64; 2]) {
        self.pair.resynchronise(t, &y);
        match &mut self.propagator {
            Propagator::Rk(p) => p.set_state(t, &y),
            Propagator::Exact(p) => {
                p.invalidate();
                p.set_state(t, &y)
            }
        }
    }

    /// The outputs at the current time, in [`OUTPUT_NAMES`] order.
    pub fn outputs(&self) -> [f64; 7] {
        let mut out = [0.0; OUTPUT_NAMES.len()];
        self.pair.outputs(self.t(), &self.state(), &mut out);
        out
    }
}

/// Everything that determines how a [`Simulation`] continues, given the scene it was built
/// from: time, state, the model's run-time state and the RK controller memory (`None` for the
/// exact propagator, whose steps depend on `(t, y)` and the mode only). Restoring it continues
/// bit-identically (FMU state get/set, FMI 2.0.x §2.1.8).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimState {
    pub t: f64,
    pub y: [f64; 2],
    pub pair: PairState,
    pub controller: Option<ControllerMemory>,
}

impl Simulation {
    /// Snapshot of the run (see [`SimState`]).
    pub fn snapshot(&self) -> SimState {
        SimState {
            t: self.t(),
            y: self.state(),
            pair: self.pair.pair_state(),
            controller: match &self.propagator {
                Propagator::Rk(p) => Some(p.controller_memory()),
                Propagator::Exact(_) => None,
            },
        }
    }

    /// Restores a snapshot taken from a simulation of the same scene. Rejects one taken with
    /// the other propagator or with a mode this scene cannot have.
    pub fn restore(&mut self, s: &SimState) -> Result<(), String> {
        if !(s.t.is_finite() && s.y.iter().all(|v| v.is_finite())) {
            return Err(format!("state (t = {}, y = {:?}) is not finite", s.t, s.y));
        }
        match (&mut self.propagator, &s.controller) {
            (Propagator::Rk(p), Some(memory)) => {
                self.pair.restore_pair_state(&s.pair)?;
                p.invalidate();
                p.restore(s.t, &s.y, memory);
            }
            (Propagator::Exact(p), None) => {
                self.pair.restore_pair_state(&s.pair)?;
                p.invalidate();
                p.set_state(s.t, &s.y);
            }
            _ => {
                return Err(format!(
                    "the snapshot was taken with another propagator than '{}'",
                    self.method_name()
                ))
            }
        }
        Ok(())
    }
}

/// A sampled run on an output grid.
pub struct Trajectory {
    pub times: Vec<f64>,
    pub rows: Vec<[f64; 7]>,
    pub stats: SolverStats,
    pub method: String,
}

impl Trajectory {
    /// RMS of the DTE with its mean removed, m.
    pub fn dte_rms(&self) -> f64 {
        let n = self.rows.len() as f64;
        let mean = self.rows.iter().map(|r| r[0]).sum::<f64>() / n;
        (self.rows.iter().map(|r| (r[0] - mean).powi(2)).sum::<f64>() / n).sqrt()
    }

    /// Largest |mesh force|, N.
    pub fn peak_mesh_force(&self) -> f64 {
        self.rows.iter().map(|r| r[2].abs()).fold(0.0, f64::max)
    }

    /// Fraction of output samples not in drive-side contact.
    pub fn contact_loss_fraction(&self) -> f64 {
        let lost = self.rows.iter().filter(|r| r[3] != 1.0).count();
        lost as f64 / self.rows.len() as f64
    }
}

/// The output grid `t_k = k·h` up to `stop_time` (the last point is `stop_time` itself when
/// it is not a multiple of `h`). Each point is computed from its index, not accumulated, so
/// long runs carry no rounding drift.
pub fn output_grid(stop_time: f64, interval: f64) -> Vec<f64> {
    let n = (stop_time / interval + 1e-9).floor() as u64;
    let mut times: Vec<f64> = (0..=n).map(|k| k as f64 * interval).collect();
    let last = times.last_mut().expect("grid has t = 0");
    if (stop_time - *last).abs() <= 1e-9 * interval {
        *last = stop_time;
    } else if *last < stop_time {
        times.push(stop_time);
    }
    times
}

/// Runs a scene from t = 0 to `stop_time`, sampling every `interval`.
pub fn run(scene: &Scene, stop_time: f64, interval: f64) -> Result<Trajectory, String> {
    let mut sim = Simulation::new(scene)?;
    let times = output_grid(stop_time, interval);
    let mut rows = Vec::with_capacity(times.len());
    for &t in &times {
        sim.advance_to(t)
            .map_err(|e| format!("integration failed: {e}"))?;
        rows.push(sim.outputs());
    }
    Ok(Trajectory {
        times,
        rows,
        stats: sim.stats(),
        method: sim.method_name(),
    })
}
