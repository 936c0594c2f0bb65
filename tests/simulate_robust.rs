//! Issue 17, acceptance 1 (`geardyn simulate`): every failing case of the reliability probe is
//! a regression test here. Each runs the path of `geardyn simulate` (scene file → load →
//! validate → limits → streamed CSV, [`geardyn::commands::simulate::simulate`]) and gets either a
//! message naming the field and its value, with neither the output nor its `.partial` sibling
//! left behind, or (the touching trapezoidal ramps) a result checked against an independent
//! form of the same stiffness.

use std::path::{Path, PathBuf};

use geardyn::commands::simulate::{simulate, SimulateOptions};
use geardyn::scene::Scene;

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
    let result = Scene::from_path(&scene)
        .map_err(String::from)
        .and_then(|s| simulate(s, opts, &out).map(|_| ()));
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

/// The stiffness source of touching trapezoidal ramps (`contact_ratio = 1 + f`,
/// `transition = w = 1 − f`) and the same function as a table. The levels of docs/model.md:
/// k_low = mean(1 − f·ε), k_high = k_low + ε·mean, the ramps centred on the switches at s = 0
/// (down) and s = 1 − f (up); the table's pieces have no zero-width flat zone between them.
fn touching_ramps_and_table(mean: f64, eps: f64, f: f64, w: f64) -> (String, String) {
    let low = mean * (1.0 - f * eps);
    let high = low + eps * mean;
    let mid = 0.5 * (low + high);
    let list = |v: &[f64]| {
        v.iter()
            .map(|x| format!("{x:?}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    (
        format!(
            "kind = \"trapezoidal\"\nmean = {mean:?}\npeak_to_peak_ratio = {eps:?}\ncontact_ratio = {:?}\ntransition = {w:?}",
            1.0 + f
        ),
        format!(
            "kind = \"table\"\nphase_points = [{}]\nvalues = [{}]",
            list(&[0.0, 0.5 * w, 1.0 - f + 0.5 * w, 1.0 - 0.5 * w]),
            list(&[mid, low, high, high])
        ),
    )
}

/// Runs both scenes on the RK path at tight tolerance; the largest differences of the DTE
/// (relative to its largest magnitude) and of the stiffness column, and the first table.
fn compare_on_rk(
    a: &str,
    b: &str,
    stop_time: Option<f64>,
    cols: (usize, usize),
) -> (f64, f64, Vec<Vec<f64>>) {
    let opts = SimulateOptions {
        method: Some("rk".into()),
        rtol: Some(1e-11),
        atol: Some(1e-17),
        stop_time,
        ..Default::default()
    };
    let (_d1, out1, r1) = run(a, &opts);
    r1.expect("touching ramps run");
    let (_d2, out2, r2) = run(b, &opts);
    r2.expect("table runs");
    let (x, y) = (table(&out1), table(&out2));
    assert_eq!(x.len(), y.len());
    let worst = |col: usize| {
        x.iter()
            .zip(&y)
            .map(|(p, q)| (p[col] - q[col]).abs())
            .fold(0.0, f64::max)
    };
    let scale = x.iter().map(|r| r[cols.0].abs()).fold(0.0, f64::max);
    (worst(cols.0) / scale, worst(cols.1), x)
}

/// Trapezoidal stiffness whose ramps touch (`transition = 1 − f`, allowed by docs/model.md):
/// the flat zone between the ramps has zero width up to rounding. The run must succeed and
/// agree with the same function given as a table, both on the RK path at tight tolerance.
#[test]
fn touching_trapezoidal_ramps_match_the_table() {
    let mean = 2.9831e8;
    let (ramps, tabled) = touching_ramps_and_table(mean, 0.35, 0.98, 0.02);
    let original =
        "kind = \"rectangular\"\nmean = 2.9831e8\npeak_to_peak_ratio = 0.35\ncontact_ratio = 1.504";
    let (a, b) = (
        edit(SPUR_PAIR, original, &ramps),
        edit(SPUR_PAIR, original, &tabled),
    );
    // mesh.dte is column 1, mesh.stiffness column 6.
    let (dte, k, rows) = compare_on_rk(&a, &b, None, (1, 6));
    // The DTE separates every period (contact loss), so the check covers events too.
    assert!(
        rows.iter().any(|r| r[4] != 1.0),
        "the run should lose contact"
    );
    assert!(dte <= 1e-7, "DTE differs by {dte:e} of its scale");
    assert!(k <= 1e-6 * mean, "stiffness differs by {k:e}");
}

/// The same for a drivetrain mesh (lumped stiffness of `fmu/countershaft_gearset`, mesh 1).
#[test]
fn touching_trapezoidal_ramps_in_a_train_match_the_table() {
    let mean = 4.24e9;
    let (ramps, tabled) = touching_ramps_and_table(mean, 0.3, 0.98, 0.02);
    let original =
        "kind = \"rectangular\"\nmean = 4.24e9\npeak_to_peak_ratio = 0.3\ncontact_ratio = 1.60";
    let (a, b) = (
        edit(COUNTERSHAFT, original, &ramps),
        edit(COUNTERSHAFT, original, &tabled),
    );
    // mesh1.dte is column 1, mesh1.stiffness column 8.
    let (dte, k, _) = compare_on_rk(&a, &b, Some(5e-3), (1, 8));
    assert!(dte <= 1e-7, "DTE differs by {dte:e} of its scale");
    assert!(k <= 1e-6 * mean, "stiffness differs by {k:e}");
}
