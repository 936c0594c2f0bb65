//! `geardyn simulate` for drivetrain scenes (`modes` is in `modes.rs`).

use std::path::Path;

use geardyn::model::train::run_train;
use geardyn::output;
use geardyn::scene::train::TrainScene;
use geardyn::scene::SolverSettings;

/// `geardyn simulate` for a drivetrain scene.
pub fn simulate(
    mut scene: TrainScene,
    out: &Path,
    settings: impl FnOnce(&mut SolverSettings) -> Result<(f64, f64), String>,
    quiet: bool,
) -> Result<(), String> {
    let (stop_time, interval) = settings(&mut scene.solver)?;
    let run = run_train(&scene, stop_time, interval)?;
    let names: Vec<&str> = run.names.iter().map(String::as_str).collect();
    output::write_csv(out, &names, &run.times, &run.rows)?;
    if !quiet {
        let st = &run.stats;
        println!(
            "scene {} → {} ({} rows)",
            scene.name,
            out.display(),
            run.times.len()
        );
        println!("  method               {}", run.method);
        for m in &scene.meshes {
            let dte = run.column(&format!("{}_dte", m.name)).expect("dte column");
            let force = run
                .column(&format!("{}_force", m.name))
                .expect("force column");
            let peak = run.rows.iter().map(|r| r[force].abs()).fold(0.0, f64::max);
            println!(
                "  {:<10} DTE RMS {:.6e} m, peak force {:.6e} N, total contact loss {:.4} of samples",
                m.name,
                run.rms(dte),
                peak,
                run.contact_loss_fraction(&m.name)
            );
        }
        println!(
            "  solver: {} steps, {} rejected, {} rhs evals, {} events, {} stops, {} guard evals",
            st.steps, st.rejected, st.rhs_evals, st.events, st.stops, st.guard_evals
        );
    }
    Ok(())
}
