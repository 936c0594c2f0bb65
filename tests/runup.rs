//! Native run-ups (issue 19 item 2, `docs/runup.md`): scene keys and their validation in both
//! formats, a constant profile equal to the constant operating point bit for bit on both
//! kernels and both propagators, the exact propagator where a run-up keeps LTI segments and
//! its refusal where it does not, and the tools that need a constant operating point (FMU,
//! periodic orbits, sweeps, harmonic balance, Floquet) refusing a run-up by name. The
//! dynamics are checked against independent scipy models in `tests/python/test_runup.py`.

use geardyn::scene::MethodChoice;
use geardyn::scene::Scene;
use geardyn::with_drivetrain;

const SPUR: &str = include_str!("../fmu/spur_pair/scene.toml");
const IDLER: &str = include_str!("../fmu/idler_gearset/scene.toml");

const SPUR_SPEED: &str = "pinion_speed = 471.238898038469   # 4500 rpm";
const IDLER_SPEED: &str =
    "input_speed = 330.6939635357677          # rad/s: mesh frequency 2000 Hz";

/// The scene text with its speed line replaced by `operating` lines (and profile tables
/// appended at the end of `[operating]`, i.e. before `[solver]`).
fn with_operating(text: &str, speed_line: &str, operating: &str, tables: &str) -> String {
    assert!(text.contains(speed_line), "scene changed: {speed_line}");
    let t = text.replace(speed_line, operating);
    t.replacen("[solver]", &format!("{tables}\n[solver]"), 1)
}

/// The scene, checked to run on the kernel the test means (`train`: the drivetrain kernel).
fn any(text: &str, train: bool) -> Result<Scene, String> {
    let scene = Scene::from_toml_str(text, "test").map_err(|e| e.0)?;
    assert_eq!(scene.pair().is_none(), train, "kernel of {}", scene.name);
    Ok(scene)
}

/// Every output row on a grid of `rows` points over `stop`, with the method name.
fn run(scene: &Scene, stop: f64, rows: usize) -> (Vec<Vec<f64>>, String) {
    with_drivetrain!(scene.simulation().unwrap(), sim => {
        let mut sim = sim;
        let mut out = Vec::new();
        for k in 0..=rows {
            let t = stop * k as f64 / rows as f64;
            sim.advance_to(t).unwrap();
            let mut row = Vec::new();
            use geardyn::model::Drivetrain;
            sim.model().output_row(sim.t(), sim.y(), &mut row);
            out.push(row);
        }
        (out, sim.method_name())
    })
}

fn bits(rows: &[Vec<f64>]) -> Vec<u64> {
    rows.iter().flatten().map(|v| v.to_bits()).collect()
}

/// The two scenes (pair, idler drivetrain) with their speed lines.
fn cases() -> [(&'static str, &'static str, &'static str, bool); 2] {
    [
        (SPUR, SPUR_SPEED, "pinion_speed", false),
        (IDLER, IDLER_SPEED, "input_speed", true),
    ]
}

#[test]
fn a_constant_profile_is_the_constant_operating_point_bit_for_bit() {
    for (text, line, key, train) in cases() {
        let speed: f64 = line
            .split('=')
            .nth(1)
            .unwrap()
            .split('#')
            .next()
            .unwrap()
            .trim()
            .parse()
            .unwrap();
        let profiles = [
            format!(
                "[operating.speed_profile]\nkind = \"table\"\ntimes = [0.0, 0.004, 0.01]\nvalues = [{speed:?}, {speed:?}, {speed:?}]"
            ),
            format!(
                "[operating.speed_profile]\nkind = \"ramp\"\nfrom = {speed:?}\nto = {speed:?}\nstart = 0.001\nend = 0.003\n\
                 [operating.torque_profile]\nkind = \"table\"\ntimes = [0.0, 0.005]\nvalues = [100.0, 100.0]"
            ),
        ];
        for method in [MethodChoice::Auto, MethodChoice::Rk] {
            let mut base = any(text, train).unwrap();
            base.solver.method = method;
            let (want, want_method) = run(&base, 0.006, 60);
            for (i, profile) in profiles.iter().enumerate() {
                let src = if i == 1 {
                    // The torque comes from its profile too.
                    with_operating(&text.replace("input_torque = 100.0", ""), line, "", profile)
                } else {
                    with_operating(text, line, "", profile)
                };
                let mut scene = any(&src, train).unwrap_or_else(|e| panic!("{key}: {e}"));
                assert!(scene.profiles.any());
                scene.solver.method = method;
                let (got, got_method) = run(&scene, 0.006, 60);
                assert_eq!(got_method, want_method, "{key} profile {i}");
                assert!(
                    bits(&got) == bits(&want),
                    "{key} profile {i} ({method:?}): not bit-identical to the constant scene"
                );
            }
        }
    }
}

#[test]
fn a_ramp_changes_the_run_and_reaches_its_speed() {
    for (text, line, _key, train) in cases() {
        let profile = "[operating.speed_profile]\nkind = \"ramp\"\nfrom = 100.0\nto = 400.0\nstart = 0.0\nend = 0.01";
        let scene = any(&with_operating(text, line, "", profile), train).unwrap();
        with_drivetrain!(scene.simulation().unwrap(), sim => {
            use geardyn::model::Drivetrain;
            let mut sim = sim;
            let p0 = Drivetrain::mesh_phase(sim.model(), 0, 0.0);
            sim.advance_to(0.02).unwrap();
            assert_eq!(Drivetrain::input_speed(sim.model()), 400.0);
            // Phase: ∫ z Ω/2π dt = z/2π (0.01·250 + 0.01·400) cycles of the first mesh.
            let f_per_speed = Drivetrain::mesh_frequency(sim.model(), 0) / 400.0;
            let want = f_per_speed * (0.01 * 250.0 + 0.01 * 400.0);
            let got = Drivetrain::mesh_phase(sim.model(), 0, 0.02) - p0;
            assert!((got - want).abs() <= 1e-9 * want, "phase {got} vs {want}");
        });
    }
}

#[test]
fn exact_applies_to_a_runup_without_ste_and_refuses_a_chirp() {
    // The spur pair has an STE: a ramp makes it a chirp.
    let ramp = "[operating.speed_profile]\nkind = \"ramp\"\nfrom = 100.0\nto = 400.0\nstart = 0.0\nend = 0.01";
    let src = with_operating(SPUR, SPUR_SPEED, "", ramp);
    let mut scene = any(&src, false).unwrap();
    scene.solver.method = MethodChoice::Exact;
    let e = scene.simulation().err().expect("exact must refuse");
    assert!(
        e.contains("operating.speed_profile") && e.contains("chirp"),
        "{e}"
    );
    scene.solver.method = MethodChoice::Auto;
    let (_, method) = run(&scene, 0.002, 4);
    assert_ne!(method, "exact");
    // Without STE the segments stay LTI: auto keeps the exact propagator.
    let no_ste = src.replace("[mesh.ste]\ncos = [1.0e-6]\n", "");
    let scene = any(&no_ste, false).unwrap();
    assert_eq!(run(&scene, 0.002, 4).1, "exact");
    // A torque profile makes the forcing vary within a segment.
    let torque = "[operating.torque_profile]\nkind = \"ramp\"\nfrom = 50.0\nto = 150.0\nstart = 0.0\nend = 0.01";
    let src = with_operating(
        &no_ste.replace("input_torque = 100.0", ""),
        "[operating.speed_profile]",
        &format!("{torque}\n[operating.speed_profile]"),
        "",
    );
    let mut scene = any(&src, false).unwrap();
    scene.solver.method = MethodChoice::Exact;
    let e = scene.simulation().err().expect("exact must refuse");
    assert!(e.contains("operating.torque_profile"), "{e}");
    // The idler train with its tip relief: gaps affine in a quadratic phase.
    let src = with_operating(IDLER, IDLER_SPEED, "", ramp);
    let mut scene = any(&src, true).unwrap();
    scene.solver.method = MethodChoice::Exact;
    let e = scene.simulation().err().expect("exact must refuse");
    assert!(e.contains("tip relief"), "{e}");
}

#[test]
fn bad_profiles_are_refused_naming_the_field_and_value() {
    let bad: [(&str, &str); 7] = [
        (
            "[operating.speed_profile]\nkind = \"ramp\"\nfrom = 100.0\nto = 400.0\nstart = 0.02\nend = 0.01",
            "operating.speed_profile: end = 0.01 s is not after start = 0.02 s",
        ),
        (
            "[operating.speed_profile]\nkind = \"table\"\ntimes = [0.0, 0.2, 0.1]\nvalues = [1.0, 2.0, 3.0]",
            "operating.speed_profile.times[2] = 0.1 s is not after times[1] = 0.2 s",
        ),
        (
            "[operating.speed_profile]\nkind = \"table\"\ntimes = [0.0, 0.1]\nvalues = [1.0, -2.0]",
            "operating.speed_profile.values[1] = -2: a speed must be >= 0",
        ),
        (
            "[operating.speed_profile]\nkind = \"ramp\"\nfrom = -1.0\nto = 2.0\nstart = 0.0\nend = 1.0",
            "operating.speed_profile.from = -1: a speed must be >= 0",
        ),
        (
            "[operating.speed_profile]\nkind = \"table\"\ntimes = [0.0, 0.1, 0.2]\nvalues = [1.0, 2.0]",
            "operating.speed_profile: times has 3 entries, values 2",
        ),
        (
            "[operating.speed_profile]\nkind = \"ramp\"\nfrom = 1.0\nto = nan\nstart = 0.0\nend = 1.0",
            "operating.speed_profile.to = NaN: must be a finite number",
        ),
        (
            "[operating.speed_profile]\nkind = \"table\"\ntimes = [0.0, inf]\nvalues = [1.0, 2.0]",
            "operating.speed_profile.times[1] = inf: must be a finite number",
        ),
    ];
    for (text, line, key, train) in cases() {
        for (profile, want) in bad.iter() {
            let e = any(&with_operating(text, line, "", profile), train).unwrap_err();
            assert!(e.contains(want), "{key}: {e}\n  wanted: {want}");
        }
        // Speed given twice, or not at all.
        let both = "[operating.speed_profile]\nkind = \"ramp\"\nfrom = 1.0\nto = 2.0\nstart = 0.0\nend = 1.0";
        let e = any(&with_operating(text, line, line, both), train).unwrap_err();
        assert!(
            e.contains(&format!("operating.{key} = ")) && e.contains("both given"),
            "{e}"
        );
        let e = any(&with_operating(text, line, "", ""), train).unwrap_err();
        assert!(e.contains(&format!("operating.{key} is missing")), "{e}");
    }
}

#[test]
fn tools_that_need_a_constant_operating_point_refuse_a_runup() {
    let ramp = "[operating.speed_profile]\nkind = \"ramp\"\nfrom = 100.0\nto = 400.0\nstart = 0.0\nend = 0.01";
    for (text, line, _key, train) in cases() {
        let scene = any(&with_operating(text, line, "", ramp), train).unwrap();
        let shoot = geardyn::analysis::shooting::shoot(&scene, &Default::default());
        let Err(e) = shoot else {
            panic!("shooting must refuse a run-up")
        };
        assert!(
            e.contains("operating.speed_profile") && e.contains("constant operating point"),
            "{e}"
        );
        let e = geardyn::analysis::floquet::monodromy(&scene).err().unwrap();
        assert!(e.contains("operating.speed_profile"), "{e}");
    }
    // The FMU takes its speed from the host.
    let dir = std::env::temp_dir().join(format!("geardyn-runup-fmu-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("scene.toml");
    std::fs::write(&scene, with_operating(SPUR, SPUR_SPEED, "", ramp)).unwrap();
    let e = geardyn::fmi::package::build_fmu(&scene, &dir, std::path::Path::new("/nonexistent.so"))
        .unwrap_err();
    assert!(
        e.contains("operating.speed_profile") && e.contains("FMU"),
        "{e}"
    );
    assert!(
        std::fs::read_dir(&dir).unwrap().count() == 1,
        "no partial output"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn simulate_refuses_a_ramp_that_goes_back_in_time_without_output() {
    let dir = std::env::temp_dir().join(format!("geardyn-runup-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("back.toml");
    let ramp = "[operating.speed_profile]\nkind = \"ramp\"\nfrom = 100.0\nto = 400.0\nstart = 0.5\nend = 0.25";
    std::fs::write(&scene, with_operating(SPUR, SPUR_SPEED, "", ramp)).unwrap();
    let out = dir.join("out.csv");
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_geardyn"))
        .args([
            "simulate",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success());
    assert!(
        stderr.contains("operating.speed_profile: end = 0.25 s is not after start = 0.5 s"),
        "{stderr}"
    );
    let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
    assert_eq!(left.len(), 1, "no output file, partial or complete");
    std::fs::remove_dir_all(&dir).unwrap();
}
