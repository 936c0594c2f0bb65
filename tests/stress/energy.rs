//! Energy balance over long runs with rectangular mesh stiffness, including the work of the
//! stiffness jumps (Oh, Grosh & Barber 2005: a step Δk at deflection δ changes the stored
//! energy by ½Δk δ²; numerics notes §5, S1).
//!
//! The bookkeeping is written here from the equation of motion (docs/model.md), not taken
//! from the solver: `E = ½ m v² + ½ k(t) δ_c² − F x` with `δ_c` the compression of the flank
//! in contact (from `x` and the clearance), the levels of `k(t)` from the scene's numbers, the
//! jump instants where the model schedules them (checked against the nominal `(j+1)·T/2`; see
//! `balance`), and the damping dissipation `∫ c v² dt` by composite Boole quadrature (5-point
//! Newton–Cotes, error O(h⁶)) of samples of `v`. A check that ignored the jump work would
//! fail: the test asserts that the jump work is many times the tolerance.

use super::{common, scene_with_mass, simulation, Propagator};
use geardyn::scene::PairScene;
use geardyn::solve::rk::Method;
use geardyn::solve::HybridSystem;

const M: f64 = 0.5;
const K_MEAN: f64 = 2.0e8;
const EPS: f64 = 0.35;
/// Contact ratio 1.5: the two stiffness levels each hold half of the mesh period.
const CONTACT_RATIO: f64 = 1.5;
/// Mesh frequency, Hz: below the primary instability (f_m ≈ 2 f_n, f_n = 3183 Hz).
const F_MESH: f64 = 1500.0;

fn k_low() -> f64 {
    K_MEAN * (1.0 - 0.5 * EPS)
}

fn k_high() -> f64 {
    k_low() + EPS * K_MEAN
}

fn mesh_period() -> f64 {
    1.0 / F_MESH
}

fn tvms_scene(contact: &str, damping_ratio: f64, torque: f64, x0: f64) -> PairScene {
    scene_with_mass(
        M,
        &format!(
            "{contact}\ndamping_ratio = {damping_ratio}\n\
             [mesh.stiffness]\nkind = \"rectangular\"\nmean = {K_MEAN:e}\n\
             peak_to_peak_ratio = {EPS}\ncontact_ratio = {CONTACT_RATIO}"
        ),
        &format!(
            "pinion_speed = {}\ninput_torque = {torque}",
            common::pinion_speed_for_mesh_frequency(F_MESH)
        ),
        &format!("[initial]\ndte = {x0:e}\ndte_rate = 0.0"),
    )
}

/// Compression of the flank in contact for total clearance `clearance` (0: bilateral).
fn compression(x: f64, clearance: Option<f64>) -> f64 {
    match clearance {
        None => x,
        Some(_) if x > 0.0 => x,
        Some(c) if x < -c => x + c,
        Some(_) => 0.0,
    }
}

struct Balance {
    /// Largest |E − E0 − W_jumps + D| over all checked samples, J.
    residual: f64,
    /// Largest |W_jumps| reached, J.
    jump_work: f64,
    /// Dissipated energy at the end, J.
    dissipated: f64,
}

/// Runs `periods` mesh periods of `scene` (damping ratio `zeta`, constant external force
/// `force` N, total clearance `clearance` or bilateral contact), each stiffness segment
/// sampled at `n` (a multiple of 4) equal sub-intervals, and books the energy at every
/// fourth sample (the end of a Boole panel).
fn balance(
    scene: &PairScene,
    prop: Propagator,
    periods: usize,
    n: usize,
    (zeta, force, clearance): (f64, f64, Option<f64>),
) -> Balance {
    assert!(n.is_multiple_of(4));
    let c = 2.0 * zeta * (K_MEAN * M).sqrt();
    let mut sim = simulation(scene, prop, 1e-6);
    let energy = |x: f64, v: f64, k: f64| {
        let d = compression(x, clearance);
        0.5 * M * v * v + 0.5 * k * d * d - force * x
    };
    let [x0, v0] = sim.state();
    // Segment 0 is [0, T/2) at k_low (phase 0 is where the pair count drops).
    let e0 = energy(x0, v0, k_low());
    let (mut work, mut dissipated) = (0.0, 0.0);
    let mut out = Balance {
        residual: 0.0,
        jump_work: 0.0,
        dissipated: 0.0,
    };
    let half = 0.5 * mesh_period();
    // c v² at the samples of the current Boole panel (5 points, 4 sub-intervals).
    let mut power = [0.0; 5];
    power[0] = c * v0 * v0;
    for segment in 0..2 * periods {
        let k = if segment % 2 == 0 { k_low() } else { k_high() };
        let h = half / n as f64;
        // The jump instant as the model schedules it (its phase clock): the nominal
        // `(segment + 1)·T/2` may differ from it in the last bit, and a sample one ulp off the
        // switch books `Δk δ v·ulp(t)` of spurious jump work per jump, which at t ≈ 60 s
        // adds up over 2e5 jumps to ~1e-8 E0 whenever the orbit keeps the sign of δv at
        // the switches. The energy bookkeeping itself stays independent of the solver.
        let switch = sim.model().next_stop();
        let nominal = (segment + 1) as f64 * half;
        assert!(
            (switch - nominal).abs() <= 1e-12 * nominal,
            "switch at {switch:e}, nominal {nominal:e}"
        );
        for i in 1..=n {
            let t = if i == n {
                switch
            } else {
                (segment as f64 + i as f64 / n as f64) * half
            };
            sim.advance_to(t).expect("advance");
            let [x, v] = sim.state();
            power[(i - 1) % 4 + 1] = c * v * v;
            if i % 4 != 0 {
                continue;
            }
            let [f0, f1, f2, f3, f4] = power;
            dissipated +=
                2.0 * h / 45.0 * (7.0 * f0 + 32.0 * f1 + 12.0 * f2 + 32.0 * f3 + 7.0 * f4);
            power[0] = f4;
            let r = energy(x, v, k) - e0 - work + dissipated;
            out.residual = out.residual.max(r.abs());
            if i == n {
                // The jump at the end of the segment: k → the other level at the same δ.
                let k_next = if segment % 2 == 0 { k_high() } else { k_low() };
                let d = compression(x, clearance);
                work += 0.5 * (k_next - k) * d * d;
                out.jump_work = out.jump_work.max(work.abs());
            }
        }
    }
    out.dissipated = dissipated;
    out
}

/// Undamped, unforced backlash oscillator (clearance 2 µm, 3 µm initial deflection) through
/// the stiffness jumps: drive-side, back-side contacts and flights.
fn undamped(periods: usize, props: &[(Propagator, f64)]) {
    let clearance = 2.0e-6;
    let scene = tvms_scene(
        &format!("contact = \"backlash\"\nbacklash = {clearance:e}"),
        0.0,
        0.0,
        3.0e-6,
    );
    let e0 = 0.5 * k_low() * 9.0e-12;
    for &(prop, tol) in props {
        let sim_events = {
            let mut sim = simulation(&scene, prop, 1e-6);
            super::advance_in_pieces(&mut sim, periods as f64 * mesh_period());
            sim.stats().events
        };
        let b = balance(&scene, prop, periods, 8, (0.0, 0.0, Some(clearance)));
        println!(
            "{prop:?}, {periods} mesh periods, {sim_events} contact events: max |E − E0 − W_jumps|/E0 = {:.2e}, max |W_jumps|/E0 = {:.2e}",
            b.residual / e0,
            b.jump_work / e0
        );
        assert!(sim_events as usize >= periods, "contact changes expected");
        assert!(b.jump_work > 1e3 * tol * e0, "the jump work must matter");
        assert!(
            b.residual <= tol * e0,
            "{prop:?}: energy residual {:e} E0 > {tol:e} E0",
            b.residual / e0
        );
    }
}

/// Damped (ζ = 0.02), constantly loaded (F = 1000 N) bilateral contact from rest at x = 0:
/// a transient, then the parametrically forced periodic response. E0 = 0; the scale is the
/// static energy ½ k̄ δ_s².
fn damped_forced(periods: usize, props: &[(Propagator, f64)]) {
    let (zeta, torque) = (0.02, 50.0);
    let force = torque / 0.05;
    let scene = tvms_scene("contact = \"linear\"", zeta, torque, 0.0);
    let scale = 0.5 * force * force / K_MEAN;
    for &(prop, tol) in props {
        let b = balance(&scene, prop, periods, 64, (zeta, force, None));
        println!(
            "{prop:?}, {periods} mesh periods: max |E − E0 − W_jumps + D|/E_s = {:.2e}, max |W_jumps|/E_s = {:.2e}, D/E_s = {:.2e}",
            b.residual / scale,
            b.jump_work / scale,
            b.dissipated / scale
        );
        assert!(b.jump_work > 1e3 * tol * scale, "the jump work must matter");
        assert!(
            b.dissipated > 1e3 * tol * scale,
            "the dissipation must matter"
        );
        assert!(
            b.residual <= tol * scale,
            "{prop:?}: energy residual {:e} E_s > {tol:e} E_s",
            b.residual / scale
        );
    }
}

const EXACT: Propagator = Propagator::Exact;
const DOP853: Propagator = Propagator::Rk(Method::Dop853, 1e-10);
const DP5: Propagator = Propagator::Rk(Method::Dp5, 1e-10);

#[test]
fn undamped_backlash_energy_with_stiffness_jumps() {
    undamped(1000, &[(EXACT, 1e-11), (DOP853, 1e-6), (DP5, 1e-6)]);
}

#[test]
#[ignore = "long: 1e5 mesh periods (exact), 1e4 (RK); bash scripts/stress.sh"]
fn undamped_backlash_energy_with_stiffness_jumps_long() {
    undamped(100_000, &[(EXACT, 1e-9)]);
    undamped(10_000, &[(DOP853, 1e-5), (DP5, 1e-5)]);
}

#[test]
fn damped_forced_energy_with_stiffness_jumps() {
    damped_forced(200, &[(EXACT, 1e-6), (DOP853, 1e-6)]);
}

#[test]
#[ignore = "long: 1e4 mesh periods; bash scripts/stress.sh"]
fn damped_forced_energy_with_stiffness_jumps_long() {
    damped_forced(10_000, &[(EXACT, 1e-5), (DOP853, 1e-5), (DP5, 1e-5)]);
}
