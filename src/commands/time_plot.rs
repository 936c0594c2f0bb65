//! `geardyn simulate --plot`: every mesh's DTE and mesh force over time, DTE above force.
//!
//! The plot reads back the CSV the run wrote, so the run itself stays streamed with flat
//! memory. A run with more rows than the plot has pixel columns is drawn as its minimum and
//! maximum per column (an envelope), which keeps every peak a decimation would lose.

use std::path::Path;

use super::simulate_run::{for_each_row, SimulateReport};
use crate::plot::{save_stacked, Axis, Plot, Series};

/// Columns of the envelope: about one per pixel of the plot area.
const BUCKETS: u64 = 800;

const COLORS: [&str; 6] = [
    "#1f4e9c", "#c0392b", "#2e8b57", "#8e44ad", "#e67e22", "#16a085",
];

/// One plotted signal, as (time, value) points: raw rows, or min/max pairs per bucket.
struct Trace {
    column: usize,
    points: Vec<(f64, f64)>,
    bucket: Option<(u64, f64, f64, f64)>,
}

impl Trace {
    fn add(&mut self, bucket: u64, t: f64, v: f64, raw: bool) {
        if raw {
            self.points.push((t, v));
            return;
        }
        match &mut self.bucket {
            Some((b, _, lo, hi)) if *b == bucket => {
                *lo = lo.min(v);
                *hi = hi.max(v);
            }
            _ => {
                self.flush();
                self.bucket = Some((bucket, t, v, v));
            }
        }
    }

    fn flush(&mut self) {
        if let Some((_, t, lo, hi)) = self.bucket.take() {
            self.points.push((t, lo));
            self.points.push((t, hi));
        }
    }
}

/// Draws the DTE and force of every mesh of the run `report` wrote to `csv` into `path` (PNG
/// or SVG by its extension).
pub fn time_plot(report: &SimulateReport, csv: &Path, path: &Path) -> Result<(), String> {
    let mut traces: Vec<Trace> = report
        .meshes
        .iter()
        .flat_map(|m| [m.dte_column, m.force_column])
        .map(|column| Trace {
            column,
            points: Vec::new(),
            bucket: None,
        })
        .collect();
    let raw = report.rows <= 2 * BUCKETS;
    for_each_row(csv, |i, fields| {
        let bucket = i * BUCKETS / report.rows.max(1);
        let t = fields.first().copied().unwrap_or(f64::NAN);
        for trace in &mut traces {
            let v = fields.get(trace.column).copied().unwrap_or(f64::NAN);
            trace.add(bucket, t, v, raw);
        }
    })?;
    traces.iter_mut().for_each(Trace::flush);

    let name = |n: usize| {
        let m = &report.meshes[n].name;
        if report.pair {
            String::new()
        } else {
            m.clone()
        }
    };
    let labels: Vec<String> = (0..report.meshes.len()).map(name).collect();
    let series = |offset: usize| -> Vec<Series> {
        traces
            .iter()
            .skip(offset)
            .step_by(2)
            .enumerate()
            .map(|(n, trace)| Series {
                label: &labels[n],
                color: COLORS[n % COLORS.len()],
                points: trace.points.clone(),
                dashed: false,
                markers: false,
                line: true,
            })
            .collect()
    };
    let dte_title = format!("{}: dynamic transmission error", report.scene);
    let force_title = format!("{}: dynamic mesh force", report.scene);
    let plots = [
        Plot {
            title: &dte_title,
            x: Axis::new("time", "s"),
            y: Axis::new("DTE", "m"),
            series: series(0),
            bands: Vec::new(),
            band_label: "",
            markers: Vec::new(),
        },
        Plot {
            title: &force_title,
            x: Axis::new("time", "s"),
            y: Axis::new("mesh force", "N"),
            series: series(1),
            bands: Vec::new(),
            band_label: "",
            markers: Vec::new(),
        },
    ];
    save_stacked(&plots, path)
}
