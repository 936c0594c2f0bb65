//! Natural frequencies and statics of the drivetrain model against printed values of Liu (2007)
//! and closed forms from the notes (issue 5, acceptance 1 and 2).

use geardyn::model::train::{modes, statics, Assembly, GearTrain};
use geardyn::scene::Scene;
use nalgebra::{DMatrix, SymmetricEigen};

fn frequencies(scene: &Scene) -> Vec<f64> {
    modes(&Assembly::new(scene))
        .iter()
        .map(|m| m.frequency)
        .collect()
}

fn within(got: &[f64], printed: &[f64], rel: f64) {
    assert_eq!(got.len(), printed.len(), "{got:?}");
    for (g, p) in got.iter().zip(printed) {
        assert!(
            (g - p).abs() <= rel * p,
            "{g} Hz vs printed {p} Hz ({got:?})"
        );
    }
}

#[test]
fn table_2_2_compliant_bearings() {
    let scene = Scene::example("idler_gearset").unwrap();
    let f = frequencies(&scene);
    println!("compliant: {f:?}");
    within(
        &f,
        &[69.0, 446.0, 499.0, 640.0, 890.0, 1076.0, 2530.0, 3850.0],
        0.005,
    );
    // Mode 3 is the follower's off-line lateral mode (Table 2.2): √(k_y3/m_3)/2π exactly.
    let lateral = (1.6637e8f64 / 16.9419).sqrt() / std::f64::consts::TAU;
    assert!(
        (f[2] - lateral).abs() < 1e-9 * lateral,
        "{} vs {lateral}",
        f[2]
    );
}

#[test]
fn table_2_2_rigid_bearings() {
    let scene = Scene::example("idler_gearset")
        .unwrap()
        .with_rigid_bearings();
    let f = frequencies(&scene);
    println!("rigid: {f:?}");
    within(&f, &[69.5, 1605.0, 3231.0], 0.005);
}

/// Without the ground couplings the rotational idler is eq. (2.12): a rigid-body mode and the
/// two modes of `M̃ ẍ + diag(k̂_1, k̂_2) x = 0`, solved here in closed form.
#[test]
fn free_rotational_idler_matches_eq_2_12() {
    let mut scene = Scene::example("idler_gearset")
        .unwrap()
        .with_rigid_bearings();
    for g in &mut scene.gears {
        g.ground_stiffness = 0.0;
    }
    let f = frequencies(&scene);
    let m = [
        0.002621 / 0.04535f64.powi(2),
        0.01091 / 0.06564f64.powi(2),
        0.1193 / 0.11218f64.powi(2),
    ];
    let s = m[0] + m[1] + m[2];
    let (a, b, c) = (
        m[0] * (m[1] + m[2]) / s,
        m[0] * m[2] / s,
        m[2] * (m[0] + m[1]) / s,
    );
    let (k1, k2) = (2.9831e8, 3.2108e8);
    // det(K − λM̃) = 0: (ac − b²)λ² − (k1 c + k2 a)λ + k1 k2 = 0.
    let (qa, qb, qc) = (a * c - b * b, -(k1 * c + k2 * a), k1 * k2);
    let disc = (qb * qb - 4.0 * qa * qc).sqrt();
    let hz = |l: f64| l.sqrt() / std::f64::consts::TAU;
    let expected = [hz((-qb - disc) / (2.0 * qa)), hz((-qb + disc) / (2.0 * qa))];
    println!("free: {f:?} vs {expected:?}");
    assert_eq!(f[0], 0.0, "rigid-body mode");
    for (g, e) in f[1..].iter().zip(expected) {
        assert!((g - e).abs() < 1e-9 * e, "{g} vs {e}");
    }
    // The notes' values of eq. (2.12): 1600.3 and 3228.3 Hz.
    within(&f[1..], &[1600.3, 3228.3], 5e-4);
}

#[test]
fn table_2_1_statics() {
    let scene = Scene::example("idler_gearset").unwrap();
    // Torque balance: T_3 = −T_1 r_3/r_1 (Table 2.1 prints −247 N·m).
    let t3 = scene.operating.load_torque;
    assert!((t3 - 100.0 * 0.11218 / 0.04535).abs() < 1e-12 * t3);
    assert!((t3 - 247.0).abs() < 0.5);
    for s in [scene.clone(), scene.with_rigid_bearings()] {
        let st = statics::equilibrium(&Assembly::new(&s), 100.0, t3, false).unwrap();
        println!(
            "forces {:?}, deflections {:?}",
            st.mesh_force, st.deflection
        );
        for f in &st.mesh_force {
            assert!((f - 2205.07).abs() < 0.005, "mesh force {f}");
            assert!((f - 100.0 / 0.04535).abs() < 1e-9 * f);
        }
        assert!(
            (st.deflection[0] - 7.392e-6).abs() < 0.5e-9,
            "{}",
            st.deflection[0]
        );
        assert!(
            (st.deflection[1] - 6.868e-6).abs() < 0.5e-9,
            "{}",
            st.deflection[1]
        );
    }
    // Unbalanced torques have no static state.
    let err = statics::equilibrium(&Assembly::new(&scene), 100.0, 200.0, false).unwrap_err();
    assert!(err.contains("not balanced"), "{err}");
}

/// Ch. 4: the counter-shaft with an elastic middle shaft has the natural frequencies of the
/// reduced model (4.2) with the mass matrix M̂ derived in the notes (§3.1, it is missing in the
/// thesis) and `K̂ = diag(k̄_1, k̄_2, k_r/r_2²)`, coordinates `x_1 = r_1ψ_1 + r_2ψ_2`,
/// `x_2 = −(r_3ψ_3 + r_4ψ_4)` (corrected), `x_3 = r_2(ψ_2 − ψ_3)`.
#[test]
fn countershaft_matches_notes_mass_matrix() {
    let mut scene = Scene::example("countershaft_gearset").unwrap();
    let k_r = 6.35e5;
    let text = scene
        .source
        .replace("rigid = true", &format!("stiffness = {k_r}"));
    scene = Scene::from_toml_str(&text, "countershaft").unwrap();
    let f = frequencies(&scene);
    let j: Vec<f64> = scene.gears.iter().map(|g| g.inertia).collect();
    let r: Vec<f64> = scene.gears.iter().map(|g| g.base_radius).collect();
    let (j1, j2, j3, j4) = (j[0], j[1], j[2], j[3]);
    let (r1, r2, r3, r4) = (r[0], r[1], r[2], r[3]);
    let d = j1 * r2 * r2 * r4 * r4
        + j2 * r1 * r1 * r4 * r4
        + j3 * r1 * r1 * r4 * r4
        + j4 * r1 * r1 * r3 * r3;
    let m11 = j1 * (j2 * r4 * r4 + j3 * r4 * r4 + j4 * r3 * r3) / d;
    let m12 = j1 * j4 * r2 * r3 / d;
    let m13 = -j1 * (j3 * r4 * r4 + j4 * r3 * r3) / d;
    let m22 = j4 * (j1 * r2 * r2 + j2 * r1 * r1 + j3 * r1 * r1) / d;
    let m23 = -j4 * r3 * (j1 * r2 * r2 + j2 * r1 * r1) / (r2 * d);
    let m33 = (j1 * j3 * r2 * r2 * r4 * r4
        + j1 * j4 * r2 * r2 * r3 * r3
        + j2 * j3 * r1 * r1 * r4 * r4
        + j2 * j4 * r1 * r1 * r3 * r3)
        / (r2 * r2 * d);
    let mm = DMatrix::from_row_slice(3, 3, &[m11, m12, m13, m12, m22, m23, m13, m23, m33]);
    let kk = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![
        4.24e9,
        3.45e9,
        k_r / (r2 * r2),
    ]));
    let l = mm.clone().cholesky().unwrap().l();
    let li = l.try_inverse().unwrap();
    let a = &li * kk * li.transpose();
    let mut w2: Vec<f64> = SymmetricEigen::new((&a + a.transpose()) * 0.5)
        .eigenvalues
        .iter()
        .copied()
        .collect();
    w2.sort_by(f64::total_cmp);
    let expected: Vec<f64> = w2
        .iter()
        .map(|l| l.sqrt() / std::f64::consts::TAU)
        .collect();
    println!("countershaft: {f:?} vs {expected:?}");
    assert_eq!(f[0], 0.0);
    for (g, e) in f[1..].iter().zip(&expected) {
        assert!((g - e).abs() < 1e-8 * e, "{g} vs {e}");
    }
    // Torque balance corrected (Table 4.1 prints −258.4): T_4 = 100·(72/51)(73/19).
    assert!((scene.operating.load_torque - 542.4149).abs() < 1e-3);
    // The model's elastic coordinates include the two mesh deflections.
    let model = GearTrain::new(&scene).unwrap();
    assert_eq!(model.elastic_dim(), 3);
}
