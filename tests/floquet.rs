//! Issue 2, acceptance 2: Meissner equation `m x'' + c x' + k(p) x = 0` with rectangular
//! stiffness. The exact propagator's monodromy is checked against (a) the closed-form product
//! of the two segment transition matrices and (b) the growth measured by RK integration over
//! 200 mesh periods, inside and outside the primary instability region (f_m ≈ 2 f_n).

mod common;

use std::f64::consts::TAU;

use common::meissner::{closed_form_monodromy, f_n, meissner, K_MEAN};
use common::M_E;
use geardyn::analysis::monodromy;
use geardyn::scene::PairScene;
use geardyn::simulation::Simulation;
use nalgebra::{Complex, DMatrix};

/// Monodromy fitted to RK samples `y(jT)`, j = 0..=periods, from two initial conditions:
/// least squares of `Y_{j+1} = M Y_j` with every pair scaled by `1/|Y_j|` so the growing tail
/// does not swamp the early, well-conditioned samples.
fn rk_fitted_monodromy(scene: &PairScene, periods: usize) -> DMatrix<f64> {
    let period = 1.0 / (common::TEETH * scene.operating.pinion_speed / TAU);
    let w_n = (K_MEAN / M_E).sqrt();
    let mut lhs = DMatrix::<f64>::zeros(2, 2); // Σ Y1 Y0ᵀ
    let mut gram = DMatrix::<f64>::zeros(2, 2); // Σ Y0 Y0ᵀ
    for y0 in [[1.0e-6, 0.0], [0.0, 1.0e-6 * w_n]] {
        let mut sim = Simulation::new(scene).expect("simulation");
        assert_ne!(sim.method_name(), "exact", "the oracle must be the RK path");
        sim.set_state(0.0, y0);
        let mut prev = nalgebra::Vector2::new(y0[0], y0[1] / w_n);
        for j in 1..=periods {
            sim.advance_to(j as f64 * period).expect("advance");
            let y = sim.state();
            let next = nalgebra::Vector2::new(y[0], y[1] / w_n);
            let w = 1.0 / prev.norm_squared();
            lhs += (next * prev.transpose()) * w;
            gram += (prev * prev.transpose()) * w;
            prev = next;
        }
    }
    // Undo the velocity scaling: M = S⁻¹ M_s S with S = diag(1, 1/w_n).
    let m_s = lhs * gram.try_inverse().expect("well-conditioned samples");
    let s = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![1.0, 1.0 / w_n]));
    let s_inv = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![1.0, w_n]));
    s_inv * m_s * s
}

fn sorted(mut mu: Vec<Complex<f64>>) -> Vec<Complex<f64>> {
    mu.sort_by(|a, b| (a.norm(), a.im).partial_cmp(&(b.norm(), b.im)).unwrap());
    mu
}

fn check(f_ratio: f64, zeta: f64, expect_unstable: bool) {
    let f_mesh = f_ratio * f_n();
    let s = meissner(f_mesh, zeta);
    let floquet = monodromy(&s).expect("monodromy");

    // (a) closed form.
    let closed = closed_form_monodromy(f_mesh, zeta);
    let exact = &floquet.monodromy;
    let norm = closed.norm();
    let dev = (0..2)
        .flat_map(|i| (0..2).map(move |j| (i, j)))
        .map(|(i, j)| (exact[(i, j)] - closed[(i, j)]).abs())
        .fold(0.0, f64::max)
        / norm;
    assert!(dev < 1e-12, "monodromy vs closed form: {dev:e}");

    // (b) RK growth over 200 mesh periods.
    let fitted = rk_fitted_monodromy(&s, 200);
    let mu_exact = sorted(floquet.multipliers.clone());
    let mu_rk = sorted(fitted.complex_eigenvalues().iter().copied().collect());
    let rho = floquet.spectral_radius();
    let worst = mu_exact
        .iter()
        .zip(&mu_rk)
        .map(|(a, b)| (a - b).norm() / a.norm())
        .fold(0.0, f64::max);
    println!(
        "f_m/f_n = {f_ratio}, ζ = {zeta}: μ_exact = {mu_exact:?}, |μ|max = {rho:.9}, \
         μ_rk = {mu_rk:?}, max rel. diff {worst:.2e}, closed-form dev {dev:.1e}"
    );
    // Undamped and stable means |μ| = 1 exactly in theory; allow for rounding.
    assert_eq!(
        rho > 1.0 + 1e-9,
        expect_unstable,
        "stability verdict, |μ|max = {rho}"
    );
    assert!(worst <= 1e-6, "multipliers differ by {worst:e} (relative)");
    if expect_unstable {
        let growth_exact = rho.ln();
        let growth_rk = mu_rk.iter().map(|m| m.norm()).fold(0.0, f64::max).ln();
        let rel = (growth_rk - growth_exact).abs() / growth_exact;
        println!("  growth per period: exact {growth_exact:.9}, RK {growth_rk:.9} (rel {rel:.1e})");
        assert!(rel <= 1e-6, "growth rate differs by {rel:e}");
    }
}

#[test]
fn inside_primary_instability_undamped() {
    check(2.0, 0.0, true);
}

#[test]
fn inside_primary_instability_damped() {
    check(2.0, 0.02, true);
}

#[test]
fn outside_instability_undamped() {
    check(1.4, 0.0, false);
    check(3.0, 0.0, false);
}

#[test]
fn outside_instability_damped() {
    check(1.4, 0.02, false);
}

#[test]
fn contact_loss_scene_is_refused() {
    let text = common::scene_text(
        "contact = \"contact_loss\"\n[mesh.stiffness]\nkind = \"constant\"\nvalue = 2e8",
        "pinion_speed = 300.0\ninput_torque = 10.0",
        "",
    );
    let s = PairScene::from_toml_str(&text, "t").unwrap();
    let err = monodromy(&s).unwrap_err();
    assert!(err.contains("mesh.contact"), "{err}");
}
