//! Recurring segments (src/solve/exact/recurrence.rs): the exact propagator decides a
//! segment's first crossing from an earlier segment of the same mode when a perturbation
//! bound proves it. Oracle: the same propagator with that switched off, where every segment
//! gets the full sampled crossing search (an independent algorithm: sampled Taylor bounds,
//! Newton on the guard's series and the enclosure search). Both runs must see the same events
//! and stay together at every mesh period, to the root-finding tolerance; and the fast path
//! must actually decide most segments of a periodic orbit (else the comparison says nothing).

use geardyn::scene::{MethodChoice, PairScene};
use geardyn::simulation::Simulation;

const SPUR_PAIR: &str = include_str!("../fmu/spur_pair/scene.toml");

fn scene(text: &str) -> PairScene {
    let mut scene = PairScene::from_toml_str(text, "test").expect("scene");
    scene.solver.method = MethodChoice::Exact;
    scene
}

/// `spur_pair` with `old` replaced by `new` in its scene text.
fn variant(old: &str, new: &str) -> PairScene {
    assert!(SPUR_PAIR.contains(old), "{old}");
    scene(&SPUR_PAIR.replace(old, new))
}

struct Comparison {
    /// Largest `|Δx|/δ_s`, `|Δx'|/(ω δ_s)` over the checkpoints.
    distance: f64,
    events: (u64, u64),
    /// Fraction of the fast run's segments (after the first tenth) a reference decided.
    decided: f64,
}

/// Runs `periods` mesh periods with and without recurring decisions, comparing the states at
/// every `stride` of a mesh period.
fn compare(scene: &PairScene, periods: u64, stride: f64) -> Comparison {
    let mut fast = Simulation::new(scene).expect("simulation");
    let mut full = Simulation::new(scene).expect("simulation");
    full.use_recurrences(false);
    let period = fast.model().mesh_period();
    let scale = fast.model().static_deflection().abs().max(1e-7);
    let omega = (fast.model().mean_stiffness() / fast.model().equivalent_mass()).sqrt();
    let checkpoints = (periods as f64 / stride).round() as u64;
    let mut distance: f64 = 0.0;
    let mut warm = None;
    for j in 1..=checkpoints {
        let t = j as f64 * stride * period;
        fast.advance_to(t).expect("fast run");
        full.advance_to(t).expect("full run");
        let ([x, v], [xr, vr]) = (fast.state(), full.state());
        distance = distance
            .max((x - xr).abs() / scale)
            .max((v - vr).abs() / (omega * scale));
        if j == checkpoints / 10 {
            warm = Some(fast.stats());
        }
    }
    let (a, b) = (warm.expect("a tenth"), fast.stats());
    assert_eq!(full.stats().recurring_segments, 0, "switched off");
    Comparison {
        distance,
        events: (b.events, full.stats().events),
        decided: (b.recurring_segments - a.recurring_segments) as f64 / (b.steps - a.steps) as f64,
    }
}

fn check(label: &str, scene: &PairScene, periods: u64, stride: f64, min_decided: f64) {
    let c = compare(scene, periods, stride);
    println!(
        "{label}: {periods} mesh periods, events {} / {} (fast / full search), \
         max state difference {:.2e} δ_s, {:.1} % of segments decided by a reference",
        c.events.0,
        c.events.1,
        c.distance,
        100.0 * c.decided
    );
    assert_eq!(c.events.0, c.events.1, "{label}: event counts differ");
    assert!(c.events.0 > 0, "{label}: a scene with events");
    // Event times agree to a few ulps of t; the orbit is stable, so the states do too.
    assert!(
        c.distance <= 1e-9,
        "{label}: runs apart by {:e} δ_s",
        c.distance
    );
    assert!(
        c.decided >= min_decided,
        "{label}: only {:.3} of the segments decided by a reference",
        c.decided
    );
}

#[test]
fn spur_pair_separating_every_period() {
    let scene = scene(SPUR_PAIR);
    check("spur_pair", &scene, 3000, 1.0, 0.95);
}

#[test]
fn output_stops_that_do_not_recur() {
    // Checkpoints every 0.37 mesh periods cut segments at phases that never repeat: few
    // references hold, and nothing may differ.
    let scene = scene(SPUR_PAIR);
    check("spur_pair, stops every 0.37 T", &scene, 1000, 0.37, 0.0);
}

#[test]
fn light_load_with_back_side_impacts() {
    // A tenth of the load: flights reach the back flank (two guards in flight).
    let scene = variant("input_torque = 100.0", "input_torque = 10.0");
    check("spur_pair at 10 N·m", &scene, 2000, 1.0, 0.0);
}
