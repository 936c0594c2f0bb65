//! Natural frequencies and mode shapes of the mean system (all pairs in contact, mean mesh
//! stiffness): `(K_b + Σ k̄_n d_n d_nᵀ) φ = ω² M φ` (Liu 2007 §2.3, Table 2.2; eq. 2.14).

use nalgebra::{Complex, DMatrix, DVector};

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

/// All modes of the mean system, ascending in frequency. With the rotating carrier frame's
/// terms ([`Assembly::frame`]), the modes of the gyroscopic system ([`gyroscopic_modes`]).
pub fn modes(asm: &Assembly) -> Vec<Mode> {
    if let Some(frame) = &asm.frame {
        return gyroscopic_modes(asm, &frame.gyroscopic);
    }
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

/// The modes of the undamped gyroscopic mean system `M q'' + Ω_c G q' + K q = 0` (Lin &
/// Parker 1999 eq. 1, `K = K_b + K_m − Ω_c² K_Ω`; Liu 2007 eq. 6.10): the roots of
/// `det(λ² M + λ Ω_c G + K) = 0` come in pairs `±λ` (M, K symmetric, G skew), purely
/// imaginary `λ = ±iω` while the system is stable. A mode's `frequency` is `ω/2π` of each root
/// with `Im λ > 0`; a real root pair `±a` (divergence: `K` not positive definite at this
/// speed) is reported once with `frequency` 0 and `rigid` false. The shapes are complex
/// (the frame couples x with y in quadrature); `shape` is the real part of the null vector of
/// `λ² M + λ Ω_c G + K` divided by its largest entry.
pub fn gyroscopic_modes(asm: &Assembly, g: &DMatrix<f64>) -> Vec<Mode> {
    let n = asm.dim();
    let k = asm.mean_stiffness_matrix();
    let m_inv = asm
        .mass
        .clone()
        .try_inverse()
        .expect("mass matrix is positive definite");
    let mut a = DMatrix::zeros(2 * n, 2 * n);
    a.view_mut((0, n), (n, n)).fill_with_identity();
    a.view_mut((n, 0), (n, n)).copy_from(&(-&m_inv * &k));
    a.view_mut((n, n), (n, n)).copy_from(&(-&m_inv * g));
    let scale = a.amax().max(f64::MIN_POSITIVE);
    let mut roots: Vec<Complex<f64>> = a
        .complex_eigenvalues()
        .iter()
        .copied()
        .filter(|l| l.im > 1e-9 * scale.sqrt() || (l.im.abs() <= 1e-9 * scale.sqrt() && l.re > 0.0))
        .collect();
    roots.sort_by(|x, y| x.im.total_cmp(&y.im));
    roots
        .into_iter()
        .map(|l| {
            let mut d: DMatrix<Complex<f64>> = asm.mass.map(|v| Complex::new(v, 0.0)) * (l * l);
            d += g.map(|v| Complex::new(v, 0.0)) * l;
            d += k.map(|v| Complex::new(v, 0.0));
            let svd = d.svd(false, true);
            let v_t = svd.v_t.expect("right singular vectors requested");
            let last = svd
                .singular_values
                .iter()
                .enumerate()
                .min_by(|x, y| x.1.total_cmp(y.1))
                .map(|(i, _)| i)
                .unwrap_or(0);
            let v: Vec<Complex<f64>> = v_t.row(last).iter().map(|c| c.conj()).collect();
            let top = v
                .iter()
                .copied()
                .max_by(|x, y| x.norm().total_cmp(&y.norm()))
                .unwrap_or(Complex::new(1.0, 0.0));
            let shape = DVector::from_iterator(n, v.iter().map(|c| (c / top).re));
            Mode {
                frequency: l.im.max(0.0) / std::f64::consts::TAU,
                shape,
                rigid: false,
            }
        })
        .collect()
}
