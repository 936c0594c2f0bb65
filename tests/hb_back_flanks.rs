//! Harmonic balance with the back flanks on their own line of action (issue 33; `docs/train.md`,
//! "Back flanks"; `docs/planetary.md`): on a stage mesh the back flanks act along the drive line
//! mirrored about the planet's radial direction, so HB carries the back deflection `S̃_n` as a
//! second coordinate of the mesh. Oracles that share no code with HB:
//!
//! - Newton shooting (the exact propagator's period map with saltation, `geardyn periodic`)
//!   from the HB state, on orbits where the ring (and sun) meshes spend a third of the period
//!   in back contact: DTE RMS, peak force, stability verdict;
//! - a backlash so large that the back flanks never touch gives the contact-loss HB;
//! - up/down `sweep`s (time integration) leave the periodic branch at HB's fold.
//!
//! And the time integration through tooth wedging (both flanks pressed at once) on the same
//! stage, where it once stopped.
//!
//! The stage is the shipped `examples/planetary/ev_reducer_3p.toml` at 10 N·m (static mesh
//! deflection 0.58 µm) with a 1 µm cosine STE on every mesh (the excitation does not scale with
//! the load, so the teeth rattle) and 2b = 1 µm.

use geardyn::analysis::hb::{self, ContinuationOptions, HbOptions};
use geardyn::analysis::shooting::shoot_from;
use geardyn::analysis::{sweep, Direction, ShootingOptions, Stability, SweepOptions};
use geardyn::commands::steady::periodic_responses;
use geardyn::model::Drivetrain;
use geardyn::scene::Scene;
use geardyn::with_drivetrain;

/// The stage with `backlash` (2b, m; `None`: contact loss, no back side).
fn stage(backlash: Option<f64>) -> Scene {
    Scene::from_toml_str(&stage_text(backlash), "ev_reducer_3p at 10 N·m with STE").unwrap()
}

/// [`stage`]'s scene text.
fn stage_text(backlash: Option<f64>) -> String {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/planetary/ev_reducer_3p.toml"
    );
    let mut text = std::fs::read_to_string(path).unwrap();
    text = text.replace("input_torque = 150.0", "input_torque = 10.0");
    let stiffness = "stiffness = { kind = \"rectangular\", mean = 4e8, peak_to_peak_ratio = \
                     0.25, contact_ratio = 1.55 }";
    assert_eq!(text.matches(stiffness).count(), 6);
    text = text.replace(stiffness, &format!("{stiffness}\nste = {{ cos = [1e-6] }}"));
    if let Some(b) = backlash {
        text = text.replace(
            "contact = \"contact_loss\"",
            &format!("contact = \"backlash\"\nbacklash = {b:e}"),
        );
    }
    text
}

/// Per mesh, the fraction of `samples` instants of the orbit through `y0` (at `t = 0`) spent in
/// back contact (`<mesh>.contact_state` = −1).
fn back_contact(scene: &Scene, y0: &[f64], samples: usize) -> Vec<f64> {
    with_drivetrain!(scene.simulation().unwrap(), sim => {
        let mut sim = sim;
        sim.set_y(0.0, y0);
        let model = sim.model().clone();
        let names = model.row_names();
        let columns: Vec<usize> = (0..model.mesh_count())
            .map(|n| {
                let c = format!("{}contact_state", model.mesh_prefix(n));
                names.iter().position(|x| *x == c).unwrap()
            })
            .collect();
        let period = geardyn::model::response_period(&model).unwrap();
        let mut count = vec![0usize; columns.len()];
        let mut row = Vec::new();
        for i in 0..samples {
            sim.advance_to(period * (i as f64 + 0.5) / samples as f64).unwrap();
            sim.model().output_row(sim.t(), sim.y(), &mut row);
            for (n, &c) in columns.iter().enumerate() {
                count[n] += usize::from(row[c] == -1.0);
            }
        }
        count.iter().map(|&c| c as f64 / samples as f64).collect()
    })
}

/// The periodic orbit by Newton shooting from `y0` (no warm-up).
fn shoot_at(scene: &Scene, y0: &[f64]) -> geardyn::analysis::PeriodicOrbit {
    with_drivetrain!(scene.simulation().unwrap(), sim => {
        let mut sim = sim;
        sim.set_y(0.0, y0);
        let options = ShootingOptions {
            warmup_periods: 0,
            ..ShootingOptions::default()
        };
        shoot_from(sim, &scene.solver, &options, &|_, _| {}).unwrap()
    })
}

/// HB (H = 40) against shooting from its state at speeds where the orbit has back contact:
/// every mesh's DTE RMS and peak force to ≤ 1e-4 (measured ≤ 1.7e-5), the spectral radius of
/// the HB state's monodromy within 1e-3 of the orbit's, and the same stability verdict.
#[test]
fn stage_with_back_contact_matches_shooting() {
    let scene = stage(Some(1e-6));
    println!("speed   H  |ΔRMS|/RMS  |Δpeak|/peak  |μ| HB      |μ| shooting  back contact");
    let mut most_back: f64 = 0.0;
    for speed in [2300.0, 2470.0, 2500.0, 2512.0] {
        let mut at = scene.clone();
        at.set_input_speed(speed);
        let mut options = ContinuationOptions::new(speed, speed + 1e-3);
        options.max_points = 1;
        options.shooting_check_margin = 0.0;
        let point = hb::continuation(&at, &HbOptions::new(40), &options)
            .unwrap()
            .remove(0);
        let hb_sol = &point.solution;
        let orbit = shoot_at(&at, &hb_sol.state_at(0.0));
        let responses = periodic_responses(&at, &orbit).unwrap();
        let back = back_contact(&at, &orbit.y0, 2000);
        let (mut rms, mut peak): (f64, f64) = (0.0, 0.0);
        for (h, s) in hb_sol.meshes.iter().zip(&responses) {
            rms = rms.max((h.dte_rms - s.dte_rms).abs() / s.dte_rms);
            peak = peak.max((h.peak_force - s.peak_force).abs() / s.peak_force);
        }
        let multipliers = point.multipliers.as_ref().unwrap();
        let hb_radius = multipliers.iter().map(|m| m.norm()).fold(0.0, f64::max);
        let radius = orbit.spectral_radius();
        println!(
            "{speed:6}  40  {rms:.2e}    {peak:.2e}      {hb_radius:.6}  {radius:.6}      {back:?}"
        );
        most_back = most_back.max(back.iter().copied().fold(0.0, f64::max));
        assert!(rms <= 1e-4 && peak <= 1e-4, "{speed}: {rms:e} {peak:e}");
        assert!((hb_radius - radius).abs() <= 1e-3, "{speed}");
        if (radius - 1.0).abs() > 1e-4 {
            assert_eq!(
                Stability::of(multipliers) == Stability::Stable,
                radius < 1.0,
                "{speed}: |μ| {hb_radius} against {radius}"
            );
        }
    }
    // The ring meshes spend a third of the period in back contact at 2500 rad/s.
    assert!(most_back > 0.3, "{most_back}");
}

/// A backlash (1 mm) the back flanks never close gives the contact-loss HB: every coordinate's
/// coefficients to 1e-10 of the largest, the per-mesh results to 1e-10 relative (the back
/// deflections are extra unknowns of the Newton system, so its rounding differs).
#[test]
fn unreached_back_flanks_change_nothing() {
    for speed in [2200.0, 2500.0] {
        let a = hb::solve(&stage(Some(1e-3)), speed, None, &HbOptions::new(20)).unwrap();
        let b = hb::solve(&stage(None), speed, None, &HbOptions::new(20)).unwrap();
        let scale = b.coefficients.iter().fold(0.0, |m: f64, x| m.max(x.abs()));
        let coefficients = (a.coefficients.iter().zip(&b.coefficients))
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max)
            / scale;
        let mut results: f64 = 0.0;
        for (x, y) in a.meshes.iter().zip(&b.meshes) {
            for (p, q) in [
                (x.dte_rms, y.dte_rms),
                (x.peak_force, y.peak_force),
                (x.force_rms, y.force_rms),
                (x.contact_loss_fraction, y.contact_loss_fraction),
            ] {
                results = results.max((p - q).abs() / q.abs().max(1e-300));
            }
        }
        let loss = b
            .meshes
            .iter()
            .map(|m| m.contact_loss_fraction)
            .fold(0.0, f64::max);
        println!("{speed}: coefficients {coefficients:.2e}, results {results:.2e} (contact loss {loss:.3})");
        assert!(loss > 0.1);
        assert!(coefficients <= 1e-10 && results <= 1e-10);
    }
}

/// `sweep` (time integration, up and down) on the stage with backlash leaves the periodic
/// branch where the HB branch folds (the lower branch ends at a saddle-node, the branch beyond
/// is unstable): both directions jump within a sweep step (2 rad/s) of the fold, and the
/// converged sweep points equal HB's lower-branch orbits (DTE RMS to 1e-3).
#[test]
fn sweep_leaves_the_branch_at_the_hb_fold() {
    let scene = stage(Some(1e-6));
    let branch = hb::continuation(
        &scene,
        &HbOptions::new(20),
        &ContinuationOptions::new(2200.0, 2260.0),
    )
    .unwrap();
    let fold = branch.iter().position(|p| p.fold).expect("a fold");
    let fold_speed = branch[fold].speed;
    println!(
        "{} points, first fold at {fold_speed:.3} rad/s",
        branch.len()
    );
    assert!((2220.0..2230.0).contains(&fold_speed));
    for p in &branch[..fold] {
        if p.speed < fold_speed - 1.0 {
            assert!(p.stable().unwrap(), "lower branch at {}", p.speed);
        }
    }
    assert!(!branch[fold + 2].stable().unwrap());
    let speeds: Vec<f64> = (0..9).map(|i| 2214.0 + 2.0 * i as f64).collect();
    // Beyond the fold the response is aperiodic: 800 response periods show it (the
    // converged points settle within ~100).
    let options = SweepOptions {
        max_transient_periods: 800,
        ..SweepOptions::new(speeds.clone(), Direction::Both)
    };
    let points = sweep(&scene, &options, &|_, _| {}).unwrap().points;
    for dir in [Direction::Up, Direction::Down] {
        for &speed in &speeds {
            let p = points
                .iter()
                .find(|p| p.direction == dir && p.speed == speed)
                .unwrap();
            let on_branch = p.converged;
            println!(
                "{dir:?} {speed}: converged {on_branch}, rp1 DTE RMS {:.4e}",
                p.meshes[1].dte_rms
            );
            // Within a sweep step below the fold the slow approach may outlast the run.
            if speed < fold_speed - 2.0 || speed > fold_speed {
                assert_eq!(on_branch, speed < fold_speed, "{dir:?} {speed}");
            }
            if on_branch {
                // HB's orbit at this speed on the lower branch (Newton from the nearest point).
                let near = branch[..fold]
                    .iter()
                    .min_by(|a, b| (a.speed - speed).abs().total_cmp(&(b.speed - speed).abs()))
                    .unwrap();
                let guess = Some(near.solution.coefficients.as_slice());
                let sol = hb::solve(&scene, speed, guess, &HbOptions::new(20)).unwrap();
                for (h, s) in sol.meshes.iter().zip(&p.meshes) {
                    let e = (h.dte_rms - s.dte_rms).abs() / s.dte_rms;
                    assert!(e <= 1e-3, "{dir:?} {speed}: {e:e}");
                }
            }
        }
    }
}

/// Tooth wedging (`docs/planetary.md`, "Tooth wedging"): at 580 and 750 rad/s the planets
/// swing radially by more than b / sin α and both flanks of the ring meshes are pressed at
/// once. Before the wedged state was modelled, `simulate` stopped there with "65 state events
/// without progress" (at 750 rad/s by both propagators), and so did the `sweep` points at 2260
/// and 2270 rad/s. Now both propagators run through (the same DTE to 1e-6 of its scale,
/// measured 1.5e-15 m), with rows in the wedged state (`contact_state` 2), and the sweep
/// completes. The time series against an independent model with wedging:
/// `tests/python/test_backflank_reference.py::test_wedged_stage_matches_geardyn`.
#[test]
fn wedged_stage_simulates_and_sweeps() {
    let dir = std::env::temp_dir().join(format!("geardyn_wedging_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let text = stage_text(Some(1e-6));
    let line = "input_speed = 1047.1975511965977";
    assert_eq!(text.matches(line).count(), 1);
    for speed in [580.0, 750.0] {
        let scene = dir.join(format!("stage_{speed}.toml"));
        std::fs::write(
            &scene,
            text.replace(line, &format!("input_speed = {speed:?}")),
        )
        .unwrap();
        let mut runs = Vec::new();
        for method in ["rk", "exact"] {
            let out = dir.join(format!("run_{speed}_{method}.csv"));
            let done = std::process::Command::new(env!("CARGO_BIN_EXE_geardyn"))
                .args(["simulate", scene.to_str().unwrap(), "--out"])
                .arg(&out)
                .args(["--method", method, "--quiet"])
                .output()
                .unwrap();
            let stderr = String::from_utf8_lossy(&done.stderr);
            assert!(done.status.success(), "{speed} {method}: {stderr}");
            let csv = std::fs::read_to_string(&out).unwrap();
            let mut lines = csv.lines();
            let names: Vec<&str> = lines.next().unwrap().split(',').collect();
            let rows: Vec<Vec<f64>> = lines
                .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
                .collect();
            let columns = |suffix: &str| -> Vec<usize> {
                (0..names.len())
                    .filter(|&c| names[c].ends_with(suffix))
                    .collect()
            };
            let wedged: usize = columns(".contact_state")
                .iter()
                .map(|&c| rows.iter().filter(|r| r[c] == 2.0).count())
                .sum();
            println!(
                "{speed} rad/s, {method}: {} rows, {wedged} mesh rows wedged",
                rows.len()
            );
            assert!(wedged > 0, "{speed} {method}");
            let dte: Vec<Vec<f64>> = rows
                .iter()
                .map(|r| columns(".dte").iter().map(|&c| r[c]).collect())
                .collect();
            runs.push(dte);
        }
        let scale = runs[1]
            .iter()
            .flatten()
            .fold(0.0, |m: f64, x| m.max(x.abs()));
        let difference = (runs[0].iter().flatten().zip(runs[1].iter().flatten()))
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        println!(
            "{speed} rad/s: RK and exact DTE differ by {difference:.2e} m (scale {scale:.2e})"
        );
        assert!(difference <= 1e-6 * scale, "{speed}: {difference:e}");
    }
    std::fs::remove_dir_all(&dir).ok();
    let speeds = vec![2260.0, 2270.0];
    let options = SweepOptions {
        max_transient_periods: 200,
        ..SweepOptions::new(speeds, Direction::Both)
    };
    let points = sweep(&stage(Some(1e-6)), &options, &|_, _| {})
        .unwrap()
        .points;
    assert_eq!(points.len(), 4);
}
