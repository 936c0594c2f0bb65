//! The `geardyn` command line: a thin layer over the library.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};

use geardyn::analysis::{self, shoot, Direction, ShootingOptions, SweepOptions, SWEEP_COLUMNS};
use geardyn::model::OUTPUT_NAMES;
use geardyn::plot::{Plot, Series};
use geardyn::scene::{MethodChoice, Scene};
use geardyn::{output, simulation};

#[derive(Parser)]
#[command(
    name = "geardyn",
    version,
    about = "Gear-mesh dynamics: DTE, mesh force and contact loss"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Simulate a scene and write its outputs to CSV.
    Simulate(SimulateArgs),
    /// Run any FMI 2.0 Co-Simulation FMU (the host runner, like `fmpy simulate`).
    Run(geardyn::host::cli::RunArgs),
    /// Show an FMU's model description: capabilities and variables.
    Info(geardyn::host::cli::FmuArg),
    /// Check an FMU (modelDescription.xml and its linux64 binary); exit 1 on problems.
    Validate(geardyn::host::cli::FmuArg),
    /// Periodic steady state by shooting, with Floquet multipliers and stability.
    Periodic(PeriodicArgs),
    /// Frequency-response sweep over pinion speed (warm start, up/down branches).
    Sweep(SweepArgs),
    /// FMI 2.0 Co-Simulation FMUs: build, print or check model descriptions.
    Fmu(geardyn::fmi::cli::FmuArgs),
}

#[derive(Args)]
struct SweepArgs {
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

#[derive(Args)]
struct PeriodicArgs {
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
struct SimulateArgs {
    /// Scene file (`scene.toml`) or a folder holding one (e.g. `fmu/spur_pair`).
    #[arg(required_unless_present = "example", conflicts_with = "example")]
    scene: Option<PathBuf>,
    /// A built-in example scene instead of a file (e.g. `spur_pair`).
    #[arg(long)]
    example: Option<String>,
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
    /// RK pair: dp5 | dop853.
    #[arg(long)]
    rk_method: Option<String>,
    /// Relative tolerance of the RK path.
    #[arg(long, allow_negative_numbers = true)]
    rtol: Option<f64>,
    /// Absolute tolerance of the RK path (m and m/s).
    #[arg(long, allow_negative_numbers = true)]
    atol: Option<f64>,
    /// Do not print the summary.
    #[arg(long)]
    quiet: bool,
}

fn positive(name: &str, v: f64) -> Result<f64, String> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(format!("--{name} {v}: must be a finite number > 0"))
    }
}

/// The scene named on the command line: a file or folder, or a built-in example.
fn load_scene(path: &Option<PathBuf>, example: &Option<String>) -> Result<Scene, String> {
    match (path, example) {
        (_, Some(name)) => Scene::example(name),
        (Some(path), None) => Scene::from_path(path),
        (None, None) => unreachable!("clap requires a scene or --example"),
    }
    .map_err(|e| e.to_string())
}

fn periodic(args: PeriodicArgs) -> Result<(), String> {
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

fn sweep(args: SweepArgs) -> Result<(), String> {
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
        };
        std::fs::write(path, plot.to_svg())
            .map_err(|e| format!("cannot write '{}': {e}", path.display()))?;
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

fn simulate(args: SimulateArgs) -> Result<(), String> {
    let mut scene = load_scene(&args.scene, &args.example)?;
    let s = &mut scene.solver;
    if let Some(m) = &args.method {
        s.method = m
            .parse::<MethodChoice>()
            .map_err(|e| format!("--method: {e}"))?;
    }
    if let Some(m) = &args.rk_method {
        s.rk_method = m.parse().map_err(|e| format!("--rk-method: {e}"))?;
    }
    if let Some(v) = args.rtol {
        s.rtol = positive("rtol", v)?;
    }
    if let Some(v) = args.atol {
        s.atol = positive("atol", v)?;
    }
    let stop_time = positive("stop-time", args.stop_time.unwrap_or(s.stop_time))?;
    let interval = positive(
        "output-interval",
        args.output_interval.unwrap_or(s.output_interval),
    )?;
    let run = simulation::run(&scene, stop_time, interval)?;
    output::write_csv(&args.out, &OUTPUT_NAMES, &run.times, &run.rows)?;
    if !args.quiet {
        let st = &run.stats;
        println!(
            "scene {} → {} ({} rows)",
            scene.name,
            args.out.display(),
            run.times.len()
        );
        println!("  method               {}", run.method);
        println!("  DTE RMS (mean removed) {:.6e} m", run.dte_rms());
        println!("  peak mesh force      {:.6e} N", run.peak_mesh_force());
        println!(
            "  contact-loss fraction {:.4} (of output samples)",
            run.contact_loss_fraction()
        );
        println!(
            "  solver: {} steps, {} rejected, {} rhs evals, {} events, {} stops, {} guard evals",
            st.steps, st.rejected, st.rhs_evals, st.events, st.stops, st.guard_evals
        );
    }
    Ok(())
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Simulate(args) => simulate(args),
        Command::Run(args) => geardyn::host::cli::run(args),
        Command::Info(args) => geardyn::host::cli::info(args),
        Command::Validate(args) => geardyn::host::cli::validate(args),
        Command::Periodic(args) => periodic(args),
        Command::Sweep(args) => sweep(args),
        Command::Fmu(args) => geardyn::fmi::cli::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::FAILURE
        }
    }
}
