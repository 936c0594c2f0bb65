//! Load sharing among the tooth pairs in contact, with pre-contact gaps (extended tooth
//! contact) and the nonlinear Hertz term (Liao et al. 2025 eq. (5); notes §1.6, recommended
//! implementation steps 3–5).
//!
//! Every candidate pair `i` has a load-independent compliance `c_i` (tooth beams and fillet
//! foundations of both gears, eqs. (1), (2), (4)), the Hertz compliance `1/K_h(F_i)` (eq. (3))
//! and a geometric gap `g_i ≥ 0` (zero on the theoretical path of contact, the linearised
//! distance to it outside). With the Sainsot fillet the cross compliances of eq. (5) vanish,
//! so the pairs are springs in parallel behind their gaps:
//!
//! `δ = (c_i + 1/K_h(F_i)) F_i + g_i` for every pair with `F_i > 0`, `δ ≤ g_i` for the others,
//! `Σ F_i = W` (the transmitted force `T/r_b1`).
//!
//! For frozen Hertz stiffnesses this is solved exactly by "water filling" (pairs close in
//! order of increasing gap); the Hertz stiffnesses are then updated from the new forces and
//! the two steps repeated to a fixed point (the paper's iteration). The Hertz deflection
//! `∝ F^0.9` makes the map a contraction with factor about `0.1 × (Hertz share of the
//! compliance)`, so it converges in a small, bounded number of steps.

use super::hertz::Hertz;

/// One candidate tooth pair.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// Load-independent compliance `c_i`, m/N.
    pub compliance: f64,
    /// Gap to close before the pair carries load, m (≥ 0).
    pub gap: f64,
}

/// The solved load distribution.
#[derive(Debug, Clone, PartialEq)]
pub struct Sharing {
    /// Mesh deflection (loaded transmission error along the line of action), m.
    pub deflection: f64,
    /// Force of each candidate, N (0 for pairs that stay open).
    pub forces: Vec<f64>,
    /// Fixed-point iterations used (1 for the linear Hertz law).
    pub iterations: usize,
}

/// Iteration cap: the contraction factor is below 0.1, so 1e-14 takes about 15 steps; reaching
/// the cap means something is wrong and is reported, never ignored.
pub const MAX_ITERATIONS: usize = 100;
const TOLERANCE: f64 = 1e-14;

/// Solves the load sharing of `load` (N) among `pairs`.
///
/// With `all_active`, every pair is forced to carry load (used inside a contact zone whose
/// pair set is known; a force that comes out negative beyond rounding is an error).
pub fn share(
    pairs: &[Candidate],
    hertz: &Hertz,
    load: f64,
    all_active: bool,
) -> Result<Sharing, String> {
    assert!(!pairs.is_empty(), "load sharing needs a candidate pair");
    let n = pairs.len();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| pairs[a].gap.total_cmp(&pairs[b].gap));
    // Start from every pair carrying the whole load (a stiff Hertz guess).
    let floor = 1e-12 * load;
    let mut k_h = vec![hertz.stiffness(load); n];
    let mut forces = vec![0.0; n];
    let mut deflection = 0.0;
    for iteration in 1..=MAX_ITERATIONS {
        let c: Vec<f64> = pairs
            .iter()
            .zip(&k_h)
            .map(|(p, &k)| p.compliance + 1.0 / k)
            .collect();
        // Water filling over the pairs in order of gap.
        let (mut sum_inv, mut sum_gap) = (0.0, 0.0);
        let mut active = 0;
        let mut delta = 0.0;
        for (j, &i) in order.iter().enumerate() {
            sum_inv += 1.0 / c[i];
            sum_gap += pairs[i].gap / c[i];
            active = j + 1;
            delta = (load + sum_gap) / sum_inv;
            let closes_next = order
                .get(j + 1)
                .is_some_and(|&next| delta > pairs[next].gap);
            if !all_active && !closes_next {
                break;
            }
        }
        let mut new_forces = vec![0.0; n];
        for &i in &order[..active] {
            new_forces[i] = (delta - pairs[i].gap) / c[i];
        }
        let change = new_forces
            .iter()
            .zip(&forces)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        forces = new_forces;
        deflection = delta;
        if !hertz.is_nonlinear() || (iteration > 1 && change <= TOLERANCE * load) {
            // Checked on the converged forces only: early iterates use a guessed Hertz law.
            if all_active {
                if let Some((i, f)) = forces.iter().enumerate().find(|(_, &f)| f < -1e-9 * load) {
                    return Err(format!(
                        "load sharing: pair {i} of a contact zone carries a negative force {f:e} N \
                         (zone bounds inconsistent)"
                    ));
                }
            }
            return Ok(Sharing {
                deflection,
                forces,
                iterations: iteration,
            });
        }
        for (k, &f) in k_h.iter_mut().zip(&forces) {
            *k = hertz.stiffness(f.max(floor));
        }
    }
    Err(format!(
        "load sharing: the Hertz fixed point did not converge in {MAX_ITERATIONS} iterations \
         (load {load} N, last deflection {deflection:e} m)"
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::geometry::spec::HertzLaw;

    fn hertz(law: HertzLaw) -> Hertz {
        Hertz {
            law,
            e: 2.06e11,
            nu: 0.3,
            width: 0.02,
        }
    }

    #[test]
    fn parallel_springs_without_gaps() {
        // Linear law: two springs in parallel, F_i ∝ 1/c_i.
        let h = hertz(HertzLaw::Linear);
        let ch = h.compliance(1.0);
        let pairs = [
            Candidate {
                compliance: 2e-9,
                gap: 0.0,
            },
            Candidate {
                compliance: 3e-9,
                gap: 0.0,
            },
        ];
        let s = share(&pairs, &h, 1000.0, false).unwrap();
        let (c1, c2) = (2e-9 + ch, 3e-9 + ch);
        let k = 1.0 / c1 + 1.0 / c2;
        assert!((s.deflection - 1000.0 / k).abs() < 1e-22);
        assert!((s.forces[0] / s.forces[1] - c2 / c1).abs() < 1e-12);
    }

    #[test]
    fn gap_larger_than_deflection_stays_open() {
        let h = hertz(HertzLaw::Nonlinear);
        let pairs = [
            Candidate {
                compliance: 2e-9,
                gap: 0.0,
            },
            Candidate {
                compliance: 2e-9,
                gap: 1e-3,
            },
        ];
        let s = share(&pairs, &h, 1000.0, false).unwrap();
        assert_eq!(s.forces[1], 0.0);
        // Single pair: δ = c F + F/K_h(F) exactly.
        let want = 2e-9 * 1000.0 + 1000.0 / h.stiffness(1000.0);
        assert!((s.deflection / want - 1.0).abs() < 1e-13);
        assert!(s.iterations <= 20, "{} iterations", s.iterations);
    }

    #[test]
    fn nonlinear_fixed_point_satisfies_every_pair() {
        let h = hertz(HertzLaw::Nonlinear);
        let pairs = [
            Candidate {
                compliance: 2e-9,
                gap: 0.0,
            },
            Candidate {
                compliance: 3e-9,
                gap: 1e-6,
            },
            Candidate {
                compliance: 2.5e-9,
                gap: 0.5e-6,
            },
        ];
        let load = 5000.0;
        let s = share(&pairs, &h, load, false).unwrap();
        let total: f64 = s.forces.iter().sum();
        assert!((total - load).abs() < 1e-9 * load);
        for (p, &f) in pairs.iter().zip(&s.forces) {
            if f > 0.0 {
                let d = p.compliance * f + f / h.stiffness(f) + p.gap;
                assert!((d / s.deflection - 1.0).abs() < 1e-12);
            } else {
                assert!(p.gap >= s.deflection);
            }
        }
    }
}
