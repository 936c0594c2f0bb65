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
    let scene = chain(3, "linear");
    let mut a = sim(&scene, MethodChoice::Exact, true);
    for k in 1..=50 {
        a.advance_to(k as f64 * PERIOD).unwrap();
    }
    a.forget_recurrences();
    let snap = a.snapshot();
    let mut b = sim(&scene, MethodChoice::Exact, true);
    b.restore(&snap).unwrap();
    for k in 51..=150 {
        let t = k as f64 * PERIOD;
        a.advance_to(t).unwrap();
        b.advance_to(t).unwrap();
        assert_eq!(a.state(), b.state(), "at period {k}");
    }
    assert!(a.composite_counts().1 > 50 && b.composite_counts().1 > 50);
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
    let text: String = ChainSpec::free(meshes, ChainBearings::Compliant, ChainContact::ContactLoss)
        .toml()
        .expect("a free chain")
        .lines()
        .filter(|l| !l.starts_with("ste ="))
        .map(|l| format!("{l}\n"))
        .collect();
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
    let scene = holding_chain(3);
    let mut a = sim(&scene, MethodChoice::Exact, true);
    for k in 1..=50 {
        a.advance_to(k as f64 * PERIOD).unwrap();
    }
    a.forget_recurrences();
    let snap = a.snapshot();
    let mut b = sim(&scene, MethodChoice::Exact, true);
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
