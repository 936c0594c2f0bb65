//! The mesh-period map of a linear single-mesh scene whose stiffness is piecewise *linear* in
//! the mesh phase, solved in closed form segment by segment (Floquet theory; He & Singh 2007
//! §5, eqs. (26)–(41)).
//!
//! With a linear contact law, constant damping `c` and a constant external force `F` the pair
//! is `m x'' + c x' + k(t) x = F`. On the augmented state `z = [x, x', 1]` each piece of the
//! stiffness gives `z' = (G_0 + G_1 τ) z`, whose transition matrix
//! [`crate::solve::polynomial::transition`] forms exactly (to rounding); the paper does the
//! same with Airy/Bessel functions per segment. The product over one period is the augmented
//! monodromy `Φ_a(T, 0) = [[Φ, g], [0, 1]]`: `Φ` the homogeneous monodromy (its eigenvalues the
//! Floquet multipliers), `g` the response to the load over one period from rest (eqs. 37–41).
//! Then, for `0 ≤ t − nT < T`,
//!
//! ```text
//! z(t) = Φ_a(t − nT, 0) Φ_a(T, 0)^n z(0)     (free and forced response, eqs. 36–41)
//! x_ss(0) = (I − Φ)⁻¹ g                       (periodic steady state)
//! ```

use nalgebra::{DMatrix, DVector};

use super::multipliers::Floquet;
use crate::model::GearPair;
use crate::scene::{ContactLaw, PairScene};
use crate::solve::polynomial;

/// One stiffness piece in time: `k(t) = k_start + slope·(t − start)` on
/// `t ∈ [start, start + duration]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimeSegment {
    /// s from `t = 0`.
    pub start: f64,
    /// s.
    pub duration: f64,
    /// N/m.
    pub k_start: f64,
    /// N/m per s.
    pub slope: f64,
}

/// The closed-form period map of a scene (see the module documentation).
#[derive(Debug, Clone)]
pub struct LinearPeriodMap {
    /// Mesh period `T`, s.
    pub period: f64,
    m_e: f64,
    damping: f64,
    force: f64,
    segments: Vec<TimeSegment>,
    /// `Φ_a(t_j, 0)` at every segment start `t_j` (the last is `Φ_a(T, 0)`).
    cumulative: Vec<DMatrix<f64>>,
}

impl LinearPeriodMap {
    /// Builds the map at the scene's pinion speed, starting at the mesh phase of `t = 0`.
    pub fn new(scene: &PairScene) -> Result<LinearPeriodMap, String> {
        if scene.mesh.contact != ContactLaw::Linear {
            return Err(format!(
                "mesh.contact = {:?}: the closed-form period map needs contact = \"linear\"",
                scene.mesh.contact.file_name()
            ));
        }
        if !scene.mesh.smooth.is_zero() {
            return Err(
                "mesh.cubic / mesh.damping_variation / operating.torque_ripple: the closed-form \
                 period map needs a linear system with constant damping and load"
                    .into(),
            );
        }
        if !scene.mesh.ste.is_zero() {
            return Err(
                "mesh.ste: the closed-form period map has no transmission-error excitation; \
                 remove mesh.ste or use the RK path"
                    .into(),
            );
        }
        if !(scene.operating.pinion_speed > 0.0 && scene.operating.pinion_speed.is_finite()) {
            return Err(format!(
                "operating.pinion_speed = {}: a mesh period needs a positive speed",
                scene.operating.pinion_speed
            ));
        }
        let Some(pieces) = scene.mesh.stiffness.pieces() else {
            return Err(
                "mesh.stiffness: the closed-form period map needs a piecewise-linear stiffness \
                 (not a Fourier series)"
                    .into(),
            );
        };
        let pair = GearPair::new(scene);
        let period = pair.mesh_period();
        // Shifted phase at t = 0, and the pieces in time from there over one period.
        let s0 = crate::mesh::cycle_fraction(pair.mesh_phase(0.0) + scene.mesh.stiffness.phase());
        let first = pieces.partition_point(|p| p.start <= s0).saturating_sub(1);
        let mut segments = Vec::with_capacity(pieces.len() + 1);
        let mut s = s0;
        let mut j = first;
        let mut wrapped = 0.0;
        loop {
            let piece = &pieces[j];
            let end_s = (piece.end + wrapped).min(s0 + 1.0);
            if end_s > s {
                segments.push(TimeSegment {
                    start: (s - s0) * period,
                    duration: (end_s - s) * period,
                    k_start: piece.value(s - wrapped),
                    slope: piece.slope / period,
                });
            }
            s = end_s;
            if s >= s0 + 1.0 {
                break;
            }
            j += 1;
            if j == pieces.len() {
                j = 0;
                wrapped += 1.0;
            }
        }
        let mut map = LinearPeriodMap {
            period,
            m_e: pair.equivalent_mass(),
            damping: pair.damping(),
            force: pair.external_force(),
            segments,
            cumulative: Vec::new(),
        };
        let mut phi = DMatrix::identity(3, 3);
        let mut cumulative = vec![phi.clone()];
        for seg in &map.segments {
            phi = map.segment_transition(seg, seg.duration) * phi;
            cumulative.push(phi.clone());
        }
        map.cumulative = cumulative;
        Ok(map)
    }

    /// `Φ_a` over the first `tau` of segment `seg`.
    fn segment_transition(&self, seg: &TimeSegment, tau: f64) -> DMatrix<f64> {
        let m = self.m_e;
        let g0 = DMatrix::from_row_slice(
            3,
            3,
            &[
                0.0,
                1.0,
                0.0,
                -seg.k_start / m,
                -self.damping / m,
                self.force / m,
                0.0,
                0.0,
                0.0,
            ],
        );
        let mut g1 = DMatrix::zeros(3, 3);
        g1[(1, 0)] = -seg.slope / m;
        polynomial::transition(&[g0, g1], tau)
    }

    /// The augmented monodromy `Φ_a(T, 0)` (3 × 3).
    pub fn augmented_monodromy(&self) -> &DMatrix<f64> {
        self.cumulative.last().expect("at least one segment")
    }

    /// The homogeneous monodromy `Φ(T, 0)` (2 × 2).
    pub fn monodromy(&self) -> DMatrix<f64> {
        self.augmented_monodromy().view((0, 0), (2, 2)).into_owned()
    }

    /// The response over one period to the load from rest, `g` (eqs. 37–41 over one cycle).
    pub fn load_response(&self) -> [f64; 2] {
        let a = self.augmented_monodromy();
        [a[(0, 2)], a[(1, 2)]]
    }

    /// The stiffness pieces over one period in time (the paper's segments, eq. 25).
    pub fn segments(&self) -> &[TimeSegment] {
        &self.segments
    }

    /// Equivalent mass `m_e`, kg.
    pub fn equivalent_mass(&self) -> f64 {
        self.m_e
    }

    /// External force `F_e` on the line of action, N.
    pub fn force(&self) -> f64 {
        self.force
    }

    /// Segment boundaries in time over one period, `0 = t_0 < … < t_m = T`.
    pub fn segment_times(&self) -> Vec<f64> {
        let mut times: Vec<f64> = self.segments.iter().map(|s| s.start).collect();
        times.push(self.period);
        times
    }

    /// `Φ_a(τ, 0)` for `τ ∈ [0, T]`.
    pub fn transition_within(&self, tau: f64) -> DMatrix<f64> {
        let j = self
            .segments
            .partition_point(|s| s.start <= tau)
            .saturating_sub(1);
        let seg = &self.segments[j];
        let local = (tau - seg.start).clamp(0.0, seg.duration);
        if local == 0.0 {
            return self.cumulative[j].clone();
        }
        self.segment_transition(seg, local) * &self.cumulative[j]
    }

    /// The state `[x, x']` at time `t ≥ 0` from `y0` at `t = 0` (free plus forced response).
    pub fn response(&self, y0: [f64; 2], t: f64) -> [f64; 2] {
        let n = (t / self.period).floor().max(0.0);
        let rest = t - n * self.period;
        let mut z = DVector::from_vec(vec![y0[0], y0[1], 1.0]);
        let a = self.augmented_monodromy();
        for _ in 0..n as u64 {
            z = a * z;
        }
        let z = self.transition_within(rest) * z;
        [z[0], z[1]]
    }

    /// The periodic steady state at `t = 0`, `(I − Φ)⁻¹ g`; `None` when `I − Φ` is singular
    /// (a multiplier at 1).
    pub fn periodic_state(&self) -> Option<[f64; 2]> {
        let phi = self.monodromy();
        let g = self.load_response();
        let lhs = DMatrix::identity(2, 2) - phi;
        let x = lhs.lu().solve(&DVector::from_vec(vec![g[0], g[1]]))?;
        Some([x[0], x[1]])
    }

    /// Monodromy and multipliers as a [`Floquet`]; the multipliers by the capped Schur
    /// iteration ([`super::multipliers`]: a monodromy that is not finite is refused, issue 34).
    pub fn floquet(&self) -> Result<Floquet, String> {
        let monodromy = self.monodromy();
        let multipliers = super::multipliers(&monodromy)?;
        Ok(Floquet {
            period: self.period,
            monodromy,
            multipliers,
            method: "closed form (Peano–Baker per stiffness piece)".into(),
        })
    }
}
