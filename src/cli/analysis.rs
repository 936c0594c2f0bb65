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
            line: true,
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

/// Columns of the `geardyn hb` CSV.
const HB_COLUMNS: [&str; 9] = [
    "speed",
    "mesh_frequency",
    "dte_mean",
    "dte_rms",
    "a1",
    "a2",
    "spectral_radius",
    "stable",
    "fold",
];

/// `geardyn hb`: harmonic balance with pseudo-arclength continuation and stability.
pub fn hb(args: HbArgs) -> Result<(), String> {
    use geardyn::analysis::hb::{continuation, ContinuationOptions, HbOptions};
    let scene = load_scene(&args.scene, &args.example)?;
    let (from, to) = args
        .speed
        .split_once(':')
        .ok_or_else(|| format!("--speed '{}': expected from:to", args.speed))?;
    let parse = |name: &str, v: &str| {
        v.trim()
            .parse::<f64>()
            .map_err(|e| format!("--speed {name} '{v}': {e}"))
    };
    let (from, to) = (
        positive("speed from", parse("from", from)?)?,
        positive("speed to", parse("to", to)?)?,
    );
    let hb_options = HbOptions {
        subharmonic: args.subharmonic,
        ..HbOptions::new(args.harmonics)
    };
    let branch = continuation(&scene, &hb_options, &ContinuationOptions::new(from, to))?;
    let rows = branch.iter().map(|p| {
        let rho = p.spectral_radius().unwrap_or(f64::NAN);
        [
            p.speed,
            p.solution.mesh_frequency,
            p.solution.coefficients[0],
            p.solution.dte_rms(),
            p.solution.mesh_harmonic(1),
            p.solution.mesh_harmonic(2),
            rho,
            p.stable().map_or(f64::NAN, |s| f64::from(u8::from(s))),
            f64::from(u8::from(p.fold)),
        ]
    });
    output::write_table(&args.out, &HB_COLUMNS, rows)?;
    if let Some(path) = &args.plot {
        let mut series: Vec<Series> = Vec::new();
        // Consecutive points of equal stability form one segment (shared end points).
        let mut start = 0;
        let stable = |i: usize| branch[i].stable().unwrap_or(true);
        let (mut stable_labelled, mut unstable_labelled) = (false, false);
        for i in 1..=branch.len() {
            if i == branch.len() || stable(i) != stable(start) {
                let is_stable = stable(start);
                let end = i.min(branch.len() - 1);
                let label = match (is_stable, stable_labelled, unstable_labelled) {
                    (true, false, _) => "HB stable",
                    (false, _, false) => "HB unstable",
                    _ => "",
                };
                if is_stable {
                    stable_labelled = true;
                } else {
                    unstable_labelled = true;
                }
                series.push(Series {
                    label,
                    color: "#1f4e9c",
                    points: branch[start..=end]
                        .iter()
                        .map(|p| (p.solution.mesh_frequency, p.solution.dte_rms()))
                        .collect(),
                    dashed: !is_stable,
                    markers: false,
                    line: true,
                });
                start = i;
            }
        }
        if args.sweep_points >= 2 {
            let (lo, hi) = (from.min(to), from.max(to));
            let speeds = (0..args.sweep_points)
                .map(|i| lo + (hi - lo) * i as f64 / (args.sweep_points - 1) as f64)
                .collect();
            let points = analysis::sweep(
                &scene,
                &SweepOptions::new(speeds, Direction::Both),
                &|_, _| {},
            )?;
            for (d, label, color) in [
                (Direction::Up, "sweep up", "#c0392b"),
                (Direction::Down, "sweep down", "#27ae60"),
            ] {
                series.push(Series {
                    label,
                    color,
                    points: points
                        .iter()
                        .filter(|p| p.direction == d)
                        .map(|p| (p.mesh_frequency, p.dte_rms))
                        .collect(),
                    dashed: false,
                    markers: true,
                    line: false,
                });
            }
        }
        let title = format!(
            "{}: harmonic balance, H = {} (DTE RMS, mean removed)",
            scene.name, args.harmonics
        );
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
    let folds = branch.iter().filter(|p| p.fold).count();
    println!(
        "scene {}: {} branch points, {} folds → {}",
        scene.name,
        branch.len(),
        folds,
        args.out.display()
    );
    for p in branch.iter().filter(|p| p.fold) {
        println!(
            "  fold near {:.4} rad/s (mesh {:.2} Hz), DTE RMS {:.4e} m",
            p.speed,
            p.solution.mesh_frequency,
            p.solution.dte_rms()
        );
    }
    Ok(())
}
