//! Which kernel runs a scene: the one place that decides it.
//!
//! Every scene file is read by one description ([`super::spec`]). The single-pair kernel
//! ([`crate::model::GearPair`], the DTE coordinate of `docs/model.md`) runs a scene that has
//! one mesh between two gears and uses only what that kernel implements; every other scene
//! runs on the drivetrain kernel (`docs/train.md`). Both give the same physics where they
//! overlap (`tests/pair_as_drivetrain.rs`); the pair kernel is the fast path and the only one
//! with the smooth terms of Bugaru (2006) (`cubic`, `damping_variation`, `damping_acts`,
//! `torque_ripple`).

use super::spec::{GearSpec, MeshForm, ParsedScene, SceneSpec};

/// The kernel chosen for a scene, and why.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum KernelChoice {
    /// The single-pair kernel.
    Pair,
    /// The drivetrain kernel; the reason names the first field that needs it.
    Drivetrain(String),
}

impl KernelChoice {
    /// One line for `--verbose`.
    pub fn describe(&self) -> String {
        match self {
            KernelChoice::Pair => {
                "kernel: single pair (one mesh between two gears, pair-kernel features only)".into()
            }
            KernelChoice::Drivetrain(why) => format!("kernel: drivetrain ({why})"),
        }
    }
}

/// The kernel of a parsed scene. A scene that asks for a pair-kernel term while something
/// else in it needs the drivetrain kernel is refused by the drivetrain validation, which
/// names the term ([`pair_only_field`]).
pub fn choose(parsed: &ParsedScene) -> KernelChoice {
    match drivetrain_reason(parsed) {
        None => KernelChoice::Pair,
        Some(why) => KernelChoice::Drivetrain(why),
    }
}

/// The first thing in the scene that only the drivetrain kernel carries.
fn drivetrain_reason(parsed: &ParsedScene) -> Option<String> {
    let spec = &parsed.spec;
    if parsed.form == MeshForm::Many {
        return Some("the meshes are a [[mesh]] array".into());
    }
    let tables: [(&str, bool); 6] = [
        ("[model]", spec.model.is_some()),
        ("[[shaft]]", !spec.shaft.is_empty()),
        ("[[port]]", !spec.port.is_empty()),
        ("[[motor]]", !spec.motor.is_empty()),
        ("[[load]]", !spec.load.is_empty()),
        ("[[inertia]]", !spec.inertia.is_empty()),
    ];
    if let Some((table, _)) = tables.iter().find(|(_, given)| *given) {
        return Some(format!("it has {table}"));
    }
    for (i, g) in spec.gear.iter().enumerate() {
        if let Some(key) = drivetrain_gear_key(g) {
            return Some(format!("gear[{i}].{key}"));
        }
    }
    if spec.gear.len() != 2 {
        // The pair validation names the count; nothing here needs the drivetrain.
        return None;
    }
    let op = &spec.operating;
    if op.input_gear.is_some() {
        return Some("operating.input_gear".into());
    }
    if op.output_gear.is_some() {
        return Some("operating.output_gear".into());
    }
    let m = spec.mesh.first()?;
    let keys: [(&str, bool); 9] = [
        ("name", m.name.is_some()),
        ("phase", m.phase.is_some()),
        ("pressure_angle", m.pressure_angle.is_some()),
        ("centre_angle", m.centre_angle.is_some()),
        ("model", m.model.is_some()),
        ("pairs", m.pairs.is_some()),
        ("tip_relief", m.tip_relief.is_some()),
        ("gaps", m.gaps.is_some()),
        ("friction", m.friction.is_some()),
    ];
    keys.iter()
        .find(|(_, given)| *given)
        .map(|(key, _)| format!("mesh.{key}"))
}

/// A gear field only the drivetrain kernel carries: bearings, masses, ground couplings and
/// manufacturing errors that are not all zero (`docs/errors.md`; all-zero errors leave the
/// scene on the pair kernel, bit for bit unchanged).
fn drivetrain_gear_key(g: &GearSpec) -> Option<&'static str> {
    let nonzero = |v: &Option<Vec<f64>>| v.as_ref().is_some_and(|v| v.iter().any(|&x| x != 0.0));
    if g.runout.as_ref().is_some_and(|r| r.amplitude != 0.0) {
        Some("runout")
    } else if nonzero(&g.pitch_errors) {
        Some("pitch_errors")
    } else if nonzero(&g.cumulative_pitch_errors) {
        Some("cumulative_pitch_errors")
    } else if g.mass.is_some() {
        Some("mass")
    } else if g.bearing_stiffness.is_some() {
        Some("bearing_stiffness")
    } else if g.bearing_damping.is_some() {
        Some("bearing_damping")
    } else if g.ground_stiffness != 0.0 {
        Some("ground_stiffness")
    } else if g.ground_damping != 0.0 {
        Some("ground_damping")
    } else {
        None
    }
}

/// The first field, as the file wrote it, that only the pair kernel implements.
pub(crate) fn pair_only_field(parsed: &ParsedScene) -> Option<String> {
    let spec: &SceneSpec = &parsed.spec;
    if spec.operating.torque_ripple.is_some() {
        return Some("operating.torque_ripple".into());
    }
    spec.mesh.iter().enumerate().find_map(|(i, m)| {
        let key = if m.cubic.is_some() {
            "cubic"
        } else if m.damping_variation.is_some() {
            "damping_variation"
        } else if m.damping_acts.is_some() {
            "damping_acts"
        } else {
            return None;
        };
        Some(parsed.mesh_field(i, key))
    })
}
