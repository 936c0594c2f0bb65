//! The run of `geardyn simulate` as a library function: take a scene (single pair or
//! drivetrain), apply the command-line solver options, check the run against its
//! [`RunLimits`], and stream the rows to a CSV file while the summaries accumulate. The
//! command ([`super::simulate`]) and the Python module call it, so the scene fuzzer
//! (`tests/scene_fuzz.rs`) exercises exactly the path a user runs.

use std::path::Path;

use super::positive;
use crate::analysis::orbit_statistics::RunStatistics;
use crate::analysis::MeshResponse;
use crate::model::{Drivetrain, MeshColumns};
use crate::output::CsvWriter;
use crate::scene::{MethodChoice, SolverSettings};
use crate::simulation::{check_in_memory, FnSink, RowSink};
use crate::simulation::{stream_with, Progress, ProgressDisplay, RunLimits, RunSummary};
use crate::simulation::{DrivenModel, Driver, OutputGrid};
use crate::solve::SolverStats;
use crate::with_drivetrain;

use crate::scene::{KernelChoice, Scene};

/// The command-line options of `geardyn simulate` (each `None` keeps the scene's setting).
#[derive(Debug, Clone, Default)]
pub struct SimulateOptions {
    pub stop_time: Option<f64>,
    pub output_interval: Option<f64>,
    pub method: Option<String>,
    pub rk_method: Option<String>,
    pub rtol: Option<f64>,
    pub atol: Option<f64>,
    pub limits: RunLimits,
    /// Where the progress shows on stderr (`--quiet`, `--progress`).
    pub progress: ProgressDisplay,
    /// Write each column's unit into the header, `dte [m]` (`--units`; [`crate::units`]).
    pub header_units: bool,
    /// No statistics from the solution (`--quiet`, which prints no summary): the summary is
    /// then only that of the output samples, and the run costs nothing for it.
    pub no_summary: bool,
}

impl SimulateOptions {
    /// Applies the options to a scene's settings; returns the stop time and the output
    /// interval.
    pub(crate) fn apply(&self, s: &mut SolverSettings) -> Result<(f64, f64), String> {
        if let Some(m) = &self.method {
            s.method = m
                .parse::<MethodChoice>()
                .map_err(|e| format!("--method: {e}"))?;
        }
        if let Some(m) = &self.rk_method {
            s.rk_method = m.parse().map_err(|e| format!("--rk-method: {e}"))?;
        }
        if let Some(v) = self.rtol {
            s.rtol = positive("rtol", v)?;
        }
        if let Some(v) = self.atol {
            s.atol = positive("atol", v)?;
        }
        let stop = positive("stop-time", self.stop_time.unwrap_or(s.stop_time))?;
        let interval = positive(
            "output-interval",
            self.output_interval.unwrap_or(s.output_interval),
        )?;
        Ok((stop, interval))
    }
}

/// The summary of one mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshSummary {
    pub name: String,
    /// RMS of the DTE with its mean removed, m.
    pub dte_rms: f64,
    /// Largest |mesh force|, N.
    pub peak_force: f64,
    /// Fraction of the run in contact loss: from the located event times when `response`
    /// is there (no tooth pair in contact on either flank); else of the output rows (single
    /// pair: not in drive-side contact; drivetrain: no tooth pair in contact).
    pub contact_loss: f64,
    /// The mesh's statistics over the run from the continuous solution
    /// ([`crate::analysis::orbit_statistics::RunStatistics`]: the exact propagator's segments
    /// or the RK steps' dense output, [`SimulateReport::source`]); `None` with speed or torque
    /// profiles or with `--quiet`, where the fields above are of the output rows.
    pub response: Option<MeshResponse>,
    /// The mesh's DTE and force columns in the CSV (0 is time).
    pub dte_column: usize,
    pub force_column: usize,
}

/// What a completed `simulate` run reports.
#[derive(Debug, Clone)]
pub struct SimulateReport {
    pub scene: String,
    pub rows: u64,
    /// The method as chosen and why (`exact (auto: …)`, printed by the summary).
    pub method: String,
    /// The propagator that ran (`exact`, `dp5`, `dop853`, `rodas4`).
    pub propagator: String,
    pub stats: SolverStats,
    /// Work units the run spent against its budget ([`crate::simulation::budget`]).
    pub work: f64,
    pub meshes: Vec<MeshSummary>,
    /// Whether the scene is a single pair (its summary is printed in the pair's layout).
    pub pair: bool,
    /// Where the summary's numbers come from.
    pub source: SummarySource,
    /// The most bytes of output the writer held at once (bounded by its buffer).
    pub peak_buffered_bytes: usize,
}

/// Where the summary of a `simulate` run comes from (issue 31: statistics from the solution,
/// not from samples).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SummarySource {
    /// The exact propagator's segments: located event times, closed-form segment states
    /// integrated by Gauss rules, refined extremes (exact to rounding).
    Segments,
    /// The RK solution: the stepper's located events and the dense output of its accepted
    /// steps, integrated and refined the same way (accurate to the integration tolerance).
    DenseOutput,
    /// The output rows (a run with speed or torque profiles, or no statistics asked for).
    Samples,
}

impl SummarySource {
    /// A short name (the Python module's `statistics_source`).
    pub fn name(self) -> &'static str {
        match self {
            SummarySource::Segments => "exact segments",
            SummarySource::DenseOutput => "dense output",
            SummarySource::Samples => "output samples",
        }
    }
}

impl SimulateReport {
    /// The summary as `geardyn simulate` prints it.
    pub fn print(&self, out: &Path) {
        println!(
            "scene {} → {} ({} rows)",
            self.scene,
            out.display(),
            self.rows
        );
        println!("  method               {}", self.method);
        // Where the numbers come from: the continuous solution (event times, segment
        // integrals and refined extremes: the exact segments or the RK dense output), or,
        // with profiles, the output rows.
        let exact = self.meshes.iter().all(|m| m.response.is_some());
        let of = match self.source {
            SummarySource::Segments => "from the event times",
            SummarySource::DenseOutput => "from the RK solution's event times",
            SummarySource::Samples => "of output samples",
        };
        if self.pair {
            let m = &self.meshes[0];
            println!("  DTE RMS (mean removed) {:.6e} m", m.dte_rms);
            println!("  peak mesh force      {:.6e} N", m.peak_force);
            println!("  contact-loss fraction {:.6} ({of})", m.contact_loss);
        } else {
            for m in &self.meshes {
                println!(
                    "  {:<10} DTE RMS {:.6e} m, peak force {:.6e} N, total contact loss {:.6} ({of})",
                    m.name, m.dte_rms, m.peak_force, m.contact_loss
                );
            }
        }
        if exact {
            match self.source {
                SummarySource::DenseOutput => println!(
                    "  statistics over the run from the continuous solution (the RK steps' dense \
                     output, accurate to the integration tolerance; as `periodic` reports them):"
                ),
                _ => println!(
                    "  statistics over the run from the continuous solution (as `periodic` reports them):"
                ),
            }
            for m in &self.meshes {
                if let Some(r) = &m.response {
                    println!("    {}", r.report_line());
                }
            }
        }
        let st = &self.stats;
        println!(
            "  solver: {} steps, {} rejected, {} rhs evals, {} events, {} stops, {} guard evals",
            st.steps, st.rejected, st.rhs_evals, st.events, st.stops, st.guard_evals
        );
    }
}

/// Runs `scene` with `opts` and writes its outputs to the CSV file `out`, streaming: each row
/// goes to `.<out>.partial` as it is computed, and the file is renamed into place when the
/// run succeeds; on any error nothing is left at either path.
pub fn simulate(
    scene: Scene,
    opts: &SimulateOptions,
    out: &Path,
) -> Result<SimulateReport, String> {
    simulate_to(scene, opts, Destination::Csv(out))
}

/// The rows of a run held in memory ([`simulate_in_memory`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RowsInMemory {
    /// The output names (the CSV's columns after `time`).
    pub names: Vec<String>,
    pub times: Vec<f64>,
    /// Row after row, `names.len()` values each.
    pub values: Vec<f64>,
}

/// [`simulate`] with the rows held in memory instead of written to a file (the Python
/// module): the same run, the same rows and the same summary, bit for bit. A result of more
/// than [`crate::simulation::MAX_IN_MEMORY_VALUES`] values is refused before the run.
pub fn simulate_in_memory(
    scene: Scene,
    opts: &SimulateOptions,
) -> Result<(SimulateReport, RowsInMemory), String> {
    let mut rows = RowsInMemory::default();
    let report = simulate_to(scene, opts, Destination::Memory(&mut rows))?;
    Ok((report, rows))
}

/// Where the rows of a run go.
enum Destination<'a> {
    /// Streamed to this CSV file.
    Csv(&'a Path),
    /// Held in memory.
    Memory(&'a mut RowsInMemory),
}

fn simulate_to(
    mut scene: Scene,
    opts: &SimulateOptions,
    out: Destination,
) -> Result<SimulateReport, String> {
    let (stop_time, interval) = opts.apply(&mut scene.solver)?;
    let name = scene.name.to_owned();
    let pair = scene.kernel == KernelChoice::Pair;
    with_drivetrain!(scene.run()?, sim => {
        let names = sim.model().row_names();
        let meshes: Vec<(String, MeshColumns)> = (0..sim.model().mesh_count())
            .map(|n| {
                let prefix = sim.model().mesh_prefix(n);
                let label = if prefix.is_empty() { "mesh".to_owned() } else { prefix.trim_end_matches('.').to_owned() };
                (label, sim.model().mesh_columns(n))
            })
            .collect();
        let summed: Vec<usize> = meshes.iter().flat_map(|(_, c)| [c.dte, c.force]).collect();
        let tallies: Vec<(usize, f64)> = meshes.iter().map(|(_, c)| (c.contact, c.contact_value)).collect();
        let statistics = if opts.no_summary { None } else { RunStatistics::new(&sim) };
        let source = match &statistics {
            Some(_) if sim.observes_segments() => SummarySource::Segments,
            Some(_) => SummarySource::DenseOutput,
            None => SummarySource::Samples,
        };
        let (run, responses) = run_streamed(
            sim,
            &names,
            RunSummary::new(&summed, &tallies),
            |sim, row| sim.model().output_row(sim.t(), sim.y(), row),
            stop_time,
            interval,
            opts,
            out,
            statistics,
        )?;
        let mut responses = responses.map(Vec::into_iter);
        let meshes = meshes
            .into_iter()
            .map(|(name, c)| {
                let fraction = run.summary.fraction(c.contact, c.contact_value);
                let response = responses.as_mut().and_then(Iterator::next);
                let (dte_rms, peak_force, contact_loss) = match &response {
                    Some(r) => (r.dte_rms, r.peak_force, r.contact_loss_fraction),
                    None => (
                        run.summary.column(c.dte).rms_about_mean(),
                        run.summary.column(c.force).max_abs(),
                        if c.value_means_contact { 1.0 - fraction } else { fraction },
                    ),
                };
                MeshSummary {
                    name,
                    dte_rms,
                    peak_force,
                    contact_loss,
                    response,
                    dte_column: c.dte + 1,
                    force_column: c.force + 1,
                }
            })
            .collect();
        Ok(run.report(name, meshes, pair, source))
    })
}

/// Whether `simulate`'s summary of `scene` (its solver settings applied) comes from the
/// continuous solution ([`RunStatistics::new`]) rather than from the output rows.
pub fn summary_from_solution(scene: &Scene) -> Result<bool, String> {
    with_drivetrain!(scene.run()?, sim => Ok(RunStatistics::new(&sim).is_some()))
}

/// Reads the run's CSV back row by row (the run itself streams, so its outputs are only in the
/// file): `row(index, values)` with every column parsed (time first; unparsable cells NaN).
/// The one reader of `--plot` and `--spectrum`.
pub fn for_each_row(csv: &Path, mut row: impl FnMut(u64, &[f64])) -> Result<(), String> {
    use std::io::BufRead;
    let read_error = |e: std::io::Error| format!("{}: {e}", csv.display());
    let file = std::fs::File::open(csv).map_err(read_error)?;
    let mut fields: Vec<f64> = Vec::new();
    for (i, line) in std::io::BufReader::new(file).lines().skip(1).enumerate() {
        let line = line.map_err(read_error)?;
        fields.clear();
        fields.extend(line.split(',').map(|f| f.parse().unwrap_or(f64::NAN)));
        row(i as u64, &fields);
    }
    Ok(())
}

/// A finished streamed run.
struct Streamed {
    rows: u64,
    method: String,
    propagator: String,
    stats: SolverStats,
    work: f64,
    summary: RunSummary,
    peak_buffered_bytes: usize,
}

impl Streamed {
    fn report(
        self,
        scene: String,
        meshes: Vec<MeshSummary>,
        pair: bool,
        source: SummarySource,
    ) -> SimulateReport {
        SimulateReport {
            scene,
            rows: self.rows,
            method: self.method,
            propagator: self.propagator,
            stats: self.stats,
            work: self.work,
            meshes,
            pair,
            source,
            peak_buffered_bytes: self.peak_buffered_bytes,
        }
    }
}

/// The one streaming run of pair and drivetrain: limits first, then the file (or the memory
/// check), then the rows, with `summary` accumulated on the way.
#[allow(clippy::too_many_arguments)]
fn run_streamed<M: DrivenModel + Drivetrain>(
    mut sim: Driver<M>,
    names: &[String],
    mut summary: RunSummary,
    outputs: impl FnMut(&Driver<M>, &mut Vec<f64>),
    stop_time: f64,
    interval: f64,
    opts: &SimulateOptions,
    out: Destination,
    mut statistics: Option<RunStatistics>,
) -> Result<(Streamed, Option<Vec<MeshResponse>>), String> {
    opts.limits
        .check(&sim.model().run_scales(), stop_time, interval)?;
    let stream = |sink: &mut dyn RowSink| {
        stream_with(
            &mut sim,
            OutputGrid::new(stop_time, interval),
            outputs,
            sink,
            &mut summary,
            &mut Progress::with_display(stop_time, opts.progress),
            opts.limits.work_budget,
            |sim, t| match &mut statistics {
                Some(s) => s.advance(sim, t),
                None => sim.advance_to(t),
            },
        )
    };
    let (rows, peak_buffered_bytes) = match out {
        Destination::Csv(path) => {
            let mut columns: Vec<String> = std::iter::once("time".to_owned())
                .chain(names.iter().cloned())
                .collect();
            if opts.header_units {
                columns = crate::units::with_units(&columns)?;
            }
            let columns: Vec<&str> = columns.iter().map(String::as_str).collect();
            let mut writer = CsvWriter::create(path, &columns)?;
            stream(&mut writer)?;
            let counts = (writer.rows(), writer.peak_buffered_bytes());
            writer.finish()?;
            counts
        }
        Destination::Memory(memory) => {
            check_in_memory(stop_time, interval, names.len())?;
            memory.names = names.to_vec();
            let (times, values) = (&mut memory.times, &mut memory.values);
            stream(&mut FnSink(|t: f64, row: &[f64]| {
                times.push(t);
                values.extend_from_slice(row);
                Ok(())
            }))?;
            (memory.times.len() as u64, 0)
        }
    };
    let responses = statistics.map(|s| s.finish(&sim));
    let method = sim.method_choice().to_owned();
    Ok((
        Streamed {
            rows,
            method,
            propagator: sim.method_name(),
            stats: sim.stats(),
            work: sim.work_spent(),
            summary,
            peak_buffered_bytes,
        },
        responses,
    ))
}
