//! `geardyn periodic` and `geardyn sweep`: steady states and frequency responses.

use std::path::PathBuf;

use clap::Args;

use geardyn::analysis::{self, shoot, Direction, ShootingOptions, SweepOptions, SWEEP_COLUMNS};
use geardyn::output;
use geardyn::plot::{Plot, Series};

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
    let options = ShootingOptions {
        periods: args.periods,
        warmup_periods: args.warmup,
        ..ShootingOptions::default()
    };
    let orbit = shoot(&scene, &options)?;
    println!(
        "scene {}: period-{} orbit at pinion speed {} rad/s (T = {:.6e} s)",
        scene.name, orbit.periods, scene.operating.pinion_speed, orbit.period
    );
    for (k, r) in orbit.residuals.iter().enumerate() {
        println!("  Newton {k}: scaled residual {r:.3e}");
    }
    println!(
        "  y0 = [x = {:e} m, x' = {:e} m/s]",
        orbit.y0[0], orbit.y0[1]
    );
    for m in &orbit.multipliers {
        println!(
            "  multiplier {:+.12} {:+.12}i  |μ| = {:.12}",
            m.re,
            m.im,
            m.norm()
        );
    }
    println!("  stability: {:?}", orbit.stability());
    Ok(())
}

pub fn sweep(args: SweepArgs) -> Result<(), String> {
    let scene = load_scene(&args.scene, &args.example)?;
    let speeds = SweepOptions::parse_range(&args.speed)?;
    let direction = args
        .direction
        .parse()
        .map_err(|e| format!("--direction: {e}"))?;
    let options = SweepOptions {
        tolerance: positive("tolerance", args.tolerance)?,
        max_transient_periods: args.max_periods,
        ..SweepOptions::new(speeds, direction)
    };
    let progress = |done: usize, total: usize| {
        eprint!("\rsweep {done}/{total} points");
        if done == total {
            eprintln!();
        }
    };
    let points = analysis::sweep(&scene, &options, &progress)?;
    output::write_table(&args.out, &SWEEP_COLUMNS, points.iter().map(|p| p.row()))?;
    if let Some(path) = &args.plot {
        let branch = |d: Direction| -> Vec<(f64, f64)> {
            points
                .iter()
                .filter(|p| p.direction == d)
                .map(|p| (p.mesh_frequency, p.dte_rms))
                .collect()
        };
        let series = [
            (Direction::Up, "up sweep", "#c0392b", false),
            (Direction::Down, "down sweep", "#2471a3", true),
        ]
        .into_iter()
        .map(|(d, label, color, dashed)| Series {
            label,
            color,
            points: branch(d),
            dashed,
            markers: true,
        })
        .filter(|s| !s.points.is_empty())
        .collect();
        let title = format!("{}: DTE RMS (mean removed)", scene.name);
        let plot = Plot {
            title: &title,
            x_label: "mesh frequency (Hz)",
            y_label: "DTE RMS (m)",
            series,
            bands: Vec::new(),
            band_label: "",
        };
        output::write_text(path, &plot.to_svg())?;
    }
    let unconverged = points.iter().filter(|p| !p.converged).count();
    println!(
        "scene {}: {} points → {}{}",
        scene.name,
        points.len(),
        args.out.display(),
        if unconverged > 0 {
            format!(" ({unconverged} not converged, marked converged = 0)")
        } else {
            String::new()
        }
    );
    Ok(())
}
