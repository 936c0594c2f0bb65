//! A run streamed to its outputs, for the single pair and the drivetrain alike: the output
//! grid as an iterator, the limits a run is checked against before it starts, the sink every
//! row goes to as soon as it is computed, the summaries accumulated online and the progress
//! line. Nothing here holds more than one row, so the memory of a run is flat in its length
//! (issue 17, issue 20 item 5).

use std::io::{IsTerminal, Write};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

use super::driver::{DrivenModel, Driver};
use super::scales::RunScales;
// The precision limit of the mesh phase is the clock's (a double resolves 2⁻²⁰ cycle there); a
// run is checked against it before it starts, every advance again (`check_advance`).
use crate::model::MAX_MESH_CYCLES;
use crate::solve::SolveError;

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
    /// The run's work budget in work units ([`super::budget`]), counted by the driver as it
    /// goes; `Some` overrides the scene's `solver.work_budget` (`--work-budget`, Python
    /// `work_budget=`), `None` keeps it (or the default of a run).
    pub work_budget: Option<f64>,
}

impl Default for RunLimits {
    fn default() -> Self {
        RunLimits {
            max_rows: DEFAULT_MAX_ROWS,
            max_mesh_periods: DEFAULT_MAX_MESH_PERIODS,
            max_mode_periods: DEFAULT_MAX_MODE_PERIODS,
            work_budget: None,
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
        self.check_span(scales, stop_time, " (raise it with --max-periods)")
    }

    /// The work part of [`RunLimits::check`]: `stop_time` of simulated time within the mesh
    /// and mode periods of the limits and the phase resolution. For an analysis that
    /// integrates a known span (the shooting of `periodic`) as for a run; `raise` is the hint
    /// appended to a limit the user may raise.
    pub fn check_work(&self, scales: &RunScales, stop_time: f64) -> Result<(), String> {
        if !(stop_time.is_finite() && stop_time > 0.0) {
            return Err(format!(
                "{stop_time:e} s of simulated time: must be a finite number > 0"
            ));
        }
        self.check_span(scales, stop_time, "")
    }

    fn check_span(&self, scales: &RunScales, stop_time: f64, raise: &str) -> Result<(), String> {
        let periods =
            (scales.mesh_frequency + 0.5 * scales.mesh_frequency_slope * stop_time) * stop_time;
        if !(periods <= self.max_mesh_periods) {
            return Err(format!(
                "{} = {:e} rad/s with stop_time = {stop_time:e} s is {periods:.4e} mesh \
                 periods (mesh frequency {:.4e} Hz, changing by {:.4e} Hz/s under the port \
                 torques); the limit is {:e} mesh periods per run{raise}",
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
                 ({rate:.4e} rad/s, set by {source}); the limit is {:e} per run{raise}",
                self.max_mode_periods
            ));
        }
        Ok(())
    }
}

/// The output grid `t_k = k·h` up to `stop_time`: every row on the grid (issue 31 item 4).
/// When `stop_time` is not a multiple of `h` (to 1e-9 of `h`) the last row is the last
/// multiple before it, not an extra row at `stop_time` off the grid (a record whose last
/// interval is shorter is not uniform, and its spectrum would not be what it says);
/// [`OutputGrid::last_point`] tells where the rows end. A multiple within 1e-9 of `h` of
/// `stop_time` is `stop_time` itself. Each point is computed from its index, not
/// accumulated, so long runs carry no rounding drift; points are produced one at a time, so
/// the grid costs no memory.
#[derive(Debug, Clone)]
pub struct OutputGrid {
    /// The last point: `stop_time`, or the last multiple of the interval before it.
    last: f64,
    interval: f64,
    /// Index of the last point.
    n: u64,
    next: u64,
}

impl OutputGrid {
    /// The grid; `stop_time` and `interval` must be finite and > 0 and their ratio within a
    /// row limit ([`RunLimits::check`]).
    pub fn new(stop_time: f64, interval: f64) -> OutputGrid {
        let n = (stop_time / interval + 1e-9).floor() as u64;
        let last = n as f64 * interval;
        let snaps = (stop_time - last).abs() <= 1e-9 * interval;
        OutputGrid {
            last: if snaps { stop_time } else { last },
            interval,
            n,
            next: 0,
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

    /// The last point: the stop time, or the last multiple of the interval before it.
    pub fn last_point(&self) -> f64 {
        self.last
    }

    /// The number of points.
    pub fn rows(&self) -> u64 {
        self.n + 1
    }
}

impl Iterator for OutputGrid {
    type Item = f64;
    fn next(&mut self) -> Option<f64> {
        let k = self.next;
        if k > self.n {
            return None;
        }
        self.next += 1;
        Some(if k < self.n {
            k as f64 * self.interval
        } else {
            self.last
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

/// When a run shows its progress on stderr (`geardyn simulate`: on a terminal unless
/// `--quiet`; everywhere with `--progress`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum ProgressDisplay {
    /// Never (library calls, the Python module).
    #[default]
    Off,
    /// A line redrawn in place, only when stderr is a terminal (a pipe or a log file gets
    /// nothing, so scripted runs stay byte-identical).
    Terminal,
    /// On a terminal as [`ProgressDisplay::Terminal`]; on a pipe or a file, a plain line every
    /// few seconds (no carriage returns or escapes).
    Always,
}

/// A progress display on stderr for long runs and analyses, the one reporter of every
/// command (`simulate`, `sweep`, `periodic`, `hb`, `spectrum`, `waterfall`). A run towards a
/// stop time shows the time reached, rows and solver work, elapsed time and an estimate of the
/// time left; an analysis shows the status it last reported ([`Progress::report`]: points
/// done, Newton iteration, speed reached) with the elapsed time and, where it knows the
/// fraction done, the time left. Nothing appears in the first [`PROGRESS_EVERY`]. The line is
/// written by a thread of its own from what was last recorded, so it keeps appearing while one
/// step of the work takes long, and the work itself only stores a few numbers. On a terminal
/// the line is redrawn in place and cleared at the end; on a pipe or a file
/// ([`ProgressDisplay::Always`]) a plain `progress: …` line every [`PROGRESS_LINE_EVERY`] and
/// one at the end.
pub struct Progress {
    shared: Option<Arc<Shown>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

/// What the work records for the progress thread, and its stop signal.
struct Shown {
    time_bits: AtomicU64,
    rows: AtomicU64,
    work: AtomicU64,
    /// An analysis' status line and fraction done (NaN: unknown), as last reported; `None`
    /// for a run towards a stop time.
    status: Option<Mutex<(String, f64)>>,
    stop: Mutex<bool>,
    wake: Condvar,
    /// Whether a line is on the terminal (to clear it at the end).
    drawn: AtomicBool,
}

/// How often the progress line is redrawn on a terminal, and how long a run must last before
/// it appears.
const PROGRESS_EVERY: Duration = Duration::from_millis(500);
/// How often a plain progress line is written to a pipe or a file.
const PROGRESS_LINE_EVERY: Duration = Duration::from_secs(2);

impl Progress {
    /// Progress towards `stop_time`, shown only when `wanted` and stderr is a terminal.
    pub fn new(stop_time: f64, wanted: bool) -> Progress {
        let display = if wanted {
            ProgressDisplay::Terminal
        } else {
            ProgressDisplay::Off
        };
        Progress::with_display(stop_time, display)
    }

    /// Progress towards `stop_time` as `display` asks.
    pub fn with_display(stop_time: f64, display: ProgressDisplay) -> Progress {
        Progress::start(stop_time, None, display)
    }

    /// The progress of an analysis as `display` asks: the status it reports
    /// ([`Progress::report`]), starting with `status`.
    pub fn of_analysis(status: &str, display: ProgressDisplay) -> Progress {
        Progress::start(
            f64::NAN,
            Some(Mutex::new((status.to_owned(), f64::NAN))),
            display,
        )
    }

    fn start(
        stop_time: f64,
        status: Option<Mutex<(String, f64)>>,
        display: ProgressDisplay,
    ) -> Progress {
        let terminal = std::io::stderr().is_terminal();
        let in_place = match display {
            ProgressDisplay::Off => None,
            ProgressDisplay::Terminal => terminal.then_some(true),
            ProgressDisplay::Always => Some(terminal),
        };
        let Some(in_place) = in_place else {
            return Progress {
                shared: None,
                thread: None,
            };
        };
        let shared = Arc::new(Shown {
            time_bits: AtomicU64::new(0),
            rows: AtomicU64::new(0),
            work: AtomicU64::new(0),
            status,
            stop: Mutex::new(false),
            wake: Condvar::new(),
            drawn: AtomicBool::new(false),
        });
        let every = if in_place {
            PROGRESS_EVERY
        } else {
            PROGRESS_LINE_EVERY
        };
        let thread = {
            let shared = shared.clone();
            std::thread::Builder::new()
                .name("geardyn-progress".into())
                .spawn(move || shared.show(stop_time, in_place, every))
                .ok()
        };
        Progress {
            shared: thread.is_some().then_some(shared),
            thread,
        }
    }

    /// Records a row at `t` and the solver work so far (three relaxed stores).
    pub fn tick(&mut self, t: f64, work: impl FnOnce() -> f64) {
        if let Some(s) = &self.shared {
            s.time_bits.store(t.to_bits(), Ordering::Relaxed);
            s.rows.fetch_add(1, Ordering::Relaxed);
            s.work.store(work() as u64, Ordering::Relaxed);
        }
    }

    /// Records an analysis' status (`status()`, formatted only when shown) and the fraction
    /// of it done (NaN: unknown). Callable from the analysis' worker threads.
    pub fn report(&self, fraction: f64, status: impl FnOnce() -> String) {
        if let Some(Some(shown)) = self.shared.as_ref().map(|s| &s.status) {
            let text = status();
            *shown.lock().unwrap_or_else(|e| e.into_inner()) = (text, fraction);
        }
    }

    /// [`Progress::report`] as an analysis takes it ([`crate::analysis::Report`]).
    pub fn reporter(&self) -> impl Fn(f64, &dyn Fn() -> String) + Sync + '_ {
        move |fraction, status| self.report(fraction, status)
    }

    /// Stops the display: clears the line drawn in place, or writes the last line to a pipe.
    pub fn finish(&mut self) {
        if let (Some(s), Some(thread)) = (self.shared.take(), self.thread.take()) {
            *s.stop.lock().unwrap_or_else(|e| e.into_inner()) = true;
            s.wake.notify_all();
            let _ = thread.join();
        }
    }
}

impl Shown {
    /// The progress thread: a line every `every` until stopped, then the end (see
    /// [`Progress`]).
    fn show(&self, stop_time: f64, in_place: bool, every: Duration) {
        let start = Instant::now();
        let mut stop = self.stop.lock().unwrap_or_else(|e| e.into_inner());
        loop {
            let (guard, _) = self
                .wake
                .wait_timeout(stop, every)
                .unwrap_or_else(|e| e.into_inner());
            stop = guard;
            if *stop {
                break;
            }
            let line = self.line(stop_time, start.elapsed().as_secs_f64());
            let mut e = std::io::stderr().lock();
            let _ = if in_place {
                write!(e, "\r\x1b[K{line}")
            } else {
                writeln!(e, "progress: {line}")
            };
            let _ = e.flush();
            self.drawn.store(in_place, Ordering::Relaxed);
        }
        let mut e = std::io::stderr().lock();
        if !in_place {
            let _ = writeln!(
                e,
                "progress: {}",
                self.line(stop_time, start.elapsed().as_secs_f64())
            );
        } else if self.drawn.load(Ordering::Relaxed) {
            let _ = write!(e, "\r\x1b[K");
        }
        let _ = e.flush();
    }

    /// The line shown after `elapsed` seconds.
    fn line(&self, stop_time: f64, elapsed: f64) -> String {
        let left = |done: f64| {
            if done > 0.0 && done < 1.0 {
                format!(", {:.0} s left", elapsed * (1.0 - done) / done)
            } else {
                String::new()
            }
        };
        if let Some(status) = &self.status {
            let (text, done) = status.lock().unwrap_or_else(|e| e.into_inner()).clone();
            return format!("{text}, {elapsed:.0} s elapsed{}", left(done));
        }
        let t = f64::from_bits(self.time_bits.load(Ordering::Relaxed));
        let done = (t / stop_time).clamp(0.0, 1.0);
        format!(
            "t = {t:.6e} s of {stop_time} s ({:.1} %), {} rows, {:.2e} work units spent, \
             {elapsed:.0} s elapsed{}",
            100.0 * done,
            self.rows.load(Ordering::Relaxed),
            self.work.load(Ordering::Relaxed) as f64,
            left(done),
        )
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.finish();
    }
}

/// Runs `sim` over `grid`, writing `outputs(sim)` of every point to `sink` as it is computed,
/// accumulating `summary` and showing `progress`. `work_budget` (work units), when given,
/// replaces the driver's budget for the run ([`super::budget`]). The one loop behind `geardyn simulate`,
/// [`crate::simulation::run`] and [`crate::model::train::run_train`].
pub fn stream<M: DrivenModel>(
    sim: &mut Driver<M>,
    grid: OutputGrid,
    outputs: impl FnMut(&Driver<M>, &mut Vec<f64>),
    sink: &mut dyn RowSink,
    summary: &mut RunSummary,
    progress: &mut Progress,
    work_budget: Option<f64>,
) -> Result<(), String> {
    stream_with(
        sim,
        grid,
        outputs,
        sink,
        summary,
        progress,
        work_budget,
        |sim, t| sim.advance_to(t),
    )
}

/// [`stream`] with the advance to each output time given: `advance(sim, t)` (an advance
/// that observes the run's segments for statistics from the solution,
/// [`crate::analysis::orbit_statistics::RunStatistics`]).
#[allow(clippy::too_many_arguments)]
pub fn stream_with<M: DrivenModel>(
    sim: &mut Driver<M>,
    grid: OutputGrid,
    mut outputs: impl FnMut(&Driver<M>, &mut Vec<f64>),
    sink: &mut dyn RowSink,
    summary: &mut RunSummary,
    progress: &mut Progress,
    work_budget: Option<f64>,
    mut advance: impl FnMut(&mut Driver<M>, f64) -> Result<(), SolveError>,
) -> Result<(), String> {
    // A run is bounded as a whole (`docs/fmu.md`, "Work budget"): the caller's budget, else
    // the scene's `solver.work_budget`, else the default of a run.
    match work_budget {
        Some(limit) => sim.set_work_budget(limit)?,
        None => sim.default_work_budget(super::budget::DEFAULT_RUN_BUDGET),
    }
    let mut row = Vec::new();
    for t in grid {
        // A row on a switching instant reports the state after the switch
        // ([`Driver::switch_at_now`]).
        let result = advance(sim, t).and_then(|()| match sim.switch_at_now() {
            Some(stop) => advance(sim, stop),
            None => Ok(()),
        });
        if let Err(e) = result {
            return Err(match e {
                // The budget's own message names the work and the likely cause.
                crate::solve::SolveError::OverBudget { message, .. } => message,
                e => explain_failure(sim, &e),
            });
        }
        outputs(sim, &mut row);
        summary.push(&row);
        progress.tick(t, || sim.work_spent());
        sink.row(t, &row)?;
    }
    progress.finish();
    Ok(())
}

/// The solver's refusal of an advance, with the likely cause when it is one of work (too many
/// steps, a step below the time resolution, too many guard samples or events).
fn explain_failure<M: DrivenModel>(sim: &Driver<M>, e: &SolveError) -> String {
    match e {
        SolveError::TooManySteps { .. }
        | SolveError::StepSizeTooSmall { .. }
        | SolveError::TooManyGuardSamples { .. }
        | SolveError::EventStorm { .. } => format!(
            "integration failed: {e}; likely cause: {}",
            super::budget::likely_cause(&sim.model().run_scales(), &sim.stats(), sim.t())
        ),
        _ => format!("integration failed: {e}"),
    }
}
