//! Bugaru et al. 2006 (`models-bugaru-2006.md`): the modified Mathieu–Duffing–Hill equation
//! `s'' + (α + α0 cos νt) s' + Ω²(1 + μ cos νt)(s + δ̄ s³) + γ s³ = Γ̃ cos νt`, simulated with
//! the single-mesh model (linear contact, Fourier stiffness, damping variation, cubic terms,
//! torque ripple) against the first-order KBM amplitude formulas (notes §3.5): the
//! fundamental resonance (cubic in s̄1², eq. 30) and the principal parametric resonance
//! (closed form of eq. 32), and the damping threshold above which the parametric resonance
//! vanishes (Δ_crit = 2πμ/√(4 − μ²)).

mod common;

use std::f64::consts::{PI, TAU};

use common::M_E;
use geardyn::scene::{MethodChoice, PairScene};
use geardyn::simulation::Simulation;
use geardyn::solve::rk::Method;

const K0: f64 = 2.0e8;
/// Length scale of the dimensionless amplitudes, m.
const L: f64 = 1.0e-5;

fn omega_n() -> f64 {
    (K0 / M_E).sqrt()
}

/// The scene for dimensionless parameters (Ω = 1 units, amplitudes in L).
fn bugaru(nu: f64, alpha: f64, alpha0: f64, mu: f64, kappa: f64, forcing: f64) -> PairScene {
    let w = omega_n();
    let damping = alpha * w * M_E;
    let variation = alpha0 * w * M_E;
    // κ' = Ω² δ̄ in 1/(m² s²) ⇒ δ̄ = κ_d / L².
    let factor = kappa / (L * L);
    // Γ̃ = r1 T̃1 / I1 (per unit equivalent mass, as in eq. 10): T̃1 = Γ̃ I1 / r1.
    let ripple = forcing * w * w * L * 0.0025 / 0.05;
    let mut s = common::scene(
        &format!(
            "contact = \"linear\"\ndamping = {damping}\ndamping_variation = {variation}\n\
             [mesh.cubic]\nstiffness_factor = {factor:e}\n\
             [mesh.stiffness]\nkind = \"fourier\"\nmean = {K0:e}\ncos = [{:e}]",
            mu * K0
        ),
        &format!(
            "pinion_speed = {}\ninput_torque = 0.0\nload_torque = 0.0\ntorque_ripple = {ripple:e}",
            common::pinion_speed_for_mesh_frequency(nu * w / TAU)
        ),
        &format!("[initial]\ndte = {:e}", 0.01 * L),
    );
    s.solver.method = MethodChoice::Rk;
    s.solver.rk_method = Method::Dop853;
    s.solver.rtol = 1e-10;
    s.solver.atol = 1e-18;
    s
}

/// Steady amplitude (in L) of the response component at `ratio` × mesh frequency, after
/// `settle` dimensionless time units, by a DFT over 20 response periods.
fn amplitude(scene: &PairScene, nu: f64, ratio: f64, settle: f64) -> f64 {
    let w = omega_n();
    let mut sim = Simulation::new(scene).unwrap();
    let period = TAU / (ratio * nu * w);
    let t0 = (settle / w / period).ceil() * period;
    let n = 20 * 64;
    let (mut re, mut im) = (0.0, 0.0);
    for i in 0..n {
        let t = t0 + i as f64 * period / 64.0;
        sim.advance_to(t).unwrap();
        let angle = TAU * i as f64 / 64.0;
        re += sim.state()[0] * angle.cos();
        im += sim.state()[0] * angle.sin();
    }
    2.0 * (re * re + im * im).sqrt() / n as f64 / L
}

/// Eq. 30 (reconstructed): ((Ω+ν)s̄/Γ̃)² {[Ω − ν + (3/8)κ s̄²]² + α²/4} = 1, Ω = 1; the positive
/// roots s̄ by bisection on each monotone stretch (here the response is single-valued).
fn fundamental_formula(nu: f64, alpha: f64, kappa: f64, forcing: f64) -> f64 {
    let g = |a: f64| {
        let s2 = a * a;
        ((1.0 + nu) * a / forcing).powi(2)
            * ((1.0 - nu + 0.375 * kappa * s2).powi(2) + alpha * alpha / 4.0)
            - 1.0
    };
    let (mut lo, mut hi) = (0.0, 10.0);
    assert!(g(hi) > 0.0);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if g(mid) > 0.0 {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Closed form of eq. 32, "+" branch, with s̄1 = 0: s̄2² = (4/(3κ))[(ν − 2) + √(A² + B² − α²)].
fn parametric_formula(nu: f64, alpha: f64, alpha0: f64, mu: f64, kappa: f64) -> Option<f64> {
    let (a, b) = (mu / nu, alpha0 / nu);
    let radicand = a * a + b * b - alpha * alpha;
    if radicand <= 0.0 {
        return None;
    }
    let s2 = 4.0 / (3.0 * kappa) * ((nu - 2.0) + radicand.sqrt());
    (s2 > 0.0).then(|| s2.sqrt())
}

#[test]
fn fundamental_resonance_matches_the_cubic() {
    let (alpha, kappa, forcing) = (0.02, 0.05, 0.005);
    println!("ν      s̄1 formula   s̄1 simulated   rel. diff");
    for nu in [0.95, 0.98, 1.0, 1.02, 1.04] {
        let scene = bugaru(nu, alpha, 0.0, 0.0, kappa, forcing);
        let formula = fundamental_formula(nu, alpha, kappa, forcing);
        let simulated = amplitude(&scene, nu, 1.0, 1500.0);
        let rel = (simulated - formula).abs() / formula;
        println!("{nu:.2}   {formula:.5}      {simulated:.5}        {rel:.2e}");
        assert!(
            rel <= 0.02,
            "fundamental at ν = {nu}: {simulated} vs {formula}"
        );
    }
}

#[test]
fn principal_parametric_resonance_matches_the_closed_form() {
    // First order in the small parameters: μ = 0.02, α = 0.002, detuning inside the band
    // |ν − 2| < √(μ²/4 − α²) ≈ 0.0099 (with μ = 0.05 the simulated amplitudes exceed the
    // formula by up to 2.1 %, the O(μ) error of a first-order method).
    let (alpha, mu, kappa) = (0.002, 0.02, 0.05);
    println!("ν      s̄2 formula   s̄2 simulated   rel. diff");
    for nu in [1.995, 2.0, 2.005, 2.009] {
        let scene = bugaru(nu, alpha, 0.0, mu, kappa, 0.0);
        let formula = parametric_formula(nu, alpha, 0.0, mu, kappa).expect("inside the band");
        let simulated = amplitude(&scene, nu, 0.5, 15000.0);
        let rel = (simulated - formula).abs() / formula;
        println!("{nu:.3}  {formula:.5}      {simulated:.5}        {rel:.2e}");
        assert!(
            rel <= 0.02,
            "parametric at ν = {nu}: {simulated} vs {formula}"
        );
    }
}

#[test]
fn parametric_resonance_vanishes_above_the_damping_threshold() {
    // Damping tied to stiffness by the logarithmic decrement (eq. 9): α = ΔΩ²/(πν),
    // α0 = ΔμΩ²/(πν); at ν = 2Ω the branch exists iff Δ < 2πμ/√(4 − μ²).
    let (mu, kappa, nu) = (0.02, 0.05, 2.0);
    let critical = 2.0 * PI * mu / (4.0 - mu * mu).sqrt();
    for (factor, expect_response) in [(0.8, true), (1.2, false)] {
        let delta = factor * critical;
        let (alpha, alpha0) = (delta / (PI * nu), delta * mu / (PI * nu));
        let scene = bugaru(nu, alpha, alpha0, mu, kappa, 0.0);
        let simulated = amplitude(&scene, nu, 0.5, 20000.0);
        let formula = parametric_formula(nu, alpha, alpha0, mu, kappa);
        println!("Δ = {factor} Δ_crit: s̄2 simulated {simulated:.5}, formula {formula:?}");
        assert_eq!(formula.is_some(), expect_response);
        if expect_response {
            let f = formula.unwrap();
            assert!((simulated - f).abs() <= 0.02 * f, "{simulated} vs {f}");
        } else {
            assert!(
                simulated < 1e-6,
                "the parametric response must decay: {simulated}"
            );
        }
    }
}
