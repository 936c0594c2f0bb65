//! Issue 19, item 4: `periodic` and `sweep` report each mesh's dynamic force — peak, RMS about
//! the mean and dynamic factor — against the closed form of the linear pair with constant
//! stiffness `k`, harmonic STE `e = a sin ω t` and damping `c`:
//! `m x'' + c(x' − ė) + k(x − e) = F` gives the mesh force `F_m = F − m x''`, so in the
//! steady state `F_m = F + m ω² |X| cos(ωt + φ)` with `X = (k + icω) a / (k − mω² + icω)`:
//! RMS `m ω² |X| / √2`, peak `F + m ω² |X|`, dynamic factor `peak / F`. For the single pair and
//! for the same pair as a one-mesh drivetrain.

mod common;

use std::f64::consts::TAU;

use common::{pinion_speed_for_mesh_frequency, scene, M_E};
use geardyn::analysis::{self, Direction, SweepOptions};
use geardyn::commands::steady::{periodic, periodic_responses};
use geardyn::scene::{KernelChoice, Scene};

const K: f64 = 2.0e8;
const C: f64 = 200.0;
const A: f64 = 1.0e-6;
/// `T_1 / r_b1`, N.
const F: f64 = 100.0 / 0.05;

/// Amplitude `m ω² |X|` of the dynamic mesh force at mesh angular frequency `w`.
fn force_amplitude(w: f64) -> f64 {
    let (nr, ni) = (K * A, C * w * A);
    let (dr, di) = (K - M_E * w * w, C * w);
    M_E * w * w * ((nr * nr + ni * ni) / (dr * dr + di * di)).sqrt()
}

fn scenes(f_mesh: f64) -> [Scene; 2] {
    let pair = scene(
        &format!(
            "contact = \"linear\"\ndamping = {C}\n[mesh.stiffness]\nkind = \"constant\"\n\
             value = {K:e}\n[mesh.ste]\nsin = [{A:e}]"
        ),
        &format!(
            "pinion_speed = {}\ninput_torque = 100.0",
            pinion_speed_for_mesh_frequency(f_mesh)
        ),
        "",
    );
    let pair = Scene::from(pair);
    let train = pair.on_drivetrain_kernel().unwrap();
    [pair, train]
}

/// Checks one mesh's statistics against the closed form: from the continuous solution
/// (issue 31), the RMS and the peak are exact to the orbit's convergence.
fn check(label: &str, f_mesh: f64, peak: f64, rms: f64, factor: f64) {
    let amp = force_amplitude(TAU * f_mesh);
    let rms_err = (rms - amp / 2f64.sqrt()).abs() / (amp / 2f64.sqrt());
    let peak_err = (peak - (F + amp)).abs() / (F + amp);
    println!(
        "{label}: F_dyn amplitude {amp:.6e} N; RMS rel. error {rms_err:.2e}; peak {peak:.9e} N \
         (closed form {:.9e}, rel. error {peak_err:.2e}); dynamic factor {factor:.6}",
        F + amp
    );
    assert!(rms_err < 1e-9, "{label}: RMS error {rms_err:e}");
    assert!(peak_err < 1e-9, "{label}: peak {peak} vs {}", F + amp);
    assert!(
        (factor - peak / F).abs() < 1e-12 * factor,
        "{label}: {factor}"
    );
}

#[test]
fn periodic_and_sweep_force_match_the_closed_form_for_both_kernels() {
    let f_n = (K / M_E).sqrt() / TAU;
    for ratio in [0.6, 1.3] {
        let f_mesh = ratio * f_n;
        for scene in scenes(f_mesh) {
            let kind = match scene.kernel {
                KernelChoice::Pair => "pair",
                KernelChoice::Drivetrain(_) => "drivetrain",
            };
            let orbit = periodic(&scene, 1, 20).unwrap();
            let meshes = periodic_responses(&scene, &orbit).unwrap();
            assert_eq!(meshes.len(), 1);
            let m = &meshes[0];
            assert!((m.mesh_frequency - f_mesh).abs() < 1e-9 * f_mesh);
            check(
                &format!("periodic {kind} f_m/f_n = {ratio}"),
                f_mesh,
                m.peak_force,
                m.force_rms,
                m.dynamic_factor,
            );
            let speed = scene.input_speed();
            let options = SweepOptions::new(vec![speed, speed * 1.001], Direction::Up);
            let sweep = analysis::sweep(&scene, &options, &|_, _| {}).unwrap();
            let p = &sweep.points[0].meshes[0];
            check(
                &format!("sweep {kind} f_m/f_n = {ratio}"),
                f_mesh,
                p.peak_force,
                p.force_rms,
                p.dynamic_factor,
            );
        }
    }
}
