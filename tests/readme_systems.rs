//! The README's "co-simulate a drivetrain of FMUs" commands on a fresh checkout (issue 39):
//! no `out/fmus` yet, so `geardyn run` must build the FMUs of the shipped system from their
//! scenes under `fmu/` and say so. The commands are read from the README row itself, so the
//! test follows the README.

use std::path::{Path, PathBuf};
use std::process::Command;

#[path = "common/files.rs"]
mod files;

use files::copy_dir;

const BIN: &str = env!("CARGO_BIN_EXE_geardyn");
const ROW: &str = "| co-simulate a drivetrain of FMUs (SSP) |";

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// A fresh checkout as far as these commands can tell: the shipped scenes and systems, no
/// `out/`.
fn fresh_checkout(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("readme_systems")
        .join(name);
    let _ = std::fs::remove_dir_all(&d);
    copy_dir(&repo().join("fmu"), &d.join("fmu"));
    copy_dir(
        &repo().join("examples/systems"),
        &d.join("examples/systems"),
    );
    d
}

/// The `geardyn run …` commands in backticks of the README row.
fn readme_commands() -> Vec<Vec<String>> {
    let readme = std::fs::read_to_string(repo().join("README.md")).unwrap();
    let row = readme
        .lines()
        .find(|l| l.starts_with(ROW))
        .unwrap_or_else(|| panic!("README.md has no row {ROW}"));
    let commands: Vec<Vec<String>> = row
        .split('`')
        .skip(1)
        .step_by(2)
        .filter(|c| c.starts_with("geardyn run "))
        .map(|c| c.split_whitespace().skip(1).map(String::from).collect())
        .collect();
    assert!(commands.len() >= 2, "{row}");
    commands
}

#[test]
fn the_readme_system_commands_work_on_a_fresh_checkout() {
    let root = fresh_checkout("fresh");
    let mut built = Vec::new();
    for args in readme_commands() {
        assert!(!root.join("d.csv").exists() || std::fs::remove_file(root.join("d.csv")).is_ok());
        let o = Command::new(BIN)
            .args(&args)
            .current_dir(&root)
            .output()
            .unwrap();
        let e = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "geardyn {}: {e}", args.join(" "));
        for line in e.lines() {
            let line = line
                .strip_prefix("note: ")
                .unwrap_or_else(|| panic!("geardyn {}: {e}", args.join(" ")));
            if let Some((fmu, _)) =
                line.split_once(" did not exist: built it from the shipped scene ")
            {
                built.push(fmu.to_string());
            }
        }
        let out = args
            .iter()
            .position(|a| a == "--out")
            .map(|i| root.join(&args[i + 1]))
            .expect("the README commands write a CSV");
        let text = std::fs::read_to_string(&out).unwrap();
        // The shipped systems' DefaultExperiment: 0.01 s at the default interval (fmpy's
        // rule: the smallest of the FMUs' defaults), one header and at least 100 rows.
        let rows = text.lines().count() - 1;
        assert!(rows > 100, "{rows} rows");
        let last: f64 = text
            .lines()
            .last()
            .unwrap()
            .split(',')
            .next()
            .unwrap()
            .parse()
            .unwrap();
        assert_eq!(last, 0.01);
    }
    // Each FMU was built once, on its first use, into out/fmus as scripts/build-fmus.sh does.
    built.sort();
    assert_eq!(
        built,
        [
            "out/fmus/emotor.fmu",
            "out/fmus/planetary_stage.fmu",
            "out/fmus/shaft_in.fmu",
            "out/fmus/shaft_out.fmu",
            "out/fmus/spur_stage.fmu",
            "out/fmus/spur_stage_speed.fmu",
            "out/fmus/vehicle_load.fmu"
        ]
    );
    for f in &built {
        assert!(root.join(f).is_file(), "{f}");
    }
}

/// A missing FMU that cannot be built (no scene of that name) is an error naming the
/// component, the source and the command that builds a geardyn FMU.
#[test]
fn a_missing_fmu_without_a_scene_names_the_build_command() {
    let root = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("readme_systems")
        .join("no_scenes");
    let _ = std::fs::remove_dir_all(&root);
    copy_dir(
        &repo().join("examples/systems/drivetrain3"),
        &root.join("examples/systems/x"),
    );
    let o = Command::new(BIN)
        .args(["run", "examples/systems/x"])
        .current_dir(&root)
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(
        e.contains("component \"motor\": its FMU source=\"../../../out/fmus/emotor.fmu\" is not in the folder examples/systems/x")
            && e.contains("`geardyn fmu build <scene folder> --out <folder>`"),
        "{e}"
    );
}
