//! Manufacturing errors of a gear (runout, pitch errors) seen by one mesh as a displacement
//! excitation along its line of action (`docs/errors.md`).
//!
//! Both enter the mesh force `k(S − e(p) − …)` as a part of the static transmission error `e`,
//! the displacement-excitation treatment of gear errors reviewed by Özgüven & Houser (1988,
//! JSV 121(3):383–411) and used for runout and pitch errors by Inalpolat & Kahraman (2009, JSV
//! 323:677–696; 2010, JSV 329:371–393): an eccentric gear adds a once-per-revolution term along
//! the line of action, a pitch error a piecewise-constant term held while the tooth is in
//! mesh. The papers are not in `reference/`: the kinematics below are derived here from the
//! drivetrain's own translation coupling (`docs/errors.md`), not copied. Neither term changes
//! the mesh stiffness (no amplitude modulation of `k`) nor the mesh position (no phase
//! modulation of `k`): documented limitations.
//!
//! - **Runout**: the geometric centre of gear `g` sits at `w_g = A(cos ψ, sin ψ)` from its
//!   rotation axis, `ψ = σ_g θ_g + φ_g` with `θ_g` the nominal rotation since `t = 0` and `σ_g`
//!   the rotation sense. Like a bearing translation (`docs/train.md`, `S_n = … + (w_a − w_b)·ℓ_n`),
//!   it changes mesh `n`'s deflection by `s_g w_g·ℓ_n` (`s_g = +1` for the mesh's pinion, −1
//!   for its gear), so the equivalent STE term is `e = −s_g A cos(σ_g θ_g + φ_g − β_n)`.
//! - **Pitch errors**: `F_i`, the cumulative pitch deviation of tooth `i` along the line of
//!   action, positive where the flank lies behind its nominal position (material missing, like
//!   a gap). Tooth `i` is in mesh over the stiffness cycle `c` (the cycle in which the pair
//!   count drops at its start) with `i = (c − c_0 + k_{g,n}) mod z`, `c_0` the cycle at `t = 0`
//!   and `k_{g,n}` the tooth offset of mesh `n` on the gear; the term is `e = F_i`.

use std::f64::consts::TAU;

/// Runout (eccentricity) of a gear: amplitude `A >= 0`, m, and the direction `φ` of the
/// geometric centre at `t = 0` in the scene frame, rad.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Runout {
    pub amplitude: f64,
    pub phase: f64,
}

/// The manufacturing errors of one gear.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GearErrors {
    pub runout: Option<Runout>,
    /// Cumulative pitch deviation per tooth, m (empty: none).
    pub cumulative_pitch: Vec<f64>,
}

impl GearErrors {
    /// Whether the errors change nothing: no runout amplitude and no pitch deviation. Such a
    /// gear is assembled without an error term, so its results are bit-identical to a gear
    /// without the keys.
    pub fn is_zero(&self) -> bool {
        self.runout.is_none_or(|r| r.amplitude == 0.0)
            && self.cumulative_pitch.iter().all(|&f| f == 0.0)
    }
}

/// One gear's errors as seen by one mesh.
#[derive(Debug, Clone, PartialEq)]
struct Term {
    /// Mesh cycles per revolution of the gear (its tooth count).
    teeth: f64,
    /// `−s_g A`, `σ_g` and `φ_g − β_n` of the runout term (amplitude 0: none).
    runout: (f64, f64, f64),
    /// Cumulative pitch deviations (empty: none) and the tooth offset `k_{g,n} − c_0`.
    pitch: Vec<f64>,
    tooth_offset: i64,
}

/// The errors of both gears of a mesh as a function of its mesh phase (the part of the STE
/// that is periodic over gear revolutions rather than mesh cycles).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MeshErrors {
    terms: Vec<Term>,
    /// Mesh phase at `t = 0` (the origin of the nominal rotations).
    p0: f64,
}

/// How one gear takes part in one mesh ([`MeshErrors::new`]).
#[derive(Debug, Clone, Copy)]
pub struct GearInMesh<'a> {
    pub errors: &'a GearErrors,
    pub teeth: u32,
    /// `+1` for the mesh's pinion (driver), `−1` for its gear.
    pub side: f64,
    /// Nominal rotation sense of the gear (`+1` ccw).
    pub sense: f64,
    /// Direction `β_n` of the mesh's line of action, rad.
    pub line_of_action: f64,
    /// Teeth between this mesh and the gear's reference mesh, `k_{g,n}`.
    pub tooth_offset: i64,
}

impl MeshErrors {
    /// The errors of the gears of a mesh whose phase at `t = 0` is `p0` and whose stiffness
    /// cycles start at integer `p0 + offset`; gears without errors add no term.
    pub fn new(gears: &[GearInMesh], p0: f64, offset: f64) -> MeshErrors {
        let c0 = (p0 + offset).floor() as i64;
        let terms = gears
            .iter()
            .filter(|g| !g.errors.is_zero())
            .map(|g| {
                let runout = match g.errors.runout {
                    Some(r) if r.amplitude != 0.0 => {
                        (-g.side * r.amplitude, g.sense, r.phase - g.line_of_action)
                    }
                    _ => (0.0, 0.0, 0.0),
                };
                let pitch = if g.errors.cumulative_pitch.iter().any(|&f| f != 0.0) {
                    g.errors.cumulative_pitch.clone()
                } else {
                    Vec::new()
                };
                Term {
                    teeth: f64::from(g.teeth),
                    runout,
                    pitch,
                    tooth_offset: g.tooth_offset - c0,
                }
            })
            .collect();
        MeshErrors { terms, p0 }
    }

    /// No error term: the mesh is exactly the error-free mesh.
    pub fn is_empty(&self) -> bool {
        self.terms.is_empty()
    }

    /// Whether `e` steps at the stiffness-cycle boundaries (pitch errors): the integrators
    /// must stop there.
    pub fn has_steps(&self) -> bool {
        self.terms.iter().any(|t| !t.pitch.is_empty())
    }

    /// The error STE `e` and `de/dp` at mesh phase `p` in stiffness cycle `cycle` (integer
    /// valued; the frozen cycle of the integrators, so that a step never leaks into the end
    /// of the interval before it).
    pub fn value_and_slope(&self, p: f64, cycle: f64) -> (f64, f64) {
        let mut e = 0.0;
        let mut slope = 0.0;
        for t in &self.terms {
            let (a, sense, phase) = t.runout;
            if a != 0.0 {
                let w = TAU / t.teeth;
                let psi = sense * w * (p - self.p0) + phase;
                let (s, c) = psi.sin_cos();
                e += a * c;
                slope -= a * s * sense * w;
            }
            if !t.pitch.is_empty() {
                let z = t.pitch.len() as i64;
                let tooth = (cycle as i64 + t.tooth_offset).rem_euclid(z);
                e += t.pitch[tooth as usize];
            }
        }
        (e, slope)
    }

    /// The largest `|d²e/dp²|` (runout curvature), 1/cycle² · m.
    pub fn curvature_bound(&self) -> f64 {
        self.terms
            .iter()
            .map(|t| t.runout.0.abs() * (TAU / t.teeth).powi(2))
            .sum()
    }

    /// The largest `|de/dp|` between pitch steps (runout slope), m per cycle.
    pub fn slope_bound(&self) -> f64 {
        self.terms
            .iter()
            .map(|t| t.runout.0.abs() * TAU / t.teeth)
            .sum()
    }

    /// Revolutions of the gears with errors per mesh cycle (`1/z`), for the response period.
    pub fn revolution_orders(&self) -> Vec<f64> {
        self.terms.iter().map(|t| 1.0 / t.teeth).collect()
    }
}

/// Cumulative pitch deviations from individual ones: `F_i = Σ_{k ≤ i} f_k` (ISO 1328-1: the
/// cumulative deviation is the running sum of the individual single-pitch deviations).
pub fn cumulative_from_individual(individual: &[f64]) -> Vec<f64> {
    let mut sum = 0.0;
    individual
        .iter()
        .map(|&f| {
            sum += f;
            sum
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn one(errors: &GearErrors) -> MeshErrors {
        MeshErrors::new(
            &[GearInMesh {
                errors,
                teeth: 4,
                side: 1.0,
                sense: 1.0,
                line_of_action: 0.0,
                tooth_offset: 0,
            }],
            0.25,
            0.0,
        )
    }

    #[test]
    fn runout_is_the_projection_of_the_rotating_centre() {
        let errors = GearErrors {
            runout: Some(Runout {
                amplitude: 2e-6,
                phase: 0.3,
            }),
            cumulative_pitch: Vec::new(),
        };
        let m = one(&errors);
        // One revolution is 4 mesh cycles: after one cycle the centre turned by π/2.
        let (e, slope) = m.value_and_slope(1.25, 1.0);
        assert!((e - (-2e-6 * (0.3 + TAU / 4.0).cos())).abs() < 1e-20);
        assert!((slope - 2e-6 * (0.3 + TAU / 4.0).sin() * TAU / 4.0).abs() < 1e-20);
        assert!(!m.has_steps());
    }

    #[test]
    fn pitch_errors_follow_the_teeth_and_zero_tables_vanish() {
        let errors = GearErrors {
            runout: None,
            cumulative_pitch: vec![1.0, 2.0, 3.0, 4.0],
        };
        let m = one(&errors);
        assert!(m.has_steps());
        for c in 0..9 {
            let expected = [1.0, 2.0, 3.0, 4.0][c % 4];
            assert_eq!(m.value_and_slope(c as f64 + 0.5, c as f64), (expected, 0.0));
        }
        let zero = GearErrors {
            runout: Some(Runout {
                amplitude: 0.0,
                phase: 1.0,
            }),
            cumulative_pitch: vec![0.0; 4],
        };
        assert!(zero.is_zero());
        assert!(one(&zero).is_empty());
        assert_eq!(
            cumulative_from_individual(&[1.0, -2.0, 1.0]),
            [1.0, -1.0, 0.0]
        );
    }
}
