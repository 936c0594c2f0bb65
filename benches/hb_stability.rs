//! Benchmark (not a test) behind the choice of the HB stability method (issue 38, "What to
//! build" 3; docs/harmonic-balance.md "Stability: monodromy, not Hill's method").
//!
//! For each scene of acceptance 4, the continuation with and without the stability step
//! (process CPU, the stability step runs its period maps on all cores; median of alternated
//! rounds): what the shooting monodromy from the HB state costs per point. Against it, the
//! least work Hill's method needs per point on the same basis: the Hill matrix has
//! `N = coordinates × (2|J| − 1)` rows (the quadratic pencil `λ²M + λC(·) + K(·)` over the
//! retained orders); a dense eigensolution is the real Schur form of its `2N` companion
//! matrix, and shift-invert Arnoldi needs at least one LU of the `N × N` complex pencil at the
//! shift. Both are measured here on matrices of those sizes (nalgebra, as the crate uses).
//!
//! Run: `nice -n 5 cargo bench --bench hb_stability`.

use std::hint::black_box;

use geardyn::analysis::hb::{continuation, BranchPoint, ContinuationOptions, HbOptions};
use geardyn::scene::Scene;
use nalgebra::{Complex, DMatrix};

#[path = "common/cpu.rs"]
mod cpu;
#[path = "common/stats.rs"]
mod stats;
use cpu::process_cpu;
use stats::median;

const ROUNDS: usize = 5;

/// A deterministic dense matrix of uniform entries in (−1, 1) (a linear congruential
/// generator: the cost of a dense factorisation does not depend on the values).
fn filled(n: usize, seed: u64) -> DMatrix<f64> {
    let mut state = seed;
    DMatrix::from_fn(n, n, |_, _| {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    })
}

/// The continuation's cost with and without stability, and the Hill matrix size of its basis.
fn stability_cost(scene: &Scene, from: f64, to: f64, h: usize) -> (usize, f64) {
    let run = |stability: bool| -> Vec<BranchPoint> {
        continuation(
            scene,
            &HbOptions::new(h),
            &ContinuationOptions {
                stability,
                ..ContinuationOptions::new(from, to)
            },
        )
        .expect("continuation")
    };
    let branch = run(true);
    let mut times = [Vec::new(), Vec::new()];
    for _ in 0..ROUNDS {
        for (stability, t) in [true, false].into_iter().zip(times.iter_mut()) {
            let started = process_cpu();
            black_box(run(stability));
            t.push(process_cpu() - started);
        }
    }
    let (with, without) = (median(&mut times[0]), median(&mut times[1]));
    let points = branch.len();
    let sol = &branch[0].solution;
    let n = sol.coordinates() * (2 * sol.orders.len() - 1);
    let per_point = (with - without) / points as f64;
    println!(
        "{} {from}..{to} rad/s, H = {h}: {points} points; continuation {without:.4} s CPU \
         without stability, {with:.4} s with → stability {:.2} ms per point ({:.0} % of the \
         run); Hill matrix N = {n} ({} coordinates × {} real tones)",
        scene.name,
        1e3 * per_point,
        100.0 * (with - without) / with,
        sol.coordinates(),
        2 * sol.orders.len() - 1,
    );
    (n, per_point)
}

/// Median CPU seconds of `f` over `rounds`.
fn timed(rounds: usize, mut f: impl FnMut()) -> f64 {
    let mut t: Vec<f64> = (0..rounds)
        .map(|_| {
            let started = process_cpu();
            f();
            process_cpu() - started
        })
        .collect();
    median(&mut t)
}

fn main() {
    let countershaft = Scene::from_toml_str(
        include_str!("../fmu/countershaft_gearset/scene.toml"),
        "countershaft_gearset",
    )
    .expect("scene");
    let spur = Scene::example("spur_pair").expect("scene");
    let idler = Scene::example("idler_gearset").expect("scene");
    let runs = [
        (&spur, 300.0, 600.0, 20),
        (&idler, 380.0, 400.0, 20),
        (&countershaft, 240.0, 250.0, 20),
        (&countershaft, 300.0, 320.0, 20),
    ];
    let costs: Vec<(usize, f64)> = runs
        .iter()
        .map(|&(s, from, to, h)| stability_cost(s, from, to, h))
        .collect();
    let mut seen = Vec::new();
    for (&(scene, ..), &(n, monodromy)) in runs.iter().zip(&costs) {
        if seen.contains(&n) {
            continue;
        }
        seen.push(n);
        // The LU of the complex N × N pencil at one shift (the least shift-invert Arnoldi needs
        // per point).
        let a = filled(n, 1);
        let b = filled(n, 2);
        let pencil = DMatrix::from_fn(n, n, |i, j| Complex::new(a[(i, j)], b[(i, j)]));
        let rounds = if n > 1000 { 1 } else { 3 };
        let lu = timed(rounds, || {
            black_box(pencil.clone().lu());
        });
        // The dense eigenvalues of the 2N companion matrix (real Schur form), up to 1000 rows
        // (beyond, minutes; the O(n³) cost is extrapolated in the docs, not here).
        let schur = (2 * n <= 1000).then(|| {
            let companion = filled(2 * n, 3);
            timed(rounds, || {
                black_box(nalgebra::linalg::Schur::new(companion.clone()));
            })
        });
        println!(
            "{}: Hill N = {n}: complex LU {:.4} s CPU ({:.0}× the monodromy per point){}",
            scene.name,
            lu,
            lu / monodromy,
            schur.map_or(String::new(), |s| format!(
                "; real Schur of the {}-row companion {s:.4} s ({:.0}× the monodromy)",
                2 * n,
                s / monodromy
            ))
        );
    }
}
