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

use super::multipliers::Floquet;
use super::shooting::PeriodMap;
use super::LinearPeriodMap;
use crate::model::{parametric_period, Drivetrain, GearPair, SceneSource};
use crate::scene::{ContactLaw, MethodChoice};
use crate::with_drivetrain;

/// The monodromy of any linear scene (every mesh with `contact = "linear"`, any number of
/// meshes and DOF) over one response period (the least common multiple of the mesh periods)
/// at the scene's constant input speed, from the phases of `t = 0`:
///
/// - a single pair with sloped stiffness pieces: the closed form of [`LinearPeriodMap`]
///   (Peano–Baker series per piece);
/// - piecewise-constant stiffness: the product of the exact segment transitions;
/// - otherwise (smooth or sloped stiffness in a drivetrain): the RK variational equations at
///   the scene's tolerances.
///
/// A scene with contact loss or backlash is refused with the reason and the command to use.
pub fn monodromy(scene: &impl SceneSource) -> Result<Floquet, String> {
    let scene = scene.to_scene();
    scene.profiles.require_constant("the Floquet analysis")?;
    let pair = scene.pair();
    let nonlinear = match &pair {
        Some(s) => (s.mesh.contact != ContactLaw::Linear)
            .then(|| format!("mesh.contact = {:?}", s.mesh.contact.file_name())),
        None => scene
            .meshes
            .iter()
            .enumerate()
            .find(|(_, m)| m.contact != ContactLaw::Linear)
            .map(|(n, m)| {
                format!(
                    "mesh[{n}].contact = {:?} (mesh '{}')",
                    m.contact.file_name(),
                    m.name
                )
            }),
    };
    if let Some(field) = nonlinear {
        return Err(format!(
            "{field}: Floquet analysis of the linear periodic system needs contact = \"linear\" \
             on every mesh (contact loss makes the system non-smooth); use `geardyn periodic`, \
             whose multipliers include the saltation matrices of the contact changes"
        ));
    }
    if !(scene.input_speed() > 0.0) {
        return Err(format!(
            "input speed {} rad/s: a period needs a positive speed",
            scene.input_speed()
        ));
    }
    if let Some(s) = &pair {
        let pair = GearPair::new(s);
        if !pair.is_piecewise_lti()
            && s.mesh.smooth.is_zero()
            && s.mesh.stiffness.pieces().is_some()
        {
            let map = LinearPeriodMap::new(s)?;
            return Ok(Floquet {
                method: "closed form (Peano–Baker per stiffness piece)".into(),
                ..map.floquet()?
            });
        }
    }
    with_drivetrain!(scene.simulation()?, sim => {
        let model = sim.model().clone();
        if !model.is_linear() {
            return Err("the mesh force has cubic terms: Floquet analysis needs a linear system; \
                        use `geardyn periodic`".into());
        }
        // Gear errors force the system but do not enter its homogeneous part: the multipliers
        // are those of the parametric (mesh) period, not of the hunting period.
        let period = parametric_period(&model)?;
        // The exact transitions whenever the segments are LTI, whatever `solver.method` says
        // for time runs: they are the closed form of the monodromy.
        let settings = crate::scene::SolverSettings {
            method: MethodChoice::Auto,
            ..scene.solver.clone()
        };
        let exact = model.is_piecewise_lti();
        // From the scene's initial state, as a run starts (the monodromy of a linear system
        // does not depend on it; the exact propagator's segment partition can).
        let y0 = sim.y().to_vec();
        let mut map = PeriodMap::new(model, &settings, period)?;
        let (_, monodromy) = map.eval(&y0)?;
        let multipliers = super::multipliers(&monodromy)?;
        Ok(Floquet {
            period,
            monodromy,
            multipliers,
            method: if exact {
                "exact segment transitions".into()
            } else {
                format!("RK variational equations (rtol {:e})", scene.solver.rtol)
            },
        })
    })
}
