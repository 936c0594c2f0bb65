//! Every shipped scene keeps its results: `geardyn simulate` of `fmu/<name>/scene.toml` at ten
//! times the scene's output interval writes exactly `fmu/<name>/reference.csv`, byte for byte.
//! The references were written by the release before the pair and drivetrain stacks were
//! merged into one model path (commit cf6f9c0); regenerate them only for a change that is
//! meant to move results, and say why in its commit.
//!
//! The element scenes (`fmu/emotor`, `fmu/shaft_in`, `fmu/shaft_out`, `fmu/vehicle_load`) are
//! FMU-only models without a `simulate` path: their references are checked through the FMU
//! model in `tests/element_fmus.rs`.

use geardyn::commands::simulate::{simulate, SimulateOptions};
use geardyn::scene::Scene;

/// Scene and output interval of its reference run.
const REFERENCES: [(&str, f64); 12] = [
    ("spur_pair", 1e-4),
    ("geometry_pair", 1e-4),
    ("bugaru_pair", 1e-4),
    ("helical_pair_friction", 2e-5),
    ("idler_gearset", 1e-4),
    ("countershaft_gearset", 1e-4),
    ("spur_stage", 1e-4),
    ("spur_stage_speed", 1e-4),
    ("idler_stage", 1e-4),
    ("countershaft_stage", 1e-4),
    ("geometry_stage", 1e-4),
    ("planetary_stage", 1e-4),
];

#[test]
fn shipped_scenes_reproduce_their_reference_outputs() {
    let dir = std::env::temp_dir().join(format!("geardyn-reference-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (name, interval) in REFERENCES {
        let folder = std::path::Path::new("fmu").join(name);
        let scene = Scene::from_path(&folder).unwrap();
        let out = dir.join(format!("{name}.csv"));
        let options = SimulateOptions {
            output_interval: Some(interval),
            ..SimulateOptions::default()
        };
        simulate(scene, &options, &out).unwrap();
        let now = std::fs::read(&out).unwrap();
        let reference = std::fs::read(folder.join("reference.csv")).unwrap();
        let lines = reference.iter().filter(|&&b| b == b'\n').count();
        assert!(
            now == reference,
            "{name}: simulate output differs from fmu/{name}/reference.csv"
        );
        println!("{name}: {lines} lines identical to the reference");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
