//! `geardyn simulate` as the command line runs it: the aliasing warning, the run to CSV
//! ([`super::simulate_run`], which the Python module and the spectrum share), then the time
//! plot, the summary and the spectrum of the run, each as asked.

use std::path::Path;

pub use super::simulate_run::{simulate, MeshSummary, SimulateOptions, SimulateReport};
pub use super::simulate_run::{simulate_in_memory, RowsInMemory, SummarySource};
use crate::scene::Scene;

/// The files `geardyn simulate` writes besides the CSV.
#[derive(Debug, Clone, Copy)]
pub struct SimulateFiles<'a> {
    /// The CSV of every output row.
    pub out: &'a Path,
    /// A plot of every mesh's DTE and force over time (PNG or SVG by the extension).
    pub plot: Option<&'a Path>,
    /// The spectrum of every mesh's DTE and force (CSV).
    pub spectrum: Option<&'a Path>,
    /// No summary on stdout.
    pub quiet: bool,
}

/// `geardyn simulate`: warns of aliasing at the output interval, runs the scene to its CSV,
/// then writes the plot, prints the summary and writes the spectrum, each as asked.
pub fn command(
    scene: Scene,
    opts: &SimulateOptions,
    files: &SimulateFiles,
) -> Result<SimulateReport, String> {
    if let Some(path) = files.plot {
        crate::plot::Format::of(path)?;
    }
    let mut settings = scene.solver.clone();
    let (stop_time, interval) = opts.apply(&mut settings)?;
    // The summary comes from the continuous solution (the exact segments or the RK dense
    // output), so the output interval decides only what the rows show: aliasing matters for a
    // spectrum of the rows (`--spectrum`) and for a summary of the rows (profiles, or no
    // summary with `--quiet`).
    let sampled_summary = {
        let mut s = scene.clone();
        s.solver = settings;
        !super::simulate_run::summary_from_solution(&s)?
    };
    if files.spectrum.is_some() || (sampled_summary && !files.quiet) {
        if let Some(warning) = super::spectrum::aliasing(&scene, interval)? {
            eprintln!("{warning}");
        }
    }
    let last = crate::simulation::OutputGrid::new(stop_time, interval).last_point();
    if last < stop_time {
        eprintln!(
            "note: stop time {stop_time:e} s is not a multiple of the output interval \
             {interval:e} s: the rows stay on the grid and end at {last:e} s"
        );
    }
    let scene_for_spectrum = scene.clone();
    let report = simulate(scene, opts, files.out)?;
    if let Some(path) = files.plot {
        super::time_plot::time_plot(&report, files.out, path)?;
    }
    if !files.quiet {
        report.print(files.out);
    }
    if let Some(path) = files.spectrum {
        let method =
            super::spectrum::spectrum_of_run(&scene_for_spectrum, &report, files.out, path)?;
        if !files.quiet {
            println!("  spectrum ({}) -> {}", method.describe(), path.display());
        }
    }
    Ok(report)
}
