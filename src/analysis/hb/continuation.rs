//! Pseudo-arclength continuation of the harmonic-balance orbit in the input speed, with fold
//! detection and the Floquet multipliers of every point.

use nalgebra::{Complex, DMatrix, DVector, Dyn, LU};

use super::problem::{Evaluation, Problem, Want};
use super::{HbOptions, HbSolution};
use crate::analysis::shooting::PeriodMap;
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
}

impl ContinuationOptions {
    pub fn new(from: f64, to: f64) -> Self {
        ContinuationOptions {
            from,
            to,
            initial_step: 0.01,
            max_step: 0.05,
            max_points: 2000,
            stability: true,
        }
    }
}

/// One point of a continued branch.
#[derive(Debug, Clone)]
pub struct BranchPoint {
    pub solution: HbSolution,
    /// Input speed, rad/s.
    pub speed: f64,
    /// Floquet multipliers (None when not computed): eigenvalues of the monodromy (with
    /// saltation) from the HB state at `t = 0`, accurate to the HB truncation error.
    pub multipliers: Option<Vec<Complex<f64>>>,
    /// Whether the step to this point passed a fold (turning point in speed).
    pub fold: bool,
}

impl BranchPoint {
    /// Largest |μ| (None when the multipliers were not computed).
    pub fn spectral_radius(&self) -> Option<f64> {
        self.multipliers
            .as_ref()
            .map(|m| m.iter().map(|c| c.norm()).fold(0.0, f64::max))
    }

    /// Stable when every multiplier lies inside the unit circle.
    pub fn stable(&self) -> Option<bool> {
        self.spectral_radius().map(|r| r < 1.0)
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
    let dim = problem.meshes.len() * problem.len;

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
    let tangent_of = |a: &LU<f64, Dyn, Dyn>| -> Option<DVector<f64>> {
        let mut rhs = DVector::zeros(dim + 1);
        rhs[dim] = 1.0;
        let t = a.solve(&rhs)?;
        Some(t.normalize())
    };
    let direction = if options.to > options.from { 1.0 } else { -1.0 };
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
    let mut tangent = tangent_of(&a0.lu()).ok_or("continuation: singular start")?;
    if tangent[dim] * direction < 0.0 {
        tangent = -tangent;
    }
    let mut points = vec![make_point(&problem, f_ref, &e0, iterations, false)];
    let mut step = options.initial_step;
    while points.len() < options.max_points {
        let predicted = &w + &tangent * step;
        let mut candidate = predicted.clone();
        let mut iterations = 0;
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
                last = Some((lu, e));
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
        let fold = next[dim] * tangent[dim] < 0.0;
        w = candidate;
        tangent = next;
        let f = w[dim] * f_ref;
        points.push(make_point(&problem, f, &e, iterations, fold));
        let speed = points[points.len() - 1].speed;
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
        if f < f_lo || f > f_hi {
            break;
        }
        step = if iterations <= 3 {
            (step * 1.5).min(options.max_step)
        } else if iterations > 6 {
            step * 0.5
        } else {
            step
        };
    }
    if options.stability {
        report(f64::NAN, &|| {
            format!(
                "hb: Floquet multipliers of {} branch points (shooting)",
                points.len()
            )
        });
        branch_stability(&problem, &mut points);
    }
    Ok(points)
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
        fold,
    }
}

/// Floquet multipliers of an orbit of `model` (at the orbit's speed) over `period` seconds from
/// its state at `t = 0`: the shooting monodromy with saltation at contact changes
/// ([`PeriodMap`]); `None` when the period map fails.
fn multipliers<M: Drivetrain>(
    model: M,
    settings: &SolverSettings,
    period: f64,
    solution: &HbSolution,
) -> Option<Vec<Complex<f64>>> {
    let mut map = PeriodMap::new(model, settings, period).ok()?;
    let (_, monodromy) = map.eval(&solution.state_at(0.0)).ok()?;
    crate::analysis::multipliers(&monodromy).ok()
}

/// The multipliers of every point of a branch. The period maps are independent of each
/// other and dominate the cost of a continuation (each is a shooting integration with
/// sensitivities), so they run on all available cores; each point's result is the same on any
/// number of threads.
fn branch_stability<M: Drivetrain + Send>(problem: &Problem<M>, points: &mut [BranchPoint]) {
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .clamp(1, points.len().max(1));
    let jobs: Vec<(usize, M, f64, &HbSolution)> = points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let mut model = problem.model.clone();
            let f = problem.frequency(p.speed);
            let ok = model.set_input_speed(0.0, p.speed).is_ok();
            (i, model, if ok { 1.0 / f } else { f64::NAN }, &p.solution)
        })
        .collect();
    let settings = &problem.settings;
    let mut results: Vec<(usize, Option<Vec<Complex<f64>>>)> = Vec::with_capacity(jobs.len());
    let mut queues: Vec<Vec<_>> = (0..threads).map(|_| Vec::new()).collect();
    for (k, job) in jobs.into_iter().enumerate() {
        queues[k % threads].push(job);
    }
    std::thread::scope(|scope| {
        let handles: Vec<_> = queues
            .into_iter()
            .map(|queue| {
                scope.spawn(move || {
                    queue
                        .into_iter()
                        .map(|(i, model, period, solution)| {
                            (i, multipliers(model, settings, period, solution))
                        })
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        for h in handles {
            results.extend(h.join().expect("stability thread"));
        }
    });
    for (i, m) in results {
        points[i].multipliers = m;
    }
}
