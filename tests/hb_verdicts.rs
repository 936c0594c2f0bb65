//! Issue 38 acceptance 4: at every computed branch point whose spectral radius differs from 1
//! by more than 1e-4, the stability verdict of `hb` is that of shooting, on `spur_pair`,
//! `idler_gearset` and `countershaft_gearset`.
//!
//! The oracle is this file's own Newton iteration on the period map (`analysis::period_map`:
//! the exact propagator with saltation, the map `geardyn periodic` integrates), started from
//! the HB state of each point and converged to a periodicity residual of 1e-11: the periodic
//! orbit nearest the HB orbit, which is the same orbit by construction, checked by the distance
//! of the two starts. Its Floquet multipliers are the eigenvalues of the converged monodromy.
//! Nothing of the HB stability step (its monodromy from the unconverged HB state, its margin,
//! its shooting check) is used, so the verdict of every point is compared, on the unstable
//! branches too, where `periodic` from its warm-up would land on another (stable) orbit.

use geardyn::analysis::hb::{continuation, BranchPoint, ContinuationOptions, HbOptions};
use geardyn::analysis::shooting::state_scale;
use geardyn::analysis::{self, period_map, Direction, Stability, SweepOptions};
use geardyn::scene::Scene;
use geardyn::with_drivetrain;
use nalgebra::{DMatrix, DVector};

/// Scaled periodicity residual the oracle's Newton converges to. The multipliers move by a few
/// times the orbit's scaled displacement (docs of `RADIUS_SENSITIVITY`), so they are within
/// ~1e-10 of the orbit's, far inside the 1e-4 the verdicts are compared at.
const ORACLE_TOLERANCE: f64 = 1e-11;

/// Largest scaled distance of the shooting orbit's start from the HB state: the HB truncation
/// error at H = 20 is ~1e-4 of the state scale (docs of `SHOOTING_CHECK_MARGIN`); a start this
/// far off is another orbit.
const SAME_ORBIT: f64 = 1e-2;

/// The residual scale of each state component (`analysis::shooting::state_scale`, the one
/// `periodic` converges in): the displacement scale, times the fastest frequency for velocities.
fn scale(scene: &Scene, y: &[f64]) -> Vec<f64> {
    with_drivetrain!(scene.simulation().unwrap(), sim => state_scale(sim.model(), y))
}

fn scaled_max(d: &[f64], scale: &[f64]) -> f64 {
    (d.iter().zip(scale))
        .map(|(x, s)| (x / s).abs())
        .fold(0.0, f64::max)
}

/// The oracle at one branch point: damped Newton on `P(y) − y` from the HB state at `t = 0`.
/// Returns the scaled distance of the converged start from the HB state and the multipliers.
fn shooting_from_hb(
    scene: &Scene,
    p: &BranchPoint,
) -> Result<(f64, Vec<nalgebra::Complex<f64>>), String> {
    let mut s = scene.clone();
    s.set_input_speed(p.speed);
    let periods = p.solution.subharmonic;
    let hb_state = p.solution.state_at(0.0);
    let scale = scale(&s, &hb_state);
    let n = hb_state.len();
    let mut y = DVector::from_vec(hb_state.clone());
    let (py, mut m) = period_map(&s, y.as_slice(), periods)?;
    let mut r = DVector::from_vec(py) - &y;
    let mut residual = scaled_max(r.as_slice(), &scale);
    let mut iterations = 0;
    while residual > ORACLE_TOLERANCE {
        iterations += 1;
        if iterations > 20 {
            return Err(format!("no convergence, scaled residual {residual:.2e}"));
        }
        let step = (&m - DMatrix::identity(n, n))
            .lu()
            .solve(&(-&r))
            .ok_or("M − I singular")?;
        // Halve the step until the residual decreases (the map is piecewise smooth at contact
        // changes).
        let mut lambda = 1.0;
        loop {
            let trial = &y + &step * lambda;
            let (p_trial, m_trial) = period_map(&s, trial.as_slice(), periods)?;
            let r_trial = DVector::from_vec(p_trial) - &trial;
            let res = scaled_max(r_trial.as_slice(), &scale);
            if res < residual || lambda < 1e-3 {
                (y, m, r, residual) = (trial, m_trial, r_trial, res);
                break;
            }
            lambda *= 0.5;
        }
    }
    let distance: Vec<f64> = y.iter().zip(&hb_state).map(|(a, b)| a - b).collect();
    let multipliers = geardyn::analysis::multipliers(&m)?;
    Ok((scaled_max(&distance, &scale), multipliers))
}

fn radius(m: &[nalgebra::Complex<f64>]) -> f64 {
    m.iter().map(|c| c.norm()).fold(0.0, f64::max)
}

/// What [`compare`] counted over a branch.
#[derive(Debug, Default)]
struct Tally {
    points: usize,
    compared: usize,
    stable: usize,
    unstable: usize,
    /// Points whose oracle radius lies within 1e-4 of 1 (not compared: the rule's exception).
    near_one: usize,
    /// Largest distance of an oracle orbit's start from its HB state (scaled).
    distance: f64,
    /// Largest |hb |μ| − shooting |μ|| relative to the larger of the two (the radius column of
    /// `geardyn hb` against the oracle's).
    radius_error: f64,
}

/// Every point of the branch of `scene` over `from..to` at `h` harmonics against the oracle
/// started from it: the oracle converges and lies on the HB orbit at every point, and the
/// verdicts agree wherever the oracle's radius is more than 1e-4 from 1.
fn compare(scene: &Scene, options: &ContinuationOptions, h: usize) -> Tally {
    let (from, to) = (options.from, options.to);
    let branch = continuation(scene, &HbOptions::new(h), options).unwrap();
    let mut tally = Tally {
        points: branch.len(),
        ..Tally::default()
    };
    for p in &branch {
        let hb_rho = p.spectral_radius().unwrap();
        let (distance, multipliers) = shooting_from_hb(scene, p)
            .unwrap_or_else(|e| panic!("{} at {} rad/s: oracle: {e}", scene.name, p.speed));
        let (rho, verdict) = (radius(&multipliers), Stability::of(&multipliers));
        println!(
            "{} {:.4} rad/s{}: hb |μ| {hb_rho:.8} {:?}{}, shooting {rho:.8} {verdict:?}, start \
             {distance:.1e} from the HB state",
            scene.name,
            p.speed,
            if p.fold { " (fold)" } else { "" },
            p.stability().unwrap(),
            if p.shooting_checked() {
                " (checked)"
            } else {
                ""
            },
        );
        assert!(
            distance <= SAME_ORBIT,
            "{} at {} rad/s: the shooting orbit starts {distance:.2e} from the HB state",
            scene.name,
            p.speed
        );
        tally.distance = tally.distance.max(distance);
        tally.radius_error = tally
            .radius_error
            .max((hb_rho - rho).abs() / hb_rho.max(rho));
        if (rho - 1.0).abs() <= 1e-4 {
            tally.near_one += 1;
            continue;
        }
        assert_eq!(
            p.stability().unwrap(),
            verdict,
            "{} at {} rad/s: hb |μ| {hb_rho}, shooting {rho}",
            scene.name,
            p.speed
        );
        tally.compared += 1;
        match verdict {
            Stability::Stable => tally.stable += 1,
            _ => tally.unstable += 1,
        }
    }
    println!("{} {from}–{to} rad/s, H = {h}: {tally:?}", scene.name);
    assert_eq!(tally.compared + tally.near_one, tally.points);
    tally
}

fn countershaft() -> Scene {
    Scene::from_toml_str(
        include_str!("../fmu/countershaft_gearset/scene.toml"),
        "countershaft_gearset",
    )
    .unwrap()
}

/// The spur pair over 300–600 rad/s at H = 20 folds twice (contact loss): the stable lower,
/// the unstable middle and the stable upper branch, every point compared (measured: 126
/// points, 23 stable, 103 unstable, |μ| up to 2.5; starts within 7.1e-4 of the HB states).
#[test]
fn spur_pair_verdicts_agree_with_shooting() {
    let t = compare(
        &Scene::example("spur_pair").unwrap(),
        &ContinuationOptions::new(300.0, 600.0),
        20,
    );
    assert!(t.stable > 0 && t.unstable > 0, "{t:?}");
}

/// The idler across its Neimark–Sacker interval (389.2–393.3 rad/s, `tests/hb_stability.rs`)
/// and a fold at 378 rad/s, with a tenth of the default largest step so that the interval holds
/// points more than 1e-4 outside the circle (measured: 54 points, 42 stable, 9 unstable, 3
/// within 1e-4 of |μ| = 1).
#[test]
fn idler_verdicts_agree_with_shooting() {
    let t = compare(
        &Scene::example("idler_gearset").unwrap(),
        &ContinuationOptions {
            max_step: 0.005,
            ..ContinuationOptions::new(380.0, 400.0)
        },
        20,
    );
    assert!(t.stable > 0 && t.unstable > 0, "{t:?}");
}

/// The countershaft at H = 20 on the total-order basis, at both of the intervals
/// (measured: 8 and 9 points, all stable, |μ| ≤ 4e-6: no contact loss there).
#[test]
fn countershaft_verdicts_agree_with_shooting() {
    let scene = countershaft();
    for (from, to) in [(240.0, 250.0), (300.0, 320.0)] {
        let t = compare(&scene, &ContinuationOptions::new(from, to), 20);
        assert!(t.compared > 0, "{t:?}");
    }
}

/// The idler over both fundamental resonances at H = 20 (folds, contact loss, the
/// Neimark–Sacker interval at the default step): measured 344 points, 199 stable and 145
/// unstable, every one compared (the four default tests of this file: 3.9 s CPU, release build).
#[test]
fn idler_over_both_resonances_verdicts_agree_with_shooting() {
    let idler = Scene::example("idler_gearset").unwrap();
    let t = compare(&idler, &ContinuationOptions::new(250.0, 760.0), 20);
    assert!(t.stable > 0 && t.unstable > 0, "{t:?}");
}

/// The countershaft with contact loss on mesh 1 (5–6 % of the period at 231–233 rad/s), where
/// the monodromies carry saltation matrices: all points stable (|μ| ~ 1e-8). The torus
/// quadrature splits its pieces at the contact switches there (Newton–Krylov, ~1 s CPU).
#[test]
fn countershaft_contact_loss_verdicts_agree_with_shooting() {
    let t = compare(&countershaft(), &ContinuationOptions::new(231.0, 233.0), 20);
    assert!(t.compared > 0, "{t:?}");
}

/// The countershaft's lower branch at 385–393.8 rad/s (contact loss on mesh 1 from 1 % to
/// 8 %, up to the hysteresis at 394 rad/s): the verdicts, and the HB radius column against the
/// oracle's (measured: 10 points, the last at 393.91 rad/s, |μ| 1.4e-5–8.4e-4, within 1.2 % of
/// the oracle's up to 393.5 rad/s and 4.0 % at 393.91; `periodic` from its warm-up at 385
/// rad/s: |μ| = 3.0002e-5, the HB column 3.003e-5).
#[test]
fn countershaft_hysteresis_lower_branch_radius_agrees_with_shooting() {
    let t = compare(&countershaft(), &ContinuationOptions::new(385.0, 393.8), 20);
    assert!(t.compared >= 8 && t.stable == t.compared, "{t:?}");
    assert!(t.radius_error <= 5e-2, "{t:?}");
}

/// The countershaft's branch from 385 rad/s upward at H = 20 with the default
/// `defect_limit`: it ends at its first point that the oracle finds more than [`SAME_ORBIT`]
/// from its periodic orbit, inside the up sweep's jump (the time-domain sweep, independent of
/// HB), and every earlier point lies within [`SAME_ORBIT`] of its orbit. Measured:
/// 13 points, the last at 394.389 rad/s (HB state 0.30 of the state scale from the orbit the
/// oracle finds, defect 0.297; the points before within 6.2e-3), the up sweep jumping to the
/// branch with a third of mesh 1's period out of contact between 394.0 and 394.5 rad/s.
#[test]
fn countershaft_branch_ends_where_h20_does_not_resolve_the_orbit() {
    let scene = countershaft();
    let branch = continuation(
        &scene,
        &HbOptions::new(20),
        &ContinuationOptions::new(385.0, 400.0),
    )
    .unwrap();
    let (last, resolved) = branch.split_last().unwrap();
    assert!(last.unresolved, "{} rad/s", last.speed);
    assert!(last.periodicity_defect.unwrap() > geardyn::analysis::hb::PERIODICITY_DEFECT_LIMIT);
    assert!(resolved.iter().all(|p| !p.unresolved));
    for p in resolved {
        let (d, _) = shooting_from_hb(&scene, p).unwrap();
        assert!(d <= SAME_ORBIT, "{} rad/s: {d:.2e}", p.speed);
    }
    let far = shooting_from_hb(&scene, last).map_or(f64::INFINITY, |(d, _)| d);
    assert!(far > SAME_ORBIT, "{} rad/s: {far:.2e}", last.speed);
    // The up sweep in 0.5 rad/s steps: the jump to heavy contact loss on mesh 1.
    let speeds: Vec<f64> = (0..=30).map(|k| 385.0 + 0.5 * f64::from(k)).collect();
    let sweep = analysis::sweep(
        &scene,
        &SweepOptions::new(speeds, Direction::Up),
        &|_, _| {},
    )
    .unwrap();
    let jump = sweep
        .points
        .windows(2)
        .find(|w| w[1].meshes[0].contact_loss_fraction > 0.2)
        .map(|w| (w[0].speed, w[1].speed))
        .unwrap();
    println!(
        "last point {:.4} rad/s, defect {:.3e}, oracle distance {far:.3e}; \
         up sweep jumps at {jump:?}",
        last.speed,
        last.periodicity_defect.unwrap()
    );
    assert!(jump.0 <= last.speed && last.speed <= jump.1, "{jump:?}");
}

/// Newton on the period map at `speed` from `y` (damped as in [`shooting_from_hb`]): the
/// converged start and its multipliers, or None after 30 iterations.
fn newton_at(
    scene: &Scene,
    speed: f64,
    y: &DVector<f64>,
) -> Option<(DVector<f64>, Vec<nalgebra::Complex<f64>>)> {
    let mut s = scene.clone();
    s.set_input_speed(speed);
    let sc = scale(&s, y.as_slice());
    let n = y.len();
    let mut y = y.clone();
    let (py, mut m) = period_map(&s, y.as_slice(), 1).ok()?;
    let mut r = DVector::from_vec(py) - &y;
    let mut residual = scaled_max(r.as_slice(), &sc);
    for _ in 0..30 {
        if residual <= ORACLE_TOLERANCE {
            return Some((y, geardyn::analysis::multipliers(&m).ok()?));
        }
        let step = (&m - DMatrix::identity(n, n)).lu().solve(&(-&r))?;
        let mut lambda = 1.0;
        loop {
            let trial = &y + &step * lambda;
            let (p_trial, m_trial) = period_map(&s, trial.as_slice(), 1).ok()?;
            let r_trial = DVector::from_vec(p_trial) - &trial;
            let res = scaled_max(r_trial.as_slice(), &sc);
            if res < residual || lambda < 1e-3 {
                (y, m, r, residual) = (trial, m_trial, r_trial, res);
                break;
            }
            lambda *= 0.5;
        }
    }
    None
}

/// The countershaft's hysteresis at 385–400 rad/s at H = 20. Every point the oracle finds its
/// orbit within [`SAME_ORBIT`] of has the oracle's verdict; every other point is marked
/// [`BranchPoint::far_from_orbit`] (the `geardyn hb` summary warns of it), and no point of the
/// lower branch is. Then the upper branch (22–33 % contact loss on mesh 1) continued downward
/// by Newton shooting from the HB orbit's last point (384.64 rad/s) in steps of 0.5 rad/s ends
/// where the down sweep (`geardyn sweep … --speed 200:400:401`) jumps, between 382.5 and 382.0
/// rad/s, not at the HB branch's turn (~373.5 rad/s): measured stable at 384.5–382.5 (|μ|
/// 1.3e-4 rising to 0.72), no convergence at 382.0, the lower branch (|μ| 3e-5) at 381.5.
/// Ignored: ~20 s wall.
#[test]
#[ignore]
fn countershaft_hysteresis_far_points_are_marked() {
    let scene = countershaft();
    // The H = 20 branch past the 394 rad/s fold, where the default `defect_limit` ends it, and
    // back below 385 rad/s.
    let options = ContinuationOptions {
        defect_limit: f64::INFINITY,
        ..ContinuationOptions::new(385.0, 400.0)
    };
    let branch = continuation(&scene, &HbOptions::new(20), &options).unwrap();
    let (mut near, mut far) = (0, 0);
    for (i, p) in branch.iter().enumerate() {
        let oracle = shooting_from_hb(&scene, p);
        println!(
            "{:.4} rad/s: hb |μ| {:.3e}, orbit error {:.2e}, defect {:.2e}, oracle {:?}",
            p.speed,
            p.spectral_radius().unwrap(),
            p.orbit_error.unwrap(),
            p.periodicity_defect.unwrap(),
            oracle.as_ref().map(|(d, m)| (*d, radius(m)))
        );
        match oracle {
            Ok((d, m)) if d <= SAME_ORBIT => {
                near += 1;
                if (radius(&m) - 1.0).abs() > 1e-4 && !p.far_from_orbit() {
                    assert_eq!(p.stability().unwrap(), Stability::of(&m), "{}", p.speed);
                }
            }
            _ => {
                far += 1;
                assert!(p.far_from_orbit(), "{} rad/s not marked", p.speed);
            }
        }
        if i < 9 {
            assert!(!p.far_from_orbit(), "lower branch {} rad/s marked", p.speed);
        }
    }
    assert!(near >= 9 && far > 0, "{near} near, {far} far");
    let last = branch.last().unwrap();
    assert!(last.speed < 385.0 && last.solution.meshes[0].contact_loss_fraction > 0.3);
    let (mut y, m) = newton_at(
        &scene,
        last.speed,
        &DVector::from_vec(last.solution.state_at(0.0)),
    )
    .expect("the upper branch's orbit at the HB branch's last point");
    assert!(radius(&m) < 1.0);
    for k in 0..=4 {
        let speed = 384.5 - 0.5 * f64::from(k);
        let (next, m) = newton_at(&scene, speed, &y).expect("upper branch");
        println!("{speed} rad/s: |μ| {:.3e}", radius(&m));
        assert!(Stability::of(&m) == Stability::Stable, "{speed} rad/s");
        y = next;
    }
    // At 382.0 rad/s Newton from the 382.5 rad/s orbit does not converge, and at 381.5 it
    // lands on the lower branch (|μ| ~ 3e-5), far from the upper orbit.
    assert!(newton_at(&scene, 382.0, &y).is_none());
    let (below, m) = newton_at(&scene, 381.5, &y).expect("an orbit at 381.5 rad/s");
    let moved: Vec<f64> = below.iter().zip(y.iter()).map(|(a, b)| a - b).collect();
    let sc = scale(&scene, y.as_slice());
    assert!(scaled_max(&moved, &sc) > 0.1 && radius(&m) < 1e-3);
}
