//! Sweeps against the perturbation theory of Liu 2007 ch. 3, specialised to one mesh
//! (`models-liu-parker-2007.md` §2.5): for `m x'' + c x' + k(t) H(x) x = F` the mode is
//! `s = 1`, `C = 1`, `c_r = 1`, `|R_3| = |κ̃_1|/k̄ = ε_pp |sin πς| / π` (rectangular wave,
//! eq. 3.13) and contact loss starts at `α_c = 1/2`, i.e. when the DTE amplitude reaches the
//! mean deflection, at the frequencies (3.33)
//! `ω_c = 1 ± √(|R_3|² − Γ²)` (in units of the natural frequency, Γ = ζ).
//! The first-order theory holds as ε → 0; the test prints the trend for three ε.

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
    let points = sweep(&scene, &options, &|_, _| {}).unwrap();
    let onset = points
        .iter()
        .position(|p| p.contact_loss_fraction > 0.0)
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
