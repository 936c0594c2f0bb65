//! Frequency sweeps: a linear scene against the closed-form frequency response, the softening
//! jump of the backlash scene (up and down branches differ only near resonance), and the
//! handling of bad ranges and non-converged points.

mod common;

use std::f64::consts::TAU;

use common::M_E;
use geardyn::analysis::{sweep, Direction, SweepOptions};
use geardyn::scene::PairScene;

fn quiet(_: usize, _: usize) {}

#[test]
fn linear_scene_matches_closed_form_frequency_response() {
    // m x'' + c(x' − ė) + k(x − e) = F with e = a cos(ω t): |X| = a |k + icω| / |k − mω² + icω|.
    let (k, c, a) = (2.0e8, 400.0, 1.0e-6);
    let scene = common::scene(
        &format!(
            "contact = \"linear\"\ndamping = {c}\n[mesh.stiffness]\nkind = \"constant\"\n\
             value = {k:e}\n[mesh.ste]\ncos = [{a:e}]"
        ),
        "pinion_speed = 500.0\ninput_torque = 100.0",
        "",
    );
    let f_n = (k / M_E).sqrt() / TAU;
    // Mesh frequencies 0.5 … 1.5 f_n.
    let speeds: Vec<f64> = (0..11)
        .map(|i| common::pinion_speed_for_mesh_frequency(f_n * (0.5 + 0.1 * i as f64)))
        .collect();
    let options = SweepOptions {
        tolerance: 1e-9,
        ..SweepOptions::new(speeds, Direction::Both)
    };
    let points = sweep(&scene, &options, &quiet).unwrap().points;
    let mut worst: f64 = 0.0;
    for p in &points {
        let w = TAU * p.mesh_frequency;
        let num = (k * k + (c * w).powi(2)).sqrt();
        let den = ((k - M_E * w * w).powi(2) + (c * w).powi(2)).sqrt();
        let expected = a * num / den;
        let rel = (p.meshes[0].harmonics[0] - expected).abs() / expected;
        worst = worst.max(rel);
        assert!(p.converged && p.response_periods == Some(1), "{p:?}");
        // The RMS of a pure harmonic is A/√2; the mean is the static deflection F/k.
        assert!(
            (p.meshes[0].dte_rms - p.meshes[0].harmonics[0] / 2f64.sqrt()).abs() <= 1e-6 * expected
        );
        assert!((p.meshes[0].dte_mean - 2000.0 / k).abs() <= 1e-9 * 2000.0 / k + 1e-6 * expected);
        assert!(
            p.meshes[0].harmonics[1] < 1e-6 * expected,
            "no second harmonic in a linear response"
        );
    }
    println!("linear sweep: max relative |A1 − closed form| = {worst:.2e}");
    assert!(worst <= 1e-6);
}

#[test]
fn backlash_scene_shows_softening_jump() {
    let scene = PairScene::example("spur_pair").unwrap();
    let speeds: Vec<f64> = (0..21).map(|i| 300.0 + 15.0 * i as f64).collect();
    let points = sweep(
        &scene,
        &SweepOptions::new(speeds.clone(), Direction::Both),
        &quiet,
    )
    .unwrap()
    .points;
    let up: Vec<_> = points
        .iter()
        .filter(|p| p.direction == Direction::Up)
        .collect();
    let mut down: Vec<_> = points
        .iter()
        .filter(|p| p.direction == Direction::Down)
        .collect();
    down.reverse();
    println!("speed   up RMS      down RMS    up loss  down loss");
    let mut branches_differ = 0;
    for (u, d) in up.iter().zip(&down) {
        assert_eq!(u.speed, d.speed);
        assert!(u.converged && d.converged);
        println!(
            "{:6.1}  {:.4e}  {:.4e}  {:.3}    {:.3}",
            u.speed,
            u.meshes[0].dte_rms,
            d.meshes[0].dte_rms,
            u.meshes[0].contact_loss_fraction,
            d.meshes[0].contact_loss_fraction
        );
        if (u.meshes[0].dte_rms - d.meshes[0].dte_rms).abs() > 0.2 * u.meshes[0].dte_rms {
            branches_differ += 1;
            // Softening: the down sweep stays on the upper, contact-losing branch.
            assert!(
                d.meshes[0].dte_rms > u.meshes[0].dte_rms
                    && d.meshes[0].contact_loss_fraction > u.meshes[0].contact_loss_fraction
            );
        }
    }
    assert!(
        branches_differ >= 2,
        "expected coexisting branches (a jump)"
    );
    // Above the resonance the two sweeps land on the same orbit (below it, the contact-losing
    // branch of a backlash pair persists far down: a classic of impact softening).
    let (u, d) = (up[20], down[20]);
    assert!(
        (u.meshes[0].dte_rms - d.meshes[0].dte_rms).abs() <= 1e-5 * u.meshes[0].dte_rms,
        "{} vs {}",
        u.meshes[0].dte_rms,
        d.meshes[0].dte_rms
    );
    // The jump up on the up sweep: one step multiplies the RMS.
    let jump = up
        .windows(2)
        .map(|w| w[1].meshes[0].dte_rms / w[0].meshes[0].dte_rms)
        .fold(0.0, f64::max);
    println!("largest step ratio on the up sweep: {jump:.2}");
    assert!(jump > 1.3);
}

#[test]
fn bad_ranges_and_unconverged_points() {
    for (range, needle) in [
        ("100:50:10", "upper end 50 rad/s"),
        ("0:50:10", "'0': must be a finite speed > 0"),
        ("100:200:1", "points = 1"),
        ("100:200", "from:to:points"),
        ("a:200:3", "'a': unknown unit"),
    ] {
        let err = SweepOptions::parse_range(range).unwrap_err();
        assert!(err.contains(needle), "{range}: {err}");
    }
    let scene = PairScene::example("spur_pair").unwrap();
    let err = sweep(&scene, &SweepOptions::new(vec![], Direction::Up), &quiet).unwrap_err();
    assert!(err.contains("zero points"), "{err}");
    // Too short a transient (and no shooting to finish it): the point is kept and marked.
    let options = SweepOptions {
        min_transient_periods: 1,
        max_transient_periods: 2,
        shooting: false,
        ..SweepOptions::new(vec![450.0, 460.0], Direction::Up)
    };
    let points = sweep(&scene, &options, &quiet).unwrap().points;
    assert_eq!(points.len(), 2);
    assert!(points
        .iter()
        .all(|p| !p.converged && p.response_periods.is_none()));
}

/// `geardyn sweep --states`: each point's recording state and phase, from which a run of the
/// scene at that speed records the point's statistics again; on the hysteresis of the shipped
/// 8-DOF idler the up and the down branch have different states at the same speed, and each
/// state gives its own branch (the Liu report's fast check relies on this: the branch a point
/// is on is pinned by its state).
#[test]
fn states_file_records_each_point_again_on_its_own_branch() {
    use geardyn::analysis::orbit_statistics::record;
    use geardyn::model::{response_period, Drivetrain};
    use geardyn::scene::Scene;
    use geardyn::with_drivetrain;

    let dir = std::env::temp_dir().join(format!("geardyn-sweep-states-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (out, states) = (dir.join("sweep.csv"), dir.join("states.csv"));
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_geardyn"))
        .args([
            "sweep",
            "--example",
            "idler_gearset",
            "--speed",
            "330:390:7",
            "--out",
        ])
        .arg(&out)
        .arg("--states")
        .arg(&states)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let read = |path: &std::path::Path| -> (Vec<String>, Vec<Vec<f64>>) {
        let text = std::fs::read_to_string(path).unwrap();
        let mut lines = text.lines();
        let head = lines
            .next()
            .unwrap()
            .split(',')
            .map(str::to_string)
            .collect();
        let rows = lines
            .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
            .collect();
        (head, rows)
    };
    let (columns, table) = read(&out);
    let (head, pinned) = read(&states);
    assert_eq!(
        &head[..4],
        ["direction", "speed", "recorded_periods", "recording_phase"]
    );
    assert_eq!(pinned.len(), table.len(), "one state per point");
    let col = |name: &str| columns.iter().position(|c| c == name).unwrap();
    let (rms1, loss2) = (col("mesh1.dte_rms"), col("mesh2.contact_loss_fraction"));
    let scene = Scene::example("idler_gearset").unwrap();
    let mut worst: f64 = 0.0;
    let mut branches_differ = false;
    for (p, t) in pinned.iter().zip(&table) {
        assert_eq!(
            (p[0], p[1]),
            (t[0], t[1]),
            "direction and speed of the point"
        );
        let mut at = scene.clone();
        at.set_input_speed(p[1]);
        let again = with_drivetrain!(at.simulation().unwrap(), sim => {
            let mut sim = sim;
            let period = response_period(sim.model()).unwrap();
            let f1 = Drivetrain::mesh_frequency(sim.model(), 0);
            let per_response = (period * f1).round().max(1.0);
            let phase0 = Drivetrain::mesh_phase(sim.model(), 0, 0.0);
            let t0 = (p[3] - phase0).rem_euclid(per_response) / f1;
            sim.set_y(t0, &p[4..]);
            record(&mut sim, &at.solver, p[2] * period, false).unwrap()
        });
        worst = worst
            .max((again[0].dte_rms - t[rms1]).abs() / t[rms1])
            .max((again[1].contact_loss_fraction - t[loss2]).abs());
        let other = table.iter().find(|o| o[1] == t[1] && o[0] != t[0]).unwrap();
        branches_differ |= t[rms1] > 2.0 * other[rms1];
    }
    println!("sweep --states: largest difference of a point recorded again {worst:.1e}");
    assert!(worst <= 1e-9, "{worst:e}");
    assert!(
        branches_differ,
        "the speeds must cross the idler's hysteresis"
    );
    std::fs::remove_dir_all(&dir).ok();
}
