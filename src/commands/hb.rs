//! `hb`: the harmonic-balance branch of any scene with its option parsing, table, plot and
//! report of `geardyn hb`.

use std::fmt::Write as _;
use std::path::Path;

use crate::analysis::hb::{continuation_reporting, BranchPoint, ContinuationOptions, HbOptions};
use crate::analysis::{self, Direction, Report, Stability, SweepOptions};
use crate::output;
use crate::plot::{Format, Marker, Series};
use crate::scene::{KernelChoice, Scene};
use crate::simulation::stream::{Progress, ProgressDisplay};
use crate::units::{both_units, rpm};

use super::steady::{branch_points, frequency_response_plot};

/// The options of `geardyn hb` as given on the command line.
pub struct HbRequest<'a> {
    /// Input-speed interval `from:to` (`300:600` in rad/s, or `3000rpm:6000rpm`): the branch
    /// starts at `from`.
    pub speed: &'a str,
    /// Order of the retained harmonics (combination tones of the mesh frequencies).
    pub harmonics: usize,
    /// Orbit period in response periods (sub-harmonic branches).
    pub subharmonic: u32,
}

/// A harmonic-balance branch over the requested speed interval.
pub struct HbBranch {
    pub from: f64,
    pub to: f64,
    pub points: Vec<BranchPoint>,
    /// Column prefix of every mesh (`""` for the single pair).
    pub prefixes: Vec<String>,
}

/// Columns before the per-mesh columns.
pub const HB_POINT_COLUMNS: [&str; 3] = ["speed", "speed_rpm", "mesh_frequency"];

/// Per-mesh columns (after the mesh's prefix): the same as `sweep`'s.
pub use crate::analysis::mesh_response::MESH_COLUMNS as HB_MESH_COLUMNS;

/// Columns after the per-mesh columns: the spectral radius of the map over
/// `spectral_radius_periods` response periods (the HB period: the subharmonic order), the
/// verdict (`stable` 1 / 0, `neutral` 1 when the radius is within
/// [`crate::analysis::shooting::NEUTRAL_TOLERANCE`] of 1), the fold flag, and `shooting_check`:
/// 0 where the multipliers are the HB orbit's, 1 where the HB radius lay within
/// [`crate::analysis::hb::SHOOTING_CHECK_MARGIN`] of 1 and the multipliers (and so radius and
/// verdict) are those of the periodic orbit Newton shooting found from the HB state, −1 where
/// that shooting found no orbit near the HB state (the HB estimate stands).
pub const HB_STABILITY_COLUMNS: [&str; 6] = [
    "spectral_radius",
    "spectral_radius_periods",
    "stable",
    "neutral",
    "fold",
    "shooting_check",
];

/// The column names of the `geardyn hb` CSV of a model with the given mesh prefixes: the
/// single pair keeps `speed, speed_rpm, mesh_frequency, dte_mean, dte_rms, dte_peak_to_peak, a1, …, spectral_radius,
/// stable, fold`; a drivetrain prefixes each mesh's columns with `<mesh name>.`.
pub fn hb_columns(prefixes: &[String]) -> Vec<String> {
    let mut names: Vec<String> = HB_POINT_COLUMNS.iter().map(|s| s.to_string()).collect();
    names.extend(crate::analysis::mesh_response::mesh_columns(prefixes));
    names.extend(HB_STABILITY_COLUMNS.iter().map(|s| s.to_string()));
    names
}

/// The index of the mesh named `name` in `scene` (`--plot-mesh`), or 0 (the single pair, or
/// the first mesh of a drivetrain) without a name; checked before any work is done.
pub fn plot_mesh_index(scene: &Scene, name: Option<&str>) -> Result<usize, String> {
    let Some(name) = name else { return Ok(0) };
    let names: Vec<&str> = match scene.kernel {
        KernelChoice::Pair => Vec::new(),
        KernelChoice::Drivetrain(_) => scene.meshes.iter().map(|m| m.name.as_str()).collect(),
    };
    names.iter().position(|n| *n == name).ok_or_else(|| {
        if names.is_empty() {
            format!("--plot-mesh '{name}': a single-mesh scene has one unnamed mesh")
        } else {
            format!(
                "--plot-mesh '{name}': no such mesh (meshes: {})",
                names.join(", ")
            )
        }
    })
}

/// `--sweep-points` within [`crate::units::MAX_SWEEP_POINTS`], checked before the branch
/// is continued (the sweep runs after it, for the plot).
pub fn check_sweep_points(points: usize) -> Result<(), String> {
    let max = crate::units::MAX_SWEEP_POINTS;
    if points > max {
        return Err(format!(
            "--sweep-points = {points}: more than the {max} a sweep may have"
        ));
    }
    Ok(())
}

impl HbRequest<'_> {
    /// The speed interval of `--speed from:to` (rad/s).
    pub fn interval(&self) -> Result<crate::units::SpeedInterval, String> {
        crate::units::parse_speed_interval("--speed", self.speed)
    }

    /// Checks the options (messages name the CLI option) and continues the branch.
    pub fn run(&self, scene: &Scene) -> Result<HbBranch, String> {
        self.run_reporting(scene, &|_, _| {})
    }

    /// [`HbRequest::run`], reporting the branch points to `report`.
    pub fn run_reporting(&self, scene: &Scene, report: Report) -> Result<HbBranch, String> {
        let crate::units::SpeedInterval { from, to } = self.interval()?;
        let hb_options = HbOptions {
            subharmonic: self.subharmonic,
            ..HbOptions::new(self.harmonics)
        };
        let points = continuation_reporting(
            scene,
            &hb_options,
            &ContinuationOptions::new(from, to),
            report,
        )?;
        let prefixes = points
            .first()
            .map(|p| p.solution.meshes.iter().map(|m| m.prefix.clone()).collect())
            .unwrap_or_default();
        Ok(HbBranch {
            from,
            to,
            points,
            prefixes,
        })
    }
}

impl HbBranch {
    /// The column names ([`hb_columns`]).
    pub fn columns(&self) -> Vec<String> {
        hb_columns(&self.prefixes)
    }

    /// One row per branch point in [`HbBranch::columns`] order (NaN where stability is
    /// unknown).
    pub fn rows(&self) -> Vec<Vec<f64>> {
        self.points
            .iter()
            .map(|p| {
                let mut row = vec![p.speed, rpm(p.speed), p.solution.mesh_frequency];
                for m in &p.solution.meshes {
                    row.extend(m.values());
                }
                let verdict = |v: Stability| {
                    p.stability()
                        .map_or(f64::NAN, |s| f64::from(u8::from(s == v)))
                };
                let check = match &p.shooting_check {
                    None => 0.0,
                    Some(c) if c.shooting_radius.is_some() => 1.0,
                    Some(_) => -1.0,
                };
                row.extend([
                    p.spectral_radius().unwrap_or(f64::NAN),
                    f64::from(p.solution.subharmonic),
                    verdict(Stability::Stable),
                    verdict(Stability::Neutral),
                    f64::from(u8::from(p.fold)),
                    check,
                ]);
                row
            })
            .collect()
    }

    /// `geardyn hb --plot` for mesh `mesh`: its DTE RMS over the input speed, stable solid,
    /// unstable dashed, folds marked, and with `sweep_points ≥ 2` an up and a down sweep over
    /// the same interval overlaid. Written to `path` (PNG or SVG by its extension).
    pub fn plot(
        &self,
        scene: &Scene,
        harmonics: usize,
        sweep_points: usize,
        mesh: usize,
        path: &Path,
    ) -> Result<(), String> {
        check_sweep_points(sweep_points)?;
        let branch = &self.points;
        let mut series: Vec<Series> = Vec::new();
        // Consecutive points of equal stability form one segment (shared end points).
        let mut start = 0;
        // Neutral (undamped) points are drawn solid with the stable ones: they do not grow.
        let stable = |i: usize| {
            (branch[i].stability())
                .is_none_or(|s| matches!(s, Stability::Stable | Stability::Neutral))
        };
        let (mut stable_labelled, mut unstable_labelled) = (false, false);
        let point = |p: &BranchPoint| (rpm(p.speed), p.solution.meshes[mesh].dte_rms);
        let markers = branch
            .iter()
            .filter(|p| p.fold)
            .map(|p| Marker {
                x: rpm(p.speed),
                label: format!("fold {:.0} rpm, {:.1} rad/s", rpm(p.speed), p.speed),
            })
            .collect();
        for i in 1..=branch.len() {
            if i == branch.len() || stable(i) != stable(start) {
                let is_stable = stable(start);
                let end = i.min(branch.len() - 1);
                let label = match (is_stable, stable_labelled, unstable_labelled) {
                    (true, false, _) if branch[start].stability() == Some(Stability::Neutral) => {
                        "HB neutral"
                    }
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
                    points: branch[start..=end].iter().map(point).collect(),
                    dashed: !is_stable,
                    markers: false,
                    line: true,
                });
                start = i;
            }
        }
        if sweep_points >= 2 {
            let (lo, hi) = (self.from.min(self.to), self.from.max(self.to));
            let speeds = (0..sweep_points)
                .map(|i| lo + (hi - lo) * i as f64 / (sweep_points - 1) as f64)
                .collect();
            let points = analysis::sweep(
                scene,
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
                    points: branch_points(&points.points, d, mesh),
                    dashed: false,
                    markers: true,
                    line: false,
                });
            }
        }
        let which = self.prefixes[mesh].trim_end_matches('.');
        let title = format!(
            "{}{}{}: harmonic balance, H = {} (DTE RMS, mean removed)",
            scene.name,
            if which.is_empty() { "" } else { " " },
            which,
            harmonics
        );
        frequency_response_plot(&title, series, markers).save(path)
    }

    /// The text `geardyn hb` prints after writing `out`: point and fold counts, then one line
    /// per fold with every mesh's DTE RMS, and where the branch ended short of the interval
    /// because the harmonics do not resolve the orbit ([`BranchPoint::unresolved`]).
    pub fn summary(&self, scene: &Scene, out: &Path) -> String {
        let branch = &self.points;
        let folds = branch.iter().filter(|p| p.fold).count();
        let mut s = format!(
            "scene {}: {} branch points, {} folds → {}\n",
            scene.name,
            branch.len(),
            folds,
            out.display()
        );
        for p in branch.iter().filter(|p| p.fold) {
            let _ = write!(
                s,
                "  fold near {:.4} rad/s (mesh {:.2} Hz), DTE RMS",
                p.speed, p.solution.mesh_frequency,
            );
            for m in &p.solution.meshes {
                let name = m.prefix.trim_end_matches('.');
                let sep = if name.is_empty() { "" } else { " " };
                let _ = write!(s, "{sep}{name} {:.4e} m", m.dte_rms);
            }
            s.push('\n');
        }
        for caveat in self.caveats() {
            let _ = writeln!(s, "  {caveat}");
        }
        s.push_str(&self.shooting_check_summary());
        s
    }

    /// What the branch's numbers cannot be trusted for, one sentence each (the CLI prints them
    /// in its summary, Python raises each as a `RuntimeWarning`): where the branch ended short
    /// of the interval because the harmonics do not resolve the orbit
    /// ([`BranchPoint::unresolved`]), the points whose verdict may be wrong (radius near 1
    /// unchecked: [`BranchPoint::verdict_uncertain`]) and those whose HB orbit is far from
    /// the periodic orbit ([`BranchPoint::far_from_orbit`]).
    pub fn caveats(&self) -> Vec<String> {
        let mut caveats = Vec::new();
        if let Some(p) = self.points.last().filter(|p| p.unresolved) {
            caveats.push(format!(
                "the branch ends at {:.4} rad/s, short of {} rad/s: there the HB state misses \
                 its period map by {:.1e} of the state scale (beyond {:.0e}), so the retained \
                 harmonics do not resolve the orbit and the branch would follow the truncation \
                 (raise --harmonics, or follow the orbit with `geardyn sweep`)",
                p.speed,
                self.to,
                p.periodicity_defect.unwrap_or(f64::NAN),
                crate::analysis::hb::PERIODICITY_DEFECT_LIMIT
            ));
        }
        let uncertain: Vec<&BranchPoint> = (self.points.iter())
            .filter(|p| p.verdict_uncertain())
            .collect();
        if let (Some(first), Some(last)) = (uncertain.first(), uncertain.last()) {
            caveats.push(format!(
                "{} points ({:.4} to {:.4} rad/s) have an HB spectral radius within {} times \
                 the HB orbit's error estimate of 1 but beyond the {:.0e} checked: their \
                 verdict may be wrong (raise --harmonics, or check with `geardyn periodic`)",
                uncertain.len(),
                first.speed,
                last.speed,
                crate::analysis::hb::RADIUS_SENSITIVITY,
                crate::analysis::hb::SHOOTING_CHECK_MARGIN
            ));
        }
        let far: Vec<&BranchPoint> = (self.points.iter())
            .filter(|p| p.far_from_orbit())
            .collect();
        if let (Some(first), Some(last)) = (far.first(), far.last()) {
            let worst = (far.iter())
                .filter_map(|p| p.orbit_error)
                .fold(0.0, f64::max);
            caveats.push(format!(
                "{} points ({:.4} to {:.4} rad/s) have an HB orbit estimated up to {:.1e} of the \
                 state scale from the periodic orbit (beyond {:.0e}): their statistics, folds \
                 and verdicts may be wrong (raise --harmonics, or check with `geardyn periodic`)",
                far.len(),
                first.speed,
                last.speed,
                worst,
                crate::analysis::hb::ORBIT_ERROR_WARNING
            ));
        }
        caveats
    }

    /// The lines on the points whose stability was checked by shooting (HB spectral radius
    /// within the margin of 1): how many, each one whose verdict the check changed, and each
    /// one where shooting found no orbit near the HB state.
    fn shooting_check_summary(&self) -> String {
        let checked: Vec<&BranchPoint> = (self.points.iter())
            .filter(|p| p.shooting_check.is_some())
            .collect();
        let mut s = String::new();
        if checked.is_empty() {
            return s;
        }
        let _ = writeln!(
            s,
            "  {} points with the HB spectral radius within {:.0e} of 1 checked by shooting from \
             the HB orbit (shooting_check = 1: radius and verdict of the shooting orbit)",
            checked.len(),
            crate::analysis::hb::SHOOTING_CHECK_MARGIN
        );
        for p in checked {
            let c = p.shooting_check.as_ref().expect("filtered");
            let shooting = p.stability().filter(|_| c.shooting_radius.is_some());
            match (c.shooting_radius, shooting) {
                (Some(r), Some(v)) if v != c.hb_stability => {
                    let _ = writeln!(
                        s,
                        "  {:.4} rad/s: HB radius {:.6} ({}), shooting orbit {:.6} ({}), \
                         {:.1e} of the state scale from the HB state",
                        p.speed,
                        c.hb_radius,
                        c.hb_stability.word(),
                        r,
                        v.word(),
                        c.distance
                    );
                }
                (Some(_), _) => {}
                _ => {
                    let _ = writeln!(
                        s,
                        "  {:.4} rad/s: HB radius {:.6} ({}); shooting found no orbit near the \
                         HB state (shooting_check = -1), the HB verdict stands",
                        p.speed,
                        c.hb_radius,
                        c.hb_stability.word()
                    );
                }
            }
        }
        s
    }
}

/// The files `geardyn hb` writes: the table, and optionally the FRF plot of one mesh (by name;
/// default the first) with `sweep_points` sweep points overlaid; `units` puts each column's
/// unit in the header.
pub struct HbFiles<'a> {
    pub out: &'a Path,
    pub plot: Option<&'a Path>,
    pub plot_mesh: Option<&'a str>,
    pub sweep_points: usize,
    pub units: bool,
}

/// `geardyn hb`: runs the continuation, writes its files and returns the summary it prints.
/// The continuation shows on stderr as `progress` says ([`Progress`]).
pub fn hb_command(
    scene: &Scene,
    request: &HbRequest,
    files: &HbFiles,
    progress: ProgressDisplay,
) -> Result<String, String> {
    check_sweep_points(files.sweep_points)?;
    let mesh = plot_mesh_index(scene, files.plot_mesh)?;
    if let Some(path) = files.plot {
        Format::of(path)?;
    }
    let interval = request.interval()?;
    eprintln!(
        "hb: input speed {} to {}",
        both_units(interval.from),
        both_units(interval.to)
    );
    let mut shown = Progress::of_analysis("hb: starting", progress);
    let branch = request.run_reporting(scene, &shown.reporter());
    shown.finish();
    let branch = branch?;
    let columns = branch.columns();
    output::write_table_with_units(files.out, &columns, branch.rows(), files.units)?;
    if let Some(path) = files.plot {
        branch.plot(scene, request.harmonics, files.sweep_points, mesh, path)?;
    }
    Ok(branch.summary(scene, files.out))
}
