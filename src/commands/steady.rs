//! `periodic` and `sweep`: the steady states and frequency responses of any scene (single
//! pair or drivetrain), with the option parsing, tables, plots and reports of
//! `geardyn periodic | sweep`.

use std::fmt::Write as _;
use std::path::Path;

use crate::analysis::mesh_response::MeshResponse;
use crate::analysis::orbit_statistics::orbit_responses;
use crate::analysis::shooting::NEUTRAL_TOLERANCE;
use crate::analysis::sweep::{Periodicity, Sweep, SweepPoint};
use crate::analysis::{
    self, multiplier_line, shoot_reporting, Direction, PeriodicOrbit, Report, ShootingOptions,
    Stability, SweepOptions,
};
use crate::model::Drivetrain;
use crate::output;
use crate::plot::{Axis, Format, Marker, Plot, Series};
use crate::scene::Scene;
use crate::simulation::stream::{Progress, ProgressDisplay};
use crate::units::{both_units, parse_speed, rpm};
use crate::with_drivetrain;

use super::positive;

/// Periodic steady state by shooting at the scene's input speed: a period-`periods` orbit
/// (in response periods) found after `warmup` response periods of integration.
pub fn periodic(scene: &Scene, periods: u32, warmup: u32) -> Result<PeriodicOrbit, String> {
    periodic_reporting(scene, periods, warmup, &|_, _| {})
}

/// [`periodic`], reporting the warm-up and the Newton iterations to `report`.
pub fn periodic_reporting(
    scene: &Scene,
    periods: u32,
    warmup: u32,
    report: Report,
) -> Result<PeriodicOrbit, String> {
    let options = ShootingOptions {
        periods,
        warmup_periods: warmup,
        ..ShootingOptions::default()
    };
    check_shooting_work(scene, &options)?;
    shoot_reporting(scene, &options, report)
}

/// The most a shooting run may integrate, checked before it starts (issue 34: `periods =
/// 10**9` ran for hours): the warm-up plus `periods` response periods for each Newton
/// iteration, within the run limits of `geardyn simulate` (mesh periods and periods of the
/// fastest mode, [`crate::simulation::RunLimits`]); the message names both counts.
pub fn check_shooting_work(scene: &Scene, options: &ShootingOptions) -> Result<(), String> {
    let (scales, period) = with_drivetrain!(scene.simulation()?, sim => {
        let model = sim.model();
        (crate::simulation::DrivenModel::run_scales(model), crate::model::response_period(model)?)
    });
    let periods = options.warmup_periods as f64
        + options.periods as f64 * (options.max_iterations as f64 + 1.0);
    let time = period * periods;
    crate::simulation::RunLimits::default()
        .check_work(&scales, time)
        .map_err(|e| {
            format!(
                "periods = {} with warmup = {}: shooting integrates up to {periods:e} response \
                 periods ({time:e} s): {e}",
                options.periods, options.warmup_periods
            )
        })
}

/// Each mesh's response on the orbit (the statistics of a `sweep` point).
pub fn periodic_responses(
    scene: &Scene,
    orbit: &PeriodicOrbit,
) -> Result<Vec<MeshResponse>, String> {
    orbit_responses(scene, orbit)
}

/// The text `geardyn periodic` prints for an orbit of `scene`: the Newton residuals, the
/// initial state with its coordinate names, each mesh's DTE at the start of the orbit, each
/// mesh's frequency and dynamic force (peak, RMS, dynamic factor), and the multipliers with the stability they imply.
pub fn periodic_report(scene: &Scene, orbit: &PeriodicOrbit) -> Result<String, String> {
    let mut s = String::new();
    // Writing to a String cannot fail.
    let _ = writeln!(
        s,
        "scene {}: period-{} orbit at input speed {} (T = {:.6e} s)",
        scene.name,
        orbit.periods,
        both_units(scene.input_speed()),
        orbit.period
    );
    for (k, r) in orbit.residuals.iter().enumerate() {
        let _ = writeln!(s, "  Newton {k}: scaled residual {r:.3e}");
    }
    with_drivetrain!(scene.simulation()?, sim => {
        let model = sim.model();
        let names = model.coordinate_names();
        let n = names.len();
        if n == 1 {
            let _ = writeln!(
                s,
                "  y0 = [x = {:e} m, x' = {:e} m/s]",
                orbit.y0[0], orbit.y0[1]
            );
        } else {
            for (i, name) in names.iter().enumerate() {
                let _ = writeln!(
                    s,
                    "  y0 {name} = {:e}, {name}' = {:e}",
                    orbit.y0[i],
                    orbit.y0[n + i]
                );
            }
            for m in 0..model.mesh_count() {
                let sample = model.mesh_sample(m, 0.0, &orbit.y0);
                let _ = writeln!(
                    s,
                    "  {}dte(0) = {:e} m",
                    model.mesh_prefix(m),
                    sample.dte
                );
            }
        }
    });
    // The names of the `sweep` and `hb` columns, so the three outputs read alike.
    for m in periodic_responses(scene, orbit)? {
        let _ = writeln!(s, "  {}", m.report_line());
    }
    for m in &orbit.multipliers {
        let _ = writeln!(s, "{}", multiplier_line(m));
    }
    let stability = orbit.stability();
    let _ = match stability {
        Stability::Neutral => writeln!(
            s,
            "  stability: {stability:?} (|μ| within {NEUTRAL_TOLERANCE:.0e} of 1)"
        ),
        _ => writeln!(s, "  stability: {stability:?}"),
    };
    Ok(s)
}

/// The options of `geardyn sweep` as given on the command line.
pub struct SweepRequest<'a> {
    /// Input-gear speeds `from:to:points` (`1000rpm:10000rpm:181`; bare numbers are rad/s).
    pub speed: &'a str,
    /// `up | down | both`.
    pub direction: &'a str,
    /// Periodicity tolerance (scaled state residual).
    pub tolerance: f64,
    /// Response periods after which a point is given up (kept, marked not converged).
    pub max_periods: u32,
    /// Keep Poincaré samples (each mesh's DTE once per mesh period).
    pub poincare: bool,
}

impl SweepRequest<'_> {
    /// Checks the options (messages name the CLI option): the sweep's settings.
    pub fn options(&self) -> Result<SweepOptions, String> {
        let speeds = SweepOptions::parse_range(self.speed)?;
        // Each point may integrate up to `max_periods` response periods: the whole sweep within
        // the mesh periods one `geardyn simulate` run may span.
        let most = speeds.len() as f64 * f64::from(self.max_periods);
        let limit = crate::simulation::stream::DEFAULT_MAX_MESH_PERIODS;
        if most > limit {
            return Err(format!(
                "--max-periods = {} over {} points: up to {most:e} response periods, more than \
                 the {limit:e} a sweep may integrate",
                self.max_periods,
                speeds.len()
            ));
        }
        let direction = self
            .direction
            .parse()
            .map_err(|e| format!("--direction: {e}"))?;
        Ok(SweepOptions {
            tolerance: positive("tolerance", self.tolerance)?,
            max_transient_periods: self.max_periods,
            poincare: self.poincare,
            ..SweepOptions::new(speeds, direction)
        })
    }

    /// Checks the options and runs the sweep.
    pub fn run(
        &self,
        scene: &Scene,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<Sweep, String> {
        analysis::sweep(scene, &self.options()?, progress)
    }
}

/// One branch of a sweep as plot points: mesh `m`'s DTE RMS over the input speed in rpm.
pub fn branch_points(points: &[SweepPoint], d: Direction, m: usize) -> Vec<(f64, f64)> {
    points
        .iter()
        .filter(|p| p.direction == d)
        .map(|p| (rpm(p.speed), p.meshes[m].dte_rms))
        .collect()
}

/// A jump of one branch of a sweep: consecutive converged points whose DTE RMS differ by more
/// than a factor 1.5 and by more than 10 % of the branch's largest RMS — the signature of a
/// hysteresis jump (or a contact-loss onset), which the plot marks.
fn jumps(points: &[(f64, f64)]) -> Vec<f64> {
    let largest = points
        .iter()
        .map(|p| p.1)
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max);
    points
        .windows(2)
        .filter(|w| {
            let (a, b) = (w[0].1, w[1].1);
            a.is_finite()
                && b.is_finite()
                && (a - b).abs() > 0.1 * largest
                && a.max(b) > 1.5 * a.min(b)
        })
        .map(|w| 0.5 * (w[0].0 + w[1].0))
        .collect()
}

/// `geardyn sweep --plot`: each mesh's DTE RMS against the input speed, one series per mesh and
/// branch that has points, with the jumps of each branch marked. Written to `path` (PNG or
/// SVG by its extension).
pub fn sweep_plot(scene: &Scene, sweep: &Sweep, path: &Path) -> Result<(), String> {
    const COLORS: [(&str, &str); 4] = [
        ("#c0392b", "#2471a3"),
        ("#e67e22", "#16a085"),
        ("#8e44ad", "#2c3e50"),
        ("#7f8c8d", "#27ae60"),
    ];
    let labels: Vec<String> = sweep
        .prefixes
        .iter()
        .flat_map(|p| {
            let mesh = p.trim_end_matches('.');
            let sep = if mesh.is_empty() { "" } else { " " };
            [
                format!("{mesh}{sep}up sweep"),
                format!("{mesh}{sep}down sweep"),
            ]
        })
        .collect();
    let mut series = Vec::new();
    let mut markers = Vec::new();
    for m in 0..sweep.prefixes.len() {
        let (up, down) = COLORS[m % COLORS.len()];
        for (k, (d, color, dashed)) in [(Direction::Up, up, false), (Direction::Down, down, true)]
            .into_iter()
            .enumerate()
        {
            let points = branch_points(&sweep.points, d, m);
            let arrow = if d == Direction::Up { "up" } else { "down" };
            markers.extend(jumps(&points).into_iter().map(|x| Marker {
                x,
                label: format!(
                    "{}jump ({arrow}) {x:.0} rpm, {:.1} rad/s",
                    mesh_tag(&sweep.prefixes[m]),
                    x * std::f64::consts::TAU / 60.0
                ),
            }));
            if !points.is_empty() {
                series.push(Series {
                    label: &labels[2 * m + k],
                    color,
                    points,
                    dashed,
                    markers: true,
                    line: true,
                });
            }
        }
    }
    let title = format!("{}: DTE RMS (mean removed)", scene.name);
    frequency_response_plot(&title, series, markers).save(path)
}

/// `"mesh1 "` for a drivetrain mesh prefix `mesh1.`, `""` for the single pair.
pub fn mesh_tag(prefix: &str) -> String {
    let mesh = prefix.trim_end_matches('.');
    if mesh.is_empty() {
        String::new()
    } else {
        format!("{mesh} ")
    }
}

/// A DTE-RMS-over-input-speed plot (the axes of every frequency response).
pub fn frequency_response_plot<'a>(
    title: &'a str,
    series: Vec<Series<'a>>,
    markers: Vec<Marker>,
) -> Plot<'a> {
    Plot {
        title,
        x: Axis::new("input speed", "rpm"),
        y: Axis::new("DTE RMS", "m"),
        series,
        bands: Vec::new(),
        band_label: "",
        markers,
    }
}

/// The lines `geardyn sweep` prints after writing `out`.
pub fn sweep_summary(scene: &Scene, sweep: &Sweep, out: &Path) -> String {
    let points = &sweep.points;
    let unconverged = points.iter().filter(|p| !p.converged).count();
    let aperiodic = points
        .iter()
        .filter(|p| p.periodicity == Periodicity::Aperiodic)
        .count();
    let mut s = format!(
        "scene {}: {} points → {}{}\n",
        scene.name,
        points.len(),
        out.display(),
        if unconverged > 0 {
            format!(
                " ({unconverged} not converged, marked converged = 0; {aperiodic} of them \
                 aperiodic, marked aperiodic = 1)"
            )
        } else {
            String::new()
        }
    );
    for p in points.iter().filter(|p| p.failure.is_some()) {
        let _ = writeln!(
            s,
            "  speed {} rad/s failed (row of NaN): {}",
            p.speed,
            p.failure.as_deref().unwrap_or_default()
        );
    }
    let period_k = points
        .iter()
        .filter(|p| p.response_periods.is_some_and(|k| k > 1))
        .count();
    if period_k > 0 {
        let _ = writeln!(s, "  {period_k} points with period-k responses (k > 1)");
    }
    s
}

/// Poincaré samples as rows `(direction, speed, mesh, index, dte)`.
pub const POINCARE_COLUMNS: [&str; 5] = ["direction", "speed", "mesh", "sample", "dte"];

/// The rows of [`POINCARE_COLUMNS`] of a sweep run with Poincaré samples.
pub fn poincare_rows(sweep: &Sweep) -> Vec<[f64; 5]> {
    let mut rows = Vec::new();
    for p in &sweep.points {
        let d = if p.direction == Direction::Up {
            1.0
        } else {
            -1.0
        };
        for (m, mesh) in p.meshes.iter().enumerate() {
            for (i, x) in mesh.poincare.iter().enumerate() {
                rows.push([d, p.speed, (m + 1) as f64, i as f64, *x]);
            }
        }
    }
    rows
}

/// `geardyn periodic`: the orbit at `speed` (`--speed` text; default the scene's input
/// speed) and the text the command prints.
/// The shooting shows on stderr as `progress` says ([`Progress`]).
pub fn periodic_command(
    scene: &mut Scene,
    speed: Option<&str>,
    periods: u32,
    warmup: u32,
    progress: ProgressDisplay,
) -> Result<String, String> {
    if let Some(text) = speed {
        let speed = parse_speed("--speed", text)?;
        eprintln!("periodic: input speed {}", both_units(speed));
        scene.set_input_speed(speed);
    }
    let mut shown = Progress::of_analysis("periodic: starting", progress);
    let orbit = periodic_reporting(scene, periods, warmup, &shown.reporter());
    shown.finish();
    periodic_report(scene, &orbit?)
}

/// The files `geardyn sweep` writes: the table, and optionally the Poincaré samples, each
/// point's recording state and the frequency-response plot; `units` puts each column's unit in
/// the headers.
pub struct SweepFiles<'a> {
    pub out: &'a Path,
    pub poincare: Option<&'a Path>,
    pub states: Option<&'a Path>,
    pub plot: Option<&'a Path>,
    pub units: bool,
}

/// The leading columns of `geardyn sweep --states`; then the state, `y0`, `y1`, … (the run's
/// state vector: the coordinates, then their rates, in `geardyn periodic`'s order).
pub const STATE_COLUMNS: [&str; 4] = ["direction", "speed", "recorded_periods", "recording_phase"];

/// `geardyn sweep --states`: per point (rows in the table's order) where its statistics were
/// recorded from: the response periods recorded, the first mesh's phase in cycles (modulo the
/// response period's cycles) and the state there ([`SweepPoint::recording_state`]). A run of
/// the scene at that speed set to that state at that phase records the same response again;
/// a failed point has 0 periods and NaN state.
pub fn state_table(sweep: &Sweep, record_periods: u32) -> (Vec<String>, Vec<Vec<f64>>) {
    let width = sweep
        .points
        .iter()
        .map(|p| p.recording_state.len())
        .max()
        .unwrap_or(0);
    let mut columns: Vec<String> = STATE_COLUMNS.iter().map(|c| c.to_string()).collect();
    columns.extend((0..width).map(|i| format!("y{i}")));
    let rows = sweep
        .points
        .iter()
        .map(|p| {
            let periods = match (&p.failure, p.response_periods) {
                (Some(_), _) => 0,
                (None, Some(k)) => k,
                (None, None) => record_periods,
            };
            let mut row = vec![p.row()[0], p.speed, f64::from(periods), p.recording_phase];
            row.extend((0..width).map(|i| p.recording_state.get(i).copied().unwrap_or(f64::NAN)));
            row
        })
        .collect();
    (columns, rows)
}

/// `geardyn sweep`: runs the sweep, writes its files and returns the summary it prints. The
/// points done show on stderr as `progress` says ([`Progress`]).
pub fn sweep_command(
    scene: &Scene,
    request: &SweepRequest,
    files: &SweepFiles,
    progress: ProgressDisplay,
) -> Result<String, String> {
    if let Some(path) = files.plot {
        Format::of(path)?;
    }
    let options = request.options()?;
    let speeds = &options.speeds;
    eprintln!(
        "sweep: input speed {} to {}, {} points",
        both_units(speeds[0]),
        both_units(speeds[speeds.len() - 1]),
        speeds.len()
    );
    let mut progress = Progress::of_analysis("sweep 0 points done", progress);
    let show = |done: usize, total: usize| {
        progress.report(done as f64 / total as f64, || {
            format!("sweep {done}/{total} points")
        })
    };
    let sweep = analysis::sweep(scene, &options, &show);
    progress.finish();
    let sweep = sweep?;
    let columns = sweep.columns();
    output::write_table_with_units(
        files.out,
        &columns,
        sweep.points.iter().map(|p| p.row()),
        files.units,
    )?;
    if let Some(path) = files.poincare {
        output::write_table_with_units(
            path,
            &POINCARE_COLUMNS,
            poincare_rows(&sweep),
            files.units,
        )?;
    }
    if let Some(path) = files.states {
        let (columns, rows) = state_table(&sweep, options.record_periods);
        output::write_table(path, &columns, rows)?;
    }
    if let Some(path) = files.plot {
        sweep_plot(scene, &sweep, path)?;
    }
    Ok(sweep_summary(scene, &sweep, files.out))
}
