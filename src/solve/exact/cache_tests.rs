//! The mode cache's memory budget ([`super::ModeCache`]): a run that meets more modes than
//! the budget holds clears the cache and rebuilds, with the same result as a run that keeps
//! them all; it never holds more than the budget, whatever the size of its modes.

use nalgebra::DMatrix;

use super::{ExactPropagator, ModeKey, PiecewiseLti};
use crate::solve::HybridSystem;

const NZ: usize = 12;

/// A chain of unit masses whose stiffness changes at every stop (`t = 1, 2, …`): every piece
/// is a mode of its own, so the run meets as many modes as pieces.
struct NewModeEveryPiece {
    piece: u64,
}

impl NewModeEveryPiece {
    fn stiffness(&self) -> f64 {
        1.0 + 0.01 * self.piece as f64
    }
}

impl HybridSystem for NewModeEveryPiece {
    fn dim(&self) -> usize {
        NZ
    }
    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) {
        let n = NZ / 2;
        for i in 0..n {
            dy[i] = y[n + i];
            dy[n + i] = -self.stiffness() * y[i];
        }
    }
    fn next_stop(&self) -> f64 {
        (self.piece + 1) as f64
    }
    fn on_stop(&mut self, _t: f64, _y: &mut [f64]) {
        self.piece += 1;
    }
}

impl PiecewiseLti for NewModeEveryPiece {
    fn lti_dim(&self) -> usize {
        NZ
    }
    fn lift(&self, _t: f64, y: &[f64], z: &mut [f64]) {
        z.copy_from_slice(y);
    }
    fn lti_matrix(&self, a: &mut DMatrix<f64>) {
        let n = NZ / 2;
        a.fill(0.0);
        for i in 0..n {
            a[(i, n + i)] = 1.0;
            a[(n + i, i)] = -self.stiffness();
        }
    }
    fn guard_row(&self, _index: usize, _w: &mut [f64]) {}
    fn mode_key(&self, key: &mut ModeKey) {
        key.clear();
        key.push(self.piece, u64::MAX);
    }
    fn max_frequency(&self) -> f64 {
        self.stiffness().sqrt()
    }
}

const PIECES: u64 = 600;

/// Runs [`PIECES`] pieces with the cache budget `budget` (bytes; `None`: the default); returns the
/// final state, the builds and clears, the most bytes the cache held and the most bytes one
/// mode held (the later, stiffer pieces take sample steps, whose matrix is built on use).
fn run(budget: Option<usize>) -> (Vec<f64>, u64, u64, usize, usize) {
    let mut sys = NewModeEveryPiece { piece: 0 };
    let mut p = ExactPropagator::new(&sys);
    p.modes.budget = budget;
    let y0: Vec<f64> = (0..NZ).map(|i| 1.0 / (1 + i) as f64).collect();
    p.set_state(0.0, &y0);
    let (mut held, mut largest) = (0, 0);
    for k in 1..=PIECES {
        p.advance_to(&mut sys, k as f64).unwrap();
        p.modes.recount();
        held = held.max(p.modes.held());
        let modes = p.modes.modes.iter().map(super::ModeTransitions::heap_bytes);
        largest = modes.fold(largest, usize::max);
    }
    let (builds, clears) = p.mode_counts();
    (p.y().to_vec(), builds, clears, held, largest)
}

#[test]
fn a_cache_over_its_budget_clears_and_continues_alike() {
    let (kept, builds, clears, _, one_mode) = run(None);
    assert_eq!(
        (builds, clears),
        (PIECES, 0),
        "the default budget keeps {PIECES} small modes"
    );
    // A budget of 10 modes: the cache holds 9 or 10 of them (room is kept for the next
    // one), then clears; it never holds more than the budget.
    let budget = 10 * one_mode;
    let (cleared, builds, clears, held, _) = run(Some(budget));
    assert_eq!(builds, PIECES);
    assert!(
        (PIECES / 12..=PIECES / 8).contains(&clears),
        "{clears} clears of a cache of 10 modes over {PIECES} modes"
    );
    assert!(held <= budget, "held {held} B, budget {budget} B");
    assert!(
        held >= budget - 2 * one_mode,
        "held {held} B, budget {budget} B"
    );
    assert_eq!(cleared, kept, "the same transitions after a clear");
}
