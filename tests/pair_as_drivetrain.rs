//! A single-mesh scene is a one-mesh drivetrain: [`TrainScene::from_pair`] gives the same
//! drivetrain the train reader builds from the same file, and the two kernels give the same
//! run.

use geardyn::scene::train::TrainScene;
use geardyn::scene::Scene;

#[test]
fn pair_scene_converts_to_the_drivetrain_the_train_reader_builds() {
    let pair = Scene::from_path("fmu/spur_pair".as_ref()).unwrap();
    let read = TrainScene::from_path("fmu/spur_pair".as_ref()).unwrap();
    let converted = TrainScene::from_pair(&pair);
    assert_eq!(converted.gears, read.gears);
    assert_eq!(converted.meshes[0].force, read.meshes[0].force);
    assert_eq!(converted.meshes[0].contact, read.meshes[0].contact);
    assert_eq!(converted.meshes[0].damping, read.meshes[0].damping);
    assert_eq!(
        converted.meshes[0].cycles_per_input_rev,
        read.meshes[0].cycles_per_input_rev
    );
    assert_eq!(converted.speed_ratio, read.speed_ratio);
    assert_eq!(converted.rotation, read.rotation);
    assert_eq!(converted.operating, read.operating);
    assert_eq!(converted.initial_dte, read.initial_dte);
    println!("{:?}\n{:?}", converted.meshes[0], read.meshes[0]);
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
    let a = TrainScene::from_toml_str(pair, "pair").unwrap();
    let b = TrainScene::from_toml_str(&train, "train").unwrap();
    let (ra, rb) = (
        run_train(&a, 0.005, 1e-5).unwrap(),
        run_train(&b, 0.005, 1e-5).unwrap(),
    );
    assert_eq!(ra.names, rb.names);
    assert_eq!(ra.rows, rb.rows);
    // The relief is there: without it the run differs.
    let plain = pair.replace("driver_magnitude = 10e-6", "driver_magnitude = 0.0");
    let c = TrainScene::from_toml_str(&plain, "plain").unwrap();
    assert_ne!(run_train(&c, 0.005, 1e-5).unwrap().rows, ra.rows);
}
