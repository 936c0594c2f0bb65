//! Gear data (issue 19, item 5 and the pressure-angle unit of item 4): material presets,
//! base radii and inertias derived from the geometry, `kind = "geometry"` in drivetrain meshes,
//! and the pressure angle in degrees in both scene formats. Oracles: closed forms evaluated
//! here by hand (r_b = m z cos α / 2, solid-disc inertia and mass, ISO 6336-2's Z_E of steel),
//! ROSS's printed inertia, and the single-pair geometry stiffness for the drivetrain mesh.

use geardyn::scene::train::TrainScene;

const FRICTION_PAIR: &str = include_str!("../examples/friction_pair.toml");

fn train_err(text: &str) -> String {
    TrainScene::from_toml_str(text, "t").unwrap_err().0
}

#[test]
fn drivetrain_pressure_angle_is_in_degrees() {
    // The shipped scene says 20.0; the model holds 20° in radians, to the bit.
    let scene = TrainScene::from_toml_str(FRICTION_PAIR, "t").unwrap();
    assert_eq!(scene.meshes[0].pressure_angle, 20f64.to_radians());
    assert_eq!(scene.meshes[0].pressure_angle, 0.3490658503988659);
    // A value left in radians is refused with the unit named, not read as 0.349°.
    let old = FRICTION_PAIR.replace("pressure_angle = 20.0 ", "pressure_angle = 0.349 ");
    let msg = train_err(&old);
    assert!(
        msg.contains("mesh[0].pressure_angle = 0.349")
            && msg.contains("degrees")
            && msg.contains("radians")
            && msg.contains("19.9962"),
        "{msg}"
    );
    for bad in ["90.0", "-20.0", "nan", "inf"] {
        let text = FRICTION_PAIR.replace(
            "pressure_angle = 20.0 ",
            &format!("pressure_angle = {bad} "),
        );
        let msg = train_err(&text).to_lowercase();
        assert!(
            msg.contains(&format!("mesh[0].pressure_angle = {}", bad.trim_end_matches(".0")))
                && msg.contains("degrees"),
            "{bad}: {msg}"
        );
    }
}
