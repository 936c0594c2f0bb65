//! Every steady-state tool on every shipped drivetrain (issue 16): `periodic`, `floquet`,
//! `band` and `sweep` on `spur_pair`, `idler_gearset` and `countershaft_gearset`, each checked
//! against an oracle that does not share the tool's integrator:
//!
//! - a shooting orbit (exact propagator with saltation) is a fixed point of the period map
//!   integrated by DOP853 at rtol 1e-12, and its multipliers are those of the monodromy
//!   formed by central differences of that RK map;
//! - the exact monodromy of a linear drivetrain equals the RK finite-difference one;
//! - a sweep point converged by Newton equals the RK time series started from its state.

use geardyn::analysis::{
    instability_bands, monodromy, shoot, sweep, Direction, ShootingOptions, SweepOptions,
};
use geardyn::model::{response_period, Drivetrain};
use geardyn::scene::Scene;
use geardyn::scene::{ContactLaw, MethodChoice};
use geardyn::simulation::Driver;
use geardyn::with_drivetrain;
use nalgebra::DMatrix;

const SCENES: [&str; 3] = ["spur_pair", "idler_gearset", "countershaft_gearset"];

/// The scene with the RK propagator at tight tolerances: the independent integrator.
fn rk(scene: &Scene) -> Scene {
    let mut s = scene.clone();
    let solver = &mut s.solver;
    solver.method = MethodChoice::Rk;
    solver.rk_method = "dop853".parse().unwrap();
    solver.rtol = 1e-12;
    solver.atol = 1e-18;
    s
}

/// `y(t0 + duration)` from `y0` at `t0 = 0` by RK.
fn rk_map(scene: &Scene, y0: &[f64], duration: f64) -> Vec<f64> {
    with_drivetrain!(rk(scene).simulation().unwrap(), sim => {
        let mut sim = sim;
        sim.set_y(0.0, y0);
        sim.advance_to(duration).unwrap();
        sim.y().to_vec()
    })
}

/// The monodromy by central differences of the RK period map, steps `h_i = 1e-6 · scale_i`.
fn rk_monodromy(scene: &Scene, y0: &[f64], duration: f64, scale: &[f64]) -> DMatrix<f64> {
    let n = y0.len();
    let mut m = DMatrix::zeros(n, n);
    for j in 0..n {
        let h = 1e-6 * scale[j];
        let (mut plus, mut minus) = (y0.to_vec(), y0.to_vec());
        plus[j] += h;
        minus[j] -= h;
        let (p, q) = (
            rk_map(scene, &plus, duration),
            rk_map(scene, &minus, duration),
        );
        for i in 0..n {
            m[(i, j)] = (p[i] - q[i]) / (2.0 * h);
        }
    }
    m
}

fn scale_of(scene: &Scene, y: &[f64]) -> Vec<f64> {
    with_drivetrain!(scene.simulation().unwrap(), sim => {
        geardyn::analysis::shooting::state_scale(sim.model(), y)
    })
}

fn sorted_moduli(m: &DMatrix<f64>) -> Vec<f64> {
    let mut v: Vec<f64> = m.complex_eigenvalues().iter().map(|z| z.norm()).collect();
    v.sort_by(f64::total_cmp);
    v
}

#[test]
fn shooting_orbits_are_fixed_points_of_an_independent_rk_map() {
    println!("scene                 DOF  |P_rk(y0) − y0|/scale  max ||μ| − |μ_fd||");
    for name in SCENES {
        let scene = Scene::example(name).unwrap();
        let orbit = shoot(&scene, &ShootingOptions::default()).unwrap();
        let scale = scale_of(&scene, &orbit.y0);
        let end = rk_map(&scene, &orbit.y0, orbit.period);
        let residual = end
            .iter()
            .zip(&orbit.y0)
            .zip(&scale)
            .map(|((a, b), s)| ((a - b) / s).abs())
            .fold(0.0, f64::max);
        let fd = rk_monodromy(&scene, &orbit.y0, orbit.period, &scale);
        let (exact, approx) = (sorted_moduli(&orbit.monodromy), sorted_moduli(&fd));
        let multiplier_error = exact
            .iter()
            .zip(&approx)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        println!(
            "{name:<20} {:>4}  {residual:.2e}               {multiplier_error:.2e}",
            orbit.y0.len() / 2
        );
        assert!(residual <= 1e-8, "{name}: RK residual {residual:e}");
        assert!(
            multiplier_error <= 1e-6,
            "{name}: multipliers differ by {multiplier_error:e}"
        );
    }
}

/// The drivetrain with every mesh's contact law linear (no contact loss): a linear periodic
/// system.
fn linear(name: &str) -> Scene {
    let mut s = Scene::example(name).unwrap();
    for m in &mut s.meshes {
        m.contact = ContactLaw::Linear;
    }
    s
}

#[test]
fn exact_monodromy_of_linear_drivetrains_matches_rk_differences() {
    for name in SCENES {
        let scene = linear(name);
        let floquet = monodromy(&scene).unwrap();
        let n = floquet.monodromy.nrows();
        let y0 = vec![0.0; n];
        // Steps of 1e-6 m and 1e-2 m/s: large enough that the RK error over the step stays
        // small (the map is affine, so the differences have no truncation error).
        let scale: Vec<f64> = (0..n).map(|i| if i < n / 2 { 1.0 } else { 1e4 }).collect();
        let fd = rk_monodromy(&scene, &y0, floquet.period, &scale);
        let norm = floquet.monodromy.amax().max(1.0);
        let diff = (&floquet.monodromy - &fd).amax() / norm;
        println!(
            "{name}: {} states, method {}, ρ = {:.9}, max |M − M_fd| / max|M| = {diff:.2e}",
            n,
            floquet.method,
            floquet.spectral_radius()
        );
        assert!(diff <= 1e-7, "{name}: {diff:e}");
    }
}

#[test]
fn floquet_refuses_contact_loss_and_says_what_to_use() {
    for name in ["idler_gearset", "countershaft_gearset"] {
        let err = monodromy(&Scene::example(name).unwrap()).unwrap_err();
        assert!(
            err.contains("mesh[0].contact") && err.contains("geardyn periodic"),
            "{err}"
        );
    }
}

#[test]
fn band_edges_of_a_linear_drivetrain_bound_unstable_speeds() {
    // The linear idler with light modal damping (ζ = 0.2 %) between 380 and 440 rad/s
    // (mesh 2.3–2.7 kHz): wherever `band` reports an unstable interval, the RK
    // finite-difference monodromy at its centre has a multiplier outside the unit circle, and
    // 1 % outside its edges none.
    let mut scene = linear("idler_gearset");
    scene.modal_damping_ratio = 0.002;
    let bands = instability_bands(&scene, 380.0, 440.0, 60).unwrap();
    println!("linear idler bands (rad/s): {bands:?}");
    assert!(
        !bands.is_empty(),
        "the lightly damped idler has a band near 2.5 kHz"
    );
    let rk_radius = |speed: f64| {
        let mut at = scene.clone();
        at.set_input_speed(speed);
        let period = with_drivetrain!(at.simulation().unwrap(), sim => response_period(sim.model()).unwrap());
        let n = monodromy(&at).unwrap().monodromy.nrows();
        let scale: Vec<f64> = (0..n).map(|i| if i < n / 2 { 1.0 } else { 1e4 }).collect();
        let fd = rk_monodromy(&at, &vec![0.0; n], period, &scale);
        sorted_moduli(&fd).last().copied().unwrap()
    };
    for b in &bands {
        let centre = rk_radius(0.5 * (b.from_speed + b.to_speed));
        let below = rk_radius(0.99 * b.from_speed);
        let above = rk_radius(1.01 * b.to_speed);
        println!(
            "band {:.3}–{:.3} rad/s: RK ρ below {below:.6}, centre {centre:.6}, above {above:.6}",
            b.from_speed, b.to_speed
        );
        assert!(
            centre > 1.0,
            "band {b:?}: RK spectral radius {centre} at its centre"
        );
        if b.from_speed > 380.0 * 1.01 {
            assert!(below < 1.0, "band {b:?}: RK ρ {below} below it");
        }
        if b.to_speed < 440.0 / 1.01 {
            assert!(above < 1.0, "band {b:?}: RK ρ {above} above it");
        }
    }
}

#[test]
fn sweep_points_match_an_rk_time_series_from_their_state() {
    for name in SCENES {
        let scene = Scene::example(name).unwrap();
        let speed = scene.input_speed();
        let options = SweepOptions::new(vec![0.97 * speed, speed], Direction::Up);
        let result = sweep(&scene, &options, &|_, _| {}).unwrap();
        let point = result.points.last().unwrap();
        assert!(point.converged, "{name}: {point:?}");
        // The orbit at this speed by shooting, integrated by RK: per-mesh DTE RMS and peak
        // force over one response period, 2048 samples per mesh period (the sweep's are from
        // the continuous solution: the sampled peak falls short by at most ~(π/2048)²/2 of
        // the force's swing).
        let mut at = scene.clone();
        at.set_input_speed(speed);
        let orbit = shoot(&at, &ShootingOptions::default()).unwrap();
        let samples = 2048 * (point.response_period * point.mesh_frequency).round() as usize;
        let (rms, peak) = with_drivetrain!(rk(&at).simulation().unwrap(), sim => {
            let mut sim: Driver<_> = sim;
            sim.set_y(0.0, &orbit.y0);
            let meshes = sim.model().mesh_count();
            let mut dte = vec![Vec::new(); meshes];
            let mut peak = vec![0.0f64; meshes];
            for i in 1..=samples {
                sim.advance_to(orbit.period * i as f64 / samples as f64).unwrap();
                for (m, d) in dte.iter_mut().enumerate() {
                    let s = sim.model().mesh_sample(m, sim.t(), sim.y());
                    d.push(s.dte);
                    peak[m] = peak[m].max(s.force.abs());
                }
            }
            let rms: Vec<f64> = dte
                .iter()
                .map(|d| {
                    let mean = d.iter().sum::<f64>() / d.len() as f64;
                    (d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / d.len() as f64).sqrt()
                })
                .collect();
            (rms, peak)
        });
        for (m, mesh) in point.meshes.iter().enumerate() {
            let e_rms = (mesh.dte_rms - rms[m]).abs() / rms[m];
            let e_peak = (mesh.peak_force - peak[m]).abs() / peak[m];
            println!(
                "{name} {}: DTE RMS {:.6e} (RK {:.6e}, rel {e_rms:.1e}), peak force {:.4} N \
                 (RK rel {e_peak:.1e}), dynamic factor {:.4}",
                mesh.prefix, mesh.dte_rms, rms[m], mesh.peak_force, mesh.dynamic_factor
            );
            assert!(e_rms <= 1e-6 && e_peak <= 1e-5, "{name} mesh {m}");
        }
    }
}

#[test]
fn a_diverging_point_is_marked_and_the_sweep_goes_on() {
    // The linear idler with ζ = 0.2 % is parametrically unstable at 420 rad/s (|μ| ≈ 1.14
    // per period, `band_edges_of_a_linear_drivetrain_bound_unstable_speeds`): its response
    // grows until the state is not finite. The point is kept with the reason, and the
    // branch continues from the scene's start.
    let mut scene = linear("idler_gearset");
    scene.modal_damping_ratio = 0.002;
    let options = SweepOptions {
        max_transient_periods: 20_000,
        ..SweepOptions::new(vec![400.0, 420.0, 440.0], Direction::Up)
    };
    let points = sweep(&scene, &options, &|_, _| {}).unwrap().points;
    assert_eq!(points.len(), 3);
    let failure = points[1]
        .failure
        .as_deref()
        .expect("the unstable point fails");
    println!("420 rad/s: {failure}");
    assert!(failure.contains("420"), "{failure}");
    assert!(!points[1].converged && points[1].meshes[0].dte_rms.is_nan());
    assert!(points[0].converged && points[2].converged, "{points:?}");
}
