//! `geardyn periodic`, `geardyn sweep` and `geardyn hb`: the arguments of the steady states
//! and frequency responses of any scene; the commands are in `geardyn::commands`.

use std::path::PathBuf;

use clap::Args;

use geardyn::commands::{hb as hb_commands, steady as commands};

use super::{ProgressArg, SceneArg, WorkBudgetArg};

#[derive(Args)]
pub struct PeriodicArgs {
    #[command(flatten)]
    pub scene: SceneArg,
    /// Input-gear speed: `4500rpm` or `471.24rad/s`; a bare number is rad/s (default: the
    /// scene's `operating.pinion_speed` or `operating.input_speed`).
    #[arg(long, allow_hyphen_values = true)]
    speed: Option<String>,
    /// Orbit period in response periods (period-k orbits); the response period is the mesh
    /// period, or the least common multiple of the mesh periods of a drivetrain.
    #[arg(long, default_value_t = 1)]
    periods: u32,
    /// Response periods integrated before Newton starts.
    #[arg(long, default_value_t = 20)]
    warmup: u32,
    #[command(flatten)]
    budget: WorkBudgetArg,
    #[command(flatten)]
    progress: ProgressArg,
}

#[derive(Args)]
pub struct SweepArgs {
    #[command(flatten)]
    pub scene: SceneArg,
    /// Input-gear speeds `from:to:points`, e.g. `1000rpm:10000rpm:181` or `300rad/s:700rad/s:41`;
    /// bare numbers are rad/s (every other gear follows its ratio).
    #[arg(long, allow_hyphen_values = true)]
    speed: String,
    /// up | down | both (both runs the two branches in parallel).
    #[arg(long, default_value = "both")]
    direction: String,
    /// Output CSV (one row per point and direction).
    #[arg(long)]
    out: PathBuf,
    /// Also plot each mesh's DTE RMS against the input speed, jumps marked (PNG or SVG by the
    /// extension).
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Periodicity tolerance (scaled state residual).
    #[arg(long, default_value_t = 1e-7)]
    tolerance: f64,
    /// Give up on a point after this many response periods (it is kept, marked not
    /// converged).
    #[arg(long, default_value_t = 3000)]
    max_periods: u32,
    /// Also write Poincaré samples (each mesh's DTE once per mesh period of the first mesh,
    /// over the recorded stretch) to this CSV.
    #[arg(long)]
    poincare: Option<PathBuf>,
    /// Also write each point's recording state to this CSV: direction, speed, the response
    /// periods recorded, the first mesh's phase (cycles) and the state y0, y1, … where the
    /// statistics start (a run set to it there records the point's response again).
    #[arg(long)]
    states: Option<PathBuf>,
    /// Write each column's unit into the CSV header, `dte [m]` (default: bare names).
    #[arg(long)]
    units: bool,
    #[command(flatten)]
    budget: WorkBudgetArg,
    #[command(flatten)]
    progress: ProgressArg,
}

pub fn periodic(args: PeriodicArgs) -> Result<(), String> {
    let mut scene = args.scene.load()?;
    args.budget.apply(&mut scene)?;
    let report = commands::periodic_command(
        &mut scene,
        args.speed.as_deref(),
        args.periods,
        args.warmup,
        args.progress.display(),
    )?;
    print!("{report}");
    Ok(())
}

pub fn sweep(args: SweepArgs) -> Result<(), String> {
    let mut scene = args.scene.load()?;
    args.budget.apply(&mut scene)?;
    let request = commands::SweepRequest {
        speed: &args.speed,
        direction: &args.direction,
        tolerance: args.tolerance,
        max_periods: args.max_periods,
        poincare: args.poincare.is_some(),
    };
    let files = commands::SweepFiles {
        out: &args.out,
        poincare: args.poincare.as_deref(),
        states: args.states.as_deref(),
        plot: args.plot.as_deref(),
        units: args.units,
    };
    print!(
        "{}",
        commands::sweep_command(&scene, &request, &files, args.progress.display())?
    );
    Ok(())
}

#[derive(Args)]
pub struct HbArgs {
    #[command(flatten)]
    pub scene: SceneArg,
    /// Input-speed interval `from:to`, e.g. `3000rpm:6000rpm`; bare numbers are rad/s. The
    /// branch starts at `from`.
    #[arg(long, allow_hyphen_values = true)]
    pub speed: String,
    /// Harmonics: the order H of the retained combination tones of the mesh frequencies (for
    /// one mesh frequency, harmonics 1…H of the mesh frequency over the subharmonic order).
    #[arg(long, default_value_t = 20)]
    pub harmonics: usize,
    /// Orbit period in response periods (sub-harmonic branches); the response period is the
    /// mesh period, or the least common multiple of the mesh periods of a drivetrain.
    #[arg(long, default_value_t = 1)]
    pub subharmonic: u32,
    /// Output CSV (one row per branch point, per-mesh columns prefixed with the mesh name).
    #[arg(long)]
    pub out: PathBuf,
    /// FRF plot (PNG or SVG by the extension): stable solid, unstable dashed, folds marked, and
    /// with `--sweep-points` the sweep points overlaid.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// The mesh the plot shows (its name; default: the first mesh).
    #[arg(long)]
    pub plot_mesh: Option<String>,
    /// Also run an up and a down sweep with this many speeds for the plot.
    #[arg(long, default_value_t = 0)]
    pub sweep_points: usize,
    /// Write each column's unit into the CSV header, `dte_rms [m]` (default: bare names).
    #[arg(long)]
    pub units: bool,
    #[command(flatten)]
    pub budget: WorkBudgetArg,
    #[command(flatten)]
    pub progress: ProgressArg,
}

/// `geardyn hb`: harmonic balance with pseudo-arclength continuation and stability.
pub fn hb(args: HbArgs) -> Result<(), String> {
    let mut scene = args.scene.load()?;
    args.budget.apply(&mut scene)?;
    let request = hb_commands::HbRequest {
        speed: &args.speed,
        harmonics: args.harmonics,
        subharmonic: args.subharmonic,
    };
    let files = hb_commands::HbFiles {
        out: &args.out,
        plot: args.plot.as_deref(),
        plot_mesh: args.plot_mesh.as_deref(),
        sweep_points: args.sweep_points,
        units: args.units,
    };
    print!(
        "{}",
        hb_commands::hb_command(&scene, &request, &files, args.progress.display())?
    );
    Ok(())
}
