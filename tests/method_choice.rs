//! `auto` says what it chose and why (issue 20, point 3): the method line of the `simulate`
//! summary is [`Driver::method_choice`], e.g. `exact (auto: every segment is linear
//! time-invariant)` or `dop853 (auto: exact refused: <the true reason>)`, and `exact`
//! requested on a scene it cannot run is refused with the same reason.

use std::process::Command;

use geardyn::scene::MethodChoice;
use geardyn::scene::Scene;
use geardyn::with_drivetrain;

fn any(text: &str) -> Scene {
    Scene::from_toml_str(text, "t").unwrap()
}

fn choice(scene: &Scene) -> String {
    with_drivetrain!(scene.simulation().unwrap(), sim => sim.method_choice().to_owned())
}

/// The refusal of `method = exact` for the scene (it must be refused).
fn exact_refusal(scene: &Scene) -> String {
    let mut s = scene.clone();
    s.solver.method = MethodChoice::Exact;
    match s.simulation() {
        Err(e) => e,
        Ok(_) => panic!("exact must be refused"),
    }
}

const EXACT: &str = "exact (auto: every segment is linear time-invariant)";

#[test]
fn pair_and_idler_choose_exact_and_say_why() {
    let pair = Scene::example("spur_pair").unwrap();
    assert_eq!(choice(&pair), EXACT);
    let idler = Scene::example("idler_gearset").unwrap();
    assert_eq!(choice(&idler), EXACT);
    // A chain beyond the old 64-bit mode key (21 meshes) is exact too, not a silent fallback.
    let chain = geardyn::scene::train::ChainSpec::new(
        32,
        geardyn::scene::train::ChainBearings::Compliant,
        geardyn::scene::train::ChainContact::ContactLoss,
    );
    let chain = Scene::chain(chain).unwrap();
    assert_eq!(choice(&chain), EXACT);
}

#[test]
fn friction_mesh_falls_back_with_the_true_reason() {
    // The example asks for rk; the question is what auto does with it.
    let s = any(&include_str!("../examples/friction_pair.toml").replace("\"rk\"", "\"auto\""));
    let c = choice(&s);
    assert!(
        c.starts_with("dop853 (auto: exact refused: mesh 'mesh1' has Coulomb tooth friction"),
        "{c}"
    );
    let e = exact_refusal(&s);
    assert!(
        e.contains("solver.method = \"exact\": mesh 'mesh1' has Coulomb tooth friction"),
        "{e}"
    );
}

#[test]
fn gear_errors_fall_back_with_the_true_reason() {
    let mut text = include_str!("../fmu/idler_gearset/scene.toml").to_owned();
    text = text.replacen(
        "ground_stiffness = 3389.6",
        "ground_stiffness = 3389.6\nrunout = { amplitude = 5e-6, phase = 0.0 }",
        1,
    );
    let s = any(&text);
    let c = choice(&s);
    assert!(
        c.starts_with("dop853 (auto: exact refused: gear runout and pitch errors on mesh 'mesh1'"),
        "{c}"
    );
    assert!(exact_refusal(&s).contains("gear runout and pitch errors on mesh 'mesh1'"));
}

#[test]
fn runup_and_smooth_pair_say_why() {
    let runup = any(include_str!("../examples/runup_spur.toml"));
    let c = choice(&runup);
    assert!(
        c.starts_with(
            "dop853 (auto: exact refused: with operating.speed_profile the STE excitation is a chirp"
        ),
        "{c}"
    );
    let smooth = any(include_str!("scenes/smooth_fourier.toml"));
    let c = choice(&smooth);
    assert!(
        c.ends_with("(auto: exact refused: the mesh stiffness is not piecewise constant (smooth, trapezoidal or tabulated with slopes), so it varies within a segment)"),
        "{c}"
    );
    assert!(exact_refusal(&smooth).contains("not piecewise constant"));
}

#[test]
fn simulate_summary_prints_the_choice() {
    let dir = std::env::temp_dir().join(format!("geardyn_method_choice_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    for (scene, want) in [
        ("fmu/idler_gearset", EXACT.to_owned()),
        (
            "examples/friction_pair.toml",
            "dop853 (auto: exact refused: mesh 'mesh1' has Coulomb tooth friction".to_owned(),
        ),
    ] {
        let out = dir.join("out.csv");
        let o = Command::new(env!("CARGO_BIN_EXE_geardyn"))
            .args(["simulate"])
            .arg(root.join(scene))
            .args(["--out"])
            .arg(&out)
            .args(["--stop-time", "0.002", "--method", "auto"])
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(
            o.status.success(),
            "{scene}: {stdout}\n{}",
            String::from_utf8_lossy(&o.stderr)
        );
        let line = stdout
            .lines()
            .find(|l| l.trim_start().starts_with("method"))
            .unwrap_or_else(|| panic!("{stdout}"));
        assert!(line.contains(&want), "{scene}: {line}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
