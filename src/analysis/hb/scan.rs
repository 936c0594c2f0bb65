//! The grid on which the per-mesh results scan a converged orbit's series before refining
//! ([`super::statistics`]): its size for the retained orders and its roots of unity, which the
//! problem computes once ([`super::problem::Problem`]).

use std::f64::consts::TAU;

/// Grid points per period of the highest retained order on which the series are scanned
/// before the best point is refined.
pub(super) const SCAN_PER_ORDER: usize = 8;

/// The scan grid's points for the retained `orders` (at least 64).
pub(super) fn scan_points(orders: &[usize]) -> usize {
    let max_order = *orders.last().expect("order 0 at least");
    (SCAN_PER_ORDER * max_order.max(1)).max(64)
}

/// `(cos, sin)(2π r/points)` for `r < points`: the scan grid's roots of unity.
pub(super) fn scan_roots(points: usize) -> Vec<(f64, f64)> {
    let h = 1.0 / points as f64;
    (0..points)
        .map(|r| {
            let (sn, cs) = (TAU * r as f64 * h).sin_cos();
            (cs, sn)
        })
        .collect()
}
