//! Issue 38 acceptance 3: harmonic balance at the default H = 20 on `spur_pair` with a runout
//! and a cumulative pitch-error table on the pinion (`docs/errors.md`). The response period is
//! one pinion revolution (38 mesh periods); the basis holds the combination tones of the mesh
//! and the revolution frequency of total order ≤ 20. The oracle is `periodic` (Newton
//! shooting, Runge–Kutta with the errors), never HB itself.

use std::f64::consts::TAU;

use geardyn::analysis::hb::{self, HbOptions};
use geardyn::commands::steady::{periodic, periodic_responses};
use geardyn::model::Drivetrain;
use geardyn::scene::Scene;
use geardyn::with_drivetrain;

/// `fmu/spur_pair` (backlash, contact loss at these speeds) with a 5 µm runout and a pitch
/// table of two tooth orders on the pinion.
fn spur_pair_with_errors() -> Scene {
    let pitch: Vec<String> = (0..38)
        .map(|i| {
            let x = i as f64 / 38.0;
            let f = |x: f64| 1e-6 * (TAU * x).sin() + 0.3e-6 * (3.0 * TAU * x).cos();
            format!("{:e}", f(x) - f(0.0))
        })
        .collect();
    let text = include_str!("../fmu/spur_pair/scene.toml")
        .replacen(
            "inertia = 0.002621",
            &format!(
                "inertia = 0.002621\nrunout = {{ amplitude = 5e-6, phase = 0.3 }}\n\
                 cumulative_pitch_errors = [{}]",
                pitch.join(", ")
            ),
            1,
        )
        .replacen(
            "damping_ratio = 0.05",
            "damping_ratio = 0.05\npressure_angle = 20.0",
            1,
        );
    Scene::from_toml_str(&text, "spur_pair_errors").unwrap()
}

fn relative(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// HB at H = 20 and `periodic` at `speed`: relative errors of the DTE RMS and the peak force.
fn errors_at(speed: f64) -> (f64, f64) {
    let mut scene = spur_pair_with_errors();
    scene.set_input_speed(speed);
    let orbit = periodic(&scene, 1, 20).unwrap();
    let reference = periodic_responses(&scene, &orbit).unwrap();
    let sol = hb::solve(&scene, speed, None, &HbOptions::new(20)).unwrap();
    assert_eq!(sol.mesh_periods, 38, "one pinion revolution");
    let (h, r) = (&sol.meshes[0], &reference[0]);
    let (e_rms, e_peak) = (
        relative(h.dte_rms, r.dte_rms),
        relative(h.peak_force, r.peak_force),
    );
    println!(
        "{speed} rad/s ({} orders): DTE RMS {:.6e} vs {:.6e} ({e_rms:.1e}), peak force \
         {:.2} vs {:.2} ({e_peak:.1e}), contact loss {:.3} vs {:.3}",
        sol.orders.len(),
        h.dte_rms,
        r.dte_rms,
        h.peak_force,
        r.peak_force,
        h.contact_loss_fraction,
        r.contact_loss_fraction
    );
    // The errors matter here: without them the orbit differs by far more than 1e-3.
    let mut plain =
        Scene::from_toml_str(include_str!("../fmu/spur_pair/scene.toml"), "spur_pair").unwrap();
    plain.set_input_speed(speed);
    let plain = hb::solve(&plain, speed, None, &HbOptions::new(20)).unwrap();
    assert!(
        relative(plain.meshes[0].dte_rms, r.dte_rms) > 1e-2,
        "{speed} rad/s"
    );
    (e_rms, e_peak)
}

/// Acceptance 3 over the scene's speeds, not one point: DTE RMS and peak force within 1e-3 of
/// `periodic` without contact loss (300–400 rad/s) and with it (440 and 520 rad/s: 44 % and
/// 25 % of the period). Measured on 2026-11-30 (`-- --nocapture`): DTE RMS ≤ 6.3e-7; peak
/// force 8.5e-4, 7.1e-4, 6.5e-4, 1.1e-5, 5.5e-5, 4.4e-5. At 380 rad/s the peak force erred by
/// 1.8e-3 (DTE RMS 8.7e-5) while the quadratures of both HB and the oracle's statistics split
/// at the nominal knots, which the runout moves by up to 2e-3 cycles (a rule across a
/// stiffness jump); both now split where the knots lie ([`Drivetrain::mesh_knot_phase`]).
#[test]
fn hb_h20_with_runout_and_pitch_errors_agrees_with_periodic() {
    let mut failed = Vec::new();
    for speed in [300.0, 350.0, 380.0, 400.0, 440.0, 520.0] {
        let (e_rms, e_peak) = errors_at(speed);
        if !(e_rms <= 1e-3 && e_peak <= 1e-3) {
            failed.push(speed);
        }
    }
    assert!(failed.is_empty(), "beyond 1e-3 at {failed:?} rad/s");
}

/// The knots the quadratures split at are where the law jumps: over one pinion revolution, the
/// mesh stiffness (every engaged pair in contact) differs 1e-9 cycles either side of each
/// knot [`Drivetrain::mesh_knot_phase`] places, and where the runout moved the knot by more
/// than 1e-6 cycles it does not jump at the nominal knot.
#[test]
fn moved_knots_are_where_the_mesh_law_jumps() {
    let scene = spur_pair_with_errors();
    with_drivetrain!(scene.simulation().unwrap(), sim => {
        let m = sim.model();
        let (f, p0) = (Drivetrain::mesh_frequency(m, 0), Drivetrain::mesh_phase(m, 0, 0.0));
        // Well beyond the STE and the errors (a few µm): every engaged pair touches.
        let s = 3.0 * Drivetrain::static_mesh_forces(m)[0] / Drivetrain::mean_mesh_law(m, 0).0;
        let k = |p: f64| Drivetrain::mesh_law(m, 0, (p - p0) / f, s, 0.0).stiffness[0];
        let jumps = |p: f64| k(p - 1e-9) != k(p + 1e-9);
        let mut moved = 0;
        let breakpoints = Drivetrain::mesh_breakpoints(m, 0);
        assert_eq!(breakpoints.len(), 2, "rectangular stiffness");
        for b in breakpoints {
            for c in 0..38 {
                let nominal = p0 + (b - p0).rem_euclid(1.0) + c as f64;
                let knot = Drivetrain::mesh_knot_phase(m, 0, nominal);
                assert!(jumps(knot), "no jump at the knot {knot} (nominal {nominal})");
                if (knot - nominal).abs() > 1e-6 {
                    moved += 1;
                    assert!(!jumps(nominal), "a jump at the nominal knot {nominal}");
                }
            }
        }
        assert!(moved > 60, "{moved} of 76 knots moved");
    })
}
