//! One mesh cycle of a mesh as a table of intervals in the cycle coordinate `s ∈ [0, 1)`,
//! each holding, per tooth-pair *slot*, the pair stiffness and gap as affine functions of `s`.
//!
//! Model-1 (Liu 2007 eq. 2.2): tooth pair stiffness `k_p(ξ)` over its engagement window
//! `ξ ∈ [0, c)` (mesh cycles), replicated every mesh cycle. Slot `j = 0 … P−1`
//! (`P = floor(c) + 1`, the smallest integer greater than c) holds the pair with
//! `ξ_j(s) = s + c − 1 − j`, so that `s = 0` is where the number of pairs in contact drops,
//! the phase reference of the lumped rectangular wave (`docs/model.md`; Liu 2007 §3.2). At the
//! cycle wrap the pair of slot `j` moves to slot `j − 1`.
//!
//! A lumped mesh is one slot with the stiffness pieces of its source and zero gap; Models 2
//! and 3 are one slot whose gap is the loaded STE or the NLTE ([`super::statics`]).

use crate::mesh::Piece;
use crate::scene::train::{GapFunction, PairStiffness};

/// Stiffness `k0 + k1·r` and gap `g0 + g1·r` of one slot, `r = s − start`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SlotLaw {
    pub k0: f64,
    pub k1: f64,
    pub g0: f64,
    pub g1: f64,
}

impl SlotLaw {
    pub fn k(&self, r: f64) -> f64 {
        self.k0 + self.k1 * r
    }
    pub fn g(&self, r: f64) -> f64 {
        self.g0 + self.g1 * r
    }
}

/// An interval `[start, end)` of the cycle with the law of every slot (`None`: the slot's
/// pair is not engaged).
#[derive(Debug, Clone, PartialEq)]
pub struct Interval {
    pub start: f64,
    pub end: f64,
    pub laws: Vec<Option<SlotLaw>>,
}

/// A mesh cycle.
#[derive(Debug, Clone, PartialEq)]
pub struct CycleTable {
    pub slots: usize,
    /// Whether slots move by one at the cycle wrap (tooth pairs); a lumped slot stays.
    pub shift_on_wrap: bool,
    pub intervals: Vec<Interval>,
}

/// Knots closer than this (in mesh cycles) are merged.
const KNOT_TOL: f64 = 1e-12;

impl CycleTable {
    /// One slot with the pieces of a piecewise stiffness source and no gap.
    pub fn lumped(pieces: &[Piece]) -> CycleTable {
        CycleTable {
            slots: 1,
            shift_on_wrap: false,
            intervals: pieces
                .iter()
                .map(|p| Interval {
                    start: p.start,
                    end: p.end,
                    laws: vec![Some(SlotLaw {
                        k0: p.k_start,
                        k1: p.slope,
                        g0: 0.0,
                        g1: 0.0,
                    })],
                })
                .collect(),
        }
    }

    /// Model-1 tooth-pair slots with the gaps of `relief` (tip relief or a gap table).
    pub fn pairs(pair: &PairStiffness, relief: &impl GapFunction) -> CycleTable {
        let c = pair.contact_ratio;
        let slots = c.floor() as usize + 1;
        let mut xi_knots: Vec<f64> = vec![0.0, c];
        xi_knots.extend(pair.pieces.iter().map(|p| p.start));
        xi_knots.extend(relief.kinks(c));
        let mut knots = vec![0.0];
        for j in 0..slots {
            for &b in &xi_knots {
                let s = b - (c - 1.0) + j as f64;
                if s > 0.0 && s < 1.0 {
                    knots.push(s);
                }
            }
        }
        knots.sort_by(f64::total_cmp);
        knots.dedup_by(|a, b| (*a - *b).abs() < KNOT_TOL);
        let mut intervals = Vec::with_capacity(knots.len());
        for (i, &start) in knots.iter().enumerate() {
            let end = knots.get(i + 1).copied().unwrap_or(1.0);
            let mid = 0.5 * (start + end);
            let laws = (0..slots)
                .map(|j| {
                    let offset = c - 1.0 - j as f64;
                    let xi_mid = mid + offset;
                    if !(0.0..c).contains(&xi_mid) {
                        return None;
                    }
                    let piece = pair.piece_at(xi_mid);
                    let (g_mid, g1) = relief.gap_and_slope(c, xi_mid);
                    Some(SlotLaw {
                        k0: piece.value(start + offset),
                        k1: piece.slope,
                        g0: g_mid - g1 * (mid - start),
                        g1,
                    })
                })
                .collect();
            intervals.push(Interval { start, end, laws });
        }
        CycleTable {
            slots,
            shift_on_wrap: true,
            intervals,
        }
    }

    /// Index of the interval containing `s ∈ [0, 1)`.
    pub fn interval_at(&self, s: f64) -> usize {
        self.intervals
            .partition_point(|iv| iv.start <= s)
            .saturating_sub(1)
    }

    /// The interval at the shifted phase `u` (any number of cycles): its index and the local
    /// coordinate `r = frac(u) − start` of its laws.
    pub fn locate(&self, u: f64) -> (usize, f64) {
        let s = u - u.floor();
        let index = self.interval_at(s);
        (index, s - self.intervals[index].start)
    }

    /// Whether the mode changes inside a cycle (the integrators must stop at the knots).
    pub fn has_stops(&self) -> bool {
        self.intervals.len() > 1
            || self.shift_on_wrap
            || self.intervals[0]
                .laws
                .iter()
                .flatten()
                .any(|l| l.k1 != 0.0 || l.g1 != 0.0)
    }

    /// Whether every slot stiffness is constant on its interval (gaps may be affine).
    pub fn stiffness_piecewise_constant(&self) -> bool {
        self.intervals
            .iter()
            .all(|iv| iv.laws.iter().flatten().all(|l| l.k1 == 0.0))
    }

    /// Largest stiffness a slot or the sum of slots reaches.
    pub fn max_total_stiffness(&self) -> f64 {
        self.intervals
            .iter()
            .map(|iv| {
                let w = iv.end - iv.start;
                iv.laws
                    .iter()
                    .flatten()
                    .map(|l| l.k(0.0).max(l.k(w)))
                    .sum::<f64>()
            })
            .fold(0.0, f64::max)
    }
}
