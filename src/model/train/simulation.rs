//! One simulation of a drivetrain scene: the [`GearTrain`] plus the propagator chosen for it
//! (the exact propagator when every segment is LTI, RK otherwise). The propagator logic is the
//! generic [`Driver`] shared with the single pair; this file adds what only a drivetrain has
//! (fallible inputs, named outputs of varying count, a state of any dimension).

use super::system::{GearTrain, TrainInputs, TrainRunState};
use crate::scene::Scene;
use crate::simulation::{
    stream, ColumnStats, DrivenModel, Driver, FnSink, OutputGrid, Progress, RunLimits, RunScales,
    RunSummary,
};
use crate::solve::rk::ControllerMemory;
use crate::solve::SolverStats;

/// A running drivetrain simulation.
pub type TrainSimulation = Driver<GearTrain>;

impl DrivenModel for GearTrain {
    type RunState = TrainRunState;
    fn not_lti_reason(&self) -> Option<String> {
        GearTrain::not_lti_reason(self)
    }
    fn resynchronise(&mut self, t: f64, y: &[f64]) {
        GearTrain::resynchronise(self, t, y)
    }
    fn run_state(&self) -> TrainRunState {
        GearTrain::run_state(self)
    }
    fn restore_run_state(&mut self, s: &TrainRunState) -> Result<(), String> {
        GearTrain::restore_run_state(self, s)
    }
    fn run_scales(&self) -> RunScales {
        GearTrain::run_scales(self)
    }
    fn check_advance(&self, t: f64, t_end: f64) -> Result<(), String> {
        GearTrain::check_advance(self, t, t_end)
    }
    fn profiles(&self) -> Option<&crate::scene::Profiles> {
        GearTrain::profiles(self)
    }
    fn apply_profiles(&mut self, t: f64) -> Result<(), String> {
        GearTrain::apply_profiles(self, t)
    }
    fn runup_not_lti(&self) -> Option<String> {
        GearTrain::runup_not_lti(self)
    }
    fn predicted_switch(&self, t: f64, y: &[f64]) -> f64 {
        GearTrain::predicted_knot_time(self, t, y)
    }
}

impl Driver<GearTrain> {
    /// Assembles the model, picks the propagator and starts at `t = 0` from the scene's
    /// initial state.
    pub fn new(scene: &Scene) -> Result<TrainSimulation, String> {
        let mut train = GearTrain::new(scene)?;
        let y0 = train.initial_state(scene)?;
        Driver::with_model(train, &y0, &scene.solver)
    }

    /// `[ξ, ξ']`.
    pub fn state(&self) -> &[f64] {
        self.y()
    }

    /// New inputs from the current time on.
    pub fn set_inputs(&mut self, inputs: TrainInputs) -> Result<(), String> {
        if inputs == self.model().inputs() {
            return Ok(());
        }
        self.change_model(|train, t| train.set_inputs(t, inputs))
    }

    /// Restarts from `(t, y)` with the mode re-derived from the state.
    pub fn set_state(&mut self, t: f64, y: &[f64]) {
        self.set_y(t, y)
    }

    pub fn output_names(&self) -> &[String] {
        self.model().output_names()
    }

    /// Outputs at the current time.
    pub fn outputs(&self, out: &mut Vec<f64>) {
        self.model().outputs(self.t(), self.y(), out);
    }

    /// Snapshot of the run (see [`TrainSimState`]).
    pub fn snapshot(&self) -> TrainSimState {
        // The run continues from here as the restored state would (exact: without its history).
        self.forget_before_next_advance();
        TrainSimState {
            t: self.t(),
            y: self.state().to_vec(),
            train: self.model().run_state(),
            controller: self.controller_memory(),
        }
    }

    /// Restores a snapshot taken from a simulation of the same scene (see [`Driver::resume`]).
    pub fn restore(&mut self, s: &TrainSimState) -> Result<(), String> {
        self.resume(s.t, &s.y, &s.train, s.controller.as_ref())
    }
}

/// Everything that determines how a [`TrainSimulation`] continues, given the scene it was
/// built from: time, `[ξ, ξ']`, the train's run-time state and the RK controller memory (`None`
/// for the exact propagator, whose steps depend on `(t, y)` and the mode only, once its
/// learned references are dropped: `Driver::forget_recurrences`). Restoring it
/// continues bit-identically (FMU state get/set, FMI 2.0.x §2.1.8); the drivetrain
/// counterpart of `crate::simulation::SimState`.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainSimState {
    pub t: f64,
    pub y: Vec<f64>,
    pub train: TrainRunState,
    pub controller: Option<ControllerMemory>,
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
        let Some(c) = self.column(&format!("{mesh}.pairs_in_contact")) else {
            return 0.0;
        };
        let lost = self.rows.iter().filter(|r| r[c] == 0.0).count();
        lost as f64 / self.rows.len() as f64
    }

    /// RMS with the mean removed of a column.
    pub fn rms(&self, column: usize) -> f64 {
        let mut s = ColumnStats::default();
        for r in &self.rows {
            s.push(r[column]);
        }
        s.rms_about_mean()
    }
}

/// The outputs of a train as a row (see [`TrainSimulation::outputs`]).
pub fn train_row(sim: &TrainSimulation, row: &mut Vec<f64>) {
    sim.outputs(row);
}

/// Runs a drivetrain scene from 0 to `stop_time`, sampling every `interval`, into memory. The
/// run is checked against the default [`RunLimits`] first.
pub fn run_train(scene: &Scene, stop_time: f64, interval: f64) -> Result<TrainTrajectory, String> {
    run_train_limited(scene, stop_time, interval, &RunLimits::default())
}

/// [`run_train`] with explicit limits (Python's `simulate(max_rows=…, …)`); the rows held in
/// memory are checked first ([`crate::simulation::check_in_memory`]).
pub fn run_train_limited(
    scene: &Scene,
    stop_time: f64,
    interval: f64,
    limits: &RunLimits,
) -> Result<TrainTrajectory, String> {
    let mut sim = TrainSimulation::new(scene)?;
    limits.check(&sim.model().run_scales(), stop_time, interval)?;
    crate::simulation::check_in_memory(stop_time, interval, sim.output_names().len())?;
    let mut times = Vec::new();
    let mut rows = Vec::new();
    let mut sink = FnSink(|t: f64, row: &[f64]| {
        times.push(t);
        rows.push(row.to_vec());
        Ok(())
    });
    stream(
        &mut sim,
        OutputGrid::new(stop_time, interval),
        train_row,
        &mut sink,
        &mut RunSummary::default(),
        &mut Progress::new(stop_time, false),
        limits.work_budget,
    )?;
    Ok(TrainTrajectory {
        names: sim.output_names().to_vec(),
        times,
        rows,
        stats: sim.stats(),
        method: sim.method_name(),
    })
}
