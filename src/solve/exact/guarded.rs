//! Recurring *guarded* sequences decided whole: a mesh period of a train on the contact-loss
//! law while contact holds, applied as one product of its transitions like a guard-free
//! sequence ([`super::composite`]), once a certificate proves that no guard crosses in it.
//!
//! The model walks its stops ahead of the state, assuming every tooth pair that enters is
//! in contact ([`super::PiecewiseLti::stops_assume_contact`]); the entering pair's contact
//! guard is a guard of the next mode, so proving every guard of every segment positive
//! from the segment's start on (`s = 0` included) also proves each assumption but the last:
//! the stop that closes the walk leads to a mode outside the sequence, so an accepted walk
//! takes that stop again from the propagated state. Where it cannot be proved, the
//! propagator restores the model's stops and takes the segments one by one, as without this
//! path.
//!
//! **The certificate** (`docs/scaling.md`, "Contact holds: guarded sequences"). For a
//! reference start `z_r` the sequence's segments are propagated by their Taylor series on
//! the balanced matrices (`B_k = D_k⁻¹ A_k D_k`, sub-steps of `‖B_k‖₁ w ≤ 2`, as
//! [`super::series_segment`]), and each guard `i` of segment `k` gets a lower bound
//! `m_{k,i} > 0` over the whole segment: `d_0 − |c_i ∘ D_k| · Σ_{j≥1} |u_j|` per sub-step
//! (a polynomial cannot move further than its terms), less the series' tail and rounding.
//! A start `z_0 = z_r + δ` differs in segment `k` by `e^{A_k s} Ψ_k δ` (`Ψ_k` the product of
//! the transitions before segment `k`, formed anyway while the sequence's product is built),
//! and `|w·e^{A_k s} x| = |(D_k w)·e^{B_k s} D_k⁻¹ x| ≤ (|D_k w| e^{|B_k| τ_k})·|D_k⁻¹ x|`
//! for `s ∈ [0, τ_k]` (`|e^{Bs}| ≤ e^{|B|s}` entry by entry). With the *spread rows*
//! `v_{k,i} = (|D_k w_i| e^{|B_k| τ_k}) |D_k⁻¹ Ψ_k|` (a property of the sequence alone, stored
//! with its product) every guard stays positive when `Σ_l W_l |δ_l| < 1` with
//! `W_l = max_{k,i} v_{k,i,l} / m_{k,i}`: one weighted sum of `n_z` terms per sequence, then
//! one mat-vec with the product.
//!
//! Where the check fails (a transient too large for the margins), the sequence is certified
//! afresh from the current start, which costs about what the segments by their series
//! cost, and the product is applied if that succeeds. The margins carry a relative slack of
//! [`SLACK`] of the guard's scale for the rounding of the reference's series and of the
//! products, so the sequence path and the segment-wise path agree to the exact solver's
//! accuracy, not to the last bit.

use nalgebra::DMatrix;

use super::balanced::{sum_terms, MAX_TERMS};
use super::enclosure::{taylor_lower_bound, Point};
use super::series_segment::THETA_MAX;
use super::transition::ModeTransitions;

/// Relative slack on each margin (of the guard's scale `|c ∘ D| · |u_0|`) and on the spreads:
/// the rounding of the reference's series over a sequence of up to
/// [`super::composite::MAX_LENGTH`] segments and of the products `Ψ_k`, far below it.
pub const SLACK: f64 = 1e-10;

/// What decides a guarded sequence from a start near its reference.
pub struct Certificate {
    reference: Vec<f64>,
    weights: Vec<f64>,
}

impl Certificate {
    /// Whether every guard of the sequence provably stays positive from `z`.
    pub fn holds(&self, z: &[f64]) -> bool {
        let sum: f64 = (self.weights.iter().zip(&self.reference).zip(z))
            .map(|((w, r), x)| w * (x - r).abs())
            .sum();
        sum < 1.0
    }

    pub fn heap_bytes(&self) -> usize {
        (self.reference.capacity() + self.weights.capacity()) * 8
    }
}

/// Appends to `out` the spread rows of one segment of `mode` lasting `tau`, one per guard `i`:
/// `v_{k,i} = (|c_i ∘ D| e^{|B|τ}) |D⁻¹ Ψ_k|` (`prefix` is `Ψ_k`, `Ψ_0 = I`), so that
/// `|w_i·e^{A s} Ψ_k δ| ≤ v_{k,i}·|δ|` for `s ∈ [0, τ]` (`|e^{Bs}| ≤ e^{|B|s}` entry by
/// entry). The row `|c_i ∘ D| e^{|B|τ}` is summed term by term (non-negative terms) with
/// the bound of its tail added to every entry. `false` where the series does not settle.
pub fn spread_rows(
    mode: &ModeTransitions,
    tau: f64,
    prefix: &DMatrix<f64>,
    out: &mut Vec<f64>,
    ws: &mut CertifyWork,
) -> bool {
    let balanced = mode.balanced();
    let b = balanced.matrix();
    let n = b.nrows();
    let scale = balanced.scale();
    // ‖xᵀ|B|‖₁ ≤ ‖x‖₁ max_j Σ_l |B_jl|.
    let row_norm = (0..n)
        .map(|j| b.row(j).iter().map(|x| x.abs()).sum::<f64>())
        .fold(0.0, f64::max);
    let phi = row_norm * tau;
    // |D⁻¹ Ψ_k|, column-major.
    ws.spread.clear();
    for l in 0..n {
        let column = prefix.column(l);
        ws.spread
            .extend(column.iter().zip(scale).map(|(p, d)| (p / d).abs()));
    }
    let rows = mode.balanced_guard_rows();
    for row in rows.chunks_exact(n) {
        ws.term.clear();
        ws.term.extend(row.iter().map(|c| c.abs()));
        ws.sum.clear();
        ws.sum.extend_from_slice(&ws.term);
        let mut settled = false;
        for k in 1..=MAX_TERMS {
            ws.next.clear();
            for l in 0..n {
                let column = &b.as_slice()[l * n..(l + 1) * n];
                let v: f64 = column.iter().zip(&ws.term).map(|(x, t)| x.abs() * t).sum();
                ws.next.push(v * tau / k as f64);
            }
            std::mem::swap(&mut ws.term, &mut ws.next);
            for (s, t) in ws.sum.iter_mut().zip(&ws.term) {
                *s += t;
            }
            let last: f64 = ws.term.iter().sum();
            let total: f64 = ws.sum.iter().sum();
            let ratio = phi / (k + 2) as f64;
            if ratio < 1.0 {
                let tail = last * (phi / (k + 1) as f64) / (1.0 - ratio);
                if tail <= 1e-6 * total {
                    for s in ws.sum.iter_mut() {
                        *s = (*s + tail) * (1.0 + SLACK);
                    }
                    settled = true;
                    break;
                }
            }
        }
        if !settled {
            return false;
        }
        for l in 0..n {
            let column = &ws.spread[l * n..(l + 1) * n];
            let v: f64 = column.iter().zip(&ws.sum).map(|(p, s)| p * s).sum();
            out.push(v * (1.0 + SLACK));
        }
    }
    true
}

/// Buffers of a certification, sized once per state dimension.
#[derive(Default)]
pub struct CertifyWork {
    terms: Vec<f64>,
    travel: Vec<f64>,
    state: Vec<f64>,
    margins: Vec<f64>,
    weights: Vec<f64>,
    spread: Vec<f64>,
    term: Vec<f64>,
    next: Vec<f64>,
    sum: Vec<f64>,
}

/// The certificate of the sequence `steps` (each segment's position in `modes` and its
/// duration; spreads `spreads`) from `z0`, or `None` where a guard's margin is not positive
/// (it may cross, or comes too close).
pub fn certify(
    modes: &[ModeTransitions],
    steps: impl IntoIterator<Item = (usize, f64)>,
    spreads: &[f64],
    z0: &[f64],
    ws: &mut CertifyWork,
) -> Option<Certificate> {
    let n = z0.len();
    ws.terms.resize((MAX_TERMS + 1) * n, 0.0);
    ws.travel.resize(n, 0.0);
    ws.state.clear();
    ws.state.extend_from_slice(z0);
    ws.weights.clear();
    ws.weights.resize(n, 0.0);
    // The next segment's spread rows start here.
    let mut spread = 0;
    for (position, tau) in steps {
        let mode = &modes[position];
        let balanced = mode.balanced();
        let (scale, norm) = (balanced.scale(), balanced.norm());
        if !norm.is_finite() {
            return None;
        }
        let rows = mode.balanced_guard_rows();
        let guards = rows.len() / n;
        // Per guard: the least lower bound over the segment.
        ws.margins.clear();
        ws.margins.resize(guards, f64::INFINITY);
        for ((u, &x), &d) in ws.terms[..n].iter_mut().zip(&ws.state).zip(scale) {
            *u = x / d;
        }
        let width_max = if norm > 0.0 {
            THETA_MAX / norm
        } else {
            f64::INFINITY
        };
        let mut left = 0.0;
        loop {
            let last = left + width_max >= tau;
            let w = if last { tau - left } else { width_max };
            let count = balanced.taylor_terms(w, n, &mut ws.terms);
            if count > MAX_TERMS {
                return None;
            }
            ws.travel.fill(0.0);
            for term in ws.terms[n..count * n].chunks_exact(n) {
                for (t, &u) in ws.travel.iter_mut().zip(term) {
                    *t += u.abs();
                }
            }
            let u0 = &ws.terms[..n];
            let first_norm: f64 = u0.iter().map(|x| x.abs()).sum();
            for (i, margin) in ws.margins.iter_mut().enumerate() {
                let row = &rows[i * n..(i + 1) * n];
                let (mut d0, mut reach, mut size, mut largest) = (0.0, 0.0, 0.0, 0.0f64);
                for ((&c, &u), &t) in row.iter().zip(u0).zip(&ws.travel) {
                    d0 += c * u;
                    reach += c.abs() * t;
                    size += c.abs() * u.abs();
                    largest = largest.max(c.abs());
                }
                // The guard's polynomial `p(σ) = Σ d_j σ^j` on `[0, 1]`: it cannot move
                // further than its terms, `d_0 − |c ∘ D| · Σ_{j≥1} |u_j|` (no coefficient
                // beyond `d_0`), or where that is not positive, the better of
                // `d_0 − Σ_{j≥1} |d_j|` and the two-sided Taylor minorant from the ends with
                // `C = Σ j(j−1)|d_j| ≥ |p''|` (as the series segments prove guards free).
                let mut lower = d0 - reach;
                if !(lower > 0.0) {
                    let (mut travel, mut end, mut slope, mut curvature) = (0.0, d0, 0.0, 0.0);
                    let mut d1 = 0.0;
                    for (j, term) in ws.terms[n..count * n].chunks_exact(n).enumerate() {
                        let j = j + 1;
                        let dj: f64 = row.iter().zip(term).map(|(c, u)| c * u).sum();
                        if j == 1 {
                            d1 = dj;
                        }
                        travel += dj.abs();
                        end += dj;
                        slope += j as f64 * dj;
                        curvature += (j * (j - 1)) as f64 * dj.abs();
                    }
                    let start = Point {
                        at: 0.0,
                        g: d0,
                        slope: d1,
                    };
                    let finish = Point {
                        at: 1.0,
                        g: end,
                        slope,
                    };
                    lower = (d0 - travel).max(taylor_lower_bound(start, finish, -curvature));
                }
                // The series' tail (below 2⁻⁵⁴ ‖u_0‖₁ in each component's sum) and rounding.
                let lower = lower - SLACK * (size + reach) - largest * first_norm * 1e-15;
                *margin = margin.min(lower);
            }
            sum_terms(&ws.terms[..count * n], n, 1.0, &mut ws.state);
            if last {
                break;
            }
            ws.terms[..n].copy_from_slice(&ws.state);
            left += w;
        }
        for (x, &d) in ws.state.iter_mut().zip(scale) {
            *x *= d;
        }
        for &margin in &ws.margins {
            if !(margin > 0.0) {
                return None;
            }
            let row = spreads.get(spread..spread + n)?;
            for (w, &v) in ws.weights.iter_mut().zip(row) {
                *w = w.max(v / margin);
            }
            spread += n;
        }
    }
    if spread != spreads.len() || !ws.weights.iter().all(|w| w.is_finite()) {
        return None;
    }
    Some(Certificate {
        reference: z0.to_vec(),
        weights: ws.weights.clone(),
    })
}
