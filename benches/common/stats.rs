//! Statistics shared by the benchmarks (included by each with `#[path]`: a bench target is
//! its own crate, and this folder has no `main.rs`, so Cargo does not take it for one).

/// The median of `v` (sorted in place; the mean of the two middle values for an even count,
/// NaN for none). Medians of alternated rounds are what the benchmarks report: one
/// preempted round on the shared machine does not move them.
pub fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}
