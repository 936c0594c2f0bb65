//! Issue 7: mesh stiffness from gear geometry. Each test states its independent oracle.
//!
//! 1. contact extents vs the textbook involute contact ratio; ETC widening and eq. (6);
//! 3. per-unit-width mean vs the ISO 6336-1 range; load dependence;
//! 4. quadrature convergence and bounded load-sharing iterations;
//! 5. the `geometry` scene source through `PairScene::from_toml_str` + `Simulation::new`;
//! 6. impossible gears rejected with the field and value named.
//!
//! (2, the comparison with ROSS, is in `tests/python/test_stiffness_ross.py`.)

use std::f64::consts::{PI, TAU};

use geardyn::mesh::geometry::spec::parse_gears_file;
use geardyn::mesh::geometry::{CurveOptions, GearPairSpec, MeshModel};
use geardyn::scene::PairScene;
use geardyn::simulation::Simulation;

const GEARS: &str = include_str!("../fmu/geometry_pair/gears.toml");
const SCENE: &str = include_str!("../fmu/geometry_pair/scene.toml");

/// A standard (ISO 53) steel pair with the given teeth, module 3 mm, 20°, L = 20 mm, solid
/// bodies with bore radius 0.4 × pitch radius (h_f = r_f/r_int ≈ 2.2–2.5, inside Sainsot's
/// fitted range).
fn pair_text(z1: i64, z2: i64, extra_pinion: &str, extra_gear: &str) -> String {
    let (b1, b2) = (0.4 * 0.0015 * z1 as f64, 0.4 * 0.0015 * z2 as f64);
    format!(
        r#"module = 0.003
pressure_angle = 20.0
face_width = 0.02
[pinion]
teeth = {z1}
bore_radius = {b1}
youngs_modulus = 2.06e11
poisson_ratio = 0.3
{extra_pinion}
[gear]
teeth = {z2}
bore_radius = {b2}
youngs_modulus = 2.06e11
poisson_ratio = 0.3
{extra_gear}
"#
    )
}

fn spec(text: &str) -> GearPairSpec {
    parse_gears_file(text, "test").unwrap()
}

fn model(text: &str) -> MeshModel {
    MeshModel::new(&spec(text), "").unwrap()
}

fn curve(m: &MeshModel, torque: f64, etc: bool) -> geardyn::mesh::geometry::StiffnessCurve {
    m.curve(CurveOptions { torque, etc }).unwrap()
}

/// Textbook involute contact ratio (e.g. Maitra, *Handbook of Gear Design*, eq. 1.31):
/// `ε = [√(r_a1² − r_b1²) + √(r_a2² − r_b2²) − a sin α_w] / (π m cos α)`, with
/// `r_a = m(z/2 + 1 + x)`, `r_b = m z cos α / 2`, and `inv α_w = inv α + 2 tan α (x1+x2)/(z1+z2)`
/// solved here by bisection (the library uses Newton), `a = (r_b1 + r_b2)/cos α_w`.
fn textbook_contact_ratio(m: f64, z1: f64, z2: f64, x1: f64, x2: f64) -> f64 {
    textbook_contact_ratio_general(m, 20.0, 1.0, z1, z2, x1, x2)
}

fn textbook_contact_ratio_general(
    m: f64,
    alpha_deg: f64,
    ha: f64,
    z1: f64,
    z2: f64,
    x1: f64,
    x2: f64,
) -> f64 {
    let a0 = alpha_deg.to_radians();
    let inv = |a: f64| a.tan() - a;
    let target = inv(a0) + 2.0 * a0.tan() * (x1 + x2) / (z1 + z2);
    let (mut lo, mut hi) = (1e-3, 1.5);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if inv(mid) < target {
            lo = mid
        } else {
            hi = mid
        }
    }
    let aw = 0.5 * (lo + hi);
    let (rb1, rb2) = (m * z1 * a0.cos() / 2.0, m * z2 * a0.cos() / 2.0);
    let (ra1, ra2) = (m * (z1 / 2.0 + ha + x1), m * (z2 / 2.0 + ha + x2));
    let a = (rb1 + rb2) / aw.cos();
    ((ra1 * ra1 - rb1 * rb1).sqrt() + (ra2 * ra2 - rb2 * rb2).sqrt() - a * aw.sin())
        / (PI * m * a0.cos())
}

/// A high-contact-ratio pair (ε ≈ 2.59: two or three pairs in contact).
const HIGH_CONTACT_RATIO: &str = r#"module = 0.003
pressure_angle = 16.0
face_width = 0.02
[pinion]
teeth = 50
addendum = 1.35
dedendum = 1.6
bore_radius = 0.03
youngs_modulus = 2.06e11
poisson_ratio = 0.3
[gear]
teeth = 50
addendum = 1.35
dedendum = 1.6
bore_radius = 0.03
youngs_modulus = 2.06e11
poisson_ratio = 0.3
"#;

#[test]
fn high_contact_ratio_pairs_have_two_and_three_pair_zones() {
    let m = model(HIGH_CONTACT_RATIO);
    let eps = textbook_contact_ratio_general(0.003, 16.0, 1.35, 50.0, 50.0, 0.0, 0.0);
    assert!(
        (m.pair.contact_ratio - eps).abs() < 1e-12 && eps > 2.0,
        "{eps}"
    );
    let c = curve(&m, 300.0, false);
    assert_eq!(c.low_pairs, 2);
    assert!((c.low_extent() - (3.0 - eps)).abs() < 1e-12);
    let with_etc = curve(&m, 300.0, true);
    assert!(with_etc.high_extent() > c.high_extent());
    let floor = -1e-9 * with_etc.load;
    assert!(with_etc
        .knots()
        .all(|k| k.forces.iter().all(|&f| f >= floor)));
}

#[test]
fn contact_extents_match_the_involute_contact_ratio_without_etc() {
    for (z1, z2, x1, x2) in [
        (20, 20, 0.0, 0.0),
        (25, 60, 0.0, 0.0),
        (62, 62, 0.0, 0.0),
        (18, 40, 0.3, -0.3),
        (17, 35, 0.4, 0.2),
    ] {
        let text = pair_text(
            z1,
            z2,
            &format!("profile_shift = {x1}"),
            &format!("profile_shift = {x2}"),
        );
        let m = model(&text);
        let eps = textbook_contact_ratio(0.003, z1 as f64, z2 as f64, x1, x2);
        assert!(
            (m.pair.contact_ratio - eps).abs() < 1e-12,
            "{z1}/{z2}: ε {} vs textbook {eps}",
            m.pair.contact_ratio
        );
        let c = curve(&m, 100.0, false);
        // Single contact lasts 2 − ε of a mesh cycle, double contact ε − 1.
        assert!((c.low_extent() - (2.0 - eps)).abs() < 1e-12, "{z1}/{z2}");
        assert!((c.high_extent() - (eps - 1.0)).abs() < 1e-12, "{z1}/{z2}");
        // The free active-set solve agrees on the number of loaded pairs inside each zone.
        for (s, want) in [(0.5 * (2.0 - eps), 1), (2.0 - eps + 0.5 * (eps - 1.0), 2)] {
            let (_, sh) = m.solve_free(s, 1000.0, false).unwrap();
            let loaded = sh.forces.iter().filter(|&&f| f > 0.0).count();
            assert_eq!(loaded, want, "{z1}/{z2} at s = {s}");
        }
        // And the zones do not depend on the load without ETC.
        let c2 = curve(&m, 400.0, false);
        assert_eq!(c2.low_extent(), c.low_extent());
    }
}

/// Eq. (6) (Liao et al. 2025) with ε = 0 and no fillet coupling, evaluated from the component
/// compliances at the theoretical bound: the extension is `(T/r_p²) Σ_j [1/K_t,j + 1/K_f,j +
/// 1/(2K_h(T))]` of the pair that carries the load alone there.
fn eq6(m: &MeshModel, torque: f64, x_loaded: f64) -> f64 {
    let rp = m.pair.pinion.r_base;
    let w = torque / rp;
    let c = m.compliance_at(x_loaded).total() + m.hertz.compliance(w);
    torque / (rp * rp) * c
}

#[test]
fn etc_widens_double_contact_with_torque_and_matches_eq6() {
    let m = model(&pair_text(25, 60, "", ""));
    let p = &m.pair;
    let eps = p.contact_ratio;
    let theta_m = TAU / p.pinion.teeth as f64;
    let s_en = 2.0 - eps;
    let mut last = eps - 1.0;
    println!("T [N·m]  double extent  entry ext [rad] (eq. 6)   exit ext [rad] (eq. 6)");
    for torque in [25.0, 50.0, 100.0, 200.0, 400.0, 800.0] {
        let c = curve(&m, torque, true);
        assert!(
            c.high_extent() > last,
            "T = {torque}: double-contact extent {} did not grow (previous {last})",
            c.high_extent()
        );
        last = c.high_extent();
        // β2: theoretical start of double contact (s = s_en), loaded pair one pitch ahead
        // of the entering pair; β3: theoretical end (s = 0), the remaining pair at x_E − p_b.
        let entry = (s_en - c.entry) * theta_m;
        let exit = c.exit * theta_m;
        let entry_eq6 = eq6(&m, torque, p.x_start + p.base_pitch);
        let exit_eq6 = eq6(&m, torque, p.x_end - p.base_pitch);
        println!(
            "{torque:7}  {:.6}  {entry:.6e} ({entry_eq6:.6e})  {exit:.6e} ({exit_eq6:.6e})",
            c.high_extent()
        );
        assert!(
            (entry / entry_eq6 - 1.0).abs() < 0.01,
            "T = {torque}: entry {entry} vs {entry_eq6}"
        );
        assert!(
            (exit / exit_eq6 - 1.0).abs() < 0.01,
            "T = {torque}: exit {exit} vs {exit_eq6}"
        );
        // At the ETC bounds the entering/leaving pair carries no load (onset), just inside it
        // carries some: the free active-set solve, which knows nothing of the zone bounds.
        let w = torque / p.pinion.r_base;
        let loaded = |s: f64| {
            let (_, sh) = m.solve_free(s, w, true).unwrap();
            sh.forces.iter().filter(|&&f| f > 1e-9 * w).count()
        };
        let d = 1e-6 * (c.entry - c.exit);
        assert_eq!(loaded(c.entry - d), 1, "T = {torque}");
        assert_eq!(loaded(c.entry + d), 2, "T = {torque}");
        assert_eq!(loaded(c.exit - d), 2, "T = {torque}");
        assert_eq!(loaded(c.exit + d), 1, "T = {torque}");
    }
}

#[test]
fn mean_stiffness_per_width_in_iso_6336_range_and_rises_with_load() {
    // ISO 6336-1 (method B): mesh stiffness c_γα ≈ 20 N/(mm·µm) for solid steel spur gears,
    // single-pair stiffness c' ≈ 14; analytical potential-energy values fall in 14–20.
    for text in [
        GEARS.to_string(),
        pair_text(20, 40, "", ""),
        pair_text(25, 60, "", ""),
        pair_text(30, 30, "", ""),
        pair_text(40, 40, "", ""),
        pair_text(50, 100, "", ""),
    ] {
        let m = model(&text);
        let width = m.pair.pinion.face_width;
        let c = curve(&m, 100.0, true);
        let per_width = c.mean() / width * 1e-9; // N/m/m → N/(mm·µm)
        println!(
            "z = {}/{}: mean {:.5e} N/m = {per_width:.3} N/(mm·µm)",
            m.pair.pinion.teeth,
            m.pair.gear.teeth,
            c.mean()
        );
        assert!((14.0..=20.0).contains(&per_width), "{per_width}");
    }
    // Load sweep in 40 N·m steps as the paper's Fig. 4: rising, increments shrinking above 100.
    let m = model(GEARS);
    let loads = [20.0, 60.0, 100.0, 140.0, 180.0, 220.0, 260.0];
    let means: Vec<f64> = loads.iter().map(|&t| curve(&m, t, true).mean()).collect();
    println!("loads {loads:?}\nmeans {means:?}");
    for i in 1..means.len() {
        assert!(
            means[i] > means[i - 1],
            "mean did not rise at {} N·m",
            loads[i]
        );
    }
    let inc: Vec<f64> = means.windows(2).map(|w| w[1] - w[0]).collect();
    for i in 2..inc.len() {
        assert!(
            inc[i] < inc[i - 1],
            "increment did not shrink at {} N·m",
            loads[i + 1]
        );
    }
    // Above 100 N·m the 40 N·m increments are below 1 % of the mean.
    assert!(inc[2] / means[2] < 0.01);
}

#[test]
fn quadrature_converges_and_load_sharing_iterations_are_bounded() {
    for text in [
        GEARS.to_string(),
        pair_text(20, 20, "", ""),
        pair_text(25, 60, "", ""),
    ] {
        let base = model(&text);
        let curves: Vec<_> = [16usize, 32, 64]
            .iter()
            .map(|&n| curve(&base.clone().with_quadrature(n), 100.0, true))
            .collect();
        let rel = |a: &geardyn::mesh::geometry::StiffnessCurve,
                   b: &geardyn::mesh::geometry::StiffnessCurve| {
            a.knots()
                .zip(b.knots())
                .map(|(x, y)| (x.stiffness / y.stiffness - 1.0).abs())
                .fold(0.0, f64::max)
        };
        let (d16, d32) = (rel(&curves[0], &curves[1]), rel(&curves[1], &curves[2]));
        println!(
            "z = {}/{}: max rel. change 16→32 points {d16:.2e}, 32→64 points {d32:.2e}; \
             Hertz fixed point ≤ {} iterations",
            base.pair.pinion.teeth,
            base.pair.gear.teeth,
            curves[1].max_iterations()
        );
        assert!(d32 < 1e-8, "doubling 32 → 64 points changed K by {d32:e}");
        assert!(curves[1].max_iterations() <= 20);
    }
}

#[test]
fn geometry_scene_runs_and_feeds_the_computed_curve() {
    let scene = PairScene::from_toml_str(SCENE, "geometry_pair").unwrap();
    // The scene's stiffness is the curve of the same gears at the operating torque.
    let m = model(GEARS);
    let c = curve(&m, scene.operating.input_torque, true);
    for i in 0..200 {
        let s = (i as f64 + 0.37) / 200.0;
        let want = c.to_table(0.0).value(s);
        assert_eq!(scene.mesh.stiffness.value(s), want);
    }
    let mut sim = Simulation::new(&scene).unwrap();
    let period = TAU / (62.0 * scene.operating.pinion_speed);
    sim.advance_to(200.0 * period).unwrap();
    let out = sim.outputs();
    assert!(out.iter().all(|v| v.is_finite()));
    // Quasi-static check: the mean DTE over whole mesh cycles ≈ W·mean(1/K) (damped, below
    // resonance, no separation): within 5 %.
    let (mut sum, n) = (0.0, 2000);
    for i in 1..=n {
        sim.advance_to(200.0 * period + 20.0 * period * i as f64 / n as f64)
            .unwrap();
        sum += sim.state()[0];
    }
    let w = scene.operating.input_torque / scene.pinion.base_radius;
    let mean_compliance = (0..4000)
        .map(|i| 1.0 / c.to_table(0.0).value((i as f64 + 0.5) / 4000.0))
        .sum::<f64>()
        / 4000.0;
    let dte = sum / n as f64;
    assert!(
        (dte / (w * mean_compliance) - 1.0).abs() < 0.05,
        "mean DTE {dte:e} vs W·mean(1/K) {:e}",
        w * mean_compliance
    );
    // The Fourier form of the same source also loads and runs.
    let fourier = SCENE.replace("form = \"table\"", "form = \"fourier\"\nharmonics = 4");
    let scene = PairScene::from_toml_str(&fourier, "fourier").unwrap();
    assert!((scene.mesh.stiffness.mean() / c.mean() - 1.0).abs() < 1e-12);
    let mut sim = Simulation::new(&scene).unwrap();
    sim.advance_to(0.002).unwrap();
}

fn rejected(text: &str, needles: &[&str]) {
    let err = MeshModel::new(&spec(text), "").expect_err("must be rejected");
    for n in needles {
        assert!(err.contains(n), "message {err:?} lacks {n:?}");
    }
}

#[test]
fn impossible_gears_are_rejected_naming_field_and_value() {
    // Undercut: z = 12 < 2 h_a*/sin²20° = 17.1 for an unshifted full-round rack.
    rejected(
        &pair_text(12, 40, "", ""),
        &["pinion.teeth = 12", "undercut", "17.10"],
    );
    // A positive shift removes it (x >= 1 − 12 sin²α/2 = 0.298).
    model(&pair_text(12, 40, "profile_shift = 0.35", ""));
    // Contact ratio below 1: stub teeth.
    rejected(
        &pair_text(20, 20, "addendum = 0.45", "addendum = 0.45"),
        &["pinion.addendum = 0.45", "contact ratio", "< 1"],
    );
    // Pointed tip: large shift on a small pinion.
    rejected(
        &pair_text(14, 40, "profile_shift = 1.2", ""),
        &["pinion.profile_shift = 1.2", "pointed"],
    );
    // Interference: a long-addendum gear tip reaches below the pinion's involute.
    rejected(
        &pair_text(18, 90, "", "addendum = 1.2"),
        &["gear.addendum = 1.2", "interference"],
    );
    let unknown = parse_gears_file(&pair_text(20, 20, "bore_radus = 0.01", ""), "f").unwrap_err();
    assert!(unknown.contains("bore_radus"), "{unknown}");
    rejected(
        &pair_text(20, 20, "", "").replacen("bore_radius = 0.012", "bore_radius = 0.03", 1),
        &["pinion.bore_radius = 0.03"],
    );
    rejected(
        &pair_text(20, 20, "", "").replace("poisson_ratio = 0.3\n", "poisson_ratio = 0.7\n"),
        &["pinion.poisson_ratio = 0.7"],
    );
    rejected(
        &pair_text(20, 20, "", "").replace("module = 0.003", "module = -0.003"),
        &["module = -0.003"],
    );
    rejected(
        &pair_text(20, 20, "", "").replace("pressure_angle = 20.0", "pressure_angle = 50.0"),
        &["pressure_angle = 50"],
    );
}

fn scene_rejected(text: &str, needles: &[&str]) {
    let err = PairScene::from_toml_str(text, "s")
        .expect_err("must be rejected")
        .0;
    for n in needles {
        assert!(err.contains(n), "message {err:?} lacks {n:?}");
    }
}

#[test]
fn geometry_scene_must_agree_with_its_gears() {
    scene_rejected(
        &SCENE.replacen("teeth = 62\nbase_radius", "teeth = 61\nbase_radius", 1),
        &[
            "mesh.pinion",
            "teeth = 61",
            "mesh.stiffness.geometry.pinion.teeth = 62",
        ],
    );
    scene_rejected(
        &SCENE.replacen("base_radius = 0.0582609393", "base_radius = 0.0583", 1),
        &["base_radius = 0.0583", "0.05826"],
    );
    scene_rejected(
        &SCENE.replace("form = \"table\"", "form = \"table\"\nharmonics = 3"),
        &["mesh.stiffness.harmonics = 3"],
    );
    scene_rejected(
        &SCENE.replace("input_torque = 100.0", "input_torque = 0.0"),
        &["operating.input_torque = 0", "mesh.stiffness.torque"],
    );
    scene_rejected(
        &SCENE.replace(
            "[mesh.stiffness.geometry.gear]\nteeth = 62",
            "[mesh.stiffness.geometry.gear]\nteeth = 12",
        ),
        &["mesh.stiffness.geometry.gear.teeth = 12", "undercut"],
    );
    scene_rejected(
        &SCENE.replace("method = \"auto\"", "method = \"exact\""),
        &["solver.method = \"exact\"", "geometry"],
    );
    // An explicit torque overrides the operating torque.
    let explicit = PairScene::from_toml_str(
        &SCENE.replace("etc = true", "etc = true\ntorque = 400.0"),
        "s",
    )
    .unwrap();
    let default = PairScene::from_toml_str(SCENE, "s").unwrap();
    assert!(explicit.mesh.stiffness.mean() > default.mesh.stiffness.mean());
}

fn geardyn(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_geardyn"))
        .args(args)
        .output()
        .expect("run geardyn")
}

#[test]
fn stiffness_cli_writes_csv_plot_and_summary() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("geometry-cli");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let (csv, svg) = (dir.join("k.csv"), dir.join("k.svg"));
    let o = geardyn(&[
        "stiffness",
        "fmu/geometry_pair/gears.toml",
        "--torque",
        "100",
        "--out",
        csv.to_str().unwrap(),
        "--plot",
        svg.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for needle in [
        "contact ratio ε = 1.78978",
        "mean stiffness",
        "N/(mm·µm)",
        "eq. 6",
        "h = 4",
        "iterations",
    ] {
        assert!(
            stdout.contains(needle),
            "summary lacks {needle:?}:\n{stdout}"
        );
    }
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "phase,pinion.angle,stiffness,deflection,pairs_loaded,force_1,force_2"
    );
    // Every row: forces sum to W = T/r_b1 and stiffness = W/deflection.
    let w = 100.0 / (0.062 * 20f64.to_radians().cos());
    let mut rows = 0;
    for line in lines {
        let v: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        assert!((v[5] + v[6] - w).abs() < 1e-8 * w, "{line}");
        assert!((v[2] * v[3] - w).abs() < 1e-8 * w, "{line}");
        rows += 1;
    }
    assert!(rows > 100);
    let plot = std::fs::read_to_string(&svg).unwrap();
    assert!(plot.starts_with("<svg") && plot.contains("ETC off"));
    // Bad input: non-zero exit, message names the value, no CSV written.
    let bad = dir.join("bad.csv");
    let o = geardyn(&[
        "stiffness",
        "fmu/geometry_pair/gears.toml",
        "--torque",
        "-1",
        "--out",
        bad.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("torque = -1"));
    assert!(!bad.exists());
    // The geometry scene runs through `geardyn simulate`.
    let sim = dir.join("sim.csv");
    let o = geardyn(&[
        "simulate",
        "fmu/geometry_pair",
        "--out",
        sim.to_str().unwrap(),
        "--stop-time",
        "0.005",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(std::fs::read_to_string(&sim).unwrap().lines().count() > 100);
}
