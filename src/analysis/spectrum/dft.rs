//! One-sided amplitude spectra by FFT (`rustfft`), in the signal's units.

use super::window::Window;
use rustfft::{num_complex::Complex, FftPlanner};

/// A one-sided spectrum: `amplitude[k]` is the amplitude (not RMS) of the cosine at
/// `frequency[k]`, in the signal's units; `amplitude[0]` is the mean.
#[derive(Debug, Clone, PartialEq)]
pub struct Spectrum {
    pub frequency: Vec<f64>,
    pub amplitude: Vec<f64>,
    /// Phase of the cosine at the first sample, rad (meaningful for the exact DFT).
    pub phase: Vec<f64>,
    /// Bin spacing, Hz.
    pub resolution: f64,
    pub window: Window,
}

impl Spectrum {
    /// Index of the largest amplitude among bins whose frequency lies in `[lo, hi]` Hz.
    pub fn peak_in(&self, lo: f64, hi: f64) -> Option<usize> {
        (0..self.frequency.len())
            .filter(|&k| self.frequency[k] >= lo && self.frequency[k] <= hi)
            .max_by(|&a, &b| self.amplitude[a].total_cmp(&self.amplitude[b]))
    }
}

/// The exact DFT of `samples`, taken at `t0 + j·duration/N` (j = 0..N) over exactly an integer
/// number of periods of the signal: every harmonic of `1/duration` falls on a bin, so there is
/// no leakage and a band-limited periodic signal's Fourier coefficients are recovered to
/// rounding (`docs/spectrum.md`). Bins sit at `k/duration`, k = 0..=N/2.
pub fn exact_dft(samples: &[f64], duration: f64) -> Result<Spectrum, String> {
    if !(duration.is_finite() && duration > 0.0) {
        return Err(format!(
            "spectrum duration = {duration}: must be positive and finite"
        ));
    }
    spectrum(
        samples,
        duration / samples.len() as f64,
        Window::Rectangular,
    )
}

/// The windowed FFT of uniformly spaced `samples` (interval `dt`, s), amplitude-corrected by
/// the window's coherent gain. For a signal whose record is not an integer number of periods;
/// with [`Window::FlatTop`] an isolated line's amplitude is within
/// [`Window::amplitude_error`].
pub fn windowed_fft(samples: &[f64], dt: f64, window: Window) -> Result<Spectrum, String> {
    spectrum(samples, dt, window)
}

fn spectrum(samples: &[f64], dt: f64, window: Window) -> Result<Spectrum, String> {
    let n = samples.len();
    if n < 2 {
        return Err(format!("spectrum: {n} samples (need at least 2)"));
    }
    if !(dt.is_finite() && dt > 0.0) {
        return Err(format!(
            "spectrum sample interval = {dt}: must be positive and finite"
        ));
    }
    if let Some(j) = samples.iter().position(|v| !v.is_finite()) {
        return Err(format!(
            "spectrum: sample {j} = {} is not finite",
            samples[j]
        ));
    }
    let w = window.weights(n);
    let gain: f64 = w.iter().sum();
    let mut buffer: Vec<Complex<f64>> = samples
        .iter()
        .zip(&w)
        .map(|(x, w)| Complex::new(x * w, 0.0))
        .collect();
    FftPlanner::new().plan_fft_forward(n).process(&mut buffer);
    let resolution = 1.0 / (n as f64 * dt);
    let half = n / 2;
    let mut frequency = Vec::with_capacity(half + 1);
    let mut amplitude = Vec::with_capacity(half + 1);
    let mut phase = Vec::with_capacity(half + 1);
    for (k, x) in buffer.iter().take(half + 1).enumerate() {
        // DC and (even N) Nyquist have no mirror bin: they are not doubled.
        let single = k == 0 || (n % 2 == 0 && k == half);
        let scale = if single { 1.0 } else { 2.0 } / gain;
        frequency.push(k as f64 * resolution);
        amplitude.push(x.norm() * scale);
        phase.push(x.arg());
    }
    Ok(Spectrum {
        frequency,
        amplitude,
        phase,
        resolution,
        window,
    })
}
