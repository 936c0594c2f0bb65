//! Line spectra as stems: one vertical line per spectral line from the bottom of the axis to
//! its amplitude, on a log or dB axis, with the largest lines labelled above their tops where
//! the label touches no stem.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::font::FAMILY;
use super::line::{draw_legend, Area};
use super::{color, drawing, output, render_with, Format, SIZE};

/// One signal's lines.
pub struct StemSeries<'a> {
    pub label: &'a str,
    /// `#rrggbb`.
    pub color: &'a str,
    /// (x, value): value in the y axis' units (amplitude, or dB with `db`).
    pub points: Vec<(f64, f64)>,
    /// Text for the largest lines, by index into `points` (`None`: unnamed).
    pub names: Vec<Option<String>>,
}

/// A stem plot.
pub struct Stems<'a> {
    pub title: &'a str,
    /// x axis title with its unit, e.g. `frequency (Hz)`.
    pub x_title: &'a str,
    /// y axis title with its unit.
    pub y_title: &'a str,
    pub x_range: (f64, f64),
    /// The y axis is a level in dB (linear axis) rather than an amplitude (log axis).
    pub db: bool,
    /// The bottom of the y axis (the stems' foot).
    pub y_floor: f64,
    pub series: Vec<StemSeries<'a>>,
    /// How many of the largest lines of each series get their name.
    pub labelled: usize,
}

/// Approximate advance of one 12 px DejaVu Sans character, px.
const CHAR_PX: i32 = 7;
const LABEL_PX: i32 = 14;

impl Stems<'_> {
    /// Writes the plot to `path` (PNG or SVG by its extension); nothing is written on error.
    pub fn save(&self, path: &Path) -> Result<(), String> {
        let bytes = render_with(Format::of(path)?, SIZE, |area| match area {
            Area::Bitmap(a) => self.draw_on(a),
            Area::Svg(a) => self.draw_on(a),
        })?;
        output::write_bytes(path, &bytes)
    }

    fn draw_on<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let (x0, x1) = self.x_range;
        let in_range = |x: f64| x >= x0 && x <= x1;
        let y_max = (self.series.iter())
            .flat_map(|s| s.points.iter())
            .filter(|p| in_range(p.0))
            .map(|p| p.1)
            .fold(f64::NEG_INFINITY, f64::max);
        let y_max = if y_max.is_finite() {
            y_max
        } else {
            self.y_floor + 1.0
        };
        let rows = self.series.len() as i32;
        // Headroom above the largest stem for its label, and a band for the legend.
        let legend_px = 22 * rows + 28;
        let head_px = 2 * LABEL_PX + 12 + legend_px;
        let plot_px = SIZE.1 as i32 - 40 - 32 - 50;
        let grow = f64::from(head_px) / f64::from(plot_px - head_px);
        if self.db {
            let top = y_max + (y_max - self.y_floor) * grow;
            let chart = ChartBuilder::on(root)
                .caption(self.title, (FAMILY, 22))
                .margin(16)
                .x_label_area_size(50)
                .y_label_area_size(80)
                .build_cartesian_2d(x0..x1, self.y_floor..top)
                .map_err(drawing)?;
            self.finish(chart)
        } else {
            let top = y_max * (y_max / self.y_floor).powf(grow);
            let chart = ChartBuilder::on(root)
                .caption(self.title, (FAMILY, 22))
                .margin(16)
                .x_label_area_size(50)
                .y_label_area_size(80)
                .build_cartesian_2d(x0..x1, (self.y_floor..top).log_scale())
                .map_err(drawing)?;
            self.finish(chart)
        }
    }

    fn finish<'c, DB, Y>(
        &self,
        mut chart: ChartContext<'c, DB, Cartesian2d<plotters::coord::types::RangedCoordf64, Y>>,
    ) -> Result<(), String>
    where
        DB: DrawingBackend + 'c,
        Y: Ranged<ValueType = f64> + plotters::coord::ranged1d::ValueFormatter<f64>,
    {
        let (x0, x1) = self.x_range;
        chart
            .configure_mesh()
            .x_desc(self.x_title)
            .y_desc(self.y_title)
            .axis_desc_style((FAMILY, 16))
            .label_style((FAMILY, 13))
            .light_line_style(RGBColor(238, 238, 238))
            .max_light_lines(2)
            .x_label_formatter(&|v| super::line::tick(*v))
            .y_label_formatter(&|v| super::line::tick(*v))
            .draw()
            .map_err(drawing)?;
        let floor = self.y_floor;
        // Signals side by side: each series' stems 4 px apart, so that none hides another.
        let px_width = {
            let (a, b) = (
                chart.backend_coord(&(x0, floor)).0,
                chart.backend_coord(&(x1, floor)).0,
            );
            (x1 - x0) / f64::from((b - a).max(1))
        };
        let n = self.series.len() as f64;
        let shift = |i: usize| (i as f64 - 0.5 * (n - 1.0)) * 4.0 * px_width;
        // Every stem's pixel column and top, for the labels to avoid.
        let mut tops: Vec<(i32, i32)> = Vec::new();
        for (i, s) in self.series.iter().enumerate() {
            let c = color(s.color)?;
            let dx = shift(i);
            let stems: Vec<(f64, f64)> = (s.points.iter())
                .filter(|p| p.0 >= x0 && p.0 <= x1 && p.1 > floor)
                .map(|p| (p.0 + dx, p.1))
                .collect();
            for p in &stems {
                let (px, py) = chart.backend_coord(&(p.0, p.1));
                tops.push((px, py));
            }
            let drawn =
                chart
                    .draw_series(stems.iter().map(|p| {
                        PathElement::new(vec![(p.0, floor), (p.0, p.1)], c.stroke_width(2))
                    }))
                    .map_err(drawing)?;
            drawn.label(s.label).legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2))
            });
            chart
                .draw_series(stems.iter().map(|p| Circle::new((p.0, p.1), 3, c.filled())))
                .map_err(drawing)?;
        }
        // Labels: the largest lines first, centred above the stem; raised above every stem the
        // text would cross, and dropped if it would overlap a label already placed.
        let mut placed: Vec<(i32, i32, i32, i32)> = Vec::new();
        let mut named: Vec<(String, i32)> = Vec::new();
        // Labels stay below the legend's band.
        let legend_px = 22 * self.series.len() as i32 + 28;
        let area_top = chart.plotting_area().get_pixel_range().1.start + legend_px;
        for s in &self.series {
            let c = color(s.color)?;
            let mut order: Vec<usize> = (0..s.points.len())
                .filter(|&i| s.names[i].is_some() && s.points[i].0 >= x0 && s.points[i].0 <= x1)
                .collect();
            order.sort_by(|&a, &b| s.points[b].1.total_cmp(&s.points[a].1));
            for &i in order.iter().take(self.labelled) {
                let text = s.names[i].clone().unwrap_or_default();
                let (px, py) = chart.backend_coord(&s.points[i]);
                // A line another signal already named at the same place needs no second name.
                if named.iter().any(|(t, x)| *t == text && (x - px).abs() <= 6) {
                    continue;
                }
                let half = CHAR_PX * text.chars().count() as i32 / 2 + 2;
                let (left, right) = (px - half, px + half);
                // The bottom of the text: 4 px above the highest stem or marker under it.
                let bottom = tops
                    .iter()
                    .filter(|(x, _)| *x >= left - 4 && *x <= right + 4)
                    .map(|(_, y)| *y)
                    .min()
                    .unwrap_or(py)
                    .min(py)
                    - 6;
                let top = bottom - LABEL_PX;
                let clash = placed
                    .iter()
                    .any(|&(l, t, r, b)| left < r && right > l && top < b && bottom > t);
                if top < area_top || clash {
                    continue;
                }
                placed.push((left, top, right, bottom));
                named.push((text.clone(), px));
                let style = TextStyle::from((FAMILY, 12).into_font())
                    .color(&c)
                    .pos(Pos::new(HPos::Center, VPos::Bottom));
                chart
                    .draw_series([
                        EmptyElement::at(s.points[i]) + Text::new(text, (0, bottom - py), style)
                    ])
                    .map_err(drawing)?;
            }
        }
        draw_legend(&mut chart, SeriesLabelPosition::UpperRight)?;
        Ok(())
    }
}
