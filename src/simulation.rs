//! One simulation of a scene: the assembled model plus the propagator chosen for it.
//!
//! Used by `geardyn simulate` and by the FMU adapter alike, so both integrate the same way.
//! The propagator logic is the generic [`Driver`] (shared with the drivetrain); this file adds
//! what is particular to one pair (its `[x, x']` state and fixed output row).

mod driver;

pub use driver::{DrivenModel, Driver, Propagator};

use crate::model::{GearPair, Inputs, PairState, OUTPUT_NAMES};
use crate::scene::Scene;
use crate::solve::rk::ControllerMemory;
use crate::solve::SolverStats;

/// A running simulation of one gear pair.
pub type Simulation = Driver<GearPair>;

impl DrivenModel for GearPair {
    type RunState = PairState;
    fn is_piecewise_lti(&self) -> bool {
        GearPair::is_piecewise_lti(self)
    }
    fn resynchronise(&mut self, t: f64, y: &[f64]) {
        GearPair::resynchronise(self, t, y)
    }
    fn run_state(&self) -> PairState {
        self.pair_state()
    }
    fn restore_run_state(&mut self, s: &PairState) -> Result<(), String> {
        self.restore_pair_state(s)
    }
    fn check_advance(&self, t: f64, t_end: f64) -> Result<(), String> {
        GearPair::check_advance(self, t, t_end)
    }
}

impl Driver<GearPair> {
    /// Assembles the model and picks the propagator (`auto`: exact when the scene is piecewise
    /// LTI). Starts at `t = 0` from the scene's initial state.
    pub fn new(scene: &Scene) -> Result<Simulation, String> {
        let mut pair = GearPair::new(scene);
        pair.check_scales()?;
        let y0 = pair.initial_state(scene);
        Driver::with_model(
            pair,
            &y0,
            &scene.solver,
            "method = exact: the stiffness is not piecewise constant (use rk or auto)",
        )
    }

    /// `[x, x']`.
    pub fn state(&self) -> [f64; 2] {
        let y = self.y();
        [y[0], y[1]]
    }

    /// New inputs from the current time on (phase continuous).
    pub fn set_inputs(&mut self, inputs: Inputs) {
        if inputs == self.model().inputs() {
            return;
        }
        let _ = self.change_model(|pair, t| {
            pair.set_inputs(t, inputs);
            Ok::<(), std::convert::Infallible>(())
        });
    }

    /// Restarts from `(t, [x, x'])` with the mode re-derived from the state.
    pub fn set_state(&mut self, t: f64, y: [f64; 2]) {
        self.set_y(t, &y)
    }

    /// The outputs at the current time, in [`OUTPUT_NAMES`] order.
    pub fn outputs(&self) -> [f64; 7] {
        let mut out = [0.0; OUTPUT_NAMES.len()];
        self.model().outputs(self.t(), &self.state(), &mut out);
        out
    }

    /// Snapshot of the run (see [`SimState`]).
    pub fn snapshot(&self) -> SimState {
        SimState {
            t: self.t(),
            y: self.state(),
            pair: self.model().pair_state(),
            controller: self.controller_memory(),
        }
    }

    /// Restores a snapshot taken from a simulation of the same scene (see [`Driver::resume`]).
    pub fn restore(&mut self, s: &SimState) -> Result<(), String> {
        self.resume(s.t, &s.y, &s.pair, s.controller.as_ref())
    }
}

/// Everything that determines how a [`Simulation`] continues, given the scene it was built
/// from: time, state, the model's run-time state and the RK controller memory (`None` for the
/// exact propagator, whose steps depend on `(t, y)` and the mode only, once its learned
/// references are dropped: [`Driver::forget_recurrences`]). Restoring it continues
/// bit-identically (FMU state get/set, FMI 2.0.x §2.1.8).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimState {
    pub t: f64,
    pub y: [f64; 2],
    pub pair: PairState,
    pub controller: Option<ControllerMemory>,
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
    let rows = sim.sample(&times, Simulation::outputs)?;
    Ok(Trajectory {
        times,
        rows,
        stats: sim.stats(),
        method: sim.method_name(),
    })
}
