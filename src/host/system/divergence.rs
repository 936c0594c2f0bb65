//! Early detection of a diverging system (issue 32, "a master that says why"): a fixed-step
//! master with a coupling that is unstable at the chosen communication step (e.g. Jacobi with
//! a zero-order hold on a stiff drivetrain) pumps energy into the system until speeds reach
//! 1e8 rad/s and an FMU refuses a step minutes of CPU later. The master stops it early.
//!
//! **The bound.** Watched: every connected Real output whose unit has a time dimension
//! (speeds, torques, forces, accelerations; the energy of a drivetrain is quadratic in its
//! speeds and torques). Angles and positions grow without bound in normal operation, and
//! signals without a unit cannot be classified: they are not watched. The watched signals are
//! grouped by unit (all torques of the system together, all speeds). For a group, `M(t)`
//! is the largest magnitude any of its signals had from the start time `t0` to `t`. The
//! system *diverges* at `t` when
//!
//! `M(t) > F · M(t0 + (t − t0)/2)`  (F = 1000 by default, `--divergence-factor`)
//!
//! has held at every communication point since `t − (t − t0)/64`, after at least 16
//! communication points and with `M` not zero over the first quarter: the group
//! grew more than F-fold (its energy F²-fold) within the second half of the run so far.
//! Growth like a power of time `(t − t0)^p` gives a factor `2^p` (a run-up, a ramp: p ≤ 9
//! passes); exponential growth `e^{σt}` exceeds any bound once `σ(t − t0)/2 > ln F`. A ramp
//! starting from exactly zero at `t_s` would give an unbounded factor just after
//! `t = 2 t_s`, but only for a fraction `1/F` of the run, which the persistence over 1/64
//! excludes. Not excluded: a whole group that is zero up to rounding (not exactly zero) and
//! then steps to F times that, e.g. a system at rest whose every torque is switched on at
//! once; `--divergence-factor 0` turns the check off.

use super::plan::Plan;
use super::units::BaseUnit;
use crate::host::description::{ModelDescription, VarType};

/// A watched signal group: every watched port of one unit.
struct Group {
    unit: String,
    /// Largest magnitude so far, and the port that had it.
    max: f64,
    argmax: usize,
    /// `(t, M(t))` each time `M` grew by more than 1 % (or became non-zero): `M` at an
    /// earlier time is read back from here (at most 1 % low, which makes the bound ≤ 1 %
    /// stricter).
    history: Vec<(f64, f64)>,
    /// Since when the bound has been exceeded without interruption.
    since: Option<f64>,
}

impl Group {
    /// `M` at time `t` (the last recorded value at or before it; 0 before any).
    fn max_at(&self, t: f64) -> f64 {
        let k = self.history.partition_point(|&(s, _)| s <= t);
        if k == 0 {
            0.0
        } else {
            self.history[k - 1].1
        }
    }
}

/// The watcher of one run.
pub struct Watch {
    factor: f64,
    t0: f64,
    /// Per watched port: (port index, group).
    ports: Vec<(usize, usize)>,
    groups: Vec<Group>,
    /// Communication points seen (after the start).
    steps: u64,
}

/// The unit of a port's variable when it has a time dimension; `None` otherwise.
fn timed_unit(md: &ModelDescription, vr: u32) -> Option<String> {
    let v = md
        .variables
        .iter()
        .find(|v| v.value_reference == vr && v.var_type == VarType::Real)?;
    let name = md.unit_of(v)?;
    let def = md.unit_definitions.iter().find(|u| u.name == name)?;
    let b = BaseUnit::from_attrs(&def.base_unit).ok()?;
    (b.exponents[2] != 0).then(|| name.to_string())
}

/// The watched producer ports of a plan, with their units: Real outputs whose unit has a time
/// dimension (an angle, a position, a ratio or a signal without a unit is not watched).
pub fn watched<'m>(
    ports: &[(usize, u32, VarType)],
    md_of: &dyn Fn(usize) -> &'m ModelDescription,
) -> Vec<(usize, String)> {
    ports
        .iter()
        .enumerate()
        .filter(|(_, &(_, _, t))| t == VarType::Real)
        .filter_map(|(p, &(e, vr, _))| timed_unit(md_of(e), vr).map(|u| (p, u)))
        .collect()
}

impl Watch {
    /// The watcher of a plan, `None` when its divergence factor is 0 (off) or no port is
    /// watched.
    pub fn new(plan: &Plan) -> Option<Watch> {
        if plan.divergence_factor == 0.0 || plan.watched.is_empty() {
            return None;
        }
        let mut w = Watch {
            factor: plan.divergence_factor,
            t0: plan.start_time,
            ports: Vec::new(),
            groups: Vec::new(),
            steps: 0,
        };
        for (p, unit) in &plan.watched {
            let g = w
                .groups
                .iter()
                .position(|g| g.unit == *unit)
                .unwrap_or_else(|| {
                    w.groups.push(Group {
                        unit: unit.clone(),
                        max: 0.0,
                        argmax: *p,
                        history: Vec::new(),
                        since: None,
                    });
                    w.groups.len() - 1
                });
            w.ports.push((*p, g));
        }
        Some(w)
    }

    /// Look at the port values `cur` at communication point `t`; `Some(message)` when the
    /// system diverges (or a watched value is not finite), naming the element and the signal.
    pub fn check(&mut self, plan: &Plan, t: f64, cur: &[f64]) -> Option<String> {
        self.steps += 1;
        for &(p, g) in &self.ports {
            let v = cur[p];
            if !v.is_finite() {
                return Some(format!(
                    "the system diverges: {} is {v} at t = {t}",
                    signal(plan, p)
                ));
            }
            let m = v.abs();
            let grp = &mut self.groups[g];
            if m > grp.max {
                grp.max = m;
                grp.argmax = p;
                let last = grp.history.last().map_or(0.0, |h| h.1);
                if last == 0.0 || m > 1.01 * last {
                    grp.history.push((t, m));
                }
            }
        }
        if self.steps < 16 {
            return None;
        }
        let elapsed = t - self.t0;
        for grp in &mut self.groups {
            let (half, quarter) = (self.t0 + elapsed / 2.0, self.t0 + elapsed / 4.0);
            let reference = grp.max_at(half);
            let exceeded = grp.max_at(quarter) > 0.0 && grp.max > self.factor * reference;
            if !exceeded {
                grp.since = None;
                continue;
            }
            let since = *grp.since.get_or_insert(t);
            if t - since >= elapsed / 64.0 {
                return Some(format!(
                    "the system diverges: {} reached {:.4e} {} at t = {t}, more than {} times the largest {} signal up to t = {half} ({reference:.4e}), and has been above that bound since t = {since}: growth faster than any power of time, the bound of docs/systems.md (a coupling instability of the fixed-step master: try a smaller --output-interval, --algorithm gauss-seidel or --extrapolation linear; --divergence-factor 0 turns this check off)",
                    signal(plan, grp.argmax),
                    grp.max,
                    grp.unit,
                    self.factor,
                    grp.unit,
                ));
            }
        }
        None
    }
}

/// `element "gear" output "input.speed"` for producer port `p`.
fn signal(plan: &Plan, p: usize) -> String {
    let (e, ..) = plan.ports[p];
    let l = plan.port_of.iter().position(|&x| x == p).unwrap_or(0);
    let name = &plan.system.links[l].from.name;
    let element = &plan.system.elements[e].name;
    let variable = name
        .strip_prefix(element.as_str())
        .and_then(|s| s.strip_prefix('.'))
        .unwrap_or(name);
    format!("element \"{element}\" output \"{variable}\"")
}
