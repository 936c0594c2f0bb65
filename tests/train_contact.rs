//! Tooth-pair contact (Model-1), tip relief, STE/NLTE statics and the Model-2/3 force laws
//! (issue 5, acceptance 4), against closed forms of Liu (2007) §2.4–2.6 (notes §1.3–1.9).

use geardyn::model::train::mesh::CycleTable;
use geardyn::model::train::statics::loaded_ste;
use geardyn::model::train::TrainSimulation;
use geardyn::scene::train::{PairStiffness, TipRelief};
use geardyn::scene::Scene;

/// Table 2.1, mesh 1.
const K_HAT: f64 = 2.9831e8;
const EPS: f64 = 0.35;
const C: f64 = 1.504;
const F: f64 = 100.0 / 0.04535;

fn k_single() -> f64 {
    K_HAT * (1.0 + EPS * (1.0 - C))
}
fn k_double() -> f64 {
    K_HAT * (1.0 + EPS * (2.0 - C))
}

/// The gap of the notes §1.5 [R], written out here.
fn gap(xi: f64, dr: (f64, f64), dn: (f64, f64)) -> f64 {
    let mut g = 0.0;
    if dr.0 > 0.0 {
        g += dr.0 * (xi - (C - dr.1)).max(0.0) / dr.1;
    }
    if dn.0 > 0.0 {
        g += dn.0 * (dn.1 - xi).max(0.0) / dn.1;
    }
    g
}

fn relief(dr: (f64, f64), dn: (f64, f64)) -> TipRelief {
    TipRelief {
        driver_magnitude: dr.0,
        driver_length: dr.1,
        driven_magnitude: dn.0,
        driven_length: dn.1,
    }
}

#[test]
fn nlte_is_the_minimum_of_the_gaps() {
    let pair = PairStiffness::rectangular(K_HAT, EPS, C);
    for (dr, dn) in [
        ((10e-6, 0.504), (10e-6, 0.504)),
        ((12e-6, 0.7), (5e-6, 0.3)),
        ((8e-6, 1.2), (0.0, 1.0)),
    ] {
        let nlte = loaded_ste(&CycleTable::pairs(&pair, &relief(dr, dn)), 0.0);
        for i in 0..1000 {
            let s = (i as f64 + 0.5) / 1000.0;
            // Pairs engaged at s: ξ = s + c − 1 − j within [0, c) (docs/train.md).
            let min = (0..2)
                .map(|j| s + C - 1.0 - j as f64)
                .filter(|xi| (0.0..C).contains(xi))
                .map(|xi| gap(xi, dr, dn))
                .fold(f64::INFINITY, f64::min);
            assert!(
                (nlte.value(s) - min).abs() < 1e-18,
                "s = {s}: NLTE {} vs min gap {min}",
                nlte.value(s)
            );
        }
    }
}

#[test]
fn loaded_ste_without_relief_is_f_over_k() {
    let pair = PairStiffness::rectangular(K_HAT, EPS, C);
    let ste = loaded_ste(&CycleTable::pairs(&pair, &TipRelief::default()), F);
    for i in 0..1000 {
        let s = (i as f64 + 0.5) / 1000.0;
        // s = 0 is where the pair count drops: single contact on [0, 2 − c).
        let expected = if s < 2.0 - C {
            F / k_single()
        } else {
            F / k_double()
        };
        assert!((ste.value(s) - expected).abs() < 1e-20, "s = {s}");
    }
    // Mean of the loaded STE vs the mean STE F/k̂ (7.392 µm, Table 2.1 statics).
    assert!((F / K_HAT - 7.392e-6).abs() < 5e-10);
    let pp = ste.peak_to_peak();
    assert!((pp - (F / k_single() - F / k_double())).abs() < 1e-20);
}

/// Eq. (2.28): ρ* = 2Fε/(k̂[1+ε(1−c)][1+ε(2−c)]) with relief from the highest point of single
/// contact (ς = c − 1) on both flanks. With both pairs in contact in double contact the STE
/// there is F/K_d + ρ/2, so the p-p STE is |F/K_s − F/K_d − ρ/2|, zero at ρ*.
#[test]
fn tip_relief_toward_the_optimum_reduces_peak_to_peak_ste() {
    let rho_star = 2.0 * F * EPS / (K_HAT * (1.0 + EPS * (1.0 - C)) * (1.0 + EPS * (2.0 - C)));
    println!("ρ* = {rho_star:e} m");
    assert!((rho_star - 5.35e-6).abs() < 0.01e-6, "notes §1.10: 5.35 µm");
    let pair = PairStiffness::rectangular(K_HAT, EPS, C);
    let mut last = f64::INFINITY;
    for k in 0..=8 {
        let rho = rho_star * k as f64 / 8.0;
        let r = relief((rho, C - 1.0), (rho, C - 1.0));
        let pp = loaded_ste(&CycleTable::pairs(&pair, &r), F).peak_to_peak();
        let expected = (F / k_single() - F / k_double() - rho / 2.0).abs();
        println!("ρ = {rho:.3e}: p-p STE {pp:.4e} (closed form {expected:.4e})");
        assert!(
            (pp - expected).abs() < 1e-18,
            "ρ = {rho}: {pp} vs {expected}"
        );
        assert!(pp < last, "p-p STE must fall as ρ → ρ*");
        last = pp;
    }
    assert!(last < 1e-18, "zero at the optimum: {last}");
    // Past the optimum the p-p grows again (modification B of §2.4 is worse than A).
    let r = relief((2.5 * rho_star, C - 1.0), (2.5 * rho_star, C - 1.0));
    assert!(loaded_ste(&CycleTable::pairs(&pair, &r), F).peak_to_peak() > 1e-7);
}

/// A free single-mesh pair with the Table 2.1 mesh 1 as `model`, at standstill phase `s`.
fn pair_scene(model: &str, rho: f64, contact: &str) -> Scene {
    let text = format!(
        r#"name = "pairs"
[[gear]]
name = "pinion"
teeth = 38
base_radius = 0.04535
inertia = 0.002621
[[gear]]
name = "idler"
teeth = 55
base_radius = 0.06564
inertia = 0.01091
[[mesh]]
pinion = "pinion"
gear = "idler"
{contact}
model = "{model}"
initial_phase = 0.0
[mesh.pairs]
kind = "rectangular"
mean = {K_HAT}
peak_to_peak_ratio = {EPS}
contact_ratio = {C}
[mesh.tip_relief]
driver_magnitude = {rho}
driver_length = {l}
driven_magnitude = {rho}
driven_length = {l}
[operating]
input_speed = 0.0
input_torque = 100.0
"#,
        l = C - 1.0
    );
    Scene::from_toml_str(&text, "pairs").unwrap()
}

/// Mesh force at phase `s` and deflection `x`: the initial phase is set to `s` and the state
/// to `[x, 0]` (the mode is re-derived from the state).
fn force_at(scene: &Scene, s: f64, x: f64) -> (f64, Vec<f64>) {
    let mut sc = scene.clone();
    sc.meshes[0].initial_phase = s;
    let mut sim = TrainSimulation::new(&sc).unwrap();
    sim.set_state(0.0, &[x, 0.0]);
    let mut out = Vec::new();
    sim.outputs(&mut out);
    let col = |n: &str| sim.output_names().iter().position(|c| c == n).unwrap();
    let pairs: Vec<f64> = sim
        .output_names()
        .iter()
        .enumerate()
        .filter(|(_, n)| n.contains(".pair") && n.ends_with(".force"))
        .map(|(i, _)| out[i])
        .collect();
    (out[col("mesh1.force")], pairs)
}

#[test]
fn model_force_laws() {
    let rho = 8e-6;
    let l = C - 1.0;
    // Model-1: Σ_p h_p k_p (S − g_p), h_p from the sign of S − g_p (eq. 2.2, 2.4).
    let m1 = pair_scene("pairs", rho, "contact = \"contact_loss\"");
    for &(s, x) in &[
        (0.2, 6e-6),
        (0.7, 6e-6),
        (0.7, 2e-6),
        (0.9, 7e-6),
        (0.55, 1e-6),
    ] {
        let (f, per_pair) = force_at(&m1, s, x);
        let mut expected = 0.0;
        for j in 0..2 {
            let xi = s + C - 1.0 - j as f64;
            if !(0.0..C).contains(&xi) {
                continue;
            }
            let k = if !(C - 1.0..1.0).contains(&xi) {
                k_double() / 2.0
            } else {
                k_single()
            };
            let g = gap(xi, (rho, l), (rho, l));
            expected += k * (x - g).max(0.0);
        }
        assert!(
            (f - expected).abs() < 1e-9 * expected.max(1.0),
            "s {s} x {x}: {f} vs {expected}"
        );
        assert!((per_pair.iter().sum::<f64>() - f).abs() < 1e-9 * f.max(1.0));
    }
    // Partial contact loss: at s = 0.55 (double contact) with x = 1 µm the incoming pair
    // (gap 8·(1 − 0.051/0.504)… µm) is open while the outgoing one (gap ≈ 0.81 µm) carries.
    let (_, per_pair) = force_at(&m1, 0.55, 1e-6);
    assert!(
        per_pair.iter().filter(|&&p| p > 0.0).count() == 1,
        "{per_pair:?}"
    );

    // Model-3: k(s)(S − NLTE(s)), NLTE = min gap (eq. 2.11).
    let m3 = pair_scene("nlte", rho, "contact = \"contact_loss\"");
    for &(s, x) in &[(0.2, 6e-6), (0.7, 6e-6), (0.9, 7e-6)] {
        let xis: Vec<f64> = (0..2)
            .map(|j| s + C - 1.0 - j as f64)
            .filter(|xi| (0.0..C).contains(xi))
            .collect();
        let k: f64 = xis
            .iter()
            .map(|&xi| {
                if !(C - 1.0..1.0).contains(&xi) {
                    k_double() / 2.0
                } else {
                    k_single()
                }
            })
            .sum();
        let nlte = xis
            .iter()
            .map(|&xi| gap(xi, (rho, l), (rho, l)))
            .fold(f64::INFINITY, f64::min);
        let expected = k * (x - nlte).max(0.0);
        let (f, _) = force_at(&m3, s, x);
        assert!(
            (f - expected).abs() < 1e-9 * expected,
            "M3 s {s}: {f} vs {expected}"
        );
    }

    // Model-2: k̂(S − (δ(s) − mean δ)) with the loaded STE at F = T_1/r_1 (eq. 2.10). With
    // ρ below ρ* both pairs carry load in double contact: δ = F/K_d + ρ/2 there, F/K_s alone.
    let m2 = pair_scene("loaded_ste", rho, "contact = \"contact_loss\"");
    let double = F / k_double() + rho / 2.0;
    let single = F / k_single();
    let mean = (C - 1.0) * double + (2.0 - C) * single;
    for &(s, x) in &[(0.2, 6e-6), (0.7, 6e-6), (0.9, 7.5e-6)] {
        let delta = if s < 2.0 - C { single } else { double };
        let expected = K_HAT * (x - (delta - mean));
        let (f, _) = force_at(&m2, s, x);
        assert!(
            (f - expected).abs() < 1e-9 * expected,
            "M2 s {s}: {f} vs {expected}"
        );
    }
}

#[test]
fn back_side_contact_uses_the_corrected_sign() {
    // Per pair with backlash 2b: F_p = k_p(S − g_p + 2b) < 0 beyond the clearance (notes §1.3
    // [R]; eq. 2.4 as printed would give +k(S − g)).
    let b = 20e-6;
    let scene = pair_scene(
        "pairs",
        0.0,
        &format!("contact = \"backlash\"\nbacklash = {b}"),
    );
    let x = -b - 1e-6;
    let (f, per_pair) = force_at(&scene, 0.2, x);
    let expected = k_single() * (x + b);
    assert!(
        (f - expected).abs() < 1e-9 * expected.abs(),
        "{f} vs {expected}"
    );
    assert!(f < 0.0);
    assert_eq!(per_pair.iter().filter(|&&p| p < 0.0).count(), 1);
    // Inside the clearance: no force.
    assert_eq!(force_at(&scene, 0.2, -b / 2.0).0, 0.0);
}

/// Tabulated gaps: a table holding the linear relief gives the same loaded STE, and the NLTE
/// of an arbitrary table is the minimum of the linearly interpolated gaps.
#[test]
fn tabulated_gaps() {
    use geardyn::scene::train::GapTable;
    let pair = PairStiffness::rectangular(K_HAT, EPS, C);
    let l = C - 1.0;
    let rho = 4e-6;
    let as_table = GapTable {
        points: vec![0.0, l, 1.0, C],
        values: vec![rho, 0.0, 0.0, rho],
    };
    let a = loaded_ste(&CycleTable::pairs(&pair, &as_table), F);
    let b = loaded_ste(&CycleTable::pairs(&pair, &relief((rho, l), (rho, l))), F);
    for i in 0..500 {
        let s = (i as f64 + 0.5) / 500.0;
        assert!((a.value(s) - b.value(s)).abs() < 1e-18, "s = {s}");
    }
    let points = [0.0, 0.2, 0.7, 1.1, C];
    let values = [3e-6, -1e-6, 2e-6, 0.5e-6, 5e-6];
    let table = GapTable {
        points: points.to_vec(),
        values: values.to_vec(),
    };
    let interp = |xi: f64| {
        let k = points
            .windows(2)
            .position(|w| xi >= w[0] && xi < w[1])
            .unwrap();
        values[k] + (values[k + 1] - values[k]) * (xi - points[k]) / (points[k + 1] - points[k])
    };
    let nlte = loaded_ste(&CycleTable::pairs(&pair, &table), 0.0);
    for i in 0..1000 {
        let s = (i as f64 + 0.5) / 1000.0;
        let min = (0..2)
            .map(|j| s + C - 1.0 - j as f64)
            .filter(|xi| (0.0..C).contains(xi))
            .map(interp)
            .fold(f64::INFINITY, f64::min);
        assert!(
            (nlte.value(s) - min).abs() < 1e-18,
            "s = {s}: {} vs {min}",
            nlte.value(s)
        );
    }
    // Scene syntax, and the table must span the window.
    let scene = pair_scene("pairs", 0.0, "contact = \"contact_loss\"");
    let text = scene.source.replace(
        "[mesh.tip_relief]\ndriver_magnitude = 0\n",
        "[mesh.gaps]\npoints = [0.0, 1.504]\nvalues = [1e-6, 2e-6]\n[mesh.tip_relief]\ndriver_magnitude = 0\n",
    );
    let e = Scene::from_toml_str(&text, "gaps").unwrap_err().0;
    assert!(e.contains("tip_relief or gaps"), "{e}");
    let text = text.replace(
        "[mesh.tip_relief]\ndriver_magnitude = 0\ndriver_length = 0.504\ndriven_magnitude = 0\ndriven_length = 0.504\n",
        "",
    );
    Scene::from_toml_str(&text, "gaps").unwrap();
    let bad = text.replace("points = [0.0, 1.504]", "points = [0.0, 1.4]");
    let e = Scene::from_toml_str(&bad, "gaps").unwrap_err().0;
    assert!(e.contains("mesh[0].gaps.points[1] = 1.4"), "{e}");
}
