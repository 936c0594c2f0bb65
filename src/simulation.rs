//! One simulation of a scene: the assembled model plus the propagator chosen for it.
//!
//! Used by `geardyn simulate` and by the FMU adapter alike, so both integrate the same way.
//! The propagator logic is the generic [`Driver`] (shared with the drivetrain); this file adds
//! what is particular to one pair (its `[x, x']` state and fixed output row).

pub mod budget;
mod driver;
mod scales;
pub mod stream;

pub use driver::{DrivenModel, Driver, Propagator, SWITCH_AT_NOW};
pub use scales::RunScales;
pub use stream::{
    stream, stream_with, ColumnStats, OutputGrid, Progress, ProgressDisplay, RowSink, RunLimits,
    RunSummary,
};

use crate::model::{GearPair, Inputs, PairState, OUTPUT_NAMES};
use crate::scene::PairScene;
use crate::solve::rk::ControllerMemory;
use crate::solve::SolverStats;

/// A running simulation of one gear pair.
pub type Simulation = Driver<GearPair>;

impl DrivenModel for GearPair {
    type RunState = PairState;
    fn not_lti_reason(&self) -> Option<String> {
        GearPair::not_lti_reason(self)
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
    fn run_scales(&self) -> RunScales {
        match self.profiles().and_then(|p| p.speed.as_ref()) {
            None => RunScales {
                mesh_frequency: (1.0 / self.mesh_period()).abs(),
                mesh_frequency_slope: 0.0,
                start_phase: self.mesh_phase(0.0).abs(),
                speed: ("operating.pinion_speed", self.inputs().pinion_speed),
                fastest_rate: self.fastest_rate(),
            },
            Some(p) => RunScales {
                mesh_frequency: self.peak_mesh_frequency(),
                mesh_frequency_slope: 0.0,
                start_phase: self.mesh_phase(0.0).abs(),
                speed: ("operating.speed_profile (its largest value)", p.max_value()),
                fastest_rate: self.fastest_rate(),
            },
        }
    }
    fn check_advance(&self, t: f64, t_end: f64) -> Result<(), String> {
        GearPair::check_advance(self, t, t_end)
    }
    fn profiles(&self) -> Option<&crate::scene::Profiles> {
        GearPair::profiles(self)
    }
    fn apply_profiles(&mut self, t: f64) -> Result<(), String> {
        GearPair::apply_profiles(self, t);
        Ok(())
    }
    fn runup_not_lti(&self) -> Option<String> {
        GearPair::runup_not_lti(self)
    }
}

impl Driver<GearPair> {
    /// Assembles the model and picks the propagator (`auto`: exact when the scene is piecewise
    /// LTI). Starts at `t = 0` from the scene's initial state.
    pub fn new(scene: &PairScene) -> Result<Simulation, String> {
        let mut pair = GearPair::new(scene);
        pair.check_scales()?;
        let y0 = pair.initial_state(scene);
        Driver::with_model(pair, &y0, &scene.solver)
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
        // The run continues from here as the restored state would (exact: without its history).
        self.forget_before_next_advance();
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

/// A sampled run on an output grid, held in memory (for callers that want arrays, such as the
/// Python package; `geardyn simulate` streams instead, [`stream`]).
pub struct Trajectory {
    pub times: Vec<f64>,
    pub rows: Vec<[f64; 7]>,
    pub stats: SolverStats,
    pub method: String,
}

impl Trajectory {
    fn column(&self, c: usize) -> ColumnStats {
        let mut s = ColumnStats::default();
        for r in &self.rows {
            s.push(r[c]);
        }
        s
    }

    /// RMS of the DTE with its mean removed, m.
    pub fn dte_rms(&self) -> f64 {
        self.column(0).rms_about_mean()
    }

    /// Largest |mesh force|, N.
    pub fn peak_mesh_force(&self) -> f64 {
        self.column(2).max_abs()
    }

    /// Fraction of output samples not in drive-side contact.
    pub fn contact_loss_fraction(&self) -> f64 {
        let lost = self.rows.iter().filter(|r| r[3] != 1.0).count();
        lost as f64 / self.rows.len() as f64
    }
}

/// The output grid as a vector (see [`OutputGrid`], which produces the same points one at a
/// time); for callers that step a [`Simulation`] themselves.
pub fn output_grid(stop_time: f64, interval: f64) -> Vec<f64> {
    OutputGrid::new(stop_time, interval).collect()
}

/// A [`RowSink`] that hands every row to a closure.
pub struct FnSink<F>(pub F);

impl<F: FnMut(f64, &[f64]) -> Result<(), String>> RowSink for FnSink<F> {
    fn row(&mut self, t: f64, values: &[f64]) -> Result<(), String> {
        (self.0)(t, values)
    }
}

/// The outputs of a pair as a row (see [`Simulation::outputs`]); inlined into the FMU's
/// output path, which runs after every step.
#[inline]
pub fn pair_row(sim: &Simulation, row: &mut Vec<f64>) {
    row.clear();
    row.extend_from_slice(&sim.outputs());
}

/// Runs a scene from t = 0 to `stop_time`, sampling every `interval`, into memory. The run is
/// checked against the default [`RunLimits`] first.
pub fn run(scene: &PairScene, stop_time: f64, interval: f64) -> Result<Trajectory, String> {
    run_limited(scene, stop_time, interval, &RunLimits::default())
}

/// Most values (rows times columns) a run held in memory may have: 2e8 doubles are 1.6 GB,
/// and a caller such as the Python module copies them once more. A longer run streams to a
/// file instead (`geardyn simulate`).
pub const MAX_IN_MEMORY_VALUES: f64 = 2e8;

/// Checks that `rows` of `columns` values fit in memory ([`MAX_IN_MEMORY_VALUES`]), before
/// anything is allocated.
pub fn check_in_memory(stop_time: f64, interval: f64, columns: usize) -> Result<(), String> {
    let rows = OutputGrid::rows_f64(stop_time, interval);
    let values = rows * (columns + 1) as f64;
    if !(values <= MAX_IN_MEMORY_VALUES) {
        return Err(format!(
            "output_interval = {interval:e} s with stop_time = {stop_time:e} s gives {rows:.4e} \
             rows of {} values, {values:.4e} in all, more than the {MAX_IN_MEMORY_VALUES:e} a \
             result held in memory may have; write it to a CSV file with `geardyn simulate`, \
             which streams",
            columns + 1
        ));
    }
    Ok(())
}

/// [`run`] with explicit limits (Python's `simulate(max_rows=…, max_periods=…, work_budget=…)`).
pub fn run_limited(
    scene: &PairScene,
    stop_time: f64,
    interval: f64,
    limits: &RunLimits,
) -> Result<Trajectory, String> {
    let mut sim = Simulation::new(scene)?;
    limits.check(&sim.model().run_scales(), stop_time, interval)?;
    check_in_memory(stop_time, interval, OUTPUT_NAMES.len())?;
    let grid = OutputGrid::new(stop_time, interval);
    let mut times = Vec::new();
    let mut rows = Vec::new();
    let mut sink = FnSink(|t: f64, row: &[f64]| {
        times.push(t);
        rows.push(<[f64; 7]>::try_from(row).expect("a pair row has 7 outputs"));
        Ok(())
    });
    stream(
        &mut sim,
        grid,
        pair_row,
        &mut sink,
        &mut RunSummary::default(),
        &mut Progress::new(stop_time, false),
        limits.work_budget,
    )?;
    Ok(Trajectory {
        times,
        rows,
        stats: sim.stats(),
        method: sim.method_name(),
    })
}
