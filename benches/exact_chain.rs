//! Exact propagator on chains of lumped meshes (issue 20, points 1–2): µs per mesh period of
//! the exact propagator against DOP853 and DP5 (`best RK/exact`: the faster of the two) on
//! simple gear chains at 2000 Hz (every mesh of a simple chain has the same mesh frequency;
//! phases staggered), rigid and compliant bearings,
//! with and without contact loss, and on the shipped `idler_gearset`; and with the rotation
//! carried (issue 18, `docs/ports.md`): `fmu/spur_stage` without its STE harmonic (backlash
//! rattle, and linear contact) and the `idler_gearset` data turning freely between torque
//! ports, where the stiffness knots are guards on the pinion angle.
//!
//! `cargo bench --bench exact_chain [-- quick]` — each line is the median of alternated rounds
//! after a warm-up run; ratios are only meaningful within one run (the machine is shared).

use geardyn::scene::train::{ChainBearings, ChainContact, ChainSpec};
use geardyn::scene::MethodChoice;
use geardyn::scene::Scene;
use geardyn::solve::rk::Method as Rk;

#[path = "common/stats.rs"]
mod stats;
use stats::median;
#[path = "common/whole_run.rs"]
mod whole_run;

fn time(scene: &Scene, method: MethodChoice, composites: bool, periods: f64) -> (f64, f64, f64) {
    time_rk(scene, method, Rk::Dop853, composites, periods)
}

/// [`time`] with the RK method `rk` (used when `method` is [`MethodChoice::Rk`]): µs per
/// period, segments and events per period (NaN if the run failed).
fn time_rk(
    scene: &Scene,
    method: MethodChoice,
    rk: Rk,
    composites: bool,
    periods: f64,
) -> (f64, f64, f64) {
    let Some((us, sim)) = whole_run::micros_per_period(scene, method, rk, composites, periods)
    else {
        return (f64::NAN, f64::NAN, f64::NAN);
    };
    let st = sim.stats();
    if std::env::var("CHAIN_DEBUG").is_ok() {
        eprintln!(
            "composites (builds, hits): {:?}, modes (builds, cache clears): {:?}, per period: \
             guard evals {:.1}, recurring segments {:.2}, series segments {:.2}, exclusions \
             {:.2}, stops {:.2}",
            sim.composite_counts(),
            sim.mode_counts(),
            st.guard_evals as f64 / periods,
            st.recurring_segments as f64 / periods,
            st.series_segments as f64 / periods,
            st.guard_exclusions as f64 / periods,
            st.stops as f64 / periods,
        );
    }
    (us, st.steps as f64 / periods, st.events as f64 / periods)
}

/// `fmu/spur_stage` without its STE harmonic (with the rotation carried an STE is not
/// piecewise-LTI), with contact law `contact`.
fn spur_stage(contact: &str) -> Scene {
    let text =
        include_str!("../fmu/spur_stage/scene.toml").replace("[mesh.ste]\ncos = [1.0e-6]\n", "");
    let text = match contact {
        "backlash" => text,
        _ => text.replace(
            "contact = \"backlash\"\nbacklash = 1.0e-4",
            &format!("contact = \"{contact}\""),
        ),
    };
    Scene::from_toml_str(&text, "spur_stage").unwrap()
}

/// The `idler_gearset` data without its ground springs, driven and loaded through torque
/// ports on the pinion and the follower (balanced through the base radii), at 2000 Hz.
fn idler_with_ports() -> Scene {
    let speed = std::f64::consts::TAU * 2000.0 / 38.0;
    let load = -100.0 * 0.11218 / 0.04535;
    let text = include_str!("../fmu/idler_gearset/scene.toml")
        .replace("ground_stiffness = 3389.6\n", "")
        .replace("ground_stiffness = 11297.9\n", "")
        .replace(
            "input_speed = 330.6939635357677          # rad/s: mesh frequency 2000 Hz\ninput_torque = 100.0",
            &format!(
                "pinion_speed = {speed:?}\n\n[[port]]\nname = \"input\"\ngear = \"pinion\"\n\
                 causality = \"torque\"\ntorque = 100.0\n\n[[port]]\nname = \"output\"\n\
                 gear = \"follower\"\ncausality = \"torque\"\ntorque = {load:?}\n"
            ),
        );
    Scene::from_toml_str(&text, "idler_ports").unwrap()
}

fn main() {
    let quick = std::env::args().any(|a| a == "quick");
    let rounds = if quick { 1 } else { 3 };
    println!("| scene | DOF | exact, segment-wise µs/period | exact µs/period | DOP853 µs/period | DP5 µs/period | best RK/exact | segment-wise/exact | segments/period | events/period |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    let mut scenes: Vec<(String, Scene, f64)> = Vec::new();
    use ChainBearings::{Compliant, Rigid};
    use ChainContact::{ContactLoss, Linear};
    for &(m, bearings, contact) in &[
        (1, Compliant, Linear),
        (4, Compliant, Linear),
        (8, Compliant, Linear),
        (16, Compliant, Linear),
        (21, Compliant, Linear),
        (8, Rigid, ContactLoss),
        (4, Compliant, ContactLoss),
    ] {
        let spec = ChainSpec::new(m, bearings, contact);
        scenes.push((spec.name(), Scene::chain(spec).unwrap(), 2000.0));
    }
    let mut idler = Scene::example("idler_gearset").unwrap();
    idler.operating.input_speed = std::f64::consts::TAU * 2000.0 / 38.0;
    scenes.push(("idler_gearset (pairs, contact loss)".into(), idler, 2000.0));
    scenes.push((
        "spur_stage ports, no STE (backlash rattle)".into(),
        spur_stage("backlash"),
        2000.0,
    ));
    scenes.push((
        "spur_stage ports, no STE (linear)".into(),
        spur_stage("linear"),
        2000.0,
    ));
    scenes.push((
        "idler_gearset ports (pairs, contact loss)".into(),
        idler_with_ports(),
        2000.0,
    ));
    let filter: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "quick" && a != "--bench" && a != "profile")
        .collect();
    for (label, scene, periods) in &scenes {
        if !filter.iter().all(|f| label.contains(f.as_str())) {
            continue;
        }
        let dof = geardyn::model::train::system::GearTrain::new(scene)
            .unwrap()
            .elastic_dim();
        let (mut seg, mut ex, mut rk, mut dp5) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let (mut segments, mut events) = (0.0, 0.0);
        if std::env::args().any(|a| a == "profile") {
            // For `perf record`: the composite path alone, longer.
            let (u, _, _) = time(scene, MethodChoice::Exact, true, 10.0 * periods);
            println!("{label}: {u:.2} µs/period");
            continue;
        }
        // Warm-up, then alternated rounds; DOP853 over a fifth of the periods.
        time(scene, MethodChoice::Exact, true, periods / 10.0);
        for _ in 0..rounds {
            seg.push(time(scene, MethodChoice::Exact, false, *periods).0);
            let (u, s, e) = time(scene, MethodChoice::Exact, true, *periods);
            ex.push(u);
            (segments, events) = (s, e);
            rk.push(time(scene, MethodChoice::Rk, false, periods / 5.0).0);
            dp5.push(time_rk(scene, MethodChoice::Rk, Rk::Dp5, false, periods / 5.0).0);
        }
        let (seg, ex, rk, dp5) = (
            median(&mut seg),
            median(&mut ex),
            median(&mut rk),
            median(&mut dp5),
        );
        // A failed RK run is NaN: the best RK is the faster one that completed.
        let best_rk = if dp5.is_nan() || rk <= dp5 { rk } else { dp5 };
        println!(
            "| {label} | {dof} | {seg:.2} | {ex:.2} | {rk:.1} | {dp5:.1} | {:.1} | {:.1} | {segments:.1} | {events:.2} |",
            best_rk / ex,
            seg / ex
        );
    }
}
