//! The waterfall of a run-up (`geardyn waterfall`, `docs/runup.md`): the scene's run-up
//! simulated on its output grid, one mesh signal (DTE or force) cut into short-time spectra by
//! [`crate::analysis::spectrum::waterfall`], each window tagged with the input gear's speed
//! from the speed profile. Mesh order k of a mesh with `z` pinion teeth per input revolution
//! lies on `f = k·z·n/60`; a resonance is where it meets a natural frequency.

use std::f64::consts::TAU;

use crate::analysis::spectrum::{waterfall, Waterfall, WaterfallOptions};
use crate::analysis::Report;
use crate::model::Drivetrain;
use crate::scene::Scene;
use crate::simulation::stream::{Progress, ProgressDisplay};
use crate::simulation::{DrivenModel, OutputGrid};
use crate::with_drivetrain;

/// Which mesh signal the waterfall analyses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RunupSignal {
    /// Dynamic transmission error, m.
    Dte,
    /// Dynamic mesh force, N.
    Force,
}

impl RunupSignal {
    /// The signal's unit (the amplitude column of the CSV).
    pub fn unit(self) -> &'static str {
        match self {
            RunupSignal::Dte => "m",
            RunupSignal::Force => "N",
        }
    }
}

impl std::str::FromStr for RunupSignal {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "dte" => Ok(RunupSignal::Dte),
            "force" => Ok(RunupSignal::Force),
            _ => Err(format!("'{s}': expected dte or force")),
        }
    }
}

/// A run-up's waterfall and what locates its orders.
#[derive(Debug, Clone)]
pub struct RunupWaterfall {
    pub map: Waterfall,
    /// Mesh cycles per input-gear revolution of the analysed mesh (its mesh order 1 in input
    /// shaft orders).
    pub mesh_order: f64,
}

/// Simulates the run-up of `scene` (it must have `operating.speed_profile`) over its
/// `solver.stop_time` on its `output_interval` grid and returns the waterfall of mesh `mesh`'s
/// `signal` (the 0 Hz line is the window mean), with the input gear's speed in rpm.
pub fn runup_waterfall(
    scene: &Scene,
    mesh: usize,
    signal: RunupSignal,
    options: &WaterfallOptions,
) -> Result<RunupWaterfall, String> {
    runup_waterfall_reporting(scene, mesh, signal, options, &|_, _| {})
}

/// [`runup_waterfall`], reporting the run-up's time reached to `report`.
pub fn runup_waterfall_reporting(
    scene: &Scene,
    mesh: usize,
    signal: RunupSignal,
    options: &WaterfallOptions,
    report: Report,
) -> Result<RunupWaterfall, String> {
    let Some(speed) = scene.profiles.speed.clone() else {
        return Err(format!(
            "scene {}: a waterfall needs a run-up (operating.speed_profile, docs/runup.md)",
            scene.name
        ));
    };
    let (stop, interval) = (scene.solver.stop_time, scene.solver.output_interval);
    with_drivetrain!(scene.simulation()?, sim => {
        let mut sim = sim;
        let count = sim.model().mesh_count();
        if mesh >= count {
            return Err(format!("mesh {mesh}: the scene has {count} mesh(es)"));
        }
        crate::simulation::RunLimits::default().check(&sim.model().run_scales(), stop, interval)?;
        let column = {
            let c = sim.model().mesh_columns(mesh);
            match signal {
                RunupSignal::Dte => c.dte,
                RunupSignal::Force => c.force,
            }
        };
        let mut t = Vec::new();
        let mut x = Vec::new();
        let mut row = Vec::new();
        sim.sample(OutputGrid::new(stop, interval), |sim, time| {
            if t.len().is_multiple_of(1024) {
                report(time / stop, &|| {
                    format!("waterfall: run-up at t = {time:.6e} s of {stop} s, {} rows", t.len())
                });
            }
            sim.model().output_row(time, sim.y(), &mut row);
            t.push(time);
            x.push(row[column]);
            Ok(())
        })?;
        // The last grid point may be the stop time off the grid: the spectrum needs one interval.
        if t.len() > 2 && ((t[t.len() - 1] - t[t.len() - 2]) - interval).abs() > 1e-9 * interval {
            t.pop();
            x.pop();
        }
        let rpm: Vec<f64> = t.iter().map(|&ti| speed.value_at(ti) * 60.0 / TAU).collect();
        // Mesh cycles per input revolution: the mesh frequency at 1 rad/s times 2π.
        let mut probe = sim.model().clone();
        probe.set_input_speed(0.0, 1.0)?;
        let mesh_order = probe.mesh_frequency(mesh) * TAU;
        let map = waterfall(&t, &x, &rpm, options)?;
        Ok(RunupWaterfall { map, mesh_order })
    })
}

/// The mesh names of a scene as `--mesh` takes them (`mesh` for the single pair).
pub fn mesh_names(scene: &Scene) -> Result<Vec<String>, String> {
    with_drivetrain!(scene.simulation()?, sim => {
        Ok((0..sim.model().mesh_count())
            .map(|n| {
                let p = sim.model().mesh_prefix(n);
                if p.is_empty() { "mesh".to_owned() } else { p.trim_end_matches('.').to_owned() }
            })
            .collect())
    })
}

/// What `geardyn waterfall` analyses, as the command line gives it.
#[derive(Debug, Clone, Copy)]
pub struct WaterfallRequest<'a> {
    /// The mesh by name (a drivetrain); `None`: the first mesh.
    pub mesh: Option<&'a str>,
    /// `dte` or `force`.
    pub signal: &'a str,
    /// Samples per short-time window.
    pub segment: usize,
    /// Fraction of a window shared with the next.
    pub overlap: f64,
    /// `hann` or `flattop`.
    pub window: &'a str,
}

/// `geardyn waterfall`: the order map of the scene's run-up to the CSV `out` (and a Campbell
/// plot), and the report of what was written.
/// The run-up shows on stderr as `progress` says ([`Progress`]).
pub fn waterfall_command(
    scene: &Scene,
    request: &WaterfallRequest,
    out: &std::path::Path,
    plot: Option<&std::path::Path>,
    progress: ProgressDisplay,
) -> Result<String, String> {
    use crate::analysis::spectrum::Window;
    if let Some(path) = plot {
        crate::plot::Format::of(path)?;
    }
    let signal: RunupSignal = request
        .signal
        .parse()
        .map_err(|e| format!("--signal {e}"))?;
    let window = match request.window {
        "hann" => Window::Hann,
        "flattop" => Window::FlatTop,
        other => return Err(format!("--window '{other}': expected hann or flattop")),
    };
    let mesh = match request.mesh {
        None => 0,
        Some(name) => {
            let names = mesh_names(scene)?;
            names.iter().position(|n| n == name).ok_or_else(|| {
                format!(
                    "--mesh '{name}': no such mesh (meshes: {})",
                    names.join(", ")
                )
            })?
        }
    };
    let options = WaterfallOptions {
        segment: request.segment,
        overlap: request.overlap,
        window,
    };
    let mut shown = Progress::of_analysis("waterfall: starting", progress);
    let w = runup_waterfall_reporting(scene, mesh, signal, &options, &shown.reporter());
    shown.finish();
    let w = w?;
    w.map.write_csv(out, signal.unit())?;
    if let Some(path) = plot {
        let orders: Vec<(String, f64)> = (1..=3)
            .map(|k| (format!("{k}×mesh"), k as f64 * w.mesh_order))
            .collect();
        let title = format!("{}: waterfall of the {}", scene.name, request.signal);
        w.map.save_plot(path, &title, &orders)?;
    }
    let map = &w.map;
    let (lo, hi) = (
        map.rpm.iter().copied().fold(f64::INFINITY, f64::min),
        map.rpm.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    );
    Ok(format!(
        "scene {} → {} ({} windows × {} frequencies, {:.0}–{:.0} rpm, {:.1} Hz resolution)\n  \
         mesh order 1 = shaft order {:.4} of the input gear: f = {:.4}·n/60 Hz\n",
        scene.name,
        out.display(),
        map.rpm.len(),
        map.frequency.len(),
        lo,
        hi,
        map.frequency.get(1).copied().unwrap_or(f64::NAN),
        w.mesh_order,
        w.mesh_order
    ))
}
