//! Order tracking in the angle domain (computed order tracking, `docs/spectrum.md`, "Order
//! cuts"): a run-up's signal sampled at equal increments of the reference shaft's angle, cut
//! into blocks of whole revolutions, and the amplitude and phase of each requested order
//! computed per block by a direct windowed Fourier sum at exactly that order.
//!
//! In the angle domain an order `o` (cycles per revolution) is a line at a fixed position,
//! whatever the speed: a run-up at any rate keeps it on one bin, where a time-domain window
//! smears it over the frequencies the ramp sweeps (Fyfe & Munck 1997, "Analysis of computed
//! order tracking", MSSP 11:187; Brandt 2011, "Noise and Vibration Analysis", §12.5). The
//! samples are taken from the solution itself at the exact angle instants
//! ([`ShaftClock::time_at_angle`]), not interpolated from a time grid, so the resampling adds
//! no interpolation error (the weak point of computed order tracking, Fyfe & Munck §3).

use std::f64::consts::TAU;

use super::window::Window;
use crate::scene::profile::Profile;

/// The nominal angle of the shaft whose speed `profile` gives (rad/s against time, piecewise
/// linear, constant outside its knots), integrated exactly from `t = 0`: piecewise quadratic.
#[derive(Debug, Clone)]
pub struct ShaftClock {
    /// Start of each piece, s (the first is 0).
    start: Vec<f64>,
    /// Angle at the start of each piece, rad.
    angle: Vec<f64>,
    /// Speed at the start of each piece, rad/s, and its slope, rad/s².
    speed: Vec<f64>,
    slope: Vec<f64>,
}

impl ShaftClock {
    pub fn new(profile: &Profile) -> ShaftClock {
        let mut starts = vec![0.0];
        starts.extend(profile.times().iter().copied().filter(|&t| t > 0.0));
        let mut clock = ShaftClock {
            start: Vec::new(),
            angle: Vec::new(),
            speed: Vec::new(),
            slope: Vec::new(),
        };
        let mut angle = 0.0;
        for (i, &t) in starts.iter().enumerate() {
            let (v, a) = profile.segment_at(t);
            if i > 0 {
                let (t0, v0, a0) = (starts[i - 1], clock.speed[i - 1], clock.slope[i - 1]);
                let h = t - t0;
                angle += v0 * h + 0.5 * a0 * h * h;
            }
            clock.start.push(t);
            clock.angle.push(angle);
            clock.speed.push(v);
            clock.slope.push(a);
        }
        clock
    }

    fn piece_at_time(&self, t: f64) -> usize {
        self.start.partition_point(|&s| s <= t).saturating_sub(1)
    }

    /// The angle turned since `t = 0`, rad.
    pub fn angle_at(&self, t: f64) -> f64 {
        let i = self.piece_at_time(t);
        let h = t - self.start[i];
        self.angle[i] + self.speed[i] * h + 0.5 * self.slope[i] * h * h
    }

    /// The speed at `t`, rad/s.
    pub fn speed_at(&self, t: f64) -> f64 {
        let i = self.piece_at_time(t);
        self.speed[i] + self.slope[i] * (t - self.start[i])
    }

    /// The first time at which the shaft has turned `angle` rad (`None` if it never does: it
    /// stops first). On a piece, `½aτ² + vτ − Δ = 0` is solved as `τ = 2Δ/(v + √(v² + 2aΔ))`,
    /// the form that keeps its digits on a slow ramp and stays defined from standstill (the
    /// stop-time formula of `docs/runup.md`, "Mesh phase").
    pub fn time_at_angle(&self, angle: f64) -> Option<f64> {
        let i = self
            .angle
            .partition_point(|&a| a <= angle)
            .saturating_sub(1);
        // Pieces that turn no angle (standstill) share their start angle with the next piece:
        // take the last piece that starts at or before `angle`.
        let delta = angle - self.angle[i];
        let (v, a) = (self.speed[i], self.slope[i]);
        let disc = v * v + 2.0 * a * delta;
        if disc < 0.0 {
            return None;
        }
        let denominator = v + disc.sqrt();
        if denominator <= 0.0 {
            return if delta == 0.0 {
                Some(self.start[i])
            } else {
                None
            };
        }
        let tau = 2.0 * delta / denominator;
        // The piece turns past `angle` before it ends (the next piece starts beyond it), so
        // the root lies on it; the clamp only keeps rounding from crossing the knot.
        let t = self.start[i] + tau;
        Some(self.start.get(i + 1).map_or(t, |&end| t.min(end)))
    }
}

/// How the angle-domain record is cut and which orders are tracked.
#[derive(Debug, Clone, PartialEq)]
pub struct OrderTrackOptions {
    /// Samples per revolution of the reference shaft; the orders reach half of it.
    pub samples_per_revolution: usize,
    /// Whole revolutions per block: the order resolution is `1/revolutions`.
    pub revolutions: usize,
    /// Fraction of a block shared with the next, in `[0, 1)`.
    pub overlap: f64,
    pub window: Window,
    /// Orders to track, cycles per reference-shaft revolution.
    pub orders: Vec<f64>,
}

/// Order cuts: `amplitude[b][k]` and `phase[b][k]` of order `orders[k]` in block `b`, whose
/// centre lies at `angle[b]` (rad turned since `t = 0`), reached at `time[b]` at `speed[b]`
/// rad/s.
#[derive(Debug, Clone, PartialEq)]
pub struct OrderCuts {
    pub orders: Vec<f64>,
    pub angle: Vec<f64>,
    pub time: Vec<f64>,
    pub speed: Vec<f64>,
    pub amplitude: Vec<Vec<f64>>,
    /// Phase of the cosine against the shaft angle, rad: the signal reads
    /// `A cos(o·φ + phase)` near the block's centre.
    pub phase: Vec<Vec<f64>>,
}

impl OrderTrackOptions {
    /// Checks the options (the message names the option and its value).
    pub fn check(&self) -> Result<(), String> {
        let n = self.samples_per_revolution;
        if n < 8 {
            return Err(format!("samples per revolution = {n}: need at least 8"));
        }
        if self.revolutions == 0 {
            return Err("--revolutions = 0: a block needs at least one revolution".into());
        }
        if !(0.0..1.0).contains(&self.overlap) {
            return Err(format!(
                "order-tracking overlap = {}: must lie in [0, 1)",
                self.overlap
            ));
        }
        if self.orders.is_empty() {
            return Err("order tracking: no order requested".into());
        }
        let nyquist = n as f64 / 2.0;
        if let Some(o) = self.orders.iter().find(|&&o| !(o > 0.0 && o < nyquist)) {
            return Err(format!(
                "order {o}: orders must lie in (0, {nyquist}) at {n} samples per revolution \
                 (half the samples per revolution; raise --order-samples)"
            ));
        }
        Ok(())
    }
}

/// The order cuts of `signal`, sampled at the shaft angles `first·Δφ, (first+1)·Δφ, …`
/// (`Δφ = 2π/samples_per_revolution`), with each block's time and speed from `clock`. Per
/// block of `M = revolutions·samples_per_revolution` samples the weighted mean is removed and
/// `X(o) = Σ w_j x_j e^{−i o φ_j}` is summed at exactly each order `o` (no bin grid, so an
/// order between bins, e.g. a gear's shaft order in pinion orders, is read where it is);
/// the amplitude is `2|X|/Σw`, the phase `arg X`. With the Hann window an order on the block's
/// bin grid (`o·revolutions` an integer) reads its amplitude exactly when its neighbours on
/// the grid are two bins or more away; the flat-top reads any order within 1e-3
/// ([`Window::amplitude_error`]).
pub fn order_cuts(
    signal: &[f64],
    first: u64,
    clock: &ShaftClock,
    options: &OrderTrackOptions,
) -> Result<OrderCuts, String> {
    options.check()?;
    let n = options.samples_per_revolution;
    let block = n * options.revolutions;
    if signal.len() < block {
        return Err(format!(
            "order tracking: {} samples ({:.2} revolutions), fewer than one block of \
             --revolutions = {} (shorten the block or lengthen the run)",
            signal.len(),
            signal.len() as f64 / n as f64,
            options.revolutions
        ));
    }
    if let Some(j) = signal.iter().position(|v| !v.is_finite()) {
        return Err(format!(
            "order tracking: sample {j} = {} is not finite",
            signal[j]
        ));
    }
    let step = (((1.0 - options.overlap) * block as f64).round() as usize).max(1);
    let w = options.window.weights(block);
    let gain: f64 = w.iter().sum();
    let dphi = TAU / n as f64;
    let mut cuts = OrderCuts {
        orders: options.orders.clone(),
        angle: Vec::new(),
        time: Vec::new(),
        speed: Vec::new(),
        amplitude: Vec::new(),
        phase: Vec::new(),
    };
    let mut start = 0usize;
    while start + block <= signal.len() {
        let x = &signal[start..start + block];
        let mean = x.iter().zip(&w).map(|(x, w)| x * w).sum::<f64>() / gain;
        let mut amplitude = Vec::with_capacity(options.orders.len());
        let mut phase = Vec::with_capacity(options.orders.len());
        for &o in &options.orders {
            // e^{−i o φ_j} by rotation from the block's first sample: the rounding grows by
            // about one unit per sample, 1e-11 over a block of 10^5 samples; each block
            // starts again from its exact angle (cycles reduced modulo 1 before the sine).
            let cycles = o * (first + start as u64) as f64 / n as f64;
            let a0 = TAU * (cycles - cycles.floor());
            let (mut c, mut s) = (a0.cos(), -a0.sin());
            let (dc, ds) = ((o * dphi).cos(), -(o * dphi).sin());
            let (mut re, mut im) = (0.0, 0.0);
            for (&xj, &wj) in x.iter().zip(&w) {
                let v = (xj - mean) * wj;
                re += v * c;
                im += v * s;
                (c, s) = (c * dc - s * ds, c * ds + s * dc);
            }
            amplitude.push(2.0 * re.hypot(im) / gain);
            phase.push(im.atan2(re));
        }
        let centre = (first + (start + block / 2) as u64) as f64 * dphi;
        let time = clock.time_at_angle(centre).unwrap_or(f64::NAN);
        cuts.angle.push(centre);
        cuts.time.push(time);
        cuts.speed.push(clock.speed_at(time));
        cuts.amplitude.push(amplitude);
        cuts.phase.push(phase);
        start += step;
    }
    Ok(cuts)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::profile::ProfileSpec;

    fn ramp(from: f64, to: f64, start: f64, end: f64) -> Profile {
        Profile::new(
            "speed",
            &ProfileSpec::Ramp {
                from,
                to,
                start,
                end,
            },
            true,
        )
        .unwrap()
    }

    #[test]
    fn the_clock_inverts_its_angle() {
        let clock = ShaftClock::new(&ramp(100.0, 800.0, 0.5, 2.5));
        for &t in &[0.0, 0.1, 0.5, 0.5 + 1e-9, 1.3, 2.5, 3.7] {
            let phi = clock.angle_at(t);
            let back = clock.time_at_angle(phi).unwrap();
            assert!(
                (back - t).abs() <= 1e-12 * (1.0 + t),
                "{t} -> {phi} -> {back}"
            );
        }
        // Closed form on the ramp: 100·0.5 + 100·h + 175·h².
        let h: f64 = 1.2;
        let phi = 50.0 + 100.0 * h + 175.0 * h * h;
        assert!((clock.angle_at(0.5 + h) - phi).abs() < 1e-12 * phi);
    }

    #[test]
    fn a_run_down_to_standstill_never_reaches_beyond_its_stop() {
        let clock = ShaftClock::new(&ramp(10.0, 0.0, 0.0, 1.0));
        assert!((clock.angle_at(5.0) - 5.0).abs() < 1e-12);
        assert!(clock.time_at_angle(4.0).is_some());
        assert_eq!(clock.time_at_angle(5.5), None);
    }

    /// A synthetic run-up signal with known orders (closed form): each order reads its
    /// amplitude and phase, and an order between bins is still found (flat-top).
    #[test]
    fn orders_of_a_synthetic_run_up() {
        let clock = ShaftClock::new(&ramp(50.0, 500.0, 0.0, 3.0));
        let n = 256;
        let dphi = TAU / n as f64;
        let samples: Vec<f64> = (0..40_000u64)
            .map(|k| {
                let phi = k as f64 * dphi;
                let t = clock.time_at_angle(phi).unwrap();
                // order 20 grows with speed (slowly), order 3.3 is fixed, a mean of 7.
                7.0 + (1.0 + 1e-3 * clock.speed_at(t)) * (20.0 * phi + 0.4).cos()
                    + 0.25 * (3.3 * phi - 1.0).cos()
            })
            .collect();
        for (window, tol_fixed) in [(Window::Hann, 0.16), (Window::FlatTop, 1e-3)] {
            let options = OrderTrackOptions {
                samples_per_revolution: n,
                revolutions: 10,
                overlap: 0.5,
                window,
                orders: vec![20.0, 3.3],
            };
            let cuts = order_cuts(&samples, 0, &clock, &options).unwrap();
            assert!(cuts.amplitude.len() > 20);
            // The amplitude changes across a block (the speed within it): the tracked value
            // is its window-weighted mean over the block's samples, which the closed form
            // gives here; the speed at the centre is within the curvature of v(φ).
            let block = n * options.revolutions;
            let w = window.weights(block);
            let gain: f64 = w.iter().sum();
            let amplitude_at = |k: usize| {
                let t = clock.time_at_angle(k as f64 * dphi).unwrap();
                1.0 + 1e-3 * clock.speed_at(t)
            };
            for b in 0..cuts.amplitude.len() {
                let start = b * block / 2;
                let want = (0..block)
                    .map(|j| w[j] * amplitude_at(start + j))
                    .sum::<f64>()
                    / gain;
                let a = cuts.amplitude[b][0];
                assert!(
                    (a - want).abs() < 2e-4 * want,
                    "{window:?} block {b}: {a} vs {want}"
                );
                let centre = 1.0 + 1e-3 * cuts.speed[b];
                assert!(
                    (a - centre).abs() < 3e-3 * centre,
                    "{window:?} block {b}: {a} vs {centre}"
                );
                assert!((cuts.phase[b][0] - 0.4).abs() < 1e-3, "{:?}", cuts.phase[b]);
                let a = cuts.amplitude[b][1];
                assert!((a - 0.25).abs() < tol_fixed * 0.25, "{window:?} 3.3: {a}");
            }
        }
    }

    #[test]
    fn options_are_checked_by_name() {
        let options = OrderTrackOptions {
            samples_per_revolution: 64,
            revolutions: 4,
            overlap: 0.5,
            window: Window::Hann,
            orders: vec![40.0],
        };
        assert!(options.check().unwrap_err().contains("order 40"));
        let o = OrderTrackOptions {
            revolutions: 0,
            orders: vec![1.0],
            ..options
        };
        assert!(o.check().unwrap_err().contains("--revolutions = 0"));
    }
}
