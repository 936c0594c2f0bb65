//! The fixed-step master: several FMU instances in one process, stepped on one grid with
//! Jacobi or Gauss–Seidel, inputs held or extrapolated (FMI 2.0.5 §4.2.1–4.2.4).
//!
//! * Grid and rows as in single-FMU runs ([`crate::host::runner`]): communication points
//!   `start + n·h`, the last step shortened to the stop time when every FMU can handle a
//!   variable step, one row at the start and one after every macro step, sampled right after
//!   the step (before the next step's inputs are set).
//! * Initialization: every instance gets `fmi2SetupExperiment` and its start values, enters
//!   initialization mode, gets its initialization-phase start values; then, in the
//!   Gauss–Seidel order, each element's connected inputs are set from its producers' current
//!   outputs and its own outputs are read (one pass, after one read of every element's outputs
//!   from its start values); then all exit initialization mode.
//! * Jacobi: every element steps from t to t+h with its producers' outputs at t.
//!   Gauss–Seidel: elements step one after another in the data-flow order
//!   ([`super::graph::order`]); a consumer gets the outputs at t+h of producers that already
//!   stepped, and those at t over a connection that closes a cycle.
//! * Coupling of a Real connection ([`Coupling`]): held (zero-order hold), *extrapolated*
//!   (`fmi2SetRealInputDerivatives` order 1 with the producer's `fmi2GetRealOutputDerivatives`
//!   at t: u(t+s) = y(t) + s·y'(t)), or, for a Gauss–Seidel connection whose producer already
//!   stepped, *interpolated* (u(t) = y(t) with the slope (y(t+h) − y(t))/h, exact for signals
//!   linear over the step). Both are second-order couplings; the hold is first order.
//! * A failing call ends the run: the rows up to then are kept, and the message names the
//!   element, the call, the time, the status and the reason the FMU logged.
//! * An element that ends the simulation itself (`fmi2Discard` with `fmi2Terminated = true`,
//!   FMI 2.0.5 §4.2.3) ends the run normally at the last communication point: the elements
//!   are at different times within the macro step it ended in, so that step has no row; a
//!   note names the element, its last successful time and its reason (issue 39).

use super::check::Link;
use super::parallel::Pool;
pub use super::plan::{Algorithm, Column, Coupling, Plan};
use super::step::{do_step, StepEnd};
use crate::host::csv::Row;
use crate::host::description::VarType;
use crate::host::input::isclose;
use crate::host::instance::{CallError, Instance};
use crate::host::runner::RowSink;
use crate::host::start::Phase;

/// Distinct producer ports of `links`, in order of first appearance, and each link's port.
pub fn producer_ports(links: &[Link]) -> (Vec<(usize, u32, VarType)>, Vec<usize>) {
    let mut ports: Vec<(usize, u32, VarType)> = Vec::new();
    let mut port_of = Vec::new();
    for l in links {
        let key = (l.from.element, l.from.vr, l.from.var_type);
        let i = ports.iter().position(|p| *p == key).unwrap_or_else(|| {
            ports.push(key);
            ports.len() - 1
        });
        port_of.push(i);
    }
    (ports, port_of)
}

/// How a run ended; the rows went to the sink.
#[derive(Default)]
pub struct Outcome {
    pub rows: usize,
    pub failure: Option<String>,
    pub notes: Vec<String>,
    /// The error-controlled master's step sequence (empty with fixed steps).
    pub steps: Vec<super::plan::StepRecord>,
}

/// Per element: which values to read after its step, and which inputs to set before it.
#[derive(Default)]
struct Io {
    real_vr: Vec<u32>,
    real_port: Vec<usize>,
    int_vr: Vec<u32>,
    int_port: Vec<usize>,
    bool_vr: Vec<u32>,
    bool_port: Vec<usize>,
    der_vr: Vec<u32>,
    der_port: Vec<usize>,
    /// All 1: the derivative order asked for each of `der_vr`.
    der_order: Vec<i32>,
    inputs: Vec<usize>,
    extra_real: (Vec<u32>, Vec<usize>),
    extra_int: (Vec<u32>, Vec<usize>),
    extra_bool: (Vec<u32>, Vec<usize>),
}

/// The values set before a step, grouped by type (reused from step to step).
#[derive(Default)]
struct Inputs {
    rv: Vec<u32>,
    rx: Vec<f64>,
    iv: Vec<u32>,
    ix: Vec<i32>,
    bv: Vec<u32>,
    bx: Vec<i32>,
    dv: Vec<u32>,
    dx: Vec<f64>,
    order: Vec<i32>,
}

impl Inputs {
    fn clear(&mut self) {
        self.rv.clear();
        self.rx.clear();
        self.iv.clear();
        self.ix.clear();
        self.bv.clear();
        self.bx.clear();
        self.dv.clear();
        self.dx.clear();
        self.order.clear();
    }
}

pub(super) struct State<'p, 'a> {
    plan: &'p Plan<'a>,
    set: Inputs,
    io: Vec<Io>,
    /// Per producer port: its value at the current communication point (at t + h once its
    /// element stepped), at the step's start, and its first derivative (where read).
    pub(super) cur: Vec<f64>,
    pub(super) prev: Vec<f64>,
    pub(super) der: Vec<f64>,
    /// Per producer port: its first derivative at the step's start (where read; the
    /// error-controlled master's Hermite inputs, [`Plan::hermite`]).
    pub(super) der_prev: Vec<f64>,
    /// Per producer port: the second and third derivatives its extrapolated connections of
    /// [`Plan::extrapolation_order`] ≥ 2 follow over the next step (the error-controlled
    /// master's [`super::extrapolation`]; zeros with fixed steps: the line).
    pub(super) higher: Vec<[f64; 2]>,
    /// Per link: a constant added to an interpolated or extrapolated input over the next
    /// step (the impulse correction of the error-controlled master; 0 with fixed steps, where
    /// adding it leaves every value's bits unchanged).
    pub(super) offset: Vec<f64>,
    /// The step ends at a switch an FMU announced (the error-controlled master's
    /// [`super::controlled`], "Steps that end at a switch"): the outputs' slopes at its end
    /// are those after the switch, so an interpolated input follows the quadratic through
    /// the values at both ends and the slope at the start, and the refresh at its end gives
    /// the compliances the slopes after the switch. Always `false` with fixed steps.
    pub(super) switch_at_end: bool,
    /// The row being assembled, per column.
    row: Vec<f64>,
    buf_f: Vec<f64>,
    buf_i: Vec<i32>,
}

/// `v` plus the impulse correction `o`; `v` itself (even −0.0) without one, so that the
/// fixed-step master's inputs keep their bits.
fn corrected(v: f64, o: f64) -> f64 {
    if o == 0.0 {
        v
    } else {
        v + o
    }
}

/// The derivatives of orders 1, 2, 3 at `s = 0` of the cubic Hermite interpolant on
/// `[0, h]` of values `y0`, `y1` and slopes `d0`, `d1` at its ends (the cubic
/// `y0 + d0·s + c₂s² + c₃s³` with `c₂ = (3Δ/h − 2d0 − d1)/h`, `c₃ = (d0 + d1 − 2Δ/h)/h²`,
/// `Δ = y1 − y0`; de Boor, A Practical Guide to Splines, ch. IV).
pub(super) fn hermite(y0: f64, y1: f64, d0: f64, d1: f64, h: f64) -> [f64; 3] {
    let secant = (y1 - y0) / h;
    let c2 = (3.0 * secant - 2.0 * d0 - d1) / h;
    let c3 = (d0 + d1 - 2.0 * secant) / (h * h);
    [d0, 2.0 * c2, 6.0 * c3]
}

/// The derivatives of orders 1, 2, 3 at `s = 0` of the quadratic on `[0, h]` through the
/// values `y0`, `y1` at its ends with slope `d0` at its start, `y0 + d0·s + (Δ/h − d0)·s²/h`:
/// the interpolant of a step whose end slope is not that of the signal over it (a switch at
/// its end, [`State::switch_at_end`]).
pub(super) fn quadratic(y0: f64, y1: f64, d0: f64, h: f64) -> [f64; 3] {
    [d0, 2.0 * ((y1 - y0) / h - d0) / h, 0.0]
}

pub(super) fn at(e: &str, t: f64, err: CallError) -> String {
    format!("element \"{e}\" at t = {t}: {err}")
}

/// Base type of a group of value references read together.
#[derive(Clone, Copy)]
enum Base {
    Real,
    Integer,
    Boolean,
}

/// Reads `vrs` (all of type `base`) and stores value j, as f64, at `out[dest[j]]`
/// (Integers and Booleans convert exactly).
fn read_into(
    inst: &mut Instance,
    base: Base,
    (vrs, dest): (&[u32], &[usize]),
    (buf_f, buf_i): (&mut Vec<f64>, &mut Vec<i32>),
    out: &mut [f64],
) -> Result<(), CallError> {
    if vrs.is_empty() {
        return Ok(());
    }
    match base {
        Base::Real => {
            buf_f.resize(vrs.len(), 0.0);
            inst.get_real(vrs, buf_f)?;
            for (&k, &v) in dest.iter().zip(buf_f.iter()) {
                out[k] = v;
            }
        }
        Base::Integer | Base::Boolean => {
            buf_i.resize(vrs.len(), 0);
            if matches!(base, Base::Boolean) {
                inst.get_boolean(vrs, buf_i)?;
            } else {
                inst.get_integer(vrs, buf_i)?;
            }
            for (&k, &v) in dest.iter().zip(buf_i.iter()) {
                out[k] = f64::from(v);
            }
        }
    }
    Ok(())
}

impl<'p, 'a> State<'p, 'a> {
    pub(super) fn new(plan: &'p Plan<'a>) -> Self {
        let n = plan.system.elements.len();
        let mut io: Vec<Io> = (0..n).map(|_| Io::default()).collect();
        for (p, &(e, vr, t)) in plan.ports.iter().enumerate() {
            let io = &mut io[e];
            match t {
                VarType::Real => {
                    io.real_vr.push(vr);
                    io.real_port.push(p);
                    if plan.needs_derivative[p] {
                        io.der_vr.push(vr);
                        io.der_port.push(p);
                        io.der_order.push(1);
                    }
                }
                VarType::Boolean => {
                    io.bool_vr.push(vr);
                    io.bool_port.push(p);
                }
                _ => {
                    io.int_vr.push(vr);
                    io.int_port.push(p);
                }
            }
        }
        for (l, link) in plan.system.links.iter().enumerate() {
            io[link.to.element].inputs.push(l);
        }
        for (k, c) in plan.columns.iter().enumerate() {
            if c.port.is_none() {
                let target = match c.var_type {
                    VarType::Real => &mut io[c.element].extra_real,
                    VarType::Boolean => &mut io[c.element].extra_bool,
                    _ => &mut io[c.element].extra_int,
                };
                target.0.push(c.vr);
                target.1.push(k);
            }
        }
        let np = plan.ports.len();
        State {
            plan,
            set: Inputs::default(),
            io,
            cur: vec![0.0; np],
            prev: vec![0.0; np],
            der: vec![0.0; np],
            der_prev: vec![0.0; np],
            higher: vec![[0.0; 2]; np],
            offset: vec![0.0; plan.system.links.len()],
            switch_at_end: false,
            row: vec![0.0; plan.columns.len()],
            buf_f: Vec::new(),
            buf_i: Vec::new(),
        }
    }

    /// Read element `e`'s producer ports into `cur`, and with `derivatives` their first
    /// derivatives where needed (not in initialization mode: FMI 2.0.5 §4.2.4 allows
    /// `fmi2GetRealOutputDerivatives` only once the slave is initialized).
    pub(super) fn read(
        &mut self,
        e: usize,
        inst: &mut Instance,
        t: f64,
        derivatives: bool,
    ) -> Result<(), String> {
        let name = &self.plan.system.elements[e].name;
        let io = &self.io[e];
        for (base, vrs, ports) in [
            (Base::Real, &io.real_vr, &io.real_port),
            (Base::Integer, &io.int_vr, &io.int_port),
            (Base::Boolean, &io.bool_vr, &io.bool_port),
        ] {
            let bufs = (&mut self.buf_f, &mut self.buf_i);
            read_into(inst, base, (vrs, ports), bufs, &mut self.cur)
                .map_err(|err| at(name, t, err))?;
        }
        if derivatives && !io.der_vr.is_empty() {
            self.buf_f.resize(io.der_vr.len(), 0.0);
            inst.get_real_output_derivatives(&io.der_vr, &io.der_order, &mut self.buf_f)
                .map_err(|err| at(name, t, err))?;
            for (&p, &v) in io.der_port.iter().zip(&self.buf_f) {
                self.der[p] = v;
            }
        }
        Ok(())
    }

    /// Set element `e`'s connected inputs for the step from `t` (length `h`; 0 during
    /// initialization, where every connection is held). `stepped[x]`: element x already
    /// stepped to t+h in this macro step.
    pub(super) fn set_inputs(
        &mut self,
        e: usize,
        inst: &mut Instance,
        t: f64,
        h: f64,
        stepped: &[bool],
    ) -> Result<(), String> {
        let plan = self.plan;
        let name = &plan.system.elements[e].name;
        // Buffers kept across steps (no allocation per step), taken while `self` is read.
        let mut b = std::mem::take(&mut self.set);
        b.clear();
        let Inputs {
            rv,
            rx,
            iv,
            ix,
            bv,
            bx,
            dv,
            dx,
            order,
        } = &mut b;
        for &l in &self.io[e].inputs {
            let link = &plan.system.links[l];
            let p = plan.port_of[l];
            match link.to.var_type {
                VarType::Real => {
                    let affine = |v: f64| {
                        if link.identity {
                            v
                        } else {
                            link.scale * v + link.offset
                        }
                    };
                    let slope = |d: f64| if link.identity { d } else { link.scale * d };
                    let coupling = if h > 0.0 {
                        plan.coupling[l]
                    } else {
                        Coupling::Hold
                    };
                    match coupling {
                        Coupling::Interpolate if stepped[link.from.element] => {
                            rv.push(link.to.vr);
                            rx.push(corrected(affine(self.prev[p]), slope(self.offset[l])));
                            if plan.hermite[l] {
                                let (d0, d1) = (self.der_prev[p], self.der[p]);
                                let c = if self.switch_at_end {
                                    quadratic(self.prev[p], self.cur[p], d0, h)
                                } else {
                                    hermite(self.prev[p], self.cur[p], d0, d1, h)
                                };
                                for (k, c) in c.into_iter().enumerate() {
                                    dv.push(link.to.vr);
                                    order.push(k as i32 + 1);
                                    dx.push(slope(c));
                                }
                            } else {
                                dv.push(link.to.vr);
                                order.push(1);
                                dx.push(slope((self.cur[p] - self.prev[p]) / h));
                            }
                        }
                        Coupling::Extrapolate if !stepped[link.from.element] => {
                            rv.push(link.to.vr);
                            rx.push(corrected(affine(self.cur[p]), slope(self.offset[l])));
                            dv.push(link.to.vr);
                            order.push(1);
                            dx.push(slope(self.der[p]));
                            // Orders 2 and 3 where the consumer takes them (the
                            // error-controlled master's `extrapolation`).
                            let q = plan.extrapolation_order[l];
                            let orders = usize::from(q).saturating_sub(1);
                            for (k, c) in self.higher[p].into_iter().enumerate().take(orders) {
                                dv.push(link.to.vr);
                                order.push(k as i32 + 2);
                                dx.push(slope(c));
                            }
                        }
                        _ => {
                            rv.push(link.to.vr);
                            rx.push(affine(self.cur[p]));
                            // The refresh at a switch: the slope after it, which the
                            // consumer's output derivatives at this point follow.
                            if h == 0.0
                                && self.switch_at_end
                                && plan.coupling[l] != Coupling::Hold
                                && plan.needs_derivative[p]
                            {
                                dv.push(link.to.vr);
                                order.push(1);
                                dx.push(slope(self.der[p]));
                            }
                        }
                    }
                }
                VarType::Boolean => {
                    bv.push(link.to.vr);
                    bx.push(self.cur[p] as i32);
                }
                _ => {
                    iv.push(link.to.vr);
                    ix.push(self.cur[p] as i32);
                }
            }
        }
        let err = |err| at(name, t, err);
        let result = (|| {
            if !rv.is_empty() {
                inst.set_real(rv, rx).map_err(err)?;
            }
            if !iv.is_empty() {
                inst.set_integer(iv, ix).map_err(err)?;
            }
            if !bv.is_empty() {
                inst.set_boolean(bv, bx).map_err(err)?;
            }
            if !dv.is_empty() {
                inst.set_real_input_derivatives(dv, order, dx)
                    .map_err(err)?;
            }
            Ok(())
        })();
        self.set = b;
        result
    }

    /// Assemble and deliver the row at `t`.
    pub(super) fn record(
        &mut self,
        insts: &mut [Instance],
        sink: &mut dyn RowSink,
        t: f64,
    ) -> Result<(), String> {
        let plan = self.plan;
        for (k, c) in plan.columns.iter().enumerate() {
            if let Some(p) = c.port {
                self.row[k] = self.cur[p];
            }
        }
        for (e, inst) in insts.iter_mut().enumerate() {
            let name = &plan.system.elements[e].name;
            let io = &self.io[e];
            for (base, (vrs, cols)) in [
                (Base::Real, &io.extra_real),
                (Base::Integer, &io.extra_int),
                (Base::Boolean, &io.extra_bool),
            ] {
                let bufs = (&mut self.buf_f, &mut self.buf_i);
                read_into(inst, base, (vrs, cols), bufs, &mut self.row)
                    .map_err(|err| at(name, t, err))?;
            }
        }
        let nr = plan
            .columns
            .iter()
            .filter(|c| c.var_type == VarType::Real)
            .count();
        let ni = plan
            .columns
            .iter()
            .filter(|c| c.var_type == VarType::Integer)
            .count();
        self.buf_i.clear();
        self.buf_i.extend(self.row[nr..].iter().map(|&v| v as i32));
        let row = Row {
            reals: &self.row[..nr],
            integers: &self.buf_i[..ni],
            booleans: &self.buf_i[ni..],
        };
        sink.row(t, &row)
            .map_err(|e| format!("writing the output row at t = {t}: {e}"))
    }
}

fn set_start(
    inst: &mut Instance,
    name: &str,
    s: &crate::host::start::StartValue,
) -> Result<(), String> {
    use crate::host::description::Value;
    let r = match &s.value {
        Value::Real(v) => inst.set_real(&[s.vr], &[*v]),
        Value::Integer(v) => inst.set_integer(&[s.vr], &[*v]),
        Value::Boolean(v) => inst.set_boolean(&[s.vr], &[i32::from(*v)]),
        Value::String(v) => inst.set_string(&[s.vr], std::slice::from_ref(v)),
    };
    r.map(|_| ()).map_err(|e| {
        format!(
            "element \"{name}\": setting the start value of \"{}\": {e}",
            s.name
        )
    })
}

/// Initialize and run the instances (`insts[i]` is element i) with fixed steps (a plan with
/// error control runs in the error-controlled master, `controlled::run`), giving every row
/// to `sink`.
/// Never panics; on failure the rows up to then have been delivered. A Jacobi plan with
/// `threads > 1` steps the elements on that many threads ([`super::parallel`]).
pub fn run<'a>(insts: &mut [Instance<'a>], plan: &Plan, sink: &mut dyn RowSink) -> Outcome {
    if plan.algorithm != Algorithm::Jacobi || plan.threads <= 1 {
        return run_with(insts, plan, sink, None);
    }
    let names: Vec<String> = plan
        .system
        .elements
        .iter()
        .map(|e| e.name.clone())
        .collect();
    std::thread::scope(|s| {
        let mut pool = Pool::<'a>::start(s, plan.threads, plan.threads_asked, &names);
        run_with(insts, plan, sink, Some(&mut pool))
    })
}

/// The Jacobi step on the pool's threads: the results in the plan's order, the first failure
/// or end as the serial step would report it.
fn parallel_step<'a>(
    pool: &Pool<'a>,
    insts: &mut [Instance<'a>],
    names: &[String],
    plan: &Plan,
    (time, step): (f64, f64),
) -> Result<(), StepEnd> {
    let mut results = pool.step(insts, names, time, step);
    for &e in &plan.order {
        match results[e].take() {
            Some(r) => r?,
            None => {
                return Err(StepEnd::Failed(format!(
                "element \"{}\": its step from t = {time} was not done (the worker thread ended)",
                names[e]
            )))
            }
        }
    }
    Ok(())
}

/// The start of every master: the instances initialised ([`initialize`]) and the row at the
/// start time recorded. The run's state and its outcome so far (that row), or the outcome
/// that ends the run there.
pub(super) fn start<'p, 'a>(
    insts: &mut [Instance],
    plan: &'p Plan<'a>,
    sink: &mut dyn RowSink,
) -> Result<(State<'p, 'a>, Outcome), Outcome> {
    let mut st = State::new(plan);
    let failed = |failure: String| Outcome {
        failure: Some(failure),
        ..Outcome::default()
    };
    initialize(insts, plan, &mut st).map_err(|m| failed(format!("initialization: {m}")))?;
    st.record(insts, sink, plan.start_time).map_err(failed)?;
    let out = Outcome {
        rows: 1,
        ..Outcome::default()
    };
    Ok((st, out))
}

/// An output point of every master: its row recorded and counted, and the divergence watch
/// asked; the message that ends the run.
pub(super) fn output_point(
    st: &mut State,
    insts: &mut [Instance],
    sink: &mut dyn RowSink,
    watch: &mut Option<super::divergence::Watch>,
    time: f64,
    out: &mut Outcome,
) -> Result<(), String> {
    st.record(insts, sink, time)?;
    out.rows += 1;
    match watch.as_mut().and_then(|w| w.check(st.plan, time, &st.cur)) {
        Some(m) => Err(m),
        None => Ok(()),
    }
}

/// Set up and initialize every instance (module doc: the initialization pass), leaving each
/// port's value and derivative at the start time in `st`.
pub(super) fn initialize(
    insts: &mut [Instance],
    plan: &Plan,
    st: &mut State,
) -> Result<(), String> {
    let t0 = plan.start_time;
    let elements = &plan.system.elements;
    let n = elements.len();
    for (e, inst) in insts.iter_mut().enumerate() {
        let name = &elements[e].name;
        inst.activity().at(t0);
        inst.setup_experiment(None, t0, Some(plan.stop_time))
            .map_err(|err| at(name, t0, err))?;
        for s in elements[e]
            .start_values
            .iter()
            .filter(|s| s.phase == Phase::Instantiated)
        {
            set_start(inst, name, s)?;
        }
        inst.enter_initialization_mode()
            .map_err(|err| at(name, t0, err))?;
        for s in elements[e]
            .start_values
            .iter()
            .filter(|s| s.phase == Phase::Initialization)
        {
            set_start(inst, name, s)?;
        }
    }
    // Every producer's outputs from its start values first: a connection that closes a
    // cycle in the Gauss–Seidel order reads its producer before that producer's own pass,
    // and must see the FMU's current output, not an unset buffer.
    for (e, inst) in insts.iter_mut().enumerate() {
        st.read(e, inst, t0, false)?;
    }
    let none = vec![false; n];
    for &e in &plan.order {
        st.set_inputs(e, &mut insts[e], t0, 0.0, &none)?;
        st.read(e, &mut insts[e], t0, false)?;
    }
    for (e, inst) in insts.iter_mut().enumerate() {
        inst.exit_initialization_mode()
            .map_err(|err| at(&elements[e].name, t0, err))?;
    }
    for (e, inst) in insts.iter_mut().enumerate() {
        st.read(e, inst, t0, true)?;
    }
    Ok(())
}

/// One macro step from `time` to `next` on this thread, in the plan's order; `stepped` is
/// all false on entry. With a pool, each element's step is timed for its assignment.
pub(super) fn serial_step<'a>(
    st: &mut State,
    insts: &mut [Instance<'a>],
    (time, next): (f64, f64),
    stepped: &mut [bool],
    mut pool: Option<&mut Pool<'a>>,
) -> Result<(), StepEnd> {
    let plan = st.plan;
    let step = next - time;
    for &e in &plan.order {
        st.set_inputs(e, &mut insts[e], time, step, stepped)?;
        insts[e].activity().at(time);
        let started = pool.is_some().then(std::time::Instant::now);
        do_step(&mut insts[e], &plan.system.elements[e].name, time, step)?;
        if let (Some(p), Some(t)) = (pool.as_deref_mut(), started) {
            p.measure(e, t.elapsed());
        }
        if plan.algorithm == Algorithm::GaussSeidel {
            st.read(e, &mut insts[e], next, true)?;
            stepped[e] = true;
        }
    }
    if plan.algorithm == Algorithm::Jacobi {
        for (e, inst) in insts.iter_mut().enumerate() {
            st.read(e, inst, next, true)?;
        }
    }
    Ok(())
}

fn run_with<'a>(
    insts: &mut [Instance<'a>],
    plan: &Plan,
    sink: &mut dyn RowSink,
    mut pool: Option<&mut Pool<'a>>,
) -> Outcome {
    let (mut st, mut out) = match start(insts, plan, sink) {
        Ok(started) => started,
        Err(out) => return out,
    };
    let t0 = plan.start_time;
    let elements = &plan.system.elements;
    let n = elements.len();
    let mut watch = super::divergence::Watch::new(plan);
    let names: Vec<String> = elements.iter().map(|e| e.name.clone()).collect();
    let (h, stop) = (plan.h, plan.stop_time);
    let mut time = t0;
    let mut n_steps: u64 = 0;
    let mut stepped = vec![false; n];
    loop {
        if time > stop || isclose(time, stop) {
            break;
        }
        if plan
            .interrupt
            .is_some_and(|f| f.load(std::sync::atomic::Ordering::Relaxed))
        {
            out.failure = Some(format!("interrupted at t = {time}"));
            return out;
        }
        let mut next = t0 + (n_steps + 1) as f64 * h;
        if next > stop && !isclose(next, stop) {
            if plan.can_vary {
                next = stop;
            } else {
                out.notes.push(format!(
                    "stopped at t = {time}, before the stop time {stop}: the next grid point {next} is past it and not every FMU can shorten a step (canHandleVariableCommunicationStepSize)"
                ));
                break;
            }
        }
        let step = next - time;
        if !(step > 0.0) {
            out.failure = Some(format!(
                "the communication step from t = {time} is {step}: the step {h} is too small for the time's floating-point resolution"
            ));
            return out;
        }
        st.prev.copy_from_slice(&st.cur);
        stepped.iter_mut().for_each(|s| *s = false);
        let parallel = pool.as_ref().is_some() && n_steps >= super::parallel::MEASURED;
        if pool.is_some() && n_steps == super::parallel::MEASURED {
            if let Some(p) = pool.as_mut() {
                p.assign();
            }
        }
        let stepping = (|| -> Result<(), StepEnd> {
            if parallel {
                for &e in &plan.order {
                    st.set_inputs(e, &mut insts[e], time, step, &stepped)?;
                    insts[e].activity().at(time);
                }
                if let Some(p) = pool.as_deref() {
                    parallel_step(p, insts, &names, plan, (time, step))?;
                }
                for (e, inst) in insts.iter_mut().enumerate() {
                    st.read(e, inst, next, true)?;
                }
                return Ok(());
            }
            serial_step(
                &mut st,
                insts,
                (time, next),
                &mut stepped,
                pool.as_deref_mut(),
            )
        })();
        match stepping {
            Ok(()) => {}
            Err(StepEnd::Failed(m)) => {
                out.failure = Some(m);
                return out;
            }
            Err(StepEnd::Ended(note)) => {
                out.notes.push(note);
                break;
            }
        }
        time = next;
        if let Err(m) = output_point(&mut st, insts, sink, &mut watch, time, &mut out) {
            out.failure = Some(m);
            return out;
        }
        if isclose(time, t0 + (n_steps + 1) as f64 * h) {
            n_steps += 1;
        }
    }
    terminate(insts, plan, time, &mut out);
    out
}

/// `fmi2Terminate` every instance at the end of a run.
pub(super) fn terminate(insts: &mut [Instance], plan: &Plan, time: f64, out: &mut Outcome) {
    for (e, inst) in insts.iter_mut().enumerate() {
        if let Err(err) = inst.terminate() {
            out.failure = Some(format!(
                "at the end: {}",
                at(&plan.system.elements[e].name, time, err)
            ));
            break;
        }
    }
}
