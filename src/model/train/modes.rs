//! Natural frequencies and mode shapes of the mean system (all pairs in contact, mean mesh
//! stiffness): `(K_b + Σ k̄_n d_n d_nᵀ) φ = ω² M φ` (Liu 2007 §2.3, Table 2.2; eq. 2.14).

use nalgebra::DVector;

use super::assembly::{generalized_eigen, Assembly};

/// One mode of the mean system.
#[derive(Debug, Clone)]
pub struct Mode {
    /// Natural frequency, Hz (0 for a rigid-body mode).
    pub frequency: f64,
    /// Shape in physical coordinates ([`Assembly::labels`]), scaled to a largest entry of +1.
    pub shape: DVector<f64>,
    /// A rigid-body mode (free rotation of an ungrounded train).
    pub rigid: bool,
}

/// Relative eigenvalue size below which a mode is rigid.
const RIGID_TOL: f64 = 1e-10;

/// All modes of the mean system, ascending in frequency.
pub fn modes(asm: &Assembly) -> Vec<Mode> {
    let (values, vectors) = generalized_eigen(&asm.mean_stiffness_matrix(), &asm.mass);
    let top = values.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
    values
        .iter()
        .enumerate()
        .map(|(i, &w2)| {
            let rigid = w2.abs() <= RIGID_TOL * top;
            let mut shape = vectors.column(i).clone_owned();
            let k = shape.iamax();
            let scale = shape[k];
            if scale != 0.0 {
                shape /= scale;
            }
            Mode {
                frequency: if rigid {
                    0.0
                } else {
                    w2.max(0.0).sqrt() / std::f64::consts::TAU
                },
                shape,
                rigid,
            }
        })
        .collect()
}
