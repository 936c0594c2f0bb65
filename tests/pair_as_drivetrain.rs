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
