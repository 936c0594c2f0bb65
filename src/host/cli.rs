//! Running one FMU for `geardyn run` (its arguments, the supervised child, the output), and
//! the FMU opening and supervised loading that `geardyn info | validate`
//! (`crate::commands::inspect`) use.
//!
//! Every error is returned as a message (printed as `error: …`, exit code 1); nothing panics
//! on a bad FMU or bad arguments. The temporary folder of the unpacked FMU is owned by
//! [`Unpacked`] and removed on every return path. `run` loads and runs the FMU in a child
//! process ([`super::supervise`]), so that this also holds when the FMU crashes, exits or
//! blocks.

use super::archive::{unpack, Unpacked};
use super::check::check;
use super::csv::{CsvWriter, CutBack};
use super::description::{parse, CoSimulation, ModelDescription};
use super::input::Input;
use super::instance::Instance;
use super::library::{FmuLibrary, Status};
use super::logger::Logger;
use super::runner::{self, Experiment};
use super::start;
use super::supervise::{Activity, ChildEnd, HostPhase, SharedActivity, Supervisor};
use std::path::{Path, PathBuf};

#[derive(clap::Args, Debug)]
#[command(after_help = "\
Exit status:
  0  the run reached the stop time, or an FMU ended the simulation itself before it
     (fmi2Discard with fmi2Terminated = true, FMI 2.0.5 4.2.3, as fmpy does): the rows end
     at its last successful time (in a system: at the last communication point), and a
     note gives its reason
  1  anything else: a bad argument or FMU, a refused step (fmi2Discard without
     fmi2Terminated, fmi2Error, fmi2Fatal), a system whose state diverges, the FMU
     crashing or ending its process, SIGINT, SIGTERM or SIGHUP (also how a blocked FMU is
     ended: the first asks the run to stop at its next step, a second one or 0.9 s without
     reaching it kills the FMU's process). The rows computed until then are kept, and the
     message says what happened, in which FMI call, at which time and, in one line, the
     reason the FMU logged.

Systems (an .ssp archive, a SystemStructure.ssd file or a folder holding one, SSP 1.0): the
FMUs run in one process with a fixed-step master (--algorithm, --extrapolation; Jacobi steps
the FMUs on threads, --threads), which stops a diverging run (--divergence-factor); the CSV
has a column Element.connector per connected signal. The shipped example systems build their
missing FMUs from fmu/ on first use. See docs/systems.md.")]
pub struct RunArgs {
    /// The FMU (.fmu file or an extracted FMU folder), or a system of FMUs: an SSP 1.0 `.ssp`
    /// archive, a `SystemStructure.ssd` file, or a folder holding one (docs/systems.md).
    pub fmu: PathBuf,
    /// Start time, s (default: DefaultExperiment startTime, else 0).
    #[arg(long, allow_negative_numbers = true)]
    pub start_time: Option<f64>,
    /// Stop time, s (default: DefaultExperiment stopTime, else start + 1).
    #[arg(long, allow_negative_numbers = true)]
    pub stop_time: Option<f64>,
    /// Output interval = communication step, s (default: DefaultExperiment stepSize, doubled
    /// until ≤ 1000 steps; else 500–1000 round steps; as fmpy). Refused when below the time's
    /// floating-point resolution at the stop time, or when it gives more than --max-rows rows.
    #[arg(long, allow_negative_numbers = true)]
    pub output_interval: Option<f64>,
    /// The most output rows (grid points from start to stop time) a run may have.
    #[arg(long, default_value_t = runner::DEFAULT_MAX_ROWS)]
    pub max_rows: u64,
    /// Start value NAME=VALUE of a parameter or input (repeatable); in a system
    /// Element.variable=VALUE, which overrides the system's parameter bindings.
    #[arg(long = "start", value_name = "NAME=VALUE")]
    pub start: Vec<String>,
    /// Input signals: CSV with a `time` column and one column per input (fmpy's convention:
    /// continuous Reals interpolated linearly at each step start, others held).
    #[arg(long)]
    pub input: Option<PathBuf>,
    /// Output CSV (fmpy layout: "time" then the variables). Default: stdout.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Variables to record, comma separated (default: all outputs). In a system: the
    /// connected signals are always recorded; add others as Element.variable.
    #[arg(long, value_delimiter = ',')]
    pub outputs: Option<Vec<String>>,
    /// Print FMU log messages at or above this status: all | warning | discard | error | fatal.
    /// `all` also switches on the FMU's debug logging (fmi2SetDebugLogging, all categories).
    #[arg(long, default_value = "warning")]
    pub log_level: String,
    /// Trace every FMI call with its arguments and status to stderr.
    #[arg(long)]
    pub fmi_trace: bool,
    /// Load this shared library globally before the FMU (repeatable), for FMUs that need an
    /// execution tool in the process, e.g. `--preload libpython3.11.so` for a PythonFMU.
    #[arg(long, value_name = "LIB")]
    pub preload: Vec<PathBuf>,
    /// Systems: the master algorithm, jacobi or gauss-seidel (default; the order follows the
    /// connections, a cycle is cut at the connection that closes it).
    #[arg(long, value_name = "ALGORITHM")]
    pub algorithm: Option<String>,
    /// Systems: none (zero-order hold) or linear (default): inputs extrapolated with the
    /// producer's output derivative (fmi2GetRealOutputDerivatives → fmi2SetRealInputDerivatives)
    /// where both FMUs can, else held, with a note naming the connection.
    #[arg(long, value_name = "MODE")]
    pub extrapolation: Option<String>,
    /// Systems with --algorithm jacobi: threads for the FMUs' steps (results bit-identical
    /// to one thread). Default: the number of cores for ≥ 3 FMUs that all allow several
    /// instances per process, kept only where a measured handoff to the threads costs less
    /// than the work it moves (docs/systems.md), else 1.
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// Systems: stop when a connected speed, torque or force grows more than this factor
    /// within the second half of the run so far (faster than any power of time: a diverging
    /// coupling; docs/systems.md); 0 turns the check off. Default 1000.
    #[arg(long, value_name = "FACTOR")]
    pub divergence_factor: Option<f64>,
    /// Systems: control the communication step by the coupling error (docs/cosimulation.md,
    /// "Error-controlled master"): each step's relative error estimate ≤ TOL, a step over it
    /// is undone (fmi2SetFMUstate) and redone smaller. Rows stay on --output-interval's grid;
    /// the step sequence goes to `<out>.steps.csv`.
    #[arg(long, value_name = "TOL")]
    pub tolerance: Option<f64>,
    /// Systems with --tolerance: the smallest communication step, s (default: the output
    /// interval / 1e6).
    #[arg(long, value_name = "S")]
    pub min_step: Option<f64>,
    /// Systems with --tolerance: the largest communication step, s (default: the output
    /// interval).
    #[arg(long, value_name = "S")]
    pub max_step: Option<f64>,
    /// Systems with --tolerance: do not carry each step's impulse deficit into the next step
    /// (for comparison; the correction keeps the drivetrain's angle from drifting).
    #[arg(long)]
    pub no_impulse_correction: bool,
    /// Systems with --tolerance: do not end steps at the switch times an FMU announces (its
    /// mesh stiffness knots; for comparison: the master then finds the kinks by its error
    /// estimate alone).
    #[arg(long)]
    pub no_switch_steps: bool,
    /// Systems: load every FMU's own binary, also where FMUs with byte-identical binaries
    /// announce that one loaded copy may serve them all (geardyn's `<SharedBinary/>`,
    /// docs/fmu.md "One binary for several FMUs"; for comparison).
    #[arg(long)]
    pub no_shared_binaries: bool,
    /// Report where the time went: the step loop, the part inside the FMU's calls, CSV writing.
    #[arg(long)]
    pub timing: bool,
}

/// Unpacks an FMU and parses its model description: the first two steps of every command
/// on an FMU.
pub fn open(fmu: &Path) -> Result<(Unpacked, ModelDescription), String> {
    let unpacked = unpack(fmu)?;
    let text = unpacked.model_description_text()?;
    let md = parse(&text, "modelDescription.xml")?;
    Ok((unpacked, md))
}

/// Loads the FMU's library with its 34 functions in a forked child; `Some(problem)` when it
/// cannot be loaded or its process dies while loading it.
pub fn supervised_load(
    supervisor: &Supervisor,
    root: &Path,
    model_identifier: &str,
) -> Result<Option<String>, String> {
    let shared = SharedActivity::new()?;
    let activity = shared.get();
    // The child's load error comes back through a pipe (read after the child has ended).
    let mut fds = [0 as libc::c_int; 2];
    // SAFETY: creates a pipe into `fds`.
    if unsafe { libc::pipe(fds.as_mut_ptr()) } != 0 {
        return Err(format!(
            "cannot create a pipe to the process that loads the FMU: {}",
            std::io::Error::last_os_error()
        ));
    }
    // SAFETY: the two descriptors were just created and are owned here.
    let (read, write) = unsafe {
        use std::os::fd::FromRawFd;
        (
            std::fs::File::from_raw_fd(fds[0]),
            std::fs::File::from_raw_fd(fds[1]),
        )
    };
    if let Some(signal) = supervisor.pending_interrupt() {
        return Err(format!("interrupted by {signal} before the FMU was loaded"));
    }
    let end = supervisor.run(activity, || {
        activity.phase(HostPhase::LoadingLibrary);
        match FmuLibrary::load(root, model_identifier) {
            Ok(_) => 0,
            Err(e) => {
                use std::io::Write as _;
                let mut write = &write;
                let _ = write.write_all(e.as_bytes());
                1
            }
        }
    })?;
    drop(write);
    Ok(match end {
        ChildEnd::Reported(0) => None,
        ChildEnd::Reported(_) => {
            use std::io::Read as _;
            let mut message = String::new();
            let _ = (&read).take(1 << 16).read_to_string(&mut message);
            Some(if message.is_empty() {
                "the FMU's library could not be loaded".into()
            } else {
                message
            })
        }
        ChildEnd::Abnormal(what) => Some(what),
    })
}

fn positive(name: &str, v: f64) -> Result<f64, String> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(format!("--{name} {v}: must be a finite number > 0"))
    }
}

/// `file://` URI of a folder (FMI 2.0.5 §2.1.5 fmuResourceLocation), percent-encoded exactly
/// like Python's `pathlib.Path.as_uri` (`urllib.parse.quote`, safe = "/"), which fmpy passes.
pub(crate) fn file_uri(p: &Path) -> String {
    let mut s = String::from("file://");
    for b in p.to_string_lossy().bytes() {
        if b.is_ascii_alphanumeric() || b"/-._~".contains(&b) {
            s.push(b as char);
        } else {
            s.push_str(&format!("%{b:02X}"));
        }
    }
    s
}

/// Check the user's request against the model description and build the experiment: start
/// values, time grid defaults (fmpy's), input signals, recorded variables.
fn plan<'a>(
    args: &RunArgs,
    md: &ModelDescription,
    pairs: &[(String, String)],
    activity: &'a Activity,
) -> Result<Experiment<'a>, String> {
    let start_values = start::resolve(md, pairs)?;
    let de = md.default_experiment.clone().unwrap_or_default();
    let start_time = args.start_time.or(de.start_time).unwrap_or(0.0);
    let stop_time = args.stop_time.or(de.stop_time).unwrap_or(start_time + 1.0);
    if !stop_time.is_finite() || stop_time <= start_time {
        return Err(format!(
            "stop time {stop_time} must be finite and after the start time {start_time}"
        ));
    }
    let output_interval = args
        .output_interval
        .unwrap_or_else(|| runner::default_interval(md, start_time, stop_time));
    runner::check_grid(start_time, stop_time, output_interval, args.max_rows)?;
    let input = match &args.input {
        Some(p) => {
            let inp = Input::from_csv(p, md)?;
            for w in &inp.warnings {
                eprintln!("warning: {}: {w}", p.display());
            }
            Some(inp)
        }
        None => None,
    };
    let outputs = match &args.outputs {
        Some(names) => {
            let n: Vec<&str> = names
                .iter()
                .map(|s| s.trim())
                .filter(|s| !s.is_empty())
                .collect();
            runner::recorded(md, &n, true)?
        }
        None => runner::recorded(md, &runner::default_outputs(md), false)?,
    };
    let exp = Experiment {
        start_time,
        stop_time,
        tolerance: de.tolerance,
        output_interval,
        start_values,
        input,
        outputs,
        timing: args.timing,
        interrupt: Some(activity.stop_request()),
    };

    Ok(exp)
}

/// Print a failure as `main` does for the other commands; the exit code. A closed pipe on
/// the output (`geardyn run x.fmu | head`) ends quietly ([`crate::pipe`]).
pub(crate) fn report(result: Result<(), String>) -> u8 {
    match result {
        Ok(()) => 0,
        Err(message) if crate::pipe::is_broken_pipe(&message) => crate::pipe::BROKEN_PIPE_STATUS,
        Err(message) => {
            eprintln!("error: {message}");
            1
        }
    }
}

/// Where the rows go: a file can be cut back after a crash (see [`CutBack`]), stdout not.
pub(crate) fn open_output(out: &Option<PathBuf>) -> Result<Box<dyn CutBack>, String> {
    Ok(match out {
        Some(p) => Box::new(
            std::fs::File::create(p).map_err(|e| format!("{}: cannot create: {e}", p.display()))?,
        ),
        None => Box::new(std::io::stdout()),
    })
}

/// " (12 rows up to t = 1.1 were written to out.csv)" after a failure, when written to a file.
pub(crate) fn rows_kept(out: &Option<PathBuf>, (rows, last): (usize, Option<f64>)) -> String {
    match (out, last) {
        (Some(p), Some(t)) => format!(
            " ({rows} rows up to t = {t} were written to {})",
            p.display()
        ),
        _ => String::new(),
    }
}

/// The parent's part: unpack, check and plan, write the CSV header, then run the FMU in a
/// child process and wait. The child reports its own end (message, exit code); when it dies
/// instead, its pending rows are written here and the message says how it ended. The
/// temporary folder is removed when `unpacked` is dropped, in every case.
pub(crate) fn supervised_run(args: &RunArgs) -> Result<u8, String> {
    if args.algorithm.is_some()
        || args.extrapolation.is_some()
        || args.divergence_factor.is_some()
        || args.threads.is_some()
    {
        return Err(format!(
            "{}: --algorithm, --extrapolation, --threads and --divergence-factor are for systems (.ssp, .ssd or a folder with SystemStructure.ssd), not a single FMU",
            args.fmu.display()
        ));
    }
    let log_level = Status::parse_level(&args.log_level).ok_or_else(|| {
        format!(
            "--log-level \"{}\": expected all, warning, discard, error or fatal",
            args.log_level
        )
    })?;
    let setup = std::time::Instant::now();
    // Before the temporary folder exists: from here on, an interrupt cannot end this process
    // with the folder left behind.
    let supervisor = Supervisor::new()?;
    let pairs = args
        .start
        .iter()
        .map(|a| start::parse_arg(a))
        .collect::<Result<Vec<_>, _>>()?;
    if let Some(h) = args.output_interval {
        positive("output-interval", h)?;
    }
    let (unpacked, md) = open(&args.fmu)?;
    let Some(cs) = md.co_simulation.clone() else {
        return Err(match &md.model_exchange {
            Some(id) => format!("{}: the FMU is Model Exchange only (<ModelExchange modelIdentifier=\"{id}\">, no <CoSimulation>); geardyn run needs an FMI 2.0 Co-Simulation FMU", args.fmu.display()),
            None => format!("{}: the FMU declares no <CoSimulation> interface", args.fmu.display()),
        });
    };
    let problems = check(&md);
    if !problems.is_empty() {
        eprintln!(
            "warning: modelDescription.xml has {} problem(s) (see `geardyn validate`); running anyway",
            problems.len()
        );
    }
    let shared = SharedActivity::new()?;
    let activity = shared.get();
    let exp = plan(args, &md, &pairs, activity)?;
    let names: Vec<String> = exp.outputs.iter().map(|o| o.name.clone()).collect();
    let where_to = args
        .out
        .as_ref()
        .map_or_else(|| "stdout".to_string(), |p| p.display().to_string());
    // No BufWriter: the CSV writer formats and writes whole blocks of rows.
    let mut csv = CsvWriter::new(open_output(&args.out)?, &names)
        .map_err(|e| format!("{where_to}: cannot write: {e}"))?;
    let child = ChildRun {
        args,
        root: unpacked.root(),
        cs: &cs,
        guid: &md.guid,
        exp: &exp,
        activity,
        log_level,
        where_to: &where_to,
        setup,
    };
    if let Some(signal) = supervisor.pending_interrupt() {
        return Err(format!("interrupted by {signal} before the FMU was loaded"));
    }
    let end = supervisor.run(activity, || report(child.run(&mut csv)))?;
    match end {
        ChildEnd::Reported(code) => Ok(code),
        ChildEnd::Abnormal(what) => {
            let completed = csv.complete_after_writer_died();
            Err(match completed {
                Ok(()) => format!("{what}{}", rows_kept(&args.out, csv.written())),
                Err(e) => {
                    format!("{what}; also: {where_to}: cannot write the rows computed before: {e}")
                }
            })
        }
    }
}

/// What the parent prepared for the child: the unpacked FMU and the planned experiment.
struct ChildRun<'a> {
    args: &'a RunArgs,
    root: &'a Path,
    cs: &'a CoSimulation,
    guid: &'a str,
    exp: &'a Experiment<'a>,
    activity: &'a Activity,
    log_level: Status,
    where_to: &'a str,
    setup: std::time::Instant,
}

impl ChildRun<'_> {
    /// The child's part: load the FMU, instantiate it, run the loop into `csv`, free it.
    fn run(&self, csv: &mut CsvWriter<Box<dyn CutBack>>) -> Result<(), String> {
        let (args, cs, activity) = (self.args, self.cs, self.activity);
        activity.phase(HostPhase::Preloading);
        super::library::preload(&args.preload)?;
        activity.phase(HostPhase::LoadingLibrary);
        let lib = FmuLibrary::load(self.root, &cs.model_identifier).map_err(|e| {
            if cs.needs_execution_tool && e.contains("undefined symbol") {
                format!("{e}\n  hint: the FMU declares needsExecutionTool=\"true\"; load the tool's library first with --preload (a PythonFMU needs libpython3.X.so)")
            } else {
                e
            }
        })?;
        let logger = Logger::new(self.log_level);
        let debug = logger.prints_all();
        let mut inst = Instance::instantiate(
            &lib,
            &cs.model_identifier,
            self.guid,
            &file_uri(&self.root.join("resources")),
            logger,
            args.fmi_trace,
            activity,
        )?;
        if debug {
            // Not fatal: debug logging is a convenience.
            if let Err(e) = inst.set_debug_logging(true) {
                eprintln!("warning: {e}");
            }
        }
        let outcome = runner::run(
            &mut inst,
            self.exp,
            cs.can_handle_variable_communication_step_size,
            csv,
        );
        drop(inst); // fmi2FreeInstance before the library is unloaded
        let flushed = csv
            .flush()
            .map_err(|e| format!("{}: cannot write: {e}", self.where_to));
        if let Some(t) = outcome.timing {
            report_timing(&t, outcome.rows, self.setup.elapsed().as_secs_f64());
        }
        for n in &outcome.notes {
            eprintln!("note: {n}");
        }
        match (&outcome.failure, flushed) {
            (Some(f), Ok(())) => Err(format!("{f}{}", rows_kept(&args.out, csv.written()))),
            (Some(f), Err(w)) => Err(format!("{f}; also: {w}")),
            (None, r) => r,
        }
    }
}

/// The `--timing` line: where the step loop's time went, and the time outside it.
fn report_timing(t: &runner::Timing, rows: usize, total_seconds: f64) {
    let pct = |x: f64| 100.0 * x / t.loop_seconds.max(1e-300);
    let own = t.loop_seconds - t.fmu_seconds - t.sink_seconds;
    eprintln!(
        "timing: {} steps in {:.3} s: inside fmi2DoStep/fmi2Get* {:.3} s ({:.1}%), CSV formatting {:.3} s ({:.1}%), runner {:.3} s ({:.1}%); outside the loop (unzip, load, instantiate, initialize, free) {:.3} s",
        rows.saturating_sub(1),
        t.loop_seconds,
        t.fmu_seconds,
        pct(t.fmu_seconds),
        t.sink_seconds,
        pct(t.sink_seconds),
        own,
        pct(own),
        total_seconds - t.loop_seconds,
    );
}

#[cfg(test)]
mod tests {
    use super::file_uri;
    use std::path::Path;

    #[test]
    fn uri_is_percent_encoded() {
        assert_eq!(
            file_uri(Path::new("/tmp/a b/résources")),
            "file:///tmp/a%20b/r%C3%A9sources"
        );
    }
}
