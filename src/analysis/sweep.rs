//! Frequency-response sweeps with warm start: the steady state at each speed starts from the
//! final state at the previous speed, so coexisting branches are followed and jumps show up as
//! the difference between the up and the down sweep (Liu 2007 §2.4.1; numerics-notes §3).
//!
//! At each speed the transient is integrated period by period until the state repeats after
//! `k` mesh periods (a periodicity residual below the tolerance, `k ≤ max_subharmonic`, so
//! period-k responses are recognised), then an integer number of mesh periods is recorded
//! (no spectral leakage) for the DTE statistics.

use std::f64::consts::TAU;

use crate::model::{Inputs, OUTPUT_NAMES};
use crate::scene::Scene;
use crate::simulation::Simulation;
use crate::solve::exact::PiecewiseLti;

/// Sweep direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    Up,
    Down,
    Both,
}

impl std::str::FromStr for Direction {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "up" => Ok(Direction::Up),
            "down" => Ok(Direction::Down),
            "both" => Ok(Direction::Both),
            other => Err(format!("direction '{other}': expected up, down or both")),
        }
    }
}

/// Response periods a period-k (k > 1) candidate must persist before it is accepted.
const CONFIRM: u32 = 10;

/// Settings of a sweep.
#[derive(Debug, Clone)]
pub struct SweepOptions {
    /// Pinion speeds, rad/s, in increasing order.
    pub speeds: Vec<f64>,
    pub direction: Direction,
    /// Mesh periods always discarded at each speed before the periodicity test.
    pub min_transient_periods: u32,
    /// Give up (and mark the point not converged) after this many mesh periods.
    pub max_transient_periods: u32,
    /// Scaled periodicity residual accepted as steady state.
    pub tolerance: f64,
    /// Longest response period looked for, in mesh periods.
    pub max_subharmonic: u32,
    /// Mesh periods recorded for the statistics (rounded up to a multiple of the response
    /// period).
    pub record_periods: u32,
    /// Samples per mesh period in the recording.
    pub samples_per_period: u32,
}

impl SweepOptions {
    pub fn new(speeds: Vec<f64>, direction: Direction) -> Self {
        SweepOptions {
            speeds,
            direction,
            min_transient_periods: 20,
            max_transient_periods: 3000,
            tolerance: 1e-7,
            max_subharmonic: 4,
            record_periods: 8,
            samples_per_period: 64,
        }
    }

    /// `from:to:points` (rad/s), evenly spaced.
    pub fn parse_range(range: &str) -> Result<Vec<f64>, String> {
        let parts: Vec<&str> = range.split(':').collect();
        if parts.len() != 3 {
            return Err(format!("--speed '{range}': expected from:to:points"));
        }
        let num = |name: &str, s: &str| {
            s.trim()
                .parse::<f64>()
                .map_err(|e| format!("--speed {name} '{s}': {e}"))
        };
        let (from, to) = (num("from", parts[0])?, num("to", parts[1])?);
        let points: usize = parts[2]
            .trim()
            .parse()
            .map_err(|e| format!("--speed points '{}': {e}", parts[2]))?;
        if !(from > 0.0 && from.is_finite()) {
            return Err(format!("--speed from = {from}: must be a finite speed > 0"));
        }
        if !(to > from && to.is_finite()) {
            return Err(format!(
                "--speed to = {to}: must be finite and greater than from = {from}"
            ));
        }
        if points < 2 {
            return Err(format!(
                "--speed points = {points}: a sweep needs at least 2"
            ));
        }
        Ok((0..points)
            .map(|i| from + (to - from) * i as f64 / (points - 1) as f64)
            .collect())
    }

    fn validate(&self) -> Result<(), String> {
        if self.speeds.is_empty() {
            return Err("sweep: no speeds (zero points)".into());
        }
        if let Some(bad) = self.speeds.iter().find(|v| !(**v > 0.0 && v.is_finite())) {
            return Err(format!("sweep speed {bad}: must be a finite speed > 0"));
        }
        if self.speeds.windows(2).any(|w| !(w[1] > w[0])) {
            return Err("sweep speeds must be strictly increasing".into());
        }
        if !(self.tolerance > 0.0) {
            return Err(format!("sweep tolerance = {}: must be > 0", self.tolerance));
        }
        if self.max_subharmonic == 0 || self.record_periods == 0 || self.samples_per_period < 8 {
            return Err(
                "sweep: max_subharmonic and record_periods must be ≥ 1, samples_per_period ≥ 8"
                    .into(),
            );
        }
        if self.max_transient_periods < self.min_transient_periods {
            return Err(format!(
                "sweep: max_transient_periods = {} below min_transient_periods = {}",
                self.max_transient_periods, self.min_transient_periods
            ));
        }
        Ok(())
    }
}

/// One point of a sweep.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepPoint {
    pub direction: Direction,
    /// Pinion speed, rad/s.
    pub speed: f64,
    /// Mesh frequency, Hz.
    pub mesh_frequency: f64,
    /// Whether a periodic steady state was found; if not, the statistics are of the last
    /// recorded stretch (kept, marked, never dropped).
    pub converged: bool,
    /// Response period in mesh periods (when converged).
    pub response_periods: Option<u32>,
    /// Periodicity residual at the end of the transient.
    pub residual: f64,
    /// Mesh periods integrated as transient.
    pub transient_periods: u32,
    pub dte_mean: f64,
    /// RMS of the DTE with the mean removed, m.
    pub dte_rms: f64,
    pub dte_peak_to_peak: f64,
    /// Amplitudes of the first three mesh harmonics of the DTE, m.
    pub harmonics: [f64; 3],
    /// Fraction of the recorded time without drive-side contact.
    pub contact_loss_fraction: f64,
    pub peak_mesh_force: f64,
}

/// Column names of [`SweepPoint::row`].
pub const SWEEP_COLUMNS: [&str; 14] = [
    "direction",
    "speed",
    "mesh_frequency",
    "converged",
    "response_periods",
    "residual",
    "transient_periods",
    "dte_mean",
    "dte_rms",
    "dte_peak_to_peak",
    "a1",
    "a2",
    "a3",
    "contact_loss_fraction",
];

impl SweepPoint {
    /// Values in [`SWEEP_COLUMNS`] order (direction as +1 up / −1 down).
    pub fn row(&self) -> [f64; 14] {
        [
            if self.direction == Direction::Up {
                1.0
            } else {
                -1.0
            },
            self.speed,
            self.mesh_frequency,
            if self.converged { 1.0 } else { 0.0 },
            self.response_periods.map_or(0.0, f64::from),
            self.residual,
            self.transient_periods as f64,
            self.dte_mean,
            self.dte_rms,
            self.dte_peak_to_peak,
            self.harmonics[0],
            self.harmonics[1],
            self.harmonics[2],
            self.contact_loss_fraction,
        ]
    }
}

/// Runs the sweep; `Both` runs the up and the down branch on two threads. `progress` is
/// called after every point with (points done, points total).
pub fn sweep(
    scene: &Scene,
    options: &SweepOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Vec<SweepPoint>, String> {
    options.validate()?;
    let total = match options.direction {
        Direction::Both => 2 * options.speeds.len(),
        _ => options.speeds.len(),
    };
    let done = std::sync::atomic::AtomicUsize::new(0);
    let tick = || {
        let d = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        progress(d, total);
    };
    match options.direction {
        Direction::Up | Direction::Down => branch(scene, options, options.direction, &tick),
        Direction::Both => {
            let (up, down) = std::thread::scope(|s| {
                let up = s.spawn(|| branch(scene, options, Direction::Up, &tick));
                let down = branch(scene, options, Direction::Down, &tick);
                (up.join().expect("sweep thread"), down)
            });
            let mut points = up?;
            points.extend(down?);
            Ok(points)
        }
    }
}

fn branch(
    scene: &Scene,
    options: &SweepOptions,
    direction: Direction,
    tick: &(dyn Fn() + Sync),
) -> Result<Vec<SweepPoint>, String> {
    let mut speeds = options.speeds.clone();
    if direction == Direction::Down {
        speeds.reverse();
    }
    let mut first = scene.clone();
    first.operating.pinion_speed = speeds[0];
    let mut sim = Simulation::new(&first)?;
    let mut points = Vec::with_capacity(speeds.len());
    for &speed in &speeds {
        let inputs = Inputs {
            pinion_speed: speed,
            ..sim.model().inputs()
        };
        sim.set_inputs(inputs);
        points.push(steady_state(&mut sim, options, direction, speed)?);
        tick();
    }
    Ok(points)
}

/// Integrates to the periodic steady state at the current inputs and records its statistics.
fn steady_state(
    sim: &mut Simulation,
    options: &SweepOptions,
    direction: Direction,
    speed: f64,
) -> Result<SweepPoint, String> {
    let period = sim.model().mesh_period();
    let x_scale = sim.model().static_deflection().abs().max(1e-9);
    let scale = [x_scale, x_scale * sim.model().max_frequency()];
    let kmax = options.max_subharmonic as usize;
    let mut history: Vec<[f64; 2]> = vec![sim.state()];
    let t0 = sim.t();
    let mut found = None;
    let mut residual = f64::INFINITY;
    let mut candidate: Option<(usize, u32)> = None;
    let mut j = 0u32;
    while j < options.max_transient_periods {
        j += 1;
        sim.advance_to(t0 + j as f64 * period)
            .map_err(|e| format!("speed {speed} rad/s: {e}"))?;
        history.push(sim.state());
        if history.len() > kmax + 1 {
            history.remove(0);
        }
        if j < options.min_transient_periods || history.len() <= kmax {
            continue;
        }
        let now = history[kmax];
        let residuals: Vec<f64> = (1..=kmax)
            .map(|k| {
                let then = history[kmax - k];
                (0..2)
                    .map(|i| ((now[i] - then[i]) / scale[i]).abs())
                    .fold(0.0, f64::max)
            })
            .collect();
        residual = residuals.iter().copied().fold(f64::INFINITY, f64::min);
        // The shortest period that repeats is the response period. A decaying transient
        // whose multiplier is close to a k-th root of unity also makes the k-residual small,
        // so k > 1 is accepted only after it has held for `CONFIRM` response periods while
        // the shorter periods kept failing.
        let best = residuals.iter().position(|&r| r <= options.tolerance);
        match (best, candidate) {
            (Some(0), _) => {
                found = Some(1);
                residual = residuals[0];
                break;
            }
            (Some(i), Some((k, since))) if k == i + 1 => {
                if j - since >= CONFIRM * k as u32 {
                    found = Some(k as u32);
                    residual = residuals[i];
                    break;
                }
            }
            (Some(i), _) => candidate = Some((i + 1, j)),
            (None, _) => candidate = None,
        }
    }
    let k = found.unwrap_or(1);
    let record = options.record_periods.div_ceil(k) * k;
    let per = options.samples_per_period as usize;
    let n = record as usize * per;
    let t_start = sim.t();
    let mut dte = Vec::with_capacity(n);
    let mut lost = 0usize;
    let mut peak_force: f64 = 0.0;
    let state_col = OUTPUT_NAMES.iter().position(|&c| c == "contact_state");
    let force_col = OUTPUT_NAMES.iter().position(|&c| c == "mesh_force");
    for i in 1..=n {
        sim.advance_to(t_start + i as f64 * period / per as f64)
            .map_err(|e| format!("speed {speed} rad/s: {e}"))?;
        let out = sim.outputs();
        dte.push(out[0]);
        if let Some(c) = state_col {
            lost += usize::from(out[c] != 1.0);
        }
        if let Some(c) = force_col {
            peak_force = peak_force.max(out[c].abs());
        }
    }
    let mean = dte.iter().sum::<f64>() / n as f64;
    let rms = (dte.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64).sqrt();
    let (lo, hi) = dte
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| {
            (lo.min(x), hi.max(x))
        });
    let mut harmonics = [0.0; 3];
    for (h, a) in harmonics.iter_mut().enumerate() {
        let (mut re, mut im) = (0.0, 0.0);
        for (i, x) in dte.iter().enumerate() {
            let angle = TAU * (h + 1) as f64 * (i + 1) as f64 / per as f64;
            re += x * angle.cos();
            im -= x * angle.sin();
        }
        *a = 2.0 * (re * re + im * im).sqrt() / n as f64;
    }
    Ok(SweepPoint {
        direction,
        speed,
        mesh_frequency: 1.0 / period,
        converged: found.is_some(),
        response_periods: found,
        residual,
        transient_periods: j,
        dte_mean: mean,
        dte_rms: rms,
        dte_peak_to_peak: hi - lo,
        harmonics,
        contact_loss_fraction: lost as f64 / n as f64,
        peak_mesh_force: peak_force,
    })
}
