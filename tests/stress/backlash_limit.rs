//! Near-zero backlash (numerics notes §5, S6): as the clearance `b` → 0 the backlash law
//! `F = kδ` (δ > 0), `0` (−b ≤ δ ≤ 0), `k(δ + b)` (δ < −b) tends to the linear law `F = kδ`, so
//! the response must converge to the linear closed form with an error ∝ b, with a bounded
//! number of events per mesh period and no step-size collapse. The motion straddles the gap
//! every mesh period (STE forcing 4 µm against a static deflection of 5 µm near resonance).
//!
//! Closed form (constant `k`, damping `c`, `e = a cos wt`): with `δ = x − e`,
//! `m δ'' + c δ' + k δ = F + m a w² cos wt`, so `δ = F/k + Re(A e^{iwt}) + δ_h`,
//! `A = m a w²/(k − m w² + i c w)`, and `δ_h` the damped free response matching
//! `δ(0) = F/k` (from `x(0) = F/k + a`) and `δ'(0) = 0`.

use std::f64::consts::TAU;

use super::{common, simulation, Propagator};
use geardyn::scene::PairScene;
use geardyn::solve::rk::Method;

const M: f64 = 0.5;
const K: f64 = 2.0e8;
const ZETA: f64 = 0.05;
const FORCE: f64 = 1000.0;
const STE: f64 = 4.0e-6;

fn f_mesh() -> f64 {
    0.8 * (K / M).sqrt() / TAU
}

fn delta_s() -> f64 {
    FORCE / K
}

fn pair_scene(contact: &str) -> PairScene {
    common::scene(
        &format!(
            "{contact}\ndamping_ratio = {ZETA}\n\
             [mesh.stiffness]\nkind = \"constant\"\nvalue = {K:e}\n[mesh.ste]\ncos = [{STE:e}]"
        ),
        &format!(
            "pinion_speed = {}\ninput_torque = {}",
            common::pinion_speed_for_mesh_frequency(f_mesh()),
            FORCE * 0.05
        ),
        &format!("[initial]\ndte = {:e}\ndte_rate = 0.0", delta_s() + STE),
    )
}

/// The linear closed form `x(t)`.
fn linear_dte(t: f64) -> f64 {
    let w = TAU * f_mesh();
    let c = 2.0 * ZETA * (K * M).sqrt();
    let (re, im) = (K - M * w * w, c * w);
    let den = re * re + im * im;
    let a = M * STE * w * w;
    // A = a / (re + i im) = a (re − i im) / den.
    let (ar, ai) = (a * re / den, -a * im / den);
    let particular = |t: f64| FORCE / K + ar * (w * t).cos() - ai * (w * t).sin();
    let wn = (K / M).sqrt();
    let sigma = ZETA * wn;
    let wd = wn * (1.0 - ZETA * ZETA).sqrt();
    let c1 = delta_s() - particular(0.0);
    // δ_h'(0) = δ'(0) − δ_p'(0), δ_p'(0) = Re(i w A) = −w·ai.
    let c2 = (0.0 + w * ai + sigma * c1) / wd;
    let delta = particular(t) + (-sigma * t).exp() * (c1 * (wd * t).cos() + c2 * (wd * t).sin());
    delta + STE * (w * t).cos()
}

/// Max |x − x_linear|/δ_s over `periods` mesh periods (32 samples each) and events per period.
fn deviation(scene: &PairScene, prop: Propagator, periods: usize) -> (f64, f64) {
    let mut sim = simulation(scene, prop, delta_s());
    let samples = 32 * periods;
    let mut worst: f64 = 0.0;
    for i in 1..=samples {
        let t = i as f64 / 32.0 / f_mesh();
        sim.advance_to(t).expect("advance");
        worst = worst.max((sim.state()[0] - linear_dte(t)).abs() / delta_s());
    }
    (worst, sim.model().events().len() as f64 / periods as f64)
}

fn check(periods: usize) {
    // The floor: each propagator's own error on the linear law (at least 10 × what it
    // measured on the linear scene over the same run).
    for (prop, floor) in [
        (Propagator::Exact, 1e-12_f64),
        (Propagator::Rk(Method::Dop853, 1e-11), 3e-11),
    ] {
        let (lin, _) = deviation(&pair_scene("contact = \"linear\""), prop, periods);
        println!("{prop:?}: linear law vs closed form {lin:.2e} δ_s");
        assert!(
            lin <= 1e-8,
            "{prop:?}: linear law off its closed form by {lin:e}"
        );
        for rel in [1e-3, 1e-6, 1e-9, 1e-12] {
            let b = rel * delta_s();
            let scene = pair_scene(&format!("contact = \"backlash\"\nbacklash = {b:e}"));
            let (err, events) = deviation(&scene, prop, periods);
            println!(
                "{prop:?}: b = {rel:.0e} δ_s: max |x − x_linear| = {err:.2e} δ_s ({:.1} b), {events:.2} events per mesh period",
                err / rel
            );
            assert!(events >= 2.0, "the motion must cross the gap");
            assert!(events <= 4.5, "event count out of bounds: {events}");
            // Measured: 3.0 b (the gap lets the teeth travel b without force twice a period).
            assert!(
                err <= 5.0 * rel + floor.max(10.0 * lin),
                "{prop:?}, b = {b:e}: error {err:e} δ_s is not O(b)"
            );
        }
    }
}

#[test]
fn near_zero_backlash_converges_to_the_linear_solution() {
    check(50);
}

#[test]
#[ignore = "long: 5000 mesh periods; bash scripts/stress.sh"]
fn near_zero_backlash_converges_to_the_linear_solution_long() {
    check(5000);
}
