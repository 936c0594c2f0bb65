//! A single-mesh scene is a one-mesh drivetrain: the resolved scene of a single-pair file is
//! the pair's one-mesh drivetrain, the pair kernel's view of it ([`Scene::pair`]) lifts back
//! to it without loss, and the two kernels give the same run.

use geardyn::scene::PairScene;
use geardyn::scene::Scene;

#[test]
fn pair_scene_is_the_one_mesh_drivetrain_and_lifts_without_loss() {
    let pair = PairScene::from_path("fmu/spur_pair".as_ref()).unwrap();
    let read = Scene::from_path("fmu/spur_pair".as_ref()).unwrap();
    assert_eq!(read.pair().as_ref(), Some(&pair));
    let lifted = Scene::from(&pair);
    assert_eq!(lifted, read);
    assert_eq!(read.gears.len(), 2);
    assert_eq!(read.meshes.len(), 1);
    assert_eq!((read.meshes[0].pinion, read.meshes[0].gear), (0, 1));
    assert_eq!(read.gears[0].name, pair.pinion.name);
    assert_eq!(read.speed_ratio, [1.0, 38.0 / 55.0]);
    assert_eq!(read.rotation, [1.0, -1.0]);
    assert_eq!(read.meshes[0].cycles_per_input_rev, 38.0);
    let train = read.on_drivetrain_kernel().unwrap();
    assert!(train.pair().is_none());
}

/// A single-mesh file that uses per-tooth-pair features (Model-1 pairs with tip relief) is read
/// as its one-mesh drivetrain: the same run as the drivetrain file, bit for bit
/// (`docs/errors.md`, "Assumptions and limitations"; the tip-relief model and its oracles are
/// those of `docs/train.md`).
#[test]
fn a_pair_file_with_tip_relief_runs_as_its_one_mesh_drivetrain() {
    use geardyn::model::train::run_train;
    use geardyn::scene::is_train_text;
    let pair = r#"
name = "relieved_pair"
[[gear]]
name = "pinion"
teeth = 38
base_radius = 0.04535
inertia = 0.002621
[[gear]]
name = "gear"
teeth = 55
base_radius = 0.06564
inertia = 0.01091
[mesh]
pinion = "pinion"
gear = "gear"
contact = "contact_loss"
model = "pairs"
damping_ratio = 0.05
[mesh.pairs]
kind = "rectangular"
mean = 2.9831e8
peak_to_peak_ratio = 0.35
contact_ratio = 1.504
[mesh.tip_relief]
driver_magnitude = 10e-6
driver_length = 0.504
driven_magnitude = 10e-6
driven_length = 0.504
[operating]
pinion_speed = 400.0
input_torque = 100.0
[solver]
stop_time = 0.005
"#;
    assert!(is_train_text(pair));
    let train = pair.replace(
        "[[gear]]\nname = \"pinion\"",
        "[model]\n[[gear]]\nname = \"pinion\"",
    );
    let a = Scene::from_toml_str(pair, "pair").unwrap();
    let b = Scene::from_toml_str(&train, "train").unwrap();
    let (ra, rb) = (
        run_train(&a, 0.005, 1e-5).unwrap(),
        run_train(&b, 0.005, 1e-5).unwrap(),
    );
    assert_eq!(ra.names, rb.names);
    assert_eq!(ra.rows, rb.rows);
    // The relief is there: without it the run differs.
    let plain = pair.replace("driver_magnitude = 10e-6", "driver_magnitude = 0.0");
    let c = Scene::from_toml_str(&plain, "plain").unwrap();
    assert_ne!(run_train(&c, 0.005, 1e-5).unwrap().rows, ra.rows);
}
