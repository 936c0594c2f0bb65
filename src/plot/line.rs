//! Line plots on any plotters backend.

use plotters::chart::SeriesAnno;
use plotters::coord::ranged1d::ValueFormatter;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::font::FAMILY;
use super::{color, drawing, Marker, Plot};

/// The drawing area of the image being rendered.
pub enum Area<'b> {
    Bitmap(DrawingArea<BitMapBackend<'b>, Shift>),
    Svg(DrawingArea<SVGBackend<'b>, Shift>),
}

/// Draws `plots` stacked top to bottom, each in an equal share of the area.
pub fn draw(plots: &[Plot], area: &Area) -> Result<(), String> {
    match area {
        Area::Bitmap(a) => stacked(plots, a),
        Area::Svg(a) => stacked(plots, a),
    }
}

fn stacked<DB: DrawingBackend>(
    plots: &[Plot],
    root: &DrawingArea<DB, Shift>,
) -> Result<(), String> {
    for (plot, area) in plots.iter().zip(root.split_evenly((plots.len(), 1))) {
        draw_on(plot, &area)?;
    }
    Ok(())
}

/// Height of one legend row and the legend's padding, px.
const LEGEND_ROW: f64 = 22.0;
const LEGEND_PAD: f64 = 28.0;
const CAPTION: u32 = 40;
const MARGIN: u32 = 16;
const X_LABELS: u32 = 50;
const Y_LABELS: u32 = 80;

/// `[lo, hi]` of the finite values, padded by 3 % (or a unit around a single value).
fn range(values: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && (!log || *v > 0.0))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if !lo.is_finite() {
        return if log { (1.0, 10.0) } else { (0.0, 1.0) };
    }
    if log {
        let (lo, hi) = if hi > lo {
            (lo, hi)
        } else {
            (lo / 2.0, hi * 2.0)
        };
        let pad = (hi / lo).powf(0.03);
        return (lo / pad, hi * pad);
    }
    if hi > lo {
        let pad = 0.03 * (hi - lo);
        (lo - pad, hi + pad)
    } else {
        let pad = if lo == 0.0 { 1.0 } else { 0.1 * lo.abs() };
        (lo - pad, hi + pad)
    }
}

/// A tick label with no trailing zeros (`3600`, `0.25`, `1.5e-7`).
pub(crate) fn tick(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    if v.abs() >= 1e6 || v.abs() < 1e-3 {
        return format!("{v:.1e}");
    }
    let s = format!("{v:.6}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// The finite runs of `points` (a NaN breaks a curve: a failed sweep point).
fn runs(points: &[(f64, f64)], log_y: bool, sx: f64, sy: f64) -> Vec<Vec<(f64, f64)>> {
    let mut out = vec![Vec::new()];
    for &(x, y) in points {
        if x.is_finite() && y.is_finite() && (!log_y || y > 0.0) {
            out.last_mut().expect("one run").push((x * sx, y * sy));
        } else if !out.last().expect("one run").is_empty() {
            out.push(Vec::new());
        }
    }
    out.retain(|r| !r.is_empty());
    out
}

/// A pixel rectangle a label occupies.
#[derive(Debug, Clone, Copy)]
struct Span {
    left: i32,
    right: i32,
    top: i32,
    bottom: i32,
}

/// Pixel length of a 13 px label (DejaVu Sans averages under 6.3 px a character).
fn label_length(label: &str) -> i32 {
    (6.3 * label.chars().count() as f64).ceil() as i32 + 6
}

/// The bottom of the lowest stretch of `length` px in the pixel column `[a, b]` between
/// `top` and `bottom` that no curve segment (with 3 px of clearance) and no label crosses.
fn free_stretch(
    curves: &[Vec<(i32, i32)>],
    taken: &[Span],
    (a, b): (i32, i32),
    (top, bottom): (i32, i32),
    length: i32,
) -> Option<i32> {
    let mut busy: Vec<(i32, i32)> = Vec::new();
    for run in curves {
        for (i, &(x, y)) in run.iter().enumerate() {
            // Each point (a marker circle) and each segment through the column.
            if x >= a - 4 && x <= b + 4 {
                busy.push((y - 5, y + 5));
            }
            if let Some(&(xn, yn)) = run.get(i + 1) {
                let (lo, hi) = (x.min(xn), x.max(xn));
                if hi < a || lo > b {
                    continue;
                }
                // The segment's y over the column's part of its x span.
                let at = |xc: i32| {
                    if xn == x {
                        y as f64
                    } else {
                        y as f64 + (yn - y) as f64 * (xc - x) as f64 / (xn - x) as f64
                    }
                };
                let (ca, cb) = (a.max(lo), b.min(hi));
                let (ya, yb) = (at(ca), at(cb));
                let (ya, yb) = if xn == x {
                    (y.min(yn) as f64, y.max(yn) as f64)
                } else {
                    (ya, yb)
                };
                busy.push((ya.min(yb).floor() as i32 - 3, ya.max(yb).ceil() as i32 + 3));
            }
        }
    }
    for t in taken {
        if t.left < b && t.right > a {
            busy.push((t.top - 2, t.bottom + 2));
        }
    }
    // Scan from the bottom up for the first gap of `length`.
    let mut floor = bottom - 6;
    let mut intervals = busy;
    intervals.sort_by_key(|iv| std::cmp::Reverse(iv.1));
    loop {
        // The busy interval that reaches lowest above `floor` and overlaps [floor - length, floor].
        let blocking = intervals
            .iter()
            .filter(|(t, bt)| *bt >= floor - length && *t <= floor)
            .map(|(t, _)| *t)
            .min();
        match blocking {
            None => return (floor - length >= top).then_some(floor),
            Some(t) => {
                floor = t - 1;
                if floor - length < top {
                    return None;
                }
            }
        }
    }
}

/// The input speed in rad/s above the plot, beside the rpm of the x axis: ticks at round
/// values of rad/s along the plotting area's top edge.
fn rad_per_s_ticks<'c, DB, Y>(
    chart: &ChartContext<'c, DB, Cartesian2d<plotters::coord::types::RangedCoordf64, Y>>,
    (x0, x1): (f64, f64),
    y_any: f64,
) -> Result<(), String>
where
    DB: DrawingBackend + 'c,
    Y: Ranged<ValueType = f64>,
{
    let to_w = std::f64::consts::TAU / 60.0;
    let (w0, w1) = (x0 * to_w, x1 * to_w);
    let span = w1 - w0;
    if !(span > 0.0) {
        return Ok(());
    }
    let raw = span / 6.0;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|f| f * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag);
    let grey = RGBColor(90, 90, 90);
    let area = chart.plotting_area().strip_coord_spec();
    let (base_x, _) = area.get_base_pixel();
    let style = TextStyle::from((FAMILY, 12).into_font())
        .color(&grey)
        .pos(Pos::new(HPos::Center, VPos::Bottom));
    let mut w = (w0 / step).ceil() * step;
    while w <= w1 + 1e-9 * span {
        let px = chart.backend_coord(&(w / to_w, y_any)).0 - base_x;
        area.draw(&PathElement::new(
            vec![(px, 0), (px, 5)],
            grey.stroke_width(1),
        ))
        .map_err(drawing)?;
        area.draw(&Text::new(
            format!("{} rad/s", tick(w)),
            (px, -2),
            style.clone(),
        ))
        .map_err(drawing)?;
        w += step;
    }
    Ok(())
}

fn draw_on<DB: DrawingBackend>(plot: &Plot, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
    let all = || plot.series.iter().flat_map(|s| s.points.iter());
    let (x0, x1) = range(
        all()
            .map(|p| p.0)
            .chain(plot.bands.iter().flat_map(|b| [b.0, b.1]))
            .chain(plot.markers.iter().map(|m| m.x)),
        false,
    );
    let (y0, y1) = range(all().map(|p| p.1), plot.y.log);
    let (sx, x_title) = plot.x.scaled(x0.abs().max(x1.abs()));
    let (sy, y_title) = plot.y.scaled(y0.abs().max(y1.abs()));
    let (x0, x1, y0, y1) = (x0 * sx, x1 * sx, y0 * sy, y1 * sy);

    // The legend gets a band of its own above the data, so it never hides a curve.
    let rows = plot.series.iter().filter(|s| !s.label.is_empty()).count()
        + usize::from(!plot.bands.is_empty());
    // An rpm axis gets its rad/s ticks above the plot: room for them below the title.
    let top_ticks = if plot.x.unit == "rpm" { 24 } else { 0 };
    let area_height = (root.dim_in_pixel().1 - CAPTION - 2 * MARGIN - X_LABELS - top_ticks) as f64;
    let share = if rows == 0 {
        0.0
    } else {
        ((rows as f64 * LEGEND_ROW + LEGEND_PAD) / area_height).min(0.6)
    };
    let grow = share / (1.0 - share);
    let y_top = if plot.y.log {
        y1 * (y1 / y0).powf(grow)
    } else {
        y1 + (y1 - y0) * grow
    };

    // With the rad/s ticks: the title first, then a strip for the ticks, then the chart.
    let body = if top_ticks > 0 {
        let below = root.titled(plot.title, (FAMILY, 22)).map_err(drawing)?;
        below.split_vertically(top_ticks).1
    } else {
        root.clone()
    };
    let mut builder = ChartBuilder::on(&body);
    if top_ticks == 0 {
        builder.caption(plot.title, (FAMILY, 22));
    }
    builder
        .margin(MARGIN)
        .x_label_area_size(X_LABELS)
        .y_label_area_size(Y_LABELS);
    if plot.y.log {
        let chart = builder
            .build_cartesian_2d(x0..x1, (y0..y_top).log_scale())
            .map_err(drawing)?;
        finish(plot, chart, (sx, sy), (y0, y1), &x_title, &y_title)
    } else {
        let chart = builder
            .build_cartesian_2d(x0..x1, y0..y_top)
            .map_err(drawing)?;
        finish(plot, chart, (sx, sy), (y0, y1), &x_title, &y_title)
    }
}

fn finish<'c, DB, Y>(
    plot: &Plot,
    mut chart: ChartContext<'c, DB, Cartesian2d<plotters::coord::types::RangedCoordf64, Y>>,
    (sx, sy): (f64, f64),
    (y0, y1): (f64, f64),
    x_title: &str,
    y_title: &str,
) -> Result<(), String>
where
    DB: DrawingBackend + 'c,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    chart
        .configure_mesh()
        .x_desc(x_title)
        .y_desc(y_title)
        .axis_desc_style((FAMILY, 16))
        .label_style((FAMILY, 13))
        .light_line_style(RGBColor(238, 238, 238))
        .max_light_lines(2)
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| tick(*v))
        .draw()
        .map_err(drawing)?;

    let band_fill = RGBColor(0xdd, 0xe8, 0xf6);
    for (k, &(a, b)) in plot.bands.iter().enumerate() {
        let rect = Rectangle::new([(a * sx, y0), (b * sx, y1)], band_fill.filled());
        let drawn = chart.draw_series(std::iter::once(rect)).map_err(drawing)?;
        if k == 0 {
            drawn.label(plot.band_label).legend(move |(x, y)| {
                Rectangle::new([(x, y - 5), (x + 20, y + 5)], band_fill.filled())
            });
        }
    }

    let grey = RGBColor(110, 110, 110);
    let mut markers: Vec<&Marker> = plot.markers.iter().collect();
    markers.sort_by(|a, b| a.x.total_cmp(&b.x));
    // The pixels the curves occupy, so that no marker label is written over one.
    let curves: Vec<Vec<(i32, i32)>> = (plot.series.iter())
        .flat_map(|s| runs(&s.points, plot.y.log, sx, sy))
        .map(|run| run.iter().map(|p| chart.backend_coord(p)).collect())
        .collect();
    let x_range = chart.x_range();
    let (data_top, data_bottom) = (
        chart.backend_coord(&(x_range.start, y1)).1,
        chart.backend_coord(&(x_range.start, y0)).1,
    );
    let mut taken: Vec<Span> = Vec::new();
    for m in markers {
        let x = m.x * sx;
        chart
            .draw_series(DashedLineSeries::new(
                [(x, y0), (x, y1)],
                6,
                4,
                grey.stroke_width(1),
            ))
            .map_err(drawing)?;
        let px = chart.backend_coord(&(x, y0)).0;
        // Rotated text reads bottom to top in a 13 px wide column beside the line: right of
        // it if a long enough stretch of that column is free of curves and labels, else left.
        let length = label_length(&m.label);
        // Above the data lies the legend's band: free left of the legend box (at most 240 px
        // wide at the right).
        let (area_x, area_y) = chart.plotting_area().get_pixel_range();
        let top = if px < area_x.end - 260 {
            area_y.start + 4
        } else {
            data_top
        };
        let place = [(px + 3, px + 17, 16), (px - 16, px - 2, -1)]
            .into_iter()
            .find_map(|(a, b, dx)| {
                free_stretch(&curves, &taken, (a, b), (top, data_bottom), length).map(|bottom| {
                    (
                        Span {
                            left: a,
                            right: b,
                            top: bottom - length,
                            bottom,
                        },
                        dx,
                    )
                })
            });
        // Nowhere free (a crowded plot): the old place, bottom up right of the line.
        let (span, dx) = place.unwrap_or((
            Span {
                left: px + 3,
                right: px + 17,
                top: data_bottom - 6 - length,
                bottom: data_bottom - 6,
            },
            16,
        ));
        taken.push(span);
        let style = TextStyle::from((FAMILY, 13).into_font())
            .color(&grey)
            .transform(FontTransform::Rotate270)
            .pos(Pos::new(HPos::Left, VPos::Bottom));
        let rise = data_bottom - span.bottom;
        let label = EmptyElement::at((x, y0)) + Text::new(m.label.clone(), (dx, -rise), style);
        chart.draw_series(std::iter::once(label)).map_err(drawing)?;
    }
    if plot.x.unit == "rpm" {
        rad_per_s_ticks(&chart, (x_range.start, x_range.end), y1)?;
    }

    for series in &plot.series {
        let c = color(series.color)?;
        // plotters draws wide lines as polygons with mitre joins, which overshoot as spikes
        // where a dense curve reverses sharply (contact loss, a min/max envelope): dense curves
        // get hairlines.
        let width = if series.points.len() > 300 { 1 } else { 2 };
        let style = c.stroke_width(width);
        let mut labelled = series.label.is_empty();
        let mut label = |drawn: &mut SeriesAnno<'c, DB>| {
            if !labelled {
                labelled = true;
                let dashed = series.dashed;
                drawn.label(series.label).legend(move |(x, y)| {
                    if dashed {
                        PathElement::new(vec![(x, y), (x + 8, y)], style)
                    } else {
                        PathElement::new(vec![(x, y), (x + 20, y)], style)
                    }
                });
            }
        };
        for run in runs(&series.points, plot.y.log, sx, sy) {
            if series.line {
                let drawn = &mut if series.dashed {
                    chart
                        .draw_series(DashedLineSeries::new(run.clone(), 8, 5, style))
                        .map_err(drawing)?
                } else {
                    chart
                        .draw_series(LineSeries::new(run.clone(), style))
                        .map_err(drawing)?
                };
                label(drawn);
            }
            if series.markers {
                let drawn = &mut chart
                    .draw_series(run.iter().map(|&p| Circle::new(p, 3, c.filled())))
                    .map_err(drawing)?;
                label(drawn);
            }
        }
    }
    if plot.series.iter().any(|s| !s.label.is_empty()) || !plot.bands.is_empty() {
        draw_legend(&mut chart, SeriesLabelPosition::UpperRight)?;
    }
    Ok(())
}

/// The series legend of a chart in the corner `position`, in the one style of every plot.
pub(super) fn draw_legend<'a, DB, CT>(
    chart: &mut ChartContext<'a, DB, CT>,
    position: SeriesLabelPosition,
) -> Result<(), String>
where
    DB: DrawingBackend + 'a,
    CT: plotters::coord::CoordTranslate,
{
    chart
        .configure_series_labels()
        .position(position)
        .label_font((FAMILY, 14))
        .background_style(WHITE.mix(0.9))
        .border_style(RGBColor(180, 180, 180))
        .draw()
        .map_err(drawing)
}
