//! Composite transitions of recurring guard-free sequences (src/solve/exact/composite.rs):
//! on a chain of lumped meshes with a linear contact law the exact propagator applies a
//! recurring run of segments (one mesh period: 2 stiffness switches per mesh) as one product
//! of its transitions. Oracles: the same propagator with composites off (every segment applied
//! on its own) and DOP853 at rtol 1e-12 (an independent integrator); the composite path must
//! actually be taken (else the comparison says nothing), and it must not be taken, or must be
//! rebuilt, where its product would be stale (new inputs, moved output points, contact loss).
//! The contact-loss law while contact holds goes by guarded products (src/solve/exact/
//! guarded.rs), checked the same way, and must give way to the segment-wise path where contact
//! is lost.

use geardyn::model::train::system::TrainInputs;
use geardyn::model::train::TrainSimulation;
use geardyn::scene::MethodChoice;
use geardyn::scene::Scene;

/// A simple chain of `meshes` lumped rectangular meshes at 2000 Hz (all meshes of a simple
/// chain share the mesh frequency), phases staggered by 0.37 cycles, compliant bearings.
fn chain(meshes: usize, contact: &str) -> Scene {
    let mut s = String::from("name = \"chain\"\n[model]\nmodal_damping_ratio = 0.02\n");
    for g in 0..=meshes {
        s.push_str(&format!(
            "[[gear]]\nname = \"g{g}\"\nteeth = 40\nbase_radius = 0.05\ninertia = 0.004\n\
             mass = 3.0\nbearing_stiffness = [1.5e8, 1.5e8]\n"
        ));
    }
    for k in 0..meshes {
        let phase = if k == 0 {
            "initial_phase = 0.1".to_string()
        } else {
            format!("phase = {}", (0.37 * k as f64).fract())
        };
        s.push_str(&format!(
            "[[mesh]]\npinion = \"g{k}\"\ngear = \"g{}\"\ncontact = \"{contact}\"\n\
             pressure_angle = 20.0\ncentre_angle = {}\n{phase}\n[mesh.stiffness]\n\
             kind = \"rectangular\"\nmean = 3e8\npeak_to_peak_ratio = 0.35\ncontact_ratio = 1.6\n",
            k + 1,
            if k % 2 == 0 { 0.3 } else { -0.3 },
        ));
    }
    s.push_str(&format!(
        "[operating]\ninput_speed = {}\ninput_torque = 100.0\n[solver]\nmethod = \"exact\"\n",
        std::f64::consts::TAU * 2000.0 / 40.0
    ));
    Scene::from_toml_str(&s, "chain").expect("chain scene")
}

fn sim(scene: &Scene, method: MethodChoice, composites: bool) -> TrainSimulation {
    let mut scene = scene.clone();
    scene.solver.method = method;
    scene.solver.rtol = 1e-12;
    scene.solver.atol = 1e-18;
    let mut sim = TrainSimulation::new(&scene).expect("simulation");
    sim.use_composites(composites);
    sim
}

/// Largest difference of the displacement and the velocity blocks, each relative to the
/// largest magnitude of its block in `reference`.
fn distance(y: &[f64], reference: &[f64]) -> f64 {
    let m = y.len() / 2;
    let block = |r: std::ops::Range<usize>| {
        let scale = reference[r.clone()]
            .iter()
            .fold(0.0f64, |a, v| a.max(v.abs()));
        r.map(|i| (y[i] - reference[i]).abs() / scale)
            .fold(0.0, f64::max)
    };
    block(0..m).max(block(m..2 * m))
}

const PERIOD: f64 = 1.0 / 2000.0;

/// Advances every simulation over `grid` (times), returning the largest distance of the first
/// from each of the others at the grid points.
fn run_together(sims: &mut [TrainSimulation], grid: impl Iterator<Item = f64>) -> Vec<f64> {
    let mut worst = vec![0.0f64; sims.len() - 1];
    for t in grid {
        for s in sims.iter_mut() {
            s.advance_to(t).expect("advance");
        }
        for (k, w) in worst.iter_mut().enumerate() {
            *w = w.max(distance(sims[0].state(), sims[k + 1].state()));
        }
    }
    worst
}

/// Exact with composites against exact segment by segment and DOP853 at rtol 1e-12, at every
/// mesh period of 400 (output points on a grid that is not commensurate with the stops).
#[test]
fn composites_agree_with_segment_wise_propagation_and_dop853() {
    let scene = chain(6, "linear");
    let mut sims = [
        sim(&scene, MethodChoice::Exact, true),
        sim(&scene, MethodChoice::Exact, false),
        sim(&scene, MethodChoice::Rk, false),
    ];
    let worst = run_together(&mut sims, (1..=400).map(|k| k as f64 * PERIOD));
    let (builds, hits) = sims[0].composite_counts();
    println!(
        "segment-wise {:e}, DOP853 {:e}; builds {builds}, hits {hits}",
        worst[0], worst[1]
    );
    assert!(
        hits >= 300,
        "the composite path decided {hits} of 400 periods"
    );
    assert_eq!(sims[1].composite_counts(), (0, 0), "switched off");
    assert!(
        worst[0] < 1e-11,
        "composite vs segment-wise: {:e}",
        worst[0]
    );
    assert!(worst[1] < 1e-8, "composite vs DOP853: {:e}", worst[1]);
}

/// A long advance (no output point for 50 periods) is cut at the return to the first mode,
/// so its periods recur and are decided by products too.
#[test]
fn long_advances_are_cut_into_recurring_periods() {
    let scene = chain(4, "linear");
    let mut sims = [
        sim(&scene, MethodChoice::Exact, true),
        sim(&scene, MethodChoice::Exact, false),
    ];
    let worst = run_together(&mut sims, (1..=4).map(|k| 50.0 * k as f64 * PERIOD));
    let (_, hits) = sims[0].composite_counts();
    assert!(hits >= 150, "{hits} periods decided by a product");
    assert!(
        worst[0] < 1e-11,
        "composite vs segment-wise: {:e}",
        worst[0]
    );
}

/// New inputs drop the products: with a stale product the constant forcing column (the
/// torque) would be the old one. The run with composites must follow the segment-wise run
/// after a torque step, and the products must be built afresh.
#[test]
fn new_inputs_invalidate_the_products() {
    let scene = chain(3, "linear");
    let mut sims = [
        sim(&scene, MethodChoice::Exact, true),
        sim(&scene, MethodChoice::Exact, false),
    ];
    run_together(&mut sims, (1..=100).map(|k| k as f64 * PERIOD));
    let (builds_before, hits_before) = sims[0].composite_counts();
    assert!(hits_before > 50);
    let inputs = TrainInputs {
        input_torque: 160.0,
        ..sims[0].model().inputs()
    };
    for s in sims.iter_mut() {
        s.set_inputs(inputs).expect("inputs");
    }
    assert_eq!(sims[0].composite_counts(), (0, 0), "dropped with the modes");
    let worst = run_together(&mut sims, (101..=200).map(|k| k as f64 * PERIOD));
    let (builds, hits) = sims[0].composite_counts();
    assert!(
        builds >= 1 && hits > 50,
        "rebuilt: {builds} builds, {hits} hits"
    );
    assert!(worst[0] < 1e-11, "after the torque step: {:e}", worst[0]);
    println!("before: {builds_before} builds, {hits_before} hits; after: {builds}, {hits}");
}

/// Output points that move relative to the stops give other switching offsets: a product of
/// the old grid must not be applied (the offsets are compared to 4 ulps of the time), and
/// the run must follow the segment-wise one on the shifted grid.
#[test]
fn moved_output_points_do_not_reuse_a_product() {
    let scene = chain(3, "linear");
    let mut sims = [
        sim(&scene, MethodChoice::Exact, true),
        sim(&scene, MethodChoice::Exact, false),
    ];
    run_together(&mut sims, (1..=100).map(|k| k as f64 * PERIOD));
    let (builds_before, _) = sims[0].composite_counts();
    // Then output points every 0.7 periods: other sequences, new products.
    let grid = (1..=200).map(|k| 100.0 * PERIOD + 0.7 * k as f64 * PERIOD);
    let worst = run_together(&mut sims, grid);
    let (builds, hits) = sims[0].composite_counts();
    assert!(builds > builds_before, "new sequences, new products");
    assert!(hits > 100);
    assert!(worst[0] < 1e-11, "shifted grid: {:e}", worst[0]);
}

/// A captured state continues bit for bit in a fresh simulation (the products are dropped at
/// capture, as the recurring-segment references are, and rebuilt from the same sequences).
#[test]
fn restored_runs_continue_bit_for_bit() {
    restored_run_continues_bit_for_bit(&chain(3, "linear"));
}

/// The contact-loss law while contact holds (the free 8-mesh chain without STE): each
/// mesh period is walked with its entering tooth pairs taken in contact and applied as one
/// product where a certificate proves every guard positive (src/solve/exact/guarded.rs).
/// The guarded sequence path must be taken, find no event, and agree with the segment-wise
/// path (which decides every segment's guards on its own) and with DOP853.
/// The free benchmark chain of issue 37 (`ChainSpec::free`, compliant bearings) on the
/// contact-loss law without its STE: the loaded meshes never separate.
fn holding_chain(meshes: usize) -> Scene {
    use geardyn::scene::train::{ChainBearings, ChainContact, ChainSpec};
    let text = ChainSpec::free(meshes, ChainBearings::Compliant, ChainContact::ContactHolds)
        .toml()
        .expect("a free chain");
    Scene::from_toml_str(&text, "free_chain").expect("a free chain scene")
}

#[test]
fn guarded_sequences_agree_with_segment_wise_propagation_and_dop853() {
    let scene = holding_chain(8);
    let mut sims = [
        sim(&scene, MethodChoice::Exact, true),
        sim(&scene, MethodChoice::Exact, false),
        sim(&scene, MethodChoice::Rk, false),
    ];
    let worst = run_together(&mut sims, (1..=400).map(|k| k as f64 * PERIOD));
    let (builds, hits) = sims[0].composite_counts();
    println!(
        "segment-wise {:e}, DOP853 {:e}; builds {builds}, hits {hits}",
        worst[0], worst[1]
    );
    assert!(
        hits >= 300,
        "guarded products decided {hits} of 400 periods"
    );
    assert_eq!(sims[1].composite_counts(), (0, 0), "switched off");
    for s in &sims {
        assert_eq!(s.stats().events, 0, "contact holds");
    }
    assert!(worst[0] < 1e-11, "guarded vs segment-wise: {:e}", worst[0]);
    assert!(worst[1] < 1e-8, "guarded vs DOP853: {:e}", worst[1]);
}

/// With contact loss (the free benchmark chain with its 15 µm STE: every mesh separates
/// every period) no guarded sequence can be proved: the walks are taken back and the run is
/// the segment-wise one, with the same contact events, within the exact solver's accuracy.
#[test]
fn guarded_walks_with_contact_loss_are_taken_back() {
    use geardyn::scene::train::{ChainBearings, ChainContact, ChainSpec};
    let text = ChainSpec::free(4, ChainBearings::Compliant, ChainContact::ContactLoss)
        .toml()
        .expect("a free chain");
    let scene = Scene::from_toml_str(&text, "free_chain").expect("a free chain scene");
    let period = 1.0 / scene.mesh_frequency(0, scene.operating.input_speed);
    let mut sims = [
        sim(&scene, MethodChoice::Exact, true),
        sim(&scene, MethodChoice::Exact, false),
    ];
    let mut worst = 0.0f64;
    for k in 1..=200 {
        for s in sims.iter_mut() {
            s.advance_to(k as f64 * period).expect("advance");
        }
        worst = worst.max(distance(sims[0].state(), sims[1].state()));
    }
    let events = [sims[0].stats().events, sims[1].stats().events];
    println!("events {events:?}, distance {worst:e}");
    assert!(events[1] >= 400, "contact is lost: {events:?}");
    assert_eq!(events[0], events[1], "the same contact events");
    assert!(worst < 1e-9, "guarded walks vs segment-wise: {worst:e}");
}

/// A captured state of a guarded chain continues bit for bit in a fresh simulation (the
/// guarded products and certificates are dropped at capture with the modes).
#[test]
fn restored_guarded_runs_continue_bit_for_bit() {
    restored_run_continues_bit_for_bit(&holding_chain(3));
}

/// Runs `scene` 50 periods, restores its snapshot in a fresh simulation and checks the two
/// for 100 more periods, each taking > 50 products.
fn restored_run_continues_bit_for_bit(scene: &Scene) {
    let mut a = sim(scene, MethodChoice::Exact, true);
    for k in 1..=50 {
        a.advance_to(k as f64 * PERIOD).unwrap();
    }
    a.forget_recurrences();
    let snap = a.snapshot();
    let mut b = sim(scene, MethodChoice::Exact, true);
    b.restore(&snap).unwrap();
    for k in 51..=150 {
        let t = k as f64 * PERIOD;
        a.advance_to(t).unwrap();
        b.advance_to(t).unwrap();
        assert_eq!(a.state(), b.state(), "at period {k}");
    }
    assert!(a.composite_counts().1 > 50 && b.composite_counts().1 > 50);
}

/// Total contact loss on Model-1 meshes (per-tooth-pair contact) without tip relief: every
/// tooth pair of a mesh has the same gap, so a pair that enters while the mesh has lost
/// contact on every pair enters apart. A guarded walk that ends at such a stop has assumed it
/// in contact with no segment of its sequence to prove it; the stop must be taken again from
/// the state (it was not: the Liu Ch. 2 orbit at 2715 Hz lost contact on mesh 1 for 0.155 of
/// the time instead of 0.082).
/// Oracle: the segment-wise path, the same contact events, states within the exact solver's
/// accuracy, and the guarded path must be taken.
#[test]
fn guarded_walks_end_before_an_unproved_stop() {
    use geardyn::scene::train::MeshForceModel;
    let mut scene = Scene::example("idler_gearset").expect("the idler");
    for m in &mut scene.meshes {
        if let MeshForceModel::Pairs { relief, .. } = &mut m.force {
            *relief = Default::default();
        }
    }
    // Near the 2529 Hz mode with little damping (tests/train_dynamics.rs,
    // model_1_without_relief_equals_lumped_mesh).
    scene.operating.input_speed = std::f64::consts::TAU * 2450.0 / 38.0;
    scene.modal_damping_ratio = 0.005;
    let f1 = scene.mesh_frequency(0, scene.operating.input_speed);
    let mut sims = [
        sim(&scene, MethodChoice::Exact, true),
        sim(&scene, MethodChoice::Exact, false),
    ];
    let mut worst = 0.0f64;
    for k in 1..=40 * 16 {
        let t = k as f64 / (16.0 * f1);
        for s in sims.iter_mut() {
            s.advance_to(t).expect("advance");
        }
        worst = worst.max(distance(sims[0].state(), sims[1].state()));
    }
    let events = [sims[0].stats().events, sims[1].stats().events];
    let hits = sims[0].composite_counts().1;
    println!("events {events:?}, guarded hits {hits}, distance {worst:e}");
    assert!(events[1] >= 40, "contact is lost: {events:?}");
    assert!(hits >= 10, "the guarded path decided {hits} sequences");
    assert_eq!(events[0], events[1], "the same contact events");
    assert!(worst < 1e-9, "guarded walks vs segment-wise: {worst:e}");
}

/// The Liu (2007) Ch. 2 idler above its mode-2 jump-down (examples/liu2007/ch2_idler.toml,
/// 100 N·m), where the down sweep of the Liu report is on transient chaos with contact loss
/// on both meshes: started from the state that sweep carries from 2730 Hz to 2715 Hz (the
/// recorded state of commit 2da87e7's sweep at 2730 Hz, run over its 8 recorded periods).
/// Oracles: the segment-wise path and DOP853 at rtol 1e-12 stay within rounding of the
/// guarded path, with the same contact events, until chaos amplifies the rounding; and a
/// relative change of 1e-12 of the start grows to 1e-2 within 500 periods, so sweep points
/// that run thousands of periods there depend on rounding (the report's note; docs/scaling.md,
/// "Sweeps through chaos").
#[test]
fn guarded_path_tracks_the_segment_wise_one_on_transient_chaos() {
    use geardyn::model::{response_period, Drivetrain};
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/liu2007/ch2_idler.toml"
    );
    let mut scene = Scene::from_path(std::path::Path::new(path)).expect("the Ch. 2 idler");
    let hz = |f: f64| std::f64::consts::TAU * f / 38.0;
    // `geardyn sweep --states` of the down sweep at 2730 Hz (speed, periods, phase, state).
    let (speed, periods, phase) = (451.3972602263228, 8.0, 0.0);
    assert!((speed - hz(2730.0)).abs() < 1e-9);
    let y_rec = [
        -1.2948031346218326e-5,
        -1.6970027238611928e-5,
        -6.880698105907316e-7,
        0.07074641283230743,
        0.02874422024571549,
        -0.016743171399240968,
    ];
    scene.operating.input_speed = speed;
    let mut warm = sim(&scene, MethodChoice::Exact, false);
    let period = response_period(warm.model()).expect("period");
    let f1 = warm.model().mesh_frequency(0);
    let t_rec = (phase - warm.model().mesh_phase(0, 0.0)).rem_euclid((period * f1).round()) / f1;
    warm.set_state(t_rec, &y_rec);
    warm.advance_to(t_rec + periods * period)
        .expect("recording");
    let (t0, y0) = (warm.t(), warm.state().to_vec());
    let start = |f: f64, method: MethodChoice, composites: bool, change: f64| {
        let mut s = sim(&scene, method, composites);
        let y: Vec<f64> = y0.iter().map(|v| v * (1.0 + change)).collect();
        s.set_state(t0, &y);
        s.change_model(|m, t| m.set_input_speed(t, hz(f)))
            .expect("new speed");
        s
    };
    // The report's 2715 Hz point (its upper branch ends there or one step above) and 5 Hz
    // either side.
    for f in [2710.0, 2715.0, 2720.0] {
        // Guarded (the first), segment-wise, DOP853, segment-wise from the changed start.
        let mut sims = [
            start(f, MethodChoice::Exact, true, 0.0),
            start(f, MethodChoice::Exact, false, 0.0),
            start(f, MethodChoice::Rk, false, 0.0),
            start(f, MethodChoice::Exact, false, 1e-12),
        ];
        let period = response_period(sims[0].model()).expect("period");
        let mut at_50 = [0.0; 3];
        let mut hits_50 = 0;
        // The first period at which each differs from the guarded path by 1e-6.
        let mut apart = [None; 3];
        let mut same_events = [0u32; 2];
        let mut changed = 0.0f64;
        for k in 1..=500u32 {
            for s in sims.iter_mut() {
                s.advance_to(t0 + k as f64 * period).expect("advance");
            }
            let d: Vec<f64> = sims[1..]
                .iter()
                .map(|s| distance(s.state(), sims[0].state()))
                .collect();
            for (a, d) in apart.iter_mut().zip(&d) {
                if a.is_none() && *d > 1e-6 {
                    *a = Some(k);
                }
            }
            if k == 50 {
                at_50.copy_from_slice(&d);
                hits_50 = sims[0].composite_counts().1;
            }
            for (j, same) in same_events.iter_mut().enumerate() {
                if *same == k - 1 && sims[j + 1].stats().events == sims[0].stats().events {
                    *same = k;
                }
            }
            changed = changed.max(distance(sims[3].state(), sims[1].state()));
        }
        let hits = sims[0].composite_counts().1;
        let events = sims[1].stats().events;
        println!(
            "{f} Hz, at 50 periods: segment-wise {:.1e}, DOP853 {:.1e}, changed start {:.1e}; \
             same event count through period {same_events:?}; 1e-6 apart from period \
             {apart:?}; changed start by 500 periods \
             {changed:.1e}; {events} events, guarded hits {hits_50} by period 50, {hits} in all",
            at_50[0], at_50[1], at_50[2]
        );
        assert!(
            events >= 1000,
            "{f} Hz: contact is lost every period: {events} events"
        );
        // The distances at 50 periods compare the paths only if products were applied.
        assert!(
            hits_50 >= 1 && hits >= 5,
            "{f} Hz: the guarded path decided {hits_50} sequences by period 50, {hits} in all"
        );
        assert!(
            at_50[0] < 1e-11,
            "{f} Hz: guarded vs segment-wise {:e}",
            at_50[0]
        );
        assert!(at_50[1] < 1e-9, "{f} Hz: guarded vs DOP853 {:e}", at_50[1]);
        assert!(
            same_events[0] >= 250 && same_events[1] >= 200,
            "{f} Hz: {same_events:?}"
        );
        assert!(
            changed > 1e-2,
            "{f} Hz: a 1e-12 change grew to {changed:e} only"
        );
    }
}
