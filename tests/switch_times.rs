//! The switch times a gear FMU announces (`solver.next_switch_time`, the vendor annotation
//! `<SwitchTimes>`; `docs/cosimulation.md`, "Steps that end at the stage's knots"), which
//! geardyn's error-controlled master ends its steps at.
//!
//! Oracle: the engine's own event location. A stage that rotates carries its stiffness knots
//! as state events on the pinion angle, located by the integrator's root finding; the
//! announced time is a quadratic Taylor prediction from the state. A step that ends the
//! master's margin ([`SWITCH_MARGIN`] of its step) short of the prediction must leave the
//! stage before the knot (it still announces the same one, to the margin), a step that ends
//! the margin past it must have crossed it (it announces the next knot, about half a mesh
//! period on). The prediction is off by up to ~1e-4 of the time to the knot here (a margin of
//! 3e-5 of it fails), a tenth of the margin.

mod common;

use common::fmu::{initialized, vr};
use geardyn::fmi::model::{CoSimModel, LoadedModel};
use geardyn::fmu::adapter::NEXT_SWITCH_TIME;
use geardyn::host::system::controlled::SWITCH_MARGIN;

fn loaded(name: &str) -> LoadedModel {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    initialized(&root.join("fmu").join(name).join("scene.toml"))
}

/// The stage's mesh period at its shipped speed (38 pinion teeth).
fn mesh_period(m: &dyn CoSimModel) -> f64 {
    let speed = m.get_real(vr(m, "operating.input_speed")).unwrap();
    std::f64::consts::TAU / (38.0 * speed)
}

/// Over ten mesh periods on the grid T_mesh/20: every knot is announced from the grid point
/// before it, and the engine crosses it within the master's margin of the announced time.
fn knots_are_where_announced(name: &str) {
    let mut loaded = loaded(name);
    let m = loaded.model.as_mut();
    let switch = vr(m, NEXT_SWITCH_TIME);
    let period = mesh_period(m);
    let h = period / 20.0;
    let (mut t, mut checked) = (0.0, 0);
    while t < 10.0 * period {
        let predicted = m.get_real(switch).unwrap();
        assert!(
            predicted > t,
            "{name}: switch {predicted} not after t = {t}"
        );
        if predicted >= t + h {
            m.do_step(t, h).unwrap();
            t += h;
            continue;
        }
        let margin = SWITCH_MARGIN * h;
        let state = m.save_state();
        // Short of it: still before the knot, which is announced where it was.
        m.do_step(t, predicted - margin - t).unwrap();
        let again = m.get_real(switch).unwrap();
        assert!(
            (again - predicted).abs() <= margin,
            "{name}: from t = {t}, announced {predicted}; {margin:e} s before it, {again}"
        );
        // Past it: the knot is crossed and the next one announced.
        m.load_state(&state).unwrap();
        let end = predicted + margin;
        m.do_step(t, end - t).unwrap();
        let next = m.get_real(switch).unwrap();
        assert!(
            next - end > 0.2 * period,
            "{name}: from t = {t}, announced {predicted}; {margin:e} s past it, {next}"
        );
        t = end;
        checked += 1;
    }
    // Two knots per mesh period (the rectangular stiffness).
    assert!(checked >= 19, "{name}: {checked} knots checked");
}

#[test]
fn the_torque_port_stage_crosses_its_knots_where_it_announces_them() {
    knots_are_where_announced("spur_stage");
}

#[test]
fn the_speed_port_stage_crosses_its_knots_where_it_announces_them() {
    knots_are_where_announced("spur_stage_speed");
}

/// The announcement in the model description is what the host reads: the variable's name in
/// `<SwitchTimes>`, resolved to its value reference; an element FMU (smooth) has none.
#[test]
fn the_description_announces_the_variable_and_the_host_resolves_it() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    for (name, announced) in [("spur_stage", true), ("spur_pair", true), ("emotor", false)] {
        let xml =
            std::fs::read_to_string(root.join(format!("modelDescription/{name}.xml"))).unwrap();
        let md = geardyn::host::description::parse(&xml, name).unwrap();
        let cs = md.co_simulation.unwrap();
        if announced {
            let vr = cs.switch_time.expect("announced");
            let v = md
                .variables
                .iter()
                .find(|v| v.value_reference == vr)
                .unwrap();
            assert_eq!(v.name, NEXT_SWITCH_TIME, "{name}");
        } else {
            assert_eq!(cs.switch_time, None, "{name}");
        }
    }
    // A name that is not a variable of the model is refused, naming it.
    let xml = std::fs::read_to_string(root.join("modelDescription/spur_stage.xml")).unwrap();
    let bad = xml.replace(
        &format!("<SwitchTimes variable=\"{NEXT_SWITCH_TIME}\"/>"),
        "<SwitchTimes variable=\"no.such\"/>",
    );
    assert_ne!(bad, xml);
    let err = geardyn::host::description::parse(&bad, "bad").unwrap_err();
    assert!(err.contains("no.such"), "{err}");
}
