//! The schema read back: units, bounds, defaults, descriptions and choices as the spec types
//! declare them, and paths as users and messages write them.

use super::*;

fn scene(text: &str) -> toml::Table {
    text.parse().unwrap()
}

#[test]
fn defaults_units_and_bounds_of_solver_fields() {
    let atol = describe("solver.atol", None).unwrap();
    assert_eq!(atol.kind, "number");
    assert_eq!(atol.default.and_then(Value::as_f64), Some(1e-15));
    assert_eq!(atol.bounds.to_string(), "> 0");
    assert!(!atol.required);
    let rtol = describe("solver.rtol", None).unwrap();
    assert_eq!(rtol.bounds.to_string(), "> 0 and < 1");
    assert_eq!(rtol.unit, Some("1"));
    let memory = describe("solver.exact_memory_mb", None).unwrap();
    assert_eq!(memory.default.and_then(Value::as_f64), Some(512.0));
    assert_eq!(memory.bounds.to_string(), ">= 1 and <= 1048576");
    let method = describe("solver.method", None).unwrap();
    assert_eq!(method.kind, "string");
    assert_eq!(method.choices, ["auto", "exact", "rk"]);
    assert_eq!(method.default.and_then(Value::as_str), Some("auto"));
}

#[test]
fn lists_of_tables_and_pairs_take_indices_and_the_single_mesh_form() {
    let teeth = describe("gear[3].teeth", None).unwrap();
    assert_eq!(teeth.kind, "integer");
    assert_eq!(teeth.bounds.to_string(), ">= 1 and <= 100000");
    assert!(teeth.required);
    assert_eq!(teeth.description, "Number of teeth.");
    let k = describe("gear[0].bearing_stiffness[1]", None).unwrap();
    assert_eq!((k.kind, k.unit), ("number", Some("N/m")));
    assert_eq!(k.bounds.to_string(), "> 0");
    let c = describe("gear[0].bearing_damping[x]", None).unwrap();
    assert_eq!(c.bounds.to_string(), ">= 0");
    // `mesh.damping` of a single-mesh file and `mesh[1].damping` of a drivetrain.
    for path in ["mesh.damping", "mesh[1].damping"] {
        let d = describe(path, None).unwrap();
        assert_eq!(
            (d.unit, d.bounds.to_string().as_str()),
            (Some("N.s/m"), ">= 0")
        );
    }
}

#[test]
fn a_tagged_table_is_read_in_the_form_the_scene_chose() {
    let s = scene(
        "[mesh]\ncontact = \"linear\"\n[mesh.stiffness]\nkind = \"trapezoidal\"\nmean = 2e8\n\
         peak_to_peak_ratio = 0.3\ncontact_ratio = 1.6\ntransition = 0.05\n",
    );
    let t = describe("mesh.stiffness.transition", Some(&s)).unwrap();
    assert_eq!(t.value.and_then(|v| v.as_float()), Some(0.05));
    assert_eq!(
        (t.unit, t.bounds.to_string().as_str()),
        (Some("cycles"), "> 0")
    );
    let kind = describe("mesh.stiffness.kind", Some(&s)).unwrap();
    assert_eq!(
        kind.value.as_ref().and_then(|v| v.as_str()),
        Some("trapezoidal")
    );
    for k in [
        "constant",
        "rectangular",
        "trapezoidal",
        "fourier",
        "table",
        "geometry",
    ] {
        assert!(
            kind.choices.iter().any(|c| c == k),
            "{k} in {:?}",
            kind.choices
        );
    }
    // A key of another form is not this scene's.
    let fourier = scene("[mesh.stiffness]\nkind = \"fourier\"\nmean = 2e8\n");
    let err = describe("mesh.stiffness.transition", Some(&fourier)).unwrap_err();
    assert!(
        err.contains("'mesh.stiffness' has no key 'transition'"),
        "{err}"
    );
}

#[test]
fn values_come_from_the_scene_under_either_spelling_of_the_speed() {
    let s = scene("[operating]\npinion_speed = 471.2\n");
    for path in ["operating.pinion_speed", "operating.input_speed"] {
        let p = describe(path, Some(&s)).unwrap();
        assert_eq!(p.value.and_then(|v| v.as_float()), Some(471.2), "{path}");
        assert_eq!(p.unit, Some("rad/s"));
        assert_eq!(p.bounds.to_string(), ">= 0");
    }
}

#[test]
fn enums_and_element_tables_are_described() {
    let contact = describe("mesh.contact", None).unwrap();
    assert_eq!(contact.choices, ["linear", "contact_loss", "backlash"]);
    assert!(contact.description.starts_with("Contact law"));
    let j = describe("motor[0].inertia", None).unwrap();
    assert_eq!(
        (j.unit, j.bounds.to_string().as_str()),
        (Some("kg.m^2"), "> 0")
    );
    assert!(describe("motor[0].name", None).unwrap().required);
    let f = describe("motor[0].torque_fraction", None).unwrap();
    assert_eq!(f.bounds.to_string(), ">= 0 and <= 1");
    assert_eq!(f.default.and_then(Value::as_f64), Some(1.0));
}

#[test]
fn unknown_keys_and_bad_paths_are_named() {
    let e = describe("solver.atoll", None).unwrap_err();
    assert!(
        e.contains("'solver' has no key 'atoll'") && e.contains("atol"),
        "{e}"
    );
    let e = describe("nope", None).unwrap_err();
    assert!(e.contains("the scene has no key 'nope'"), "{e}");
    let e = describe("gear[a].teeth", None).unwrap_err();
    assert!(e.contains("index 'a'"), "{e}");
    let e = describe("solver.atol.x", None).unwrap_err();
    assert!(e.contains("'solver.atol' is not a table"), "{e}");
    assert!(bounds_of("gear[0].name")
        .unwrap_err()
        .contains("not a number"));
}

#[test]
fn bounds_contain_what_they_say() {
    let b = describe("solver.rtol", None).unwrap().bounds;
    assert!(b.contains(1e-9) && !b.contains(0.0) && !b.contains(1.0) && !b.contains(f64::NAN));
    let open = Bounds::default();
    assert!(open.is_open() && open.contains(-1e300) && !open.contains(f64::INFINITY));
}
