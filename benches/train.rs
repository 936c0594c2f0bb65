//! Cost per mesh period of the drivetrain model (issue 5, acceptance 7): the 2-DOF idler
//! (Liu 2007 Ch. 3 form: rigid bearings, no ground couplings) and the 8-DOF idler (Table 2.1,
//! compliant bearings), each with lumped meshes and with per-tooth-pair contact (Model-1 with
//! tip relief), with the exact propagator and with DOP853.
//!
//! `cargo bench --bench train` — wall time is the median of alternated rounds after a warm-up;
//! work counts (steps, events, stops) are machine independent. Timings are only comparable
//! within one run (the machine is shared).

use std::time::Instant;

use geardyn::mesh::MeshStiffness;
use geardyn::model::train::TrainSimulation;
use geardyn::scene::train::MeshForceModel;
use geardyn::scene::MethodChoice;
use geardyn::scene::Scene;
use geardyn::solve::SolverStats;

#[path = "common/stats.rs"]
mod stats;
use stats::median;

const PERIODS: f64 = 400.0;
const RUNS: usize = 5;

fn idler(dof8: bool, per_pair: bool) -> Scene {
    let mut s = Scene::example("idler_gearset").unwrap();
    if !dof8 {
        s = s.with_rigid_bearings();
        for g in &mut s.gears {
            g.ground_stiffness = 0.0;
        }
    }
    if !per_pair {
        let rect = [(2.9831e8, 0.35, 1.504), (3.2108e8, 0.4, 1.510)];
        for (m, (mean, eps, c)) in s.meshes.iter_mut().zip(rect) {
            m.force = MeshForceModel::Lumped {
                stiffness: MeshStiffness::rectangular(mean, eps, c, 0.0),
                ste: Default::default(),
            };
        }
    }
    // Mesh frequency 1400 Hz: modification A at 100 N·m; contact events on the pairs.
    s.operating.input_speed = std::f64::consts::TAU * 1400.0 / 38.0;
    s
}

/// One run of `PERIODS` mesh periods, advanced in communication steps of a quarter mesh
/// period as an FMU master would: wall time, work counts and the method's name.
fn run_once(scene: &Scene) -> (f64, SolverStats, String) {
    let f1 = scene.mesh_frequency(0, scene.operating.input_speed);
    let t_end = PERIODS / f1;
    let mut sim = TrainSimulation::new(scene).unwrap();
    let start = Instant::now();
    let steps = (PERIODS * 4.0) as usize;
    for k in 1..=steps {
        sim.advance_to(k as f64 * t_end / steps as f64).unwrap();
    }
    let elapsed = start.elapsed().as_secs_f64();
    (elapsed, sim.stats(), sim.method_name())
}

/// Exact propagator and DOP853 on one scene: a warm-up of both, then `RUNS` rounds that run
/// each once (alternated, so load from other processes hits both alike); medians.
fn bench(name: &str, scene: &Scene) {
    let variants: Vec<Scene> = [MethodChoice::Exact, MethodChoice::Rk]
        .into_iter()
        .map(|method| {
            let mut s = scene.clone();
            s.solver.method = method;
            s.solver.rtol = 1e-9;
            s.solver.atol = 1e-15;
            s
        })
        .collect();
    let warm: Vec<_> = variants.iter().map(run_once).collect();
    let mut times = vec![Vec::new(); variants.len()];
    for _ in 0..RUNS {
        for (v, t) in variants.iter().zip(times.iter_mut()) {
            t.push(run_once(v).0);
        }
    }
    for ((_, st, method_name), t) in warm.iter().zip(times.iter_mut()) {
        println!(
            "{name:<34} {method_name:>7} {:>10.2} µs/period  {:>7.1} steps  {:>6.2} events  {:>6.2} stops  {:>8.1} rhs  (per mesh period)",
            median(t) / PERIODS * 1e6,
            st.steps as f64 / PERIODS,
            st.events as f64 / PERIODS,
            st.stops as f64 / PERIODS,
            st.rhs_evals as f64 / PERIODS,
        );
    }
}

fn main() {
    println!("geardyn drivetrain benchmark: {PERIODS} mesh periods at 1400 Hz, median of {RUNS} alternated rounds after a warm-up");
    for (dof8, label) in [(false, "2-DOF idler"), (true, "8-DOF idler")] {
        for (per_pair, contact) in [(false, "lumped"), (true, "per-pair + tip relief")] {
            let scene = idler(dof8, per_pair);
            bench(&format!("{label}, {contact}"), &scene);
        }
    }
}
