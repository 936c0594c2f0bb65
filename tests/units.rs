//! Issue 19, item 4 and acceptance 5: every speed option is `--speed` and takes rpm and rad/s
//! (a bare number is rad/s, and `--help` says so), equal speeds in either unit give identical
//! results, a bad unit is named, and CSV headers can carry units (`--units`) while the default
//! header stays the bare names.

use std::path::PathBuf;
use std::process::{Command, Output};

use geardyn::analysis::sweep::sweep_columns;
use geardyn::commands::hb::hb_columns;
use geardyn::commands::steady::POINCARE_COLUMNS;
use geardyn::model::Drivetrain;
use geardyn::scene::Scene;
use geardyn::units::{from_rpm, with_units};
use geardyn::with_drivetrain;

fn geardyn(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_geardyn"))
        .args(args)
        .output()
        .unwrap()
}

fn ok(args: &[&str]) -> Output {
    let o = geardyn(args);
    assert!(
        o.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

fn workdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("geardyn-units-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// `rpm` written in rad/s exactly as the parser converts it (`{:?}` round-trips).
fn rad_s(rpm: f64) -> String {
    format!("{:?}", from_rpm(rpm))
}

#[test]
fn every_speed_option_takes_rpm_and_rad_s_alike() {
    let dir = workdir("same");
    // periodic: one speed; the report carries every digit of the orbit.
    let w = rad_s(4500.0);
    let texts: Vec<String> = ["4500rpm".to_owned(), format!("{w}rad/s"), w.clone()]
        .iter()
        .map(|s| {
            let o = ok(&["periodic", "--example", "spur_pair", "--speed", s]);
            let err = String::from_utf8_lossy(&o.stderr);
            assert!(
                err.contains("periodic: input speed 471.239 rad/s (4500 rpm)"),
                "{err}"
            );
            String::from_utf8(o.stdout).unwrap()
        })
        .collect();
    assert!(texts[0].contains("at input speed 471.239 rad/s (4500 rpm)"));
    assert_eq!(texts[0], texts[1]);
    assert_eq!(texts[0], texts[2]);

    // sweep and hb: the CSV files byte for byte.
    let (a, b) = (rad_s(4000.0), rad_s(4200.0));
    let csv = |cmd: &[&str], speed: &str, name: &str| {
        let out = dir.join(name);
        let mut args = cmd.to_vec();
        args.extend(["--speed", speed, "--out", out.to_str().unwrap()]);
        let o = ok(&args);
        (
            std::fs::read_to_string(&out).unwrap(),
            String::from_utf8_lossy(&o.stderr).into_owned(),
        )
    };
    let sweep = ["sweep", "--example", "idler_gearset", "--direction", "up"];
    let (rpm_csv, echo) = csv(&sweep, "4000rpm:4200rpm:3", "s1.csv");
    assert!(
        echo.contains(
            "sweep: input speed 418.879 rad/s (4000 rpm) to 439.823 rad/s (4200 rpm), 3 points"
        ),
        "{echo}"
    );
    assert_eq!(
        rpm_csv,
        csv(&sweep, &format!("{a}rad/s:{b}rad/s:3"), "s2.csv").0
    );
    assert_eq!(rpm_csv, csv(&sweep, &format!("{a}:{b}:3"), "s3.csv").0);
    // The rpm column is the speed column converted.
    let header: Vec<&str> = rpm_csv.lines().next().unwrap().split(',').collect();
    let row: Vec<f64> = rpm_csv
        .lines()
        .nth(3)
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    let col = |n: &str| row[header.iter().position(|h| *h == n).unwrap()];
    assert!((col("speed_rpm") - 4200.0).abs() < 1e-9, "{row:?}");

    let hb = ["hb", "--example", "spur_pair", "--harmonics", "6"];
    let (rpm_csv, echo) = csv(&hb, "3820rpm:3900rpm", "h1.csv");
    assert!(
        echo.contains("hb: input speed 400.029 rad/s (3820 rpm)"),
        "{echo}"
    );
    let (a, b) = (rad_s(3820.0), rad_s(3900.0));
    assert_eq!(rpm_csv, csv(&hb, &format!("{a}rad/s:{b}rad/s"), "h2.csv").0);
    assert_eq!(rpm_csv, csv(&hb, &format!("{a}:{b}"), "h3.csv").0);

    // band: the scan in rpm and in rad/s prints the same bands.
    let band = |speed: &str| {
        String::from_utf8(
            ok(&[
                "band",
                "fmu/helical_pair_friction",
                "--speed",
                speed,
                "--points",
                "40",
            ])
            .stdout,
        )
        .unwrap()
    };
    let text = band("18000rpm:20000rpm");
    assert!(text.contains("between 18000 and 20000 rpm"), "{text}");
    assert!(text.contains("unstable"), "{text}");
    assert_eq!(
        text,
        band(&format!("{}rad/s:{}rad/s", rad_s(18000.0), rad_s(20000.0)))
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_speeds_are_named_and_leave_no_file() {
    let dir = workdir("bad");
    let out = dir.join("never.csv");
    let out = out.to_str().unwrap();
    let cases: [(&[&str], &str, &str); 7] = [
        (
            &["sweep", "--example", "spur_pair", "--out", out],
            "1000rpn:2000rpm:5",
            "'1000rpn': unknown unit",
        ),
        (
            &["hb", "--example", "spur_pair", "--out", out],
            "1000rpn:2000rpm",
            "'1000rpn': unknown unit",
        ),
        (
            &["periodic", "--example", "spur_pair"],
            "4500rpn",
            "'4500rpn': unknown unit",
        ),
        (
            &["floquet", "fmu/helical_pair_friction"],
            "19000 rev",
            "'19000 rev': unknown unit",
        ),
        (
            &["band", "fmu/helical_pair_friction"],
            "15000:25000rpm",
            "give the unit on both ends",
        ),
        (
            &["sweep", "--example", "spur_pair", "--out", out],
            "-300:700:5",
            "'-300': must be a finite speed > 0",
        ),
        (
            &["periodic", "--example", "spur_pair"],
            "1000rpm:2000rpm",
            "expected one speed",
        ),
    ];
    for (args, speed, needle) in cases {
        let mut a = args.to_vec();
        a.extend(["--speed", speed]);
        let o = geardyn(&a);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{a:?} must fail");
        assert!(err.contains(needle), "{a:?}: {err}");
        assert!(err.contains("--speed"), "{a:?}: {err}");
        println!("{}: {}", a[0], err.trim());
    }
    assert!(std::fs::read_dir(&dir).unwrap().next().is_none());
    // The old spellings are gone, not silently reinterpreted.
    for old in [
        &["floquet", "fmu/helical_pair_friction", "--rpm", "19000"][..],
        &[
            "band",
            "fmu/helical_pair_friction",
            "--from-rpm",
            "1",
            "--to-rpm",
            "2",
        ],
    ] {
        assert!(!geardyn(old).status.success(), "{old:?}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn help_states_the_speed_unit() {
    for cmd in ["periodic", "sweep", "hb", "floquet", "band"] {
        let help = String::from_utf8(ok(&[cmd, "--help"]).stdout).unwrap();
        let speed = help
            .split("\n      --speed ")
            .nth(1)
            .unwrap_or_else(|| panic!("{cmd} has no --speed:\n{help}"));
        let line = speed.split("\n      --").next().unwrap();
        assert!(
            line.contains("rpm") && line.contains("rad/s") && line.contains("bare number"),
            "{cmd}: {line}"
        );
    }
}

/// Every column any command writes, for every shipped scene (single pairs and drivetrains),
/// has a unit in the table.
#[test]
fn every_output_column_has_a_unit() {
    let mut checked = 0;
    for name in [
        "spur_pair",
        "geometry_pair",
        "bugaru_pair",
        "helical_pair_friction",
        "idler_gearset",
        "countershaft_gearset",
    ] {
        let scene = Scene::from_path(&PathBuf::from("fmu").join(name)).unwrap();
        let (rows, prefixes) = with_drivetrain!(scene.simulation().unwrap(), sim => {
            let model = sim.model();
            let prefixes: Vec<String> = (0..model.mesh_count()).map(|m| model.mesh_prefix(m)).collect();
            (model.row_names(), prefixes)
        });
        for columns in [
            [vec!["time".to_owned()], rows].concat(),
            sweep_columns(&prefixes),
            hb_columns(&prefixes),
        ] {
            let with = with_units(&columns).unwrap_or_else(|e| panic!("{name}: {e}"));
            checked += with.len();
        }
    }
    let stiffness = geardyn::commands::stiffness::stiffness(
        "fmu/geometry_pair/gears.toml".as_ref(),
        100.0,
        true,
    )
    .unwrap();
    checked += with_units(&stiffness.columns()).unwrap().len();
    checked += with_units(&POINCARE_COLUMNS).unwrap().len();
    println!("{checked} columns, each with a unit");
}

#[test]
fn units_header_only_on_request() {
    let dir = workdir("header");
    for (scene, first) in [
        (
            "spur_pair",
            "time [s],mesh.dte [m],mesh.dte_rate [m/s],mesh.force [N],",
        ),
        (
            "idler_gearset",
            "time [s],mesh1.dte [m],mesh1.dte_rate [m/s],",
        ),
    ] {
        let (plain, units) = (dir.join("plain.csv"), dir.join("units.csv"));
        let run = |out: &PathBuf, extra: &[&str]| {
            let mut a = vec![
                "simulate",
                "--example",
                scene,
                "--stop-time",
                "0.002",
                "--quiet",
            ];
            a.extend(["--out", out.to_str().unwrap()]);
            a.extend(extra);
            ok(&a);
            std::fs::read_to_string(out).unwrap()
        };
        let (p, u) = (run(&plain, &[]), run(&units, &["--units"]));
        assert!(
            u.starts_with(first),
            "{scene}: {}",
            u.lines().next().unwrap()
        );
        // Same data; the default header is the reference's (bare names).
        assert_eq!(p.split_once('\n').unwrap().1, u.split_once('\n').unwrap().1);
        let reference = std::fs::read_to_string(format!("fmu/{scene}/reference.csv")).unwrap();
        assert_eq!(p.lines().next(), reference.lines().next());
    }
    let out = dir.join("sweep.csv");
    ok(&[
        "sweep",
        "--example",
        "spur_pair",
        "--speed",
        "4000rpm:4100rpm:2",
        "--direction",
        "up",
        "--units",
        "--out",
        out.to_str().unwrap(),
    ]);
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(
        text.starts_with("direction [1],speed [rad/s],speed_rpm [rpm],mesh_frequency [Hz],"),
        "{text}"
    );
    assert!(
        text.contains("peak_force [N],force_rms [N],dynamic_factor [1]"),
        "{text}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
