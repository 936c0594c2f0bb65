//! Heatmaps (waterfall / Campbell diagrams): a value over two axes as colour, with straight
//! lines through the origin overlaid (order lines `f = o·rpm/60`).

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::font::FAMILY;
use super::line::Area;
use super::{drawing, output, render_with, Format, SIZE};

/// Most columns drawn: wider maps are reduced by taking each group's largest value (a peak
/// stays visible), which keeps the SVG small.
const MAX_COLUMNS: usize = 480;
/// Colour range below the largest value, dB.
const DYNAMIC_RANGE_DB: f64 = 60.0;

/// `values[row][col]` at `x[col]` (frequency, Hz) and `y[row]` (speed, rpm), colour in dB
/// relative to the largest value; `lines` are (label, order): `x = order·y/60`.
pub struct Heatmap<'a> {
    pub title: &'a str,
    pub x: &'a [f64],
    pub y: &'a [f64],
    pub values: &'a [Vec<f64>],
    pub lines: Vec<(String, f64)>,
}

impl Heatmap<'_> {
    /// Writes the map to `path` (PNG or SVG by its extension); nothing is written on error.
    pub fn save(&self, path: &Path) -> Result<(), String> {
        if self.y.is_empty() || self.x.len() < 2 || self.values.len() != self.y.len() {
            return Err(format!(
                "heatmap: {} rows of values for {} speeds and {} frequencies",
                self.values.len(),
                self.y.len(),
                self.x.len()
            ));
        }
        let bytes = render_with(Format::of(path)?, SIZE, |area| match area {
            Area::Bitmap(a) => self.draw_on(a),
            Area::Svg(a) => self.draw_on(a),
        })?;
        output::write_bytes(path, &bytes)
    }

    fn draw_on<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let group = self.x.len().div_ceil(MAX_COLUMNS);
        let dx = (self.x[1] - self.x[0]) * group as f64;
        let x0 = self.x[0];
        let x1 = self.x[self.x.len() - 1] + dx;
        let (y_lo, y_hi) = self
            .y
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            });
        // Each row spans halfway to its neighbours.
        let half = if self.y.len() > 1 {
            0.5 * (y_hi - y_lo) / (self.y.len() - 1) as f64
        } else {
            1.0
        };
        let peak = self
            .values
            .iter()
            .flatten()
            .fold(0.0, |m: f64, &v| m.max(v));
        let mut chart = ChartBuilder::on(root)
            .caption(self.title, (FAMILY, 22))
            .margin(16)
            .x_label_area_size(50)
            .y_label_area_size(80)
            .build_cartesian_2d(x0..x1, (y_lo - half)..(y_hi + half))
            .map_err(drawing)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("frequency (Hz)")
            .y_desc("speed (rpm)")
            .axis_desc_style((FAMILY, 16))
            .label_style((FAMILY, 13))
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| format!("{v:.0}"))
            .draw()
            .map_err(drawing)?;
        let cells = self.values.iter().enumerate().flat_map(|(r, row)| {
            (0..row.len().div_ceil(group)).map(move |g| {
                let v = row[g * group..((g + 1) * group).min(row.len())]
                    .iter()
                    .fold(0.0, |m: f64, &v| m.max(v));
                let xa = x0 + g as f64 * dx;
                let yc = self.y[r];
                Rectangle::new(
                    [(xa, yc - half), (xa + dx, yc + half)],
                    colour(v, peak).filled(),
                )
            })
        });
        chart.draw_series(cells).map_err(drawing)?;
        for (label, order) in &self.lines {
            let (ya, yb) = (0.0f64.max(y_lo - half), y_hi + half);
            let points = [(order * ya / 60.0, ya), (order * yb / 60.0, yb)];
            chart
                .draw_series(LineSeries::new(points, WHITE.stroke_width(1)))
                .map_err(drawing)?;
            // The label at the top end of the line when that end is inside the map.
            let xt = order * (y_hi + half) / 60.0;
            if xt < x1 {
                chart
                    .draw_series([Text::new(
                        label.clone(),
                        (xt, y_hi),
                        (FAMILY, 13).into_font().color(&WHITE),
                    )])
                    .map_err(drawing)?;
            }
        }
        Ok(())
    }
}

/// Dark blue (≤ −60 dB) through teal and green to yellow (the largest value).
fn colour(v: f64, peak: f64) -> RGBColor {
    const STOPS: [(u8, u8, u8); 5] = [
        (20, 20, 70),
        (40, 70, 140),
        (30, 140, 140),
        (90, 190, 90),
        (250, 230, 40),
    ];
    let db = if v > 0.0 && peak > 0.0 {
        20.0 * (v / peak).log10()
    } else {
        -DYNAMIC_RANGE_DB
    };
    let s = ((db + DYNAMIC_RANGE_DB) / DYNAMIC_RANGE_DB).clamp(0.0, 1.0) * (STOPS.len() - 1) as f64;
    let i = (s.floor() as usize).min(STOPS.len() - 2);
    let f = s - i as f64;
    let mix = |a: u8, b: u8| (a as f64 + f * (b as f64 - a as f64)).round() as u8;
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}
