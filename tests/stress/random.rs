//! Randomised parameters (numerics notes §5, S9): a seeded SplitMix64 generator (no new
//! dependency) draws single-mesh scenes — damping ratio, rectangular stiffness (contact
//! ratio, peak-to-peak ratio), STE amplitude, mesh frequency across the resonances, clearance,
//! initial phase and deflection — and for each the exact propagator and DOP853 (rtol 1e-10)
//! must produce the identical event sequence, with event times and DTE that agree. A failing
//! case prints its seed and parameters, so it can be replayed with `case(seed)`.
//!
//! Known defect, accounted for separately: either propagator can miss an excursion that falls
//! between its guard samples — a separation and the return to the same flank, or a shallow
//! touch of a flank during a flight (RK: between the interior samples of a step, which grow
//! long in ballistic flight, see `grazing.rs`; the exact propagator in some cases too, seed
//! 229: a 14 µs back-side flight, 8.6 % of a mesh period, found by RK at rtol 1e-10…1e-13 and
//! by the exact propagator itself with 1.5 µs output stops). A case whose sequences first
//! differ by such an excursion (within a mesh period) is counted and printed, and the motion
//! after it is not compared (it differs); its share must stay small (measured: 2 of 300, 23 of
//! 5000). The strict variant and the seed-229 regression are `#[ignore]`d with the defect.

use std::f64::consts::TAU;

use super::{common, max_time_difference, simulation, states, Propagator};
use geardyn::model::ContactState;
use geardyn::scene::Scene;
use geardyn::solve::rk::Method;

/// SplitMix64 (Steele, Lea & Flood 2014): a tiny, well-mixed 64-bit generator.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[lo, hi)`.
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Log-uniform in `[lo, hi)`.
    fn log_uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.uniform(lo.ln(), hi.ln()).exp()
    }
}

const K_MEAN: f64 = 2.0e8;
/// δ_s = F/k̄ with F = 1000 N (50 N·m on r_b1 = 0.05 m).
const DELTA_S: f64 = 5.0e-6;
const PERIODS: f64 = 20.0;

/// The scene of case `seed` and its description.
fn case(seed: u64) -> (Scene, String) {
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

/// Whether the two event lists first differ by an excursion in one of them: at the first
/// difference, one list has an event followed within `max` by the return to the state before
/// it (a short flight from a flank, or a short touch of a flank during a flight), and the other
/// list continues with the event after that excursion. The motion after a missed excursion
/// differs, so nothing after it is compared.
fn first_difference_is_short_excursion(
    a: &[(f64, ContactState)],
    b: &[(f64, ContactState)],
    max: f64,
) -> bool {
    // The first differing state, or the end of the shorter list.
    let i = (0..a.len().min(b.len()))
        .find(|&k| a[k].1 != b[k].1)
        .unwrap_or(a.len().min(b.len()));
    if a.len() == b.len() && i == a.len() {
        return false;
    }
    // An excursion in `l` starting at `j` (the first differing state is at `j` or `j + 1`).
    let excursion = |l: &[(f64, ContactState)], o: &[(f64, ContactState)], j: usize| {
        j >= 1
            && j + 1 < l.len()
            && l[j + 1].1 == l[j - 1].1
            && l[j + 1].0 - l[j].0 < max
            // The other list continues after the excursion, or ends where it starts.
            && if j + 2 < l.len() {
                j < o.len() && l[j + 2].1 == o[j].1
            } else {
                o.len() == j
            }
    };
    let at = |j: usize| excursion(a, b, j) || excursion(b, a, j);
    at(i) || (i >= 1 && at(i - 1))
}

/// Runs cases `first..first + n`; returns the total event count and the number of cases
/// that differ only by short flights missed by one of the propagators.
fn run_cases(first: u64, n: u64, strict: bool) -> (usize, usize) {
    let mut total = 0;
    let mut short_flight_cases = 0;
    let mut worst = (0.0f64, 0.0f64);
    for seed in first..first + n {
        let (scene, text) = case(seed);
        let mut exact = simulation(&scene, Propagator::Exact, DELTA_S);
        let stop = PERIODS * exact.model().mesh_period();
        exact.advance_to(stop).expect("exact");
        let mut rk = simulation(
            &scene,
            Propagator::Rk(Method::Dop853, 1e-10),
            1e-6 * DELTA_S,
        );
        rk.advance_to(stop).expect("rk");
        let (a, b) = (
            exact.model().events().to_vec(),
            rk.model().events().to_vec(),
        );
        let period = exact.model().mesh_period();
        if !strict && first_difference_is_short_excursion(&a, &b, period) {
            short_flight_cases += 1;
            println!(
                "  seed {seed}: a short excursion is missing in one run (known defect); \
                 exact {} events, RK {}",
                a.len(),
                b.len()
            );
            total += a.len();
            continue;
        }
        assert_eq!(
            states(&b),
            states(&a),
            "seed {seed}: event sequences differ ({} exact, {} RK events)\n  {text}\n  exact {a:?}\n  RK    {b:?}",
            a.len(),
            b.len()
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
        "{n} random cases from seed {first}: {total} events, sequences identical except {short_flight_cases} cases with a short excursion missing in one run; max |Δt| = {:.2e} mesh periods, max |ΔDTE| = {:.2e} δ_s",
        worst.0, worst.1
    );
    (total, short_flight_cases)
}

#[test]
fn random_scenes_have_identical_event_sequences() {
    let (events, short) = run_cases(0, 300, false);
    assert!(events >= 300, "the cases must exercise contact changes");
    assert!(
        short <= 6,
        "{short} of 300 cases differ by a missed excursion"
    );
}

#[test]
#[ignore = "long: 5000 random cases; bash scripts/stress.sh"]
fn random_scenes_have_identical_event_sequences_long() {
    let (_, short) = run_cases(1_000_000, 5_000, false);
    assert!(
        short <= 100,
        "{short} of 5000 cases differ by a missed excursion"
    );
}

#[test]
#[ignore = "known defect: RK misses grazing dips shorter than its guard-sample spacing"]
fn random_scenes_have_identical_event_sequences_strict() {
    run_cases(0, 300, true);
}

/// Known defect: without output stops, the exact propagator misses the back-side flight of
/// seed 229 at t ≈ 1.230–1.244 ms that RK (rtol 1e-10 and 1e-13, both pairs) and the exact
/// propagator itself with stops every 1.5 µs find.
#[test]
#[ignore = "known defect: the exact propagator misses a short back-side flight (seed 229)"]
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
