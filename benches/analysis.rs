//! Benchmark (not a test) of the steady-state tools on the single-mesh backlash scene
//! `spur_pair` (issue 8): a 400-point sweep (200 speeds up and 200 down, warm start and
//! periodicity detection), the same 400 points by brute-force integration (each from the
//! scene's static start, a fixed transient long enough for every point, then the same
//! recording), and a full harmonic-balance continuation with Floquet stability of every point.
//! All measured in one run; the ratios are the result.
//!
//! Run: `cargo bench --bench analysis` (or `scripts/bench.sh`).

use std::time::Instant;

use geardyn::analysis::hb::{continuation, ContinuationOptions, HbOptions};
use geardyn::analysis::{sweep, Direction, SweepOptions};
use geardyn::scene::Scene;
use geardyn::simulation::Simulation;

const FROM: f64 = 300.0;
const TO: f64 = 600.0;
const POINTS: usize = 200;

/// Brute force: every point from the scene's start, `transient` mesh periods, then the same
/// 8 recorded periods at 64 samples as the sweep.
fn brute_force(scene: &Scene, speeds: &[f64], transient: u32) -> f64 {
    let mut checksum = 0.0;
    for &speed in speeds {
        let mut s = scene.clone();
        s.operating.pinion_speed = speed;
        let mut sim = Simulation::new(&s).expect("simulation");
        let period = sim.model().mesh_period();
        sim.advance_to(transient as f64 * period).expect("advance");
        let t0 = sim.t();
        let mut sum2 = 0.0;
        for i in 1..=8 * 64 {
            sim.advance_to(t0 + i as f64 * period / 64.0)
                .expect("advance");
            sum2 += sim.state()[0].powi(2);
        }
        checksum += sum2;
    }
    checksum
}

fn main() {
    let scene = Scene::example("spur_pair").expect("built-in scene");
    let speeds: Vec<f64> = (0..POINTS)
        .map(|i| FROM + (TO - FROM) * i as f64 / (POINTS - 1) as f64)
        .collect();

    let t = Instant::now();
    let points = sweep(
        &scene,
        &SweepOptions::new(speeds.clone(), Direction::Both),
        &|_, _| {},
    )
    .expect("sweep");
    let warm = t.elapsed().as_secs_f64();
    let longest = points
        .iter()
        .map(|p| p.transient_periods)
        .max()
        .unwrap_or(0);
    let unconverged = points.iter().filter(|p| !p.converged).count();

    // The brute-force transient: the longest one the warm sweep needed, so that every point
    // is at least as settled (from a cold start it needs more; this favours brute force).
    let both: Vec<f64> = speeds.iter().chain(speeds.iter().rev()).copied().collect();
    let t = Instant::now();
    let checksum = brute_force(&scene, &both, longest);
    let brute = t.elapsed().as_secs_f64();

    let t = Instant::now();
    let branch = continuation(
        &scene,
        &HbOptions::new(20),
        &ContinuationOptions::new(FROM, TO),
    )
    .expect("continuation");
    let hb = t.elapsed().as_secs_f64();
    let folds = branch.iter().filter(|p| p.fold).count();

    println!("steady state of spur_pair over {FROM}..{TO} rad/s");
    println!(
        "  sweep, {} points up+down (warm start, periodicity test): {warm:.3} s ({unconverged} not converged, longest transient {longest} periods)",
        points.len()
    );
    println!(
        "  brute force, same {} points ({longest} transient periods each): {brute:.3} s  → ratio {:.1}× (checksum {checksum:.3e})",
        both.len(),
        brute / warm
    );
    println!(
        "  harmonic balance H = 20, continuation with Floquet stability: {hb:.3} s, {} points, {folds} folds",
        branch.len()
    );
}
