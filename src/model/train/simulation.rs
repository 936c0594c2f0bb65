//! One simulation of a drivetrain scene: the [`GearTrain`] plus the propagator chosen for it
//! (the exact propagator when every segment is LTI, RK otherwise). Same interface as
//! `crate::simulation::Simulation` for the single pair, so the FMU adapter can drive either.

use super::system::{GearTrain, TrainInputs, TrainRunState};
use crate::scene::train::TrainScene;
use crate::scene::MethodChoice;
use crate::simulation::output_grid;
use crate::solve::exact::ExactPropagator;
use crate::solve::rk::{ControllerMemory, RkOptions, RkStepper};
use crate::solve::{SolveError, SolverStats};

enum Propagator {
    Rk(Box<RkStepper>),
    Exact(Box<ExactPropagator>),
}

/// A running drivetrain simulation.
pub struct TrainSimulation {
    train: GearTrain,
    propagator: Propagator,
}

impl TrainSimulation {
    /// Assembles the model, picks the propagator and starts at `t = 0` from the scene's
    /// initial state.
    pub fn new(scene: &TrainScene) -> Result<TrainSimulation, String> {
        let mut train = GearTrain::new(scene)?;
        let y0 = train.initial_state(scene)?;
        let s = &scene.solver;
        let exact = match s.method {
            MethodChoice::Exact => {
                if !train.is_piecewise_lti() {
                    return Err(
                        "solver.method = \"exact\": the train's segments are not all \
                                linear time-invariant (use rk or auto)"
                            .into(),
                    );
                }
                true
            }
            MethodChoice::Auto => train.is_piecewise_lti(),
            MethodChoice::Rk => false,
        };
        let propagator = if exact {
            let mut p = ExactPropagator::new(&train);
            p.set_state(0.0, &y0);
            Propagator::Exact(Box::new(p))
        } else {
            let options = RkOptions {
                rtol: s.rtol,
                atol: s.atol,
                ..RkOptions::new(s.rk_method)
            };
            let mut p = RkStepper::new(options, y0.len())?;
            p.set_state(0.0, &y0);
            Propagator::Rk(Box::new(p))
        };
        Ok(TrainSimulation { train, propagator })
    }

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

    /// `[ξ, ξ']`.
    pub fn state(&self) -> &[f64] {
        match &self.propagator {
            Propagator::Rk(p) => p.y(),
            Propagator::Exact(p) => p.y(),
        }
    }

    pub fn stats(&self) -> SolverStats {
        match &self.propagator {
            Propagator::Rk(p) => *p.stats(),
            Propagator::Exact(p) => *p.stats(),
        }
    }

    pub fn model(&self) -> &GearTrain {
        &self.train
    }

    pub fn model_mut(&mut self) -> &mut GearTrain {
        &mut self.train
    }

    /// Integrates to `t_end` with the inputs held constant.
    pub fn advance_to(&mut self, t_end: f64) -> Result<(), SolveError> {
        match &mut self.propagator {
            Propagator::Rk(p) => p.advance_to(&mut self.train, t_end),
            Propagator::Exact(p) => p.advance_to(&mut self.train, t_end),
        }
    }

    /// New inputs from the current time on.
    pub fn set_inputs(&mut self, inputs: TrainInputs) -> Result<(), String> {
        if inputs == self.train.inputs() {
            return Ok(());
        }
        let t = self.t();
        self.train.set_inputs(t, inputs)?;
        match &mut self.propagator {
            Propagator::Rk(p) => p.invalidate(),
            Propagator::Exact(p) => p.invalidate(),
        }
        Ok(())
    }

    /// Restarts from `(t, y)` with the mode re-derived from the state.
    pub fn set_state(&mut self, t: f64, y: &[f64]) {
        self.train.resynchronise(t, y);
        match &mut self.propagator {
            Propagator::Rk(p) => p.set_state(t, y),
            Propagator::Exact(p) => {
                p.invalidate();
                p.set_state(t, y)
            }
        }
    }

    pub fn output_names(&self) -> &[String] {
        self.train.output_names()
    }

    /// Outputs at the current time.
    pub fn outputs(&self, out: &mut Vec<f64>) {
        let y = self.state().to_vec();
        self.train.outputs(self.t(), &y, out);
    }
}

/// Everything that determines how a [`TrainSimulation`] continues, given the scene it was
/// built from: time, `[ξ, ξ']`, the train's run-time state and the RK controller memory (`None`
/// for the exact propagator, whose steps depend on `(t, y)` and the mode only). Restoring it
/// continues bit-identically (FMU state get/set, FMI 2.0.x §2.1.8); the drivetrain
/// counterpart of `crate::simulation::SimState`.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainSimState {
    pub t: f64,
    pub y: Vec<f64>,
    pub train: TrainRunState,
    pub controller: Option<ControllerMemory>,
}

impl TrainSimulation {
    /// Snapshot of the run (see [`TrainSimState`]).
    pub fn snapshot(&self) -> TrainSimState {
        TrainSimState {
            t: self.t(),
            y: self.state().to_vec(),
            train: self.train.run_state(),
            controller: match &self.propagator {
                Propagator::Rk(p) => Some(p.controller_memory()),
                Propagator::Exact(_) => None,
            },
        }
    }

    /// Restores a snapshot taken from a simulation of the same scene. Rejects one of another
    /// dimension, taken with the other propagator, or with a mode this train cannot have;
    /// on failure nothing changes.
    pub fn restore(&mut self, s: &TrainSimState) -> Result<(), String> {
        let dim = self.state().len();
        if s.y.len() != dim {
            return Err(format!(
                "the state has {} entries, this train {dim}",
                s.y.len()
            ));
        }
        if !(s.t.is_finite() && s.y.iter().all(|v| v.is_finite())) {
            return Err(format!("state (t = {}, y = {:?}) is not finite", s.t, s.y));
        }
        match (&mut self.propagator, &s.controller) {
            (Propagator::Rk(p), Some(memory)) => {
                self.train.restore_run_state(&s.train)?;
                p.invalidate();
                p.restore(s.t, &s.y, memory);
            }
            (Propagator::Exact(p), None) => {
                self.train.restore_run_state(&s.train)?;
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

/// A sampled run.
pub struct TrainTrajectory {
    pub names: Vec<String>,
    pub times: Vec<f64>,
    pub rows: Vec<Vec<f64>>,
    pub stats: SolverStats,
    pub method: String,
}

impl TrainTrajectory {
    /// Column index of an output.
    pub fn column(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }

    /// Fraction of samples with total contact loss on the mesh named `mesh`.
    pub fn contact_loss_fraction(&self, mesh: &str) -> f64 {
        let Some(c) = self.column(&format!("{mesh}_pairs_in_contact")) else {
            return 0.0;
        };
        let lost = self.rows.iter().filter(|r| r[c] == 0.0).count();
        lost as f64 / self.rows.len() as f64
    }

    /// RMS with the mean removed of a column.
    pub fn rms(&self, column: usize) -> f64 {
        let n = self.rows.len() as f64;
        let mean = self.rows.iter().map(|r| r[column]).sum::<f64>() / n;
        (self
            .rows
            .iter()
            .map(|r| (r[column] - mean).powi(2))
            .sum::<f64>()
            / n)
            .sqrt()
    }
}

/// Runs a drivetrain scene from 0 to `stop_time`, sampling every `interval`.
pub fn run_train(
    scene: &TrainScene,
    stop_time: f64,
    interval: f64,
) -> Result<TrainTrajectory, String> {
    let mut sim = TrainSimulation::new(scene)?;
    let times = output_grid(stop_time, interval);
    let mut rows = Vec::with_capacity(times.len());
    let mut out = Vec::new();
    for &t in &times {
        sim.advance_to(t)
            .map_err(|e| format!("integration failed: {e}"))?;
        sim.outputs(&mut out);
        rows.push(out.clone());
    }
    Ok(TrainTrajectory {
        names: sim.output_names().to_vec(),
        times,
        rows,
        stats: sim.stats(),
        method: sim.method_name(),
    })
}
