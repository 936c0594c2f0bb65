//! Issue 17, acceptance 1 (`geardyn simulate`): every failing case of the reliability probe is
//! a regression test here. Each runs the path of `geardyn simulate` (scene file → load →
//! validate → limits → streamed CSV, [`geardyn::commands::simulate::simulate`]) and gets either a
//! message naming the field and its value, with neither the output nor its `.partial` sibling
//! left behind, or (the touching trapezoidal ramps) a result checked against an independent
//! form of the same stiffness.

use std::path::{Path, PathBuf};

use geardyn::commands::simulate::{simulate, AnyScene, SimulateOptions};

const SPUR_PAIR: &str = include_str!("../fmu/spur_pair/scene.toml");
const IDLER: &str = include_str!("../fmu/idler_gearset/scene.toml");
const COUNTERSHAFT: &str = include_str!("../fmu/countershaft_gearset/scene.toml");

/// Replaces `from` (which must occur) in `text`.
fn edit(text: &str, from: &str, to: &str) -> String {
    assert!(text.contains(from), "{from:?} not in the scene");
    text.replacen(from, to, 1)
}

/// Writes `text` as a scene in a fresh folder and runs `simulate` on it.
fn run(text: &str, opts: &SimulateOptions) -> (tempfile::TempDir, PathBuf, Result<(), String>) {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.toml");
    std::fs::write(&scene, text).unwrap();
    let out = dir.path().join("out.csv");
    let result = AnyScene::from_path(&scene).and_then(|s| simulate(s, opts, &out).map(|_| ()));
    (dir, out, result)
}

/// Asserts a refusal whose message holds every piece of `expected`, and nothing left behind.
fn refused(text: &str, opts: &SimulateOptions, expected: &[&str]) -> String {
    let (dir, out, result) = run(text, opts);
    let msg = result.expect_err("the scene must be refused");
    for e in expected {
        assert!(msg.contains(e), "message {msg:?} lacks {e:?}");
    }
    assert_no_output(dir.path(), &out);
    msg
}

/// [`refused`] with the default options.
fn refuses(text: &str, expected: &[&str]) -> String {
    refused(text, &Default::default(), expected)
}

fn assert_no_output(dir: &Path, out: &Path) {
    assert!(!out.exists(), "output left behind");
    let left: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n != "scene.toml")
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}

#[test]
fn tiny_output_interval_is_refused_by_the_row_limit() {
    let scene = edit(
        SPUR_PAIR,
        "output_interval = 1.0e-5",
        "output_interval = 1e-300",
    );
    refuses(&scene, &["output_interval = 1e-300", "rows", "--max-rows"]);
    // The same as a command-line option, and for a drivetrain.
    let opts = SimulateOptions {
        output_interval: Some(1e-300),
        ..Default::default()
    };
    refused(SPUR_PAIR, &opts, &["output_interval = 1e-300", "rows"]);
    refused(IDLER, &opts, &["output_interval = 1e-300", "rows"]);
}

#[test]
fn raising_the_row_limit_is_explicit() {
    // 0.02 s every 1e-5 s: 2001 rows; a limit of 2000 refuses, 2001 runs.
    let mut opts = SimulateOptions::default();
    opts.limits.max_rows = 2000;
    refused(SPUR_PAIR, &opts, &["2000 rows per run"]);
    opts.limits.max_rows = 2001;
    let (_dir, out, result) = run(SPUR_PAIR, &opts);
    result.unwrap();
    let text = std::fs::read_to_string(out).unwrap();
    assert_eq!(text.lines().count(), 2002, "header and 2001 rows");
}

#[test]
fn huge_harmonic_lists_are_refused_before_allocating() {
    let cos = vec!["1.0e-9"; 100_000].join(",");
    let scene = edit(SPUR_PAIR, "cos = [1.0e-6]", &format!("cos = [{cos}]"));
    refuses(&scene, &["mesh.ste.cos", "100000", "256"]);
    // A drivetrain mesh's STE.
    let scene = edit(
        COUNTERSHAFT,
        "[mesh.stiffness]",
        &format!("[mesh.ste]\ncos = [{cos}]\n\n[mesh.stiffness]"),
    );
    refuses(&scene, &["mesh[0].ste.cos", "100000", "256"]);
}

#[test]
fn overdamped_mesh_is_refused() {
    let scene = edit(SPUR_PAIR, "damping_ratio = 0.05", "damping_ratio = 1e300");
    refuses(&scene, &["mesh.damping_ratio", "1e300", "at most 100"]);
    let scene = edit(SPUR_PAIR, "damping_ratio = 0.05", "damping = 1e12");
    refuses(&scene, &["mesh.damping", "1e12"]);
}

#[test]
fn stiff_mesh_exceeds_the_work_limit() {
    // Within f64's range but far too stiff for the run: the work limit says what sets the rate.
    let scene = edit(SPUR_PAIR, "mean = 2.9831e8", "mean = 1e40");
    refuses(&scene, &["fastest mode", "mesh.stiffness", "--max-periods"]);
    // Beyond what the propagators can square: refused by the range check, naming the value.
    let scene = edit(SPUR_PAIR, "mean = 2.9831e8", "mean = 1e300");
    refuses(&scene, &["mean stiffness 1e300 N/m", "beyond 1e150 1/s"]);
}

#[test]
fn fast_pinion_exceeds_the_mesh_period_limit() {
    let scene = edit(
        SPUR_PAIR,
        "pinion_speed = 471.238898038469",
        "pinion_speed = 1e12",
    );
    refuses(&scene, &["operating.pinion_speed = 1e12", "mesh periods"]);
    let opts = SimulateOptions {
        stop_time: Some(1e6),
        output_interval: Some(1e3),
        ..Default::default()
    };
    refused(IDLER, &opts, &["operating.input_speed", "mesh periods"]);
}

#[test]
fn phase_beyond_resolution_is_refused() {
    let scene = edit(IDLER, "initial_phase = 0.0", "initial_phase = 1e20");
    refuses(&scene, &["initial_phase 1e20", "resolve"]);
}

#[test]
fn huge_base_radius_names_the_field() {
    let scene = edit(SPUR_PAIR, "base_radius = 0.04535", "base_radius = 1e300");
    refuses(&scene, &["gear[0].base_radius = 1e300", "inertia"]);
    let scene = edit(IDLER, "base_radius = 0.04535", "base_radius = 1e300");
    refuses(&scene, &["gear[0].base_radius = 1e300"]);
}

#[test]
fn tooth_load_beyond_a_tooth_is_refused() {
    let scene = edit(SPUR_PAIR, "input_torque = 100.0", "input_torque = 1e9");
    refuses(&scene, &["operating.input_torque = 1e9", "base pitch"]);
}

#[test]
fn huge_tooth_count_says_too_large() {
    for scene in [SPUR_PAIR, IDLER] {
        let scene = edit(scene, "teeth = 38", "teeth = 9223372036854775807");
        let msg = refuses(
            &scene,
            &["gear[0].teeth = 9223372036854775807", "too large", "100000"],
        );
        assert!(!msg.contains(">= 1"), "{msg}");
    }
}

#[test]
fn train_mass_spread_is_refused() {
    let scene = edit(IDLER, "inertia = 0.002621", "inertia = 9007199254740992.0");
    refuses(&scene, &["gear[0].inertia = 9.007199254740992e15", "ratio"]);
}

/// The CSV columns of a run as numbers (header dropped).
fn table(path: &Path) -> Vec<Vec<f64>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect()
}

/// Trapezoidal stiffness whose ramps touch (`transition = 1 − f`, allowed by docs/model.md):
/// the flat zone between the ramps has zero width up to rounding. The run must succeed and
/// agree with the same function given as a table (whose pieces have no such zone), both on the
/// RK path at tight tolerance.
#[test]
fn touching_trapezoidal_ramps_match_the_table() {
    // contact_ratio 1.98: f = 0.98, single-contact zone 1 − f = 0.02 = transition. The levels
    // of docs/model.md: k_low = mean(1 − f·ε), k_high = k_low + ε·mean, the ramps centred on
    // the switches at s = 0 (down) and s = 1 − f (up).
    let (mean, eps, f, w) = (2.9831e8_f64, 0.35, 0.98, 0.02);
    let low = mean * (1.0 - f * eps);
    let high = low + eps * mean;
    let mid = 0.5 * (low + high);
    let trapezoidal = edit(
        SPUR_PAIR,
        "kind = \"rectangular\"\nmean = 2.9831e8\npeak_to_peak_ratio = 0.35\ncontact_ratio = 1.504",
        "kind = \"trapezoidal\"\nmean = 2.9831e8\npeak_to_peak_ratio = 0.35\ncontact_ratio = 1.98\ntransition = 0.02",
    );
    let points = [0.0, 0.5 * w, 1.0 - f + 0.5 * w, 1.0 - 0.5 * w];
    let values = [mid, low, high, high];
    let fmt = |v: &[f64]| {
        v.iter()
            .map(|x| format!("{x:?}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let tabled = edit(
        SPUR_PAIR,
        "kind = \"rectangular\"\nmean = 2.9831e8\npeak_to_peak_ratio = 0.35\ncontact_ratio = 1.504",
        &format!(
            "kind = \"table\"\nphase_points = [{}]\nvalues = [{}]",
            fmt(&points),
            fmt(&values)
        ),
    );
    let opts = SimulateOptions {
        method: Some("rk".into()),
        rtol: Some(1e-11),
        atol: Some(1e-17),
        ..Default::default()
    };
    let (_d1, out1, r1) = run(&trapezoidal, &opts);
    r1.expect("touching ramps run");
    let (_d2, out2, r2) = run(&tabled, &opts);
    r2.expect("table runs");
    let (a, b) = (table(&out1), table(&out2));
    assert_eq!(a.len(), b.len());
    let scale = a.iter().map(|r| r[1].abs()).fold(0.0, f64::max);
    let worst = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x[1] - y[1]).abs())
        .fold(0.0, f64::max);
    // The DTE separates every period (contact loss), so the check covers events too.
    let separated = a.iter().filter(|r| r[4] != 1.0).count();
    assert!(separated > 0, "the run should lose contact");
    assert!(
        worst <= 1e-7 * scale,
        "DTE differs by {worst:e} (scale {scale:e})"
    );
    // The stiffness column itself agrees at every sample.
    let k_worst = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x[6] - y[6]).abs())
        .fold(0.0, f64::max);
    assert!(k_worst <= 1e-6 * mean, "stiffness differs by {k_worst:e}");
}

/// The same for a drivetrain mesh (lumped stiffness of `fmu/countershaft_gearset`, mesh 1):
/// touching ramps against the table of the same function, RK at tight tolerance.
#[test]
fn touching_trapezoidal_ramps_in_a_train_match_the_table() {
    let (mean, eps, f, w) = (4.24e9_f64, 0.3, 0.98, 0.02);
    let low = mean * (1.0 - f * eps);
    let high = low + eps * mean;
    let mid = 0.5 * (low + high);
    let original =
        "kind = \"rectangular\"\nmean = 4.24e9\npeak_to_peak_ratio = 0.3\ncontact_ratio = 1.60";
    let trapezoidal = edit(
        COUNTERSHAFT,
        original,
        "kind = \"trapezoidal\"\nmean = 4.24e9\npeak_to_peak_ratio = 0.3\ncontact_ratio = 1.98\ntransition = 0.02",
    );
    let list = |v: &[f64]| {
        v.iter()
            .map(|x| format!("{x:?}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let tabled = edit(
        COUNTERSHAFT,
        original,
        &format!(
            "kind = \"table\"\nphase_points = [{}]\nvalues = [{}]",
            list(&[0.0, 0.5 * w, 1.0 - f + 0.5 * w, 1.0 - 0.5 * w]),
            list(&[mid, low, high, high])
        ),
    );
    let opts = SimulateOptions {
        method: Some("rk".into()),
        rtol: Some(1e-11),
        atol: Some(1e-17),
        stop_time: Some(5e-3),
        ..Default::default()
    };
    let (_d1, out1, r1) = run(&trapezoidal, &opts);
    r1.expect("touching ramps run");
    let (_d2, out2, r2) = run(&tabled, &opts);
    r2.expect("table runs");
    let (a, b) = (table(&out1), table(&out2));
    assert_eq!(a.len(), b.len());
    // mesh1_dte is column 1, mesh1_stiffness column 8.
    let scale = a.iter().map(|r| r[1].abs()).fold(0.0, f64::max);
    let worst = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x[1] - y[1]).abs())
        .fold(0.0, f64::max);
    assert!(
        worst <= 1e-7 * scale,
        "DTE differs by {worst:e} (scale {scale:e})"
    );
    let k_worst = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x[8] - y[8]).abs())
        .fold(0.0, f64::max);
    assert!(k_worst <= 1e-6 * mean, "stiffness differs by {k_worst:e}");
}
