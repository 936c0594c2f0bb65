//! Randomised parameters (numerics notes §5, S9): a seeded SplitMix64 generator (no new
//! dependency) draws single-mesh scenes — damping ratio, rectangular stiffness (contact
//! ratio, peak-to-peak ratio), STE amplitude, mesh frequency across the resonances, clearance,
//! initial phase and deflection — and for each the exact propagator and DOP853 (rtol 1e-10)
//! must produce the identical event sequence, with event times and DTE that agree. A failing
//! case prints its seed and parameters, so it can be replayed with `case(seed)`.
//!
//! Fixed with the suite: the exact propagator missed an excursion that fell between its guard
//! samples — a separation and the return to the same flank, or a shallow touch of a flank
//! during a flight (seed 229: a 14 µs back-side flight, 8.6 % of a mesh period; seeds 1001515
//! and 1001995 of the long set, each reproduced by the exact propagator with 1 µs output
//! stops). Its sample-interval search only looked for a dip when the guard's slope went from
//! − to + across the interval, and after an event only when the guard ended the interval
//! below zero and falling; it now proves each interval free of crossings with a curvature
//! bound or finds the first crossing on the guard's Taylor polynomial
//! (`src/solve/exact/enclosure.rs`). The event search of RK bounds each guard along the
//! step's interpolant (`src/solve/rk/graze.rs`). A case whose sequences first differ by an
//! excursion that only one propagator has (within a mesh period) is classified and printed;
//! none may remain (measured before the fix: 2 of 5000 missed by the exact propagator; RK,
//! sampled at 4 interior points per step before its fix, 1 of 300 and 21 of 5000).

use std::f64::consts::TAU;

use super::{common, max_time_difference, simulation, states, Propagator};
use geardyn::model::ContactState;
use geardyn::scene::PairScene;
use geardyn::solve::rk::Method;

use crate::common::rng::SplitMix64;

const K_MEAN: f64 = 2.0e8;
/// δ_s = F/k̄ with F = 1000 N (50 N·m on r_b1 = 0.05 m).
const DELTA_S: f64 = 5.0e-6;
const PERIODS: f64 = 20.0;

/// The scene of case `seed` and its description.
fn case(seed: u64) -> (PairScene, String) {
    let mut r = SplitMix64(seed);
    let zeta = r.uniform(0.005, 0.2);
    let contact_ratio = r.uniform(1.1, 1.9);
    let eps = r.uniform(0.05, 0.6);
    let ste = r.uniform(0.0, 1.0) * DELTA_S;
    let f_n = (K_MEAN / common::M_E).sqrt() / TAU;
    let f_ratio = r.uniform(0.2, 3.0);
    let clearance = r.log_uniform(1e-3, 2.0) * DELTA_S;
    let phase = r.uniform(0.0, 1.0);
    let x0 = r.uniform(-1.0, 3.0) * DELTA_S;
    let text = format!(
        "ζ = {zeta:.4}, contact ratio {contact_ratio:.3}, ε = {eps:.3}, STE {ste:.3e} m, \
         f_m/f_n = {f_ratio:.3}, clearance {clearance:.3e} m, phase {phase:.3}, x0 = {x0:.3e} m"
    );
    let scene = common::scene(
        &format!(
            "contact = \"backlash\"\nbacklash = {clearance:e}\ndamping_ratio = {zeta}\n\
             initial_phase = {phase}\n\
             [mesh.stiffness]\nkind = \"rectangular\"\nmean = {K_MEAN:e}\n\
             peak_to_peak_ratio = {eps}\ncontact_ratio = {contact_ratio}\n\
             [mesh.ste]\ncos = [{ste:e}]"
        ),
        &format!(
            "pinion_speed = {}\ninput_torque = 50.0",
            common::pinion_speed_for_mesh_frequency(f_ratio * f_n)
        ),
        &format!("[initial]\ndte = {x0:e}\ndte_rate = 0.0"),
    );
    (scene, text)
}

/// Which propagator missed an excursion the other one found.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Missed {
    ByExact,
    ByRk,
}

/// Whether the two event lists first differ by an excursion in one of them: at the first
/// difference, one list has an event followed within `max` by the return to the state before
/// it (a short flight from a flank, or a short touch of a flank during a flight), and the other
/// list continues with the event after that excursion. The motion after a missed excursion
/// differs, so nothing after it is compared.
fn missed_short_excursion(
    exact: &[(f64, ContactState)],
    rk: &[(f64, ContactState)],
    max: f64,
) -> Option<Missed> {
    let (a, b) = (exact, rk);
    // The first differing state, or the end of the shorter list.
    let i = (0..a.len().min(b.len()))
        .find(|&k| a[k].1 != b[k].1)
        .unwrap_or(a.len().min(b.len()));
    if a.len() == b.len() && i == a.len() {
        return None;
    }
    // An excursion in `l` starting at `j` (the first differing state is at `j` or `j + 1`):
    // `Some(|Δt|)` between the event after it and the other list's continuation there.
    let excursion = |l: &[(f64, ContactState)], o: &[(f64, ContactState)], j: usize| {
        let shape =
            j >= 1 && j + 1 < l.len() && l[j + 1].1 == l[j - 1].1 && l[j + 1].0 - l[j].0 < max;
        if !shape {
            return None;
        }
        // The other list continues after the excursion, or ends where it starts.
        if j + 2 < l.len() {
            (j < o.len() && l[j + 2].1 == o[j].1).then(|| (l[j + 2].0 - o[j].0).abs())
        } else {
            (o.len() == j).then_some(0.0)
        }
    };
    // Alternating sequences can fit both readings; the one whose continuation matches in time
    // is the real one.
    let mut candidates = Vec::new();
    for j in [i.saturating_sub(1), i] {
        if let Some(dt) = excursion(a, b, j) {
            candidates.push((dt, Missed::ByRk));
        }
        if let Some(dt) = excursion(b, a, j) {
            candidates.push((dt, Missed::ByExact));
        }
    }
    candidates
        .into_iter()
        .min_by(|x, y| x.0.total_cmp(&y.0))
        .map(|c| c.1)
}

/// Runs cases `first..first + n`; returns the total event count and the number of cases
/// that differ only by a short excursion the exact propagator missed (counted unless
/// `strict`, where it fails at once with the sequences; an excursion RK missed always fails).
fn run_cases(first: u64, n: u64, strict: bool) -> (usize, usize) {
    let mut total = 0;
    let mut exact_misses = 0;
    let mut worst = (0.0f64, 0.0f64);
    for seed in first..first + n {
        let (scene, text) = case(seed);
        let mut exact = simulation(&scene, Propagator::Exact, DELTA_S);
        let stop = PERIODS * exact.model().mesh_period();
        exact
            .advance_to(stop)
            .unwrap_or_else(|e| panic!("seed {seed}: exact: {e}\n  {text}"));
        let mut rk = simulation(
            &scene,
            Propagator::Rk(Method::Dop853, 1e-10),
            1e-6 * DELTA_S,
        );
        rk.advance_to(stop)
            .unwrap_or_else(|e| panic!("seed {seed}: RK: {e}\n  {text}"));
        let (a, b) = (
            exact.model().events().to_vec(),
            rk.model().events().to_vec(),
        );
        let period = exact.model().mesh_period();
        if !strict && missed_short_excursion(&a, &b, period) == Some(Missed::ByExact) {
            exact_misses += 1;
            println!(
                "  seed {seed}: a short excursion RK found is missing in the exact run; exact {} \
                 events, RK {}",
                a.len(),
                b.len()
            );
            total += a.len();
            continue;
        }
        assert_eq!(
            states(&b),
            states(&a),
            "seed {seed}: event sequences differ ({} exact, {} RK events; missed excursion: \
             {:?})\n  {text}\n  exact {a:?}\n  RK    {b:?}",
            a.len(),
            b.len(),
            missed_short_excursion(&a, &b, period)
        );
        let dt = max_time_difference(&a, &b) / period;
        let dx = (exact.state()[0] - rk.state()[0]).abs() / DELTA_S;
        assert!(
            dt <= 1e-6 && dx <= 1e-6,
            "seed {seed}: event times differ by {dt:e} mesh periods, final DTE by {dx:e} δ_s\n  {text}"
        );
        worst = (worst.0.max(dt), worst.1.max(dx));
        total += a.len();
    }
    println!(
        "{n} random cases from seed {first}: {total} events, sequences identical except {exact_misses} cases with a short excursion missing in the exact run; max |Δt| = {:.2e} mesh periods, max |ΔDTE| = {:.2e} δ_s",
        worst.0, worst.1
    );
    (total, exact_misses)
}

#[test]
fn random_scenes_have_identical_event_sequences() {
    let (events, exact_misses) = run_cases(0, 300, false);
    assert!(events >= 300, "the cases must exercise contact changes");
    assert_eq!(
        exact_misses, 0,
        "{exact_misses} of 300 cases differ by an excursion the exact propagator missed"
    );
}

#[test]
#[ignore = "long: 5000 random cases; bash scripts/stress.sh"]
fn random_scenes_have_identical_event_sequences_long() {
    let (_, exact_misses) = run_cases(1_000_000, 5_000, false);
    assert_eq!(
        exact_misses, 0,
        "{exact_misses} of 5000 cases differ by an excursion the exact propagator missed"
    );
}

#[test]
fn random_scenes_have_identical_event_sequences_strict() {
    run_cases(0, 300, true);
}

/// Regression: the two cases of the long set whose excursion the exact propagator missed
/// before its sample intervals were searched rigorously (`src/solve/exact/enclosure.rs`).
#[test]
fn exact_finds_the_short_excursions_of_seeds_1001515_and_1001995() {
    for seed in [1_001_515, 1_001_995] {
        run_cases(seed, 1, true);
    }
}

/// Regression: without output stops, the exact propagator missed the back-side flight of
/// seed 229 at t ≈ 1.230–1.244 ms that RK (rtol 1e-10 and 1e-13, both pairs) and the exact
/// propagator itself with stops every 1.5 µs find.
#[test]
fn exact_finds_the_short_back_side_flight_of_seed_229() {
    let (scene, _) = case(229);
    let mut exact = simulation(&scene, Propagator::Exact, DELTA_S);
    exact.advance_to(1.35e-3).expect("exact");
    let mut rk = simulation(
        &scene,
        Propagator::Rk(Method::Dop853, 1e-13),
        1e-6 * DELTA_S,
    );
    rk.advance_to(1.35e-3).expect("rk");
    assert_eq!(states(exact.model().events()), states(rk.model().events()));
}

/// Regression (fixed with the suite): after snapping onto the back-side surface, rounding left
/// the new contact's guard a few ulp below 0, so RK never saw the end of a 0.5 µs back-side
/// touch and stayed in back-side contact for the remaining 13 mesh periods.
#[test]
fn rk_leaves_a_short_back_side_touch_seed_1001012() {
    let (scene, text) = case(1_001_012);
    let mut exact = simulation(&scene, Propagator::Exact, DELTA_S);
    let stop = PERIODS * exact.model().mesh_period();
    exact.advance_to(stop).expect("exact");
    let mut rk = simulation(
        &scene,
        Propagator::Rk(Method::Dop853, 1e-10),
        1e-6 * DELTA_S,
    );
    rk.advance_to(stop).expect("rk");
    let (a, b) = (exact.model().events(), rk.model().events());
    assert_eq!(states(b), states(a), "{text}");
    assert!(max_time_difference(a, b) <= 1e-6 * exact.model().mesh_period());
}
