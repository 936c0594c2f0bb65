//! Heatmaps (waterfall / Campbell diagrams): a value over two axes as colour, with a colour
//! bar in dB and order lines overlaid (`f = o·rpm/60` over frequency, vertical over order).

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::font::FAMILY;
use super::line::Area;
use super::{drawing, output, render_with, Format, SIZE};

/// Most columns drawn per row: wider maps are reduced by taking each group's largest value (a
/// peak stays visible), which keeps the SVG small.
const MAX_COLUMNS: usize = 480;
/// Default colour range below the largest value, dB.
pub const DYNAMIC_RANGE_DB: f64 = 60.0;
/// Width of the colour bar's strip (bar, ticks and title), px.
const BAR_STRIP: u32 = 110;

/// `values[row][col]` at `x[col]` (frequency, Hz) and `y[row]` (speed, rpm), colour in dB
/// relative to the largest value shown; `lines` are (label, order): `x = order·y/60`, or
/// `x = order` with `order_axis`.
pub struct Heatmap<'a> {
    pub title: &'a str,
    pub x: &'a [f64],
    pub y: &'a [f64],
    pub values: &'a [Vec<f64>],
    pub lines: Vec<(String, f64)>,
    /// The x axis in orders (`x·60/y`, cycles per revolution) instead of frequency.
    pub order_axis: bool,
    /// The x range drawn (Hz, or orders with `order_axis`); `None`: all of it.
    pub x_range: Option<(f64, f64)>,
    /// Colour range below the largest value shown, dB.
    pub dynamic_range: f64,
    /// The values' unit (the colour bar's reference: `dB re 12.3 µm`).
    pub unit: &'a str,
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
        if !(self.dynamic_range.is_finite() && self.dynamic_range > 0.0) {
            return Err(format!(
                "--dynamic-range = {}: must be a positive number of dB",
                self.dynamic_range
            ));
        }
        let bytes = render_with(Format::of(path)?, SIZE, |area| match area {
            Area::Bitmap(a) => self.draw_on(a),
            Area::Svg(a) => self.draw_on(a),
        })?;
        output::write_bytes(path, &bytes)
    }

    /// The x coordinate of column `c` in row `r`.
    fn x_at(&self, r: usize, x: f64) -> f64 {
        if self.order_axis && self.y[r] > 0.0 {
            x * 60.0 / self.y[r]
        } else if self.order_axis {
            f64::NAN
        } else {
            x
        }
    }

    /// The drawn x range: the requested one, else all the map covers.
    fn x_limits(&self, dx: f64) -> (f64, f64) {
        if let Some(r) = self.x_range {
            return r;
        }
        let last = self.x[self.x.len() - 1] + dx;
        if !self.order_axis {
            return (self.x[0], last);
        }
        let hi = (0..self.y.len())
            .map(|r| self.x_at(r, last))
            .filter(|v| v.is_finite())
            .fold(0.0, f64::max);
        (0.0, hi)
    }

    fn draw_on<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let (map_area, bar_area) = root.split_horizontally(SIZE.0 - BAR_STRIP);
        let group = self.x.len().div_ceil(MAX_COLUMNS);
        let dx = (self.x[1] - self.x[0]) * group as f64;
        let (x0, x1) = self.x_limits(dx);
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
        // The colour scale is relative to the largest value shown (in the x range).
        let inside = |r: usize, c: usize| {
            let v = self.x_at(r, self.x[c]);
            v >= x0 && v <= x1
        };
        let peak = (0..self.values.len())
            .flat_map(|r| (0..self.values[r].len()).map(move |c| (r, c)))
            .filter(|&(r, c)| inside(r, c))
            .fold(0.0, |m: f64, (r, c)| m.max(self.values[r][c]));
        let mut chart = ChartBuilder::on(&map_area)
            .caption(self.title, (FAMILY, 22))
            .margin(16)
            .x_label_area_size(50)
            .y_label_area_size(80)
            .build_cartesian_2d(x0..x1, (y_lo - half)..(y_hi + half))
            .map_err(drawing)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(if self.order_axis {
                "order (cycles per input revolution)"
            } else {
                "frequency (Hz)"
            })
            .y_desc("input speed (rpm)")
            .axis_desc_style((FAMILY, 16))
            .label_style((FAMILY, 13))
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| format!("{v:.0}"))
            .draw()
            .map_err(drawing)?;
        let range = self.dynamic_range;
        let cells = self.values.iter().enumerate().flat_map(|(r, row)| {
            (0..row.len().div_ceil(group)).filter_map(move |g| {
                let v = row[g * group..((g + 1) * group).min(row.len())]
                    .iter()
                    .fold(0.0, |m: f64, &v| m.max(v));
                let fa = self.x[0] + g as f64 * dx;
                let (xa, xb) = (self.x_at(r, fa), self.x_at(r, fa + dx));
                // Cells outside the range are not drawn (plotters would clip them, but an SVG
                // would still carry them).
                if !(xb > x0 && xa < x1) {
                    return None;
                }
                let yc = self.y[r];
                Some(Rectangle::new(
                    [(xa.max(x0), yc - half), (xb.min(x1), yc + half)],
                    colour(v, peak, range).filled(),
                ))
            })
        });
        chart.draw_series(cells).map_err(drawing)?;
        for (label, order) in &self.lines {
            let (ya, yb) = (0.0f64.max(y_lo - half), y_hi + half);
            let (xa, xb) = if self.order_axis {
                (*order, *order)
            } else {
                (order * ya / 60.0, order * yb / 60.0)
            };
            if xb < x0 || xa > x1 {
                continue;
            }
            // Cut the ray where it leaves the map (plotters would pull an outside end onto
            // the edge and bend the line).
            let (xb, yb) = if xb > x1 {
                (x1, 60.0 * x1 / order)
            } else {
                (xb, yb)
            };
            let (xa, ya) = if xa < x0 {
                (x0, 60.0 * x0 / order)
            } else {
                (xa, ya)
            };
            chart
                .draw_series(LineSeries::new([(xa, ya), (xb, yb)], WHITE.stroke_width(1)))
                .map_err(drawing)?;
            // The label just right of the line's top end, when that end is inside the map: on
            // the dark background beside the line, not on it.
            if yb >= y_hi + half && xb < x1 && xb >= x0 {
                let anchor = EmptyElement::at((xb, y_hi + half))
                    + Text::new(
                        label.clone(),
                        (4, 4),
                        (FAMILY, 13).into_font().color(&WHITE),
                    );
                chart.draw_series([anchor]).map_err(drawing)?;
            } else if xb >= x1 {
                // A ray that leaves through the right edge: its label above the exit, right
                // aligned inside the map (the ray runs lower to the left of it).
                let style = TextStyle::from((FAMILY, 13).into_font())
                    .color(&WHITE)
                    .pos(Pos::new(HPos::Right, VPos::Bottom));
                let anchor = EmptyElement::at((xb, yb)) + Text::new(label.clone(), (-4, -4), style);
                chart.draw_series([anchor]).map_err(drawing)?;
            }
        }
        draw_bar(&bar_area, peak, range, self.unit)
    }
}

/// The colour bar: the colour scale from −`range` dB to 0 dB re `peak`, with ticks every
/// 10 or 20 dB and the reference written out.
fn draw_bar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    peak: f64,
    range: f64,
    unit: &str,
) -> Result<(), String> {
    let title = format!("dB re {}", super::engineering(peak, unit));
    let mut chart = ChartBuilder::on(area)
        .margin_top(16 + 40)
        .margin_bottom(16 + 50)
        .margin_right(8)
        .y_label_area_size(44)
        .build_cartesian_2d(0.0..1.0, -range..0.0)
        .map_err(drawing)?;
    let step = if range > 80.0 { 20.0 } else { 10.0 };
    chart
        .configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_labels((range / step) as usize + 1)
        .y_label_formatter(&|v| format!("{v:.0}"))
        .label_style((FAMILY, 13))
        .draw()
        .map_err(drawing)?;
    let steps = 120;
    let strips = (0..steps).map(|k| {
        let a = -range + range * k as f64 / steps as f64;
        let b = -range + range * (k + 1) as f64 / steps as f64;
        let level = 10f64.powf(0.5 * (a + b) / 20.0);
        Rectangle::new([(0.0, a), (1.0, b)], colour(level, 1.0, range).filled())
    });
    chart.draw_series(strips).map_err(drawing)?;
    area.draw(&Text::new(
        title,
        (4, 24),
        (FAMILY, 13).into_font().color(&BLACK),
    ))
    .map_err(drawing)?;
    Ok(())
}

/// Dark blue (≤ −`range` dB) through teal and green to yellow (the largest value).
fn colour(v: f64, peak: f64, range: f64) -> RGBColor {
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
        -range
    };
    let s = ((db + range) / range).clamp(0.0, 1.0) * (STOPS.len() - 1) as f64;
    let i = (s.floor() as usize).min(STOPS.len() - 2);
    let f = s - i as f64;
    let mix = |a: u8, b: u8| (a as f64 + f * (b as f64 - a as f64)).round() as u8;
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}
