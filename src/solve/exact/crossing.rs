//! Locating the first guard crossing inside one exactly propagated segment.
//!
//! The guards are linear in `z`, so each one is a sum of damped exponentials and sinusoids in
//! τ. They are sampled every `h` (a quarter of the fastest period of the mode, one cached
//! mat-vec `z + D_0 z` per sample); a sign change is bracketed, and so is a dip between two
//! samples (a minimum of the guard, found from its derivative `w·A·z`, that lies below zero:
//! grazing contact), then Brent locates the crossing on the guard's Taylor series
//! ([`GuardSeries`]).

use super::guard_series::GuardSeries;
use super::transition::{mat_vec, ModeTransitions};
use super::PiecewiseLti;
use crate::solve::roots::brent_bracket;
use crate::solve::SolverStats;

/// Buffers of the crossing search, sized once per state dimension (no allocation per
/// segment).
#[derive(Default)]
pub struct Workspace {
    /// Guard rows `w_i`, `guard_count × nz`.
    rows: Vec<f64>,
    /// Slope rows `Aᵀ w_i` (`ġ = w·A z`).
    slope_rows: Vec<f64>,
    z_left: Vec<f64>,
    z_right: Vec<f64>,
    scratch: Vec<f64>,
}

/// The first crossing: `τ*` just past it and the guard.
pub struct Crossing {
    pub tau: f64,
    pub index: usize,
}

/// The cubic Hermite basis `(h00, h10, h01, h11)` at `s = j/16`, `j = 1..=15`.
const HERMITE_BASIS: [[f64; 4]; 15] = {
    let mut basis = [[0.0; 4]; 15];
    let mut j = 1;
    while j < 16 {
        let s = j as f64 / 16.0;
        let (s2, s3) = (s * s, s * s * s);
        basis[j - 1] = [
            2.0 * s3 - 3.0 * s2 + 1.0,
            s3 - 2.0 * s2 + s,
            -2.0 * s3 + 3.0 * s2,
            s3 - s2,
        ];
        j += 1;
    }
    basis
};

/// A bracket `(lo, hi, g(lo), g(hi))` of a crossing inside one sample interval.
type Bracket = (f64, f64, f64, f64);

/// Everything that stays fixed while one segment is searched.
struct Segment<'a> {
    mode: &'a ModeTransitions,
    stats: &'a mut SolverStats,
    scratch: &'a mut [f64],
}

/// The earliest crossing of a guard in `(0, tau]` of the segment from `z` (at time `t`),
/// skipping guards in `excluded` (proved positive on the whole segment). Without a crossing,
/// `z_end` receives the state at `tau` (computed only then: a segment cut short by an event
/// never pays for its end state).
#[allow(clippy::too_many_arguments)]
pub fn first_crossing<S: PiecewiseLti>(
    sys: &S,
    mode: &mut ModeTransitions,
    ws: &mut Workspace,
    stats: &mut SolverStats,
    t: f64,
    z: &[f64],
    z_end: &mut [f64],
    tau: f64,
    excluded: u64,
) -> Option<Crossing> {
    let nz = z.len();
    let m = sys.guard_count();
    ws.rows.resize(m * nz, 0.0);
    ws.slope_rows.resize(m * nz, 0.0);
    ws.z_left.resize(nz, 0.0);
    ws.z_right.resize(nz, 0.0);
    ws.scratch.resize(2 * nz, 0.0);
    for i in 0..m {
        let row = &mut ws.rows[i * nz..(i + 1) * nz];
        sys.guard_row(i, row);
        // (Aᵀ w)_j = Σ_i A_ij w_i: column j of A (column-major) dotted with w.
        for (j, column) in mode.a.as_slice().chunks_exact(nz).enumerate() {
            ws.slope_rows[i * nz + j] = column.iter().zip(row.iter()).map(|(a, w)| a * w).sum();
        }
    }
    let h = mode.sample_step;
    let tol = 4.0 * f64::EPSILON * (t.abs() + tau);
    ws.z_left.copy_from_slice(z);
    let mut k = 0u64;
    loop {
        let left = k as f64 * h;
        let last = left + h >= tau;
        let width = if last { tau - left } else { h };
        if last {
            mode.apply(tau, z, z_end);
            ws.z_right.copy_from_slice(z_end);
        } else {
            mat_vec(mode.sample_increment(), &ws.z_left, &mut ws.z_right);
            for (r, l) in ws.z_right.iter_mut().zip(&ws.z_left) {
                *r += l;
            }
        }
        let mut best: Option<(f64, usize)> = None;
        let mut segment = Segment {
            mode,
            stats,
            scratch: &mut ws.scratch,
        };
        for i in 0..m {
            if i < 64 && excluded & (1 << i) != 0 {
                continue;
            }
            let row = &ws.rows[i * nz..(i + 1) * nz];
            let slope_row = &ws.slope_rows[i * nz..(i + 1) * nz];
            let g_left = dot(row, &ws.z_left);
            let g_right = dot(row, &ws.z_right);
            segment.stats.guard_evals += 2;
            let bracket = if g_left > 0.0 {
                if g_right < 0.0 {
                    Some((0.0, width, g_left, g_right))
                } else {
                    segment.dip(
                        row,
                        slope_row,
                        &ws.z_left,
                        &ws.z_right,
                        width,
                        g_left,
                        g_right,
                    )
                }
            } else {
                // Only right after an event: the state sits on the surface, so the guard is
                // zero up to rounding and its direction decides.
                segment.leave_surface(row, slope_row, &ws.z_left, &ws.z_right, width, g_right)
            };
            if let Some((lo, hi, g_lo, g_hi)) = bracket {
                if hi == 0.0 {
                    // The new mode is invalid from the start (grazing): switch at once.
                    best = Some((0.0, i));
                    break;
                }
                let series = GuardSeries::new(row, &mode.a, &ws.z_left, width, segment.scratch);
                let mut evals = 0u64;
                let (_, after) = brent_bracket(
                    |s| {
                        evals += 1;
                        series.value(s)
                    },
                    lo,
                    hi,
                    g_lo,
                    g_hi,
                    tol,
                );
                segment.stats.guard_evals += evals;
                if best.is_none_or(|(s_best, _)| after < s_best) {
                    best = Some((after, i));
                }
            }
        }
        if let Some((after, index)) = best {
            return Some(Crossing {
                tau: left + after,
                index,
            });
        }
        if last {
            return None;
        }
        std::mem::swap(&mut ws.z_left, &mut ws.z_right);
        k += 1;
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

impl Segment<'_> {
    /// The stationary point of the guard inside a sample interval whose end slopes `d_left`
    /// and `d_right` have opposite signs: `(s, g(s))`.
    fn stationary_point(
        &mut self,
        row: &[f64],
        z_left: &[f64],
        width: f64,
        d_left: f64,
        d_right: f64,
    ) -> (f64, f64) {
        let series = GuardSeries::new(row, &self.mode.a, z_left, width, self.scratch);
        let mut evals = 0u64;
        let (s, _) = brent_bracket(
            |s| {
                evals += 1;
                series.slope(s)
            },
            0.0,
            width,
            d_left,
            d_right,
            1e-13 * width,
        );
        self.stats.guard_evals += evals + 1;
        (s, series.value(s))
    }

    /// A guard that starts on its surface (`g <= 0` by rounding after a snap). If it rises, a
    /// later return below zero inside the interval is bracketed from its maximum; if it does
    /// not rise, the mode is left at once (returned as the bracket `(0, 0, 0, 0)`).
    fn leave_surface(
        &mut self,
        row: &[f64],
        slope_row: &[f64],
        z_left: &[f64],
        z_right: &[f64],
        width: f64,
        g_right: f64,
    ) -> Option<Bracket> {
        let d_left = dot(slope_row, z_left);
        self.stats.guard_evals += 1;
        if d_left <= 0.0 {
            return Some((0.0, 0.0, 0.0, 0.0));
        }
        if g_right > 0.0 {
            return None;
        }
        let d_right = dot(slope_row, z_right);
        self.stats.guard_evals += 1;
        if d_right >= 0.0 {
            return None;
        }
        let (s_max, g_max) = self.stationary_point(row, z_left, width, d_left, d_right);
        if g_max > 0.0 {
            Some((s_max, width, g_max, g_right))
        } else {
            Some((0.0, 0.0, 0.0, 0.0))
        }
    }

    /// A guard that is non-negative at both ends of a sample interval may still dip below zero
    /// in between (grazing). With a quarter-period spacing the guard has at most one interior
    /// minimum; it is located from the derivative `w·A·z` and, if negative, returned as a
    /// bracket of the first crossing.
    #[allow(clippy::too_many_arguments)]
    fn dip(
        &mut self,
        row: &[f64],
        slope_row: &[f64],
        z_left: &[f64],
        z_right: &[f64],
        width: f64,
        g_left: f64,
        g_right: f64,
    ) -> Option<Bracket> {
        let d_left = dot(slope_row, z_left);
        let d_right = dot(slope_row, z_right);
        self.stats.guard_evals += 2;
        if !(d_left < 0.0 && d_right > 0.0) {
            return None;
        }
        // Cubic Hermite estimate of the minimum; only a near-zero estimate is worth the search.
        let hermite_min = HERMITE_BASIS.iter().fold(g_left.min(g_right), |lowest, h| {
            let g = h[0] * g_left + h[1] * width * d_left + h[2] * g_right + h[3] * width * d_right;
            lowest.min(g)
        });
        let scale = g_left.abs() + g_right.abs() + width * (d_left.abs() + d_right.abs());
        if hermite_min > 0.05 * scale {
            return None;
        }
        let (s_min, g_min) = self.stationary_point(row, z_left, width, d_left, d_right);
        (g_min < 0.0).then_some((0.0, s_min, g_left.max(0.0), g_min))
    }
}
