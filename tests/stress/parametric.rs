//! Parametric instability must not be damped away by any method (numerics notes §5, S5):
//! the Meissner equation (rectangular stiffness, ε = 0.35, contact ratio 1.5, ζ = 0.01)
//! integrated by every propagator, at tight and loose tolerances. Oracle: the growth per mesh
//! period `ln ρ`, `ρ` the spectral radius of the closed-form monodromy (product of the two
//! segments' transition matrices, `tests/common/meissner.rs`; eigenvalues of a 2×2 from its
//! trace and determinant here). `tests/floquet.rs` checks DOP853 at rtol 1e-10 at two
//! frequencies; this check covers DP5, loose tolerances and (long variant) a sweep across the
//! instability tongue, where the verdict (growth or decay) must match at every point.

use super::common::meissner::{closed_form_monodromy, f_n, meissner, K_MEAN};
use super::common::M_E;
use super::{simulation, Propagator};
use geardyn::solve::rk::Method;

const ZETA: f64 = 0.01;

/// Spectral radius of the closed-form monodromy.
fn rho(f_mesh: f64) -> f64 {
    let m = closed_form_monodromy(f_mesh, ZETA);
    let (tr, det) = (m.trace(), m.determinant());
    let disc = tr * tr / 4.0 - det;
    if disc >= 0.0 {
        (tr / 2.0).abs() + disc.sqrt()
    } else {
        det.sqrt()
    }
}

/// Growth per mesh period measured over periods `n/2..n` from the amplitude of the state
/// (`|x|` and `|x'|/ω_n`, maximised over a period's samples).
fn measured_growth(f_mesh: f64, prop: Propagator, n: usize) -> f64 {
    let w_n = (K_MEAN / M_E).sqrt();
    let mut sim = simulation(&meissner(f_mesh, ZETA), prop, 1e-6);
    let period = 1.0 / f_mesh;
    let amplitude = |sim: &mut geardyn::simulation::Simulation, j: usize| {
        (0..16)
            .map(|i| {
                sim.advance_to((j as f64 + i as f64 / 16.0) * period)
                    .expect("advance");
                let [x, v] = sim.state();
                x.hypot(v / w_n)
            })
            .fold(0.0, f64::max)
    };
    let a = amplitude(&mut sim, n / 2);
    let b = amplitude(&mut sim, n);
    (b / a).ln() / (n - n / 2) as f64
}

fn props() -> [(Propagator, f64); 5] {
    [
        (Propagator::Exact, 1e-9),
        (Propagator::Rk(Method::Dop853, 1e-10), 1e-8),
        (Propagator::Rk(Method::Dp5, 1e-10), 1e-7),
        (Propagator::Rk(Method::Dop853, 1e-6), 1e-5),
        (Propagator::Rk(Method::Dp5, 1e-5), 1e-3),
    ]
}

#[test]
fn primary_instability_grows_at_the_closed_form_rate_for_every_method() {
    let f_mesh = 2.0 * f_n();
    let expected = rho(f_mesh).ln();
    assert!(
        expected > 0.05,
        "the test point must be well inside the tongue"
    );
    for (prop, tol) in props() {
        let got = measured_growth(f_mesh, prop, 200);
        let rel = (got - expected).abs() / expected;
        println!("f_m = 2 f_n, {prop:?}: growth per period {got:.9} vs ln ρ = {expected:.9} (rel {rel:.1e})");
        assert!(rel <= tol, "{prop:?}: growth {got} vs {expected}");
    }
}

#[test]
#[ignore = "long: 41 frequencies across the tongue × 5 methods; bash scripts/stress.sh"]
fn stability_verdict_matches_across_the_tongue() {
    let mut unstable = 0;
    for i in 0..=40 {
        let ratio = 1.6 + 0.02 * i as f64;
        let f_mesh = ratio * f_n();
        let expected = rho(f_mesh).ln();
        if expected.abs() < 2e-3 {
            continue; // too close to the boundary for a verdict over 200 periods
        }
        unstable += usize::from(expected > 0.0);
        for (prop, _) in props() {
            let got = measured_growth(f_mesh, prop, 400);
            assert_eq!(
                got > 0.0,
                expected > 0.0,
                "f_m/f_n = {ratio}, {prop:?}: growth {got:e}, closed form ln ρ = {expected:e}"
            );
        }
        println!("f_m/f_n = {ratio:.2}: ln ρ = {expected:+.4e}, all methods agree");
    }
    assert!(unstable >= 5, "the sweep must cross the tongue");
}
