//! The run-up waterfall: short-time spectra of a signal, one row per window, tagged with the
//! shaft speed over that window (`docs/spectrum.md`, "Waterfall").

use super::dft::windowed_fft;
use super::window::Window;
use crate::output::CsvWriter;
use std::path::Path;

/// How the record is cut into short-time windows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WaterfallOptions {
    /// Samples per window; the frequency resolution is `1/(segment·dt)`.
    pub segment: usize,
    /// Fraction of a window shared with the next, in `[0, 1)`.
    pub overlap: f64,
    pub window: Window,
}

impl Default for WaterfallOptions {
    fn default() -> Self {
        WaterfallOptions {
            segment: 1024,
            overlap: 0.5,
            window: Window::Hann,
        }
    }
}

/// A speed–frequency amplitude map: `amplitude[r][c]` is the amplitude (signal units) at
/// `frequency[c]` Hz in the window centred on `time[r]`, where the shaft turned at `rpm[r]`
/// (mean over the window).
#[derive(Debug, Clone, PartialEq)]
pub struct Waterfall {
    pub rpm: Vec<f64>,
    pub time: Vec<f64>,
    pub frequency: Vec<f64>,
    pub amplitude: Vec<Vec<f64>>,
    pub window: Window,
}

/// Short-time spectra of `signal` sampled at uniform times `t` (s), with the reference shaft
/// speed `rpm` (rev/min) at each sample. A line of order `o` (cycles per shaft revolution)
/// appears as a ridge on `f = o·rpm/60`, a straight line through the origin of the
/// (rpm, Hz) plane; a resonance is a ridge at constant frequency.
pub fn waterfall(
    t: &[f64],
    signal: &[f64],
    rpm: &[f64],
    options: &WaterfallOptions,
) -> Result<Waterfall, String> {
    let n = t.len();
    if signal.len() != n || rpm.len() != n {
        return Err(format!(
            "waterfall: {n} times, {} signal samples and {} speeds (must be equal)",
            signal.len(),
            rpm.len()
        ));
    }
    let segment = options.segment;
    if segment < 8 {
        return Err(format!(
            "waterfall segment = {segment}: need at least 8 samples"
        ));
    }
    if n < segment {
        return Err(format!(
            "waterfall: {n} samples, fewer than one segment ({segment})"
        ));
    }
    if !(0.0..1.0).contains(&options.overlap) {
        return Err(format!(
            "waterfall overlap = {}: must lie in [0, 1)",
            options.overlap
        ));
    }
    let dt = (t[n - 1] - t[0]) / (n - 1) as f64;
    if !(dt.is_finite() && dt > 0.0) {
        return Err(format!(
            "waterfall: times from {} to {} s are not increasing",
            t[0],
            t[n - 1]
        ));
    }
    // A short-time FFT needs one sample interval; an irregular record would smear every line.
    if let Some(j) = (1..n).find(|&j| ((t[j] - t[j - 1]) - dt).abs() > 1e-6 * dt) {
        return Err(format!(
            "waterfall: sample interval {} s at t = {} s differs from the mean {dt} s (resample first)",
            t[j] - t[j - 1],
            t[j]
        ));
    }
    let step = (((1.0 - options.overlap) * segment as f64).round() as usize).max(1);
    // The map holds a spectrum per window: bounded before the windows are taken (issue 34:
    // an overlap of 1 - 1e-10 made one window per sample, and a map of 10^8 cells).
    let cells = ((n - segment) / step + 1) as f64 * (segment / 2 + 1) as f64;
    if cells > MAX_WATERFALL_CELLS {
        return Err(format!(
            "waterfall segment = {segment} with overlap = {} over {n} samples: {} windows of {} \
             lines, {cells:e} values, more than the {MAX_WATERFALL_CELLS:e} a map may hold (lower \
             the overlap or the segment)",
            options.overlap,
            (n - segment) / step + 1,
            segment / 2 + 1
        ));
    }
    let mut map = Waterfall {
        rpm: Vec::new(),
        time: Vec::new(),
        frequency: Vec::new(),
        amplitude: Vec::new(),
        window: options.window,
    };
    let mut start = 0;
    while start + segment <= n {
        let range = start..start + segment;
        let spectrum = windowed_fft(&signal[range.clone()], dt, options.window)?;
        if map.frequency.is_empty() {
            map.frequency = spectrum.frequency;
        }
        map.amplitude.push(spectrum.amplitude);
        map.rpm
            .push(rpm[range.clone()].iter().sum::<f64>() / segment as f64);
        map.time.push(0.5 * (t[range.start] + t[range.end - 1]));
        start += step;
    }
    Ok(map)
}

/// Most values (windows times frequency lines) of a waterfall map: 80 MB in memory, about
/// 1 GB of long-form CSV.
pub const MAX_WATERFALL_CELLS: f64 = 1e7;

impl Waterfall {
    /// Frequency of the largest amplitude in row `row` within `[lo, hi]` Hz.
    pub fn ridge(&self, row: usize, lo: f64, hi: f64) -> Option<f64> {
        let a = &self.amplitude[row];
        (0..self.frequency.len())
            .filter(|&c| self.frequency[c] >= lo && self.frequency[c] <= hi)
            .max_by(|&x, &y| a[x].total_cmp(&a[y]))
            .map(|c| self.frequency[c])
    }

    /// Writes the map in long form, one line per (window, frequency):
    /// `time_s, rpm, frequency_Hz, order, amplitude_<unit>`, where the order is
    /// `frequency / (rpm/60)` (cycles per reference-shaft revolution).
    pub fn write_csv(&self, path: &Path, unit: &str) -> Result<(), String> {
        self.write_csv_within(path, unit, None, None)
    }

    /// [`Waterfall::write_csv`] keeping only the lines within `frequency` (Hz) and `order`
    /// (cycles per reference revolution), both inclusive.
    pub fn write_csv_within(
        &self,
        path: &Path,
        unit: &str,
        frequency: Option<(f64, f64)>,
        order_range: Option<(f64, f64)>,
    ) -> Result<(), String> {
        let within = |v: f64, r: Option<(f64, f64)>| r.is_none_or(|(lo, hi)| v >= lo && v <= hi);
        let amplitude = format!("amplitude_{unit}");
        let mut csv = CsvWriter::create(
            path,
            &["time_s", "rpm", "frequency_Hz", "order", &amplitude],
        )?;
        for (r, row) in self.amplitude.iter().enumerate() {
            let shaft_hz = self.rpm[r] / 60.0;
            for (c, a) in row.iter().enumerate() {
                let f = self.frequency[c];
                let order = if shaft_hz != 0.0 {
                    f / shaft_hz
                } else {
                    f64::NAN
                };
                if within(f, frequency) && within(order, order_range) {
                    csv.row([self.time[r], self.rpm[r], f, order, *a])?;
                }
            }
        }
        csv.finish()
    }
}

/// How a waterfall is drawn ([`Waterfall::save_plot_with`]).
#[derive(Debug, Clone, PartialEq)]
pub struct WaterfallPlot {
    /// Order lines overlaid: (label, order in cycles per reference revolution).
    pub orders: Vec<(String, f64)>,
    /// The x axis in orders instead of frequency.
    pub order_axis: bool,
    /// The x range drawn: Hz, or orders with `order_axis`.
    pub x_range: Option<(f64, f64)>,
    /// Colour range below the largest value shown, dB.
    pub dynamic_range: f64,
    /// The amplitudes' unit (the colour bar's reference).
    pub unit: String,
}

impl Default for WaterfallPlot {
    fn default() -> Self {
        WaterfallPlot {
            orders: Vec::new(),
            order_axis: false,
            x_range: None,
            dynamic_range: crate::plot::DYNAMIC_RANGE_DB,
            unit: String::new(),
        }
    }
}

impl Waterfall {
    /// The map as a heatmap (frequency over rpm, colour = amplitude in dB below its peak) with
    /// the order lines `orders` (label, order) overlaid, to PNG or SVG by extension.
    pub fn save_plot(
        &self,
        path: &Path,
        title: &str,
        orders: &[(String, f64)],
    ) -> Result<(), String> {
        let plot = WaterfallPlot {
            orders: orders.to_vec(),
            ..WaterfallPlot::default()
        };
        self.save_plot_with(path, title, &plot)
    }

    /// The map as a heatmap drawn as `plot` says: over frequency or order, in a range, with
    /// a colour bar in dB re the largest value shown.
    pub fn save_plot_with(
        &self,
        path: &Path,
        title: &str,
        plot: &WaterfallPlot,
    ) -> Result<(), String> {
        crate::plot::Heatmap {
            title,
            x: &self.frequency,
            y: &self.rpm,
            values: &self.amplitude,
            lines: plot.orders.clone(),
            order_axis: plot.order_axis,
            x_range: plot.x_range,
            dynamic_range: plot.dynamic_range,
            unit: &plot.unit,
        }
        .save(path)
    }
}
