//! Drivetrain scenes: bad topology and bad parameters are rejected with a message naming the
//! field and its value (issue 5, acceptance 6); valid variants are accepted.

use geardyn::scene::Scene;

const GEARS: &str = r#"
[[gear]]
name = "a"
teeth = 20
base_radius = 0.04
inertia = 0.002

[[gear]]
name = "b"
teeth = 40
base_radius = 0.08
inertia = 0.01

[[gear]]
name = "c"
teeth = 20
base_radius = 0.04
inertia = 0.002
"#;

fn mesh(pinion: &str, gear: &str) -> String {
    format!(
        r#"
[[mesh]]
pinion = "{pinion}"
gear = "{gear}"
contact = "contact_loss"
[mesh.stiffness]
kind = "constant"
value = 2e8
"#
    )
}

fn scene(body: &str) -> Result<Scene, String> {
    let text =
        format!("name = \"t\"\n{body}\n[operating]\ninput_speed = 100.0\ninput_torque = 10.0\n");
    Scene::from_toml_str(&text, "test").map_err(|e| e.0)
}

fn rejects(body: &str, needles: &[&str]) {
    let msg = scene(body).expect_err("scene must be rejected");
    for n in needles {
        assert!(msg.contains(n), "message {msg:?} lacks {n:?}");
    }
}

#[test]
fn valid_two_mesh_train_is_accepted() {
    let s = scene(&format!("{GEARS}{}{}", mesh("a", "b"), mesh("b", "c"))).unwrap();
    assert_eq!(s.meshes.len(), 2);
    // Speeds: b turns at 20/40 of a, c at 40/20 of b; senses alternate.
    assert_eq!(s.speed_ratio, vec![1.0, 0.5, 1.0]);
    assert_eq!(s.rotation, vec![1.0, -1.0, 1.0]);
    // Balanced load on c: T·r_b/r_a·r_c/r_b = T·0.04/0.04.
    assert!((s.operating.load_torque - 10.0).abs() < 1e-12);
}

#[test]
fn mesh_with_unknown_gear() {
    rejects(
        &format!("{GEARS}{}{}", mesh("a", "b"), mesh("b", "ghost")),
        &["mesh[1].gear = \"ghost\"", "no gear of that name"],
    );
}

#[test]
fn mesh_name_must_be_an_identifier() {
    let named = mesh("b", "c").replacen("[[mesh]]", "[[mesh]]\nname = \"mesh 2\"", 1);
    rejects(
        &format!("{GEARS}{}{named}", mesh("a", "b")),
        &["mesh[1].name = \"mesh 2\": must be an identifier"],
    );
    // The same check, named as the file wrote it, in a single-mesh file.
    let one = format!("{GEARS}{}", mesh("a", "b"))
        .replacen("[[mesh]]", "[mesh]\nname = \"m-1\"", 1)
        .replace(
            "[[gear]]\nname = \"c\"",
            "[[gear]]\nname = \"c\"\nground_stiffness = 1e4",
        );
    rejects(&one, &["mesh.name = \"m-1\": must be an identifier"]);
}

#[test]
fn gear_in_two_meshes_with_inconsistent_kinematics() {
    // a drives b and c; a rigid shaft joins b (0.5 × input) and c (1 × input): impossible.
    let body = format!(
        "{GEARS}{}{}\n[[shaft]]\ngears = [\"b\", \"c\"]\nrigid = true\n",
        mesh("a", "b"),
        mesh("a", "c")
    );
    rejects(&body, &["inconsistent kinematics", "shaft[0]"]);
    // Three external gears meshing in a ring: the rotation senses cannot alternate.
    let ring = format!(
        "{GEARS}{}{}{}",
        mesh("a", "b"),
        mesh("b", "c"),
        mesh("c", "a")
    );
    rejects(&ring, &["inconsistent kinematics", "(ccw)", "(cw)"]);
}

#[test]
fn disconnected_train_without_ground() {
    let body = format!(
        "{GEARS}\n[[gear]]\nname = \"d\"\nteeth = 20\nbase_radius = 0.04\ninertia = 0.002\n{}",
        mesh("a", "b")
    );
    rejects(&body, &["gear \"c\"", "disconnected", "ground"]);
    // The same part held by a ground coupling stands still and is accepted.
    let grounded = format!(
        "{}\n[[gear]]\nname = \"d\"\nteeth = 20\nbase_radius = 0.04\ninertia = 0.002\nground_stiffness = 1e4\n{}{}",
        GEARS.replace(
            "name = \"c\"\nteeth = 20\nbase_radius = 0.04\ninertia = 0.002",
            "name = \"c\"\nteeth = 20\nbase_radius = 0.04\ninertia = 0.002\nground_stiffness = 1e4"
        ),
        mesh("a", "b"),
        mesh("c", "d")
    );
    let text = format!(
        "name = \"t\"\n{grounded}\n[operating]\noutput_gear = \"b\"\ninput_speed = 1.0\ninput_torque = 1.0\n"
    );
    let s = Scene::from_toml_str(&text, "test").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.speed_ratio[2], 0.0);
}

#[test]
fn zero_inertia() {
    rejects(
        &format!(
            "{}{}",
            GEARS.replacen("inertia = 0.01", "inertia = 0.0", 1),
            mesh("a", "b") + &mesh("b", "c")
        ),
        &["gear[1].inertia = 0", "> 0"],
    );
}

#[test]
fn non_positive_bearing_stiffness_with_translations() {
    let gears = GEARS.replacen(
        "inertia = 0.002\n",
        "inertia = 0.002\nmass = 1.0\nbearing_stiffness = [0.0, 1e8]\n",
        1,
    );
    rejects(
        &format!("{gears}{}{}", mesh("a", "b"), mesh("b", "c")),
        &[
            "gear[0].bearing_stiffness[x] = 0",
            "translations are enabled",
        ],
    );
    let negative = GEARS.replacen(
        "inertia = 0.002\n",
        "inertia = 0.002\nmass = 1.0\nbearing_stiffness = [1e8, -5.0]\n",
        1,
    );
    rejects(
        &format!("{negative}{}{}", mesh("a", "b"), mesh("b", "c")),
        &["gear[0].bearing_stiffness[y] = -5"],
    );
    // With rigid bearings the translations are off and the field is not used.
    let rigid = format!(
        "[model]\nbearings = \"rigid\"\n{}{}{}",
        GEARS.replacen(
            "inertia = 0.002\n",
            "inertia = 0.002\nmass = 1.0\nbearing_stiffness = [1e8, 1e8]\n",
            1
        ),
        mesh("a", "b"),
        mesh("b", "c")
    );
    assert!(scene(&rigid).unwrap().gears[0].bearing.is_none());
}

#[test]
fn translations_need_mass_and_angles() {
    let gears = GEARS.replacen(
        "inertia = 0.002\n",
        "inertia = 0.002\nbearing_stiffness = [1e8, 1e8]\n",
        1,
    );
    rejects(
        &format!("{gears}{}{}", mesh("a", "b"), mesh("b", "c")),
        &["gear[0].mass", "missing"],
    );
    let gears = GEARS.replacen(
        "inertia = 0.002\n",
        "inertia = 0.002\nmass = 1.0\nbearing_stiffness = [1e8, 1e8]\n",
        1,
    );
    rejects(
        &format!("{gears}{}{}", mesh("a", "b"), mesh("b", "c")),
        &["mesh[0].pressure_angle", "missing"],
    );
}

#[test]
fn mesh_parameters_are_located() {
    rejects(
        &format!(
            "{GEARS}{}",
            mesh("a", "b").replace("value = 2e8", "value = -1.0")
        ),
        &["mesh[0].stiffness.value = -1"],
    );
    rejects(
        &format!(
            "{GEARS}{}",
            mesh("a", "b").replace("gear = \"b\"", "gear = \"a\"")
        ),
        &["mesh[0].gear = \"a\"", "same gear"],
    );
    let bad_phase = format!("{GEARS}{}{}", mesh("a", "b"), mesh("b", "c")).replacen(
        "contact = \"contact_loss\"",
        "contact = \"contact_loss\"\nphase = 0.3",
        1,
    );
    rejects(&bad_phase, &["mesh[0].phase = 0.3", "reference"]);
    let pairs = format!(
        "{GEARS}\n[[mesh]]\npinion = \"a\"\ngear = \"b\"\ncontact = \"contact_loss\"\nmodel = \"pairs\"\n\
         [mesh.pairs]\nkind = \"rectangular\"\nmean = 2e8\npeak_to_peak_ratio = 0.3\ncontact_ratio = 2.4\n"
    );
    rejects(&pairs, &["mesh[0].pairs.contact_ratio = 2.4", "1 < c < 2"]);
    let relief = pairs.replace("contact_ratio = 2.4", "contact_ratio = 1.5")
        + "[mesh.tip_relief]\ndriver_magnitude = 1e-5\ndriver_length = 1.7\n";
    rejects(&relief, &["mesh[0].tip_relief.driver_length = 1.7"]);
    let mismatched = GEARS.replacen("base_radius = 0.08", "base_radius = 0.09", 1);
    rejects(
        &format!("{mismatched}{}", mesh("a", "b")),
        &["mesh[0]", "base pitches differ"],
    );
}

#[test]
fn single_mesh_scene_reads_as_a_train() {
    let text = include_str!("../fmu/spur_pair/scene.toml");
    let s = Scene::from_toml_str(text, "spur_pair").unwrap();
    assert_eq!(s.meshes.len(), 1);
    assert_eq!(s.gears.len(), 2);
    assert!(!geardyn::scene::is_train_text(text));
}

#[test]
fn mesh_driven_backwards_is_rejected() {
    // The input gear is "a" (first gear); naming the driven gear as the pinion of the second
    // mesh would make that mesh unable to carry load.
    rejects(
        &format!("{GEARS}{}{}", mesh("a", "b"), mesh("c", "b")),
        &[
            "mesh[1].pinion = \"c\"",
            "driven through mesh[1]",
            "swap pinion and gear",
        ],
    );
}

#[test]
fn ground_damper_on_a_freely_turning_train_is_rejected() {
    let gears = GEARS.replacen(
        "inertia = 0.01\n",
        "inertia = 0.01\nground_damping = 2.0\n",
        1,
    );
    rejects(
        &format!("{gears}{}", mesh("a", "b")),
        &["gear[1].ground_damping = 2", "turns freely"],
    );
}
