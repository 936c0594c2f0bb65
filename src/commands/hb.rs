//! `hb`: the harmonic-balance branch with its option parsing, table, plot and report of
//! `geardyn hb`.

use std::fmt::Write as _;
use std::path::Path;

use crate::analysis::hb::{continuation, BranchPoint, ContinuationOptions, HbOptions};
use crate::analysis::{self, Direction, SweepOptions};
use crate::plot::Series;
use crate::scene::Scene;

use super::positive;
use super::steady::{branch_points, dte_rms_plot};

/// The options of `geardyn hb` as given on the command line.
pub struct HbRequest<'a> {
    /// Pinion-speed interval `from:to`, rad/s: the branch starts at `from`.
    pub speed: &'a str,
    /// Harmonics of the response frequency.
    pub harmonics: usize,
    /// Response period in mesh periods (sub-harmonic branches).
    pub subharmonic: u32,
}

/// A harmonic-balance branch over the requested speed interval.
pub struct HbBranch {
    pub from: f64,
    pub to: f64,
    pub points: Vec<BranchPoint>,
}

/// Columns of the `geardyn hb` CSV ([`HbBranch::rows`]).
pub const HB_COLUMNS: [&str; 9] = [
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

impl HbRequest<'_> {
    /// Checks the options (messages name the CLI option) and continues the branch.
    pub fn run(&self, scene: &Scene) -> Result<HbBranch, String> {
        let (from, to) = self
            .speed
            .split_once(':')
            .ok_or_else(|| format!("--speed '{}': expected from:to", self.speed))?;
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
            subharmonic: self.subharmonic,
            ..HbOptions::new(self.harmonics)
        };
        let points = continuation(scene, &hb_options, &ContinuationOptions::new(from, to))?;
        Ok(HbBranch { from, to, points })
    }
}

impl HbBranch {
    /// One row per branch point in [`HB_COLUMNS`] order (NaN where stability is unknown).
    pub fn rows(&self) -> Vec<[f64; 9]> {
        self.points
            .iter()
            .map(|p| {
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
            })
            .collect()
    }

    /// The SVG `geardyn hb --plot` draws: stable solid, unstable dashed, and with
    /// `sweep_points ≥ 2` an up and a down sweep over the same interval overlaid.
    pub fn plot(
        &self,
        scene: &Scene,
        harmonics: usize,
        sweep_points: usize,
    ) -> Result<String, String> {
        let branch = &self.points;
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
                    points: branch_points(&points.points, d, 0),
                    dashed: false,
                    markers: true,
                    line: false,
                });
            }
        }
        let title = format!(
            "{}: harmonic balance, H = {} (DTE RMS, mean removed)",
            scene.name, harmonics
        );
        Ok(dte_rms_plot(&title, series))
    }

    /// The text `geardyn hb` prints after writing `out`: point and fold counts, then one line
    /// per fold.
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
            let _ = writeln!(
                s,
                "  fold near {:.4} rad/s (mesh {:.2} Hz), DTE RMS {:.4e} m",
                p.speed,
                p.solution.mesh_frequency,
                p.solution.dte_rms()
            );
        }
        s
    }
}
