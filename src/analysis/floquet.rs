//! Floquet analysis of the mesh-periodic linear system (Meissner/Hill equation).
//!
//! With a linear contact law the gear pair is `y' = A(p) y + f(p)` with `A` periodic in the
//! mesh phase. At constant pinion speed the mesh period `T = 1/f_m` is the period of `A`, and
//! the homogeneous flow over one period, the monodromy matrix `M`, decides stability: the
//! Floquet multipliers are its eigenvalues, the response grows like `|μ_max|^(t/T)`
//! (Nayfeh & Mook, *Nonlinear Oscillations*, §5.2; numerics-notes §2.3). For a
//! piecewise-constant stiffness `M` is the exact product of the segment transition matrices,
//! which the exact propagator forms while it tracks `∂y/∂y0`. For a piecewise-*linear*
//! stiffness (sloped pieces) the closed-form monodromy is [`super::LinearPeriodMap`], whose
//! segments are propagated by the polynomial (Peano–Baker) series of `solve::polynomial`.

use nalgebra::{Complex, DMatrix};

use crate::model::GearPair;
use crate::scene::{ContactLaw, Scene};
use crate::solve::exact::ExactPropagator;

/// Monodromy matrix and Floquet multipliers over one mesh period.
#[derive(Debug, Clone)]
pub struct Floquet {
    /// Mesh period `T`, s.
    pub period: f64,
    /// `M = ∂y(T)/∂y(0)` for `y = [x, x']`.
    pub monodromy: DMatrix<f64>,
    /// Eigenvalues of `M`.
    pub multipliers: Vec<Complex<f64>>,
}

impl Floquet {
    /// Largest `|μ|`; the linear response is asymptotically stable when it is below 1.
    pub fn spectral_radius(&self) -> f64 {
        self.multipliers
            .iter()
            .map(|m| m.norm())
            .fold(0.0, f64::max)
    }
}

/// The exact monodromy of a scene with a linear contact law and a piecewise-constant mesh
/// stiffness, at the scene's (constant) pinion speed, starting at mesh phase of `t = 0`.
pub fn exact_monodromy(scene: &Scene) -> Result<Floquet, String> {
    if scene.mesh.contact != ContactLaw::Linear {
        return Err(format!(
            "mesh.contact = {:?}: Floquet analysis of the mesh-periodic linear system needs \
             contact = \"linear\" (contact loss makes the system non-smooth)",
            scene.mesh.contact
        ));
    }
    if !(scene.operating.pinion_speed > 0.0) {
        return Err(format!(
            "operating.pinion_speed = {}: a mesh period needs a positive speed",
            scene.operating.pinion_speed
        ));
    }
    let mut pair = GearPair::new(scene);
    if !pair.is_piecewise_lti() {
        return Err(
            "mesh.stiffness: the exact monodromy needs a piecewise-constant stiffness \
             (constant or rectangular); for piecewise-linear stiffness (trapezoidal, table, \
             helical) use LinearPeriodMap (`geardyn floquet`)"
                .into(),
        );
    }
    let period = pair.mesh_period();
    let y0 = pair.initial_state(scene);
    let mut propagator = ExactPropagator::new(&pair);
    propagator.set_state(0.0, &y0);
    propagator.track_sensitivity(true);
    propagator
        .advance_to(&mut pair, period)
        .map_err(|e| format!("monodromy: {e}"))?;
    let monodromy = propagator
        .sensitivity()
        .expect("tracking was switched on")
        .clone();
    let multipliers = monodromy.complex_eigenvalues().iter().copied().collect();
    Ok(Floquet {
        period,
        monodromy,
        multipliers,
    })
}
