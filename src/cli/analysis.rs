//! `geardyn periodic` and `geardyn sweep`: steady states and frequency responses.

use std::path::PathBuf;

use clap::Args;

use geardyn::analysis::SWEEP_COLUMNS;
use geardyn::commands::analysis as commands;
use geardyn::output;

use super::{load_scene, positive};

#[derive(Args)]
pub struct PeriodicArgs {
    /// Scene file (`scene.toml`) or a folder holding one.
    #[arg(required_unless_present = "example", conflicts_with = "example")]
    scene: Option<PathBuf>,
    /// A built-in example scene instead of a file (e.g. `spur_pair`).
    #[arg(long)]
    example: Option<String>,
    /// Pinion speed, rad/s (default: the scene's `operating.pinion_speed`).
    #[arg(long, allow_negative_numbers = true)]
    speed: Option<f64>,
    /// Orbit period in mesh periods (period-k orbits).
    #[arg(long, default_value_t = 1)]
    periods: u32,
    /// Mesh periods integrated before Newton starts.
    #[arg(long, default_value_t = 20)]
    warmup: u32,
}

#[derive(Args)]
pub struct SweepArgs {
    /// Scene file (`scene.toml`) or a folder holding one.
    #[arg(required_unless_present = "example", conflicts_with = "example")]
    scene: Option<PathBuf>,
    /// A built-in example scene instead of a file (e.g. `spur_pair`).
    #[arg(long)]
    example: Option<String>,
    /// Pinion speeds `from:to:points`, rad/s.
    #[arg(long, allow_hyphen_values = true)]
    speed: String,
    /// up | down | both (both runs the two branches in parallel).
    #[arg(long, default_value = "both")]
    direction: String,
    /// Output CSV (one row per point and direction).
    #[arg(long)]
    out: PathBuf,
    /// Also draw the DTE RMS against mesh frequency as SVG.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Periodicity tolerance (scaled state residual).
    #[arg(long, default_value_t = 1e-7)]
    tolerance: f64,
    /// Give up on a point after this many mesh periods (it is kept, marked not converged).
    #[arg(long, default_value_t = 3000)]
    max_periods: u32,
}

pub fn periodic(args: PeriodicArgs) -> Result<(), String> {
    let mut scene = load_scene(&args.scene, &args.example)?;
    if let Some(speed) = args.speed {
        scene.operating.pinion_speed = positive("speed", speed)?;
    }
    let orbit = commands::periodic(&scene, args.periods, args.warmup)?;
    print!("{}", commands::periodic_report(&scene, &orbit));
    Ok(())
}

pub fn sweep(args: SweepArgs) -> Result<(), String> {
    let scene = load_scene(&args.scene, &args.example)?;
    let request = commands::SweepRequest {
        speed: &args.speed,
        direction: &args.direction,
        tolerance: args.tolerance,
        max_periods: args.max_periods,
    };
    let progress = |done: usize, total: usize| {
        eprint!("\rsweep {done}/{total} points");
        if done == total {
            eprintln!();
        }
    };
    let points = request.run(&scene, &progress)?;
    output::write_table(&args.out, &SWEEP_COLUMNS, points.iter().map(|p| p.row()))?;
    if let Some(path) = &args.plot {
        output::write_text(path, &commands::sweep_plot(&scene, &points))?;
    }
    print!("{}", commands::sweep_summary(&scene, &points, &args.out));
    Ok(())
}

#[derive(Args)]
pub struct HbArgs {
    /// Scene file (`scene.toml`) or a folder holding one.
    #[arg(required_unless_present = "example", conflicts_with = "example")]
    pub scene: Option<PathBuf>,
    /// A built-in example scene instead of a file (e.g. `spur_pair`).
    #[arg(long)]
    pub example: Option<String>,
    /// Pinion-speed interval `from:to`, rad/s: the branch starts at `from`.
    #[arg(long, allow_hyphen_values = true)]
    pub speed: String,
    /// Harmonics of the response frequency.
    #[arg(long, default_value_t = 20)]
    pub harmonics: usize,
    /// Response period in mesh periods (sub-harmonic branches).
    #[arg(long, default_value_t = 1)]
    pub subharmonic: u32,
    /// Output CSV (one row per branch point).
    #[arg(long)]
    pub out: PathBuf,
    /// FRF plot (SVG): stable solid, unstable dashed, and with `--sweep-points` the sweep
    /// points overlaid.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Also run an up and a down sweep with this many speeds for the plot.
    #[arg(long, default_value_t = 0)]
    pub sweep_points: usize,
}

/// `geardyn hb`: harmonic balance with pseudo-arclength continuation and stability.
pub fn hb(args: HbArgs) -> Result<(), String> {
    let scene = load_scene(&args.scene, &args.example)?;
    let request = commands::HbRequest {
        speed: &args.speed,
        harmonics: args.harmonics,
        subharmonic: args.subharmonic,
    };
    let branch = request.run(&scene)?;
    output::write_table(&args.out, &commands::HB_COLUMNS, branch.rows())?;
    if let Some(path) = &args.plot {
        let svg = branch.plot(&scene, args.harmonics, args.sweep_points)?;
        output::write_text(path, &svg)?;
    }
    print!("{}", branch.summary(&scene, &args.out));
    Ok(())
}
