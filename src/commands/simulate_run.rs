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
    /// Fraction of the run in contact loss (single pair: not in drive-side contact;
    /// drivetrain: no tooth pair in contact): from the located event times when
    /// `response` is there, else of the output rows.
    pub contact_loss: f64,
    /// The mesh's statistics over the run from the continuous solution
    /// ([`crate::analysis::orbit_statistics::RunStatistics`]: the exact propagator); `None`
    /// on the RK propagator or with `--quiet`, where the fields above are of the output rows.
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
    pub method: String,
    pub stats: SolverStats,
    /// Work units the run spent against its budget ([`crate::simulation::budget`]).
    pub work: f64,
    pub meshes: Vec<MeshSummary>,
    /// Whether the scene is a single pair (its summary is printed in the pair's layout).
    pub pair: bool,
    /// The most bytes of output the writer held at once (bounded by its buffer).
    pub peak_buffered_bytes: usize,
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
        // integrals and refined extremes), or, on the RK propagator, the output rows.
        let exact = self.meshes.iter().all(|m| m.response.is_some());
        let of = if exact {
            "from the event times"
        } else {
            "of output samples"
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
            println!("  statistics over the run from the continuous solution (as `periodic` reports them):");
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
    mut scene: Scene,
    opts: &SimulateOptions,
    out: &Path,
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
        let (run, responses) = run_to_csv(
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
        Ok(run.report(name, meshes, pair))
    })
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
    stats: SolverStats,
    work: f64,
    summary: RunSummary,
    peak_buffered_bytes: usize,
}

impl Streamed {
    fn report(self, scene: String, meshes: Vec<MeshSummary>, pair: bool) -> SimulateReport {
        SimulateReport {
            scene,
            rows: self.rows,
            method: self.method,
            stats: self.stats,
            work: self.work,
            meshes,
            pair,
            peak_buffered_bytes: self.peak_buffered_bytes,
        }
    }
}

/// The one streaming run of pair and drivetrain: limits first, then the file, then the rows,
/// with `summary` accumulated on the way.
#[allow(clippy::too_many_arguments)]
fn run_to_csv<M: DrivenModel + Drivetrain>(
    mut sim: Driver<M>,
    names: &[String],
    mut summary: RunSummary,
    outputs: impl FnMut(&Driver<M>, &mut Vec<f64>),
    stop_time: f64,
    interval: f64,
    opts: &SimulateOptions,
    out: &Path,
    mut statistics: Option<RunStatistics>,
) -> Result<(Streamed, Option<Vec<MeshResponse>>), String> {
    opts.limits
        .check(&sim.model().run_scales(), stop_time, interval)?;
    let mut columns: Vec<String> = std::iter::once("time".to_owned())
        .chain(names.iter().cloned())
        .collect();
    if opts.header_units {
        columns = crate::units::with_units(&columns)?;
    }
    let columns: Vec<&str> = columns.iter().map(String::as_str).collect();
    let mut writer = CsvWriter::create(out, &columns)?;
    stream_with(
        &mut sim,
        OutputGrid::new(stop_time, interval),
        outputs,
        &mut writer,
        &mut summary,
        &mut Progress::with_display(stop_time, opts.progress),
        opts.limits.work_budget,
        |sim, t| match &mut statistics {
            Some(s) => s.advance(sim, t),
            None => sim.advance_to(t),
        },
    )?;
    let responses = statistics.map(|s| s.finish(&sim));
    let rows = writer.rows();
    let peak_buffered_bytes = writer.peak_buffered_bytes();
    writer.finish()?;
    let method = sim.method_choice().to_owned();
    Ok((
        Streamed {
            rows,
            method,
            stats: sim.stats(),
            work: sim.work_spent(),
            summary,
            peak_buffered_bytes,
        },
        responses,
    ))
}
