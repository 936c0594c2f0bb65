//! `geardyn simulate`: a scene to CSV with a summary.

use std::path::PathBuf;

use clap::Args;

use geardyn::commands::simulate::{self, SimulateFiles, SimulateOptions};

use super::SceneArg;
use geardyn::simulation::stream::{DEFAULT_MAX_MESH_PERIODS, DEFAULT_MAX_ROWS};
use geardyn::simulation::{ProgressDisplay, RunLimits};

#[derive(Args)]
pub struct SimulateArgs {
    #[command(flatten)]
    pub scene: SceneArg,
    /// Output CSV file.
    #[arg(long)]
    out: PathBuf,
    /// End time, s (default: the scene's `solver.stop_time`).
    #[arg(long, allow_negative_numbers = true)]
    stop_time: Option<f64>,
    /// Output interval, s (default: the scene's `solver.output_interval`).
    #[arg(long, allow_negative_numbers = true)]
    output_interval: Option<f64>,
    /// Propagator: auto | rk | exact.
    #[arg(long)]
    method: Option<String>,
    /// RK method: dp5 | dop853 | rodas4 (the stiff, L-stable Rosenbrock method).
    #[arg(long)]
    rk_method: Option<String>,
    /// Relative tolerance of the RK path.
    #[arg(long, allow_negative_numbers = true)]
    rtol: Option<f64>,
    /// Absolute tolerance of the RK path (m and m/s).
    #[arg(long, allow_negative_numbers = true)]
    atol: Option<f64>,
    /// Most output rows a run may write (default 1e8; a guard against an output interval
    /// that would fill the disk).
    #[arg(long)]
    max_rows: Option<u64>,
    /// Most periods a run may span, of the fastest mesh and of the fastest mode each
    /// (default 1e9; a guard against inputs that would run for days).
    #[arg(long, allow_negative_numbers = true)]
    max_periods: Option<f64>,
    /// The run's work budget in work units (about one multiply-add each; overrides the
    /// scene's solver.work_budget, default 2e9, docs/fmu.md "Work budget"). A run beyond it
    /// stops with a message naming the likely cause (stiffness, speed, events, step count);
    /// raise it to run such a scene anyway.
    #[arg(long)]
    work_budget: Option<f64>,
    /// Show the progress on stderr also when it is not a terminal (a plain `progress: …` line
    /// every 2 s and at the end); on a terminal it shows anyway unless --quiet.
    #[arg(long)]
    progress: bool,
    /// Also plot every mesh's DTE and mesh force over time (PNG or SVG by the extension).
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Also write the spectrum of every mesh's DTE and force to this CSV (exact DFT when the
    /// run spans an integer number of response periods, flat-top windowed FFT otherwise).
    #[arg(long)]
    spectrum: Option<PathBuf>,
    /// Do not print the summary.
    #[arg(long)]
    quiet: bool,
    /// Write each column's unit into the CSV header, `dte [m]` (default: bare names).
    #[arg(long)]
    units: bool,
}

pub fn run(args: SimulateArgs) -> Result<(), String> {
    let scene = args.scene.load()?;
    let periods = match args.max_periods {
        Some(p) => super::positive("max-periods", p)?,
        None => DEFAULT_MAX_MESH_PERIODS,
    };
    let opts = SimulateOptions {
        stop_time: args.stop_time,
        output_interval: args.output_interval,
        method: args.method,
        rk_method: args.rk_method,
        rtol: args.rtol,
        atol: args.atol,
        limits: RunLimits {
            max_rows: args.max_rows.unwrap_or(DEFAULT_MAX_ROWS),
            max_mesh_periods: periods,
            max_mode_periods: periods,
            work_budget: args.work_budget,
        },
        progress: match (args.progress, args.quiet) {
            (true, _) => ProgressDisplay::Always,
            (false, false) => ProgressDisplay::Terminal,
            (false, true) => ProgressDisplay::Off,
        },
        header_units: args.units,
        no_summary: args.quiet,
    };
    let files = SimulateFiles {
        out: &args.out,
        plot: args.plot.as_deref(),
        spectrum: args.spectrum.as_deref(),
        quiet: args.quiet,
    };
    simulate::command(scene, &opts, &files)?;
    Ok(())
}
