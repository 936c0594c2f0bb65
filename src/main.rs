//! The `geardyn` command line: a thin layer over the library.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};

use geardyn::model::OUTPUT_NAMES;
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
    #[arg(long)]
    stop_time: Option<f64>,
    /// Output interval, s (default: the scene's `solver.output_interval`).
    #[arg(long)]
    output_interval: Option<f64>,
    /// Propagator: auto | rk | exact.
    #[arg(long)]
    method: Option<String>,
    /// RK pair: dp5 | dop853.
    #[arg(long)]
    rk_method: Option<String>,
    /// Relative tolerance of the RK path.
    #[arg(long)]
    rtol: Option<f64>,
    /// Absolute tolerance of the RK path (m and m/s).
    #[arg(long)]
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

fn simulate(args: SimulateArgs) -> Result<(), String> {
    let mut scene = match (&args.scene, &args.example) {
        (_, Some(name)) => Scene::example(name),
        (Some(path), None) => Scene::from_path(path),
        (None, None) => unreachable!("clap requires a scene or --example"),
    }
    .map_err(|e| e.to_string())?;
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
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::FAILURE
        }
    }
}
