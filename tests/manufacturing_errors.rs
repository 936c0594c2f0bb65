//! Gear runout and pitch errors (`docs/errors.md`): a closed form for runout, zero errors
//! changing nothing bit for bit in both scene formats, the hunting period, the exact
//! propagator's refusal and the validation messages. The independent scipy models are in
//! `tests/python/test_manufacturing_errors.py`.

use std::f64::consts::TAU;

use geardyn::model::response_period;
use geardyn::scene::PairScene;
use geardyn::scene::Scene;
use geardyn::scene::{is_train_text, KernelChoice};
use geardyn::simulation::run;
use geardyn::with_drivetrain;

/// The scene of either format, as every command reads it.
fn any(text: &str) -> Result<Scene, String> {
    Scene::from_toml_str(text, "t").map_err(|e| e.to_string())
}

const Z: [u32; 2] = [25, 40];
const R: [f64; 2] = [0.0352, 0.0564];
const I: [f64; 2] = [0.0010, 0.0040];

fn pair(errors: [&str; 2], stiffness: &str, contact: &str, extra: &str) -> String {
    format!(
        r#"
name = "errors"
[[gear]]
name = "pinion"
teeth = {}
base_radius = {}
inertia = {}
{}
[[gear]]
name = "gear"
teeth = {}
base_radius = {}
inertia = {}
{}
[mesh]
pinion = "pinion"
gear = "gear"
contact = "{contact}"
damping = 500.0
{extra}
[mesh.stiffness]
{stiffness}
[operating]
pinion_speed = 400.0
input_torque = 150.0
[solver]
method = "auto"
rtol = 1e-11
atol = 1e-18
stop_time = 0.01
"#,
        Z[0], R[0], I[0], errors[0], Z[1], R[1], I[1], errors[1]
    )
}

const RECTANGULAR: &str =
    "kind = \"rectangular\"\nmean = 3.0e8\npeak_to_peak_ratio = 0.2\ncontact_ratio = 1.6";

/// Constant mesh stiffness: `m x'' + c x' + k x = F + k e + c ė` is linear time-invariant,
/// so the runout `e = −A_1 cos(Ω_1 t + φ_1 − β) + A_2 cos(−Ω_2 t + φ_2 − β)` (`docs/errors.md`) gives
/// the steady response `x = F/k + Re Σ E_g H(Ω_g) e^{±iΩ_g t}`, `H = (k + icΩ)/(k − mΩ² + icΩ)`.
#[test]
fn runout_on_a_constant_stiffness_is_the_closed_form_sdof_response() {
    let (a1, phi1, a2, phi2): (f64, f64, f64, f64) = (5e-6, 0.3, 3e-6, -1.0);
    let text = pair(
        [
            &format!("runout = {{ amplitude = {a1}, phase = {phi1} }}"),
            &format!("runout = {{ amplitude = {a2}, phase = {phi2} }}"),
        ],
        "kind = \"constant\"\nvalue = 3.0e8",
        "linear",
        // The runout also moves the mesh position and the centre distance; a constant
        // stiffness without backlash does not see them, so the closed form stays exact.
        "pressure_angle = 20.0",
    );
    let scene = any(&text).unwrap();
    assert!(
        matches!(scene.kernel, KernelChoice::Drivetrain(_)),
        "a pair scene with errors runs as its one-mesh drivetrain"
    );
    let train = &scene;
    let (k, c, speed) = (3.0e8, 500.0, 400.0);
    let m = 1.0 / (R[0] * R[0] / I[0] + R[1] * R[1] / I[1]);
    let force = 150.0 / R[0];
    // Transient decays as exp(−c t / 2m): 0.1 s is e^-51.
    let stop = 0.1;
    let trajectory = geardyn::model::train::run_train(train, stop + 0.004, 2e-5).unwrap();
    let dte = trajectory
        .names
        .iter()
        .position(|n| n == "mesh1.dte")
        .unwrap();
    let omega1 = speed;
    let omega2 = speed * f64::from(Z[0]) / f64::from(Z[1]);
    // Complex response to e = Re[E e^{iΩt}] at frequency Ω (Ω < 0 for the gear: cw).
    let line = |amp_re: f64, amp_im: f64, w: f64, t: f64| {
        let (num_re, num_im) = (k, c * w);
        let (den_re, den_im) = (k - m * w * w, c * w);
        let den = den_re * den_re + den_im * den_im;
        let h_re = (num_re * den_re + num_im * den_im) / den;
        let h_im = (num_im * den_re - num_re * den_im) / den;
        let (x_re, x_im) = (amp_re * h_re - amp_im * h_im, amp_re * h_im + amp_im * h_re);
        x_re * (w * t).cos() - x_im * (w * t).sin()
    };
    let beta = 20f64.to_radians();
    let mut worst: f64 = 0.0;
    for (t, row) in trajectory.times.iter().zip(&trajectory.rows) {
        if *t < stop {
            continue;
        }
        // Pinion: E = −A_1 e^{i(φ_1 − β)} at Ω_1; gear: E = A_2 e^{i(φ_2 − β)} at −Ω_2, with
        // the line of action at β = centre_angle + pressure_angle = 20°.
        let (p1, p2) = (phi1 - beta, phi2 - beta);
        let x = force / k
            + line(-a1 * p1.cos(), -a1 * p1.sin(), omega1, *t)
            + line(a2 * p2.cos(), a2 * p2.sin(), -omega2, *t);
        worst = worst.max((row[dte] - x).abs());
    }
    println!("runout closed form: max error {worst:.3e} m for runouts of 5 and 3 µm");
    assert!(worst < 1e-9 * a1, "{worst}");
}

/// Zero runout and zero pitch tables assemble no error term: both kernels give the same bits.
#[test]
fn zero_errors_change_nothing_bit_for_bit() {
    let zero_pitch = |z: u32| vec!["0.0"; z as usize].join(", ");
    let zeros = [
        format!(
            "runout = {{ amplitude = 0.0, phase = 1.0 }}\ncumulative_pitch_errors = [{}]",
            zero_pitch(Z[0])
        ),
        format!("pitch_errors = [{}]", zero_pitch(Z[1])),
    ];
    // The single pair: zero errors keep it on the pair kernel.
    let with = pair(
        [&zeros[0], &zeros[1]],
        RECTANGULAR,
        "backlash",
        "backlash = 1e-4",
    );
    let without = pair(["", ""], RECTANGULAR, "backlash", "backlash = 1e-4");
    assert!(any(&with).unwrap().kernel == KernelChoice::Pair);
    let a = run(&PairScene::from_toml_str(&with, "t").unwrap(), 0.01, 1e-5).unwrap();
    let b = run(
        &PairScene::from_toml_str(&without, "t").unwrap(),
        0.01,
        1e-5,
    )
    .unwrap();
    assert_eq!(a.rows, b.rows);
    // A drivetrain (`[model]` makes it one): the same.
    let train = |t: &str| {
        t.replace(
            "[[gear]]\nname = \"pinion\"",
            "[model]\nbearings = \"rigid\"\n[[gear]]\nname = \"pinion\"",
        )
    };
    let (tw, to) = (train(&with), train(&without));
    assert!(is_train_text(&tw) && is_train_text(&to));
    let run_train = |t: &str| {
        let s = Scene::from_toml_str(t, "t").unwrap();
        geardyn::model::train::run_train(&s, 0.01, 1e-5)
            .unwrap()
            .rows
    };
    let (ra, rb) = (run_train(&tw), run_train(&to));
    assert_eq!(ra, rb);
    // The non-zero table does change the run (the test can fail).
    let mut pitch = vec!["0.0"; Z[0] as usize];
    pitch[3] = "1e-6";
    let some = train(&pair(
        [
            &format!("cumulative_pitch_errors = [{}]", pitch.join(", ")),
            "",
        ],
        RECTANGULAR,
        "backlash",
        "backlash = 1e-4",
    ));
    assert_ne!(run_train(&some), rb);
}

/// With errors the response repeats once per hunting period, lcm(25, 40) = 200 mesh cycles;
/// `exact` refuses with the reason and `auto` runs Runge–Kutta.
#[test]
fn errors_set_the_hunting_period_and_the_method() {
    let runout = "runout = { amplitude = 2e-6 }";
    let alpha = "pressure_angle = 20.0";
    let both = any(&pair([runout, runout], RECTANGULAR, "linear", alpha)).unwrap();
    let one = any(&pair([runout, ""], RECTANGULAR, "linear", alpha)).unwrap();
    let none = any(&pair(["", ""], RECTANGULAR, "linear", "")).unwrap();
    let mesh_period = TAU / (400.0 * f64::from(Z[0]));
    let period = |s: &Scene| {
        with_drivetrain!(s.simulation().unwrap(), sim => {
            (response_period(sim.model()).unwrap(), sim.method_name())
        })
    };
    let (p, method) = period(&both);
    assert!(
        (p / mesh_period - 200.0).abs() < 1e-9,
        "{}",
        p / mesh_period
    );
    assert!(!method.contains("exact"), "{method}");
    assert!((period(&one).0 / mesh_period - 25.0).abs() < 1e-9);
    assert!((period(&none).0 / mesh_period - 1.0).abs() < 1e-12);
    let exact = pair([runout, ""], RECTANGULAR, "linear", alpha).replace("\"auto\"", "\"exact\"");
    let err = match any(&exact).unwrap().simulation() {
        Err(e) => e,
        Ok(_) => panic!("exact must refuse gear errors"),
    };
    assert!(err.contains("runout and pitch errors"), "{err}");
}

#[test]
fn bad_errors_name_the_field_and_the_value() {
    let cases = [
        (
            "runout = { amplitude = -5e-6, phase = 0.0 }".to_string(),
            "gear[0].runout.amplitude = -0.000005",
        ),
        (
            "runout = { amplitude = 1e-6, phase = nan }".to_string(),
            "gear[0].runout.phase = NaN",
        ),
        (
            "cumulative_pitch_errors = [1e-6, 0.0]".to_string(),
            "gear[0].cumulative_pitch_errors has 2 values: a pitch table needs one value per tooth, 25",
        ),
        (
            format!("pitch_errors = [1e-6{}]", ", 0.0".repeat(24)),
            "gear[0].pitch_errors: the individual pitch deviations sum to 1e-6 m, not 0",
        ),
        (
            format!(
                "pitch_errors = [{z}]\ncumulative_pitch_errors = [{z}]",
                z = vec!["1e-7"; 25].join(", ")
            ),
            "gear[0].pitch_errors and gear[0].cumulative_pitch_errors: give one of them",
        ),
        (
            format!("cumulative_pitch_errors = [inf{}]", ", 0.0".repeat(24)),
            "gear[0].cumulative_pitch_errors[0] = inf",
        ),
    ];
    for (keys, expected) in cases {
        let text = pair([&keys, ""], RECTANGULAR, "linear", "");
        let err = any(&text).unwrap_err();
        assert!(err.contains(expected), "{keys}: {err}");
    }
    // A runout moves the centre distance: the mesh needs its operating pressure angle.
    let text = pair(
        ["", "runout = { amplitude = 1e-6 }"],
        RECTANGULAR,
        "linear",
        "",
    );
    let err = any(&text).unwrap_err();
    assert!(
        err.contains("mesh.pressure_angle: missing; gear \"gear\" has a runout"),
        "{err}"
    );
}

/// An idler with runout sits in two meshes: where each is around it must be given.
#[test]
fn an_idler_with_errors_needs_its_mesh_geometry() {
    let text = r#"
name = "idler"
[model]
bearings = "rigid"
[[gear]]
name = "pinion"
teeth = 38
base_radius = 0.04535
inertia = 0.00262
[[gear]]
name = "idler"
teeth = 55
base_radius = 0.06564
inertia = 0.00327
runout = { amplitude = 1e-6 }
[[gear]]
name = "gear"
teeth = 94
base_radius = 0.1122
inertia = 0.119
[[mesh]]
pinion = "pinion"
gear = "idler"
contact = "linear"
centre_angle = 0.0
pressure_angle = 20.0
[mesh.stiffness]
kind = "constant"
value = 3e8
[[mesh]]
pinion = "idler"
gear = "gear"
contact = "linear"
pressure_angle = 20.0
[mesh.stiffness]
kind = "constant"
value = 3e8
[operating]
input_speed = 200.0
input_torque = 100.0
"#;
    let err = any(text).unwrap_err();
    assert!(
        err.contains("mesh[1].centre_angle: missing; gear \"idler\" has runout or pitch errors"),
        "{err}"
    );
}

/// The moving start of contact of a runout (`docs/errors.md`, "Runout as a moving centre")
/// acts alike on a Model-1 pair table and on the lumped rectangular stiffness it sums to:
/// the same run with `model = "pairs"` and `[mesh.pairs] kind = "rectangular"` as with the
/// lumped `[mesh.stiffness] kind = "rectangular"` (validated against scipy in
/// `tests/python/test_runout_modulation.py`). Linear contact: the two models then have one
/// steady state each, compared after the start transient (the Model-1 start differs).
#[test]
fn a_runout_moves_the_start_of_contact_of_pair_tables_as_of_the_lumped_wave() {
    let scene = |mesh: &str, runout: &str| {
        format!(
            r#"
name = "pairs_vs_lumped"
[model]
bearings = "rigid"
[[gear]]
name = "pinion"
teeth = 38
base_radius = 0.04535
inertia = 0.002621
[[gear]]
name = "gear"
teeth = 55
base_radius = 0.06564
inertia = 0.01091
{runout}
[mesh]
pinion = "pinion"
gear = "gear"
contact = "linear"
damping = 1500.0
pressure_angle = 20.0
centre_angle = 0.0
{mesh}
[operating]
input_speed = 471.238898038469
input_torque = 100.0
[solver]
method = "auto"
rtol = 1e-11
atol = 1e-18
stop_time = 0.04
output_interval = 1e-5
"#
        )
    };
    let lumped = "[mesh.stiffness]\nkind = \"rectangular\"\nmean = 2.9831e8\n\
                  peak_to_peak_ratio = 0.35\ncontact_ratio = 1.504";
    let pairs = "model = \"pairs\"\n[mesh.pairs]\nkind = \"rectangular\"\nmean = 2.9831e8\n\
                 peak_to_peak_ratio = 0.35\ncontact_ratio = 1.504";
    let dte = |text: &str| {
        let s = any(text).unwrap();
        let run = geardyn::model::train::run_train(&s, 0.04, 1e-5).unwrap();
        let col = run.names.iter().position(|n| n == "mesh1.dte").unwrap();
        // The last 10 ms: the start transient (time constant 1.1 ms) has decayed by e^-27.
        let from = run.times.iter().position(|&t| t >= 0.03).unwrap();
        run.rows[from..]
            .iter()
            .map(|r| r[col])
            .collect::<Vec<f64>>()
    };
    let gap = |a: &[f64], b: &[f64]| {
        let scale = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max)
            / scale
    };
    let runout = "runout = { amplitude = 20e-6, phase = 0.7 }";
    let plain = gap(&dte(&scene(lumped, "")), &dte(&scene(pairs, "")));
    let (with_lumped, with_pairs) = (dte(&scene(lumped, runout)), dte(&scene(pairs, runout)));
    let moved = gap(&with_lumped, &with_pairs);
    // The size of what the runout does, for scale: without the moving start of contact the
    // pair table would miss the amplitude modulation of the lumped wave, a part of this.
    let modulation = gap(&with_lumped, &dte(&scene(lumped, "")));
    println!(
        "pairs vs lumped: {plain:.2e} without runout, {moved:.2e} with a 20 µm runout \
         (the runout itself changes the DTE by {modulation:.2e})"
    );
    assert!(moved <= 10.0 * plain.max(1e-10), "{moved} vs {plain}");
    assert!(modulation > 1e-3);
}
