//! Contact lines of the tooth pairs on the contact rectangle as functions of the mesh phase
//! (He & Singh 2007 eqs. (11)–(12), Fig. 2), clipped generically instead of through the
//! paper's zone table Z1–Z8 (notes §2.3), and their integrals, eqs. (4)–(5), (9)–(10).
//!
//! Mesh phase `s` (mesh cycles): the top end (`z = +W/2`) of pair `i` sits at
//! `x_i(s) = L_T1A + (s + i) λ` (eq. 11 with `s = Ω_p r_bp t / λ`), so at `s = 0` pair 0 enters
//! contact at A. Along the line `x(z) = x_i − (W/2 − z) tan β_b`.

use super::geometry::HelicalGeometry;

/// The part of one tooth pair's contact line inside the contact rectangle.
///
/// `z_m < z_f` are its ends (the paper's z_m, z_f), `x_m = x(z_m)`, `x_f = x(z_f)`; the line
/// crosses the pitch line `x = L_T1P` at `z_p`, clamped into `[z_m, z_f]` (so `z_p = z_f` when
/// the whole line is in approach, `z_p = z_m` when it is all in recess).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactLine {
    /// Tooth-pair index `i` (pair 0 entered contact last).
    pub pair: usize,
    pub z_m: f64,
    pub z_f: f64,
    pub x_m: f64,
    pub x_f: f64,
    pub z_p: f64,
}

/// Raw integrals of a contact line over `z` (He & Singh eqs. (4)–(5), (9)), the quantities
/// the mesh forces and moments are built from for any stiffness density `k` and friction `μ`.
///
/// "Approach" is the part with `x < L_T1P` (friction on the pinion points one way), "recess"
/// the part with `x > L_T1P`. The moment arms are `x` for the pinion and `x_g − x` for the gear,
/// so e.g. `∫_app (x_g − x) dz = x_g · approach_length − approach_moment`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ContactLineIntegrals {
    /// Δz = z_f − z_m (the paper's Δ̄ = −Δz c1).
    pub length: f64,
    /// z_p − z_m.
    pub approach_length: f64,
    /// z_f − z_p.
    pub recess_length: f64,
    /// ∫_app x dz, pinion friction arm (the paper's (Δ·x)(x_m, x_p) = −this · c1).
    pub approach_moment: f64,
    /// ∫_rec x dz (the paper's (Δ·x)(x_p, x_f) = −this · c1).
    pub recess_moment: f64,
}

impl ContactLineIntegrals {
    /// Sum over several lines.
    pub fn add(&mut self, other: &ContactLineIntegrals) {
        self.length += other.length;
        self.approach_length += other.approach_length;
        self.recess_length += other.recess_length;
        self.approach_moment += other.approach_moment;
        self.recess_moment += other.recess_moment;
    }
}

impl ContactLine {
    /// `x` on this line at height `z`.
    pub fn x_at(&self, z: f64) -> f64 {
        if self.z_f > self.z_m {
            self.x_m + (self.x_f - self.x_m) * (z - self.z_m) / (self.z_f - self.z_m)
        } else {
            self.x_m
        }
    }

    /// The integrals of this line; `x` is linear in `z`, so `∫ x dz` over a piece is the mean
    /// of its end values times its length.
    pub fn integrals(&self) -> ContactLineIntegrals {
        let x_p = self.x_at(self.z_p);
        let approach_length = self.z_p - self.z_m;
        let recess_length = self.z_f - self.z_p;
        ContactLineIntegrals {
            length: self.z_f - self.z_m,
            approach_length,
            recess_length,
            approach_moment: 0.5 * (self.x_m + x_p) * approach_length,
            recess_moment: 0.5 * (x_p + self.x_f) * recess_length,
        }
    }
}

impl HelicalGeometry {
    /// Number of tooth pairs that can share the contact rectangle, `ceil((L_AD + W tan β_b)/λ)`
    /// (3 for the paper's pair, "either 2 or 3 pairs in contact").
    pub fn pairs_tracked(&self) -> usize {
        ((self.contact_length() + self.helix_advance()) / self.base_pitch).ceil() as usize
    }

    /// The contact line of pair `i` at mesh phase `s ∈ [0, 1)`, or `None` when the pair is
    /// out of contact (or touches the rectangle in a single point).
    pub fn contact_line(&self, pair: usize, s: f64) -> Option<ContactLine> {
        let half = 0.5 * self.face_width;
        let top = self.l_t1a + (s + pair as f64) * self.base_pitch;
        let slope = self.base_helix_angle.tan();
        let (z_m, z_f, z_p) = if slope == 0.0 {
            // Spur: the line is parallel to z, in contact over the whole face or not at all.
            if top < self.l_t1a || top >= self.l_t1d {
                return None;
            }
            let z_p = if top < self.l_t1p { half } else { -half };
            (-half, half, z_p)
        } else {
            // x(z) = top − (half − z)·slope ⇒ z(x) = half − (top − x)/slope, increasing in x.
            let z_of = |x: f64| half - (top - x) / slope;
            let z_m = z_of(self.l_t1a).max(-half);
            let z_f = z_of(self.l_t1d).min(half);
            if !(z_f > z_m) {
                return None;
            }
            (z_m, z_f, z_of(self.l_t1p).clamp(z_m, z_f))
        };
        let x_at = |z: f64| top - (half - z) * slope;
        Some(ContactLine {
            pair,
            z_m,
            z_f,
            x_m: x_at(z_m),
            x_f: x_at(z_f),
            z_p,
        })
    }

    /// Contact lines of all pairs in contact at mesh phase `s` (any real; reduced mod 1).
    pub fn pair_lines(&self, s: f64) -> Vec<ContactLine> {
        let s = crate::mesh::cycle_fraction(s);
        (0..self.pairs_tracked())
            .filter_map(|i| self.contact_line(i, s))
            .collect()
    }

    /// Sum of the integrals of all lines in contact at mesh phase `s`.
    pub fn total_integrals(&self, s: f64) -> ContactLineIntegrals {
        let mut total = ContactLineIntegrals::default();
        for line in self.pair_lines(s) {
            total.add(&line.integrals());
        }
        total
    }

    /// The mesh phases in `[0, 1)`, sorted, where any line's end or pitch crossing changes
    /// which edge it is clipped by: a top or bottom end crossing A, P or D (the paper's region
    /// boundaries t_j/T, eq. (25) and Fig. 2b, generically). Between consecutive breakpoints
    /// every integral is a polynomial (of degree ≤ 2) in `s`. Always contains 0.
    pub fn breakpoints(&self) -> Vec<f64> {
        let advance = self.helix_advance();
        let mut points = vec![0.0];
        for landmark in [self.l_t1a, self.l_t1p, self.l_t1d] {
            for end_offset in [0.0, advance] {
                // Top end at landmark + end_offset puts the bottom end (or top end) on it.
                let s = crate::mesh::cycle_fraction(
                    (landmark + end_offset - self.l_t1a) / self.base_pitch,
                );
                points.push(s);
            }
        }
        points.sort_by(f64::total_cmp);
        // Coincident events (e.g. the spur case, where both ends are one) are merged.
        let mut merged: Vec<f64> = Vec::with_capacity(points.len());
        for s in points {
            if s >= 1.0 - 1e-12 {
                continue;
            }
            if merged.last().is_none_or(|&last| s - last > 1e-12) {
                merged.push(s);
            }
        }
        merged
    }
}
