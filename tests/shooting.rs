//! Shooting with the exact monodromy (saltation matrices at contact changes) on the backlash
//! scenes: quadratic convergence, the orbit against long integrations by both propagators, and
//! the monodromy against central finite differences of the RK period map.

use geardyn::analysis::{shoot, ShootingOptions, Stability};
use geardyn::scene::{MethodChoice, PairScene};
use geardyn::simulation::Simulation;
use geardyn::solve::rk::Method;
use nalgebra::DMatrix;

fn spur_pair() -> PairScene {
    PairScene::example("spur_pair").unwrap()
}

fn double_sided() -> PairScene {
    let text = include_str!("../fmu/spur_pair/scene.toml")
        .replacen("backlash = 1.0e-4", "backlash = 1.0e-5", 1)
        .replacen("cos = [1.0e-6]", "cos = [3.0e-6]", 1);
    PairScene::from_toml_str(&text, "double_sided").unwrap()
}

fn rk(scene: &PairScene) -> PairScene {
    let mut s = scene.clone();
    s.solver.method = MethodChoice::Rk;
    s.solver.rk_method = Method::Dop853;
    s.solver.rtol = 1e-13;
    s.solver.atol = 1e-20;
    s
}

/// RK period map from `y0` at t = 0.
fn rk_period_map(scene: &PairScene, y0: [f64; 2], duration: f64) -> [f64; 2] {
    let mut sim = Simulation::new(&rk(scene)).unwrap();
    sim.set_state(0.0, y0);
    sim.advance_to(duration).unwrap();
    sim.state()
}

fn check_scene(label: &str, scene: &PairScene) {
    let orbit = shoot(scene, &ShootingOptions::default()).expect("shooting");
    println!(
        "{label}: residuals {:?}\n  y0 = {:?}, multipliers {:?}, {:?}",
        orbit
            .residuals
            .iter()
            .map(|r| format!("{r:.1e}"))
            .collect::<Vec<_>>(),
        orbit.y0,
        orbit.multipliers,
        orbit.stability()
    );
    assert_eq!(orbit.stability(), Stability::Stable);
    // Quadratic convergence: once in the asymptotic range, r_{k+1} ≤ C r_k² with a moderate C
    // (a linearly convergent iteration would give r_{k+1}/r_k² → ∞).
    let r = &orbit.residuals;
    assert!(
        r.len() >= 3,
        "too few iterations to judge the convergence order: {r:?}"
    );
    let last = r.len() - 1;
    let (a, b) = (r[last - 2], r[last - 1]);
    if a < 1e-2 && b > 1e-15 {
        let c = b / (a * a);
        println!("  r_k+1 / r_k² = {c:.2e}");
        assert!(c < 1e3, "not quadratic: {r:?}");
    }

    // Long integrations from the scene's initial state, 400 mesh periods, by both propagators.
    let x_scale = orbit.y0[0].abs();
    let v_scale = orbit.y0[1].abs().max(1e-3 * x_scale * 2e4);
    for s in [scene.clone(), rk(scene)] {
        let mut sim = Simulation::new(&s).unwrap();
        sim.advance_to(400.0 * orbit.period).unwrap();
        let y = sim.state();
        let dx = (y[0] - orbit.y0[0]).abs() / x_scale;
        let dv = (y[1] - orbit.y0[1]).abs() / v_scale;
        println!(
            "  long run [{}]: |Δx|/x = {dx:.1e}, |Δv|/v = {dv:.1e}",
            sim.method_name()
        );
        assert!(dx <= 1e-9 && dv <= 1e-9, "orbit differs from the long run");
    }

    // Monodromy against central differences of the RK period map.
    let h = [1e-4 * x_scale, 1e-4 * v_scale];
    let mut fd = DMatrix::zeros(2, 2);
    for j in 0..2 {
        let mut plus = [orbit.y0[0], orbit.y0[1]];
        let mut minus = plus;
        plus[j] += h[j];
        minus[j] -= h[j];
        let (p, m) = (
            rk_period_map(scene, plus, orbit.period),
            rk_period_map(scene, minus, orbit.period),
        );
        for i in 0..2 {
            fd[(i, j)] = (p[i] - m[i]) / (2.0 * h[j]);
        }
    }
    // Compare in the scaled coordinates (x/x_s, v/v_s).
    let mut worst: f64 = 0.0;
    for i in 0..2 {
        for j in 0..2 {
            let s = [x_scale, v_scale];
            let scaled = |m: &DMatrix<f64>| m[(i, j)] * s[j] / s[i];
            worst = worst.max((scaled(&orbit.monodromy) - scaled(&fd)).abs());
        }
    }
    println!(
        "  monodromy {} vs RK finite differences {}: max scaled diff {worst:.1e}",
        orbit.monodromy, fd
    );
    assert!(
        worst <= 1e-5,
        "saltation-corrected monodromy differs from finite differences"
    );
}

#[test]
fn spur_pair_orbit_with_contact_loss() {
    check_scene("spur_pair", &spur_pair());
}

#[test]
fn double_sided_impact_orbit() {
    check_scene("double_sided", &double_sided());
}

#[test]
fn bad_options_are_rejected() {
    let err = shoot(
        &spur_pair(),
        &ShootingOptions {
            periods: 0,
            ..Default::default()
        },
    )
    .unwrap_err();
    assert!(err.contains("periods = 0"), "{err}");
    let err = shoot(
        &spur_pair(),
        &ShootingOptions {
            tolerance: f64::NAN,
            ..Default::default()
        },
    )
    .unwrap_err();
    assert!(err.contains("tolerance = NaN"), "{err}");
}

#[test]
fn smooth_scene_orbit_by_rk_variational_equations() {
    // Trapezoidal stiffness with contact loss: not piecewise LTI, so the period map and its
    // Jacobian come from RK variational equations with saltation matrices.
    let text = include_str!("../fmu/spur_pair/scene.toml")
        .replacen(
            "kind = \"rectangular\"\nmean = 2.9831e8\npeak_to_peak_ratio = 0.35\ncontact_ratio = 1.504",
            "kind = \"trapezoidal\"\nmean = 2.9831e8\npeak_to_peak_ratio = 0.35\ncontact_ratio = 1.504\ntransition = 0.1",
            1,
        )
        .replacen("method = \"auto\"", "method = \"rk\"\nrtol = 1e-12\natol = 1e-20", 1);
    let scene = PairScene::from_toml_str(&text, "trapezoidal").unwrap();
    check_scene("trapezoidal (RK variational)", &scene);
}
