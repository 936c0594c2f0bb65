//! The co-simulation master loop for one FMI 2.0 CS FMU (FMI 2.0.5 §4.2.4, the calling
//! sequence of Co-Simulation): instantiate → setup experiment → start values → initialization
//! mode (start values, inputs) → step loop on the output grid → terminate → free.
//!
//! The grid, the time defaults and the input handling follow fmpy 0.3.32 `simulate_fmu` /
//! `simulateCS` so that the two give the same rows, bit for bit, on the same FMU:
//! * start time: `DefaultExperiment.startTime` or 0; stop time: `--stop-time`,
//!   `DefaultExperiment.stopTime`, or start + 1; tolerance: `DefaultExperiment.tolerance`
//!   (passed to `fmi2SetupExperiment` only when given); the stop time is always passed.
//! * output interval `h`: `--output-interval`, else `DefaultExperiment.stepSize` doubled until
//!   there are at most 1000 steps, else fmpy's `auto_interval` (500–1000 steps).
//! * communication points `start + n·h` (not accumulated), shortened to an input event when the
//!   FMU can handle a variable step size; the last step is shortened to the stop time only if
//!   `canHandleVariableCommunicationStepSize="true"` (§4.3.1), otherwise the run ends at the
//!   last full grid point before the stop time (and says so).
//! * one output row at the start time and one after every `fmi2DoStep`.
//!
//! Rows go to a [`RowSink`] as they are sampled. A failing call ends the loop: the rows computed
//! until then have been delivered, and the failure (call, time, status, the FMU's logged
//! reason) is returned. After `fmi2Discard`, `fmi2GetBooleanStatus(fmi2Terminated)` and
//! `fmi2GetRealStatus(fmi2LastSuccessfulTime)` are asked (FMI 2.0.5 §4.2.3). An FMU that
//! ends the simulation itself (`fmi2Terminated = true`: a stair at its last step, a drive
//! cycle that is over) ends the run normally, as in fmpy's `simulate_fmu` and the
//! Reference-FMUs' co-simulation example: a row at its last successful time, a note with its
//! reason, exit 0 (issue 39). A Discard without it is a refused step: a failure (exit 1).

use super::csv::Row;
use super::description::{Causality, ModelDescription, Value, VarType};
use super::input::{isclose, Input, Values};
use super::instance::{CallError, Instance};
use super::start::{Phase, StartValue};

/// What the user asked for (already checked against the model description).
pub struct Experiment<'a> {
    pub start_time: f64,
    pub stop_time: f64,
    pub tolerance: Option<f64>,
    pub output_interval: f64,
    pub start_values: Vec<StartValue>,
    pub input: Option<Input>,
    pub outputs: Vec<Recorded>,
    /// Measure the time spent inside `fmi2DoStep` and the output getters (`--timing`).
    pub timing: bool,
    /// Polled before every step: when set, the run stops as after a failure.
    pub interrupt: Option<&'a std::sync::atomic::AtomicBool>,
}

/// One recorded variable.
#[derive(Debug, Clone)]
pub struct Recorded {
    pub name: String,
    pub vr: u32,
    pub var_type: VarType,
}

/// Where the step loop's time went (`--timing`).
#[derive(Debug, Clone, Copy)]
pub struct Timing {
    pub loop_seconds: f64,
    pub fmu_seconds: f64,
    pub sink_seconds: f64,
}

/// Receives each output row as soon as it is sampled.
pub trait RowSink {
    fn row(&mut self, t: f64, row: &Row) -> std::io::Result<()>;
}

impl<W: std::io::Write> RowSink for super::csv::CsvWriter<W> {
    fn row(&mut self, t: f64, row: &Row) -> std::io::Result<()> {
        super::csv::CsvWriter::row(self, t, row)
    }
}

/// How a run ended (the rows went to the [`RowSink`]).
pub struct Outcome {
    /// Rows delivered to the sink.
    pub rows: usize,
    /// `Some(reason)` when the run failed; the rows up to the failure are still there.
    pub failure: Option<String>,
    /// Notes that are not failures (early stop, FMU-requested termination).
    pub notes: Vec<String>,
    /// With [`Experiment::timing`]: seconds in the step loop, of which inside the FMU's
    /// fmi2DoStep/fmi2Get* calls and in the row sink (CSV formatting), so the runner's own
    /// share can be reported.
    pub timing: Option<Timing>,
}

/// fmpy `util.auto_interval`: a round interval giving 500–1000 steps over `t`.
pub fn auto_interval(t: f64) -> f64 {
    // np.round rounds half to even, as f64::round_ties_even does.
    let mut h = 10f64.powf((t.log10()).round_ties_even() - 3.0);
    let n = t / h;
    if n >= 2500.0 {
        h *= 5.0;
    } else if n >= 2000.0 {
        h *= 4.0;
    } else if n >= 1000.0 {
        h *= 2.0;
    } else if n <= 200.0 {
        h /= 5.0;
    } else if n <= 250.0 {
        h /= 4.0;
    } else if n <= 500.0 {
        h /= 2.0;
    }
    h
}

/// The default output interval (fmpy `simulate_fmu`, CS branch).
pub fn default_interval(md: &ModelDescription, start: f64, stop: f64) -> f64 {
    match md.default_experiment.as_ref().and_then(|d| d.step_size) {
        Some(mut h) if h > 0.0 && h.is_finite() => {
            while (stop - start) / h > 1000.0 {
                h *= 2.0;
            }
            h
        }
        _ => auto_interval(stop - start),
    }
}

/// The most output rows a run may have unless the user raises it (`geardyn run --max-rows`):
/// ten million rows are a CSV of about a gigabyte for ten columns. A mistyped interval
/// (`1e-300` for `1e-3`) must be refused, not fill the disk.
pub const DEFAULT_MAX_ROWS: u64 = 10_000_000;

/// Refuse a grid that cannot advance or would give more than `max_rows` rows: the output
/// interval `h` must not be below the spacing of `f64` at the larger of the start and stop
/// times (there, `start + n·h` would stop advancing or round unevenly), and the grid points
/// from `start` to `stop`, both included, must be at most `max_rows` (rows added at input
/// events are extra).
pub fn check_grid(start: f64, stop: f64, h: f64, max_rows: u64) -> Result<(), String> {
    let largest = start.abs().max(stop.abs());
    let resolution = f64::from_bits(largest.to_bits() + 1) - largest;
    if h < resolution {
        return Err(format!(
            "output interval {h:?} s is below the resolution of the time at {largest:?} s ({resolution:?} s): the communication points would not advance"
        ));
    }
    let rows = ((stop - start) / h).ceil() + 1.0;
    if rows > max_rows as f64 {
        let shown = if rows < 1e15 {
            format!("{rows:.0}")
        } else {
            format!("{rows:e}")
        };
        return Err(format!(
            "output interval {h:?} s from t = {start:?} to {stop:?} s gives {shown} output rows, more than the maximum of {max_rows} (--max-rows raises it)"
        ));
    }
    Ok(())
}

/// The variables recorded when `--outputs` is not given (fmpy `_get_output_variables`): all
/// outputs; else up to 5 continuous states (the targets of `derivative=`); else the first 5
/// variables. String variables are never recorded (fmpy records Real, Integer, Boolean), nor
/// a variable named `time` (the time column).
pub fn default_outputs(md: &ModelDescription) -> Vec<&str> {
    let outs: Vec<&str> = md
        .variables
        .iter()
        .filter(|v| v.causality == Causality::Output)
        .map(|v| v.name.as_str())
        .collect();
    if !outs.is_empty() {
        return outs;
    }
    let states: Vec<&str> = md
        .model_structure
        .derivatives
        .iter()
        .flatten()
        .filter_map(|u| md.variables.get(u.index.wrapping_sub(1)))
        .filter_map(|d| d.derivative)
        .filter_map(|s| md.variables.get((s as usize).wrapping_sub(1)))
        .map(|v| v.name.as_str())
        .take(5)
        .collect();
    if !states.is_empty() {
        return states;
    }
    md.variables
        .iter()
        .take(5)
        .map(|v| v.name.as_str())
        .collect()
}

/// Resolve output names to recorded columns, in fmpy's column order: Reals, then Integers
/// (and Enumerations), then Booleans, each in document order. An unknown name or a String
/// variable is an error when `explicit` (the user named it), skipped otherwise.
pub fn recorded(
    md: &ModelDescription,
    names: &[&str],
    explicit: bool,
) -> Result<Vec<Recorded>, String> {
    if explicit {
        for n in names {
            match md.variable(n) {
                None => return Err(format!("--outputs: the FMU has no variable named \"{n}\"")),
                Some(v) if v.var_type == VarType::String => {
                    return Err(format!("--outputs: \"{n}\" is a String variable; only Real, Integer, Enumeration and Boolean variables can be recorded"))
                }
                Some(_) if *n == "time" => {
                    return Err("--outputs: \"time\" is always the first column".into())
                }
                _ => {}
            }
        }
    }
    let mut out = Vec::new();
    for kind in [VarType::Real, VarType::Integer, VarType::Boolean] {
        for v in &md.variables {
            let base = if v.var_type == VarType::Enumeration {
                VarType::Integer
            } else {
                v.var_type
            };
            if base == kind && v.name != "time" && names.contains(&v.name.as_str()) {
                out.push(Recorded {
                    name: v.name.clone(),
                    vr: v.value_reference,
                    var_type: base,
                });
            }
        }
    }
    Ok(out)
}

/// Reads the recorded variables with one `fmi2Get*` call per type, into buffers sized once.
struct Sampler {
    real_vr: Vec<u32>,
    int_vr: Vec<u32>,
    bool_vr: Vec<u32>,
    real: Vec<f64>,
    int: Vec<i32>,
    boolean: Vec<i32>,
}

impl Sampler {
    fn new(outputs: &[Recorded]) -> Sampler {
        let vrs = |t: VarType| -> Vec<u32> {
            outputs
                .iter()
                .filter(|o| o.var_type == t)
                .map(|o| o.vr)
                .collect()
        };
        let (real_vr, int_vr, bool_vr) = (
            vrs(VarType::Real),
            vrs(VarType::Integer),
            vrs(VarType::Boolean),
        );
        Sampler {
            real: vec![0.0; real_vr.len()],
            int: vec![0; int_vr.len()],
            boolean: vec![0; bool_vr.len()],
            real_vr,
            int_vr,
            bool_vr,
        }
    }

    /// Read the outputs; the row borrows the buffers.
    fn sample(&mut self, inst: &mut Instance) -> Result<Row<'_>, CallError> {
        if !self.real_vr.is_empty() {
            inst.get_real(&self.real_vr, &mut self.real)?;
        }
        if !self.int_vr.is_empty() {
            inst.get_integer(&self.int_vr, &mut self.int)?;
        }
        if !self.bool_vr.is_empty() {
            inst.get_boolean(&self.bool_vr, &mut self.boolean)?;
        }
        Ok(Row {
            reals: &self.real,
            integers: &self.int,
            booleans: &self.boolean,
        })
    }
}

fn set_start(inst: &mut Instance, s: &StartValue) -> Result<(), String> {
    let r = match &s.value {
        Value::Real(v) => inst.set_real(&[s.vr], &[*v]),
        Value::Integer(v) => inst.set_integer(&[s.vr], &[*v]),
        Value::Boolean(v) => inst.set_boolean(&[s.vr], &[i32::from(*v)]),
        Value::String(v) => inst.set_string(&[s.vr], std::slice::from_ref(v)),
    };
    r.map(|_| ())
        .map_err(|e| format!("setting the start value of \"{}\": {e}", s.name))
}

fn apply_input(
    inst: &mut Instance,
    input: &Input,
    t: f64,
    after_event: bool,
) -> Result<(), CallError> {
    for g in &input.groups {
        match (input.values(g, t, after_event), g.setter) {
            (Values::Real(v), _) => inst.set_real(&g.vrs, &v)?,
            (Values::Int(v), super::input::Setter::Boolean) => {
                // fmi2Boolean is 0/1; numpy's cast of e.g. 2.0 gives 2, which FMUs treat as true.
                inst.set_boolean(&g.vrs, &v)?
            }
            (Values::Int(v), _) => inst.set_integer(&g.vrs, &v)?,
        };
    }
    Ok(())
}

/// Sample the outputs at `t` and hand the row to the sink; a failure message on error.
fn record(
    sampler: &mut Sampler,
    inst: &mut Instance,
    sink: &mut dyn RowSink,
    out: &mut Outcome,
    t: f64,
) -> Result<(), String> {
    let row = sampler
        .sample(inst)
        .map_err(|err| format!("reading outputs at t = {t}: {err}"))?;
    sink.row(t, &row)
        .map_err(|e| format!("writing the output row at t = {t}: {e}"))?;
    out.rows += 1;
    Ok(())
}

/// A run whose FMU returned `fmi2Discard` with `fmi2Terminated = true` in the step from
/// `time` (FMI 2.0.5 §4.2.3) ends there: a row at its last successful time `last` when it is
/// past `time` (as fmpy's `simulate_fmu` samples there), and a note with the FMU's reason. Not
/// a failure: the FMU ended the simulation itself. Returns the time the rows end at.
fn ended_by_fmu(
    inst: &mut Instance,
    sampler: &mut Sampler,
    sink: &mut dyn RowSink,
    out: &mut Outcome,
    (time, last, stop): (f64, Option<f64>, f64),
    err: &CallError,
) -> Result<f64, String> {
    let end = last.filter(|&tl| tl > time).unwrap_or(time);
    if end > time {
        inst.activity().at(end);
        record(sampler, inst, sink, out, end)?;
    }
    out.notes.push(format!(
        "the FMU ended the simulation itself at t = {end}, before the stop time {stop} (fmi2Terminated after {}); the rows end there",
        err.message
    ));
    Ok(end)
}

/// Initialize and run the instance, giving every output row to `sink` as it is computed.
/// Never panics; on failure the rows up to then have been delivered.
pub fn run(
    inst: &mut Instance,
    exp: &Experiment,
    can_handle_variable_step: bool,
    sink: &mut dyn RowSink,
) -> Outcome {
    let mut out = Outcome {
        rows: 0,
        failure: None,
        notes: Vec::new(),
        timing: None,
    };
    let mut sampler = Sampler::new(&exp.outputs);
    let t0 = exp.start_time;
    let activity = inst.activity();
    activity.at(t0);

    // Initialization (FMI 2.0.5 §4.2.4 state machine: instantiated → initialization mode).
    let init = (|| -> Result<(), String> {
        let e = |err: CallError| format!("initialization at t = {t0}: {err}");
        inst.setup_experiment(exp.tolerance, t0, Some(exp.stop_time))
            .map_err(e)?;
        for s in exp
            .start_values
            .iter()
            .filter(|s| s.phase == Phase::Instantiated)
        {
            set_start(inst, s)?;
        }
        inst.enter_initialization_mode().map_err(e)?;
        for s in exp
            .start_values
            .iter()
            .filter(|s| s.phase == Phase::Initialization)
        {
            set_start(inst, s)?;
        }
        if let Some(input) = &exp.input {
            apply_input(inst, input, t0, false).map_err(e)?;
        }
        inst.exit_initialization_mode().map_err(e)?;
        Ok(())
    })();
    if let Err(msg) = init {
        out.failure = Some(msg);
        return out;
    }
    if let Err(msg) = record(&mut sampler, inst, sink, &mut out, t0) {
        out.failure = Some(msg);
        return out;
    }

    let h = exp.output_interval;
    let stop = exp.stop_time;
    let mut time = t0;
    let mut n_steps: u64 = 0;
    let loop_start = std::time::Instant::now();
    let mut in_fmu = std::time::Duration::ZERO;
    let mut in_sink = std::time::Duration::ZERO;
    loop {
        if time > stop || isclose(time, stop) {
            break;
        }
        if exp
            .interrupt
            .is_some_and(|f| f.load(std::sync::atomic::Ordering::Relaxed))
        {
            out.failure = Some(format!("interrupted at t = {time}"));
            let _ = inst.terminate();
            return out;
        }
        let next_regular = t0 + (n_steps + 1) as f64 * h;
        let mut next = next_regular;
        if let Some(input) = &exp.input {
            let ev = input.next_event(time);
            if can_handle_variable_step && next > ev && !isclose(next, ev) {
                next = ev;
            }
        }
        if next > stop && !isclose(next, stop) {
            if can_handle_variable_step {
                next = stop;
            } else {
                out.notes.push(format!(
                    "stopped at t = {time}, before the stop time {stop}: the next grid point {next} is past it and the FMU cannot shorten a step (canHandleVariableCommunicationStepSize is false)"
                ));
                break;
            }
        }
        let step = next - time;
        if !(step > 0.0) {
            // Possible when h is below the resolution of the time (start + n·h == t).
            out.failure = Some(format!(
                "the communication step from t = {time} is {step}: the output interval {h} is too small for the time's floating-point resolution"
            ));
            return out;
        }
        if let Some(input) = &exp.input {
            if let Err(err) = apply_input(inst, input, time, true) {
                out.failure = Some(format!("setting inputs at t = {time}: {err}"));
                return out;
            }
        }
        let call_start = exp.timing.then(std::time::Instant::now);
        let stepped = inst.do_step(time, step);
        if let Err(err) = stepped {
            let mut msg =
                format!("the FMU refused the step from t = {time} with h = {step}: {err}");
            if err.status == super::library::Status::Discard {
                let (terminated, last) = inst.discard_details();
                if terminated == Some(true) {
                    let ended = (time, last, stop);
                    match ended_by_fmu(inst, &mut sampler, sink, &mut out, ended, &err) {
                        Ok(end) => {
                            time = end;
                            break;
                        }
                        Err(m) => {
                            out.failure = Some(m);
                            return out;
                        }
                    }
                }
                if let Some(tl) = last {
                    msg.push_str(&format!("; last successful time {tl}"));
                }
            }
            out.failure = Some(msg);
            return out;
        }
        time = next;
        activity.at(time);
        let sampled = sampler.sample(inst);
        if let Some(t) = call_start {
            in_fmu += t.elapsed();
        }
        let row = match sampled {
            Ok(row) => row,
            Err(err) => {
                out.failure = Some(format!("reading outputs at t = {time}: {err}"));
                return out;
            }
        };
        let sink_start = exp.timing.then(std::time::Instant::now);
        let sunk = sink.row(time, &row);
        if let Some(t) = sink_start {
            in_sink += t.elapsed();
        }
        if let Err(e) = sunk {
            out.failure = Some(format!("writing the output row at t = {time}: {e}"));
            return out;
        }
        out.rows += 1;
        if isclose(time, next_regular) {
            n_steps += 1;
        }
    }
    if exp.timing {
        out.timing = Some(Timing {
            loop_seconds: loop_start.elapsed().as_secs_f64(),
            fmu_seconds: in_fmu.as_secs_f64(),
            sink_seconds: in_sink.as_secs_f64(),
        });
    }
    if let Err(err) = inst.terminate() {
        out.failure = Some(format!("at the end (t = {time}): {err}"));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_bounds_name_the_interval_and_the_bound() {
        assert!(check_grid(0.0, 1.0, 1e-5, DEFAULT_MAX_ROWS).is_ok());
        // Exactly at the bound: 0, h, ..., 1 are 11 rows.
        assert!(check_grid(0.0, 1.0, 0.1, 11).is_ok());
        let e = check_grid(0.0, 1.0, 0.1, 10).unwrap_err();
        assert!(
            e.contains("gives 11 output rows, more than the maximum of 10"),
            "{e}"
        );
        let e = check_grid(0.0, 1.0, 1e-300, u64::MAX).unwrap_err();
        assert!(
            e.contains(
                "1e-300 s is below the resolution of the time at 1.0 s (2.220446049250313e-16 s)"
            ),
            "{e}"
        );
        let e = check_grid(0.0, 1.0, 1e-12, DEFAULT_MAX_ROWS).unwrap_err();
        assert!(e.contains("gives 1000000000001 output rows"), "{e}");
        let e = check_grid(1e20, 2e20, 1e-3, u64::MAX).unwrap_err();
        assert!(e.contains("resolution of the time at 2e20 s"), "{e}");
    }

    #[test]
    fn fmpy_auto_interval() {
        // Values computed with fmpy.util.auto_interval.
        assert_eq!(auto_interval(1.0), 0.002);
        assert_eq!(auto_interval(10.0), 0.02);
    }
}
