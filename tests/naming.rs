//! One naming convention (issue 18, `docs/fmu.md` "Names"): every output of every shipped FMU
//! and every native CSV column is `<owner>.<quantity>` with an owner the scene defines, every
//! parameter and input is a key path of the scene (the one local, the announced switch time,
//! beside the solver settings), and the FMU output of a quantity is the
//! native column of it, so no name mapping is needed between them anywhere.
//!
//! The owner sets are read from the scene files here with the `toml` crate, independently of
//! the code that builds the names.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use geardyn::commands::simulate::{simulate, SimulateOptions};
use geardyn::host::description::{parse, Causality};
use geardyn::scene::Scene;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The shipped scenes: every `fmu/<name>/scene.toml`.
fn shipped() -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(root().join("fmu"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.join("scene.toml").exists())
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// A name segment: lower-case ASCII word (`mesh1`, `dte_rate`, `pair0`, `flange_a`).
fn is_word(s: &str) -> bool {
    let mut b = s.bytes();
    b.next().is_some_and(|c| c.is_ascii_lowercase())
        && b.all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == b'_')
}

/// `^[a-z][a-z0-9_]*(\.[a-z][a-z0-9_]*)+$`: at least an owner and a quantity.
fn is_dotted(name: &str) -> bool {
    let parts: Vec<&str> = name.split('.').collect();
    parts.len() >= 2 && parts.iter().all(|p| is_word(p))
}

/// What a scene names, from its TOML: owners of outputs and roots of parameter key paths.
struct SceneNames {
    owners: BTreeSet<String>,
    /// First segments of parameter and input names: tables of the file and named items.
    roots: BTreeSet<String>,
    /// An element scene's own `[element]` keys (its parameters are written relative to it).
    element_keys: BTreeSet<String>,
}

fn scene_names(folder: &Path) -> SceneNames {
    let text = std::fs::read_to_string(folder.join("scene.toml")).unwrap();
    let doc: toml::Table = text.parse().unwrap();
    let names_of = |key: &str| -> Vec<String> {
        doc.get(key)
            .and_then(|v| v.as_array())
            .map(|a| {
                a.iter()
                    .filter_map(|t| t.get("name").and_then(|n| n.as_str()).map(String::from))
                    .collect()
            })
            .unwrap_or_default()
    };
    let mut owners = BTreeSet::new();
    let mut roots: BTreeSet<String> = doc.keys().cloned().collect();
    let mut element_keys = BTreeSet::new();
    if let Some(element) = doc.get("element").and_then(|e| e.as_table()) {
        // The element FMU's one element is named by its kind; its ports are flanges.
        owners.insert(element["kind"].as_str().unwrap().to_string());
        owners.extend(["flange", "flange_a", "flange_b"].map(String::from));
        roots.extend(["flange", "flange_a", "flange_b"].map(String::from));
        element_keys.extend(element.keys().cloned());
    } else if doc.contains_key("mesh") && doc["mesh"].is_array() {
        // A drivetrain: meshes default to mesh1, mesh2, … (docs/train.md).
        let meshes = doc["mesh"].as_array().unwrap();
        for (n, m) in meshes.iter().enumerate() {
            let name = m
                .get("name")
                .and_then(|v| v.as_str())
                .map_or(format!("mesh{}", n + 1), String::from);
            owners.insert(name);
        }
        owners.extend(names_of("gear"));
        // A planetary stage's carrier is a body of its own (`[[carrier]]`, docs/planetary.md).
        owners.extend(names_of("carrier"));
        owners.extend(names_of("port"));
        // `[model]` has defaults: its keys are parameters whether or not the file has it.
        roots.insert("model".to_string());
    } else {
        // A single mesh: its one mesh is `mesh`, its gears `pinion` and `gear`.
        owners.extend(["mesh", "pinion", "gear"].map(String::from));
    }
    roots.extend(owners.iter().cloned());
    if !doc.contains_key("element") {
        // Tables of the format with defaults: keys whether or not the file writes them.
        roots.extend(["initial", "operating"].map(String::from));
    }
    SceneNames {
        owners,
        roots,
        element_keys,
    }
}

/// The reasons `name` breaks the rule for its causality (empty when it follows it).
fn check(name: &str, causality: Causality, names: &SceneNames) -> Option<String> {
    match causality {
        Causality::Output => {
            if !is_dotted(name) {
                return Some(format!("output '{name}' is not <owner>.<quantity>"));
            }
            let owner = name.split('.').next().unwrap();
            (!names.owners.contains(owner)).then(|| {
                format!(
                    "output '{name}': owner '{owner}' is none of the scene's {:?}",
                    names.owners
                )
            })
        }
        Causality::Parameter | Causality::CalculatedParameter | Causality::Input => {
            let first = name.split('.').next().unwrap();
            let relative = names.element_keys.contains(first);
            let ok = name.split('.').all(is_word)
                && (names.roots.contains(first) && is_dotted(name) || relative);
            (!ok).then(|| format!("{causality:?} '{name}' is not a key path of the scene"))
        }
        Causality::Independent => (name != "time").then(|| format!("independent '{name}'")),
        // The announced switch time, beside the solver settings (docs/fmu.md "Names").
        Causality::Local => (name != geardyn::fmu::adapter::NEXT_SWITCH_TIME)
            .then(|| format!("local '{name}' in a shipped FMU")),
    }
}

#[test]
fn every_shipped_fmu_variable_follows_the_convention() {
    let mut problems = Vec::new();
    let mut checked = 0;
    for name in shipped() {
        let folder = root().join("fmu").join(&name);
        let names = scene_names(&folder);
        let file = root().join("modelDescription").join(format!("{name}.xml"));
        let md = parse(&std::fs::read_to_string(&file).unwrap(), &name).unwrap();
        for v in &md.variables {
            checked += 1;
            if let Some(p) = check(&v.name, v.causality, &names) {
                problems.push(format!("{name}: {p}"));
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    println!(
        "{checked} variables of {} FMUs follow the convention",
        shipped().len()
    );
}

#[test]
fn the_checker_refuses_the_old_names() {
    // Oracle for the check itself: the names the FMUs had before the rename must fail it.
    let pair = scene_names(&root().join("fmu/spur_pair"));
    let train = scene_names(&root().join("fmu/idler_gearset"));
    let motor = scene_names(&root().join("fmu/emotor"));
    for (old, causality, names) in [
        ("dte", Causality::Output, &pair),
        ("mesh_force", Causality::Output, &pair),
        ("pinion_speed", Causality::Input, &pair),
        ("mesh1_dte", Causality::Output, &train),
        ("mesh1_pair0_force", Causality::Output, &train),
        ("idler_x", Causality::Output, &train),
        ("input_speed", Causality::Input, &train),
        ("electric_torque", Causality::Output, &motor),
        ("speed_reference", Causality::Input, &motor),
        ("bogus.dte", Causality::Output, &train),
    ] {
        assert!(check(old, causality, names).is_some(), "'{old}' passed");
    }
    for (new, causality, names) in [
        ("mesh.dte", Causality::Output, &pair),
        ("operating.pinion_speed", Causality::Input, &pair),
        ("mesh1.pair0.force", Causality::Output, &train),
        ("idler.x", Causality::Output, &train),
        ("motor.electric_torque", Causality::Output, &motor),
        ("controller.speed_reference", Causality::Input, &motor),
        ("inertia", Causality::Parameter, &motor),
    ] {
        assert_eq!(check(new, causality, names), None, "'{new}'");
    }
}

/// The outputs of an FMU in value-reference order (the order of the native columns).
fn fmu_outputs(name: &str) -> Vec<String> {
    let file = root().join("modelDescription").join(format!("{name}.xml"));
    let md = parse(&std::fs::read_to_string(&file).unwrap(), name).unwrap();
    let mut out: Vec<_> = md
        .variables
        .iter()
        .filter(|v| v.causality == Causality::Output)
        .map(|v| (v.value_reference, v.name.clone()))
        .collect();
    out.sort();
    out.into_iter().map(|(_, n)| n).collect()
}

#[test]
fn fmu_outputs_are_the_native_csv_columns() {
    let dir = std::env::temp_dir().join(format!("geardyn-naming-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for name in shipped() {
        let folder = root().join("fmu").join(&name);
        let reference = std::fs::read_to_string(folder.join("reference.csv")).unwrap();
        let header = reference.lines().next().unwrap().to_string();
        let expected = format!("time,{}", fmu_outputs(&name).join(","));
        // The reference (native run, or the FMU model for the element scenes) has the FMU's
        // names; the native `simulate` writes them where it runs the scene.
        assert_eq!(header, expected, "{name}: reference.csv header");
        let text = std::fs::read_to_string(folder.join("scene.toml")).unwrap();
        if text.contains("[element]") {
            continue;
        }
        let out = dir.join(format!("{name}.csv"));
        let options = SimulateOptions {
            stop_time: Some(1e-4),
            ..SimulateOptions::default()
        };
        simulate(Scene::from_path(&folder).unwrap(), &options, &out).unwrap();
        let native = std::fs::read_to_string(&out).unwrap();
        assert_eq!(native.lines().next().unwrap(), expected, "{name}: simulate");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn summary_tables_of_a_drivetrain_carry_the_mesh_as_owner() {
    let prefixes = ["mesh1.".to_string(), "mesh2.".to_string()];
    for (command, columns, per_mesh) in [
        (
            "sweep",
            geardyn::analysis::sweep::sweep_columns(&prefixes),
            &geardyn::analysis::sweep::MESH_COLUMNS[..],
        ),
        (
            "hb",
            geardyn::commands::hb::hb_columns(&prefixes),
            &geardyn::commands::hb::HB_MESH_COLUMNS[..],
        ),
    ] {
        for m in ["mesh1", "mesh2"] {
            for q in per_mesh {
                let c = format!("{m}.{q}");
                assert!(columns.contains(&c), "{command}: no '{c}' in {columns:?}");
            }
        }
        assert!(
            !columns
                .iter()
                .any(|c| c.starts_with("mesh1_") || c.starts_with("mesh2_")),
            "{command}: {columns:?}"
        );
    }
}
