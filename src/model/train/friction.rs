//! Tooth friction of a Model-1 mesh over the mesh cycle (Liu 2007 Ch. 5, eq. 4.44 with
//! 4.46–4.48 and the corrections of notes §4.3 [R]).
//!
//! Per tooth pair i in drive contact with normal force `N_i = k_i(δ − g_i)` the friction force
//! on the pinion is `f_i = μ sgn(v_i) N_i` along the flanks' common off-line-of-action velocity
//! `ê_s`, equal and opposite on the gear (Coulomb, `v_i ≈ v̄_i`: the sign is +1 before the pitch
//! point, −1 after it, a known function of the mesh phase). Its generalised force is
//! `f_i t(l_i)` ([`super::assembly::FrictionVectors`]), so the equations gain
//! `−Σ_i μ sgn(v_i) k_i t(l_i) dᵀ` in the stiffness: the non-symmetric `L` matrix of (4.44)
//! (moment `L_m` through the arms `l_i`, `D − l_i`, force `L_μ` on the bearings). The sign
//! switch is a knot of the cycle table: the integrators stop on it like on any stiffness knot.

use super::mesh::CycleTable;

/// Friction of one engaged slot on one interval, per metre of the slot's deflection
/// `δ_j = S − e − g_j`: the generalised friction force is `δ_j (w0(r) b0 + w1(r) b1)`,
/// `r = s − interval start` (mesh cycles). `w0` is the friction force on the pinion along `ê_s`
/// per metre of deflection (N/m), `w1` its moment about the pinion's base tangent point
/// (N, the arm-weighted sum). Both are polynomials of degree ≤ 2 in `r`:
///
/// - spur pair (Liu 2007 eq. 4.44): `w0 = μ sgn(v) k(r)`, `w1 = μ sgn(v) k(r) l(r)` with the
///   pair stiffness `k` and the arm `l` affine in `r`;
/// - helical pair (He & Singh 2007 eqs. 7, 10): friction distributed along the contact line,
///   `w0 = μk(Δz_app − Δz_rec)`, `w1 = μk(∫_app x dz − ∫_rec x dz)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SlotFriction {
    pub w0: [f64; 3],
    pub w1: [f64; 3],
}

impl SlotFriction {
    pub fn weights(&self, r: f64) -> (f64, f64) {
        let p = |c: &[f64; 3]| c[0] + r * (c[1] + r * c[2]);
        (p(&self.w0), p(&self.w1))
    }
}

/// The friction laws of every slot on every interval of a Model-1 cycle table, and the
/// reduced friction vectors `b0 = Qᵀ base`, `b1 = Qᵀ per_arm`
/// ([`super::assembly::FrictionVectors`]).
#[derive(Debug, Clone, PartialEq)]
pub struct FrictionTable {
    pub intervals: Vec<Vec<Option<SlotFriction>>>,
    pub b0: Vec<f64>,
    pub b1: Vec<f64>,
    /// Largest |w0| and |w1| over the cycle (for the step-size bound).
    pub bound: (f64, f64),
}

impl FrictionTable {
    /// `weights(ξ)` gives `(w0, w1)` of a pair at window position `ξ` (mesh cycles, pair
    /// contact ratio `c`). It is sampled at three interior points of each interval and fitted
    /// exactly by a quadratic, so it must be a polynomial of degree ≤ 2 on every interval of
    /// `table` (whose knots must include the pitch-point crossings).
    pub fn new(
        table: &CycleTable,
        c: f64,
        weights: impl Fn(f64) -> (f64, f64),
        b0: Vec<f64>,
        b1: Vec<f64>,
    ) -> Self {
        let mut bound: (f64, f64) = (0.0, 0.0);
        let intervals = table
            .intervals
            .iter()
            .map(|iv| {
                let w = iv.end - iv.start;
                iv.laws
                    .iter()
                    .enumerate()
                    .map(|(j, law)| {
                        law.map(|_| {
                            let xi0 = iv.start + c - 1.0 - j as f64;
                            let (a1, b1) = weights(xi0 + 0.25 * w);
                            let (a2, b2) = weights(xi0 + 0.5 * w);
                            let (a3, b3) = weights(xi0 + 0.75 * w);
                            let slot = SlotFriction {
                                w0: quadratic(a1, a2, a3, w),
                                w1: quadratic(b1, b2, b3, w),
                            };
                            for r in [0.0, 0.5 * w, w] {
                                let (x, y) = slot.weights(r);
                                bound = (bound.0.max(x.abs()), bound.1.max(y.abs()));
                            }
                            slot
                        })
                    })
                    .collect()
            })
            .collect();
        FrictionTable {
            intervals,
            b0,
            b1,
            bound,
        }
    }
}

/// Coefficients `[c0, c1, c2]` in `r` of the quadratic through `(w/4, y1), (w/2, y2),
/// (3w/4, y3)`.
fn quadratic(y1: f64, y2: f64, y3: f64, w: f64) -> [f64; 3] {
    if w == 0.0 {
        return [y2, 0.0, 0.0];
    }
    // In u = r/w: q(u) = y2 + (y3 − y1)(u − ½)·2 + (y1 − 2y2 + y3)(u − ½)²·8.
    let d1 = 2.0 * (y3 - y1);
    let d2 = 8.0 * (y1 - 2.0 * y2 + y3);
    let c0 = y2 - 0.5 * d1 + 0.25 * d2;
    let c1 = d1 - d2;
    let c2 = d2;
    [c0, c1 / w, c2 / (w * w)]
}

#[cfg(test)]
mod tests {
    use super::quadratic;

    #[test]
    fn quadratic_fit_is_exact() {
        let f = |r: f64| 3.0 - 2.0 * r + 0.7 * r * r;
        let w = 0.37;
        let c = quadratic(f(0.25 * w), f(0.5 * w), f(0.75 * w), w);
        for r in [0.0, 0.1, w] {
            let q = c[0] + r * (c[1] + r * c[2]);
            assert!((q - f(r)).abs() < 1e-13, "{q} vs {}", f(r));
        }
    }
}
