//! A minimal SVG line plot (no plotting crate): one or more polylines over shared axes with
//! "nice" ticks, optional shaded x-bands, a title and axis labels.

use std::fmt::Write;

/// One polyline.
pub struct Series<'a> {
    pub label: &'a str,
    pub color: &'a str,
    pub points: Vec<(f64, f64)>,
}

/// A plot description.
pub struct Plot<'a> {
    pub title: &'a str,
    pub x_label: &'a str,
    pub y_label: &'a str,
    pub series: Vec<Series<'a>>,
    /// Shaded x-intervals (e.g. double-contact zones) with a legend label.
    pub bands: Vec<(f64, f64)>,
    pub band_label: &'a str,
}

/// Tick positions covering `[lo, hi]` with a 1-2-5 step (about `n` ticks).
fn ticks(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    let span = (hi - lo).max(f64::MIN_POSITIVE);
    let raw = span / n as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    (first..=last).map(|i| i as f64 * step).collect()
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

impl Plot<'_> {
    /// The SVG document.
    pub fn to_svg(&self) -> String {
        let (w, h) = (800.0, 480.0);
        let (left, right, top, bottom) = (90.0, 20.0, 40.0, 60.0);
        let all = self.series.iter().flat_map(|s| s.points.iter());
        let (mut x0, mut x1, mut y0, mut y1) = (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        );
        for &(x, y) in all {
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
        if !(x1 > x0) {
            x1 = x0 + 1.0;
        }
        let pad = 0.05 * (y1 - y0).max(y1.abs() * 1e-3);
        let (y0, y1) = (y0 - pad, y1 + pad);
        let px = |x: f64| left + (x - x0) / (x1 - x0) * (w - left - right);
        let py = |y: f64| h - bottom - (y - y0) / (y1 - y0) * (h - top - bottom);
        let mut s = String::new();
        let _ = writeln!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif" font-size="12">"#
        );
        let _ = writeln!(s, r#"<rect width="{w}" height="{h}" fill="white"/>"#);
        for &(a, b) in &self.bands {
            let (a, b) = (a.max(x0), b.min(x1));
            if b > a {
                let _ = writeln!(
                    s,
                    r##"<rect x="{:.2}" y="{top}" width="{:.2}" height="{:.2}" fill="#dde8f6"/>"##,
                    px(a),
                    px(b) - px(a),
                    h - top - bottom
                );
            }
        }
        // Axes, ticks and grid.
        let _ = writeln!(
            s,
            r#"<rect x="{left}" y="{top}" width="{}" height="{}" fill="none" stroke="black"/>"#,
            w - left - right,
            h - top - bottom
        );
        for t in ticks(x0, x1, 8) {
            let x = px(t);
            let _ = writeln!(
                s,
                r##"<line x1="{x:.2}" y1="{top}" x2="{x:.2}" y2="{}" stroke="#cccccc"/><text x="{x:.2}" y="{}" text-anchor="middle">{}</text>"##,
                h - bottom,
                h - bottom + 16.0,
                format_tick(t)
            );
        }
        for t in ticks(y0, y1, 6) {
            let y = py(t);
            let _ = writeln!(
                s,
                r##"<line x1="{left}" y1="{y:.2}" x2="{}" y2="{y:.2}" stroke="#cccccc"/><text x="{}" y="{:.2}" text-anchor="end">{}</text>"##,
                w - right,
                left - 6.0,
                y + 4.0,
                format_tick(t)
            );
        }
        // Later series dashed, so that coinciding curves stay visible.
        for (i, series) in self.series.iter().enumerate() {
            let dash = if i == 0 {
                ""
            } else {
                r#" stroke-dasharray="6 4""#
            };
            let pts: Vec<String> = series
                .points
                .iter()
                .map(|&(x, y)| format!("{:.2},{:.2}", px(x), py(y)))
                .collect();
            let _ = writeln!(
                s,
                r#"<polyline fill="none" stroke="{}" stroke-width="1.8"{dash} points="{}"/>"#,
                series.color,
                pts.join(" ")
            );
        }
        // Legend on a white box.
        let rows = self.series.len() + usize::from(!self.bands.is_empty());
        let _ = writeln!(
            s,
            r##"<rect x="{}" y="{}" width="200" height="{}" fill="white" stroke="#999999"/>"##,
            w - right - 206.0,
            top + 4.0,
            16.0 * rows as f64 + 6.0
        );
        let mut ly = top + 16.0;
        for series in &self.series {
            let _ = writeln!(
                s,
                r#"<line x1="{}" y1="{ly}" x2="{}" y2="{ly}" stroke="{}" stroke-width="2"/><text x="{}" y="{}">{}</text>"#,
                w - right - 200.0,
                w - right - 175.0,
                series.color,
                w - right - 170.0,
                ly + 4.0,
                escape(series.label)
            );
            ly += 16.0;
        }
        if !self.bands.is_empty() {
            let _ = writeln!(
                s,
                r##"<rect x="{}" y="{}" width="25" height="10" fill="#dde8f6" stroke="#999999"/><text x="{}" y="{}">{}</text>"##,
                w - right - 200.0,
                ly - 5.0,
                w - right - 170.0,
                ly + 4.0,
                escape(self.band_label)
            );
        }
        let _ = writeln!(
            s,
            r#"<text x="{}" y="24" text-anchor="middle" font-size="15">{}</text>"#,
            w / 2.0,
            escape(self.title)
        );
        let _ = writeln!(
            s,
            r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#,
            left + (w - left - right) / 2.0,
            h - 16.0,
            escape(self.x_label)
        );
        let _ = writeln!(
            s,
            r#"<text transform="translate(18,{}) rotate(-90)" text-anchor="middle">{}</text>"#,
            top + (h - top - bottom) / 2.0,
            escape(self.y_label)
        );
        s.push_str("</svg>\n");
        s
    }
}

fn format_tick(t: f64) -> String {
    let a = t.abs();
    if a != 0.0 && !(1e-3..1e5).contains(&a) {
        format!("{t:.2e}")
    } else {
        let s = format!("{t:.4}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_cover_range_with_round_steps() {
        let t = ticks(0.0, 1.0, 8);
        assert_eq!(t.first(), Some(&0.0));
        assert!((t[1] - 0.2).abs() < 1e-12 || (t[1] - 0.1).abs() < 1e-12);
        assert!(*t.last().unwrap() <= 1.0);
    }

    #[test]
    fn svg_is_well_formed_enough() {
        let plot = Plot {
            title: "a < b",
            x_label: "x",
            y_label: "y",
            series: vec![Series {
                label: "k",
                color: "black",
                points: vec![(0.0, 1.0), (1.0, 2.0)],
            }],
            bands: vec![(0.2, 0.4)],
            band_label: "band",
        };
        let svg = plot.to_svg();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        assert!(svg.contains("a &lt; b") && svg.contains("<polyline"));
    }
}
