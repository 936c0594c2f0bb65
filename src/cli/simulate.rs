//! `geardyn simulate`: a scene to CSV with a summary.

use std::path::PathBuf;

use clap::Args;

use geardyn::model::OUTPUT_NAMES;
use geardyn::scene::train::TrainScene;
use geardyn::scene::{MethodChoice, SolverSettings};
use geardyn::{output, simulation};

use super::{load_scene, positive};

#[derive(Args)]
pub struct SimulateArgs {
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

pub fn run(args: SimulateArgs) -> Result<(), String> {
    use geardyn::scene::train::{is_train_file, TRAIN_EXAMPLES};
    match (&args.scene, &args.example) {
        (Some(path), None) if is_train_file(path).map_err(|e| e.to_string())? => {
            let scene = TrainScene::from_path(path).map_err(|e| e.to_string())?;
            return simulate_train(scene, &args);
        }
        (None, Some(name)) if TRAIN_EXAMPLES.iter().any(|(n, _)| n == name) => {
            let scene = TrainScene::example(name).map_err(|e| e.to_string())?;
            return simulate_train(scene, &args);
        }
        _ => {}
    }
    let mut scene = load_scene(&args.scene, &args.example)?;
    let (stop_time, interval) = apply_solver_options(&mut scene.solver, &args)?;
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

/// The command-line solver options applied to a scene's settings; returns the stop time and
/// the output interval.
fn apply_solver_options(s: &mut SolverSettings, args: &SimulateArgs) -> Result<(f64, f64), String> {
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
    let stop = positive("stop-time", args.stop_time.unwrap_or(s.stop_time))?;
    let interval = positive(
        "output-interval",
        args.output_interval.unwrap_or(s.output_interval),
    )?;
    Ok((stop, interval))
}

/// Drivetrain scenes: the same solver options, applied to the train's settings.
fn simulate_train(scene: TrainScene, args: &SimulateArgs) -> Result<(), String> {
    super::train::simulate(
        scene,
        &args.out,
        |s| apply_solver_options(s, args),
        args.quiet,
    )
}
