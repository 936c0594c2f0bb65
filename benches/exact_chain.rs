//! Exact propagator on chains of lumped meshes (issue 20, points 1–2): µs per mesh period of
//! the exact propagator against DOP853 on simple gear chains at 2000 Hz (every mesh of a
//! simple chain has the same mesh frequency; phases staggered), rigid and compliant bearings,
//! with and without contact loss, and on the shipped `idler_gearset`.
//!
//! `cargo bench --bench exact_chain [-- quick]` — each line is the median of alternated rounds
//! after a warm-up run; ratios are only meaningful within one run (the machine is shared).

use std::time::Instant;

use geardyn::model::train::TrainSimulation;
use geardyn::scene::train::TrainScene;
use geardyn::scene::MethodChoice;

/// A chain of `meshes` lumped meshes at 2000 Hz: `meshes + 1` equal gears (40 teeth), gear `k`
/// drives gear `k + 1`; rectangular mesh stiffness (mean 3e8 N/m, 35 % peak to peak, contact
/// ratio 1.6), phases staggered by 0.37 cycles, 2 % modal damping. `loss`: contact loss
/// enabled at a light load (10 N·m), else a linear contact law at 100 N·m.
pub fn chain(meshes: usize, compliant: bool, loss: bool) -> TrainScene {
    let mut s = String::new();
    s.push_str(&format!(
        "name = \"chain{meshes}\"\n[model]\nbearings = \"{}\"\nmodal_damping_ratio = 0.02\n",
        if compliant { "compliant" } else { "rigid" }
    ));
    for g in 0..=meshes {
        s.push_str(&format!(
            "[[gear]]\nname = \"g{g}\"\nteeth = 40\nbase_radius = 0.05\ninertia = 0.004\nmass = 3.0\nbearing_stiffness = [1.5e8, 1.5e8]\n"
        ));
    }
    for k in 0..meshes {
        let angle = if k % 2 == 0 { 0.3 } else { -0.3 };
        let phase = if k == 0 {
            "initial_phase = 0.0".to_string()
        } else {
            format!("phase = {}", (0.37 * k as f64).fract())
        };
        s.push_str(&format!(
            "[[mesh]]\nname = \"m{k}\"\npinion = \"g{k}\"\ngear = \"g{}\"\ncontact = \"{}\"\npressure_angle = 20.0\ncentre_angle = {angle}\n{phase}\n[mesh.stiffness]\nkind = \"rectangular\"\nmean = 3e8\npeak_to_peak_ratio = 0.35\ncontact_ratio = 1.6\n",
            k + 1,
            if loss { "contact_loss" } else { "linear" }
        ));
    }
    s.push_str(&format!(
        "[operating]\ninput_speed = {}\ninput_torque = {}\n[solver]\nmethod = \"exact\"\nrtol = 1e-9\natol = 1e-15\n",
        std::f64::consts::TAU * 2000.0 / 40.0,
        if loss { 10.0 } else { 100.0 }
    ));
    TrainScene::from_toml_str(&s, "chain").unwrap()
}

fn time(scene: &TrainScene, method: MethodChoice, periods: f64) -> (f64, f64, f64) {
    let mut scene = scene.clone();
    scene.solver.method = method;
    scene.solver.rtol = 1e-9;
    scene.solver.atol = 1e-15;
    let f1 = scene.mesh_frequency(0, scene.operating.input_speed);
    let t_end = periods / f1;
    let mut sim = TrainSimulation::new(&scene).unwrap();
    let start = Instant::now();
    let steps = periods as usize;
    for k in 1..=steps {
        sim.advance_to(k as f64 * t_end / steps as f64).unwrap();
    }
    let us = start.elapsed().as_secs_f64() / periods * 1e6;
    let st = sim.stats();
    if std::env::var("CHAIN_DEBUG").is_ok() {
        eprintln!("composites (builds, hits): {:?}", sim.composite_counts());
    }
    (us, st.steps as f64 / periods, st.events as f64 / periods)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    v[v.len() / 2]
}

fn main() {
    let quick = std::env::args().any(|a| a == "quick");
    let rounds = if quick { 1 } else { 3 };
    println!("| scene | DOF | exact µs/period | DOP853 µs/period | DOP853/exact | exact segments/period | events/period |");
    println!("|---|---:|---:|---:|---:|---:|---:|");
    let mut scenes: Vec<(String, TrainScene, f64)> = Vec::new();
    for &(m, compliant, loss) in &[
        (1, true, false),
        (4, true, false),
        (8, true, false),
        (16, true, false),
        (8, false, true),
        (4, true, true),
    ] {
        let label = format!(
            "chain {m} meshes, {}, {}",
            if compliant { "compliant" } else { "rigid" },
            if loss { "contact loss" } else { "linear" }
        );
        let periods = 2000.0;
        scenes.push((label, chain(m, compliant, loss), periods));
    }
    let mut idler = TrainScene::example("idler_gearset").unwrap();
    idler.operating.input_speed = std::f64::consts::TAU * 2000.0 / 38.0;
    scenes.push(("idler_gearset (pairs, contact loss)".into(), idler, 2000.0));
    let filter: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "quick" && a != "--bench")
        .collect();
    for (label, scene, periods) in &scenes {
        if !filter.iter().all(|f| label.contains(f.as_str())) {
            continue;
        }
        let dof = geardyn::model::train::system::GearTrain::new(scene)
            .unwrap()
            .elastic_dim();
        let (mut ex, mut rk) = (Vec::new(), Vec::new());
        let (mut seg, mut ev) = (0.0, 0.0);
        // Warm-up, then alternated rounds.
        time(scene, MethodChoice::Exact, periods / 10.0);
        for _ in 0..rounds {
            let (u, s, e) = time(scene, MethodChoice::Exact, *periods);
            ex.push(u);
            (seg, ev) = (s, e);
            rk.push(time(scene, MethodChoice::Rk, periods / 5.0).0);
        }
        let (ex, rk) = (median(ex), median(rk));
        println!(
            "| {label} | {dof} | {ex:.2} | {rk:.1} | {:.1} | {seg:.1} | {ev:.2} |",
            rk / ex
        );
    }
}
