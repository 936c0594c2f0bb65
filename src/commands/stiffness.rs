//! `stiffness`: mesh stiffness over one mesh period from gear geometry (docs/stiffness.md),
//! with the table, plot and summary of `geardyn stiffness`.

use std::path::Path;

use crate::mesh::geometry::{report, spec, CurveOptions, MeshModel, StiffnessCurve};

/// A stiffness curve and the mesh model it was computed from.
pub struct Stiffness {
    pub model: MeshModel,
    pub curve: StiffnessCurve,
}

/// Reads a gears file and computes the curve at pinion torque `torque` (N·m), with or without
/// extended tooth contact; messages name the file or the `--torque` option.
pub fn stiffness(gears: &Path, torque: f64, etc: bool) -> Result<Stiffness, String> {
    let origin = gears.display().to_string();
    let text = std::fs::read_to_string(gears)
        .map_err(|e| format!("cannot read gears file '{origin}': {e}"))?;
    let spec = spec::parse_gears_file(&text, &origin)?;
    let model = MeshModel::new(&spec, "").map_err(|e| format!("{origin}: {e}"))?;
    let curve = model
        .curve(CurveOptions { torque, etc })
        .map_err(|e| format!("--torque {torque}: {e}"))?;
    Ok(Stiffness { model, curve })
}

impl Stiffness {
    /// Column names of the table, one force column per tooth pair that can be loaded.
    pub fn columns(&self) -> Vec<String> {
        report::csv_names(self.curve.low_pairs + 1)
    }

    /// One row per knot of the curve, in [`Stiffness::columns`] order.
    pub fn rows(&self) -> Vec<Vec<f64>> {
        report::csv_rows(&self.curve)
    }

    /// `geardyn stiffness --plot` (PNG or SVG by the extension of `path`); with ETC on, the
    /// ETC-off curve is drawn too.
    pub fn plot(&self, path: &std::path::Path) -> Result<(), String> {
        let title = format!("Mesh stiffness, T = {} N·m", self.curve.options.torque);
        if self.curve.options.etc {
            let off = self.model.curve(CurveOptions {
                etc: false,
                ..self.curve.options
            })?;
            report::plot(&[("ETC on", &self.curve), ("ETC off", &off)], &title, path)
        } else {
            report::plot(&[("ETC off", &self.curve)], &title, path)
        }
    }

    /// `geardyn stiffness --pairs`: the pair curve of Model-1 (`crate::mesh::geometry::pairs`,
    /// the curve `[mesh.pairs] kind = "geometry"` uses) with each knot's compliance terms, so
    /// that an independent evaluation can check every term.
    pub fn write_pairs(&self, path: &Path, torque: f64, etc: bool) -> Result<(), String> {
        let extension = if etc {
            crate::mesh::geometry::pairs::ETC_EXTENSION
        } else {
            0.0
        };
        let curve = self
            .model
            .pair_curve(torque, extension)
            .map_err(|e| format!("--torque {torque}: {e}"))?;
        let names: Vec<String> = [
            "xi",
            "position",
            "beam_pinion",
            "beam_gear",
            "fillet_pinion",
            "fillet_gear",
            "hertz",
            "stiffness",
        ]
        .map(String::from)
        .to_vec();
        let rows: Vec<Vec<f64>> = (0..curve.points.len())
            .map(|j| {
                let c = self.model.compliance_at(curve.positions[j]);
                vec![
                    curve.points[j],
                    curve.positions[j],
                    c.beam[0],
                    c.beam[1],
                    c.fillet[0],
                    c.fillet[1],
                    1.0 / curve.hertz,
                    curve.values[j],
                ]
            })
            .collect();
        crate::output::write_table(path, &names, rows.iter().map(|r| r.iter().copied()))
    }

    /// The summary `geardyn stiffness` prints (`harmonics` checked by [`check_harmonics`]), with `harmonics` Fourier harmonics.
    pub fn summary(&self, harmonics: usize) -> String {
        report::summary(&self.model, &self.curve, harmonics)
    }
}

/// Most Fourier harmonics of the stiffness summary: far beyond what a curve of a few hundred
/// knots resolves; a bound so that `--harmonics 1e12` is refused instead of computed.
pub const MAX_SUMMARY_HARMONICS: usize = 10_000;

/// `--harmonics` within [`MAX_SUMMARY_HARMONICS`].
pub fn check_harmonics(harmonics: usize) -> Result<(), String> {
    if harmonics > MAX_SUMMARY_HARMONICS {
        return Err(format!(
            "--harmonics = {harmonics}: more than the {MAX_SUMMARY_HARMONICS} the summary lists"
        ));
    }
    Ok(())
}

/// The files and summary of `geardyn stiffness`.
#[derive(Debug, Clone, Copy)]
pub struct StiffnessFiles<'a> {
    /// The CSV, one row per knot of the curve.
    pub out: &'a Path,
    /// The plot (PNG or SVG by the extension).
    pub plot: Option<&'a Path>,
    /// Fourier harmonics in the summary.
    pub harmonics: usize,
    /// No summary.
    pub quiet: bool,
    /// Units in the CSV header.
    pub units: bool,
    /// The per-tooth-pair curve of Model-1 (`[mesh.pairs] kind = "geometry"`), one row per
    /// knot, with the compliance terms.
    pub pairs: Option<&'a Path>,
}

/// `geardyn stiffness`: the curve of the gears file at pinion torque `torque` to the CSV (and
/// the plot), and the summary (empty with `quiet`).
pub fn stiffness_command(
    gears: &Path,
    torque: f64,
    etc: bool,
    files: &StiffnessFiles,
) -> Result<String, String> {
    check_harmonics(files.harmonics)?;
    let st = stiffness(gears, torque, etc)?;
    let names = st.columns();
    let rows = st.rows();
    crate::output::write_table_with_units(
        files.out,
        &names,
        rows.iter().map(|r| r.iter().copied()),
        files.units,
    )?;
    if let Some(path) = files.plot {
        st.plot(path)?;
    }
    if let Some(path) = files.pairs {
        st.write_pairs(path, torque, etc)?;
    }
    if files.quiet {
        return Ok(String::new());
    }
    Ok(format!(
        "{}curve → {}\n",
        st.summary(files.harmonics),
        files.out.display()
    ))
}
