//! Plots of every command (frequency responses, time series, stiffness curves, spectra):
//! drawn with `plotters`, written as PNG or SVG by the file's extension.
//!
//! Axes carry a quantity and an SI unit; the plot picks the engineering prefix that suits the
//! data (metres become µm, newtons kN), so no axis reads `5.00e-5`. The legend sits in a band
//! reserved above the data, so it never hides a curve. Text is drawn with the bundled DejaVu
//! Sans (`assets/fonts/`), so rendering needs no system font library.

mod axis;
mod campbell;
mod font;
mod heatmap;
mod line;
mod stems;

pub use axis::Axis;
pub use campbell::{Campbell, Crossing};
pub use heatmap::{Heatmap, DYNAMIC_RANGE_DB};
pub use stems::{StemSeries, Stems};

use std::path::Path;

use crate::output;

/// One curve.
pub struct Series<'a> {
    /// Legend text; empty for a continuation of the curve above (one legend row per curve).
    pub label: &'a str,
    /// `#rrggbb`.
    pub color: &'a str,
    pub points: Vec<(f64, f64)>,
    pub dashed: bool,
    /// Draw a small circle at each point (sweep samples).
    pub markers: bool,
    /// Join the points by a line (off for scattered samples).
    pub line: bool,
}

/// A vertical line at `x` with a short label: a jump of a sweep, a fold of a branch, a
/// resonance.
pub struct Marker {
    pub x: f64,
    pub label: String,
}

/// A line plot with labelled axes.
pub struct Plot<'a> {
    pub title: &'a str,
    pub x: Axis<'a>,
    pub y: Axis<'a>,
    pub series: Vec<Series<'a>>,
    /// Shaded x-intervals (e.g. double-contact zones), with one legend label.
    pub bands: Vec<(f64, f64)>,
    pub band_label: &'a str,
    pub markers: Vec<Marker>,
}

/// `value` in `unit` with the engineering prefix the plots use, to 3 significant digits
/// (`12.3 µm`, `2.05 kN`); a unitless value as it is.
pub fn engineering(value: f64, unit: &str) -> String {
    let unit = if unit == "1" { "" } else { unit };
    let (scale, title) = Axis::new("", unit).scaled(value.abs());
    // The title reads " (µm)": the prefixed unit between the parentheses.
    let prefixed = title
        .trim()
        .trim_start_matches('(')
        .trim_end_matches(')')
        .to_string();
    let v = value * scale;
    let digits = if v.abs() >= 100.0 {
        0
    } else if v.abs() >= 10.0 {
        1
    } else {
        2
    };
    format!("{v:.digits$} {prefixed}").trim_end().to_string()
}

/// Image formats, chosen by the file extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    Png,
    Svg,
}

impl Format {
    /// The format `path`'s extension names (`.png`, `.svg`, any case).
    pub fn of(path: &Path) -> Result<Format, String> {
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref()
        {
            Some("png") => Ok(Format::Png),
            Some("svg") => Ok(Format::Svg),
            _ => Err(format!(
                "plot file {}: the extension must be .png or .svg",
                path.display()
            )),
        }
    }
}

/// Pixel size of every plot.
pub const SIZE: (u32, u32) = (960, 600);

impl Plot<'_> {
    /// Writes the plot to `path` (PNG or SVG by its extension); nothing is written on error.
    pub fn save(&self, path: &Path) -> Result<(), String> {
        let bytes = self.render(Format::of(path)?)?;
        output::write_bytes(path, &bytes)
    }

    /// The encoded image.
    pub fn render(&self, format: Format) -> Result<Vec<u8>, String> {
        render_with(format, SIZE, |area| {
            line::draw(std::slice::from_ref(self), area)
        })
    }
}

/// Plots stacked vertically in one image sharing its width (e.g. DTE over force), each as tall
/// as a single [`Plot`] less a quarter.
pub fn save_stacked(plots: &[Plot], path: &Path) -> Result<(), String> {
    let format = Format::of(path)?;
    let height = (SIZE.1 as f64 * 0.75) as u32 * plots.len().max(1) as u32;
    let bytes = render_with(format, (SIZE.0, height), |area| line::draw(plots, area))?;
    output::write_bytes(path, &bytes)
}

/// Runs `draw` on a white drawing area of `size` pixels and encodes the result.
pub(crate) fn render_with<F>(format: Format, size: (u32, u32), draw: F) -> Result<Vec<u8>, String>
where
    F: Fn(&line::Area<'_>) -> Result<(), String>,
{
    use plotters::prelude::*;
    font::register();
    match format {
        Format::Svg => {
            let mut svg = String::new();
            {
                let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
                root.fill(&WHITE).map_err(drawing)?;
                draw(&line::Area::Svg(root.clone()))?;
                root.present().map_err(drawing)?;
            }
            Ok(svg.into_bytes())
        }
        Format::Png => {
            let mut rgb = vec![0u8; (size.0 * size.1 * 3) as usize];
            {
                let root = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
                root.fill(&WHITE).map_err(drawing)?;
                draw(&line::Area::Bitmap(root.clone()))?;
                root.present().map_err(drawing)?;
            }
            encode_png(&rgb, size)
        }
    }
}

fn encode_png(rgb: &[u8], size: (u32, u32)) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, size.0, size.1);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder
        .write_header()
        .map_err(|e| format!("PNG encoding: {e}"))?;
    writer
        .write_image_data(rgb)
        .map_err(|e| format!("PNG encoding: {e}"))?;
    writer.finish().map_err(|e| format!("PNG encoding: {e}"))?;
    Ok(out)
}

pub(crate) fn drawing<E: std::fmt::Debug>(e: E) -> String {
    format!("drawing the plot: {e:?}")
}

/// `#rrggbb` as a colour.
pub(crate) fn color(hex: &str) -> Result<plotters::style::RGBColor, String> {
    let digits = hex.strip_prefix('#').filter(|d| d.len() == 6);
    let parse = |d: &str, i: usize| u8::from_str_radix(&d[i..i + 2], 16).ok();
    match digits.and_then(|d| Some((parse(d, 0)?, parse(d, 2)?, parse(d, 4)?))) {
        Some((r, g, b)) => Ok(plotters::style::RGBColor(r, g, b)),
        None => Err(format!("plot colour {hex:?}: expected #rrggbb")),
    }
}

#[cfg(test)]
mod tests;
