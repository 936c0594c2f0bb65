//! A run streamed to its outputs, for the single pair and the drivetrain alike: the output
//! grid as an iterator, the limits a run is checked against before it starts, the sink every
//! row goes to as soon as it is computed, the summaries accumulated online and the progress
//! line. Nothing here holds more than one row, so the memory of a run is flat in its length
//! (issue 17, issue 20 item 5).

use std::io::{IsTerminal, Write};
use std::time::{Duration, Instant};

use super::driver::{DrivenModel, Driver, RunScales};
// The precision limit of the mesh phase is the clock's (a double resolves 2⁻²⁰ cycle there); a
// run is checked against it before it starts, every advance again (`check_advance`).
use crate::model::MAX_MESH_CYCLES;

/// Default of [`RunLimits::max_rows`]: 1e8 rows are about 15 GB of CSV for a single pair.
pub const DEFAULT_MAX_ROWS: u64 = 100_000_000;
/// Default of [`RunLimits::max_mesh_periods`]: 1e9 mesh periods take about 4 min for the
/// shipped spur pair (0.23 s per 1e6) and hours for a drivetrain.
pub const DEFAULT_MAX_MESH_PERIODS: f64 = 1e9;
/// Default of [`RunLimits::max_mode_periods`]: as many periods of the fastest mode as mesh
/// periods (a stiff mode costs the RK path steps, and the event search work, in proportion).
pub const DEFAULT_MAX_MODE_PERIODS: f64 = 1e9;

/// Bounds on the work and output of one run, checked before the run starts so that an input
/// that would take days, fill the disk or lose its time resolution is refused with a message
/// instead of hanging. `geardyn simulate --max-rows / --max-periods` raise them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunLimits {
    /// Output rows (the grid points including t = 0 and the stop time).
    pub max_rows: u64,
    /// Mesh periods of the fastest mesh over the run.
    pub max_mesh_periods: f64,
    /// Periods of the fastest mode (natural frequency, damping rate, STE harmonic) over the
    /// run.
    pub max_mode_periods: f64,
}

impl Default for RunLimits {
    fn default() -> Self {
        RunLimits {
            max_rows: DEFAULT_MAX_ROWS,
            max_mesh_periods: DEFAULT_MAX_MESH_PERIODS,
            max_mode_periods: DEFAULT_MAX_MODE_PERIODS,
        }
    }
}

impl RunLimits {
    /// Checks a run of `stop_time` sampled every `interval` of a model with `scales` against
    /// the limits; the message names the quantities, their values and the limit.
    pub fn check(&self, scales: &RunScales, stop_time: f64, interval: f64) -> Result<(), String> {
        if !(stop_time.is_finite() && stop_time > 0.0) {
            return Err(format!(
                "stop_time = {stop_time:e}: must be a finite number > 0"
            ));
        }
        if !(interval.is_finite() && interval > 0.0) {
            return Err(format!(
                "output_interval = {interval:e}: must be a finite number > 0"
            ));
        }
        let rows = OutputGrid::rows_f64(stop_time, interval);
        if !(rows <= self.max_rows as f64) {
            return Err(format!(
                "output_interval = {interval:e} s with stop_time = {stop_time:e} s gives {rows:.4e} output rows; \
                 the limit is {} rows per run (raise it with --max-rows)",
                self.max_rows
            ));
        }
        let periods =
            (scales.mesh_frequency + 0.5 * scales.mesh_frequency_slope * stop_time) * stop_time;
        if !(periods <= self.max_mesh_periods) {
            return Err(format!(
                "{} = {:e} rad/s with stop_time = {stop_time:e} s is {periods:.4e} mesh \
                 periods (mesh frequency {:.4e} Hz, changing by {:.4e} Hz/s under the port \
                 torques); the limit is {:e} mesh periods per run (raise it with --max-periods)",
                scales.speed.0,
                scales.speed.1,
                scales.mesh_frequency,
                scales.mesh_frequency_slope,
                self.max_mesh_periods
            ));
        }
        let phase = scales.start_phase + periods;
        if !(phase <= MAX_MESH_CYCLES) {
            return Err(format!(
                "the mesh phase would reach {phase:.4e} cycles (initial_phase {:e} + {periods:.4e} mesh \
                 periods); beyond {MAX_MESH_CYCLES:e} cycles a double cannot resolve the mesh cycle",
                scales.start_phase
            ));
        }
        let (rate, source) = scales.fastest_rate;
        let mode_periods = rate / std::f64::consts::TAU * stop_time;
        if !(mode_periods <= self.max_mode_periods) {
            return Err(format!(
                "stop_time = {stop_time:e} s spans {mode_periods:.4e} periods of the fastest mode \
                 ({rate:.4e} rad/s, set by {source}); the limit is {:e} per run (raise it with \
                 --max-periods)",
                self.max_mode_periods
            ));
        }
        Ok(())
    }
}

/// The output grid `t_k = k·h` up to `stop_time` (the last point is `stop_time` itself when
/// it is not a multiple of `h`). Each point is computed from its index, not accumulated, so
/// long runs carry no rounding drift; points are produced one at a time, so the grid costs no
/// memory.
#[derive(Debug, Clone)]
pub struct OutputGrid {
    stop_time: f64,
    interval: f64,
    /// Index of the last multiple of `h`.
    n: u64,
    next: u64,
    /// Whether `stop_time` follows the last multiple as an extra point.
    tail: bool,
}

impl OutputGrid {
    /// The grid; `stop_time` and `interval` must be finite and > 0 and their ratio within a
    /// row limit ([`RunLimits::check`]).
    pub fn new(stop_time: f64, interval: f64) -> OutputGrid {
        let n = (stop_time / interval + 1e-9).floor() as u64;
        let last = n as f64 * interval;
        let snaps = (stop_time - last).abs() <= 1e-9 * interval;
        OutputGrid {
            stop_time,
            interval,
            n,
            next: 0,
            tail: !snaps && last < stop_time,
        }
    }

    /// The number of points as a float, defined for any ratio (no integer overflow), for the
    /// check against the row limit.
    pub fn rows_f64(stop_time: f64, interval: f64) -> f64 {
        let n = (stop_time / interval + 1e-9).floor();
        if n < 1e15 {
            OutputGrid::new(stop_time, interval).rows() as f64
        } else {
            n + 1.0
        }
    }

    /// The number of points.
    pub fn rows(&self) -> u64 {
        self.n + 1 + u64::from(self.tail)
    }
}

impl Iterator for OutputGrid {
    type Item = f64;
    fn next(&mut self) -> Option<f64> {
        let k = self.next;
        if k > self.n + u64::from(self.tail) {
            return None;
        }
        self.next += 1;
        Some(if k < self.n {
            k as f64 * self.interval
        } else if k == self.n {
            let last = k as f64 * self.interval;
            if (self.stop_time - last).abs() <= 1e-9 * self.interval {
                self.stop_time
            } else {
                last
            }
        } else {
            self.stop_time
        })
    }
}

/// Where the rows of a run go, one at a time: `time` and the output values.
pub trait RowSink {
    fn row(&mut self, t: f64, values: &[f64]) -> Result<(), String>;
}

impl RowSink for crate::output::CsvWriter {
    fn row(&mut self, t: f64, values: &[f64]) -> Result<(), String> {
        crate::output::CsvWriter::row(self, std::iter::once(t).chain(values.iter().copied()))
    }
}

/// Mean, spread and peak of one output column, accumulated one value at a time (Welford's
/// update, which stays accurate where the textbook `Σx² − n·mean²` cancels: the DTE is a
/// small ripple on a large mean deflection).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ColumnStats {
    count: u64,
    mean: f64,
    m2: f64,
    max_abs: f64,
}

impl ColumnStats {
    pub fn push(&mut self, x: f64) {
        self.count += 1;
        let d = x - self.mean;
        self.mean += d / self.count as f64;
        self.m2 += d * (x - self.mean);
        self.max_abs = self.max_abs.max(x.abs());
    }

    pub fn mean(&self) -> f64 {
        self.mean
    }

    /// RMS about the mean (population form, as the summaries have always printed it).
    pub fn rms_about_mean(&self) -> f64 {
        (self.m2 / self.count as f64).sqrt()
    }

    /// Largest |value|.
    pub fn max_abs(&self) -> f64 {
        self.max_abs
    }
}

/// Online summary of some columns of a run (only those a report needs, so the cost per row
/// stays a few operations), and how many rows had each of some `(column, value)` pairs
/// (contact states).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RunSummary {
    pub rows: u64,
    columns: Vec<(usize, ColumnStats)>,
    tallies: Vec<(usize, f64, u64)>,
}

impl RunSummary {
    /// A summary of the columns `columns`, counting the rows where column `c` equals `v` for
    /// each `(c, v)` in `tallies`.
    pub fn new(columns: &[usize], tallies: &[(usize, f64)]) -> RunSummary {
        RunSummary {
            rows: 0,
            columns: columns
                .iter()
                .map(|&c| (c, ColumnStats::default()))
                .collect(),
            tallies: tallies.iter().map(|&(c, v)| (c, v, 0)).collect(),
        }
    }

    pub fn push(&mut self, values: &[f64]) {
        self.rows += 1;
        for (c, s) in &mut self.columns {
            s.push(values[*c]);
        }
        for (c, v, n) in &mut self.tallies {
            if values[*c] == *v {
                *n += 1;
            }
        }
    }

    /// The statistics of column `c` (one given to [`RunSummary::new`]).
    pub fn column(&self, c: usize) -> ColumnStats {
        self.columns
            .iter()
            .find(|(tc, _)| *tc == c)
            .map_or_else(ColumnStats::default, |t| t.1)
    }

    /// Fraction of rows where column `c` equalled `v` (a pair given to [`RunSummary::new`]).
    pub fn fraction(&self, c: usize, v: f64) -> f64 {
        let n = self
            .tallies
            .iter()
            .find(|&&(tc, tv, _)| tc == c && tv == v)
            .map_or(0, |t| t.2);
        n as f64 / self.rows as f64
    }
}

/// A one-line progress display on stderr for long runs, only when stderr is a terminal (a
/// pipe or a log file gets nothing, so scripted runs stay byte-identical).
pub struct Progress {
    enabled: bool,
    stop_time: f64,
    start: Instant,
    last: Instant,
    shown: bool,
    rows: u64,
}

/// How often the progress line is redrawn, and how long a run must last before it appears.
const PROGRESS_EVERY: Duration = Duration::from_millis(500);

impl Progress {
    /// Progress towards `stop_time`, shown only when `wanted` and stderr is a terminal.
    pub fn new(stop_time: f64, wanted: bool) -> Progress {
        let now = Instant::now();
        Progress {
            enabled: wanted && std::io::stderr().is_terminal(),
            stop_time,
            start: now,
            last: now,
            shown: false,
            rows: 0,
        }
    }

    /// Called once per row; looks at the clock only every 256 rows, so the cost per row is an
    /// increment.
    pub fn tick(&mut self, t: f64) {
        self.rows += 1;
        if !self.enabled || self.rows % 256 != 1 {
            return;
        }
        let now = Instant::now();
        if now.duration_since(self.last) < PROGRESS_EVERY {
            return;
        }
        self.last = now;
        self.shown = true;
        let done = (t / self.stop_time).clamp(0.0, 1.0);
        let elapsed = now.duration_since(self.start).as_secs_f64();
        let eta = if done > 0.0 {
            format!("{:.0} s left", elapsed * (1.0 - done) / done)
        } else {
            String::new()
        };
        let mut e = std::io::stderr().lock();
        let _ = write!(
            e,
            "\r\x1b[Kt = {t:.6} s of {} s ({:.1} %), {} rows, {elapsed:.0} s elapsed, {eta}",
            self.stop_time,
            100.0 * done,
            self.rows
        );
        let _ = e.flush();
    }

    /// Clears the progress line, if one was shown.
    pub fn finish(&mut self) {
        if self.shown {
            let mut e = std::io::stderr().lock();
            let _ = write!(e, "\r\x1b[K");
            let _ = e.flush();
            self.shown = false;
        }
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.finish();
    }
}

/// Runs `sim` over `grid`, writing `outputs(sim)` of every point to `sink` as it is computed,
/// accumulating `summary` and showing `progress`. The one loop behind `geardyn simulate`,
/// [`crate::simulation::run`] and [`crate::model::train::run_train`].
pub fn stream<M: DrivenModel>(
    sim: &mut Driver<M>,
    grid: OutputGrid,
    mut outputs: impl FnMut(&Driver<M>, &mut Vec<f64>),
    sink: &mut dyn RowSink,
    summary: &mut RunSummary,
    progress: &mut Progress,
) -> Result<(), String> {
    let mut row = Vec::new();
    sim.sample(grid, |sim, t| {
        outputs(sim, &mut row);
        summary.push(&row);
        progress.tick(t);
        sink.row(t, &row)
    })?;
    progress.finish();
    Ok(())
}
