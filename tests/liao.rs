//! Liao et al. 2025 SDOF form `x̄'' + 2ξx̄' + K̄(τ) f(x̄) = F̄` (dead-zone backlash, Fourier
//! stiffness with four harmonics, damping acting always): Floquet multipliers of the periodic
//! orbit by Hsu's method (piecewise-constant stiffness parts, exact propagation with saltation
//! matrices), checked against Liouville's formula `μ1 μ2 = exp(∮ tr Q) = exp(−4πξ/ω)`, which
//! Table 1 of the paper satisfies with ξ = 0.047 (notes §4), and converging as the parts are
//! refined.

mod common;

use std::f64::consts::{PI, TAU};

use common::M_E;
use geardyn::analysis::{shoot, ShootingOptions};
use geardyn::scene::PairScene;

const K0: f64 = 2.0e8;
const XI: f64 = 0.047;
/// Characteristic length b_c and dimensionless half-backlash b̄ = 1.
const BC: f64 = 1.0e-5;

fn liao_scene(omega: f64, damping_acts: &str) -> PairScene {
    let f_n = (K0 / M_E).sqrt() / TAU;
    let c = [0.25, -0.08, 0.03, 0.01].map(|v| v * K0);
    let d = [-0.15, 0.05, 0.02, -0.008].map(|v| v * K0);
    // F̄ = 0.2: static deflection 0.2 b_c, i.e. F = 0.2 b_c K0, input torque F·r_b1.
    let torque = 0.2 * BC * K0 * 0.05;
    common::scene(
        &format!(
            "contact = \"backlash\"\nbacklash = {:e}\ndamping_ratio = {XI}\n\
             damping_acts = \"{damping_acts}\"\n[mesh.stiffness]\nkind = \"fourier\"\n\
             mean = {K0:e}\ncos = [{:e}, {:e}, {:e}, {:e}]\nsin = [{:e}, {:e}, {:e}, {:e}]",
            2.0 * BC,
            c[0],
            c[1],
            c[2],
            c[3],
            d[0],
            d[1],
            d[2],
            d[3]
        ),
        &format!(
            "pinion_speed = {}\ninput_torque = {torque}",
            common::pinion_speed_for_mesh_frequency(omega * f_n)
        ),
        "",
    )
}

fn hsu(scene: &PairScene, parts: usize) -> PairScene {
    let mut s = scene.clone();
    s.mesh.stiffness = scene.mesh.stiffness.cell_averaged(parts).unwrap();
    s
}

/// Fraction of the orbit period spent out of drive-side contact (sampled).
fn orbit_separation(scene: &PairScene, orbit: &geardyn::analysis::PeriodicOrbit) -> f64 {
    let mut sim = geardyn::simulation::Simulation::new(scene).unwrap();
    sim.set_state(0.0, [orbit.y0[0], orbit.y0[1]]);
    let n = 1000;
    (1..=n)
        .filter(|&i| {
            sim.advance_to(orbit.period * i as f64 / n as f64).unwrap();
            sim.outputs()[3] != 1.0
        })
        .count() as f64
        / n as f64
}

#[test]
fn multiplier_product_obeys_liouville_and_hsu_converges() {
    let mut any_separation = false;
    for omega in [0.898, 0.767, 0.599] {
        let scene = liao_scene(omega, "always");
        let expected = (-4.0 * PI * XI / omega).exp();
        let mut previous: Option<Vec<f64>> = None;
        let mut previous_change: Option<f64> = None;
        let mut separated = 0.0f64;
        println!("ω = {omega}: exp(−4πξ/ω) = {expected:.10}");
        for parts in [32, 64, 128, 256] {
            let orbit = shoot(&hsu(&scene, parts), &ShootingOptions::default()).expect("orbit");
            let product = orbit
                .multipliers
                .iter()
                .fold(nalgebra::Complex::new(1.0, 0.0), |p, m| p * m);
            // Multipliers sorted by (re, im); compared between refinements.
            let mut mu = orbit.multipliers.clone();
            mu.sort_by(|a, b| (a.re, a.im).partial_cmp(&(b.re, b.im)).unwrap());
            let moduli: Vec<f64> = mu.iter().flat_map(|m| [m.re, m.im]).collect();
            let rel = (product.re - expected).abs() / expected;
            let change = previous.as_ref().map(|p| {
                p.iter()
                    .zip(&moduli)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max)
            });
            println!(
                "  Hsu {parts:3} parts: μ = {mu:.6?}, separated {:.3}, μ1μ2 = {:.12}, rel. dev {rel:.1e}, change {:?}",
                orbit_separation(&hsu(&scene, parts), &orbit),
                product.re,
                change.map(|c| format!("{c:.1e}"))
            );
            assert!(product.im.abs() < 1e-12, "the product is real");
            assert!(
                rel <= 1e-10,
                "Liouville: μ1μ2 = {} vs {expected}",
                product.re
            );
            // Hsu's method converges at second order: halving the parts divides the change by
            // about four.
            if let (Some(c), Some(pc)) = (change, previous_change) {
                assert!(
                    c < pc / 2.5,
                    "Hsu refinement did not converge at second order"
                );
            }
            previous_change = change;
            separated = separated.max(orbit_separation(&hsu(&scene, parts), &orbit));
            previous = Some(moduli);
        }
        any_separation |= separated > 0.1;
    }
    assert!(
        any_separation,
        "at least one orbit must lose contact (saltation matrices used)"
    );
}

#[test]
fn hsu_converges_to_the_smooth_monodromy() {
    // The smooth system's multipliers from RK variational equations with saltation (the
    // "exact" monodromy next to Hsu's approximation, Liao 2025 §4).
    let mut smooth = liao_scene(0.898, "always");
    smooth.solver.method = geardyn::scene::MethodChoice::Rk;
    smooth.solver.rtol = 1e-12;
    smooth.solver.atol = 1e-20;
    let exact = shoot(&smooth, &ShootingOptions::default()).expect("smooth orbit");
    let key = |m: &nalgebra::Complex<f64>| (m.re, m.im);
    let mut mu_exact = exact.multipliers.clone();
    mu_exact.sort_by(|a, b| key(a).partial_cmp(&key(b)).unwrap());
    println!("smooth (RK variational): μ = {mu_exact:.6?}");
    let mut last = f64::INFINITY;
    for parts in [32, 64, 128, 256] {
        let orbit = shoot(&hsu(&smooth, parts), &ShootingOptions::default()).expect("orbit");
        let mut mu = orbit.multipliers.clone();
        mu.sort_by(|a, b| key(a).partial_cmp(&key(b)).unwrap());
        let diff = mu
            .iter()
            .zip(&mu_exact)
            .map(|(a, b)| (a - b).norm())
            .fold(0.0, f64::max);
        println!("  Hsu {parts:3} parts: max |μ_Hsu − μ| = {diff:.2e}");
        assert!(
            diff < last / 2.5,
            "Hsu must converge (second order) to the smooth multipliers"
        );
        last = diff;
    }
    assert!(last < 1e-3);
}

#[test]
fn damping_switched_off_in_separation_breaks_the_identity() {
    // Oracle that the check can fail: with damping only in contact the trace is not constant
    // around an orbit that separates, so the product differs from exp(−4πξ/ω).
    let scene = hsu(&liao_scene(0.898, "in_contact"), 64);
    let orbit = shoot(&scene, &ShootingOptions::default()).expect("orbit");
    let product: f64 = orbit
        .multipliers
        .iter()
        .fold(nalgebra::Complex::new(1.0, 0.0), |p, m| p * m)
        .re;
    let expected = (-4.0 * PI * 0.047 / 0.898f64).exp();
    println!("in_contact damping: μ1μ2 = {product:.6}, exp(−4πξ/ω) = {expected:.6}");
    assert!((product - expected).abs() > 1e-3 * expected);
}
