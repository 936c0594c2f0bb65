//! Issue 2, acceptance 7: `geardyn simulate` on bad input exits non-zero with a message that
//! names the field and the value, and leaves no CSV behind; and the happy path writes the
//! documented CSV and summary.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const SPUR_PAIR: &str = include_str!("../fmu/spur_pair/scene.toml");

fn geardyn(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_geardyn"))
        .args(args)
        .output()
        .expect("run geardyn")
}

/// A fresh folder under the target directory (no temp-dir crate needed).
fn workdir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("cli-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Writes `scene` and runs `simulate` on it; asserts failure, that stderr contains every
/// `needle`, and that no output file (or temporary) is left.
fn expect_rejected(name: &str, scene: Option<&str>, needles: &[&str]) {
    let dir = workdir(name);
    let path = dir.join("scene.toml");
    if let Some(text) = scene {
        std::fs::write(&path, text).unwrap();
    }
    let out = dir.join("out.csv");
    let o = geardyn(&[
        "simulate",
        path.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    println!("{name}: {stderr}");
    assert!(!o.status.success(), "{name}: expected failure");
    for needle in needles {
        assert!(
            stderr.contains(needle),
            "{name}: '{needle}' not in: {stderr}"
        );
    }
    let left: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|f| f != "scene.toml")
        .collect();
    assert!(left.is_empty(), "{name}: files left behind: {left:?}");
}

fn edited(from: &str, to: &str) -> String {
    assert!(SPUR_PAIR.contains(from), "template lacks '{from}'");
    SPUR_PAIR.replacen(from, to, 1)
}

#[test]
fn missing_file() {
    expect_rejected("missing", None, &["cannot read scene file", "scene.toml"]);
}

#[test]
fn toml_syntax_error_has_line_and_column() {
    let text = edited("[mesh]\n", "[mesh\n");
    expect_rejected("syntax", Some(&text), &["line 28, column", "expected"]);
}

#[test]
fn unknown_key() {
    let text = edited("inertia = 0.002621", "inertia = 0.002621\ncolour = \"red\"");
    expect_rejected(
        "unknown",
        Some(&text),
        &["unknown field `colour`", "line 21"],
    );
}

#[test]
fn nan_value() {
    let text = edited("inertia = 0.002621", "inertia = nan");
    expect_rejected("nan", Some(&text), &["gear[0].inertia", "NaN"]);
}

#[test]
fn negative_inertia() {
    let text = edited("inertia = 0.01091", "inertia = -0.01091");
    expect_rejected("inertia", Some(&text), &["gear[1].inertia", "-0.01091"]);
}

#[test]
fn negative_stiffness() {
    let text = edited("mean = 2.9831e8", "mean = -2.9831e8");
    expect_rejected(
        "stiffness",
        Some(&text),
        &["mesh.stiffness.mean", "-298310000"],
    );
}

#[test]
fn contact_ratio_below_one() {
    let text = edited("contact_ratio = 1.504", "contact_ratio = 0.95");
    expect_rejected(
        "ratio",
        Some(&text),
        &["mesh.stiffness.contact_ratio", "0.95"],
    );
}

#[test]
fn negative_backlash() {
    let text = edited("backlash = 1.0e-4", "backlash = -1.0e-4");
    expect_rejected("backlash", Some(&text), &["mesh.backlash", "-0.0001"]);
}

#[test]
fn bad_command_line_values() {
    let dir = workdir("args");
    let out = dir.join("out.csv");
    for (args, needle) in [
        (vec!["--stop-time", "-1"], "--stop-time -1"),
        (vec!["--output-interval", "0"], "--output-interval 0"),
        (vec!["--method", "euler"], "euler"),
        (vec!["--rtol", "NaN"], "--rtol NaN"),
    ] {
        let mut all = vec![
            "simulate",
            "--example",
            "spur_pair",
            "--out",
            out.to_str().unwrap(),
        ];
        all.extend(args);
        let o = geardyn(&all);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{all:?} accepted");
        assert!(stderr.contains(needle), "'{needle}' not in: {stderr}");
        assert!(!out.exists(), "{all:?} left a CSV");
    }
    let o = geardyn(&[
        "simulate",
        "--example",
        "no_such_scene",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("no_such_scene"));
}

#[test]
fn unwritable_output_is_reported_and_leaves_nothing() {
    let dir = workdir("unwritable");
    let out = dir.join("no/such/dir/out.csv");
    let o = geardyn(&[
        "simulate",
        "--example",
        "spur_pair",
        "--out",
        out.to_str().unwrap(),
        "--stop-time",
        "1e-3",
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("out.csv"));
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
}

#[test]
fn example_run_writes_documented_csv() {
    let dir = workdir("ok");
    let out = dir.join("spur_pair.csv");
    let o = geardyn(&[
        "simulate",
        "--example",
        "spur_pair",
        "--out",
        out.to_str().unwrap(),
        "--stop-time",
        "2e-3",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    for needle in [
        "DTE RMS",
        "peak mesh force",
        "contact-loss fraction",
        "steps",
        "events",
    ] {
        assert!(
            stdout.contains(needle),
            "summary lacks '{needle}': {stdout}"
        );
    }
    let csv = std::fs::read_to_string(&out).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "time,mesh.dte,mesh.dte_rate,mesh.force,mesh.contact_state,mesh.phase,mesh.stiffness,mesh.static_deflection"
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 201, "2 ms at 10 µs plus t = 0");
    assert_eq!(rows[200][0], 2e-3);
    // Initial DTE is the static deflection plus e(0) = 1 µm (scene: initial dte = "static").
    let static_deflection = rows[0][7];
    assert!((rows[0][1] - (static_deflection + 1e-6)).abs() < 1e-18);
    assert!(
        (static_deflection - 7.392e-6).abs() < 1e-9,
        "{static_deflection}"
    );
}

#[test]
fn trapezoid_transition_equal_to_the_zone_is_accepted() {
    // f = 1.4 − 1 rounds below 0.4; the zone as written must still be allowed.
    let text = SPUR_PAIR.replacen(
        "kind = \"rectangular\"\nmean = 2.9831e8\npeak_to_peak_ratio = 0.35\ncontact_ratio = 1.504",
        "kind = \"trapezoidal\"\nmean = 2.9831e8\npeak_to_peak_ratio = 0.35\ncontact_ratio = 1.4\ntransition = 0.4",
        1,
    );
    assert!(text.contains("transition = 0.4"));
    geardyn::scene::PairScene::from_toml_str(&text, "t").expect("transition = zone accepted");
    let too_long = text.replacen("transition = 0.4", "transition = 0.4001", 1);
    let err = geardyn::scene::PairScene::from_toml_str(&too_long, "t").unwrap_err();
    assert!(err.to_string().contains("transition = 0.4001"), "{err}");
}
