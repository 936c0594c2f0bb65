//! Benchmark (not a test) of the closed-form period map of the helical scene
//! (`helical_pair_friction`, He & Singh 2007): the monodromy at 200 speeds from 15,000 to
//! 25,000 rpm by the polynomial (Peano–Baker) segment propagator, against the same monodromy
//! by RK (DOP853, rtol 1e-11) from two unit initial states, measured side by side in one run.
//! The ratio and the largest multiplier difference are the result. Times are medians of
//! alternated rounds after a warm-up of both.
//!
//! Run: `cargo bench --bench helical`.

use std::hint::black_box;
use std::time::Instant;

use geardyn::analysis::LinearPeriodMap;
use geardyn::scene::PairScene;
use geardyn::simulation::Simulation;
use geardyn::units::from_rpm;
use nalgebra::DMatrix;

#[path = "common/stats.rs"]
mod stats;
use stats::median;

const POINTS: usize = 200;
/// Timed rounds after the warm-up; each round runs the closed form and RK once.
const ROUNDS: usize = 7;

fn rk_monodromy(scene: &PairScene, period: f64) -> DMatrix<f64> {
    let w = (scene.mesh.stiffness.mean() / scene.equivalent_mass()).sqrt();
    let mut m = DMatrix::zeros(2, 2);
    for (j, y0) in [[1.0, 0.0], [0.0, w]].into_iter().enumerate() {
        let mut sim = Simulation::new(scene).expect("simulation");
        sim.set_state(0.0, y0);
        sim.advance_to(period).expect("advance");
        let y = sim.state();
        let scale = if j == 0 { 1.0 } else { 1.0 / w };
        m[(0, j)] = y[0] * scale;
        m[(1, j)] = y[1] * scale;
    }
    m
}

fn main() {
    let text = include_str!("../fmu/helical_pair_friction/scene.toml")
        .replace("input_torque = 225.96965805523337", "input_torque = 0.0")
        .replace("rtol = 1e-10", "rtol = 1e-11\nmethod = \"rk\"")
        .replace("atol = 1e-16", "atol = 1e-18");
    let base = PairScene::from_toml_str(&text, "bench").expect("scene");
    let scenes: Vec<PairScene> = (0..POINTS)
        .map(|i| {
            let mut s = base.clone();
            s.operating.pinion_speed =
                from_rpm(15_000.0 + 10_000.0 * i as f64 / (POINTS - 1) as f64);
            s
        })
        .collect();

    let closed_form = || -> Vec<DMatrix<f64>> {
        scenes
            .iter()
            .map(|s| LinearPeriodMap::new(s).expect("map").monodromy())
            .collect()
    };
    let by_rk = || -> Vec<DMatrix<f64>> {
        scenes
            .iter()
            .map(|s| {
                let period =
                    std::f64::consts::TAU / (s.pinion.teeth as f64 * s.operating.pinion_speed);
                rk_monodromy(s, period)
            })
            .collect()
    };
    // Warm-up of both (also the results compared below), then rounds that alternate the two
    // so that load from other processes on the shared cores hits both alike; medians.
    let closed = closed_form();
    let numeric = by_rk();
    let (mut times_closed, mut times_rk) = (Vec::new(), Vec::new());
    for _ in 0..ROUNDS {
        let t = Instant::now();
        black_box(closed_form());
        times_closed.push(t.elapsed().as_secs_f64());
        let t = Instant::now();
        black_box(by_rk());
        times_rk.push(t.elapsed().as_secs_f64());
    }
    let t_closed = median(&mut times_closed);
    let t_rk = median(&mut times_rk);

    let worst = closed
        .iter()
        .zip(&numeric)
        .map(|(a, b)| (a.trace() - b.trace()).abs())
        .fold(0.0, f64::max);
    println!(
        "helical_pair_friction monodromy at {POINTS} speeds (15,000–25,000 rpm, μ = 0.2), \
         median of {ROUNDS} alternated rounds after a warm-up:"
    );
    println!(
        "  closed form (polynomial series) {:.3} ms, {:.1} µs per speed",
        1e3 * t_closed,
        1e6 * t_closed / POINTS as f64
    );
    println!(
        "  RK DOP853 rtol 1e-11            {:.3} ms, {:.1} µs per speed",
        1e3 * t_rk,
        1e6 * t_rk / POINTS as f64
    );
    println!("  ratio RK / closed form {:.1}", t_rk / t_closed);
    println!("  max |tr Φ_closed − tr Φ_RK| = {worst:.2e}");
}
