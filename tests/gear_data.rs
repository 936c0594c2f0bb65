//! Gear data (issue 19, item 5 and the pressure-angle unit of item 4): material presets,
//! base radii and inertias derived from the geometry, `kind = "geometry"` in drivetrain meshes,
//! and the pressure angle in degrees in both scene formats. Oracles: closed forms evaluated
//! here by hand (r_b = m z cos α / 2, solid-disc inertia and mass, ISO 6336-2's Z_E of steel),
//! ROSS's printed inertia, and the single-pair geometry stiffness for the drivetrain mesh.

use geardyn::scene::Scene;

const FRICTION_PAIR: &str = include_str!("../examples/friction_pair.toml");

fn train_err(text: &str) -> String {
    Scene::from_toml_str(text, "t").unwrap_err().0
}

#[test]
fn drivetrain_pressure_angle_is_in_degrees() {
    // The shipped scene says 20.0; the model holds 20° in radians, to the bit.
    let scene = Scene::from_toml_str(FRICTION_PAIR, "t").unwrap();
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
            msg.contains(&format!(
                "mesh[0].pressure_angle = {}",
                bad.trim_end_matches(".0")
            )) && msg.contains("degrees"),
            "{bad}: {msg}"
        );
    }
}

use std::f64::consts::PI;

use geardyn::mesh::geometry::spec::parse_gears_file;
use geardyn::mesh::geometry::MeshModel;
use geardyn::model::train::TrainSimulation;
use geardyn::scene::PairScene;

const USER_PAIR: &str = include_str!("../examples/user_pair.toml");
const GEOMETRY_PAIR: &str = include_str!("../fmu/geometry_pair/scene.toml");

/// The user's data (module 3 mm, 20°, 20 mm face, steel ρ = 7850 kg/m³) for `z` teeth and a
/// bore of radius `bore`: base radius, disc inertia and disc mass by hand.
fn by_hand(z: f64, bore: f64) -> (f64, f64, f64) {
    let (m, alpha, width, rho) = (0.003, 20f64.to_radians(), 0.02, 7850.0);
    let r = m * z / 2.0;
    let base = r * alpha.cos();
    let inertia = 0.5 * rho * PI * width * (r.powi(4) - bore.powi(4));
    let mass = rho * PI * width * (r * r - bore * bore);
    (base, inertia, mass)
}

fn rel(a: f64, b: f64) -> f64 {
    ((a - b) / b).abs()
}

fn pair_err(text: &str) -> String {
    PairScene::from_toml_str(text, "t").unwrap_err().0
}

#[test]
fn user_pair_builds_from_geometry_and_steel_alone() {
    assert!(!USER_PAIR.contains("base_radius =") && !USER_PAIR.contains("inertia ="));
    let scene = PairScene::from_toml_str(USER_PAIR, "user_pair").unwrap();
    for (gear, z, bore) in [(&scene.pinion, 25.0, 0.010), (&scene.gear, 40.0, 0.015)] {
        let (base, inertia, _) = by_hand(z, bore);
        assert!(rel(gear.base_radius, base) < 1e-15, "{gear:?} r_b {base}");
        assert!(rel(gear.inertia, inertia) < 1e-14, "{gear:?} J {inertia}");
    }
    // The numbers of the example's header comment.
    assert!((scene.pinion.base_radius - 0.035238).abs() < 5e-7);
    assert!((scene.gear.base_radius - 0.056382).abs() < 5e-7);
    assert!((scene.pinion.inertia - 4.8522e-4).abs() < 5e-8);
    assert!((scene.gear.inertia - 3.1836e-3).abs() < 5e-7);
    // Equivalent mass from the derived bodies, m_e = 1/(r_b1²/J1 + r_b2²/J2).
    let (b1, j1, _) = by_hand(25.0, 0.010);
    let (b2, j2, _) = by_hand(40.0, 0.015);
    let m_e = 1.0 / (b1 * b1 / j1 + b2 * b2 / j2);
    assert!(rel(scene.equivalent_mass(), m_e) < 1e-14);
}

#[test]
fn derived_inertia_reproduces_ross() {
    // ROSS (ross-rotordynamics 2.3.0, GearElementTVMS.Ip) gives 0.0036024860 kg·m² for the
    // 62-tooth, m = 2 mm, L = 20 mm, bore 17.5 mm gear at ρ = 7810 kg/m³ (fmu/geometry_pair):
    // the same disc between bore and pitch circle.
    let text = GEOMETRY_PAIR
        .replace("base_radius = 0.0582609393\ninertia = 0.0036024860\n", "")
        .replace(
            "poisson_ratio = 0.2993\n",
            "poisson_ratio = 0.2993\ndensity = 7810.0\n",
        );
    assert!(!text.contains("inertia ="));
    let scene = PairScene::from_toml_str(&text, "t").unwrap();
    for g in [&scene.pinion, &scene.gear] {
        eprintln!(
            "derived inertia {} kg·m² vs ROSS 0.0036024860: relative {:.1e}",
            g.inertia,
            rel(g.inertia, 0.0036024860)
        );
        assert!(rel(g.inertia, 0.0036024860) < 1e-8, "{}", g.inertia);
        assert!(rel(g.base_radius, 0.062 * 20f64.to_radians().cos()) < 1e-15);
    }
    // Given values win: the shipped scene (rounded r_b, ROSS inertia) is unchanged.
    let shipped = PairScene::from_toml_str(GEOMETRY_PAIR, "t").unwrap();
    assert_eq!(shipped.pinion.base_radius, 0.0582609393);
    assert_eq!(shipped.pinion.inertia, 0.0036024860);
}

#[test]
fn steel_preset_is_iso_6336_steel_and_explicit_values_override_it() {
    let gears = |pinion: &str| {
        format!(
            "module = 0.003\npressure_angle = 20.0\nface_width = 0.02\n\
             [pinion]\nteeth = 25\nbore_radius = 0.01\n{pinion}\n\
             [gear]\nteeth = 40\nbore_radius = 0.015\nmaterial = \"steel\"\n"
        )
    };
    let model = |pinion: &str| {
        let spec = parse_gears_file(&gears(pinion), "g").unwrap();
        MeshModel::new(&spec, "").map_err(|e| e.to_string())
    };
    let steel = model("material = \"steel\"").unwrap();
    let p = &steel.pair.pinion;
    // ISO 6336-2 elasticity factor of steel on steel, Z_E = √(E/(2π(1 − ν²))) = 189.8 √(N/mm²).
    let z_e = (p.e / 1e6 / (2.0 * PI * (1.0 - p.nu * p.nu))).sqrt();
    assert!((z_e - 189.8).abs() < 0.05, "Z_E = {z_e}");
    assert_eq!((p.e, p.nu, p.density), (206e9, 0.3, Some(7850.0)));
    let over = model("material = \"steel\"\nyoungs_modulus = 2.1e11\ndensity = 7800.0").unwrap();
    let q = &over.pair.pinion;
    assert_eq!((q.e, q.nu, q.density), (2.1e11, 0.3, Some(7800.0)));
    // Without a material, E and ν are required and there is no density (no derived inertia).
    let plain = model("youngs_modulus = 2.06e11\npoisson_ratio = 0.3").unwrap();
    assert_eq!(plain.pair.pinion.density, None);
    assert_eq!(plain.pair.pinion.inertia(), None);
    // Unknown material: named, with the known ones.
    let msg = model("material = \"unobtainium\"").unwrap_err();
    assert!(
        msg.contains("pinion.material = \"unobtainium\"") && msg.contains("known: \"steel\""),
        "{msg}"
    );
    let msg = model("poisson_ratio = 0.3").unwrap_err();
    assert!(
        msg.contains("pinion.youngs_modulus: missing") && msg.contains("\"steel\""),
        "{msg}"
    );
    let msg = model("material = \"steel\"\ndensity = -7850.0").unwrap_err();
    assert!(msg.contains("pinion.density = -7850"), "{msg}");
    let msg = model("material = \"steel\"\npoisson_ratio = 0.6").unwrap_err();
    assert!(msg.contains("pinion.poisson_ratio = 0.6"), "{msg}");
}

#[test]
fn bad_gear_data_in_scenes_is_rejected_with_field_and_value() {
    // A base radius that is not the geometry's.
    let text = USER_PAIR.replace("teeth = 25\n\n", "teeth = 25\nbase_radius = 0.0353\n\n");
    let msg = pair_err(&text);
    assert!(
        msg.contains("gear[0].base_radius = 0.0353")
            && msg.contains("0.0352384")
            && msg.contains("mesh.stiffness.geometry.pinion"),
        "{msg}"
    );
    // Within the tolerance, a rounded radius is kept as given.
    let text = USER_PAIR.replace("teeth = 25\n\n", "teeth = 25\nbase_radius = 0.035238\n\n");
    assert_eq!(
        PairScene::from_toml_str(&text, "t")
            .unwrap()
            .pinion
            .base_radius,
        0.035238
    );
    // No density anywhere: the inertia cannot be derived.
    let text = USER_PAIR.replacen(
        "material = \"steel\"         # E = 206 GPa, ν = 0.3, ρ = 7850 kg/m³",
        "youngs_modulus = 2.06e11\npoisson_ratio = 0.3",
        1,
    );
    let msg = pair_err(&text);
    assert!(
        msg.contains("gear[0].inertia: missing") && msg.contains("mesh.stiffness.geometry.pinion"),
        "{msg}"
    );
    // Unknown material in a scene.
    let msg = pair_err(&USER_PAIR.replacen("material = \"steel\"", "material = \"stell\"", 1));
    assert!(
        msg.contains("mesh.stiffness.geometry.pinion.material = \"stell\"")
            && msg.contains("\"steel\""),
        "{msg}"
    );
    // Without a geometry stiffness nothing is derivable.
    let text = "name = \"p\"\n[[gear]]\nname = \"a\"\nteeth = 20\ninertia = 1e-3\n\
                [[gear]]\nname = \"b\"\nteeth = 20\nbase_radius = 0.03\ninertia = 1e-3\n\
                [mesh]\npinion = \"a\"\ngear = \"b\"\ncontact = \"linear\"\n\
                [mesh.stiffness]\nkind = \"constant\"\nvalue = 1e8\n\
                [operating]\npinion_speed = 100.0\ninput_torque = 10.0\n";
    let msg = pair_err(text);
    assert!(msg.contains("gear[0].base_radius: missing"), "{msg}");
    let msg = pair_err(&text.replacen(
        "teeth = 20\ninertia = 1e-3\n",
        "teeth = 20\nbase_radius = 0.03\n",
        1,
    ));
    assert!(msg.contains("gear[0].inertia: missing"), "{msg}");
    let msg = pair_err(&text.replace(
        "teeth = 20\ninertia",
        "teeth = 20\nbase_radius = -0.03\ninertia",
    ));
    assert!(msg.contains("gear[0].base_radius = -0.03"), "{msg}");
}

/// The user's pair as a drivetrain, followed by a 25-tooth gear: `pinion → idler → output`,
/// both meshes from geometry, bearings as `bearings` says.
fn idler_train(bearings: &str) -> String {
    let geometry = |z1: i64, b1: f64, z2: i64, b2: f64| {
        format!(
            "[mesh.stiffness]\nkind = \"geometry\"\n\
             [mesh.stiffness.geometry]\nmodule = 0.003\npressure_angle = 20.0\nface_width = 0.02\n\
             [mesh.stiffness.geometry.pinion]\nteeth = {z1}\nbore_radius = {b1:?}\nmaterial = \"steel\"\n\
             [mesh.stiffness.geometry.gear]\nteeth = {z2}\nbore_radius = {b2:?}\nmaterial = \"steel\"\n"
        )
    };
    format!(
        "name = \"geometry_idler\"\n[model]\nbearings = \"{bearings}\"\n\
         [[gear]]\nname = \"pinion\"\nteeth = 25\n\
         [[gear]]\nname = \"idler\"\nteeth = 40\nbearing_stiffness = [5e8, 5e8]\n\
         [[gear]]\nname = \"output\"\nteeth = 25\n\
         [[mesh]]\npinion = \"pinion\"\ngear = \"idler\"\ncontact = \"contact_loss\"\n\
         damping_ratio = 0.05\npressure_angle = 20.0\ncentre_angle = 0.0\n{}\
         [[mesh]]\npinion = \"idler\"\ngear = \"output\"\ncontact = \"contact_loss\"\n\
         damping_ratio = 0.05\ncentre_angle = 1.0\n{}\
         [operating]\ninput_speed = 314.1592653589793\ninput_torque = 150.0\n\
         [solver]\nmethod = \"rk\"\n",
        geometry(25, 0.010, 40, 0.015),
        geometry(40, 0.015, 25, 0.010),
    )
}

#[test]
fn drivetrain_geometry_mesh_equals_the_single_pair_geometry_stiffness() {
    // The user's pair read as a one-mesh drivetrain: same bodies, same stiffness.
    let pair = PairScene::from_toml_str(USER_PAIR, "p").unwrap();
    let train = Scene::from_toml_str(USER_PAIR, "t").unwrap();
    assert_eq!(train.gears[0].base_radius, pair.pinion.base_radius);
    assert_eq!(train.gears[1].inertia, pair.gear.inertia);
    assert_eq!(train.meshes[0].mean_stiffness(), pair.mesh.stiffness.mean());

    // Two geometry meshes: the second carries the idler's torque T·r_b,idler/r_b,pinion =
    // 150·40/25 = 240 N·m, so it equals the single pair 40/25 computed at torque = 240.
    let train = Scene::from_toml_str(&idler_train("compliant"), "t").unwrap();
    let single = |z1: i64, b1: f64, z2: i64, b2: f64, torque: &str| {
        let text = USER_PAIR
            .replace("teeth = 25\n", "teeth = Z1\n")
            .replace("teeth = 40\n", "teeth = Z2\n")
            .replace("Z1", &z1.to_string())
            .replace("Z2", &z2.to_string())
            .replace("bore_radius = 0.010 ", &format!("bore_radius = {b1:?} "))
            .replace("bore_radius = 0.015\n", &format!("bore_radius = {b2:?}\n"))
            .replace(
                "kind = \"geometry\"",
                &format!("kind = \"geometry\"\n{torque}"),
            );
        PairScene::from_toml_str(&text, "p").unwrap()
    };
    let first = single(25, 0.010, 40, 0.015, "");
    let second = single(40, 0.015, 25, 0.010, "torque = 240.0");
    assert_eq!(second.pinion.teeth, 40);
    assert_eq!(
        train.meshes[0].mean_stiffness(),
        first.mesh.stiffness.mean()
    );
    let k2 = train.meshes[1].mean_stiffness();
    assert!(rel(k2, second.mesh.stiffness.mean()) < 1e-12, "{k2}");
    // The load dependence is visible: at the input torque the 40/25 mesh is softer.
    let at_150 = single(40, 0.015, 25, 0.010, "torque = 150.0");
    assert!(at_150.mesh.stiffness.mean() < k2);
    // Bodies derived from the geometry, the idler's mass for its bearings included.
    let (b40, j40, m40) = by_hand(40.0, 0.015);
    let (b25, j25, _) = by_hand(25.0, 0.010);
    let idler = &train.gears[1];
    assert!(rel(idler.base_radius, b40) < 1e-15 && rel(idler.inertia, j40) < 1e-14);
    assert!(rel(idler.mass.unwrap(), m40) < 1e-14, "{:?}", idler.mass);
    assert!(rel(train.gears[2].base_radius, b25) < 1e-15);
    assert!(rel(train.gears[2].inertia, j25) < 1e-14);
    assert_eq!(train.gears[0].mass, None); // no bearing, no mass needed
                                           // Mesh 1 gives pressure_angle = 20.0 (degrees); mesh 2 takes the geometry's working
                                           // pressure angle, which for unshifted gears is the rack's 20°.
    assert_eq!(train.meshes[0].pressure_angle, 20f64.to_radians());
    assert!(rel(train.meshes[1].pressure_angle, 20f64.to_radians()) < 1e-14);
    let msg = train_err(&idler_train("compliant").replacen(
        "pressure_angle = 20.0\ncentre_angle",
        "pressure_angle = 25.0\ncentre_angle",
        1,
    ));
    assert!(
        msg.contains("mesh[0].pressure_angle = 25")
            && msg.contains("working pressure angle 20")
            && msg.contains("mesh[0].stiffness.geometry"),
        "{msg}"
    );
    // Bad data inside a drivetrain geometry mesh is located in that mesh.
    let msg = train_err(&idler_train("compliant").replacen(
        "bore_radius = 0.015\nmaterial = \"steel\"",
        "bore_radius = 0.015\nmaterial = \"brass\"",
        2,
    ));
    assert!(
        msg.contains("mesh[1].stiffness.geometry.pinion.material = \"brass\"")
            || msg.contains("mesh[0].stiffness.geometry.gear.material = \"brass\""),
        "{msg}"
    );
    // The second mesh's gears must be the geometry's: teeth, and a given base radius.
    let text = idler_train("compliant").replace(
        "name = \"output\"\nteeth = 25",
        "name = \"output\"\nteeth = 26",
    );
    let msg = train_err(&text);
    // The geometry names the gear that disagrees with it, before the base pitches are compared
    // (as in a single-pair scene: one mesh validation).
    assert!(
        msg.contains("mesh[1].gear (\"output\").teeth = 26")
            && msg.contains("mesh[1].stiffness.geometry.gear.teeth = 25"),
        "{msg}"
    );
    let text = idler_train("compliant").replace(
        "name = \"output\"\nteeth = 25",
        "name = \"output\"\nteeth = 25\nbase_radius = 0.0366",
    );
    let msg = train_err(&text);
    assert!(
        msg.contains("gear[2].base_radius = 0.0366")
            && msg.contains("mesh[1].stiffness.geometry.gear"),
        "{msg}"
    );
}

#[test]
fn drivetrain_with_geometry_meshes_runs() {
    let scene = Scene::from_toml_str(&idler_train("compliant"), "t").unwrap();
    let mut sim = TrainSimulation::new(&scene).unwrap();
    let names = sim.output_names().to_vec();
    let col = |n: &str| names.iter().position(|x| x == n).unwrap();
    let (f1, f2) = (col("mesh1.force"), col("mesh2.force"));
    // 196 mesh periods at 1250 Hz, sampled 20.37 times per period: a rate incommensurate
    // with the mesh, so that the sample mean of the jumping mesh force is not biased by
    // aliased harmonics (at exactly 20 samples per period the bias is 1.5 %).
    let mut out = Vec::new();
    let (mut sum1, mut sum2, mut n) = (0.0, 0.0, 0.0);
    for k in 1..=4000 {
        sim.advance_to(k as f64 / (20.37 * 1250.0)).unwrap();
        sim.outputs(&mut out);
        assert!(out.iter().all(|v| v.is_finite()), "{out:?}");
        if k > 2000 {
            sum1 += out[f1];
            sum2 += out[f2];
            n += 1.0;
        }
    }
    // Both meshes carry the static force T/r_b,pinion = 150/0.035238 N on average (the idler
    // passes it on; torque balance of the pinion over a steady response): 1.0e-4 measured
    // over the second half.
    let force = 150.0 / by_hand(25.0, 0.010).0;
    for mean in [sum1 / n, sum2 / n] {
        assert!(rel(mean, force) < 5e-4, "mean force {mean} vs {force}");
    }
}
