//! Issue 32 acceptance 2: the gear-stage FMUs take `fmi2SetRealInputDerivatives` of orders
//! 1–3 on every continuous input (`docs/cosimulation.md`, "Cubic inputs into the gear
//! stages"), through the same factory `fmi2Instantiate` uses.
//!
//! Oracle for the torque ports: the stage's angular momentum balance. The mesh force acts on
//! both gears with opposite moments about their base radii, so with the speeds positive in
//! each gear's own sense `J₁ω₁' = T_in − F r₁`, `J₂ω₂' = T_out + F r₂` and
//! `L = J₁ω₁/r₁ + J₂ω₂/r₂` changes by `∫ (T_in/r₁ + T_out/r₂) dt` whatever the mesh does
//! (contact, backlash, damping): under the cubic inputs a closed-form quartic. It holds on
//! the exact propagator (the stage without its STE harmonic) and on DOP853 (the shipped stage).
//!
//! Speed ports: the neighbour's angle and speed follow their cubics (a held angle the
//! integral of the speed's cubic, a quintic in closed form) and the step is the same as two
//! half steps whose second half is given the same cubic re-expanded about the midpoint.

mod common;

use common::fmu::{initialized, vr};
use geardyn::fmi::model::{CoSimModel, LoadedModel};

fn read(path: &str) -> String {
    std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(path)).unwrap()
}

/// Loads a scene from text (in a temporary folder) and initializes it at `t = 0`.
fn model(text: &str) -> LoadedModel {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, text).unwrap();
    initialized(&path)
}

fn get(m: &dyn CoSimModel, name: &str) -> f64 {
    m.get_real(vr(m, name)).unwrap()
}

/// `u + u'h + u''h²/2 + u'''h³/6` and its integral over `[0, h]`.
fn cubic(d: [f64; 4], h: f64) -> (f64, f64) {
    let [u0, u1, u2, u3] = d;
    let value = u0 + u1 * h + u2 * h * h / 2.0 + u3 * h.powi(3) / 6.0;
    let integral = u0 * h + u1 * h * h / 2.0 + u2 * h.powi(3) / 6.0 + u3 * h.powi(4) / 24.0;
    (value, integral)
}

const R1: f64 = 0.04535;
const R2: f64 = 0.06563815789473684;
const J1: f64 = 0.002621;
const J2: f64 = 0.01091;

fn momentum(m: &dyn CoSimModel) -> f64 {
    J1 * get(m, "input.speed") / R1 + J2 * get(m, "output.speed") / R2
}

/// Sets the derivatives `d[1..]` of every named input.
fn set_derivatives(m: &mut dyn CoSimModel, inputs: &[(&str, [f64; 4])]) {
    for (name, d) in inputs {
        let r = vr(m, name);
        for order in 1..=3 {
            m.set_input_derivative(r, order, d[order as usize]).unwrap();
        }
    }
}

/// One step of 5e-4 s (the 4500-rpm grid step of `docs/cosimulation.md`) under cubic port
/// torques: the momentum balance to rounding, the inputs at the cubic's end, an FMU state
/// with the derivatives redoing the step bit for bit, the next step held, order 4 refused.
fn torque_cubic(text: &str, method: &str, tolerance: f64) {
    let h = 5e-4;
    let t_in = [100.0, 2e5, -4e8, 1e12];
    let t_out = [-144.73684210526315, -1.5e5, 6e8, -2e12];
    let mut loaded = model(text);
    let m = loaded.model.as_mut();
    assert_eq!(m.capabilities().max_input_derivative_order, 3);
    let l0 = momentum(m);
    set_derivatives(m, &[("input.torque", t_in), ("output.torque", t_out)]);
    assert!(m
        .set_input_derivative(vr(m, "input.torque"), 4, 1.0)
        .is_err());
    let saved = m.save_state();
    m.do_step(0.0, h).unwrap();
    let ((in_end, in_int), (out_end, out_int)) = (cubic(t_in, h), cubic(t_out, h));
    let expected = in_int / R1 + out_int / R2;
    // What orders 2 and 3 add to the momentum: the balance must resolve them.
    let higher = (cubic([0.0, 0.0, t_in[2], t_in[3]], h).1 / R1
        + cubic([0.0, 0.0, t_out[2], t_out[3]], h).1 / R2)
        .abs();
    let err = (momentum(m) - l0 - expected).abs();
    println!(
        "{method}: momentum change {:.6e}, error {err:.2e} ({:.2e} of the orders 2–3 part {higher:.3e})",
        momentum(m) - l0,
        err / higher
    );
    assert!(err <= tolerance * higher, "{err:e} vs {higher:e}");
    assert!((get(m, "input.torque") - in_end).abs() <= 1e-12 * in_end.abs());
    assert!((get(m, "output.torque") - out_end).abs() <= 1e-12 * out_end.abs());
    let first = (get(m, "input.speed"), get(m, "mesh1.dte"));
    m.load_state(&saved).unwrap();
    m.do_step(0.0, h).unwrap();
    assert_eq!((get(m, "input.speed"), get(m, "mesh1.dte")), first);
    // The next step holds the inputs at the cubic's end: the derivatives were for one step.
    let l1 = momentum(m);
    m.do_step(h, h).unwrap();
    let held = (in_end / R1 + out_end / R2) * h;
    assert!((momentum(m) - l1 - held).abs() <= tolerance * higher);
}

#[test]
fn torque_ports_take_a_cubic_exactly() {
    // Without the STE harmonic (a function of the carried angle) the stage runs exact, the
    // cubic on the lifted chain τ, τ²/2, τ³/6.
    let no_ste = read("fmu/spur_stage/scene.toml").replace("[mesh.ste]\ncos = [1.0e-6]\n", "");
    assert!(no_ste.len() < read("fmu/spur_stage/scene.toml").len());
    torque_cubic(&no_ste, "exact", 1e-9);
}

#[test]
fn torque_ports_take_a_cubic_on_rk() {
    torque_cubic(&read("fmu/spur_stage/scene.toml"), "dop853", 1e-6);
}

/// The speed ports: a held angle integrates the speed's cubic (the input reads the quartic
/// after the step), and one step under cubic angle and speed inputs equals two half steps
/// with the cubic re-expanded about the midpoint (same forcing; a wrong coefficient or
/// anchor would split them).
#[test]
fn speed_ports_take_a_cubic() {
    let text = read("fmu/spur_stage_speed/scene.toml");
    let h = 5e-4;
    // The neighbour of the input port: angle a, speed w; of the output port: its speed only.
    let mut loaded = model(&text);
    let m = loaded.model.as_mut();
    assert_eq!(m.capabilities().max_input_derivative_order, 3);
    let (a0, w0, v0) = (
        get(m, "input.angle"),
        get(m, "input.speed"),
        get(m, "output.speed"),
    );
    let w = [w0, 3e3, -2e7, 8e10];
    let a = [a0, w0, w[1], w[2]];
    let v = [v0, -1e3, 1e7, -5e10];
    let mut two = model(&text);
    let m2 = two.model.as_mut();
    set_derivatives(
        m,
        &[("input.angle", a), ("input.speed", w), ("output.speed", v)],
    );
    m.do_step(0.0, h).unwrap();
    // Held output angle: φ0 + ∫ of the speed's cubic.
    let phi0 = get(m2, "output.angle");
    let phi_end = phi0 + cubic(v, h).1;
    assert!(
        (get(m, "output.angle") - phi_end).abs() <= 1e-14 * phi_end.abs().max(1.0),
        "{} {phi_end}",
        get(m, "output.angle")
    );
    assert!((get(m, "input.speed") - cubic(w, h).0).abs() <= 1e-12 * w0);
    // Two half steps: the Taylor coefficients of the same cubics about h/2.
    let about = |d: [f64; 4], s: f64| -> [f64; 4] {
        [
            cubic(d, s).0,
            d[1] + d[2] * s + d[3] * s * s / 2.0,
            d[2] + d[3] * s,
            d[3],
        ]
    };
    set_derivatives(
        m2,
        &[("input.angle", a), ("input.speed", w), ("output.speed", v)],
    );
    m2.do_step(0.0, h / 2.0).unwrap();
    let mid = [about(a, h / 2.0), about(w, h / 2.0), about(v, h / 2.0)];
    for (name, d) in ["input.angle", "input.speed", "output.speed"]
        .iter()
        .zip(&mid)
    {
        let r = vr(m2, name);
        m2.set_real(r, d[0]).unwrap();
    }
    set_derivatives(
        m2,
        &[
            ("input.angle", mid[0]),
            ("input.speed", mid[1]),
            ("output.speed", mid[2]),
        ],
    );
    m2.do_step(h / 2.0, h / 2.0).unwrap();
    for out in ["input.torque", "output.torque"] {
        let (one, halves) = (get(m, out), get(m2, out));
        println!("{out}: one step {one:.12e}, two halves {halves:.12e}");
        assert!(
            (one - halves).abs() <= 1e-7 * one.abs(),
            "{out}: {one} {halves}"
        );
    }
    // And the cubic matters: the same step with the ramps alone ends elsewhere.
    let mut ramp = model(&text);
    let m3 = ramp.model.as_mut();
    for (name, d) in [("input.angle", a), ("input.speed", w), ("output.speed", v)] {
        let r = vr(m3, name);
        m3.set_input_derivative(r, 1, d[1]).unwrap();
    }
    m3.do_step(0.0, h).unwrap();
    let moved = (get(m3, "input.torque") - get(m, "input.torque")).abs();
    assert!(
        moved > 1e-3 * get(m, "input.torque").abs(),
        "orders 2–3 move the torque by {moved:e}"
    );
}
