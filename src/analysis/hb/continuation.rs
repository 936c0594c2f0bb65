//! Pseudo-arclength continuation of the harmonic-balance orbit in the input speed, with fold
//! detection and the Floquet multipliers of every point.

use nalgebra::{Complex, DMatrix, DVector};

use super::blocked_lu::{Factorised, FrozenJacobian};
use super::krylov::{krylov_corrector, krylov_tangent, Corrected};
use super::problem::{Evaluation, Problem, Want, CHORD_UNKNOWNS};
use super::{HbOptions, HbSolution};
use crate::analysis::shooting::{newton, state_scale, PeriodMap, ShootingOptions, Stability};
use crate::analysis::Report;
use crate::model::{Drivetrain, SceneSource};
use crate::scene::SolverSettings;
use crate::simulation::Driver;
use crate::with_drivetrain;

/// Settings of the continuation.
#[derive(Debug, Clone)]
pub struct ContinuationOptions {
    /// Input-speed interval, rad/s: the branch starts at `from` and ends when it leaves the
    /// interval.
    pub from: f64,
    pub to: f64,
    /// Initial and largest arclength step (scaled units).
    pub initial_step: f64,
    pub max_step: f64,
    pub max_points: usize,
    /// Compute the Floquet multipliers of each point (shooting monodromy from the HB state).
    pub stability: bool,
    /// A point whose HB spectral radius lies within this of 1 has its verdict checked by
    /// Newton shooting from the HB state ([`ShootingCheck`]); default
    /// [`SHOOTING_CHECK_MARGIN`], 0 never checks, infinity checks every point.
    pub shooting_check_margin: f64,
    /// A large system's branch (more than 512 unknowns, `CHORD_UNKNOWNS`) ends at its first point
    /// whose [`BranchPoint::periodicity_defect`] exceeds this ([`BranchPoint::unresolved`]);
    /// default [`PERIODICITY_DEFECT_LIMIT`], infinity never ends it.
    pub defect_limit: f64,
}

/// Default [`ContinuationOptions::shooting_check_margin`]. The HB radius is that of the
/// monodromy along the trajectory from the HB state, which lies off the periodic orbit by the
/// truncation error (the contact kinks make it decay like 1/H: on `idler_gearset` at
/// 380–400 rad/s 5.5e-4, 2.7e-4, 1.35e-4, 6.7e-5 of the state scale at H = 10, 20, 40, 80).
/// Where a contact switch of the orbit is sensitive to that offset, the radius errs by up to
/// [`RADIUS_SENSITIVITY`] times it (the multiplier that crosses the unit circle at the
/// idler's Neimark–Sacker point: 2.4e-3, 1.24e-3, 6.4e-4, 3.4e-4 at those H; the lightly
/// damped modes' multipliers within 1e-7). 2e-3 covers that error plus the 1e-4 the verdicts
/// are compared at for H ≥ 20 and keeps the check to the few points near the circle (11 of
/// 344 on the idler's 250–760 rad/s branch at H = 20); where a coarser orbit may err by more,
/// the summary of `geardyn hb` says so ([`BranchPoint::verdict_uncertain`]).
pub const SHOOTING_CHECK_MARGIN: f64 = 2e-3;

/// The largest measured ratio of the HB radius error near `|μ| = 1` to the HB orbit's scaled
/// distance from the periodic orbit (4.7 on `idler_gearset` at H = 10–80, rounded up).
/// Beside folds, where a real multiplier passes +1 with unbounded slope, the ratio is larger
/// (up to ~150 measured), but there the fold itself marks the change of stability.
pub const RADIUS_SENSITIVITY: f64 = 5.0;

/// An HB orbit whose estimated scaled distance from the periodic orbit
/// ([`BranchPoint::orbit_error`]) exceeds this is a poor approximation of it: its statistics,
/// its folds and its verdict may be wrong, and the summary of `geardyn hb` says so. Measured on
/// `countershaft_gearset` at H = 20: 1.6e-3–2.4e-3 on the lower branch at 385–394 rad/s (the
/// orbit Newton shooting finds from the HB state 1.6e-3–2.4e-3 away), 0.16–1.05 on the branch
/// with 22–33 % contact loss on mesh 1 (at 384.64 rad/s estimated 0.165, found 0.170), where
/// the HB branch turns at ~373.5 rad/s while the periodic orbit's branch ends at 382.0–382.5
/// rad/s (shooting continuation, `tests/hb_verdicts.rs`); 1e-2 lies between the two.
pub const ORBIT_ERROR_WARNING: f64 = 1e-2;

/// Default [`ContinuationOptions::defect_limit`]: the scaled periodicity defect of the HB state
/// beyond which a large system's branch is not continued, because its course would be the
/// truncation's, not the orbit's. The defect, unlike the Newton step of
/// [`BranchPoint::orbit_error`], stays finite at a fold (the step divides by `M − I`, singular
/// where a multiplier passes +1). Measured on `countershaft_gearset` at H = 20 (docs/
/// harmonic-balance.md, "Where H = 20 does not resolve the orbit"): within 2 % of the distance
/// of the orbit Newton shooting converges to from the HB state at all 31 points of 385–400
/// rad/s; 1.6e-3–6.2e-3 on the lower branch up to the 394 rad/s fold, 0.3 beside it (Newton
/// step 104), 0.02–0.034 and 0.14–0.29 beyond it, where the H = 20 branch turns at 373.5 rad/s
/// and the orbit's at 382.0–382.5. 1e-2 is the distance at which `tests/hb_verdicts.rs` takes a
/// shooting orbit for another orbit.
pub const PERIODICITY_DEFECT_LIMIT: f64 = 1e-2;

/// A shooting orbit is taken as the HB orbit's when its start lies within this many times the
/// first Newton step from the HB state (the step estimates the distance; measured within 5 %
/// of it away from folds): farther away, Newton has found another orbit.
pub const SHOOTING_CHECK_DISTANCE: f64 = 2.0;

/// Scaled periodicity residual at which the check's Newton stops. The radius moves by about
/// five times the orbit's scaled displacement near `|μ| = 1` (measured on `idler_gearset`), so
/// this keeps the checked radius within ~1e-8 of the converged one, far inside the 1e-4 the
/// verdicts are compared at, and the Newton step from the HB state usually reaches it with
/// the one period map the check costs.
const SHOOTING_CHECK_TOLERANCE: f64 = 1e-9;

/// Newton iterations of the shooting check; the start is the HB orbit, within its truncation
/// error of the periodic orbit, so Newton converges in a few (quadratically, away from folds).
const SHOOTING_CHECK_ITERATIONS: usize = 12;

impl ContinuationOptions {
    pub fn new(from: f64, to: f64) -> Self {
        ContinuationOptions {
            from,
            to,
            initial_step: 0.01,
            max_step: 0.05,
            max_points: 2000,
            stability: true,
            shooting_check_margin: SHOOTING_CHECK_MARGIN,
            defect_limit: PERIODICITY_DEFECT_LIMIT,
        }
    }
}

/// One point of a continued branch.
#[derive(Debug, Clone)]
pub struct BranchPoint {
    pub solution: HbSolution,
    /// Input speed, rad/s.
    pub speed: f64,
    /// Floquet multipliers over the HB period (None when not computed): eigenvalues of the
    /// monodromy (with saltation) from the HB state at `t = 0`, accurate to the HB truncation
    /// error; where the shooting check converged ([`BranchPoint::shooting_check`]), those of
    /// the periodic orbit Newton shooting found from the HB state.
    pub multipliers: Option<Vec<Complex<f64>>>,
    /// Set where the HB spectral radius lay within
    /// [`ContinuationOptions::shooting_check_margin`] of 1.
    pub shooting_check: Option<ShootingCheck>,
    /// The scaled size of the Newton step from the HB state (from its period map and
    /// monodromy, no integration): the estimate of the HB orbit's distance from the periodic
    /// orbit in the shooting residual's scale ([`state_scale`]); None without multipliers.
    pub orbit_error: Option<f64>,
    /// The largest scaled component of `P(y) − y`, the HB state `y` against its period map
    /// `P` (shooting residual scale, [`state_scale`]); None without the period map.
    pub periodicity_defect: Option<f64>,
    /// Whether the branch ended at this point because its periodicity defect exceeded
    /// [`ContinuationOptions::defect_limit`]: H does not resolve the orbit here.
    pub unresolved: bool,
    /// Whether the step to this point passed a fold (turning point in speed).
    pub fold: bool,
}

/// The check of a point's stability near `|μ| = 1` by Newton shooting from the HB state
/// (the period map and monodromy with saltation that `geardyn periodic` uses).
#[derive(Debug, Clone)]
pub struct ShootingCheck {
    /// The spectral radius of the monodromy along the trajectory from the HB state (the
    /// estimate that was checked).
    pub hb_radius: f64,
    /// The verdict of those multipliers.
    pub hb_stability: Stability,
    /// The shooting orbit's spectral radius; None when Newton did not converge within
    /// [`SHOOTING_CHECK_DISTANCE`] first Newton steps of the HB state (then the HB estimate
    /// stands).
    pub shooting_radius: Option<f64>,
    /// Scaled distance of the shooting orbit's start from the HB state (NaN without one).
    pub distance: f64,
    /// Scaled size of the first Newton step from the HB state (computed from the HB map and
    /// monodromy alone): the estimate of that distance the margin is scaled by.
    pub newton_step: f64,
    /// Newton iterations of the check (period maps evaluated after the HB one).
    pub iterations: usize,
}

impl BranchPoint {
    /// Largest |μ| (None when the multipliers were not computed).
    pub fn spectral_radius(&self) -> Option<f64> {
        self.multipliers
            .as_ref()
            .map(|m| m.iter().map(|c| c.norm()).fold(0.0, f64::max))
    }

    /// The verdict of the multipliers ([`Stability::of`]; neutral within
    /// [`crate::analysis::shooting::NEUTRAL_TOLERANCE`] of the unit circle).
    pub fn stability(&self) -> Option<Stability> {
        self.multipliers.as_deref().map(Stability::of)
    }

    /// Stable when every multiplier lies inside the unit circle (by more than the neutral
    /// tolerance).
    pub fn stable(&self) -> Option<bool> {
        self.stability().map(|s| s == Stability::Stable)
    }

    /// Whether the verdict of unchecked HB multipliers may be wrong: the radius lies within
    /// [`RADIUS_SENSITIVITY`] times the HB orbit's error of 1 (outside the check's margin,
    /// else it would have been checked).
    pub fn verdict_uncertain(&self) -> bool {
        match (self.spectral_radius(), self.orbit_error) {
            (Some(r), Some(e)) if self.shooting_check.is_none() => {
                (r - 1.0).abs() <= RADIUS_SENSITIVITY * e
            }
            _ => false,
        }
    }

    /// Whether the HB orbit's estimated distance from the periodic orbit exceeds
    /// [`ORBIT_ERROR_WARNING`] (false without an estimate, or where the shooting check found
    /// the orbit: its multipliers are then the orbit's).
    pub fn far_from_orbit(&self) -> bool {
        !self.shooting_checked() && self.orbit_error.is_some_and(|e| e > ORBIT_ERROR_WARNING)
    }

    /// Whether the multipliers came from the shooting orbit of the check.
    pub fn shooting_checked(&self) -> bool {
        self.shooting_check
            .as_ref()
            .is_some_and(|c| c.shooting_radius.is_some())
    }
}

/// Pseudo-arclength continuation of the HB orbit in input speed (Keller 1977; Krack & Gross
/// §4.2): predictor along the tangent of `r(s, λ) = 0`, corrector orthogonal to it, step size
/// adapted to the Newton effort. Turning points (folds) are passed and marked.
pub fn continuation(
    scene: &impl SceneSource,
    hb: &HbOptions,
    options: &ContinuationOptions,
) -> Result<Vec<BranchPoint>, String> {
    continuation_reporting(scene, hb, options, &|_, _| {})
}

/// [`continuation`], reporting each branch point (the speed reached of the interval) and the
/// stability step to `report`.
pub fn continuation_reporting(
    scene: &impl SceneSource,
    hb: &HbOptions,
    options: &ContinuationOptions,
    report: Report,
) -> Result<Vec<BranchPoint>, String> {
    if !(options.from > 0.0 && options.to.is_finite() && options.from.is_finite())
        || options.from == options.to
    {
        return Err(format!(
            "continuation range {}..{} rad/s: need two different finite speeds > 0",
            options.from, options.to
        ));
    }
    let mut scene = scene.to_scene();
    scene.profiles.require_constant("harmonic balance")?;
    crate::model::train::planetary::require_fixed_frame_speed(&scene, "harmonic balance")?;
    scene.set_input_speed(options.from);
    let settings = scene.solver.clone();
    with_drivetrain!(scene.simulation()?, sim => {
        let problem = Problem::new(sim.model().clone(), settings, hb)?;
        continue_branch(problem, sim, hb, options, report)
    })
}

fn continue_branch<M: Drivetrain + Send>(
    mut problem: Problem<M>,
    sim: Driver<M>,
    hb: &HbOptions,
    options: &ContinuationOptions,
    report: Report,
) -> Result<Vec<BranchPoint>, String> {
    let f_ref = problem.f;
    let (f_lo, f_hi) = (
        problem.frequency(options.from.min(options.to)),
        problem.frequency(options.from.max(options.to)),
    );
    let xs = problem.x_scale;
    let dim = problem.coordinates() * problem.len;

    let seed = problem.seed(sim)?;
    let (start, _, iterations) = problem.newton(seed, f_ref, hb)?;
    // Scaled unknowns w = [s/x_s, f/f_ref].
    let mut w = DVector::zeros(dim + 1);
    w.rows_mut(0, dim).copy_from(&(&start / xs));
    w[dim] = 1.0;
    let all = Want {
        jacobian: true,
        frequency: true,
        samples: false,
        linear: false,
    };
    // Scaled residual r/x_s and the bordered matrix [∂r/∂s, ∂r/∂λ · f_ref/x_s; 0]: its last
    // row is the caller's (the tangent), set before it is factorised.
    let scaled = |problem: &mut Problem<M>,
                  w: &DVector<f64>,
                  want: Want|
     -> Result<(DVector<f64>, DMatrix<f64>, Evaluation), String> {
        let s = w.rows(0, dim) * xs;
        let f = w[dim] * f_ref;
        let mut e = problem.evaluate(&s, f, want)?;
        let mut a = DMatrix::zeros(dim + 1, dim + 1);
        a.view_mut((0, 0), (dim, dim))
            .copy_from(e.jacobian.as_ref().expect("asked for"));
        a.view_mut((0, dim), (dim, 1))
            .copy_from(&(e.d_frequency.take().expect("asked for") * (f_ref / xs)));
        Ok((&e.residual / xs, a, e))
    };
    // The unit tangent of the bordered matrix `a` whose last row is the previous tangent.
    let tangent_of = |a: &Factorised| -> Option<DVector<f64>> {
        let mut rhs = DVector::zeros(dim + 1);
        rhs[dim] = 1.0;
        let t = a.solve(&rhs)?;
        Some(t.normalize())
    };
    let direction = if options.to > options.from { 1.0 } else { -1.0 };
    let chord = dim > CHORD_UNKNOWNS;
    // On the torus (krylov.rs): the start's tangent `[−J⁻¹ ∂r/∂λ; 1]` by GMRES, no matrix.
    let mut on_torus = None;
    if chord && problem.torus.is_some() {
        let want = Want {
            jacobian: false,
            frequency: true,
            samples: true,
            linear: true,
        };
        let mut e = problem.evaluate(&start, f_ref, want)?;
        if problem.torus.is_some() {
            let d = e.d_frequency.take().expect("asked for") * (f_ref / xs);
            let t = krylov_tangent(&problem, &d)
                .ok_or("continuation: GMRES did not converge at the start")?;
            on_torus = Some((e, t));
        }
    }
    let (e0, mut tangent, mut factored) = match on_torus {
        Some((e, t)) => (e, t, None),
        None => {
            let mut seed = DVector::zeros(dim + 1);
            seed[dim] = direction;
            let (_, mut a0, e0) = scaled(
                &mut problem,
                &w,
                Want {
                    samples: true,
                    ..all
                },
            )?;
            a0.set_row(dim, &seed.transpose());
            // Large systems: the chord corrector ([`chord_corrector`]) starts from this
            // factorisation.
            let lu0 = Factorised::new(a0, chord);
            let tangent = tangent_of(&lu0).ok_or("continuation: singular start")?;
            (e0, tangent, chord.then_some(lu0))
        }
    };
    if tangent[dim] * direction < 0.0 {
        tangent = -tangent;
    }
    let mut points = vec![make_point(&problem, f_ref, &e0, iterations, false)];
    // A large system's points take their stability step as the branch goes (its period map
    // costs a small part of a corrector there), so that the branch ends where H no longer
    // resolves the orbit instead of following the truncation (`defect_limit`).
    let watch = chord && (options.stability || options.defect_limit.is_finite());
    let mut ended = watch && watch_point(&problem, &mut points[0], options);
    // The Newton–Krylov corrector's preconditioner, kept over branch points.
    let mut frozen = FrozenJacobian::default();
    let mut step = options.initial_step;
    while !ended && points.len() < options.max_points {
        // A study's per-point timeout (`budget::with_deadline`): the Newton solves run no
        // driver, so the branch looks at the clock once per point.
        if let Some(message) = crate::simulation::budget::deadline_passed(f64::NAN) {
            return Err(message);
        }
        let predicted = &w + &tangent * step;
        let mut candidate = predicted.clone();
        let mut iterations = 0;
        let mut refreshed = 0;
        let mut newton_like = !chord;
        let next = if chord {
            // On the torus Newton–Krylov; where the torus declines (a switch it cannot
            // bracket), the chord method on the line quadrature from the predictor.
            let krylov = if problem.torus.is_some() {
                krylov_corrector(
                    &mut problem,
                    &mut frozen,
                    &mut candidate,
                    (&predicted, &tangent),
                    (xs, f_ref),
                    hb.tolerance,
                )
            } else {
                Corrected::Declined
            };
            let outcome = match krylov {
                Corrected::Converged(e, its) => {
                    newton_like = true;
                    Some((*e, its, 0))
                }
                Corrected::Failed => None,
                Corrected::Declined => {
                    candidate = predicted.clone();
                    chord_corrector(
                        &mut problem,
                        &mut factored,
                        &mut candidate,
                        (&predicted, &tangent),
                        (xs, f_ref),
                        hb.tolerance,
                    )
                }
            };
            let Some((e, its, refreshes)) = outcome else {
                factored = None;
                step *= 0.5;
                if step < 1e-8 {
                    return Err(format!(
                        "continuation stalled near {:.3} rad/s (step below 1e-8)",
                        points.last().map_or(options.from, |p| p.speed)
                    ));
                }
                continue;
            };
            iterations = its;
            refreshed = refreshes;
            // The secant of the last two points is the next tangent (Keller 1977): the chord
            // matrix is not the Jacobian at the new point.
            let next = (&candidate - &w).normalize();
            (next, e)
        } else {
            // The corrector: Newton on [r; tᵀ(w − w_pred)] = 0. It stops at the iterate whose
            // update is below the tolerance and keeps that iterate's evaluation (the factorised
            // bordered matrix, whose last row is the tangent: the next tangent's matrix; node
            // samples for the results): no extra evaluation or factorisation per point.
            let mut last = None;
            for it in 1..=12 {
                iterations = it;
                let with_samples = Want {
                    samples: true,
                    ..all
                };
                let Ok((r, mut a, e)) = scaled(&mut problem, &candidate, with_samples) else {
                    break;
                };
                a.set_row(dim, &tangent.transpose());
                let mut g = DVector::zeros(dim + 1);
                g.rows_mut(0, dim).copy_from(&r);
                g[dim] = tangent.dot(&(&candidate - &predicted));
                let lu = a.lu();
                let Some(delta) = lu.solve(&(-g)) else {
                    break;
                };
                if delta.amax() <= hb.tolerance.max(1e-13) * 10.0 {
                    last = Some((Factorised::Unblocked(lu), e));
                    break;
                }
                candidate += &delta;
            }
            let Some((lu, e)) = last else {
                step *= 0.5;
                if step < 1e-8 {
                    return Err(format!(
                        "continuation stalled near {:.3} rad/s (step below 1e-8)",
                        points.last().map_or(options.from, |p| p.speed)
                    ));
                }
                continue;
            };
            let mut next = tangent_of(&lu).ok_or("continuation: singular tangent")?;
            if next.dot(&tangent) < 0.0 {
                next = -next;
            }
            (next, e)
        };
        let (next, e) = next;
        let fold = next[dim] * tangent[dim] < 0.0;
        w = candidate;
        tangent = next;
        let f = w[dim] * f_ref;
        points.push(make_point(&problem, f, &e, iterations, fold));
        let last = points.len() - 1;
        ended = watch && watch_point(&problem, &mut points[last], options);
        let speed = points[last].speed;
        report(
            ((speed - options.from) / (options.to - options.from)).clamp(0.0, 1.0),
            &|| {
                format!(
                    "hb: {} branch points, input speed {speed:.6} rad/s of {} to {}",
                    points.len(),
                    options.from,
                    options.to
                )
            },
        );
        if ended || f < f_lo || f > f_hi {
            break;
        }
        step = if !newton_like {
            // Chord iterations converge linearly: more of them, and a refreshed Jacobian, are
            // what a step too long shows.
            if refreshed == 0 && iterations <= 10 {
                (step * 1.5).min(options.max_step)
            } else if refreshed > 1 || iterations > 18 {
                step * 0.5
            } else {
                step
            }
        } else if iterations <= 3 {
            (step * 1.5).min(options.max_step)
        } else if iterations > 6 {
            step * 0.5
        } else {
            step
        };
    }
    if options.stability && !watch {
        report(f64::NAN, &|| {
            format!(
                "hb: Floquet multipliers of {} branch points (shooting)",
                points.len()
            )
        });
        branch_stability(&problem, &mut points, options.shooting_check_margin);
    }
    Ok(points)
}

/// Iterations of the chord corrector before the step is halved.
const CHORD_ITERATIONS: usize = 24;

/// A chord update that shrinks by less than this factor against the previous one asks for
/// the Jacobian at the next iterate.
const CHORD_CONTRACTION: f64 = 0.5;

/// Jacobian refreshes of one chord correction before the step is halved.
const CHORD_REFRESHES: usize = 3;

/// The corrector of a large system: the chord method (Keller 1977; Krack & Gross 2019 §4.2)
/// on `[r; tᵀ(w − w_pred)] = 0` with the factorised bordered matrix `factored` kept from an
/// earlier point, refreshed (Jacobian, frequency derivative, LU at the current iterate) only
/// when an update shrinks by less than [`CHORD_CONTRACTION`]. On the countershaft at H = 20
/// (1682 unknowns) the Jacobian's Toeplitz sums cost ~10 residuals and its LU ~3e9 flops, so
/// linear convergence with residuals alone is the cheaper route (docs/harmonic-balance.md
/// "Solver"). Returns the last iterate's evaluation (with node samples), the iterations and the
/// refreshes; None when it does not converge.
fn chord_corrector<M: Drivetrain>(
    problem: &mut Problem<M>,
    factored: &mut Option<Factorised>,
    candidate: &mut DVector<f64>,
    (predicted, tangent): (&DVector<f64>, &DVector<f64>),
    (xs, f_ref): (f64, f64),
    tolerance: f64,
) -> Option<(Evaluation, usize, usize)> {
    let dim = candidate.len() - 1;
    let mut refreshes = 0;
    let mut previous = f64::INFINITY;
    for it in 1..=CHORD_ITERATIONS {
        let s = candidate.rows(0, dim) * xs;
        let f = candidate[dim] * f_ref;
        let refresh = factored.is_none();
        if refresh && refreshes == CHORD_REFRESHES {
            return None;
        }
        let want = Want {
            jacobian: refresh,
            frequency: refresh,
            samples: true,
            linear: false,
        };
        let mut e = problem.evaluate(&s, f, want).ok()?;
        if refresh {
            refreshes += 1;
            let mut a = DMatrix::zeros(dim + 1, dim + 1);
            a.view_mut((0, 0), (dim, dim))
                .copy_from(e.jacobian.as_ref()?);
            a.view_mut((0, dim), (dim, 1))
                .copy_from(&(e.d_frequency.take()? * (f_ref / xs)));
            a.set_row(dim, &tangent.transpose());
            e.jacobian = None;
            *factored = Some(Factorised::new(a, true));
        }
        let mut g = DVector::zeros(dim + 1);
        g.rows_mut(0, dim).copy_from(&(&e.residual / xs));
        g[dim] = tangent.dot(&(&*candidate - predicted));
        let delta = factored.as_ref()?.solve(&(-g))?;
        let size = delta.amax();
        if !size.is_finite() {
            *factored = None;
            return None;
        }
        if size <= tolerance.max(1e-13) * 10.0 {
            return Some((e, it, refreshes));
        }
        if size > CHORD_CONTRACTION * previous {
            *factored = None;
        }
        previous = size;
        *candidate += &delta;
    }
    None
}

/// A branch point without its multipliers (computed for the whole branch at the end).
fn make_point<M: Drivetrain>(
    problem: &Problem<M>,
    f: f64,
    e: &Evaluation,
    iterations: usize,
    fold: bool,
) -> BranchPoint {
    BranchPoint {
        speed: problem.speed(f),
        solution: problem.solution(f, e, iterations),
        multipliers: None,
        shooting_check: None,
        orbit_error: None,
        periodicity_defect: None,
        unresolved: false,
        fold,
    }
}

/// A point's multipliers, its shooting check, the HB orbit's estimated error and its
/// periodicity defect (all None when the period map fails).
#[derive(Default)]
struct PointStability {
    multipliers: Option<Vec<Complex<f64>>>,
    check: Option<ShootingCheck>,
    orbit_error: Option<f64>,
    defect: Option<f64>,
}

impl PointStability {
    /// Stores the result in `point`; the multipliers and the check only `with_multipliers`.
    fn store(self, point: &mut BranchPoint, with_multipliers: bool) {
        if with_multipliers {
            point.multipliers = self.multipliers;
            point.shooting_check = self.check;
        }
        point.orbit_error = self.orbit_error;
        point.periodicity_defect = self.defect;
    }
}

/// Floquet multipliers of an orbit of `model` (at the orbit's speed) over `period` seconds from
/// its state at `t = 0`: the shooting monodromy with saltation at contact changes
/// ([`PeriodMap`]); empty when the period map fails. When their spectral radius is within
/// `margin` of 1, Newton shooting from the HB state finds the periodic orbit and its
/// multipliers replace the HB ones (kept in the [`ShootingCheck`]).
fn multipliers<M: Drivetrain>(
    model: M,
    settings: &SolverSettings,
    period: f64,
    solution: &HbSolution,
    margin: f64,
) -> PointStability {
    let Ok(mut map) = PeriodMap::new(model, settings, period) else {
        return PointStability::default();
    };
    let y = solution.state_at(0.0);
    let Ok((py, monodromy)) = map.eval(&y) else {
        return PointStability::default();
    };
    let Ok(hb) = crate::analysis::multipliers(&monodromy) else {
        return PointStability::default();
    };
    let radius = |m: &[Complex<f64>]| m.iter().map(|c| c.norm()).fold(0.0, f64::max);
    let hb_radius = radius(&hb);
    let scale = state_scale(map.model(), &y);
    let scaled = |d: &mut dyn Iterator<Item = f64>| {
        d.zip(&scale)
            .map(|(d, s)| (d / s).abs())
            .fold(0.0, f64::max)
    };
    let defect = Some(scaled(&mut y.iter().zip(&py).map(|(a, b)| b - a)));
    // The Newton step from the HB state, from its map and monodromy (no integration).
    let n = y.len();
    let step = (&monodromy - DMatrix::identity(n, n))
        .lu()
        .solve(&(DVector::from_column_slice(&y) - &py));
    let newton_step = step
        .as_ref()
        .map_or(f64::INFINITY, |s| scaled(&mut s.iter().copied()));
    if !((hb_radius - 1.0).abs() <= margin) {
        return PointStability {
            multipliers: Some(hb),
            check: None,
            orbit_error: Some(newton_step),
            defect,
        };
    }
    let options = ShootingOptions {
        periods: solution.subharmonic,
        warmup_periods: 0,
        tolerance: SHOOTING_CHECK_TOLERANCE,
        max_iterations: SHOOTING_CHECK_ITERATIONS,
    };
    let start = match &step {
        Some(s) if newton_step.is_finite() => y.iter().zip(s.iter()).map(|(a, d)| a + d).collect(),
        _ => y.clone(),
    };
    let orbit = newton(&mut map, start, &options).ok().map(|orbit| {
        let distance = scaled(&mut y.iter().zip(&orbit.y0).map(|(a, b)| a - b));
        (orbit, distance)
    });
    match orbit {
        Some((orbit, distance)) if distance <= SHOOTING_CHECK_DISTANCE * newton_step => {
            let check = ShootingCheck {
                hb_radius,
                hb_stability: Stability::of(&hb),
                shooting_radius: Some(orbit.spectral_radius()),
                distance,
                newton_step,
                iterations: orbit.residuals.len(),
            };
            PointStability {
                multipliers: Some(orbit.multipliers),
                check: Some(check),
                orbit_error: Some(newton_step),
                defect,
            }
        }
        other => {
            let check = ShootingCheck {
                hb_radius,
                hb_stability: Stability::of(&hb),
                shooting_radius: None,
                distance: other.map_or(f64::NAN, |(_, d)| d),
                newton_step,
                iterations: 0,
            };
            PointStability {
                multipliers: Some(hb),
                check: Some(check),
                orbit_error: Some(newton_step),
                defect,
            }
        }
    }
}

/// The model at `point`'s speed and its HB period (NaN when the speed cannot be set): the
/// arguments of [`multipliers`].
fn at_point<M: Drivetrain>(problem: &Problem<M>, point: &BranchPoint) -> (M, f64) {
    let mut model = problem.model.clone();
    let f = problem.frequency(point.speed);
    let ok = model.set_input_speed(0.0, point.speed).is_ok();
    (model, if ok { 1.0 / f } else { f64::NAN })
}

/// The stability step of a large system's point as the branch goes
/// ([`ContinuationOptions::defect_limit`]); returns whether the branch ends at it.
fn watch_point<M: Drivetrain>(
    problem: &Problem<M>,
    point: &mut BranchPoint,
    options: &ContinuationOptions,
) -> bool {
    let (model, period) = at_point(problem, point);
    let result = multipliers(
        model,
        &problem.settings,
        period,
        &point.solution,
        options.shooting_check_margin,
    );
    result.store(point, options.stability);
    point.unresolved = point
        .periodicity_defect
        .is_some_and(|d| d > options.defect_limit);
    point.unresolved
}

/// The multipliers of every point of a branch. The period maps are independent of each
/// other and dominate the cost of a continuation (each is a shooting integration with
/// sensitivities), so they run on all available cores; each point's result is the same on any
/// number of threads.
fn branch_stability<M: Drivetrain + Send>(
    problem: &Problem<M>,
    points: &mut [BranchPoint],
    margin: f64,
) {
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .clamp(1, points.len().max(1));
    let jobs: Vec<(usize, M, f64, &HbSolution)> = points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let (model, period) = at_point(problem, p);
            (i, model, period, &p.solution)
        })
        .collect();
    let settings = &problem.settings;
    let mut results: Vec<(usize, PointStability)> = Vec::with_capacity(jobs.len());
    let mut queues: Vec<Vec<_>> = (0..threads).map(|_| Vec::new()).collect();
    for (k, job) in jobs.into_iter().enumerate() {
        queues[k % threads].push(job);
    }
    let deadline = crate::simulation::budget::Deadline::current();
    std::thread::scope(|scope| {
        let handles: Vec<_> = queues
            .into_iter()
            .map(|queue| {
                scope.spawn(move || {
                    deadline.run(|| {
                        queue
                            .into_iter()
                            .map(|(i, model, period, solution)| {
                                (i, multipliers(model, settings, period, solution, margin))
                            })
                            .collect::<Vec<_>>()
                    })
                })
            })
            .collect();
        for h in handles {
            results.extend(h.join().expect("stability thread"));
        }
    });
    for (i, result) in results {
        result.store(&mut points[i], true);
    }
}
