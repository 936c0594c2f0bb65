//! The stiffness of **one tooth pair** over its engagement window, from the gear geometry:
//! what Liu (2007) Model-1 (eq. 2.2, per-pair stiffness `k_{n,p}` and gap `g_{n,p}`) needs in
//! place of the thesis' finite-element pair curves (Fig. 2.2). `docs/stiffness.md`, "Tooth
//! pairs from geometry".
//!
//! A pair in contact at distance `x` from T1 on the line of action has the load-independent
//! compliance of the tooth beams and fillet foundations of both gears (Liao et al. 2025
//! eqs. (1), (2), (4); [`MeshModel::compliance_at`]) plus the Hertz compliance (eq. (3)):
//!
//! `k_pair(ξ) = 1 / (c(x(ξ)) + 1/K_h(W))`, `x(ξ) = x_A + p_b (ξ − e)`,
//!
//! with `W = T/r_b1` the transmitted force. **Load dependence:** the nonlinear Hertz law is
//! evaluated at `W` (the single-pair load), so the pair curve is computed for one torque, at
//! scene load, and a scene at another torque has another curve (tabulated over torque, one
//! curve per torque); within a run the pair is a linear spring, as Liu's Model-1 requires.
//! With `hertz = "linear"` the curve does not depend on the torque.
//!
//! **Extended tooth contact** (Liao et al. 2025 eq. (6), as in [`super::curve`]): the window
//! runs `e` mesh cycles beyond the theoretical path of contact at both ends. There the contact
//! stays at the path end (tip contact; the compliance is the end's) and the pair carries load
//! only when the mesh deflection exceeds the linearised gap `p_b·(distance beyond the end)`,
//! which the pair model adds to the profile-modification gap ([`PairCurve::extension_gap`]).
//! Without ETC, `e = 0`.

use super::MeshModel;

/// Default ETC extension of the pair window beyond each end of the path of contact, mesh
/// cycles. At its end the ETC gap is `p_b e` (75 µm for Liu's Ch. 2 gears), far above any
/// mesh deflection of those scenes (static 7 µm, dynamic peaks ≈ 25 µm); a pair that would
/// need more is not in contact there (the window ends).
pub const ETC_EXTENSION: f64 = 0.01;

/// One tooth pair's stiffness over its window `ξ ∈ [0, c + 2e]`, mesh cycles.
#[derive(Debug, Clone, PartialEq)]
pub struct PairCurve {
    /// The involute contact ratio `c` (the theoretical window length).
    pub contact_ratio: f64,
    /// ETC extension `e` at each end, mesh cycles (0 without ETC).
    pub extension: f64,
    /// Base pitch `p_b`, m: the gap grows by `p_b` per mesh cycle beyond the path ends.
    pub base_pitch: f64,
    /// Knots `ξ_j`, from 0 to `c + 2e`.
    pub points: Vec<f64>,
    /// Pair stiffness at the knots, N/m (linear between them).
    pub values: Vec<f64>,
    /// Position on the line of action (distance from T1, m) of each knot's contact.
    pub positions: Vec<f64>,
    /// Hertz stiffness used, N/m.
    pub hertz: f64,
}

impl PairCurve {
    /// Window length `c + 2e`.
    pub fn window(&self) -> f64 {
        self.contact_ratio + 2.0 * self.extension
    }

    /// The ETC gap (m) and its slope (m per mesh cycle) at `ξ` of the window: `p_b` times the
    /// distance beyond the theoretical path of contact, 0 on it.
    pub fn extension_gap(&self, xi: f64) -> (f64, f64) {
        let (e, c) = (self.extension, self.contact_ratio);
        if xi < e {
            (self.base_pitch * (e - xi), -self.base_pitch)
        } else if xi > e + c {
            (self.base_pitch * (xi - e - c), self.base_pitch)
        } else {
            (0.0, 0.0)
        }
    }
}

impl MeshModel {
    /// The pair curve at pinion torque `torque` (N·m), with `extension` mesh cycles of ETC
    /// (0: none). Knots: `samples` intervals on each of the three zones of the theoretical
    /// window (`[0, c−1]`, `[c−1, 1]`, `[1, c]`, where the mesh changes between one and two
    /// pairs for `1 < c < 2`; for other `c` the window is split in thirds), and the two ETC
    /// ends, where the stiffness is constant.
    pub fn pair_curve(&self, torque: f64, extension: f64) -> Result<PairCurve, String> {
        if !(torque.is_finite() && torque > 0.0) {
            return Err(format!(
                "torque = {torque}: must be a finite number > 0 N·m"
            ));
        }
        if !(extension.is_finite() && (0.0..0.5).contains(&extension)) {
            return Err(format!(
                "extension = {extension}: must lie in [0, 0.5) mesh cycles"
            ));
        }
        let p = &self.pair;
        let c = p.contact_ratio;
        let load = torque / p.pinion.r_base;
        let hertz = self.hertz.stiffness(load);
        let zones = if c > 1.0 && c < 2.0 {
            [0.0, c - 1.0, 1.0, c]
        } else {
            [0.0, c / 3.0, 2.0 * c / 3.0, c]
        };
        let mut xis = Vec::new();
        if extension > 0.0 {
            xis.push(-extension);
        }
        for z in zones.windows(2) {
            for j in 0..self.samples {
                xis.push(z[0] + (z[1] - z[0]) * j as f64 / self.samples as f64);
            }
        }
        xis.push(c);
        if extension > 0.0 {
            xis.push(c + extension);
        }
        let mut points = Vec::with_capacity(xis.len());
        let mut values = Vec::with_capacity(xis.len());
        let mut positions = Vec::with_capacity(xis.len());
        for xi in xis {
            let x = (p.x_start + p.base_pitch * xi).clamp(p.x_start, p.x_end);
            let compliance = self.compliance_at(x).total() + 1.0 / hertz;
            points.push(xi + extension);
            values.push(1.0 / compliance);
            positions.push(x);
        }
        // The last knot is exactly the window end (c + 2e), whatever the rounding of the sum.
        let n = points.len();
        points[n - 1] = c + 2.0 * extension;
        Ok(PairCurve {
            contact_ratio: c,
            extension,
            base_pitch: p.base_pitch,
            points,
            values,
            positions,
            hertz,
        })
    }
}
