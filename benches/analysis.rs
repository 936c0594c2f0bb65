//! Benchmark (not a test) of the steady-state tools on the single-mesh backlash scene
//! `spur_pair` and the 8-DOF idler drivetrain `idler_gearset` (issues 8 and 16): for each, a
//! 400-point sweep (200 speeds up and 200 down) with the Newton-shooting warm start, the same
//! sweep with warm-started transient integration only (no shooting), the same 400 points by
//! brute-force integration (each from the scene's static start, a fixed transient, then the
//! same recording), and a harmonic-balance continuation with Floquet stability of every point.
//! Then the harmonic-balance continuation of `idler_gearset` across both fundamental
//! resonances (issue 16; goal ≤ 1 s on the 2-core machine), with and without the stability of
//! each point. All measured in one run; the ratios are the result.
//!
//! Last (issue 31 acceptance 7b): the alias-free spectrum of a periodic orbit (each mesh's
//! DTE and force, 40 mesh harmonics, integrated over each segment) against the shooting that
//! finds the orbit, in thread CPU time.
//!
//! Then (issue 38) the countershaft's harmonic balance at H = 20 against the sweep of the
//! same speeds: the two ranges, and with contact loss on mesh 1 its fundamental
//! resonance (231–233 rad/s), 200–380 rad/s (the torus split at the contact switches) and
//! 200–400 rad/s (the branch ends where H = 20 no longer resolves the orbit).
//!
//! Run: `cargo bench --bench analysis` (or `scripts/bench.sh`); `-- spectrum` for the
//! spectrum rows alone, `-- countershaft` for the countershaft rows alone.

use std::hint::black_box;
use std::time::Instant;

use geardyn::analysis::hb::{continuation, ContinuationOptions, HbOptions};
use geardyn::analysis::{sweep, Direction, SweepOptions};
use geardyn::model::{response_period, Drivetrain};
use geardyn::scene::PairScene;
use geardyn::scene::Scene;
use geardyn::with_drivetrain;

#[path = "common/cpu.rs"]
mod cpu;
#[path = "common/stats.rs"]
mod stats;
use cpu::{process_cpu, thread_cpu};
use stats::median;

const POINTS: usize = 200;

/// Brute force: every point from the scene's start, `transient` response periods, then one
/// recorded response period at 64 samples per mesh period, as the sweep records a periodic
/// point.
fn brute_force(scene: &Scene, speeds: &[f64], transient: u32) -> f64 {
    let mut checksum = 0.0;
    for &speed in speeds {
        let mut s = scene.clone();
        s.set_input_speed(speed);
        checksum += with_drivetrain!(s.simulation().expect("simulation"), sim => {
            let mut sim = sim;
            let period = response_period(sim.model()).expect("period");
            sim.advance_to(transient as f64 * period).expect("advance");
            let t0 = sim.t();
            let samples = 64 * (period * sim.model().mesh_frequency(0)).round() as usize;
            let mut sum2 = 0.0;
            for i in 1..=samples {
                sim.advance_to(t0 + i as f64 * period / samples as f64)
                    .expect("advance");
                sum2 += sim.model().mesh_sample(0, sim.t(), sim.y()).dte.powi(2);
            }
            sum2
        });
    }
    checksum
}

fn bench(name: &str, from: f64, to: f64, transient: u32) {
    let scene = Scene::example(name).expect("built-in scene");
    let speeds: Vec<f64> = (0..POINTS)
        .map(|i| from + (to - from) * i as f64 / (POINTS - 1) as f64)
        .collect();
    let options = SweepOptions::new(speeds.clone(), Direction::Both);

    let shooting_options = options.clone();
    let plain_options = SweepOptions {
        shooting: false,
        ..options.clone()
    };
    let both: Vec<f64> = speeds.iter().chain(speeds.iter().rev()).copied().collect();
    // Warm-up of all three (also the counts below), then rounds alternating them so that load
    // from other processes on the shared cores hits all alike; medians.
    let shot = sweep(&scene, &shooting_options, &|_, _| {}).expect("sweep");
    let plain = sweep(&scene, &plain_options, &|_, _| {}).expect("sweep");
    let checksum = brute_force(&scene, &both, transient);
    let (mut t_shooting, mut t_warm, mut t_brute) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..ROUNDS {
        let t = Instant::now();
        black_box(sweep(&scene, &shooting_options, &|_, _| {}).expect("sweep"));
        t_shooting.push(t.elapsed().as_secs_f64());
        let t = Instant::now();
        black_box(sweep(&scene, &plain_options, &|_, _| {}).expect("sweep"));
        t_warm.push(t.elapsed().as_secs_f64());
        let t = Instant::now();
        black_box(brute_force(&scene, &both, transient));
        t_brute.push(t.elapsed().as_secs_f64());
    }
    let (shooting, warm, brute) = (
        median(&mut t_shooting),
        median(&mut t_warm),
        median(&mut t_brute),
    );
    let newton = shot
        .points
        .iter()
        .filter(|p| p.newton_iterations > 0)
        .count();
    let integrated = shot
        .points
        .iter()
        .filter(|p| p.transient_periods > 0)
        .count();
    let unconverged = shot.points.iter().filter(|p| !p.converged).count();
    let plain_unconverged = plain.points.iter().filter(|p| !p.converged).count();

    println!(
        "{name}: steady state over {from}..{to} rad/s, {} points up+down (median of {ROUNDS} \
         alternated rounds after a warm-up)",
        both.len()
    );
    println!(
        "  sweep, Newton-shooting warm start:      {shooting:7.3} s ({newton} points by Newton, \
         {integrated} with integrated transients, {unconverged} not converged)"
    );
    println!(
        "  sweep, warm-started transients only:    {warm:7.3} s ({plain_unconverged} not converged) \
         → {:.1}× the shooting sweep",
        warm / shooting
    );
    println!(
        "  brute force, {transient} response periods each: {brute:7.3} s → {:.1}× the shooting \
         sweep (checksum {checksum:.3e})",
        brute / shooting
    );
}

/// Timed rounds after the warm-up.
const ROUNDS: usize = 3;

/// Issue 38 acceptance 1: `geardyn hb fmu/countershaft_gearset --speed from:to --harmonics 20`
/// (continuation with the stability of every point) against the up sweep of the same speeds
/// (the branch points'), in process CPU time, measured in one run (one round each: the HB
/// branch takes tens of seconds).
fn countershaft_hb_against_sweep(from: f64, to: f64) {
    let scene = Scene::from_toml_str(
        include_str!("../fmu/countershaft_gearset/scene.toml"),
        "countershaft_gearset",
    )
    .expect("scene");
    let t = process_cpu();
    let branch = continuation(
        &scene,
        &HbOptions::new(20),
        &ContinuationOptions::new(from, to),
    )
    .expect("continuation");
    let hb = process_cpu() - t;
    let mut speeds: Vec<f64> = branch.iter().map(|p| p.speed).collect();
    speeds.sort_by(f64::total_cmp);
    let t = process_cpu();
    let swept = sweep(
        &scene,
        &SweepOptions::new(speeds.clone(), Direction::Up),
        &|_, _| {},
    )
    .expect("sweep");
    let sw = process_cpu() - t;
    black_box(swept);
    let folds = branch.iter().filter(|p| p.fold).count();
    let end = (branch.last())
        .filter(|p| p.unresolved)
        .map_or(String::new(), |p| {
            format!(" (ends unresolved at {:.4} rad/s)", p.speed)
        });
    println!(
        "countershaft_gearset {from}..{to} rad/s: hb H = 20 (total-order basis, with stability) \
         {hb:.3} s CPU, {} points{end}, {folds} folds; up sweep of the same {} speeds {sw:.4} s \
         CPU → hb/sweep {:.0}×",
        branch.len(),
        speeds.len(),
        hb / sw
    );
}

/// Alternated rounds of [`spectrum_against_shooting`] (each a few milliseconds).
const SPECTRUM_ROUNDS: usize = 21;

/// Issue 31 acceptance 7b: one shooting orbit (`geardyn periodic`: the warm-up and Newton
/// shooting) against the spectrum of that orbit as `geardyn spectrum --samples 80` takes it
/// (the simulation set up on the orbit's start, then each mesh's DTE and force integrated
/// over one response period), in thread CPU time, median of [`SPECTRUM_ROUNDS`] alternated rounds.
fn spectrum_against_shooting(name: &str, speed: f64, harmonics: usize) {
    use geardyn::analysis::spectrum::orbit_lines;
    use geardyn::analysis::{shoot, ShootingOptions};
    let mut scene = Scene::example(name).expect("built-in scene");
    scene.set_input_speed(speed);
    let options = ShootingOptions::default();
    let spectrum = |y0: &[f64]| -> (usize, f64) {
        with_drivetrain!(scene.simulation().expect("simulation"), sim => {
            let mut sim = sim;
            let model = sim.model();
            let columns: Vec<usize> = (0..model.mesh_count())
                .flat_map(|n| [model.mesh_columns(n).dte, model.mesh_columns(n).force])
                .collect();
            let period = response_period(model).expect("period");
            let cycles = (period * model.mesh_frequency(0)).round() as usize;
            sim.set_y(0.0, y0);
            let lines = orbit_lines(&mut sim, &columns, period, harmonics * cycles)
                .expect("lines")
                .expect("integrated");
            (lines[0].amplitude.len() - 1, lines[0].amplitude[cycles])
        })
    };
    let orbit = shoot(&scene, &options).expect("orbit");
    let (lines, first) = spectrum(&orbit.y0);
    let (mut t_shoot, mut t_spectrum) = (Vec::new(), Vec::new());
    for _ in 0..SPECTRUM_ROUNDS {
        let t = thread_cpu();
        black_box(shoot(&scene, &options).expect("orbit"));
        t_shoot.push(thread_cpu() - t);
        let t = thread_cpu();
        black_box(spectrum(&orbit.y0));
        t_spectrum.push(thread_cpu() - t);
    }
    let (shooting, lines_cost) = (median(&mut t_shoot), median(&mut t_spectrum));
    println!(
        "{name} at {speed} rad/s: one shooting orbit {:.3} ms CPU; its spectrum ({lines} \
         lines, DTE and force of every mesh) {:.3} ms CPU → {:.3}× the shooting (median of \
         {SPECTRUM_ROUNDS} alternated rounds; line 1×mesh of mesh 1's DTE {first:.6e} m)",
        1e3 * shooting,
        1e3 * lines_cost,
        lines_cost / shooting
    );
}

/// Issue 38 acceptance 2: the spur pair's HB continuation (H = 20, with stability), wall time.
fn spur_pair_hb() {
    let scene = PairScene::example("spur_pair").expect("built-in scene");
    let spur_hb = || {
        continuation(
            &scene,
            &HbOptions::new(20),
            &ContinuationOptions::new(300.0, 600.0),
        )
        .expect("continuation")
    };
    let branch = spur_hb();
    let mut times = Vec::new();
    for _ in 0..ROUNDS {
        let t = Instant::now();
        black_box(spur_hb());
        times.push(t.elapsed().as_secs_f64());
    }
    let hb = median(&mut times);
    let folds = branch.iter().filter(|p| p.fold).count();
    println!(
        "spur_pair: harmonic balance H = 20, continuation with Floquet stability: {hb:.3} s (median of \
         {ROUNDS} after a warm-up), {} points, {folds} folds",
        branch.len()
    );
}

/// Issue 38 acceptance 2: the idler train's HB continuation at H = 10 and 20, with and without
/// stability, wall time.
fn idler_hb() {
    // The 8-DOF idler train across both fundamental resonances (mesh modes at 2529 and
    // 3851 Hz; 250..760 rad/s is 1512..4596 Hz of mesh frequency).
    let idler = Scene::example("idler_gearset").expect("built-in scene");
    let (from, to) = (250.0, 760.0);
    println!(
        "idler_gearset: harmonic balance over {from}..{to} rad/s (median of {ROUNDS} rounds \
         alternating with and without stability, after a warm-up)"
    );
    for h in [10, 20] {
        let variants: Vec<(bool, ContinuationOptions)> = [true, false]
            .into_iter()
            .map(|stability| {
                (
                    stability,
                    ContinuationOptions {
                        stability,
                        ..ContinuationOptions::new(from, to)
                    },
                )
            })
            .collect();
        let run = |options: &ContinuationOptions| {
            continuation(&idler, &HbOptions::new(h), options).expect("continuation")
        };
        let branches: Vec<_> = variants.iter().map(|(_, o)| run(o)).collect();
        let mut times = vec![Vec::new(); variants.len()];
        for _ in 0..ROUNDS {
            for ((_, o), t) in variants.iter().zip(times.iter_mut()) {
                let started = Instant::now();
                black_box(run(o));
                t.push(started.elapsed().as_secs_f64());
            }
        }
        for (((stability, _), branch), t) in variants.iter().zip(&branches).zip(times.iter_mut()) {
            let folds: Vec<String> = branch
                .iter()
                .filter(|p| p.fold)
                .map(|p| format!("{:.1}", p.speed))
                .collect();
            println!(
                "  H = {h:2}, {}: {:.3} s, {} points, folds at {} rad/s",
                if *stability {
                    "with Floquet stability"
                } else {
                    "without stability    "
                },
                median(t),
                branch.len(),
                folds.join(", ")
            );
        }
    }
}

fn main() {
    // `cargo bench --bench analysis -- hb`: the spur pair's and the idler's HB rows alone.
    if std::env::args().any(|a| a == "hb") {
        spur_pair_hb();
        idler_hb();
        return;
    }
    // `cargo bench --bench analysis -- countershaft`: these rows alone.
    if std::env::args().any(|a| a == "countershaft") {
        countershaft_hb_against_sweep(240.0, 250.0);
        countershaft_hb_against_sweep(300.0, 320.0);
        countershaft_hb_against_sweep(231.0, 233.0);
        countershaft_hb_against_sweep(200.0, 380.0);
        // The whole range: the branch ends where H = 20 no longer resolves the orbit (past the
        // lower branch's last point before the 394 rad/s jump).
        countershaft_hb_against_sweep(200.0, 400.0);
        return;
    }
    spectrum_against_shooting("idler_gearset", 420.0, 40);
    spectrum_against_shooting("idler_gearset", 390.0, 40);
    spectrum_against_shooting("countershaft_gearset", 232.0, 40);
    // `cargo bench --bench analysis -- spectrum`: these rows alone.
    if std::env::args().any(|a| a == "spectrum") {
        return;
    }
    bench("spur_pair", 300.0, 600.0, 800);
    bench("idler_gearset", 250.0, 760.0, 500);
    spur_pair_hb();
    idler_hb();
    countershaft_hb_against_sweep(240.0, 250.0);
    countershaft_hb_against_sweep(300.0, 320.0);
    countershaft_hb_against_sweep(231.0, 233.0);
    countershaft_hb_against_sweep(200.0, 380.0);
}
