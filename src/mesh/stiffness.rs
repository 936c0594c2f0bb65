//! Mesh-stiffness sources `k(p)` (`docs/model.md`, "Mesh stiffness").
//!
//! Piecewise sources (constant, rectangular, trapezoidal, table) are stored as a list of
//! linear pieces over one period of the shifted phase `s = frac(p + phase)`. The model tracks
//! the current piece and freezes it over a segment, so the integrator sees a smooth right-hand
//! side and lands exactly on the piece boundaries (known-time stops, numerics-notes §2.1).

use super::PhaseSeries;

/// One linear piece `k(s) = k_start + slope·(s − start)` on `s ∈ [start, end)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Piece {
    pub start: f64,
    pub end: f64,
    pub k_start: f64,
    /// dk/ds, N/m per mesh cycle.
    pub slope: f64,
}

impl Piece {
    /// Value at shifted phase `s` measured in the same cycle as `start` (may lie slightly
    /// outside the piece: the piece is extrapolated, which is what mode freezing asks for).
    pub fn value(&self, s: f64) -> f64 {
        self.k_start + self.slope * (s - self.start)
    }

    fn integral(&self) -> f64 {
        let w = self.end - self.start;
        w * (self.k_start + 0.5 * self.slope * w)
    }

    fn k_end(&self) -> f64 {
        self.value(self.end)
    }
}

/// A mesh-stiffness source as a periodic function of mesh phase.
#[derive(Debug, Clone, PartialEq)]
pub enum MeshStiffness {
    /// Linear pieces covering `[0, 1)` of the shifted phase in order.
    Piecewise { phase: f64, pieces: Vec<Piece> },
    /// `mean + Σ a_h cos(2πhs) + b_h sin(2πhs)`.
    Fourier {
        phase: f64,
        mean: f64,
        series: PhaseSeries,
    },
}

impl MeshStiffness {
    pub fn constant(value: f64) -> Self {
        MeshStiffness::Piecewise {
            phase: 0.0,
            pieces: vec![Piece {
                start: 0.0,
                end: 1.0,
                k_start: value,
                slope: 0.0,
            }],
        }
    }

    /// Low and high levels of the rectangular wave: `k_low = mean(1 − fε)`, `k_high = k_low + ε·mean`
    /// with `f = c − floor(c)` (so that the mean is `mean`).
    pub fn rectangular_levels(
        mean: f64,
        peak_to_peak_ratio: f64,
        contact_ratio: f64,
    ) -> (f64, f64, f64) {
        let f = contact_ratio - contact_ratio.floor();
        let low = mean * (1.0 - f * peak_to_peak_ratio);
        (f, low, low + peak_to_peak_ratio * mean)
    }

    /// Rectangular wave: `k_low` on `[0, 1−f)`, `k_high` on `[1−f, 1)` (Liu 2007 §2.3: `s = 0`
    /// is where the number of pairs in contact drops).
    pub fn rectangular(mean: f64, peak_to_peak_ratio: f64, contact_ratio: f64, phase: f64) -> Self {
        let (f, low, high) = Self::rectangular_levels(mean, peak_to_peak_ratio, contact_ratio);
        let flat = |start, end, k| Piece {
            start,
            end,
            k_start: k,
            slope: 0.0,
        };
        let pieces = if f == 0.0 || peak_to_peak_ratio == 0.0 {
            vec![flat(0.0, 1.0, mean)]
        } else {
            vec![flat(0.0, 1.0 - f, low), flat(1.0 - f, 1.0, high)]
        };
        MeshStiffness::Piecewise { phase, pieces }
    }

    /// Rectangular wave with linear ramps of width `transition` centred on both switches.
    pub fn trapezoidal(
        mean: f64,
        peak_to_peak_ratio: f64,
        contact_ratio: f64,
        transition: f64,
        phase: f64,
    ) -> Self {
        let (f, low, high) = Self::rectangular_levels(mean, peak_to_peak_ratio, contact_ratio);
        if f == 0.0 || peak_to_peak_ratio == 0.0 {
            return Self::rectangular(mean, peak_to_peak_ratio, contact_ratio, phase);
        }
        let w = transition;
        let down = (low - high) / w;
        let up = (high - low) / w;
        let mid = 0.5 * (low + high);
        let rise = 1.0 - f;
        let candidates = [
            (0.0, 0.5 * w, mid, down),
            (0.5 * w, rise - 0.5 * w, low, 0.0),
            (rise - 0.5 * w, rise + 0.5 * w, low, up),
            (rise + 0.5 * w, 1.0 - 0.5 * w, high, 0.0),
            (1.0 - 0.5 * w, 1.0, high, down),
        ];
        let pieces = candidates
            .iter()
            .filter(|(start, end, _, _)| end > start)
            .map(|&(start, end, k_start, slope)| Piece {
                start,
                end,
                k_start,
                slope,
            })
            .collect();
        MeshStiffness::Piecewise { phase, pieces }
    }

    /// Periodic piecewise-linear interpolation of `(phase_points, values)`; the points must be
    /// strictly increasing in `[0, 1)` (checked by the scene validation).
    pub fn table(phase_points: &[f64], values: &[f64], phase: f64) -> Self {
        let n = phase_points.len();
        let mut pieces = Vec::with_capacity(n + 1);
        let knot = |i: usize| (phase_points[i], values[i]);
        let segment = |(s0, k0): (f64, f64), (s1, k1): (f64, f64)| Piece {
            start: s0,
            end: s1,
            k_start: k0,
            slope: (k1 - k0) / (s1 - s0),
        };
        let (s_first, k_first) = knot(0);
        let (s_last, k_last) = knot(n - 1);
        let wrap = segment((s_last - 1.0, k_last), (s_first, k_first));
        if s_first > 0.0 {
            // The wrap-around interval [s_last − 1, s_first) restricted to [0, s_first).
            pieces.push(Piece {
                start: 0.0,
                end: s_first,
                k_start: wrap.value(0.0),
                slope: wrap.slope,
            });
        }
        for i in 0..n - 1 {
            pieces.push(segment(knot(i), knot(i + 1)));
        }
        pieces.push(segment((s_last, k_last), (s_first + 1.0, k_first)));
        let last = pieces.last_mut().expect("table has a last piece");
        last.end = 1.0;
        MeshStiffness::Piecewise { phase, pieces }
    }

    pub fn fourier(mean: f64, cos: &[f64], sin: &[f64], phase: f64) -> Self {
        MeshStiffness::Fourier {
            phase,
            mean,
            series: PhaseSeries::new(cos, sin),
        }
    }

    /// Hsu's piecewise-constant approximation (Hsu 1974, J. Appl. Mech. 41:1097; Liao et al.
    /// 2025 eqs. 47–52): `cells` equal parts of the shifted phase, each at the exact mean of
    /// the source over the part, so the mean stiffness is kept. The result is piecewise LTI:
    /// the exact propagator then gives the monodromy of the approximated system, which
    /// converges to the smooth one as `cells` grows.
    pub fn cell_averaged(&self, cells: usize) -> Result<MeshStiffness, String> {
        if cells == 0 {
            return Err("cells = 0: at least one part is needed".into());
        }
        let width = 1.0 / cells as f64;
        let pieces = (0..cells)
            .map(|i| {
                let (a, b) = (i as f64 * width, (i + 1) as f64 * width);
                Piece {
                    start: a,
                    end: if i + 1 == cells { 1.0 } else { b },
                    k_start: self.shifted_integral(a, b) / (b - a),
                    slope: 0.0,
                }
            })
            .collect();
        Ok(MeshStiffness::Piecewise {
            phase: self.phase(),
            pieces,
        })
    }

    /// `∫_a^b k ds` over the shifted phase, `0 ≤ a < b ≤ 1` (exact for both kinds).
    fn shifted_integral(&self, a: f64, b: f64) -> f64 {
        match self {
            MeshStiffness::Piecewise { pieces, .. } => pieces
                .iter()
                .map(|p| {
                    let (lo, hi) = (a.max(p.start), b.min(p.end));
                    if hi > lo {
                        (hi - lo) * 0.5 * (p.value(lo) + p.value(hi))
                    } else {
                        0.0
                    }
                })
                .sum(),
            MeshStiffness::Fourier { mean, series, .. } => {
                let mut total = mean * (b - a);
                for (h, &(ah, bh)) in series.coefficients().iter().enumerate() {
                    let w = std::f64::consts::TAU * (h + 1) as f64;
                    total += ah * ((w * b).sin() - (w * a).sin()) / w
                        - bh * ((w * b).cos() - (w * a).cos()) / w;
                }
                total
            }
        }
    }

    /// The phase shift of the source, mesh cycles.
    pub fn phase(&self) -> f64 {
        match self {
            MeshStiffness::Piecewise { phase, .. } | MeshStiffness::Fourier { phase, .. } => *phase,
        }
    }

    /// The pieces of a piecewise source; `None` for a smooth (Fourier) source.
    pub fn pieces(&self) -> Option<&[Piece]> {
        match self {
            MeshStiffness::Piecewise { pieces, .. } => Some(pieces),
            MeshStiffness::Fourier { .. } => None,
        }
    }

    /// True when every piece is constant: the segments are then linear time-invariant and the
    /// exact propagator applies.
    pub fn is_piecewise_constant(&self) -> bool {
        self.pieces()
            .is_some_and(|pieces| pieces.iter().all(|piece| piece.slope == 0.0))
    }

    /// Exact mean over one period.
    pub fn mean(&self) -> f64 {
        match self {
            MeshStiffness::Piecewise { pieces, .. } => pieces.iter().map(Piece::integral).sum(),
            MeshStiffness::Fourier { mean, .. } => *mean,
        }
    }

    /// `k(p)` at mesh phase `p`.
    pub fn value(&self, p: f64) -> f64 {
        match self {
            MeshStiffness::Piecewise { phase, pieces } => {
                let s = crate::mesh::cycle_fraction(p + phase);
                let j = pieces
                    .partition_point(|piece| piece.start <= s)
                    .saturating_sub(1);
                pieces[j].value(s)
            }
            MeshStiffness::Fourier {
                phase,
                mean,
                series,
            } => mean + series.value(p + phase),
        }
    }

    /// The smallest value over a period: exact for piecewise sources, sampled for Fourier
    /// sources (64 points per harmonic, plus the amplitude bound as a shortcut).
    /// An upper bound of the stiffness over the cycle, N/m (the largest knot of a piecewise
    /// source, `mean + Σ|harmonic|` of a Fourier one): the stiffest the mesh gets, which sets
    /// its fastest natural frequency.
    pub fn maximum(&self) -> f64 {
        match self {
            MeshStiffness::Piecewise { pieces, .. } => pieces
                .iter()
                .flat_map(|piece| [piece.k_start, piece.k_end()])
                .fold(0.0, f64::max),
            MeshStiffness::Fourier { mean, series, .. } => mean + series.amplitude_bound(),
        }
    }

    pub fn minimum(&self) -> (f64, f64) {
        match self {
            MeshStiffness::Piecewise { pieces, .. } => pieces
                .iter()
                .flat_map(|piece| [(piece.k_start, piece.start), (piece.k_end(), piece.end)])
                .fold((f64::INFINITY, 0.0), |best, cand| {
                    if cand.0 < best.0 {
                        cand
                    } else {
                        best
                    }
                }),
            MeshStiffness::Fourier { mean, series, .. } => {
                if mean - series.amplitude_bound() > 0.0 {
                    return (mean - series.amplitude_bound(), 0.0);
                }
                let n = 64 * (series.harmonics() + 1);
                (0..n)
                    .map(|i| {
                        let s = i as f64 / n as f64;
                        (mean + series.value(s), s)
                    })
                    .fold((f64::INFINITY, 0.0), |best, cand| {
                        if cand.0 < best.0 {
                            cand
                        } else {
                            best
                        }
                    })
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sampled_mean(k: &MeshStiffness) -> f64 {
        let n = 200_000;
        (0..n)
            .map(|i| k.value((i as f64 + 0.5) / n as f64))
            .sum::<f64>()
            / n as f64
    }

    #[test]
    fn rectangular_has_requested_mean_and_levels() {
        let k = MeshStiffness::rectangular(3e8, 0.35, 1.504, 0.0);
        assert!((k.mean() - 3e8).abs() < 1e-6);
        assert!((sampled_mean(&k) - 3e8).abs() < 3e8 * 1e-5);
        // Just before s = 0 two pairs carry the load; just after, one pair.
        let high = k.value(0.9999);
        let low = k.value(0.0001);
        assert!((high - low - 0.35 * 3e8).abs() < 1e-4);
        assert!(
            (k.value(0.496 + 1e-9) - high).abs() < 1e-4,
            "double contact starts at 1 − f"
        );
    }

    #[test]
    fn trapezoidal_keeps_mean_and_is_continuous() {
        let k = MeshStiffness::trapezoidal(2e8, 0.4, 1.6, 0.1, 0.25);
        assert!((k.mean() - 2e8).abs() < 1e-6);
        assert!((sampled_mean(&k) - 2e8).abs() < 2e8 * 1e-6);
        let pieces = k.pieces().unwrap();
        for pair in pieces.windows(2) {
            assert_eq!(pair[0].end, pair[1].start);
            assert!((pair[0].k_end() - pair[1].k_start).abs() < 1e-6);
        }
        assert!((pieces.last().unwrap().k_end() - pieces[0].k_start).abs() < 1e-6);
    }

    #[test]
    fn table_interpolates_periodically() {
        let k = MeshStiffness::table(&[0.2, 0.5, 0.9], &[1.0, 3.0, 2.0], 0.0);
        assert!((k.value(0.35) - 2.0).abs() < 1e-12);
        // Wrap: from (0.9, 2) to (1.2, 1): at s = 0.05 → 2 − 0.15/0.3.
        assert!((k.value(0.05) - 1.5).abs() < 1e-12);
        assert!((k.value(0.95) - (2.0 - 0.05 / 0.3)).abs() < 1e-12);
        assert!((k.mean() - sampled_mean(&k)).abs() < 1e-8);
        assert_eq!(k.minimum().0, 1.0);
    }

    #[test]
    fn phase_shift_moves_the_wave() {
        let k0 = MeshStiffness::rectangular(1.0, 0.5, 1.5, 0.0);
        let k1 = MeshStiffness::rectangular(1.0, 0.5, 1.5, 0.25);
        for i in 0..40 {
            let p = i as f64 / 40.0 + 0.0123;
            assert_eq!(k1.value(p), k0.value(p + 0.25));
        }
    }
}
