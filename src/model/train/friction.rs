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
use crate::scene::train::MeshFriction;

/// Friction law of one engaged slot on one interval: sign and arm `l = arm0 + arm1·r`,
/// `r = s − interval start` (mesh cycles).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SlotFriction {
    /// `μ sgn(v)`.
    pub signed_coefficient: f64,
    pub arm0: f64,
    pub arm1: f64,
}

impl SlotFriction {
    pub fn arm(&self, r: f64) -> f64 {
        self.arm0 + self.arm1 * r
    }
}

/// The friction laws of every slot on every interval of a Model-1 cycle table, and the
/// reduced friction vectors `b0 = Qᵀ base`, `b1 = Qᵀ per_arm`.
#[derive(Debug, Clone, PartialEq)]
pub struct FrictionTable {
    pub intervals: Vec<Vec<Option<SlotFriction>>>,
    pub b0: Vec<f64>,
    pub b1: Vec<f64>,
    pub coefficient: f64,
    pub loa_length: f64,
}

impl FrictionTable {
    /// `table` must be built from the pair stiffness split at the pitch point
    /// ([`crate::scene::train::PairStiffness::with_friction_bending`]), so that no interval
    /// straddles it; `c` is the pair's contact ratio.
    pub fn new(
        table: &CycleTable,
        c: f64,
        friction: &MeshFriction,
        b0: Vec<f64>,
        b1: Vec<f64>,
    ) -> Self {
        let intervals = table
            .intervals
            .iter()
            .map(|iv| {
                let mid = 0.5 * (iv.start + iv.end);
                iv.laws
                    .iter()
                    .enumerate()
                    .map(|(j, law)| {
                        law.map(|_| {
                            let offset = c - 1.0 - j as f64;
                            SlotFriction {
                                signed_coefficient: friction.coefficient
                                    * friction.sliding_sign(mid + offset),
                                arm0: friction.pinion_arm(iv.start + offset),
                                arm1: friction.base_pitch,
                            }
                        })
                    })
                    .collect()
            })
            .collect();
        FrictionTable {
            intervals,
            b0,
            b1,
            coefficient: friction.coefficient,
            loa_length: friction.loa_length,
        }
    }
}
