//! The error-controlled master (`--tolerance`, issue 32 item 1): the communication step is
//! chosen by an estimate of the coupling error of every step, a step whose estimate exceeds
//! the tolerance is undone on every FMU (`fmi2GetFMUstate` before it, `fmi2SetFMUstate` to
//! undo it, FMI 2.0.5 §2.1.8) and redone smaller, and the step adapts within
//! `[h_min, h_max]`.
//!
//! **The estimate** (Schierz, Arnold & Clauß, "Co-simulation with communication step size
//! control in an FMI compatible master algorithm", 9th Modelica Conference 2012, §3: the
//! error of a step is the error of the inputs' polynomial approximation over it). After the
//! step every producer's output at its end, `y(t+H)`, is known; what each consumer was given
//! over the step is known too:
//!
//! * extrapolated, `y(t) + s·y'(t)`: its defect at the step's end, `|y(t+H) − y(t) − H·y'(t)|`
//!   (≈ `H²|y''|/2`); into a consumer that takes input derivatives of order `q` = 2 or 3
//!   ([`Plan::extrapolation_order`]) the polynomial of degree `q` whose higher derivatives
//!   come from the last accepted step ([`super::extrapolation`]), its defect `|y(t+H) − p(H)|`
//!   of order `q + 1`;
//! * interpolated (Gauss–Seidel, the producer stepped first), the chord from `y(t)` to
//!   `y(t+H)`: its largest distance from the signal, `H·|y'(t+H) − y'(t)|/8` (≈ `H²|y''|/8`),
//!   plus, for a compliance's effort, how far the end it was given lies from the refreshed
//!   one (below);
//! * held: `|y(t+H) − y(t)|` (≈ `H|y'|`, first order);
//! * interpolated into a consumer that takes input derivatives up to order 3 (its vendor
//!   annotation, [`Plan::hermite`]): the cubic Hermite interpolant of `y`, `y'` at both ends
//!   (`master::hermite`), whose own error is fourth order. Its estimate is that of an embedded
//!   pair: the distance of the quadratic through `y(t)`, `y'(t)`, `y(t+H)` from the cubic,
//!   `4H/27·|y'(t) + y'(t+H) − 2Δ/H|` (third order, so an upper bound of the cubic's error
//!   where the signal is smooth), plus, as for the chord, how far the end value and slope it
//!   was given lie from the refreshed ones (`4H/27` is the largest value of the end-slope
//!   basis function). The step's exponent is then 3.
//!
//! Each defect is divided by `tol` times the signal's scale, its largest magnitude so far
//! (the step's own values included): a relative tolerance as an ODE solver's `rtol·|y|`. An
//! angle's magnitude grows with the run, so its defects weigh less and less; the torques and
//! speeds then decide (an angle measured against its advance over the step instead would
//! reject any held angle at any step: its defect is that advance). The step's error `err` is
//! the largest ratio over the connections; `err ≤ 1` accepts the step. The next step is
//! `H·clamp(0.9·err^(−1/p), 0.2, 2)` with `p` the order of the deciding defect (2; 3 for a
//! Hermite pair, `q + 1` for an extrapolation of degree `q`; 1 with a held connection), within
//! `[h_min, h_max]`. A step an FMU refuses (`fmi2Discard`, `fmi2Error`) is undone and redone
//! at a quarter; at `h_min` the refusal ends the run, and a step at `h_min` over the
//! tolerance is accepted and counted.
//!
//! **Order: compliances first** ([`super::graph::compliances_first`]). The elements whose
//! connected outputs depend directly on a connected input (ModelStructure: shafts, a gear
//! stage's speed ports, whose torques follow the angles and speeds they are given) step
//! first, so that their efforts reach the bodies interpolated, and the bodies' flows, which
//! are integrals of those efforts and smooth, reach them extrapolated. After the step each
//! compliance gets the flows its producers actually reached and its outputs are read again
//! (`refresh`): the difference from what it returned is the flows' extrapolation error as
//! the bodies felt it, counted in the effort's own tolerance; the impulse carried into the
//! next step is taken against the refreshed efforts, and the next step starts from them.
//! The fixed-step masters keep their order (`graph::order`) and their results.
//!
//! **Steps that end at a switch.** An FMU may announce the time of its next switch (the
//! vendor annotation `<SwitchTimes>`: geardyn's gear FMUs, their mesh stiffness knots, where
//! the outputs' slopes jump). A step that would pass it ends [`SWITCH_MARGIN`] of the step
//! after it (a predicted switch is off by a little), so no input polynomial spans the kink:
//! over that step an interpolated input follows the quadratic through the values at both
//! ends and the slope at the start ([`super::master::quadratic`]; the slope at the end is
//! the one after the switch), its defect and impulse are the quadratic's, the compliances'
//! refresh gives them the slopes after the switch, and no history of higher derivatives
//! spans it (the next step takes those of the step before, carried to the switch). Without
//! it the master found each knot by halving its steps toward it, about fifteen attempts a
//! knot (docs/cosimulation.md, "Steps that end at the stage's knots").
//!
//! **Rows on the user's grid.** The steps land on every output point: the time to the next
//! output point is split into `ceil(remaining / H)` equal steps, so each row is the FMUs'
//! own output at its time, no interpolation.
//!
//! **The step sequence** (every attempt: its start, length, error, accepted or not) is
//! returned with the outcome and written to `<out>.steps.csv`.

use super::extrapolation::{self, History};
use super::master::{output_point, serial_step, start, terminate, Outcome, State};
pub use super::plan::StepRecord;
use super::plan::{Coupling, ErrorControl, Plan};
use super::step::StepEnd;
use crate::fmi::model::input_polynomial;
use crate::host::cli::RunArgs;
use crate::host::description::VarType;
use crate::host::input::isclose;
use crate::host::instance::Instance;
use crate::host::runner::RowSink;
// How far past a step's end an announced switch may lie and still be the step's end: the FMU
// reports the state after a switch within this rounding of a communication point.
use crate::simulation::SWITCH_AT_NOW;

/// The settings of `--tolerance`, `--min-step`, `--max-step`; `None` without `--tolerance`
/// or where the system cannot roll back (a note says so: fixed steps).
pub(super) fn settings(
    args: &RunArgs,
    h_out: f64,
    can_vary: bool,
    fmus: &super::Fmus,
    notes: &mut Vec<String>,
) -> Result<Option<ErrorControl>, String> {
    let Some(tol) = args.tolerance else {
        for (flag, given) in [
            ("--min-step", args.min_step.is_some()),
            ("--max-step", args.max_step.is_some()),
            ("--no-impulse-correction", args.no_impulse_correction),
            ("--no-switch-steps", args.no_switch_steps),
        ] {
            if given {
                return Err(format!(
                    "{flag}: a setting of the error-controlled master; give --tolerance too"
                ));
            }
        }
        return Ok(None);
    };
    if !(tol.is_finite() && tol > 0.0 && tol < 1.0) {
        return Err(format!(
            "--tolerance {tol}: must be a relative tolerance, > 0 and < 1"
        ));
    }
    let h_max = args.max_step.unwrap_or(h_out);
    let h_min = args.min_step.unwrap_or(h_max * 1e-6);
    if !(h_max.is_finite() && h_max > 0.0) {
        return Err(format!("--max-step {h_max}: must be a finite number > 0"));
    }
    if !(h_min.is_finite() && h_min > 0.0 && h_min <= h_max) {
        return Err(format!(
            "--min-step {h_min}: must be a finite number > 0 and at most the largest step {h_max}"
        ));
    }
    let cannot: Vec<&str> = fmus
        .mds
        .iter()
        .zip(&fmus.sources)
        .filter(|(md, _)| {
            !md.co_simulation
                .as_ref()
                .is_some_and(|c| c.can_get_and_set_fmu_state)
        })
        .map(|(_, s)| s.as_str())
        .collect();
    if !cannot.is_empty() {
        notes.push(format!(
            "--tolerance {tol}: fixed communication steps of {h_out} s, without error control: {} cannot get and set its state (canGetAndSetFMUstate), so a step cannot be undone",
            cannot.join(", ")
        ));
        return Ok(None);
    }
    if !can_vary {
        notes.push(format!(
            "--tolerance {tol}: fixed communication steps of {h_out} s, without error control: not every FMU can vary its communication step (canHandleVariableCommunicationStepSize)"
        ));
        return Ok(None);
    }
    let switch_times = (fmus.fmu_of.iter())
        .map(|&i| {
            let announced = fmus.mds[i]
                .co_simulation
                .as_ref()
                .and_then(|c| c.switch_time);
            announced.filter(|_| !args.no_switch_steps)
        })
        .collect();
    Ok(Some(ErrorControl {
        tolerance: tol,
        h_min,
        h_max,
        impulse_correction: !args.no_impulse_correction,
        switch_times,
    }))
}

/// Per producer port: its largest magnitude so far, the scale of its defects.
struct Scales(Vec<f64>);

impl Scales {
    /// The scale of port `p` over a step from `prev` to `cur`.
    fn of(&self, p: usize, prev: f64, cur: f64) -> f64 {
        self.0[p].max(prev.abs()).max(cur.abs())
    }

    fn accept(&mut self, cur: &[f64]) {
        for (s, v) in self.0.iter_mut().zip(cur) {
            if v.is_finite() {
                *s = s.max(v.abs());
            }
        }
    }
}

/// Per producer port: its value and derivative at the step's end as its consumers were given
/// them (before [`refresh`]).
struct Given {
    value: Vec<f64>,
    der: Vec<f64>,
}

/// The step's error relative to the tolerance (module doc), and the order of its defects.
fn estimate(
    plan: &Plan,
    ctl: &ErrorControl,
    scales: &Scales,
    given: &Given,
    st: &State,
    history: &History,
    h: f64,
) -> (f64, i32) {
    let der_start = &st.der_prev;
    let mut err: f64 = 0.0;
    let mut order = 2;
    // The order of the link with the largest ratio: 3 for a Hermite pair's defect, that of
    // its polynomial for a higher-order extrapolation, else 2.
    let mut deciding = 2;
    for (l, link) in plan.system.links.iter().enumerate() {
        if link.to.var_type != VarType::Real {
            continue;
        }
        let p = plan.port_of[l];
        let (y0, y1) = (st.prev[p], st.cur[p]);
        let q = plan.extrapolation_order[l];
        let higher = extrapolation::up_to(st.higher[p], q);
        let defect = match plan.coupling[l] {
            // As the consumer got it (master::State::set_inputs): an interpolated
            // connection's producer steps first, an extrapolated one's after or alongside.
            // The chord ended at `given[p]`, what the producer returned with the inputs it
            // was given; `y1` is its output refreshed with the actual ones (`refresh`).
            // A step that ends at a switch gave the quadratic through y0, d0, y1 (the slope
            // at its end is the one after the switch): its error is that of a quadratic,
            // `2h³|y‴|/81` at most for a cubic signal, y‴ from the last accepted step.
            Coupling::Interpolate if plan.hermite[l] && st.switch_at_end => {
                let third = history.higher(p, y0, der_start[p], 3)[1];
                2.0 * h * h * h * third.abs() / 81.0 + (y1 - given.value[p]).abs()
            }
            // The chord's distance from the quadratic through y0, d0, y1, without the slope
            // at the end (a switch there).
            Coupling::Interpolate if plan.needs_derivative[p] && st.switch_at_end => {
                (y1 - y0 - h * der_start[p]).abs() / 4.0 + (y1 - given.value[p]).abs()
            }
            Coupling::Interpolate if plan.hermite[l] => {
                let (d0, d1) = (der_start[p], st.der[p]);
                // The quadratic through y0, d0, y1 is the lower-order member of the pair:
                // its distance from the cubic, `4h/27·|d0 + d1 − 2Δ/h|`, bounds the cubic's
                // error from above (the cubic's own is fourth order). Then the refresh: the
                // cubic the consumer got ended at `given`, with slope `given_der`.
                let pair = 4.0 * h / 27.0 * (d0 + d1 - 2.0 * (y1 - y0) / h).abs();
                let moved = 4.0 * h / 27.0 * (d1 - given.der[p]).abs();
                pair + (y1 - given.value[p]).abs() + moved
            }
            Coupling::Interpolate => {
                if plan.needs_derivative[p] {
                    h * (st.der[p] - der_start[p]).abs() / 8.0 + (y1 - given.value[p]).abs()
                } else {
                    // No derivative: the chord's distance from the line of the step before is
                    // not known; the change over the step bounds it at first order.
                    order = 1;
                    (y1 - y0).abs()
                }
            }
            Coupling::Extrapolate if higher != [0.0; 2] => {
                (y1 - input_polynomial(y0, der_start[p], higher, h)).abs()
            }
            Coupling::Extrapolate => (y1 - y0 - h * der_start[p]).abs(),
            Coupling::Hold => {
                order = 1;
                (y1 - y0).abs()
            }
        };
        if defect == 0.0 {
            continue;
        }
        let sc = ctl.tolerance * scales.of(p, y0, y1);
        let r = if (defect / sc).is_nan() {
            f64::INFINITY
        } else {
            defect / sc
        };
        if r > err {
            err = r;
            deciding = match plan.coupling[l] {
                Coupling::Interpolate if plan.hermite[l] => 3,
                // The polynomial of degree q is off by O(H^(q+1)).
                Coupling::Extrapolate if higher != [0.0; 2] => 1 + i32::from(q),
                _ => 2,
            };
        }
    }
    // The step's exponent is that of the defect that decides; a held connection's first
    // order keeps its say (as before the Hermite inputs).
    if order == 2 {
        order = deciding;
    }
    (err, order)
}

/// Per link: adds the impulse (time integral) its consumer missed over the step just taken,
/// the producer's output integrated by the cubic Hermite rule from its values and derivatives
/// at both ends (the quadratic's rule at a switch) minus the integral of the polynomial the
/// consumer was given; the next step adds it spread over that step (at most at the rate of
/// this one, the rest carried), so that the impulses exchanged stay equal to that rule's
/// accuracy (nothing where a derivative is missing).
fn impulse_deficits(plan: &Plan, st: &State, given: &Given, h: f64, deficit: &mut [f64]) {
    let der_start = &st.der_prev;
    for (l, link) in plan.system.links.iter().enumerate() {
        let p = plan.port_of[l];
        if link.to.var_type != VarType::Real || !plan.needs_derivative[p] {
            continue;
        }
        let (y0, y1, d0, d1) = (st.prev[p], st.cur[p], der_start[p], st.der[p]);
        // At a switch the end slope is the one after it: the quadratic through y0, d0, y1
        // is the rule then, and what an interpolated consumer was given.
        let quadratic = |end: f64| h / 3.0 * (2.0 * y0 + end) + h * h / 6.0 * d0;
        let hermite = if st.switch_at_end {
            quadratic(y1)
        } else {
            h / 2.0 * (y0 + y1) + h * h / 12.0 * (d0 - d1)
        };
        let given = match plan.coupling[l] {
            Coupling::Extrapolate => {
                let higher = extrapolation::up_to(st.higher[p], plan.extrapolation_order[l]);
                extrapolation::integral(y0, d0, higher, h)
            }
            Coupling::Interpolate if plan.hermite[l] && st.switch_at_end => {
                quadratic(given.value[p])
            }
            Coupling::Interpolate if plan.hermite[l] => {
                h / 2.0 * (y0 + given.value[p]) + h * h / 12.0 * (d0 - given.der[p])
            }
            Coupling::Interpolate => h / 2.0 * (y0 + given.value[p]),
            Coupling::Hold => continue,
        };
        deficit[l] += hermite - given;
    }
}

/// The elements whose connected outputs depend directly on a connected input
/// ([`Plan::feedthrough`]): the error-controlled order steps them first
/// ([`super::graph::compliances_first`]).
fn compliances(plan: &Plan) -> Vec<usize> {
    plan.order
        .iter()
        .copied()
        .filter(|&e| {
            plan.system
                .links
                .iter()
                .zip(&plan.feedthrough)
                .any(|(l, f)| l.to.element == e && !f.is_empty())
        })
        .collect()
}

/// After a step: each compliance, which stepped with its flows extrapolated, gets the flows
/// its producers reached at the step's end, and its efforts are read again (they follow
/// those inputs directly). Its consumers were given the chord to the efforts of the
/// extrapolated flows; the difference is the error of that extrapolation as the consumers
/// feel it, and the next step starts from the refreshed, consistent efforts.
fn refresh(
    compliances: &[usize],
    st: &mut State,
    insts: &mut [Instance],
    time: f64,
    stepped: &[bool],
) -> Result<(), String> {
    for &e in compliances {
        st.set_inputs(e, &mut insts[e], time, 0.0, stepped)?;
        st.read(e, &mut insts[e], time, true)?;
    }
    Ok(())
}

/// How many of the largest steps ahead an announced switch is read again after every step.
const SWITCH_REACH: f64 = 4.0;

/// How far past an announced switch a step ends, relative to the step the controller would
/// take (at least the smallest step and a billionth of the time): a predicted switch (a
/// stiffness knot on a carried angle) is off by the phase's third-order term, up to ~1e-4 of
/// the time to it at a drivetrain's grid step (`tests/switch_times.rs`), and a switch just
/// ahead is passed by a step of this length, not one at the time's resolution. The kink then
/// lies this far before the step's end, where it moves the inputs by its slope's jump times
/// this margin: ~5 % of the tolerance at `1e-4` on the drivetrains.
pub const SWITCH_MARGIN: f64 = 1e-3;

/// Reads each announcing element's next switch time ([`ErrorControl::switch_times`]) at
/// `time`; the largest double (or more) is none.
fn read_switch_times(
    insts: &mut [Instance],
    plan: &Plan,
    ctl: &ErrorControl,
    time: f64,
    switch_at: &mut [f64],
) -> Result<(), String> {
    for (e, vr) in ctl.switch_times.iter().enumerate() {
        let Some(vr) = *vr else { continue };
        let mut t = [f64::INFINITY];
        insts[e]
            .get_real(&[vr], &mut t)
            .map_err(|err| super::master::at(&plan.system.elements[e].name, time, err))?;
        switch_at[e] = if t[0] < f64::MAX { t[0] } else { f64::INFINITY };
    }
    Ok(())
}

/// Undo a step: every instance back to its saved state, the ports to the step's start.
fn roll_back(insts: &mut [Instance], plan: &Plan, st: &mut State, time: f64) -> Result<(), String> {
    for (e, inst) in insts.iter_mut().enumerate() {
        inst.restore_state()
            .map_err(|err| super::master::at(&plan.system.elements[e].name, time, err))?;
    }
    st.cur.copy_from_slice(&st.prev);
    st.der.copy_from_slice(&st.der_prev);
    Ok(())
}

/// Run the instances with error control (module doc), giving a row to `sink` at every
/// output point. Never panics; on failure the rows up to then have been delivered.
pub(super) fn run(
    insts: &mut [Instance],
    plan: &Plan,
    ctl: &ErrorControl,
    sink: &mut dyn RowSink,
) -> Outcome {
    let (mut st, mut out) = match start(insts, plan, sink) {
        Ok(started) => started,
        Err(out) => return out,
    };
    let t0 = plan.start_time;
    let elements = &plan.system.elements;
    let mut watch = super::divergence::Watch::new(plan);
    let mut scales = Scales(st.cur.iter().map(|v| v.abs()).collect());
    let compliances = compliances(plan);
    let mut given = Given {
        value: st.cur.clone(),
        der: st.der.clone(),
    };
    let mut stepped = vec![false; elements.len()];
    let (h_out, stop) = (plan.h, plan.stop_time);
    let mut time = t0;
    let mut k: u64 = 1;
    let mut h = ctl.h_max;
    let (mut over, mut refused) = (0u64, 0u64);
    let mut deficit = vec![0.0; plan.system.links.len()];
    let mut carry = vec![0.0; plan.system.links.len()];
    // The last accepted step, whose impulse deficits `deficit` holds, and whether it ended
    // at a switch (the rate at which they are given, below).
    let (mut last_step, mut last_at_switch) = (0.0_f64, false);
    // After a switch: per port, the higher derivatives carried across it.
    let mut across: Option<Vec<[f64; 2]>> = None;
    // The first step after a switch, as a fraction of the largest step: its inputs start
    // without higher derivatives (no history spans the switch), so the step the controller
    // would take after it may be too long; learned from the steps after the switches before.
    let mut after_switch = 1.0_f64;
    let conserve = ctl.impulse_correction;
    // Per producer port: the highest degree its extrapolated connections take, and the last
    // accepted step that gives its higher derivatives (`extrapolation`).
    let mut degree = vec![1u8; plan.ports.len()];
    for (l, &q) in plan.extrapolation_order.iter().enumerate() {
        let p = plan.port_of[l];
        degree[p] = degree[p].max(q);
    }
    let mut history = History::new(plan.ports.len());
    // The error of the last undone attempt from `time`: an error that does not fall with
    // the step is a jump at the step's start (a feed-through output recomputed from its
    // exact inputs at t), which no smaller step cures: that step is taken.
    let mut undone: Option<(f64, f64)> = None;
    // Whether the instances were just rolled back to the states saved at `time`.
    let mut restored = false;
    // Per element: the time of its next switch it announced (∞: none).
    let mut switch_at = vec![f64::INFINITY; elements.len()];
    if let Err(m) = read_switch_times(insts, plan, ctl, time, &mut switch_at) {
        out.failure = Some(m);
        return out;
    }
    while !(time > stop || isclose(time, stop)) {
        if plan
            .interrupt
            .is_some_and(|f| f.load(std::sync::atomic::Ordering::Relaxed))
        {
            out.failure = Some(format!("interrupted at t = {time}"));
            return out;
        }
        let mut target = t0 + k as f64 * h_out;
        if target > stop || isclose(target, stop) {
            target = stop;
        }
        let remaining = target - time;
        let parts = (remaining / h * (1.0 - 1e-12)).ceil().max(1.0);
        let mut next = if parts <= 1.0 {
            target
        } else {
            time + remaining / parts
        };
        // The step ends just past the first announced switch it would pass (a predicted
        // switch is off by the prediction's error, and a step that ends short of it starts
        // the next one with the slopes before it), or at its own end when the switch lies
        // within that margin before it or within rounding after it (the FMU then reports
        // the state after it).
        let switch = switch_at.iter().copied().fold(f64::INFINITY, f64::min);
        st.switch_at_end = switch > time && switch - next <= SWITCH_AT_NOW * next.abs();
        if st.switch_at_end {
            // Not below a billionth of the time: a step at the smallest step of a long run
            // may be below an FMU's time resolution (geardyn's: 2^20 ulps of the time).
            let margin = (SWITCH_MARGIN * (next - time))
                .max(ctl.h_min)
                .max(1e-9 * next.abs());
            next = next.min(switch + margin);
        }
        let step = next - time;
        if !(step > 0.0) {
            out.failure = Some(format!(
                "the communication step from t = {time} is {step}: too small for the time's floating-point resolution"
            ));
            return out;
        }
        // After an undone attempt every instance is in the state saved at `time` (restored
        // from it): saving it again would give the same state.
        if !restored {
            for (e, inst) in insts.iter_mut().enumerate() {
                if let Err(err) = inst.save_state() {
                    out.failure = Some(super::master::at(&elements[e].name, time, err));
                    return out;
                }
            }
        }
        restored = false;
        st.prev.copy_from_slice(&st.cur);
        st.der_prev.copy_from_slice(&st.der);
        stepped.iter_mut().for_each(|s| *s = false);
        // Where the step before or this one ends at a switch, the deficit is given at most
        // at the rate of the step that made it and the rest carried: a step much shorter
        // than that one (the short step to an output point after a switch, or to a switch
        // just after a grid point) would otherwise take an offset many times its own error,
        // a jump of its inputs. Any other deficit goes whole into the next step: carried on
        // through the short steps after undone attempts, it would be an offset that no
        // smaller step removes.
        let spread = if st.switch_at_end || last_at_switch {
            step.max(last_step)
        } else {
            step
        };
        for ((o, c), d) in st.offset.iter_mut().zip(&mut carry).zip(&deficit) {
            *o = d / spread;
            *c = if spread > step { d - *o * step } else { 0.0 };
        }
        // Higher derivatives from a step much shorter than this one (the short step to an
        // output point just after a switch) would be extrapolated far beyond their span.
        let reach = history.reaches(step);
        for (p, &q) in degree.iter().enumerate() {
            if q >= 2 {
                st.higher[p] = if let Some(c) = &across {
                    c[p]
                } else if reach {
                    history.higher(p, st.cur[p], st.der[p], q)
                } else {
                    [0.0; 2]
                };
            }
        }
        let at_min = step <= ctl.h_min * (1.0 + 1e-9);
        match serial_step(&mut st, insts, (time, next), &mut stepped, None) {
            Ok(()) => {}
            Err(StepEnd::Ended(note)) => {
                out.notes.push(note);
                break;
            }
            Err(StepEnd::Failed(m)) if at_min => {
                out.failure = Some(format!(
                    "{m} (at the smallest step, --min-step {})",
                    ctl.h_min
                ));
                return out;
            }
            Err(StepEnd::Failed(_)) => {
                refused += 1;
                out.steps.push(StepRecord {
                    time,
                    step,
                    error: f64::INFINITY,
                    accepted: false,
                });
                if let Err(m) = roll_back(insts, plan, &mut st, time) {
                    out.failure = Some(m);
                    return out;
                }
                restored = true;
                h = (step / 4.0).max(ctl.h_min);
                continue;
            }
        }
        given.value.copy_from_slice(&st.cur);
        given.der.copy_from_slice(&st.der);
        if let Err(m) = refresh(&compliances, &mut st, insts, next, &stepped) {
            out.failure = Some(m);
            return out;
        }
        let (err, order) = estimate(plan, ctl, &scales, &given, &st, &history, step);
        let factor = |err: f64| {
            if err == 0.0 {
                2.0
            } else {
                (0.9 * err.powf(-1.0 / f64::from(order))).clamp(0.2, 2.0)
            }
        };
        let stuck = undone.is_some_and(|(t, e)| t == time && err >= 0.9 * e);
        if !reach {
            // A step without higher derivatives (after a switch): what it says of the first
            // steps after the next switch.
            if err > 1.0 {
                after_switch = (step / ctl.h_max * factor(err)).clamp(0.1, after_switch);
            } else if err < 0.3 {
                after_switch = (after_switch * 1.1).min(1.0);
            }
        }
        if err > 1.0 && !at_min && !stuck {
            undone = Some((time, err));
            out.steps.push(StepRecord {
                time,
                step,
                error: err,
                accepted: false,
            });
            if let Err(m) = roll_back(insts, plan, &mut st, time) {
                out.failure = Some(m);
                return out;
            }
            restored = true;
            h = (step * factor(err).min(0.9)).max(ctl.h_min);
            continue;
        }
        if err > 1.0 {
            over += 1;
        }
        undone = None;
        out.steps.push(StepRecord {
            time,
            step,
            error: err,
            accepted: true,
        });
        (last_step, last_at_switch) = (step, st.switch_at_end);
        scales.accept(&st.cur);
        if st.switch_at_end {
            // The slopes jumped at the step's end: no history spans it. The next step takes
            // the higher derivatives of the one before it, carried to the switch.
            history.forget();
            across = Some(
                st.higher
                    .iter()
                    .map(|&[c2, c3]| [c2 + c3 * step, c3])
                    .collect(),
            );
        } else {
            history.accept(&st.prev, &st.der_prev, step);
            across = None;
        }
        // A switch predicted from afar moves as the motion goes on; it is read again once
        // it is near (within a few of the largest steps) or passed.
        let near = next + SWITCH_REACH * ctl.h_max;
        if switch_at.iter().any(|&s| s <= near) || st.switch_at_end {
            if let Err(m) = read_switch_times(insts, plan, ctl, next, &mut switch_at) {
                out.failure = Some(m);
                return out;
            }
        }
        if conserve {
            // What the offsets did not carry over this step, and this step's own deficits.
            deficit.copy_from_slice(&carry);
            impulse_deficits(plan, &st, &given, step, &mut deficit);
        }
        // A step cut short to land on an output point or a switch does not shrink the next
        // one.
        let base = if next == target || st.switch_at_end {
            h.max(step)
        } else {
            step
        };
        h = (base * factor(err)).clamp(ctl.h_min, ctl.h_max);
        if st.switch_at_end {
            h = h.min(after_switch * ctl.h_max);
        }
        time = next;
        if next == target {
            if let Err(m) = output_point(&mut st, insts, sink, &mut watch, time, &mut out) {
                out.failure = Some(m);
                return out;
            }
            k += 1;
        }
    }
    out.notes.push(summary(&out.steps, ctl, over, refused));
    terminate(insts, plan, time, &mut out);
    out
}

/// The note of a controlled run: steps taken and undone, their range.
fn summary(steps: &[StepRecord], ctl: &ErrorControl, over: u64, refused: u64) -> String {
    let accepted: Vec<f64> = steps
        .iter()
        .filter(|s| s.accepted)
        .map(|s| s.step)
        .collect();
    let rejected = steps.len() - accepted.len();
    let (lo, hi) = accepted
        .iter()
        .fold((f64::INFINITY, 0.0_f64), |(a, b), &h| (a.min(h), b.max(h)));
    let mut s = format!(
        "error control at --tolerance {}: {} steps accepted, {rejected} undone ({refused} of them refused by an FMU), step {lo:.3e} to {hi:.3e} s",
        ctl.tolerance,
        accepted.len()
    );
    if over > 0 {
        s.push_str(&format!(
            "; {over} steps exceeded the tolerance (at the smallest step {:e} s, or with an error that did not fall with the step)",
            ctl.h_min
        ));
    }
    s
}

/// The step sequence as CSV: `time,step,error,accepted` (error relative to the tolerance).
pub fn steps_csv(steps: &[StepRecord]) -> String {
    use crate::host::csv::write_real;
    let mut s = String::from("\"time\",\"step\",\"error\",\"accepted\"\n");
    for r in steps {
        write_real(&mut s, r.time);
        s.push(',');
        write_real(&mut s, r.step);
        s.push(',');
        write_real(&mut s, r.error);
        s.push_str(if r.accepted { ",True\n" } else { ",False\n" });
    }
    s
}
