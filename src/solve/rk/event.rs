//! State-event detection and location on the interpolant of an accepted step.
//!
//! An event is a guard going from `>= 0` to `< 0` (a guard that is exactly 0 where integration
//! restarts and stays `>= 0` is not one, so a state snapped onto the surface is not re-detected).
//! Guards the system declares affine in the state ([`HybridSystem::affine_guard`], the contact
//! gaps of the gear models) are bounded along the whole interpolant ([`super::graze`]): a
//! grazing dip below zero between the step ends is found however long the step, and an
//! ordinary step costs one bound test. Other guards are sampled at `guard_samples` interior
//! points of the dense output as well as at the step end, which catches an excursion longer
//! than the sample spacing (Shampine & Thompson 2000, Comput. Math. Appl. 39:43–54). Touching
//! the surface (a minimum exactly 0) is not an event, as for the exact propagator.
//! The first bracketed crossing is refined with the
//! Illinois variant of regula falsi (Dowell & Jarratt 1971; as used for event location by
//! Hiebert & Shampine 1980, Sandia SAND80-0180), which costs only interpolant evaluations, to
//! a bracket of a few ulp of `t`. The returned time is the bracket end where the guard is
//! already negative: the event has happened there, so the system can switch mode consistently.

use super::dense;
use super::graze::GuardOnStep;
use super::Method;
use crate::solve::{HybridSystem, SolverStats};

#[derive(Debug, Clone, Default)]
pub(crate) struct EventState {
    /// Guards at the start of the next step (valid if `valid` and `m` guards).
    g0: Vec<f64>,
    ga: Vec<f64>,
    gb: Vec<f64>,
    gm: Vec<f64>,
    /// Affine guards: gradients `w` (`m × n`), curvature bounds of their time parts, and a
    /// gradient scratch row.
    w: Vec<f64>,
    time_curvature: Vec<f64>,
    grad: Vec<f64>,
    m: usize,
    valid: bool,
    last_t: f64,
    storm: u64,
}

/// Illinois iterations are bounded; bisection fall-backs guarantee the bracket halves at least
/// every other iteration, so 200 covers any f64 bracket.
const MAX_ITER: usize = 200;

impl EventState {
    pub fn invalidate(&mut self) {
        self.valid = false;
    }

    /// A restart at a given state: the guards are stale and the run of events without
    /// progress is over. A caller that re-integrates from a saved state (the probes of
    /// `analysis::orbit_statistics` go back to a cell's start many times) meets the same event
    /// at the same time again; that is a new trajectory, not a storm, and counting it with the
    /// previous runs' events failed healthy runs (issue 36: geometry pairs on the RK path).
    pub fn restart(&mut self) {
        self.valid = false;
        self.storm = 0;
    }

    /// Guard values at the step start, evaluated only after a (re)start.
    pub fn ensure_start<S: HybridSystem>(
        &mut self,
        sys: &S,
        t: f64,
        y: &[f64],
        m: usize,
        stats: &mut SolverStats,
    ) {
        if self.valid && self.m == m {
            return;
        }
        if self.g0.len() < m {
            for v in [&mut self.g0, &mut self.ga, &mut self.gb, &mut self.gm] {
                v.resize(m, 0.0);
            }
        }
        self.m = m;
        sys.guards(t, y, &mut self.g0[..m]);
        // A guard starts >= 0 (the mode matches the state), but after an event the state is
        // snapped onto the surface and rounding (x = e − c, then δ + c = x − e + c) can leave
        // it a few ulp below 0. Such a guard could never go from >= 0 to < 0: a contact shorter
        // than the first step would then never end (found by the stress suite: DOP853 stuck in
        // back-side contact for 13 mesh periods). Start it at 0, so the first negative sample
        // is the event.
        for g in &mut self.g0[..m] {
            *g = g.max(0.0);
        }
        stats.guard_evals += 1;
        self.valid = true;
    }

    /// Records an event at `t_ev`; returns how many events happened in a row without time
    /// progressing by more than a few hundred ulp of `scale`.
    pub fn note_event(&mut self, t_ev: f64, scale: f64) -> u64 {
        if self.storm > 0 && t_ev - self.last_t <= 1e3 * f64::EPSILON * scale {
            self.storm += 1;
        } else {
            self.storm = 1;
        }
        self.last_t = t_ev;
        self.storm
    }

    /// Looks for the first guard crossing in the accepted step `(t0, h, t1)` whose end state
    /// is `y1` and whose interpolant is `(method, r)`. Returns `(t_event, guard index)`; when
    /// there is none, the end-of-step guard values become the next step's start values.
    #[allow(clippy::too_many_arguments)]
    pub fn locate<S: HybridSystem>(
        &mut self,
        sys: &S,
        m: usize,
        samples: usize,
        (t0, h, t1): (f64, f64, f64),
        y1: &[f64],
        interp: (Method, &[f64]),
        ytmp: &mut [f64],
        stats: &mut SolverStats,
    ) -> Option<(f64, usize)> {
        if self.affine_structure(sys, m, (t0, t1), y1.len()) {
            return self.locate_affine(sys, m, (t0, h, t1), y1, interp, ytmp, stats);
        }
        let parts = samples + 1;
        self.ga[..m].copy_from_slice(&self.g0[..m]);
        let mut ta = t0;
        for j in 1..=parts {
            let tb = if j == parts {
                sys.guards(t1, y1, &mut self.gb[..m]);
                t1
            } else {
                let theta = j as f64 / parts as f64;
                let tb = (t0 + theta * h).min(t1);
                dense::eval(interp.0, (tb - t0) / h, interp.1, ytmp);
                sys.guards(tb, ytmp, &mut self.gb[..m]);
                tb
            };
            stats.guard_evals += 1;
            let mut first: Option<(f64, usize)> = None;
            for i in 0..m {
                if self.ga[i] >= 0.0 && self.gb[i] < 0.0 {
                    let a = (ta, self.ga[i]);
                    let b = (tb, self.gb[i]);
                    let tr = self.illinois(sys, i, a, b, (t0, h), interp, ytmp, stats);
                    if !matches!(first, Some((tf, _)) if tf <= tr) {
                        first = Some((tr, i));
                    }
                }
            }
            if first.is_some() {
                return first;
            }
            std::mem::swap(&mut self.ga, &mut self.gb);
            ta = tb;
        }
        std::mem::swap(&mut self.g0, &mut self.ga);
        None
    }

    /// Whether every guard of the mode is affine with a gradient (`w` and the curvature bound
    /// of each are then in `self.w`, `self.time_curvature`).
    fn affine_structure<S: HybridSystem>(
        &mut self,
        sys: &S,
        m: usize,
        (t0, t1): (f64, f64),
        n: usize,
    ) -> bool {
        if self.w.len() < m * n {
            self.w.resize(m * n, 0.0);
            self.grad.resize(n, 0.0);
        }
        if self.time_curvature.len() < m {
            self.time_curvature.resize(m, 0.0);
        }
        for i in 0..m {
            match sys.affine_guard(i, t0, t1, &mut self.w[i * n..(i + 1) * n]) {
                Some(c) => self.time_curvature[i] = c,
                None => return false,
            }
        }
        true
    }

    /// Event search for affine guards ([`graze`]): a guard positive at both step ends is still
    /// searched for an interior dip, but only where its bounds leave one possible.
    #[allow(clippy::too_many_arguments)]
    fn locate_affine<S: HybridSystem>(
        &mut self,
        sys: &S,
        m: usize,
        (t0, h, t1): (f64, f64, f64),
        y1: &[f64],
        interp: (Method, &[f64]),
        ytmp: &mut [f64],
        stats: &mut SolverStats,
    ) -> Option<(f64, usize)> {
        let n = y1.len();
        sys.guards(t1, y1, &mut self.gb[..m]);
        stats.guard_evals += 1;
        let mut first: Option<(f64, usize)> = None;
        for i in 0..m {
            let (g_start, g_end) = (self.g0[i], self.gb[i]);
            let bracket = {
                let mut guard = GuardOnStep::new(
                    sys,
                    i,
                    (t0, h, t1),
                    interp,
                    y1,
                    ytmp,
                    &mut self.gm[..m],
                    &mut self.grad[..n],
                    stats,
                    &self.w[i * n..(i + 1) * n],
                    self.time_curvature[i],
                );
                let start = guard.point(0.0, Some(g_start));
                let end = guard.point(1.0, Some(g_end));
                guard
                    .first_crossing(start, end)
                    .map(|(lo, hi)| ((guard.time(lo.at), lo.g), (guard.time(hi.at), hi.g)))
            };
            if let Some((a, b)) = bracket {
                if matches!(first, Some((tf, _)) if tf <= a.0) {
                    continue;
                }
                let tr = self.illinois(sys, i, a, b, (t0, h), interp, ytmp, stats);
                if !matches!(first, Some((tf, _)) if tf <= tr) {
                    first = Some((tr, i));
                }
            }
        }
        if first.is_none() {
            std::mem::swap(&mut self.g0, &mut self.gb);
        }
        first
    }

    /// Illinois on guard `i` over `[ta, tb]` with `g(ta) >= 0 > g(tb)`; returns the final `tb`.
    #[allow(clippy::too_many_arguments)]
    fn illinois<S: HybridSystem>(
        &mut self,
        sys: &S,
        i: usize,
        (mut ta, mut ga): (f64, f64),
        (mut tb, mut gb): (f64, f64),
        (t0, h): (f64, f64),
        interp: (Method, &[f64]),
        ytmp: &mut [f64],
        stats: &mut SolverStats,
    ) -> f64 {
        let m = self.m;
        let tol = 4.0 * f64::EPSILON * ta.abs().max(tb.abs());
        let mut side = 0i8;
        let mut width_before = tb - ta;
        for iter in 0..MAX_ITER {
            let width = tb - ta;
            if width <= tol {
                break;
            }
            // Every second iteration must at least halve the bracket, else bisect: Illinois
            // is superlinear on smooth guards but interpolant noise near the root can stall it.
            let bisect = iter % 2 == 1 && width > 0.5 * width_before;
            if iter % 2 == 1 {
                width_before = width;
            }
            let mut tm = if bisect || ga == gb {
                ta + 0.5 * width
            } else {
                tb - gb * (width / (gb - ga))
            };
            if !(tm > ta && tm < tb) {
                tm = ta + 0.5 * width;
                if !(tm > ta && tm < tb) {
                    break;
                }
            }
            dense::eval(interp.0, (tm - t0) / h, interp.1, ytmp);
            sys.guards(tm, ytmp, &mut self.gm[..m]);
            stats.guard_evals += 1;
            let gm = self.gm[i];
            if gm < 0.0 {
                tb = tm;
                gb = gm;
                if side == -1 {
                    ga *= 0.5;
                }
                side = -1;
            } else {
                ta = tm;
                ga = gm;
                if side == 1 {
                    gb *= 0.5;
                }
                side = 1;
            }
        }
        tb
    }
}
