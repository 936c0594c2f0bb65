//! `[mesh.pairs] kind = "geometry"` (issue 36): Model-1 tooth pairs from the gear geometry in a
//! drivetrain scene (`examples/liu2007/ch2_idler_geometry.toml`). The pair curve itself is checked
//! against an independent evaluation in `tests/python/test_liu_geometry_pairs.py`; here: the
//! scene path hands exactly that curve to the model, tip relief and the ETC gap combine on the
//! extended window, the torque of each mesh is the static one, and bad input is refused with
//! the field named.

use geardyn::analysis::{sweep, Direction, SweepOptions};
use geardyn::mesh::geometry::pairs::ETC_EXTENSION;
use geardyn::mesh::geometry::MeshModel;
use geardyn::scene::spec::GearPairSpec;
use geardyn::scene::train::{GapFunction, MeshForceModel, PairGap};
use geardyn::scene::Scene;

const SCENE: &str = include_str!("../examples/liu2007/ch2_idler_geometry.toml");

fn geometry_tables() -> Vec<GearPairSpec> {
    let v: toml::Value = toml::from_str(SCENE).unwrap();
    v["mesh"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["pairs"]["geometry"].clone().try_into().unwrap())
        .collect()
}

fn with_relief(rho: f64) -> String {
    let mut text = String::new();
    for (i, part) in SCENE.split("\n[mesh.pairs]\n").enumerate() {
        if i > 0 {
            let c = if i == 1 { 1.504 } else { 1.510 };
            text.push_str(&format!(
                "\n[mesh.tip_relief]\ndriver_magnitude = {rho:e}\ndriver_length = {l}\n\
                 driven_magnitude = {rho:e}\ndriven_length = {l}\n\n[mesh.pairs]\n",
                l = c - 1.0
            ));
        }
        text.push_str(part);
    }
    text
}

#[test]
fn scene_pairs_are_the_geometry_pair_curve_at_each_mesh_torque() {
    let scene = Scene::from_toml_str(SCENE, "ch2_idler_geometry.toml").unwrap();
    let specs = geometry_tables();
    // Static pinion torques: 100 N·m on the pinion, carried to the idler by the base radii.
    let torques = [100.0, 100.0 * 0.06564 / 0.04535];
    for (m, (spec, torque)) in scene.meshes.iter().zip(specs.iter().zip(torques)) {
        let MeshForceModel::Pairs { pair, relief, .. } = &m.force else {
            panic!("{}: not a pair model", m.name);
        };
        let model = MeshModel::new(spec, "").unwrap();
        let curve = model.pair_curve(torque, ETC_EXTENSION).unwrap();
        assert_eq!(pair.contact_ratio, curve.window());
        assert_eq!(pair.pieces.len(), curve.points.len() - 1);
        for (p, (w, k)) in pair
            .pieces
            .iter()
            .zip(curve.points.windows(2).zip(curve.values.windows(2)))
        {
            assert_eq!((p.start, p.end, p.k_start), (w[0], w[1], k[0]));
            assert!((p.value(p.end) / k[1] - 1.0).abs() < 1e-12);
        }
        // No relief: the gap is the ETC gap only, zero on the theoretical window.
        let c = curve.contact_ratio;
        for (xi, want) in [
            (0.0, curve.base_pitch * ETC_EXTENSION),
            (ETC_EXTENSION, 0.0),
            (0.5, 0.0),
            (ETC_EXTENSION + c, 0.0),
            (c + 2.0 * ETC_EXTENSION, curve.base_pitch * ETC_EXTENSION),
        ] {
            let (g, _) = relief.gap_and_slope(curve.window(), xi);
            assert!(
                (g - want).abs() < 1e-18,
                "{}: ξ = {xi}: {g:e} vs {want:e}",
                m.name
            );
        }
        assert!((c - [1.504, 1.510][m.name.ends_with('2') as usize]).abs() < 1e-9);
    }
}

#[test]
fn tip_relief_acts_on_the_theoretical_window_plus_the_etc_gap() {
    let rho = 25e-6;
    let scene = Scene::from_toml_str(&with_relief(rho), "relief").unwrap();
    for m in &scene.meshes {
        let MeshForceModel::Pairs {
            pair,
            relief: PairGap::Table(gaps),
            ..
        } = &m.force
        else {
            panic!("{}: expected the combined gap table", m.name);
        };
        let e = ETC_EXTENSION;
        let c = pair.contact_ratio - 2.0 * e;
        let pb = (gaps.values[0] - rho) / e;
        let gap = |xi: f64| gaps.gap_and_slope(pair.contact_ratio, xi).0;
        // Driven tip relief at the start of the theoretical window, driver tip relief at its
        // end (notes §1.5), each ρ there, falling linearly to 0 at the HPSTC / LPSTC.
        assert!((gap(e) - rho).abs() < 1e-15);
        assert!((gap(e + c) - rho).abs() < 1e-15);
        assert!(gap(e + c - 1.0).abs() < 1e-15);
        assert!(gap(e + 1.0).abs() < 1e-15);
        assert!((gap(e + 0.5 * (c - 1.0)) - 0.5 * rho).abs() < 1e-15);
        // Beyond the path ends: ρ plus p_b per mesh cycle.
        let base_pitch = std::f64::consts::PI * 0.00254 * 20f64.to_radians().cos();
        assert!(
            (pb / base_pitch - 1.0).abs() < 1e-9,
            "{}: p_b {pb:e}",
            m.name
        );
        assert!((gap(pair.contact_ratio) - (rho + pb * e)).abs() < 1e-15);
    }
}

#[test]
fn bad_geometry_pairs_are_refused_naming_the_field() {
    let cases = [
        (
            SCENE.replacen("teeth = 38\nprofile_shift", "teeth = 39\nprofile_shift", 1),
            "mesh[0].pairs.geometry.pinion.teeth = 39",
        ),
        (
            SCENE.replacen(
                "[mesh.pairs]\nkind = \"geometry\"\netc = true",
                "[mesh.pairs]\nkind = \"geometry\"\netc = true\ntorque = -5.0",
                1,
            ),
            "mesh[0].pairs.torque = -5",
        ),
        (
            SCENE.replacen("pressure_angle = 21.22 ", "pressure_angle = 22.0 ", 1),
            "mesh[0].pressure_angle = 22",
        ),
        (
            SCENE.replacen(
                "[mesh.pairs]\nkind = \"geometry\"",
                "[mesh.friction]\ncoefficient = 0.05\n\n[mesh.pairs]\nkind = \"geometry\"",
                1,
            ),
            "mesh[0].friction",
        ),
    ];
    for (text, want) in cases {
        assert_ne!(text, SCENE, "edit for {want} did not apply");
        let e = Scene::from_toml_str(&text, "bad").unwrap_err().to_string();
        assert!(e.contains(want), "expected {want:?} in: {e}");
    }
}

/// The Ch. 2 geometry scene at 50 N·m with relief A (10 µm) under `rtol`.
fn relief_a_at_50_nm(rtol: f64) -> Scene {
    let text = with_relief(1e-5)
        .replace("input_torque = 100.0", "input_torque = 50.0")
        .replace(
            "method = \"auto\"",
            &format!(
                "method = \"auto\"\nrtol = {rtol:e}\natol = {:e}",
                rtol * 1e-6
            ),
        );
    assert!(text.contains("input_torque = 50.0") && text.contains("rtol = "));
    Scene::from_toml_str(&text, "ch2_idler_geometry.toml (relief A, 50 N·m)").unwrap()
}

/// Regression (issue 36): sloped pair stiffness puts the scene on the RK integrator, and the
/// sweep's recording of the orbit (`analysis::orbit_statistics`) restarts it at a cell's start
/// for each of its probes. Every restart met the same contact event at the same time, and the
/// count of "events without progress" was carried over the restarts: after 100 of them the
/// healthy run failed with "state events without progress" (a row of NaN at 2210.5 rpm). The
/// points must complete and agree with the same sweep at a 100× tighter tolerance.
#[test]
fn geometry_pair_sweep_point_survives_probe_restarts_and_matches_a_tighter_run() {
    let speeds = vec![231.48, 231.486];
    let run = |rtol: f64| {
        let scene = relief_a_at_50_nm(rtol);
        sweep(
            &scene,
            &SweepOptions::new(speeds.clone(), Direction::Up),
            &|_, _| {},
        )
        .unwrap()
        .points
    };
    let (nominal, tight) = (run(1e-9), run(1e-11));
    for (a, b) in nominal.iter().zip(&tight) {
        assert!(
            a.converged && b.converged,
            "speed {}: not converged",
            a.speed
        );
        assert_eq!(a.response_periods, b.response_periods, "speed {}", a.speed);
        for (ma, mb) in a.meshes.iter().zip(&b.meshes) {
            let what = format!("speed {} {}", a.speed, ma.prefix);
            assert!(ma.dte_rms.is_finite(), "{what}: the point failed (NaN row)");
            let rel = |x: f64, y: f64| (x - y).abs() / y.abs();
            assert!(
                rel(ma.dte_rms, mb.dte_rms) < 1e-4,
                "{what}: DTE RMS {} vs {}",
                ma.dte_rms,
                mb.dte_rms
            );
            assert!(
                rel(ma.peak_force, mb.peak_force) < 1e-4,
                "{what}: peak force {} vs {}",
                ma.peak_force,
                mb.peak_force
            );
            assert!(
                (ma.contact_loss_fraction - mb.contact_loss_fraction).abs() < 1e-4,
                "{what}: contact loss {} vs {}",
                ma.contact_loss_fraction,
                mb.contact_loss_fraction
            );
        }
    }
}
