//! Transition operators of one LTI mode `z' = A z`, applied to vectors without a matrix
//! exponential per segment.
//!
//! * Segment durations that recur (whole stiffness pieces and output intervals at constant
//!   speed, event times in a periodic steady state) get `Φ(τ) = e^{Aτ}` cached per duration
//!   bin (nalgebra's Padé scaling-and-squaring, Higham 2005): a steady run pays one mat-vec
//!   per segment.
//! * Durations that do not recur (transients, chaotic rattle) are composed from a binary
//!   ladder of `D_j = e^{A h_j} − I`,
//!   `h_j = h·2^{−j}` (and `2^j h` above the sample step `h`), so an arbitrary `τ` costs one
//!   mat-vec per set bit of `τ/h` plus a two-term Taylor remainder. Storing `e^{Ah} − I`
//!   instead of `e^{Ah}` keeps the small levels accurate: the ladder is built from the
//!   smallest level's Taylor series by the squaring `D_{j−1} = D_j (D_j + 2I)`, which has no
//!   cancellation against the identity (Higham 2008, *Functions of Matrices*, §10.6 on
//!   computing `e^A − I`); the relative error grows only by one rounding per level.

use nalgebra::DMatrix;

/// Fraction levels of the ladder below the sample step: the Taylor remainder then acts over
/// less than `h·2⁻²⁰`, where `|λ τ| < π/2 · 2⁻²⁰ ≈ 1.5e-6` and two terms leave ~1e-19.
const FRACTION_LEVELS: usize = 20;
/// Top ladder levels computed by `expm` directly rather than by squaring.
const DIRECT_LEVELS: usize = 6;
/// Recurring durations kept per mode with their own `e^{Aτ}`; replaced round-robin.
const RECURRING_CAPACITY: usize = 16;
/// Durations seen once per mode (candidates for recurring ones).
const SEEN_CAPACITY: usize = 32;

/// `out = m · z` for a column-major `n × n` matrix (the single pair's augmented sizes
/// `3 + 2H` get a fixed-size, unrolled loop).
#[inline]
pub fn mat_vec(m: &[f64], z: &[f64], out: &mut [f64]) {
    match z.len() {
        3 => mat_vec_fixed::<3>(m, z, out),
        5 => mat_vec_fixed::<5>(m, z, out),
        7 => mat_vec_fixed::<7>(m, z, out),
        9 => mat_vec_fixed::<9>(m, z, out),
        n => {
            out.fill(0.0);
            for (column, &zj) in m[..n * n].chunks_exact(n).zip(z) {
                for (o, &mij) in out.iter_mut().zip(column) {
                    *o += mij * zj;
                }
            }
        }
    }
}

#[inline(always)]
fn mat_vec_fixed<const N: usize>(m: &[f64], z: &[f64], out: &mut [f64]) {
    let m = &m[..N * N];
    let z: &[f64; N] = z.try_into().expect("vector of the matrix size");
    let mut acc = [0.0; N];
    for j in 0..N {
        let zj = z[j];
        for i in 0..N {
            acc[i] += m[j * N + i] * zj;
        }
    }
    out[..N].copy_from_slice(&acc);
}

/// `out = (m + δ·p) z` in one pass (a binned transition with its first-order remainder).
#[inline]
fn mat_vec_shifted(m: &[f64], p: &[f64], delta: f64, z: &[f64], out: &mut [f64]) {
    match z.len() {
        3 => mat_vec_shifted_fixed::<3>(m, p, delta, z, out),
        5 => mat_vec_shifted_fixed::<5>(m, p, delta, z, out),
        7 => mat_vec_shifted_fixed::<7>(m, p, delta, z, out),
        9 => mat_vec_shifted_fixed::<9>(m, p, delta, z, out),
        n => {
            out.fill(0.0);
            for j in 0..n {
                for i in 0..n {
                    out[i] += (m[j * n + i] + delta * p[j * n + i]) * z[j];
                }
            }
        }
    }
}

#[inline(always)]
fn mat_vec_shifted_fixed<const N: usize>(
    m: &[f64],
    p: &[f64],
    delta: f64,
    z: &[f64],
    out: &mut [f64],
) {
    let m = &m[..N * N];
    let p = &p[..N * N];
    let z: &[f64; N] = z.try_into().expect("vector of the matrix size");
    let mut acc = [0.0; N];
    for j in 0..N {
        let zj = z[j];
        for i in 0..N {
            acc[i] += (m[j * N + i] + delta * p[j * N + i]) * zj;
        }
    }
    out[..N].copy_from_slice(&acc);
}

/// `z += d · z` (one ladder level), `scratch` of length `n`.
#[inline]
fn apply_increment(d: &[f64], z: &mut [f64], scratch: &mut [f64]) {
    mat_vec(d, z, scratch);
    for (zi, si) in z.iter_mut().zip(scratch.iter()) {
        *zi += si;
    }
}

/// Everything the propagator needs of one mode.
pub struct ModeTransitions {
    /// `A` of the mode.
    pub a: DMatrix<f64>,
    /// Guard sample spacing and ladder base `h`: a quarter of the fastest period of the mode
    /// (so the guard has at most one extremum per sample interval).
    pub sample_step: f64,
    /// `D_j = e^{A h 2^{−j}} − I`, `j = 0..=FRACTION_LEVELS`.
    fractions: Vec<DMatrix<f64>>,
    /// `e^{A h 2^{j}} − I`, `j = 1, 2, …`, grown on demand (long partial segments).
    multiples: Vec<DMatrix<f64>>,
    /// `(centre bits of τ_c, e^{A τ_c}, e^{A τ_c} A)` of recurring segment durations.
    recurring: Vec<(u64, DMatrix<f64>, DMatrix<f64>)>,
    next_recurring_slot: usize,
    /// Duration bins seen once.
    seen: Vec<u64>,
    next_seen_slot: usize,
}

impl ModeTransitions {
    /// Builds the ladder of the mode `a` whose fastest rate is bounded by `rate` (rad/s).
    pub fn new(a: DMatrix<f64>, rate: f64) -> ModeTransitions {
        let n = a.nrows();
        // The system's bound may miss a fast real eigenvalue (heavy damping): the diagonals
        // of A and A² estimate it from the mode itself.
        let a2 = &a * &a;
        let own = (0..n)
            .map(|i| a[(i, i)].abs().max(a2[(i, i)].abs().sqrt()))
            .fold(0.0, f64::max);
        let rate = rate.max(own);
        let sample_step = if rate > 0.0 && rate.is_finite() {
            std::f64::consts::FRAC_PI_2 / rate
        } else {
            // No dynamics at all (A nilpotent and zero rates): any step is exact.
            1.0
        };
        let bottom = sample_step / (1u64 << FRACTION_LEVELS) as f64;
        let mut fractions = vec![expm_minus_identity_small(&a, bottom)];
        for _ in 0..FRACTION_LEVELS {
            let d = fractions.last().expect("ladder has a bottom level");
            fractions.push(square_increment(d));
        }
        fractions.reverse();
        // The top levels carry most of every transition: their error (one squaring adds one
        // rounding, so ~2·FRACTION_LEVELS ε relative at `D_0`) would drift systematically
        // (e.g. energy in an undamped run), so they come from the Padé `expm` directly.
        for (j, d) in fractions.iter_mut().enumerate().take(DIRECT_LEVELS) {
            let step = sample_step / (1u64 << j) as f64;
            *d = expm_balanced(&a, step) - DMatrix::identity(n, n);
        }
        ModeTransitions {
            a,
            sample_step,
            fractions,
            multiples: Vec::new(),
            recurring: Vec::new(),
            next_recurring_slot: 0,
            seen: Vec::new(),
            next_seen_slot: 0,
        }
    }

    /// `D_0 = e^{A h} − I` (one guard sample step).
    pub fn sample_increment(&self) -> &[f64] {
        self.fractions[0].as_slice()
    }

    /// `z ← e^{A·tau} z` by the ladder (any `tau >= 0`). `scratch` holds `2n`.
    pub fn propagate(&mut self, tau: f64, z: &mut [f64], scratch: &mut [f64]) {
        let n = z.len();
        let (tmp, tmp2) = scratch.split_at_mut(n);
        let h = self.sample_step;
        let mut rem = tau;
        // Multiples of h, greedy from the top: `rem − level` is exact (Sterbenz) because
        // `level <= rem < 2·level` at every applied level.
        if rem >= h {
            let mut top = 0;
            while h * 2f64.powi(top + 1) <= rem {
                top += 1;
            }
            while self.multiples.len() < top as usize {
                let step = h * 2f64.powi(self.multiples.len() as i32 + 1);
                let n = self.a.nrows();
                let next = expm_balanced(&self.a, step) - DMatrix::identity(n, n);
                self.multiples.push(next);
            }
            for j in (0..=top).rev() {
                let level = h * 2f64.powi(j);
                if rem >= level {
                    let d = if j == 0 {
                        &self.fractions[0]
                    } else {
                        &self.multiples[j as usize - 1]
                    };
                    apply_increment(d.as_slice(), z, tmp);
                    rem -= level;
                }
            }
        }
        for (j, d) in self.fractions.iter().enumerate().skip(1) {
            let level = h / (1u64 << j) as f64;
            if rem >= level {
                apply_increment(d.as_slice(), z, tmp);
                rem -= level;
            }
        }
        if rem > 0.0 {
            // z += rem·A z + rem²/2·A² z.
            mat_vec(self.a.as_slice(), z, tmp);
            mat_vec(self.a.as_slice(), tmp, tmp2);
            for i in 0..n {
                z[i] += rem * (tmp[i] + 0.5 * rem * tmp2[i]);
            }
        }
    }

    /// `out = e^{A·tau} z`, the transition of one segment.
    ///
    /// Durations recur: whole stiffness pieces and output-grid intervals at constant speed,
    /// and in a periodic steady state also the times to and from contact events. A duration
    /// seen for the second time gets its own `e^{A τ_c}` (nalgebra's `expm`, once), so a
    /// steady run pays one mat-vec per segment and the error per segment is that of one
    /// `expm`. A duration seen once goes through the ladder ([`Self::propagate`], about ten
    /// mat-vecs, each adding a rounding of the same level matrix: ~1e-15 per segment, where a
    /// fresh `expm` would cost a few µs).
    ///
    /// Durations that differ only in their last bits (`t_stop − t` rounds differently every
    /// period) share one bin of relative width 2⁻³²; the remainder `δ = τ − τ_c`
    /// (`|δ| ≤ 2⁻³³ τ`) is applied as `(e^{A τ_c} + δ e^{A τ_c} A) z` in one pass — exact up to
    /// `|Aδ|²/2 ≤ (1.2e-10 |Aτ|)²/2`, below 2e-18 for `|Aτ| ≤ 15`. `scratch` holds `2n`
    /// (ladder).
    pub fn apply(&mut self, tau: f64, z: &[f64], out: &mut [f64], scratch: &mut [f64]) {
        const LOW: u32 = 20;
        let bits = tau.to_bits();
        let centre_bits = bits.wrapping_add(1 << (LOW - 1)) & !((1u64 << LOW) - 1);
        let slot = match self
            .recurring
            .iter()
            .position(|(b, _, _)| *b == centre_bits)
        {
            Some(slot) => slot,
            None if self.seen.contains(&centre_bits) => {
                let phi = expm_balanced(&self.a, f64::from_bits(centre_bits));
                let phi_a = &phi * &self.a;
                let entry = (centre_bits, phi, phi_a);
                if self.recurring.len() < RECURRING_CAPACITY {
                    self.recurring.push(entry);
                    self.recurring.len() - 1
                } else {
                    let slot = self.next_recurring_slot;
                    self.recurring[slot] = entry;
                    self.next_recurring_slot = (slot + 1) % RECURRING_CAPACITY;
                    slot
                }
            }
            None => {
                if self.seen.len() < SEEN_CAPACITY {
                    self.seen.push(centre_bits);
                } else {
                    self.seen[self.next_seen_slot] = centre_bits;
                    self.next_seen_slot = (self.next_seen_slot + 1) % SEEN_CAPACITY;
                }
                out.copy_from_slice(z);
                self.propagate(tau, out, scratch);
                return;
            }
        };
        let delta = tau - f64::from_bits(centre_bits);
        let (_, phi, phi_a) = &self.recurring[slot];
        mat_vec_shifted(phi.as_slice(), phi_a.as_slice(), delta, z, out);
    }
}

/// `e^{A τ}` by nalgebra's Padé scaling-and-squaring applied to the *balanced* matrix
/// `B = D⁻¹ A D` (Parlett & Reinsch 1969, as LAPACK `gebal`; `D` a diagonal of powers of two,
/// so the scaling is exact): `e^{Aτ} = D e^{Bτ} D⁻¹`. The augmented gear states differ by
/// many orders of magnitude (metres, m/s, unit harmonics), so `‖Aτ‖₁` is ~10⁴× the spectral
/// radius; unbalanced, the scaling-and-squaring takes ~14 extra squarings and loses ~10⁻¹⁴
/// relative accuracy — harmless once, but a cached transition reused on a periodic orbit
/// would drift systematically (e.g. energy of an undamped rattle).
pub fn expm_balanced(a: &DMatrix<f64>, tau: f64) -> DMatrix<f64> {
    let n = a.nrows();
    let mut b = a * tau;
    let mut scale = vec![1.0f64; n];
    loop {
        let mut converged = true;
        for i in 0..n {
            let (mut c, mut r) = (0.0f64, 0.0f64);
            for j in 0..n {
                if j != i {
                    c += b[(j, i)].abs();
                    r += b[(i, j)].abs();
                }
            }
            if c == 0.0 || r == 0.0 {
                continue;
            }
            let mut f = 1.0f64;
            let (mut cc, mut rr) = (c, r);
            while cc < rr / 2.0 {
                cc *= 2.0;
                rr /= 2.0;
                f *= 2.0;
            }
            while cc >= rr * 2.0 {
                cc /= 2.0;
                rr *= 2.0;
                f /= 2.0;
            }
            if (cc + rr) < 0.95 * (c + r) {
                converged = false;
                scale[i] *= f;
                // B ← F⁻¹ B F with F = diag(.., f, ..): column i times f, row i over f.
                for j in 0..n {
                    b[(j, i)] *= f;
                    b[(i, j)] /= f;
                }
            }
        }
        if converged {
            break;
        }
    }
    let mut e = b.exp();
    for i in 0..n {
        for j in 0..n {
            e[(i, j)] *= scale[i] / scale[j];
        }
    }
    e
}

/// `e^{Ah} − I` for a tiny step by its Taylor series (converges in a few terms: `|λh|` is
/// about 1.5e-6 at the bottom of the ladder); nalgebra's `expm` minus `I` if it does not
/// settle within 30 terms.
fn expm_minus_identity_small(a: &DMatrix<f64>, h: f64) -> DMatrix<f64> {
    let ah = a * h;
    let mut term = ah.clone();
    let mut sum = ah.clone();
    for k in 2..30 {
        term = &term * &ah / k as f64;
        let settled = term
            .iter()
            .zip(sum.iter())
            .all(|(t, s)| t.abs() <= 1e-18 * s.abs() || *t == 0.0);
        sum += &term;
        if settled {
            return sum;
        }
    }
    let n = a.nrows();
    expm_balanced(a, h) - DMatrix::identity(n, n)
}

/// `e^{2Ah} − I = D (D + 2I)` for `D = e^{Ah} − I`.
fn square_increment(d: &DMatrix<f64>) -> DMatrix<f64> {
    let n = d.nrows();
    let mut d_plus = d.clone();
    for i in 0..n {
        d_plus[(i, i)] += 2.0;
    }
    d * d_plus
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A damped oscillator with harmonic and constant forcing in the augmented form.
    fn forced_oscillator() -> DMatrix<f64> {
        let (k, c, w) = (3.5e8, 2.0e3, 1.8e4);
        #[rustfmt::skip]
        let a = DMatrix::from_row_slice(5, 5, &[
            0.0, 1.0, 0.0, 0.0, 0.0,
            -k, -c, 350.0, -20.0, 2.6e3,
            0.0, 0.0, 0.0, -w, 0.0,
            0.0, 0.0, w, 0.0, 0.0,
            0.0, 0.0, 0.0, 0.0, 0.0,
        ]);
        a
    }

    fn max_rel_diff(x: &[f64], y: &[f64]) -> f64 {
        let scale = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        x.iter()
            .zip(y)
            .map(|(a, b)| (a - b).abs() / scale)
            .fold(0.0, f64::max)
    }

    /// The ladder and the whole-segment bins against nalgebra's `expm` of the full step
    /// (an independent evaluation: Padé scaling-and-squaring of `Aτ` itself).
    #[test]
    fn ladder_matches_expm_for_arbitrary_durations() {
        let a = forced_oscillator();
        let mut modes = ModeTransitions::new(a.clone(), (3.5e8f64).sqrt());
        let z0 = [1e-5, 0.2, 0.6, 0.8, 1.0];
        let mut scratch = [0.0; 10];
        for &tau in &[0.0, 1.3e-9, 3.1e-5, 8.7e-5, 1.75e-4, 3.3e-4, 2.1e-3] {
            let reference = (&a * tau).exp() * nalgebra::DVector::from_column_slice(&z0);
            let mut z = z0;
            modes.propagate(tau, &mut z, &mut scratch);
            let err = max_rel_diff(&z, reference.as_slice());
            assert!(err < 1e-13, "ladder, tau = {tau:e}: {err:e}");
            // First sighting (ladder), then the recurring duration's own exponential.
            for _ in 0..3 {
                let mut out = [0.0; 5];
                modes.apply(tau * (1.0 + 3e-16), &z0, &mut out, &mut scratch);
                let err = max_rel_diff(&out, reference.as_slice());
                assert!(err < 1e-13, "apply, tau = {tau:e}: {err:e}");
            }
        }
    }
}
