//! Sweeps against the perturbation theory of Liu 2007 ch. 3, specialised to one mesh
//! (`models-liu-parker-2007.md` §2.5): for `m x'' + c x' + k(t) H(x) x = F` the mode is
//! `s = 1`, `C = 1`, `c_r = 1`, `|R_3| = |κ̃_1|/k̄ = ε_pp |sin πς| / π` (rectangular wave,
//! eq. 3.13) and contact loss starts at `α_c = 1/2`, i.e. when the DTE amplitude reaches the
//! mean deflection, at the frequencies (3.33)
//! `ω_c = 1 ± √(|R_3|² − Γ²)` (in units of the natural frequency, Γ = ζ).
//! The first-order theory holds as ε → 0; the tests print the trend for three ε, for the
//! onset of contact loss and for the resonance peak on the backbone (eq. 3.34).

mod common;

use std::f64::consts::{PI, TAU};

use common::M_E;
use geardyn::analysis::{sweep, Direction, SweepOptions};

const K: f64 = 2.0e8;
const CONTACT_RATIO: f64 = 1.5;

/// Relative error of the up-sweep onset of contact loss for one ε, in units of the detuning
/// `1 − ω_c1`.
fn onset_error(eps: f64) -> (f64, f64, f64) {
    let r3 = eps * (PI * CONTACT_RATIO).sin().abs() / PI;
    let zeta = 0.5 * r3;
    let omega_c1 = 1.0 - (r3 * r3 - zeta * zeta).sqrt();
    let f_n = (K / M_E).sqrt() / TAU;
    let scene = common::scene(
        &format!(
            "contact = \"contact_loss\"\ndamping_ratio = {zeta}\n[mesh.stiffness]\n\
             kind = \"rectangular\"\nmean = {K:e}\npeak_to_peak_ratio = {eps}\n\
             contact_ratio = {CONTACT_RATIO}"
        ),
        "pinion_speed = 100.0\ninput_torque = 100.0",
        "",
    );
    // Up sweep over ω/ω_n from well below the onset to the resonance, resolution 1/200 of
    // the detuning.
    let detuning = 1.0 - omega_c1;
    let ratios: Vec<f64> = (0..=300)
        .map(|i| 1.0 - 2.0 * detuning + 1.5 * detuning * i as f64 / 200.0)
        .collect();
    let speeds = ratios
        .iter()
        .map(|r| common::pinion_speed_for_mesh_frequency(r * f_n))
        .collect();
    let options = SweepOptions {
        tolerance: 1e-9,
        max_transient_periods: 20_000,
        ..SweepOptions::new(speeds, Direction::Up)
    };
    let points = sweep(&scene, &options, &|_, _| {}).unwrap().points;
    let onset = points
        .iter()
        .position(|p| p.meshes[0].contact_loss_fraction > 0.0)
        .expect("contact loss before resonance");
    let measured = ratios[onset];
    ((measured - omega_c1).abs() / detuning, measured, omega_c1)
}

#[test]
fn contact_loss_onset_approaches_perturbation_theory() {
    println!("ε_pp    ω_c1 theory   ω_c1 sweep   |error| / detuning");
    let mut errors = Vec::new();
    for eps in [0.2, 0.1, 0.05] {
        let (err, measured, theory) = onset_error(eps);
        println!("{eps:5}   {theory:.6}      {measured:.6}     {err:.3}");
        errors.push(err);
    }
    assert!(
        errors.windows(2).all(|w| w[1] <= w[0] + 0.01),
        "the error must not grow as ε → 0: {errors:?}"
    );
    assert!(
        errors[2] < 0.1,
        "at ε = 0.05 the onset is within 10 % of the detuning"
    );
}

/// Peak of the resonance (eq. 3.34): `α_p = |R_3|/(2Γ)` and, on the backbone,
/// `ω_p = 1 − (θ − sinθ cosθ)/(2π)` with `θ = arccos(1/(2α_p))`. With `Γ = |R_3|/(1 + ε)` the
/// separation stays small as ε → 0 (the theory assumes θ/π = O(ε)). Returns the relative
/// errors of the peak amplitude and of the peak detuning `1 − ω_p`.
fn peak_errors(eps: f64) -> (f64, f64) {
    let r3 = eps * (PI * CONTACT_RATIO).sin().abs() / PI;
    let zeta = r3 / (1.0 + eps);
    let alpha_p = r3 / (2.0 * zeta);
    let theta = (1.0 / (2.0 * alpha_p)).acos();
    let omega_p = 1.0 - (theta - theta.sin() * theta.cos()) / (2.0 * PI);
    let f_n = (K / M_E).sqrt() / TAU;
    let scene = common::scene(
        &format!(
            "contact = \"contact_loss\"\ndamping_ratio = {zeta}\n[mesh.stiffness]\n\
             kind = \"rectangular\"\nmean = {K:e}\npeak_to_peak_ratio = {eps}\n\
             contact_ratio = {CONTACT_RATIO}"
        ),
        "pinion_speed = 100.0\ninput_torque = 100.0",
        "",
    );
    let static_deflection = 100.0 / 0.05 / K;
    // Down sweep across the resonance, resolution 1/100 of the half-power width 2ζ.
    let width = 2.0 * zeta;
    let ratios: Vec<f64> = (0..=400)
        .map(|i| 1.0 + 2.0 * width - i as f64 * width / 100.0)
        .collect();
    let speeds: Vec<f64> = ratios
        .iter()
        .rev()
        .map(|r| common::pinion_speed_for_mesh_frequency(r * f_n))
        .collect();
    let options = SweepOptions {
        tolerance: 1e-9,
        max_transient_periods: 50_000,
        ..SweepOptions::new(speeds, Direction::Down)
    };
    let points = sweep(&scene, &options, &|_, _| {}).unwrap().points;
    let peak = points
        .iter()
        .max_by(|a, b| a.meshes[0].harmonics[0].total_cmp(&b.meshes[0].harmonics[0]))
        .unwrap();
    // DTE amplitude 2|s|α x̄ with s = 1.
    let alpha = peak.meshes[0].harmonics[0] / (2.0 * static_deflection);
    let omega = peak.mesh_frequency / f_n;
    println!("{eps:5}   α_p {alpha_p:.5} vs {alpha:.5}   ω_p {omega_p:.6} vs {omega:.6}");
    (
        (alpha - alpha_p).abs() / alpha_p,
        ((1.0 - omega) - (1.0 - omega_p)).abs() / (1.0 - omega_p),
    )
}

#[test]
fn resonance_peak_approaches_the_backbone() {
    println!("ε_pp    peak amplitude α (theory vs sweep)   peak frequency ω/ω_n (theory vs sweep)");
    let errors: Vec<(f64, f64)> = [0.2, 0.1, 0.05].into_iter().map(peak_errors).collect();
    println!("relative errors (amplitude, detuning): {errors:.3?}");
    assert!(
        errors.windows(2).all(|w| w[1].0 <= w[0].0 + 0.01),
        "amplitude error must not grow"
    );
    assert!(errors[2].0 < 0.05, "peak amplitude within 5 % at ε = 0.05");
    // The backbone's frequency shift is itself O(ε^{3/2}) here, so its first-order error is
    // relatively large; it must still shrink as ε → 0.
    assert!(
        errors.windows(2).all(|w| w[1].1 < w[0].1),
        "peak detuning error must fall"
    );
}
