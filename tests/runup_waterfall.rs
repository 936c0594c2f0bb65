//! Issue 19, acceptance 4 on the data: the waterfall of the built-in run-up `runup_spur`
//! (`examples/runup_spur.toml`, `docs/runup.md`) shows the mesh orders as straight lines
//! through the origin, `f = k·z1·n/60`, and a resonance where mesh order 1 crosses the
//! natural frequency of the mean system, `f_n = sqrt(k̄/m_e)/2π` computed here from the
//! scene's inertias, base radii and mean stiffness. Run through both kernels: the single pair
//! and the same file read as a one-mesh drivetrain.

use std::f64::consts::TAU;

use geardyn::analysis::spectrum::WaterfallOptions;
use geardyn::commands::runup::{runup_waterfall, RunupSignal};
use geardyn::scene::PairScene;
use geardyn::scene::Scene;

const RUNUP: &str = include_str!("../examples/runup_spur.toml");

/// Least-squares line `f = a·n + b` through the points.
fn fit(points: &[(f64, f64)]) -> (f64, f64) {
    let n = points.len() as f64;
    let (sx, sy) = points
        .iter()
        .fold((0.0, 0.0), |(a, b), &(x, y)| (a + x, b + y));
    let (mx, my) = (sx / n, sy / n);
    let (sxy, sxx) = points.iter().fold((0.0, 0.0), |(a, b), &(x, y)| {
        (a + (x - mx) * (y - my), b + (x - mx) * (x - mx))
    });
    let slope = sxy / sxx;
    (slope, my - slope * mx)
}

fn check(scene: &Scene, kernel: &str) {
    let pair = PairScene::from_toml_str(RUNUP, "runup").unwrap();
    let z1 = f64::from(pair.pinion.teeth);
    let m_e = 1.0
        / (pair.pinion.base_radius.powi(2) / pair.pinion.inertia
            + pair.gear.base_radius.powi(2) / pair.gear.inertia);
    let f_n = (pair.mesh.stiffness.mean() / m_e).sqrt() / TAU;
    let n_res = 60.0 * f_n / z1;

    let w = runup_waterfall(scene, 0, RunupSignal::Dte, &WaterfallOptions::default()).unwrap();
    assert!(
        (w.mesh_order - z1).abs() < 1e-12 * z1,
        "{kernel}: {}",
        w.mesh_order
    );
    let map = &w.map;
    let bin = map.frequency[1] - map.frequency[0];
    let nyquist = *map.frequency.last().unwrap();

    // Orders 1 and 2 of the mesh: the strongest line near k·z1·n/60 in every window.
    for k in [1.0, 2.0] {
        let points: Vec<(f64, f64)> = (0..map.rpm.len())
            .filter_map(|r| {
                let f = k * z1 * map.rpm[r] / 60.0;
                (1.15 * f < nyquist)
                    .then(|| {
                        map.ridge(r, 0.85 * f, 1.15 * f)
                            .map(|ridge| (map.rpm[r], ridge))
                    })
                    .flatten()
            })
            .collect();
        assert!(
            points.len() > 50,
            "{kernel}: order {k} has {} windows",
            points.len()
        );
        let (slope, intercept) = fit(&points);
        let want = k * z1 / 60.0;
        println!(
            "{kernel}: mesh order {k}: f = {slope:.5}·n + {intercept:.2} Hz (expected {want:.5}·n)"
        );
        assert!(
            (slope / want - 1.0).abs() < 2e-3,
            "{kernel}: slope {slope} vs {want}"
        );
        assert!(
            intercept.abs() < bin,
            "{kernel}: intercept {intercept} Hz, bin {bin} Hz"
        );
    }

    // Resonance: the amplitude along mesh order 1 peaks where it crosses f_n.
    let along: Vec<(f64, f64)> = (0..map.rpm.len())
        .map(|r| {
            let f = z1 * map.rpm[r] / 60.0;
            let a = (0..map.frequency.len())
                .filter(|&c| (map.frequency[c] - f).abs() <= 2.0 * bin)
                .map(|c| map.amplitude[r][c])
                .fold(0.0, f64::max);
            (map.rpm[r], a)
        })
        .collect();
    let (n_peak, a_peak) =
        along
            .iter()
            .copied()
            .fold((0.0, 0.0), |best, p| if p.1 > best.1 { p } else { best });
    let far: Vec<f64> = along
        .iter()
        .filter(|p| (p.0 - n_res).abs() > 0.3 * n_res)
        .map(|p| p.1)
        .collect();
    let far_max = far.iter().copied().fold(0.0, f64::max);
    // Speed span of one window: segment · output_interval · ramp rate.
    let span = 1000.0 * 2e-5 * (8000.0 - 1000.0) / 2.0;
    println!(
        "{kernel}: order-1 amplitude peaks at {n_peak:.0} rpm ({a_peak:.3e} m, {:.1}× the largest \
         30 % away); f_n = {f_n:.1} Hz is met at {n_res:.0} rpm; window span {span:.0} rpm",
        a_peak / far_max
    );
    // Within the window's speed span plus the damped-peak shift (−0.25 % at ζ = 0.05) and the
    // lag of a sweep through a resonance.
    assert!((n_peak - n_res).abs() < span + 0.01 * n_res, "{kernel}");
    assert!(a_peak > 3.0 * far_max, "{kernel}: no resonance peak");
}

#[test]
fn runup_waterfall_orders_and_resonance_single_pair() {
    let scene = Scene::example("runup_spur").unwrap();
    assert!(scene.pair().is_some());
    check(&scene, "pair");
}

#[test]
fn runup_waterfall_orders_and_resonance_drivetrain() {
    let train = Scene::from_toml_str(RUNUP, "runup as drivetrain").unwrap();
    check(&train.on_drivetrain_kernel().unwrap(), "drivetrain");
}

#[test]
fn waterfall_refuses_a_scene_without_a_runup() {
    let scene = Scene::example("spur_pair").unwrap();
    let e = runup_waterfall(&scene, 0, RunupSignal::Dte, &WaterfallOptions::default()).unwrap_err();
    assert!(e.contains("operating.speed_profile"), "{e}");
}

/// The EV-like 3-planet stage (`examples/planetary/ev_reducer_3p.toml`: Z = 23/25/73, ring
/// held, sun in) with a 5 µm tangential pin error on planet 1 (so that the sun moves), run up
/// from `W0` to `W1` rad/s over `STOP` s.
const EV_STAGE: &str = include_str!("../examples/planetary/ev_reducer_3p.toml");
const W0: f64 = 500.0;
const W1: f64 = 1500.0;
const STOP: f64 = 0.05;
const DT: f64 = 2e-5;

fn stage_runup() -> Scene {
    let text = EV_STAGE
        .replacen(
            "position_angle = 0.0\n",
            "position_angle = 0.0\npin_error = [0.0, 5e-6]\n",
            1,
        )
        .replace("input_speed = 1047.1975511965977\n", "")
        + &format!(
            "[operating.speed_profile]\nkind = \"ramp\"\nfrom = {W0:?}\nto = {W1:?}\n\
             start = 0.0\nend = {STOP:?}\n[solver]\nstop_time = {STOP:?}\n\
             output_interval = {DT:?}\n"
        );
    Scene::from_toml_str(&text, "stage runup").unwrap()
}

/// `waterfall --signal sun.x_fixed / sun.y_fixed` (`docs/planetary.md`, "Fixed-frame
/// spectra"): the map equals the short-time spectra of the run's carrier-frame columns
/// `sun.x`, `sun.y` rotated here by the carrier's nominal angle, written by hand for the ramp
/// and Willis' ratio, `θ_c = (Z_s/(Z_s + Z_r))·(ω0 t + ½ a t²)` with `Z_s/(Z_s + Z_r) = 23/96`
/// (ccw input): `X = x cos θ_c − y sin θ_c`, `Y = x sin θ_c + y cos θ_c`. The control (the
/// unrotated x) differs. The report labels the planet-pass orders `k × 3 × 23/96`.
#[test]
fn fixed_frame_waterfall_is_the_rotated_carrier_frame_run() {
    let scene = stage_runup();
    let sun = scene.gear_index("sun").unwrap();
    assert_eq!(scene.rotation[sun], 1.0, "the input turns ccw");
    let run = geardyn::model::train::run_train(&scene, STOP, DT).unwrap();
    let (cx, cy) = (run.column("sun.x").unwrap(), run.column("sun.y").unwrap());
    let accel = (W1 - W0) / STOP;
    let carrier = 23.0 / 96.0;
    let options = WaterfallOptions::default();
    let t: Vec<f64> = run.times.clone();
    let rpm: Vec<f64> = t.iter().map(|&t| (W0 + accel * t) * 60.0 / TAU).collect();
    let rotated = |axis: usize| -> Vec<f64> {
        run.rows
            .iter()
            .zip(&t)
            .map(|(row, &t)| {
                let theta = carrier * (W0 * t + 0.5 * accel * t * t);
                let (x, y) = (row[cx], row[cy]);
                if axis == 0 {
                    x * theta.cos() - y * theta.sin()
                } else {
                    x * theta.sin() + y * theta.cos()
                }
            })
            .collect()
    };
    let diff = |a: &geardyn::analysis::spectrum::Waterfall,
                b: &geardyn::analysis::spectrum::Waterfall| {
        assert_eq!(a.amplitude.len(), b.amplitude.len());
        let peak = a.amplitude.iter().flatten().fold(0.0_f64, |m, &v| m.max(v));
        let worst = a
            .amplitude
            .iter()
            .flatten()
            .zip(b.amplitude.iter().flatten())
            .fold(0.0_f64, |m, (p, q)| m.max((p - q).abs()));
        worst / peak
    };
    for (axis, signal) in [(0, "sun.x_fixed"), (1, "sun.y_fixed")] {
        let s = RunupSignal::parse_for(&scene, signal).unwrap();
        let w = runup_waterfall(&scene, 0, s, &options).unwrap();
        let oracle =
            geardyn::analysis::spectrum::waterfall(&t, &rotated(axis), &rpm, &options).unwrap();
        let d = diff(&w.map, &oracle);
        assert!(d < 1e-9, "{signal}: {d:e} of the largest line");
        if axis == 0 {
            let x: Vec<f64> = run.rows.iter().map(|r| r[cx]).collect();
            let control = geardyn::analysis::spectrum::waterfall(&t, &x, &rpm, &options).unwrap();
            assert!(diff(&oracle, &control) > 0.1, "the rotation matters");
        }
    }
    // Refusals name the signal; the report labels the planet pass.
    let e = RunupSignal::parse_for(&scene, "planet1.x_fixed").unwrap_err();
    assert!(e.contains("central member"), "{e}");
    let dir = std::env::temp_dir().join(format!("geardyn-wf-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let request = geardyn::commands::runup::WaterfallRequest {
        signal: "sun.x_fixed",
        ..Default::default()
    };
    let text = geardyn::commands::runup::waterfall_command(
        &scene,
        &request,
        &dir.join("wf.csv"),
        None,
        Default::default(),
    )
    .unwrap();
    std::fs::remove_dir_all(&dir).ok();
    let pass = 3.0 * 23.0 / 96.0;
    for k in 1..=3 {
        let want = format!(
            "{k}×carrier_planet_pass = shaft order {} ",
            geardyn::commands::runup::order_text(k as f64 * pass)
        );
        assert!(text.contains(&want), "{want:?} in {text}");
    }
    assert!(
        text.contains("1×mesh-1×carrier = shaft order 17.25 "),
        "{text}"
    );
}
