//! Periodic steady state by shooting: Newton on the period map `P(y0) = y(kT; y0)` with its
//! exact Jacobian, the monodromy matrix (numerics-notes §3; Nayfeh & Balachandran, *Applied
//! Nonlinear Dynamics*, §7.3). For piecewise-LTI scenes the monodromy is the product of the
//! segment transition matrices and, at each contact change, the saltation matrix
//! ([`ExactPropagator::track_sensitivity`]), so Newton converges quadratically also through
//! contact loss and back-side impacts. Other scenes (smooth stiffness, cubic terms) use the
//! variational equations carried along the RK integration ([`Variational`]), with the same
//! saltation matrices.

use nalgebra::{Complex, DMatrix, DVector};

use crate::model::{response_period, Drivetrain, SceneSource};
use crate::scene::{MethodChoice, SolverSettings};
use crate::simulation::Driver;
use crate::solve::exact::ExactPropagator;
use crate::solve::rk::{RkOptions, RkStepper};
use crate::solve::variational::Variational;
use crate::with_drivetrain;

use super::Report;

/// Settings of [`shoot`].
#[derive(Debug, Clone)]
pub struct ShootingOptions {
    /// Orbit period in response periods (period-k orbits): mesh periods of a single mesh, the
    /// least common multiple of the mesh periods of a drivetrain.
    pub periods: u32,
    /// Response periods integrated from the scene's initial state before Newton starts (a guess
    /// inside the basin of the attracting orbit).
    pub warmup_periods: u32,
    /// Convergence: scaled residual `max_i |P(y)_i − y_i| / scale_i` below this.
    pub tolerance: f64,
    pub max_iterations: usize,
}

impl Default for ShootingOptions {
    fn default() -> Self {
        ShootingOptions {
            periods: 1,
            warmup_periods: 20,
            tolerance: 1e-12,
            max_iterations: 30,
        }
    }
}

/// A converged periodic orbit.
#[derive(Debug, Clone)]
pub struct PeriodicOrbit {
    /// State `[x, x']` at `t = 0` (mesh phase `p0`) on the orbit.
    pub y0: Vec<f64>,
    /// Orbit period, s (`periods` mesh periods).
    pub period: f64,
    pub periods: u32,
    /// `∂P/∂y0` on the orbit.
    pub monodromy: DMatrix<f64>,
    pub multipliers: Vec<Complex<f64>>,
    /// Scaled residual before each Newton step and after the last one.
    pub residuals: Vec<f64>,
}

/// How an orbit loses stability, read off the critical multiplier (Seydel, *Practical
/// Bifurcation and Stability Analysis*, §7.4).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stability {
    /// Every multiplier inside the unit circle by more than [`NEUTRAL_TOLERANCE`].
    Stable,
    /// The largest multiplier on the unit circle within [`NEUTRAL_TOLERANCE`] (an undamped
    /// orbit): neither decaying nor growing at the accuracy of the monodromy.
    Neutral,
    /// A real multiplier beyond +1 (fold / saddle-node branch).
    SaddleNode,
    /// A real multiplier beyond −1.
    PeriodDoubling,
    /// A complex pair outside the unit circle.
    NeimarkSacker,
}

/// A largest multiplier with `||μ| − 1| ≤ NEUTRAL_TOLERANCE` is on the unit circle: the
/// verdict is [`Stability::Neutral`]. The tolerance is the accuracy of a computed multiplier
/// on the unit circle: the exact transitions carry rounding only (an undamped orbit's
/// multipliers come out within ~1e-13 of the circle), but a double multiplier (two undamped
/// modes in resonance, the border of a parametric band) splits by `√ε ≈ 1.5e-8` under that
/// rounding, and the RK variational equations carry the scene's `rtol` (1e-10 where scenes
/// use them). Half a decade above `√ε`, and growth or decay at `1e-7` per period takes 10⁷
/// periods to change the amplitude by a factor e, so nothing is lost by calling it neutral.
pub const NEUTRAL_TOLERANCE: f64 = 1e-7;

impl Stability {
    /// The verdict of a set of Floquet multipliers.
    pub fn of(multipliers: &[Complex<f64>]) -> Stability {
        let Some(critical) = multipliers
            .iter()
            .copied()
            .max_by(|a, b| a.norm().total_cmp(&b.norm()))
        else {
            return Stability::Stable;
        };
        let radius = critical.norm();
        if radius < 1.0 - NEUTRAL_TOLERANCE {
            Stability::Stable
        } else if radius <= 1.0 + NEUTRAL_TOLERANCE {
            Stability::Neutral
        } else if critical.im.abs() > 1e-12 * radius {
            Stability::NeimarkSacker
        } else if critical.re > 0.0 {
            Stability::SaddleNode
        } else {
            Stability::PeriodDoubling
        }
    }

    /// The verdict as the reports print it.
    pub fn word(self) -> &'static str {
        match self {
            Stability::Stable => "stable",
            Stability::Neutral => "neutral",
            Stability::SaddleNode => "unstable (saddle-node)",
            Stability::PeriodDoubling => "unstable (period doubling)",
            Stability::NeimarkSacker => "unstable (Neimark–Sacker)",
        }
    }
}

impl PeriodicOrbit {
    pub fn spectral_radius(&self) -> f64 {
        self.multipliers
            .iter()
            .map(|m| m.norm())
            .fold(0.0, f64::max)
    }

    pub fn stability(&self) -> Stability {
        Stability::of(&self.multipliers)
    }
}

/// The period map with its Jacobian, on a model assembled once: the exact propagator's
/// sensitivity for piecewise-LTI scenes, RK variational equations otherwise (both with
/// saltation matrices at contact changes).
pub struct PeriodMap<M: Drivetrain> {
    model: M,
    propagator: MapPropagator,
    /// The map runs from `start` to `start + duration`.
    start: f64,
    duration: f64,
}

enum MapPropagator {
    Exact(Box<ExactPropagator>),
    Rk(RkOptions),
}

impl<M: Drivetrain> PeriodMap<M> {
    /// The map over `duration` seconds from `t = 0` with the model's current inputs.
    pub fn new(model: M, settings: &SolverSettings, duration: f64) -> Result<Self, String> {
        if !(duration > 0.0 && duration.is_finite()) {
            return Err(format!(
                "input speed {} rad/s: a period map needs a positive speed",
                model.input_speed()
            ));
        }
        let propagator = if model.is_piecewise_lti() && settings.method != MethodChoice::Rk {
            MapPropagator::Exact(Box::new(ExactPropagator::new(&model)))
        } else {
            MapPropagator::Rk(RkOptions {
                rtol: settings.rtol,
                atol: settings.atol,
                ..RkOptions::new(settings.rk_method)
            })
        };
        Ok(PeriodMap {
            model,
            propagator,
            start: 0.0,
            duration,
        })
    }

    /// The same map starting at time `start` (a sweep shoots from where its run stands).
    pub fn starting_at(mut self, start: f64) -> Self {
        self.start = start;
        self
    }

    pub fn duration(&self) -> f64 {
        self.duration
    }

    pub fn model(&self) -> &M {
        &self.model
    }

    /// `P(y0)` and `∂P/∂y0`.
    pub fn eval(&mut self, y0: &[f64]) -> Result<(DVector<f64>, DMatrix<f64>), String> {
        let (t0, t1) = (self.start, self.start + self.duration);
        self.model.resynchronise(t0, y0);
        match &mut self.propagator {
            MapPropagator::Exact(p) => {
                p.invalidate();
                p.set_state(t0, y0);
                p.track_sensitivity(true);
                p.advance_to(&mut self.model, t1)
                    .map_err(|e| format!("period map: {e}"))?;
                let y = DVector::from_column_slice(p.y());
                Ok((y, p.sensitivity().expect("tracking is on").clone()))
            }
            MapPropagator::Rk(options) => {
                let mut system = Variational::new(&mut self.model, t0, y0)?;
                let z0 = system.initial_state(y0);
                let mut stepper = RkStepper::new(options.clone(), z0.len())?;
                stepper.set_state(t0, &z0);
                stepper
                    .advance_to(&mut system, t1)
                    .map_err(|e| format!("period map: {e}"))?;
                if let Some(failure) = system.failure.take() {
                    return Err(format!("period map: {failure}"));
                }
                let n = y0.len();
                let z = stepper.y();
                let phi = system.transition(z);
                Ok((
                    DVector::from_column_slice(&z[..n]),
                    DMatrix::from_row_slice(n, n, &phi),
                ))
            }
        }
    }
}

/// The period map over `periods` response periods from `y0` at `t = 0` and its Jacobian
/// (exact monodromy for piecewise-LTI scenes, RK variational equations otherwise; saltation at
/// contact changes), at the scene's operating point.
pub fn period_map(
    scene: &impl SceneSource,
    y0: &[f64],
    periods: u32,
) -> Result<(Vec<f64>, DMatrix<f64>), String> {
    let scene = scene.to_scene();
    with_drivetrain!(scene.simulation()?, sim => {
        let duration = response_period(sim.model())? * periods as f64;
        let mut map = PeriodMap::new(sim.model().clone(), &scene.solver, duration)?;
        let (y, m) = map.eval(y0)?;
        Ok((y.as_slice().to_vec(), m))
    })
}

/// Finds the period-`k` orbit of a scene at its operating point by damped Newton shooting
/// (exact monodromy for piecewise-LTI scenes, RK variational equations otherwise). `k` counts
/// response periods: the mesh period of a single mesh, the least common multiple of the mesh
/// periods of a drivetrain.
pub fn shoot(scene: &impl SceneSource, options: &ShootingOptions) -> Result<PeriodicOrbit, String> {
    shoot_reporting(scene, options, &|_, _| {})
}

/// [`shoot`], reporting the warm-up and each Newton iteration with its residual to `report`.
pub fn shoot_reporting(
    scene: &impl SceneSource,
    options: &ShootingOptions,
    report: Report,
) -> Result<PeriodicOrbit, String> {
    scene
        .to_scene()
        .profiles
        .require_constant("the periodic orbit (shooting)")?;
    if options.periods == 0 {
        return Err("periods = 0: an orbit spans at least one mesh period".into());
    }
    if !(options.tolerance > 0.0) {
        return Err(format!(
            "tolerance = {}: must be a number > 0",
            options.tolerance
        ));
    }
    let scene = scene.to_scene();
    if !(scene.input_speed() > 0.0) {
        let field = match scene.kernel {
            crate::scene::KernelChoice::Pair => "operating.pinion_speed",
            crate::scene::KernelChoice::Drivetrain(_) => "operating.input_speed",
        };
        return Err(format!(
            "{field} = {}: a periodic orbit needs a positive speed",
            scene.input_speed()
        ));
    }
    with_drivetrain!(scene.simulation()?, sim => shoot_from(sim, &scene.solver, options, report))
}

/// [`shoot`] on a running simulation: the warm-up continues from its state.
pub fn shoot_from<M: Drivetrain>(
    mut sim: Driver<M>,
    settings: &SolverSettings,
    options: &ShootingOptions,
    report: Report,
) -> Result<PeriodicOrbit, String> {
    let base = response_period(sim.model())?;
    // After whole response periods every mesh phase is where it was at t = 0, so the state
    // after the warm-up is a guess for the map that starts at t = 0.
    let model = sim.model().clone();
    let t0 = sim.t();
    if options.warmup_periods > 0 {
        report(f64::NAN, &|| {
            format!(
                "shooting: warm-up over {} response periods",
                options.warmup_periods
            )
        });
        sim.advance_to(t0 + base * options.warmup_periods as f64)
            .map_err(|e| format!("warm-up: {e}"))?;
    }
    let mut map = PeriodMap::new(model, settings, base * options.periods as f64)?;
    newton_reporting(&mut map, sim.y().to_vec(), options, report)
}

/// Damped Newton on `P(y) − y = 0` with the scaled residual of [`state_scale`].
pub fn newton<M: Drivetrain>(
    map: &mut PeriodMap<M>,
    guess: Vec<f64>,
    options: &ShootingOptions,
) -> Result<PeriodicOrbit, String> {
    newton_reporting(map, guess, options, &|_, _| {})
}

/// [`newton`], reporting each iteration and its residual to `report`.
pub fn newton_reporting<M: Drivetrain>(
    map: &mut PeriodMap<M>,
    guess: Vec<f64>,
    options: &ShootingOptions,
    report: Report,
) -> Result<PeriodicOrbit, String> {
    let scale = state_scale(map.model(), &guess);
    let scaled_norm = |r: &DVector<f64>| {
        r.iter()
            .zip(&scale)
            .map(|(ri, si)| (ri / si).abs())
            .fold(0.0, f64::max)
    };

    let mut y = DVector::from_vec(guess);
    let (mut py, mut m) = map.eval(y.as_slice())?;
    let mut residual = scaled_norm(&(&py - &y));
    let mut residuals = vec![residual];
    loop {
        report(f64::NAN, &|| {
            format!(
                "shooting: Newton iteration {} of at most {}, scaled residual {residual:.2e} \
                 (converged below {:.0e})",
                residuals.len(),
                options.max_iterations,
                options.tolerance
            )
        });
        if residual <= options.tolerance {
            let multipliers = super::multipliers(&m)?;
            // One more Newton step from the converged iterate, with the map and monodromy
            // already evaluated there (no further integration): Newton converges
            // quadratically, so its error is of the order of the residual squared, and the
            // statistics recorded on the orbit (`analysis::orbit_statistics`, exact to ~1e-12)
            // do not carry the periodicity tolerance (a sweep's 1e-7).
            let n = y.len();
            if let Some(step) = (&m - DMatrix::identity(n, n)).lu().solve(&(&y - &py)) {
                if step.iter().all(|v| v.is_finite()) {
                    y += step;
                }
            }
            return Ok(PeriodicOrbit {
                y0: y.as_slice().to_vec(),
                period: map.duration,
                periods: options.periods,
                monodromy: m,
                multipliers,
                residuals,
            });
        }
        if residuals.len() > options.max_iterations {
            let trail: Vec<String> = residuals.iter().map(|r| format!("{r:.2e}")).collect();
            return Err(format!(
                "shooting did not converge in {} iterations (scaled residuals {})",
                options.max_iterations,
                trail.join(", ")
            ));
        }
        let n = y.len();
        let jacobian = &m - DMatrix::identity(n, n);
        let step = jacobian
            .lu()
            .solve(&(&y - &py))
            .ok_or("shooting: M − I is singular (a multiplier equals 1: fold point)")?;
        // Damped Newton: halve the step until the residual decreases (contact changes make
        // the period map only piecewise smooth).
        let mut lambda = 1.0;
        loop {
            let trial = &y + &step * lambda;
            let (p_trial, m_trial) = map.eval(trial.as_slice())?;
            let r_trial = scaled_norm(&(&p_trial - &trial));
            if r_trial < residual || lambda < 1e-3 {
                y = trial;
                py = p_trial;
                m = m_trial;
                residual = r_trial;
                break;
            }
            lambda *= 0.5;
        }
        residuals.push(residual);
    }
}

/// Residual scale of each state component: the model's displacement scale (or the state's
/// own size when larger) for displacements, times the fastest frequency for velocities.
pub fn state_scale<M: Drivetrain>(model: &M, y: &[f64]) -> Vec<f64> {
    let n = y.len() / 2;
    let x_scale = y[..n]
        .iter()
        .fold(model.displacement_scale(), |a, b| a.max(b.abs()));
    let v_scale = x_scale * model.max_frequency();
    (0..2 * n)
        .map(|i| if i < n { x_scale } else { v_scale })
        .collect()
}
