//! Issue 2, acceptance 1: constant stiffness without contact loss against the closed-form
//! solution of `m x'' + c(x' − ė) + k(x − e) = F` (free and harmonically forced), for the
//! exact propagator and both RK methods.

mod common;

use std::f64::consts::TAU;

use common::{pinion_speed_for_mesh_frequency, scene, M_E};
use geardyn::scene::PairScene;
use geardyn::simulation::Simulation;

const K: f64 = 2.0e8;

/// Underdamped response of `m x'' + c x' + k x = 0` from `(x0, v0)`.
fn free_response(c: f64, x0: f64, v0: f64, t: f64) -> f64 {
    let sigma = c / (2.0 * M_E);
    let wd = (K / M_E - sigma * sigma).sqrt();
    (-sigma * t).exp() * (x0 * (wd * t).cos() + (v0 + sigma * x0) / wd * (wd * t).sin())
}

/// Steady-state response to `F` and the STE harmonics `(a_h, b_h)` at mesh angular frequency
/// `wm`: returns `(x_p(t), x_p'(t))`.
fn particular(c: f64, force: f64, ste: &[(f64, f64)], wm: f64, t: f64) -> (f64, f64) {
    let (mut x, mut v) = (force / K, 0.0);
    for (i, &(a, b)) in ste.iter().enumerate() {
        let w = (i + 1) as f64 * wm;
        // e = Re[E e^{iwt}], E = a − ib; (k − m w² + icw) X = (k + icw) E.
        let (er, ei) = (a, -b);
        let (nr, ni) = (K * er - c * w * ei, K * ei + c * w * er);
        let (dr, di) = (K - M_E * w * w, c * w);
        let den = dr * dr + di * di;
        let (xr, xi) = ((nr * dr + ni * di) / den, (ni * dr - nr * di) / den);
        let (s, co) = (w * t).sin_cos();
        x += xr * co - xi * s;
        v += w * (-xr * s - xi * co);
    }
    (x, v)
}

fn sample(scene: &PairScene, times: &[f64]) -> (String, Vec<f64>) {
    let mut sim = Simulation::new(scene).expect("simulation");
    let xs = times
        .iter()
        .map(|&t| {
            sim.advance_to(t).expect("advance");
            sim.state()[0]
        })
        .collect();
    (sim.method_name(), xs)
}

fn solver_variants() -> [&'static str; 3] {
    [
        "[solver]\nmethod = \"exact\"",
        "[solver]\nmethod = \"rk\"\nrk_method = \"dop853\"\nrtol = 1e-12\natol = 1e-20",
        "[solver]\nmethod = \"rk\"\nrk_method = \"dp5\"\nrtol = 1e-12\natol = 1e-20",
    ]
}

fn check(label: &str, scene: &PairScene, times: &[f64], oracle: impl Fn(f64) -> f64) -> f64 {
    let (method, xs) = sample(scene, times);
    let expected: Vec<f64> = times.iter().map(|&t| oracle(t)).collect();
    let scale = expected.iter().map(|x| x.abs()).fold(0.0, f64::max);
    let err = common::max_abs_diff(&xs, &expected) / scale;
    println!("{label} [{method}]: max |x − x_closed| / max|x| = {err:.2e}");
    err
}

#[test]
fn free_response_matches_closed_form() {
    let (x0, v0) = (1.0e-6, 0.01);
    for damping in [0.0, 200.0] {
        for solver in solver_variants() {
            let initial = format!("[initial]\ndte = {x0:e}\ndte_rate = {v0}\n{solver}");
            let s = scene(
                &format!(
                    "contact = \"linear\"\ndamping = {damping}\n\
                     [mesh.stiffness]\nkind = \"constant\"\nvalue = {K:e}"
                ),
                "pinion_speed = 300.0\ninput_torque = 0.0",
                &initial,
            );
            // 40 natural periods, 25 samples each.
            let t_n = TAU / (K / M_E).sqrt();
            let times: Vec<f64> = (0..=1000).map(|i| i as f64 * t_n / 25.0).collect();
            let err = check(&format!("free c={damping}"), &s, &times, |t| {
                free_response(damping, x0, v0, t)
            });
            assert!(err <= 1e-9, "free response error {err:e} > 1e-9");
        }
    }
}

#[test]
fn forced_response_matches_closed_form() {
    // Two STE harmonics with cos and sin parts, a static load of T1/r_b1 = 2000 N, mesh
    // frequency 0.7·f_n so the transient and the steady state are both visible.
    let ste = [(1.0e-6, -0.4e-6), (0.3e-6, 0.2e-6)];
    let f_n = (K / M_E).sqrt() / TAU;
    let f_mesh = 0.7 * f_n;
    let force = 100.0 / 0.05;
    for damping in [0.0, 200.0] {
        for solver in solver_variants() {
            let s = scene(
                &format!(
                    "contact = \"linear\"\ndamping = {damping}\n\
                     [mesh.stiffness]\nkind = \"constant\"\nvalue = {K:e}\n\
                     [mesh.ste]\ncos = [{:e}, {:e}]\nsin = [{:e}, {:e}]",
                    ste[0].0, ste[1].0, ste[0].1, ste[1].1
                ),
                &format!(
                    "pinion_speed = {}\ninput_torque = 100.0",
                    pinion_speed_for_mesh_frequency(f_mesh)
                ),
                solver,
            );
            // Initial state "static": x0 = F/k + e(0), x0' = 0.
            let x0 = force / K + ste[0].0 + ste[1].0;
            let wm = TAU * f_mesh;
            let (xp0, vp0) = particular(damping, force, &ste, wm, 0.0);
            let times: Vec<f64> = (0..=1000)
                .map(|i| i as f64 * 30.0 / f_mesh / 1000.0)
                .collect();
            let err = check(&format!("forced c={damping}"), &s, &times, |t| {
                particular(damping, force, &ste, wm, t).0
                    + free_response(damping, x0 - xp0, -vp0, t)
            });
            assert!(err <= 1e-9, "forced response error {err:e} > 1e-9");
        }
    }
}

#[test]
fn closed_form_check_can_fail() {
    // A 1e-6 relative change of the stiffness must be visible at the 1e-9 level.
    let s = scene(
        &format!(
            "contact = \"linear\"\n[mesh.stiffness]\nkind = \"constant\"\nvalue = {:e}",
            K * (1.0 + 1e-6)
        ),
        "pinion_speed = 300.0\ninput_torque = 0.0",
        "[initial]\ndte = 1e-6",
    );
    let t_n = TAU / (K / M_E).sqrt();
    let times: Vec<f64> = (0..=1000).map(|i| i as f64 * t_n / 25.0).collect();
    let err = check("perturbed", &s, &times, |t| {
        free_response(0.0, 1e-6, 0.0, t)
    });
    assert!(err > 1e-6, "a perturbed stiffness went unnoticed ({err:e})");
}
