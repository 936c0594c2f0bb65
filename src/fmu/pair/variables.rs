//! The gear model's variable table (FMI 2.0.x §2.2.7): value references, causality,
//! variability, start values from the scene, units and descriptions. The same table drives
//! the C ABI and the generated `modelDescription.xml`.

use crate::fmi::model::{VarKind, Variable};
use crate::fmu::table::{calculated, inputs, output, param, InputRows};
use crate::scene::{ContactLaw, InitialDte, PairScene};
use crate::simulation::Simulation;

// Value references: stable per meaning, grouped by causality (gaps leave room to grow).
pub const VR_PINION_INERTIA: u32 = 0;
pub const VR_GEAR_INERTIA: u32 = 1;
pub const VR_PINION_BASE_RADIUS: u32 = 2;
pub const VR_GEAR_BASE_RADIUS: u32 = 3;
pub const VR_DAMPING: u32 = 4;
pub const VR_BACKLASH: u32 = 5;
pub const VR_INITIAL_PHASE: u32 = 6;
pub const VR_INITIAL_DTE_RATE: u32 = 7;
pub const VR_INITIAL_DTE: u32 = 8;
pub const VR_INITIAL_STATIC: u32 = 9;
pub const VR_EQUIVALENT_MASS: u32 = 20;
pub const VR_MEAN_STIFFNESS: u32 = 21;
pub const VR_PINION_SPEED: u32 = 30;
pub const VR_INPUT_TORQUE: u32 = 31;
pub const VR_LOAD_TORQUE: u32 = 32;
/// Outputs in [`crate::model::OUTPUT_NAMES`] order: `VR_OUTPUT0 + i`.
pub const VR_OUTPUT0: u32 = 40;
pub const VR_CONTACT_STATE: u32 = VR_OUTPUT0 + 3;

/// The inputs (their value references are the kernel's `INPUTS`).
pub(super) const INPUTS: InputRows = InputRows {
    vrs: [VR_PINION_SPEED, VR_INPUT_TORQUE, VR_LOAD_TORQUE],
    speed: "operating.pinion_speed",
    descriptions: [
        "Nominal pinion speed; the mesh phase advances with it (z1*speed/2pi mesh cycles per second)",
        "Torque driving the pinion",
        "Load torque magnitude on the gear (positive resists the gear's rotation)",
    ],
};

/// (name, unit, description) of the outputs, in `OUTPUT_NAMES` order (`docs/model.md`).
const OUTPUTS: [(&str, Option<&str>, &str); 7] = [
    (
        "mesh.dte",
        Some("m"),
        "Dynamic transmission error x = r_b1*theta1 + r_b2*theta2 along the line of action",
    ),
    ("mesh.dte_rate", Some("m/s"), "Rate of the dynamic transmission error"),
    (
        "mesh.force",
        Some("N"),
        "Dynamic mesh force k(p)*delta + c_m*delta' in the current contact state (0 when separated)",
    ),
    (
        "mesh.contact_state",
        None,
        "Contact state: 1 drive side, 0 separated, -1 back side",
    ),
    ("mesh.phase", Some("cycle"), "Mesh phase frac(p), in mesh cycles"),
    ("mesh.stiffness", Some("N/m"), "Mesh stiffness k(p) of the current segment"),
    (
        "mesh.static_deflection",
        Some("m"),
        "Mean static deflection F_ext / mean stiffness under the current inputs",
    ),
];

/// The start value of `initial.dte`.
pub(super) fn initial_dte_start(scene: &PairScene) -> f64 {
    match scene.initial_dte {
        InitialDte::Value(x) => x,
        // Informational while `initial.static_dte` is true; show the value the scene's
        // operating point gives.
        InitialDte::Static => Simulation::new(scene).map_or(0.0, |s| s.state()[0]),
    }
}

/// The variable table of a scene (start values from the scene; `initial.dte` from
/// [`initial_dte_start`]).
pub(super) fn variables(scene: &PairScene, initial_dte: f64) -> Vec<Variable> {
    let mut v = vec![
        param(
            "pinion.inertia",
            VR_PINION_INERTIA,
            scene.pinion.inertia,
            Some("kg.m2"),
            "Polar mass moment of inertia of the pinion",
        ),
        param(
            "gear.inertia",
            VR_GEAR_INERTIA,
            scene.gear.inertia,
            Some("kg.m2"),
            "Polar mass moment of inertia of the gear",
        ),
        param(
            "pinion.base_radius",
            VR_PINION_BASE_RADIUS,
            scene.pinion.base_radius,
            Some("m"),
            "Base-circle radius of the pinion",
        ),
        param(
            "gear.base_radius",
            VR_GEAR_BASE_RADIUS,
            scene.gear.base_radius,
            Some("m"),
            "Base-circle radius of the gear",
        ),
        param(
            "mesh.damping",
            VR_DAMPING,
            scene.mesh.damping,
            Some("N.s/m"),
            "Viscous mesh damping c_m (a damping_ratio in the scene is resolved with the scene's inertias and not recomputed when they change)",
        ),
    ];
    if let ContactLaw::Backlash { clearance } = scene.mesh.contact {
        v.push(param(
            "mesh.backlash",
            VR_BACKLASH,
            clearance,
            Some("m"),
            "Total backlash (clearance 2b) along the line of action",
        ));
    }
    v.extend([
        param(
            "mesh.initial_phase",
            VR_INITIAL_PHASE,
            scene.mesh.initial_phase,
            Some("cycle"),
            "Mesh phase p0 at the start time, in mesh cycles",
        ),
        param(
            "initial.dte_rate",
            VR_INITIAL_DTE_RATE,
            scene.initial_dte_rate,
            Some("m/s"),
            "Initial rate of the dynamic transmission error",
        ),
        param(
            "initial.dte",
            VR_INITIAL_DTE,
            initial_dte,
            Some("m"),
            "Initial dynamic transmission error (used when initial.static_dte is false)",
        ),
        Variable {
            kind: VarKind::Boolean,
            unit: None,
            ..param(
                "initial.static_dte",
                VR_INITIAL_STATIC,
                f64::from(u8::from(scene.initial_dte == InitialDte::Static)),
                None,
                "true: the initial DTE is the mean static deflection under the inputs at initialization plus the STE at p0; false: initial.dte",
            )
        },
        calculated(
            "mesh.equivalent_mass",
            VR_EQUIVALENT_MASS,
            "kg",
            "Equivalent mass on the line of action 1/(r_b1^2/I1 + r_b2^2/I2)",
        ),
        calculated(
            "mesh.mean_stiffness",
            VR_MEAN_STIFFNESS,
            "N/m",
            "Mean mesh stiffness over one mesh period",
        ),
    ]);
    v.extend(inputs(&INPUTS, super::start_inputs(scene)));
    for (i, (name, unit, desc)) in OUTPUTS.iter().enumerate() {
        let vr = VR_OUTPUT0 + i as u32;
        let mut o = output(name, vr, *unit, desc, vr == VR_CONTACT_STATE);
        // Direct feedthrough (ModelStructure/Outputs, FMI 2.0.x §2.2.8): the STE rate in the
        // damping term scales with the speed; the static deflection is F_ext / k̄.
        o.depends_on = match *name {
            "mesh.force" => vec![VR_PINION_SPEED],
            "mesh.static_deflection" => vec![VR_INPUT_TORQUE, VR_LOAD_TORQUE],
            _ => Vec::new(),
        };
        v.push(o);
    }
    v
}
