//! The Campbell diagram: natural frequencies as horizontal lines over the input speed, the
//! mesh and shaft orders as rays `f = o·n/60` from the origin, and each crossing (a critical
//! speed) marked and labelled with its speed. Speeds in rpm, with rad/s on the top axis.

use std::f64::consts::TAU;
use std::path::Path;

use plotters::coord::{CoordTranslate, Shift};
use plotters::prelude::*;

use super::font::FAMILY;
use super::line::{draw_legend, Area};
use super::{color, drawing, output, render_with, Format, SIZE};

/// A Campbell diagram.
pub struct Campbell<'a> {
    pub title: &'a str,
    /// Input-speed range, rpm.
    pub rpm: (f64, f64),
    /// (label, natural frequency in Hz) of each elastic mode.
    pub modes: Vec<(String, f64)>,
    /// (label, order in cycles per input revolution) of each ray.
    pub orders: Vec<(String, f64)>,
}

/// A label's pixel rectangle.
#[derive(Debug, Clone, Copy)]
struct Rect {
    left: i32,
    right: i32,
    top: i32,
    bottom: i32,
}

impl Rect {
    fn overlaps(&self, o: &Rect) -> bool {
        self.left < o.right && self.right > o.left && self.top < o.bottom && self.bottom > o.top
    }

    /// Whether the segment `a`–`b` passes through the rectangle (2 px of clearance).
    fn crosses(&self, a: (i32, i32), b: (i32, i32)) -> bool {
        let (l, r) = (self.left - 2, self.right + 2);
        let (t, btm) = (self.top - 2, self.bottom + 2);
        let (x_lo, x_hi) = (a.0.min(b.0), a.0.max(b.0));
        if x_hi < l || x_lo > r {
            return false;
        }
        let at = |x: i32| {
            if a.0 == b.0 {
                a.1 as f64
            } else {
                a.1 as f64 + (b.1 - a.1) as f64 * (x - a.0) as f64 / (b.0 - a.0) as f64
            }
        };
        let (xa, xb) = (l.max(x_lo), r.min(x_hi));
        let (ya, yb) = if a.0 == b.0 {
            (a.1.min(b.1) as f64, a.1.max(b.1) as f64)
        } else {
            (at(xa).min(at(xb)), at(xa).max(at(xb)))
        };
        yb >= t as f64 && ya <= btm as f64
    }
}

/// Approximate pixel width of `text` in DejaVu Sans at `size` px.
fn text_width(text: &str, size: i32) -> i32 {
    (0.58 * size as f64 * text.chars().count() as f64).ceil() as i32
}

/// One crossing of an order ray with a natural frequency.
#[derive(Debug, Clone, PartialEq)]
pub struct Crossing {
    pub order: usize,
    pub mode: usize,
    pub rpm: f64,
    pub frequency: f64,
}

const RAY_COLORS: [&str; 6] = [
    "#c0392b", "#2471a3", "#16a085", "#8e44ad", "#d68910", "#566573",
];

impl Campbell<'_> {
    /// The frequency range drawn: to 1.3 times the highest natural frequency, unless the rays
    /// end below that (without modes, to the highest ray's end).
    pub fn top(&self) -> f64 {
        let rays = (self.orders.iter())
            .map(|(_, o)| o * self.rpm.1 / 60.0)
            .fold(0.0, f64::max);
        let highest_mode = self.modes.iter().map(|m| m.1).fold(0.0, f64::max);
        if highest_mode > 0.0 {
            (1.3 * highest_mode)
                .min(1.05 * rays)
                .max(1.1 * highest_mode)
        } else {
            1.05 * rays
        }
    }

    /// Every crossing of a ray with a mode line inside the diagram, by speed.
    pub fn crossings(&self) -> Vec<Crossing> {
        let top = self.top();
        let mut out = Vec::new();
        for (i, (_, o)) in self.orders.iter().enumerate() {
            for (m, (_, f)) in self.modes.iter().enumerate() {
                let rpm = 60.0 * f / o;
                if *f <= top && rpm >= self.rpm.0 && rpm <= self.rpm.1 {
                    out.push(Crossing {
                        order: i,
                        mode: m,
                        rpm,
                        frequency: *f,
                    });
                }
            }
        }
        out.sort_by(|a, b| a.rpm.total_cmp(&b.rpm));
        out
    }

    /// Writes the diagram to `path` (PNG or SVG by its extension); nothing is written on error.
    pub fn save(&self, path: &Path) -> Result<(), String> {
        let (lo, hi) = self.rpm;
        if !(lo.is_finite() && hi.is_finite() && lo >= 0.0 && hi > lo) {
            return Err(format!(
                "Campbell diagram: speed range {lo}:{hi} rpm must be increasing and >= 0"
            ));
        }
        if self.orders.is_empty() {
            return Err("Campbell diagram: no order to draw".into());
        }
        let bytes = render_with(Format::of(path)?, SIZE, |area| match area {
            Area::Bitmap(a) => self.draw_on(a),
            Area::Svg(a) => self.draw_on(a),
        })?;
        output::write_bytes(path, &bytes)
    }

    fn draw_on<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let (x0, x1) = self.rpm;
        let top = self.top();
        // A band above the data for the legend (one row per ray), as in the line plots.
        let band = (self.orders.len() as f64 * 22.0 + 28.0) / 420.0;
        let y_top = top * (1.0 + band / (1.0 - band));
        let mut chart = ChartBuilder::on(root)
            .caption(self.title, (FAMILY, 22))
            .margin(16)
            .x_label_area_size(50)
            .top_x_label_area_size(40)
            .y_label_area_size(80)
            .build_cartesian_2d(x0..x1, 0.0..y_top)
            .map_err(drawing)?
            .set_secondary_coord(x0 * TAU / 60.0..x1 * TAU / 60.0, 0.0..y_top);
        chart
            .configure_mesh()
            .x_desc("input speed (rpm)")
            .y_desc("frequency (Hz)")
            .axis_desc_style((FAMILY, 16))
            .label_style((FAMILY, 13))
            .light_line_style(RGBColor(238, 238, 238))
            .max_light_lines(2)
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| format!("{v:.0}"))
            .draw()
            .map_err(drawing)?;
        chart
            .configure_secondary_axes()
            .x_desc("input speed (rad/s)")
            .axis_desc_style((FAMILY, 16))
            .label_style((FAMILY, 13))
            .x_label_formatter(&|v| format!("{v:.0}"))
            .draw()
            .map_err(drawing)?;
        let grey = RGBColor(90, 90, 90);
        // Everything drawn so far in pixels, for the labels to keep clear of: the rays and the
        // mode lines as segments, the labels as rectangles.
        let coord = chart.as_coord_spec().clone();
        let p = |x: f64, y: f64| coord.translate(&(x, y));
        let mut lines: Vec<((i32, i32), (i32, i32))> = Vec::new();
        for (_, o) in &self.orders {
            let end = (60.0 * top / o).min(x1);
            let start = x0.min(end);
            lines.push((p(start, o * start / 60.0), p(end, o * end / 60.0)));
        }
        for (_, f) in self.modes.iter().filter(|m| m.1 <= top) {
            lines.push((p(x0, *f), p(x1, *f)));
        }
        let (left_px, right_px) = (p(x0, 0.0).0, p(x1, 0.0).0);
        let (top_px, bottom_px) = (p(x0, top).1, p(x0, 0.0).1);
        let mut placed: Vec<Rect> = Vec::new();
        let free = |r: &Rect, placed: &[Rect]| {
            r.left >= left_px
                && r.right <= right_px
                && r.top >= top_px
                && r.bottom <= bottom_px
                && !placed.iter().any(|q| q.overlaps(r))
                && !lines.iter().any(|&(a, b)| r.crosses(a, b))
        };
        // Mode lines closer than a label's height share one label: `modes 2–4: 446, 499, 641 Hz`.
        let mut drawn_modes: Vec<(usize, f64)> = (self.modes.iter().enumerate())
            .filter(|(_, m)| m.1 <= top)
            .map(|(i, m)| (i, m.1))
            .collect();
        drawn_modes.sort_by(|a, b| a.1.total_cmp(&b.1));
        let mut groups: Vec<Vec<(usize, f64)>> = Vec::new();
        for m in drawn_modes {
            match groups.last_mut() {
                Some(g) if p(x0, g[g.len() - 1].1).1 - p(x0, m.1).1 < 16 => g.push(m),
                _ => groups.push(vec![m]),
            }
        }
        for (_, f) in self.modes.iter().filter(|m| m.1 <= top) {
            chart
                .draw_series(DashedLineSeries::new(
                    [(x0, *f), (x1, *f)],
                    6,
                    4,
                    grey.stroke_width(1),
                ))
                .map_err(drawing)?;
        }
        for g in &groups {
            let text = if g.len() == 1 {
                self.modes[g[0].0].0.clone()
            } else {
                format!(
                    "modes {}–{}: {} Hz",
                    g[0].0 + 1,
                    g[g.len() - 1].0 + 1,
                    g.iter()
                        .map(|m| format!("{:.0}", m.1))
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            };
            let width = text_width(&text, 13);
            // Above the group's highest line (or below its lowest), at the right end or the
            // left, wherever nothing else is.
            let (hi, lo) = (p(x0, g[g.len() - 1].1).1, p(x0, g[0].1).1);
            let candidates = [
                Rect {
                    left: right_px - 4 - width,
                    right: right_px - 4,
                    top: hi - 18,
                    bottom: hi - 3,
                },
                Rect {
                    left: left_px + 4,
                    right: left_px + 4 + width,
                    top: hi - 18,
                    bottom: hi - 3,
                },
                Rect {
                    left: right_px - 4 - width,
                    right: right_px - 4,
                    top: lo + 3,
                    bottom: lo + 18,
                },
                Rect {
                    left: left_px + 4,
                    right: left_px + 4 + width,
                    top: lo + 3,
                    bottom: lo + 18,
                },
            ];
            if let Some(r) = candidates.into_iter().find(|r| free(r, &placed)) {
                placed.push(r);
                root.draw(&Text::new(
                    text,
                    (
                        r.left - root.get_base_pixel().0,
                        r.top + 1 - root.get_base_pixel().1,
                    ),
                    (FAMILY, 13).into_font().color(&grey),
                ))
                .map_err(drawing)?;
            }
        }
        for (i, (label, o)) in self.orders.iter().enumerate() {
            let c = color(RAY_COLORS[i % RAY_COLORS.len()])?;
            // The ray ends at the top of the data, below the legend band.
            let end = (60.0 * top / o).min(x1);
            let start = x0.min(end);
            chart
                .draw_series(LineSeries::new(
                    [(start, o * start / 60.0), (end, o * end / 60.0)],
                    c.stroke_width(2),
                ))
                .map_err(drawing)?
                .label(label.clone())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2))
                });
        }
        // Crossings: a circle each; the speed written beside it where it touches no line and
        // no other label (first the crossings of the lowest orders, the strongest lines).
        let mut crossings = self.crossings();
        for cross in &crossings {
            let (cx, cy) = p(cross.rpm, cross.frequency);
            placed.push(Rect {
                left: cx - 6,
                right: cx + 6,
                top: cy - 6,
                bottom: cy + 6,
            });
        }
        crossings.sort_by(|a, b| {
            a.order
                .cmp(&b.order)
                .then(b.frequency.total_cmp(&a.frequency))
        });
        for cross in &crossings {
            let c = color(RAY_COLORS[cross.order % RAY_COLORS.len()])?;
            chart
                .draw_series([Circle::new(
                    (cross.rpm, cross.frequency),
                    5,
                    c.stroke_width(2),
                )])
                .map_err(drawing)?;
            let text = format!("{:.0} rpm", cross.rpm);
            let (w, h) = (text_width(&text, 12), 14);
            let (cx, cy) = p(cross.rpm, cross.frequency);
            let candidates = [
                Rect {
                    left: cx + 7,
                    right: cx + 7 + w,
                    top: cy + 4,
                    bottom: cy + 4 + h,
                },
                Rect {
                    left: cx - 7 - w,
                    right: cx - 7,
                    top: cy - 4 - h,
                    bottom: cy - 4,
                },
                Rect {
                    left: cx + 7,
                    right: cx + 7 + w,
                    top: cy - 4 - h,
                    bottom: cy - 4,
                },
                Rect {
                    left: cx - 7 - w,
                    right: cx - 7,
                    top: cy + 4,
                    bottom: cy + 4 + h,
                },
            ];
            // Its own circle is not in the way.
            let others: Vec<Rect> = (placed.iter())
                .filter(|q| !(q.left == cx - 6 && q.top == cy - 6))
                .copied()
                .collect();
            if let Some(r) = candidates.into_iter().find(|r| free(r, &others)) {
                placed.push(r);
                root.draw(&Text::new(
                    text,
                    (
                        r.left - root.get_base_pixel().0,
                        r.top + 1 - root.get_base_pixel().1,
                    ),
                    (FAMILY, 12).into_font().color(&c),
                ))
                .map_err(drawing)?;
            }
        }
        draw_legend(&mut chart, SeriesLabelPosition::UpperLeft)?;
        Ok(())
    }
}
