//! The drivetrain CLI: `geardyn modes` prints Table 2.2 (issue 5, acceptance 1) and the
//! statics; `geardyn simulate` runs drivetrain scenes and rejects bad topology with a message.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn geardyn(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_geardyn"))
        .args(args)
        .output()
        .expect("run geardyn")
}

fn repo(path: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join(path)
        .display()
        .to_string()
}

fn workdir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("train-cli-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The frequencies column of `geardyn modes`.
fn frequencies(stdout: &str) -> Vec<f64> {
    stdout
        .lines()
        .filter_map(|l| {
            let mut f = l.split_whitespace();
            let first = f.next()?;
            first.parse::<usize>().ok()?;
            f.next()?.parse::<f64>().ok()
        })
        .collect()
}

#[test]
fn modes_reproduce_table_2_2() {
    let o = geardyn(&["modes", &repo("fmu/idler_gearset")]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    let f = frequencies(&text);
    let printed = [69.0, 446.0, 499.0, 640.0, 890.0, 1076.0, 2530.0, 3850.0];
    assert_eq!(f.len(), 8, "{text}");
    for (g, p) in f.iter().zip(printed) {
        assert!((g - p).abs() <= 0.005 * p, "{g} vs {p}\n{text}");
    }
    assert!(text.contains("mesh force    2205.0717 N"), "{text}");

    let o = geardyn(&["modes", &repo("fmu/idler_gearset"), "--rigid-bearings"]);
    let f = frequencies(&String::from_utf8_lossy(&o.stdout));
    for (g, p) in f.iter().zip([69.5, 1605.0, 3231.0]) {
        assert!((g - p).abs() <= 0.005 * p, "{g} vs {p}");
    }
}

#[test]
fn simulate_writes_train_outputs() {
    let dir = workdir("simulate");
    let out = dir.join("out.csv");
    let o = geardyn(&[
        "simulate",
        &repo("fmu/countershaft_gearset"),
        "--out",
        out.to_str().unwrap(),
        "--stop-time",
        "0.002",
        "--output-interval",
        "1e-4",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(&out).unwrap();
    let header = csv.lines().next().unwrap();
    for col in [
        "time",
        "mesh1.dte",
        "mesh1.force",
        "mesh1.contact_loss_fraction",
        "mesh2.dte",
        "mesh2.phase",
    ] {
        assert!(
            header.split(',').any(|c| c == col),
            "{col} missing: {header}"
        );
    }
    assert_eq!(csv.lines().count(), 22);
    // Mesh 2 runs at 19/72 of mesh 1's frequency, from phase φ = 0.257.
    let row: Vec<f64> = csv
        .lines()
        .last()
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    let names: Vec<&str> = header.split(',').collect();
    let col = |n: &str| names.iter().position(|c| *c == n).unwrap();
    let f1 = 51.0 * 246.39942381096415 / std::f64::consts::TAU;
    let p2 = (0.257 + 19.0 / 72.0 * f1 * 0.002f64).rem_euclid(1.0);
    assert!(
        (row[col("mesh2.phase")] - p2).abs() < 1e-9,
        "{}",
        row[col("mesh2.phase")]
    );
}

#[test]
fn simulate_rejects_bad_topology() {
    let dir = workdir("bad");
    let text = std::fs::read_to_string(repo("fmu/idler_gearset/scene.toml"))
        .unwrap()
        .replace("gear = \"follower\"", "gear = \"ghost\"");
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    let out = dir.join("out.csv");
    let o = geardyn(&[
        "simulate",
        path.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("mesh[1].gear = \"ghost\""), "{err}");
    assert!(!out.exists());
}

#[test]
fn built_in_drivetrain_examples() {
    let dir = workdir("examples");
    for name in ["idler_gearset", "countershaft_gearset"] {
        let out = dir.join(format!("{name}.csv"));
        let o = geardyn(&[
            "simulate",
            "--example",
            name,
            "--out",
            out.to_str().unwrap(),
            "--stop-time",
            "1e-3",
            "--quiet",
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let csv = std::fs::read_to_string(&out).unwrap();
        assert!(csv.starts_with("time,mesh1.dte,"), "{name}");
    }
}

/// An unknown example name is refused with every built-in name, pair and drivetrain alike,
/// and no file is written.
#[test]
fn unknown_example_lists_pair_and_drivetrain_examples() {
    let out = workdir("unknown_example").join("x.csv");
    let o = geardyn(&[
        "simulate",
        "--example",
        "nope",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    for name in [
        "'nope'",
        "spur_pair",
        "idler_gearset",
        "countershaft_gearset",
    ] {
        assert!(err.contains(name), "{name} missing from: {err}");
    }
    assert!(!out.exists());
}

/// `geardyn hb` takes a drivetrain: per-mesh columns with the mesh names as prefixes, the plot
/// of the chosen mesh, and the single pair keeps its unprefixed columns.
#[test]
fn hb_writes_per_mesh_columns_for_every_scene() {
    let dir = workdir("hb");
    let (csv, svg) = (dir.join("idler.csv"), dir.join("idler.svg"));
    let o = geardyn(&[
        "hb",
        "--example",
        "idler_gearset",
        "--speed",
        "400:410",
        "--harmonics",
        "4",
        "--out",
        csv.to_str().unwrap(),
        "--plot",
        svg.to_str().unwrap(),
        "--plot-mesh",
        "mesh2",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(&csv).unwrap();
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let mut expected = vec!["speed", "speed_rpm", "mesh_frequency"];
    // The per-mesh columns of `sweep` (one list, `analysis::mesh_response::MESH_COLUMNS`).
    let per_mesh = [
        "dte_mean",
        "dte_rms",
        "dte_peak_to_peak",
        "a1",
        "a2",
        "a3",
        "contact_loss_fraction",
        "separation_phase",
        "peak_force",
        "force_rms",
        "dynamic_factor",
        "mesh_frequency",
    ];
    let names: Vec<String> = ["mesh1", "mesh2"]
        .iter()
        .flat_map(|m| per_mesh.iter().map(move |c| format!("{m}.{c}")))
        .collect();
    expected.extend(names.iter().map(String::as_str));
    expected.extend([
        "spectral_radius",
        "spectral_radius_periods",
        "stable",
        "neutral",
        "fold",
        "shooting_check",
    ]);
    assert_eq!(header, expected);
    let rows: Vec<Vec<f64>> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert!(rows.len() >= 2);
    for row in &rows {
        assert_eq!(row.len(), header.len());
        // On the contact-loss branch of the first resonance: mesh 2 separates, both meshes
        // see a dynamic factor above 1, the orbit is stable.
        let col = |name: &str| row[header.iter().position(|h| *h == name).unwrap()];
        assert!(col("mesh2.contact_loss_fraction") > 0.05, "{row:?}");
        assert!(col("mesh1.dynamic_factor") > 1.0 && col("mesh2.dynamic_factor") > 1.0);
        assert_eq!(col("stable"), 1.0);
    }
    let plot = std::fs::read_to_string(&svg).unwrap();
    assert!(
        plot.contains("idler_gearset mesh2: harmonic balance"),
        "{plot}"
    );

    let o = geardyn(&[
        "hb",
        "--example",
        "idler_gearset",
        "--speed",
        "400:410",
        "--out",
        csv.to_str().unwrap(),
        "--plot-mesh",
        "mesh9",
    ]);
    assert!(!o.status.success());
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("--plot-mesh 'mesh9': no such mesh"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );

    let pair = dir.join("pair.csv");
    let o = geardyn(&[
        "hb",
        "--example",
        "spur_pair",
        "--speed",
        "400:420",
        "--harmonics",
        "8",
        "--out",
        pair.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(&pair).unwrap();
    assert_eq!(
        text.lines().next().unwrap(),
        "speed,speed_rpm,mesh_frequency,dte_mean,dte_rms,dte_peak_to_peak,a1,a2,a3,\
         contact_loss_fraction,separation_phase,peak_force,force_rms,dynamic_factor,\
         spectral_radius,spectral_radius_periods,stable,neutral,fold,shooting_check"
    );
}
