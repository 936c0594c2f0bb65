//! Periodic steady state by shooting: Newton on the period map `P(y0) = y(kT; y0)` with its
//! exact Jacobian, the monodromy matrix (numerics-notes §3; Nayfeh & Balachandran, *Applied
//! Nonlinear Dynamics*, §7.3). For piecewise-LTI scenes the monodromy is the product of the
//! segment transition matrices and, at each contact change, the saltation matrix
//! ([`ExactPropagator::track_sensitivity`]), so Newton converges quadratically also through
//! contact loss and back-side impacts.

use nalgebra::{Complex, DMatrix, DVector};

use crate::model::GearPair;
use crate::scene::Scene;
use crate::solve::exact::{ExactPropagator, PiecewiseLti};

/// Settings of [`shoot`].
#[derive(Debug, Clone)]
pub struct ShootingOptions {
    /// Orbit period in mesh periods (period-k orbits).
    pub periods: u32,
    /// Mesh periods integrated from the scene's initial state before Newton starts (a guess
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
    Stable,
    /// A real multiplier beyond +1 (fold / saddle-node branch).
    SaddleNode,
    /// A real multiplier beyond −1.
    PeriodDoubling,
    /// A complex pair outside the unit circle.
    NeimarkSacker,
}

impl PeriodicOrbit {
    pub fn spectral_radius(&self) -> f64 {
        self.multipliers
            .iter()
            .map(|m| m.norm())
            .fold(0.0, f64::max)
    }

    pub fn stability(&self) -> Stability {
        let critical = self
            .multipliers
            .iter()
            .copied()
            .max_by(|a, b| a.norm().total_cmp(&b.norm()))
            .expect("at least one multiplier");
        if critical.norm() <= 1.0 {
            Stability::Stable
        } else if critical.im.abs() > 1e-12 * critical.norm() {
            Stability::NeimarkSacker
        } else if critical.re > 0.0 {
            Stability::SaddleNode
        } else {
            Stability::PeriodDoubling
        }
    }
}

/// The period map with its Jacobian, on a pair assembled once.
struct PeriodMap {
    pair: GearPair,
    propagator: ExactPropagator,
    duration: f64,
}

impl PeriodMap {
    fn eval(&mut self, y0: &[f64]) -> Result<(DVector<f64>, DMatrix<f64>), String> {
        self.pair.resynchronise(0.0, y0);
        self.propagator.invalidate();
        self.propagator.set_state(0.0, y0);
        self.propagator.track_sensitivity(true);
        self.propagator
            .advance_to(&mut self.pair, self.duration)
            .map_err(|e| format!("period map: {e}"))?;
        let y = DVector::from_column_slice(self.propagator.y());
        let m = self
            .propagator
            .sensitivity()
            .expect("tracking is on")
            .clone();
        Ok((y, m))
    }
}

/// Finds the period-`k` orbit of a piecewise-LTI scene at its operating point by damped
/// Newton shooting.
pub fn shoot(scene: &Scene, options: &ShootingOptions) -> Result<PeriodicOrbit, String> {
    if options.periods == 0 {
        return Err("periods = 0: an orbit spans at least one mesh period".into());
    }
    if !(options.tolerance > 0.0) {
        return Err(format!(
            "tolerance = {}: must be a number > 0",
            options.tolerance
        ));
    }
    if !(scene.operating.pinion_speed > 0.0) {
        return Err(format!(
            "operating.pinion_speed = {}: a periodic orbit needs a positive speed",
            scene.operating.pinion_speed
        ));
    }
    let mut pair = GearPair::new(scene);
    if !pair.is_piecewise_lti() {
        return Err(
            "mesh.stiffness: shooting with the exact monodromy needs a piecewise-constant \
             stiffness (constant or rectangular)"
                .into(),
        );
    }
    let mesh_period = pair.mesh_period();
    let duration = mesh_period * options.periods as f64;
    let mut guess = pair.initial_state(scene).to_vec();
    let mut propagator = ExactPropagator::new(&pair);
    if options.warmup_periods > 0 {
        propagator.set_state(0.0, &guess);
        let t_warm = mesh_period * options.warmup_periods as f64;
        propagator
            .advance_to(&mut pair, t_warm)
            .map_err(|e| format!("warm-up: {e}"))?;
        guess.copy_from_slice(propagator.y());
    }
    // Residual scale: the static deflection (or the clearance when unloaded) for x, times the
    // fastest frequency for x'.
    let x_scale = pair.static_deflection().abs().max(1e-9).max(guess[0].abs());
    let scale = [x_scale, x_scale * pair.max_frequency()];
    let scaled_norm = |r: &DVector<f64>| {
        r.iter()
            .zip(&scale)
            .map(|(ri, si)| (ri / si).abs())
            .fold(0.0, f64::max)
    };

    let mut map = PeriodMap {
        pair,
        propagator,
        duration,
    };
    let mut y = DVector::from_vec(guess);
    let (mut py, mut m) = map.eval(y.as_slice())?;
    let mut residual = scaled_norm(&(&py - &y));
    let mut residuals = vec![residual];
    loop {
        if residual <= options.tolerance {
            let multipliers = m.complex_eigenvalues().iter().copied().collect();
            return Ok(PeriodicOrbit {
                y0: y.as_slice().to_vec(),
                period: duration,
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
