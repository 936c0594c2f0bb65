//! One geardyn run of a work-precision problem: the library path `geardyn simulate` and the
//! FMUs take (`Simulation`/`TrainSimulation::advance_to` on the dense error grid, each grid
//! point a stop), with the contact changes recorded.

#![allow(dead_code)]

use geardyn::model::train::TrainSimulation;
use geardyn::scene::MethodChoice;
use geardyn::simulation::Simulation;
use geardyn::solve::rk::Method;
use geardyn::solve::SolverStats;

use crate::problems::{Kind, Problem};

/// A geardyn propagator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Propagator {
    Exact,
    Rk(Method),
}

impl Propagator {
    pub fn label(self) -> &'static str {
        match self {
            Propagator::Exact => "geardyn exact",
            Propagator::Rk(Method::Dp5) => "geardyn DP5",
            Propagator::Rk(Method::Dop853) => "geardyn DOP853",
            Propagator::Rk(Method::Rodas4) => "geardyn RODAS4",
        }
    }
}

/// What a run produced: the DTE of every mesh on the grid (`dte[mesh][k]`), the state at the
/// end, the contact-change times and the solver counters.
#[derive(Debug, Clone)]
pub struct RunOutput {
    pub dte: Vec<Vec<f64>>,
    pub final_state: Vec<f64>,
    pub event_times: Vec<f64>,
    pub stats: SolverStats,
}

/// The static deflection used to normalise every error of the problem, m: `F_ext/k̄` of the
/// pair, or of the first mesh of a drivetrain (`T_1/(r_b1 k̄_1)`).
pub fn x_scale(problem: &Problem) -> f64 {
    match problem.kind {
        Kind::Pair => Simulation::new(&problem.pair_scene())
            .expect("problem assembles")
            .model()
            .static_deflection(),
        Kind::Train => {
            let scene = problem.train_scene();
            let mesh = &scene.meshes[0];
            let r_b = scene.gears[mesh.pinion].base_radius;
            scene.operating.input_torque.abs() / (r_b * mesh.mean_stiffness())
        }
    }
}

/// Whether the exact propagator applies (every segment LTI).
pub fn exact_eligible(problem: &Problem) -> bool {
    run_setup(problem, Propagator::Exact, 1e-6, 1e-12).is_ok()
}

enum Sim {
    Pair(Box<Simulation>),
    Train(Box<TrainSimulation>),
}

fn run_setup(problem: &Problem, prop: Propagator, rtol: f64, atol: f64) -> Result<Sim, String> {
    let (method, rk_method) = match prop {
        Propagator::Exact => (MethodChoice::Exact, Method::Dop853),
        Propagator::Rk(m) => (MethodChoice::Rk, m),
    };
    match problem.kind {
        Kind::Pair => {
            let mut scene = problem.pair_scene();
            scene.solver.method = method;
            scene.solver.rk_method = rk_method;
            scene.solver.rtol = rtol;
            scene.solver.atol = atol;
            let mut sim = Simulation::new(&scene)?;
            sim.model_mut().record_events();
            Ok(Sim::Pair(Box::new(sim)))
        }
        Kind::Train => {
            let mut scene = problem.train_scene();
            scene.solver.method = method;
            scene.solver.rk_method = rk_method;
            scene.solver.rtol = rtol;
            scene.solver.atol = atol;
            let mut sim = TrainSimulation::new(&scene)?;
            sim.model_mut().record_events();
            Ok(Sim::Train(Box::new(sim)))
        }
    }
}

/// Runs `problem` with `prop` at `(rtol, atol)` over its dense grid.
pub fn run(problem: &Problem, prop: Propagator, rtol: f64, atol: f64) -> Result<RunOutput, String> {
    let times = problem.sample_times();
    match run_setup(problem, prop, rtol, atol)? {
        Sim::Pair(mut sim) => {
            let mut dte = Vec::with_capacity(times.len());
            for &t in &times {
                sim.advance_to(t).map_err(|e| e.to_string())?;
                dte.push(sim.state()[0]);
            }
            Ok(RunOutput {
                dte: vec![dte],
                final_state: sim.state().to_vec(),
                event_times: sim.model().events().iter().map(|e| e.0).collect(),
                stats: sim.stats(),
            })
        }
        Sim::Train(mut sim) => {
            let meshes = problem.train_scene().meshes.len();
            let m = sim.model().elastic_dim();
            let mut dte = vec![Vec::with_capacity(times.len()); meshes];
            for &t in &times {
                sim.advance_to(t).map_err(|e| e.to_string())?;
                let y = sim.state();
                for (n, series) in dte.iter_mut().enumerate() {
                    let row = sim.model().mesh_row(n);
                    series.push(row.iter().zip(&y[..m]).map(|(a, b)| a * b).sum());
                }
            }
            Ok(RunOutput {
                dte,
                final_state: sim.state().to_vec(),
                event_times: sim.model().events().iter().map(|e| e.0).collect(),
                stats: sim.stats(),
            })
        }
    }
}

/// Wall time of `run` without the bookkeeping of the error (events are still recorded: the
/// recording is a push per event).
pub fn timed_run(problem: &Problem, prop: Propagator, rtol: f64, atol: f64) -> f64 {
    let start = std::time::Instant::now();
    let out = run(problem, prop, rtol, atol);
    let elapsed = start.elapsed().as_secs_f64();
    std::hint::black_box(out).ok();
    elapsed
}
