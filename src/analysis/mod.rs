//! Steady-state and stability analysis on top of the model and the propagators.

pub mod band;
pub mod floquet;
pub mod hb;
pub mod linear_period;
pub mod mesh_response;
pub mod multipliers;
pub mod orbit_statistics;
pub mod shooting;
pub mod spectrum;
pub mod sweep;

/// The eigenvalues (Floquet multipliers) of a monodromy matrix, by a real Schur form with an
/// iteration cap (nalgebra's `complex_eigenvalues` iterates without one): a matrix that is not
/// finite, or whose QR iteration does not converge within 100 sweeps per dimension, is refused
/// with a message instead of looping (issue 34).
pub fn multipliers(m: &nalgebra::DMatrix<f64>) -> Result<Vec<nalgebra::Complex<f64>>, String> {
    let n = m.nrows();
    if !m.iter().all(|x| x.is_finite()) {
        return Err(format!("the {n}×{n} monodromy matrix is not finite"));
    }
    let schur = nalgebra::linalg::Schur::try_new(m.clone(), f64::EPSILON, 100 * n.max(1))
        .ok_or_else(|| {
            format!(
                "the eigenvalues of the {n}×{n} monodromy matrix did not converge within {} \
                 iterations",
                100 * n.max(1)
            )
        })?;
    Ok(schur.complex_eigenvalues().iter().copied().collect())
}

/// How a long analysis reports where it stands, for a progress display
/// ([`crate::simulation::Progress`]): the fraction done (NaN: unknown) and its status line,
/// formatted only when it is shown. `&|_, _| {}` reports nothing.
pub type Report<'a> = &'a (dyn Fn(f64, &dyn Fn() -> String) + Sync);

pub use band::{instability_bands, InstabilityBand};
pub use floquet::monodromy;
pub use linear_period::LinearPeriodMap;
pub use multipliers::{multiplier_line, Floquet};
pub use shooting::{period_map, shoot, shoot_reporting, PeriodicOrbit, ShootingOptions, Stability};
pub use sweep::{sweep, Direction, MeshResponse, Periodicity, Sweep, SweepOptions, SweepPoint};
