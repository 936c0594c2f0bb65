//! The drivetrain model's variable table (FMI 2.0.x §2.2.7): value references, causality,
//! variability, start values from the scene, units and descriptions. The same table drives
//! the C ABI and the generated `modelDescription.xml`; the outputs are exactly
//! `TrainSimulation::output_names`, in that order, so FMU and `geardyn simulate` columns
//! have the same names.

use crate::fmi::model::Causality;
use crate::fmi::model::Variable;
use crate::fmu::table::{calculated, inputs, output, param, InputRows};
use crate::scene::train::{MeshForceModel, PairModel, PortEnd};
use crate::scene::Scene;

// Value references: stable per meaning, grouped by causality; per-gear and per-mesh blocks
// are 1000 wide (index = gear or mesh number in the scene).
pub const VR_MODAL_DAMPING: u32 = 0;
pub const VR_INITIAL_PHASE: u32 = 1;
pub const VR_INPUT_SPEED: u32 = 30;
pub const VR_INPUT_TORQUE: u32 = 31;
pub const VR_LOAD_TORQUE: u32 = 32;
/// Speed ports (`docs/ports.md`): the neighbour's angle and speed at the input and the output
/// gear.
pub const VR_INPUT_PORT_ANGLE: u32 = 33;
pub const VR_INPUT_PORT_SPEED: u32 = 34;
pub const VR_OUTPUT_PORT_ANGLE: u32 = 35;
pub const VR_OUTPUT_PORT_SPEED: u32 = 36;
pub const VR_GEAR_INERTIA0: u32 = 1000;
pub const VR_MESH_DAMPING0: u32 = 2000;
pub const VR_MEAN_STIFFNESS0: u32 = 3000;
/// Outputs in `TrainSimulation::output_names` order: `VR_OUTPUT0 + i`.
pub const VR_OUTPUT0: u32 = 10000;
/// Width of a per-gear or per-mesh block.
pub const BLOCK: usize = 1000;

/// The inputs (their value references are the kernel's `INPUTS`).
pub(super) const INPUTS: InputRows = InputRows {
    vrs: [VR_INPUT_SPEED, VR_INPUT_TORQUE, VR_LOAD_TORQUE],
    speed: "operating.input_speed",
    descriptions: [
        "Nominal speed of the input gear; every mesh phase advances with it by the train's kinematics",
        "Torque driving the input gear",
        "Load torque magnitude on the output gear (positive resists its rotation)",
    ],
};

/// The gear or mesh number of `vr` in the block starting at `base`, for `len` gears or meshes.
pub(super) fn block_index(vr: u32, base: u32, len: usize) -> Option<usize> {
    vr.checked_sub(base)
        .map(|i| i as usize)
        .filter(|&i| i < len.min(BLOCK))
}

/// Per-mesh output quantities: (suffix, unit, Integer?, description).
const MESH_OUTPUTS: [(&str, Option<&str>, bool, &str); 10] = [
    (
        "dte",
        Some("m"),
        false,
        "Dynamic transmission error (rotational part r_a*theta_a - r_b*theta_b along the line of action)",
    ),
    ("dte_rate", Some("m/s"), false, "Rate of the dynamic transmission error"),
    (
        "deflection",
        Some("m"),
        false,
        "Mesh deflection S = d'q (rotations and bearing translations along the line of action)",
    ),
    (
        "force",
        Some("N"),
        false,
        "Total dynamic mesh force (sum over the tooth pairs in contact plus mesh damping)",
    ),
    (
        "contact_state",
        None,
        true,
        "Contact state: 1 drive side, 0 total contact loss, -1 back side",
    ),
    (
        "pairs_in_contact",
        None,
        true,
        "Number of tooth pairs in contact",
    ),
    ("phase", Some("cycle"), false, "Mesh phase frac(p), in mesh cycles"),
    (
        "stiffness",
        Some("N/m"),
        false,
        "Mesh stiffness: sum over the engaged tooth pairs",
    ),
    (
        "contact_loss_fraction",
        Some("1"),
        false,
        "Fraction of the time since the (re)start with total contact loss",
    ),
    (
        "friction_force",
        Some("N"),
        false,
        "Tooth friction force on the pinion along the flanks' sliding direction (meshes with [mesh.friction])",
    ),
];

/// A gear as a description names it: "the pinion", "the gear" when its name is a gear noun,
/// else "gear g1", so that a gear named "gear" never reads "gear gear" (issue 32).
fn gear_named(name: &str) -> String {
    const NOUNS: [&str; 8] = [
        "gear", "pinion", "wheel", "idler", "sun", "ring", "planet", "carrier",
    ];
    if NOUNS.contains(&name) {
        format!("the {name}")
    } else {
        format!("gear {name}")
    }
}

/// Unit, kind and description of output `name` (one of `output_names`), or an error naming
/// it when the table does not know it (a new output must be described here before it ships).
fn describe_output(
    scene: &Scene,
    name: &str,
) -> Result<(Option<&'static str>, bool, String), String> {
    for m in &scene.meshes {
        let Some(q) = name
            .strip_prefix(m.name.as_str())
            .and_then(|r| r.strip_prefix('.'))
        else {
            continue;
        };
        if let Some((_, unit, int, desc)) = MESH_OUTPUTS.iter().find(|o| o.0 == q) {
            return Ok((*unit, *int, format!("{}: {desc}", m.name)));
        }
        if let Some(j) = q
            .strip_prefix("pair")
            .and_then(|r| r.strip_suffix(".force"))
        {
            return Ok((
                Some("N"),
                false,
                format!(
                    "{}: force of tooth-pair slot {j} (Model-1, 0 when not in contact)",
                    m.name
                ),
            ));
        }
    }
    for g in &scene.gears {
        // A planet's translations on its carrier pin (docs/planetary.md, eq. P3).
        for (axis, what) in [("radial", "Radial"), ("tangential", "Tangential")] {
            if name == format!("{}.{axis}", g.name) {
                return Ok((
                    Some("m"),
                    false,
                    format!(
                        "{what} translation of planet {} in its carrier's frame (tangential \
                         in the stage's sense)",
                        gear_named(&g.name)
                    ),
                ));
            }
        }
        for axis in ["x", "y"] {
            if name == format!("{}.{axis}", g.name) {
                return Ok((
                    Some("m"),
                    false,
                    format!(
                        "Bearing translation {axis} of {} (scene frame)",
                        gear_named(&g.name)
                    ),
                ));
            }
        }
    }
    for (q, unit, what) in [
        ("angle", "rad", "Angle"),
        ("speed", "rad/s", "Speed"),
        ("acceleration", "rad/s2", "Angular acceleration"),
    ] {
        for g in &scene.gears {
            if name == format!("{}.{q}", g.name) {
                return Ok((
                    Some(unit),
                    false,
                    format!(
                        "{what} of the body of {} (positive in its nominal rotation sense; \
                         the angle from the pinion at 0 at the start)",
                        gear_named(&g.name)
                    ),
                ));
            }
        }
        for p in scene.ports.iter().filter(|p| p.coupling.is_none()) {
            if name == format!("{}.{q}", p.name) {
                return Ok((
                    Some(unit),
                    false,
                    format!(
                        "Port {}: {} of the shaft of {} (positive in its nominal rotation \
                         sense)",
                        p.name,
                        what.to_lowercase(),
                        gear_named(&scene.gears[p.gear].name)
                    ),
                ));
            }
        }
    }
    for p in scene.ports.iter().filter(|p| p.coupling.is_some()) {
        if name == format!("{}.torque", p.name) {
            return Ok((
                Some("N.m"),
                false,
                format!(
                    "Port {} (speed causality, on {}): torque the gear stage applies TO its \
                     neighbour through the coupling, -(k (angle - theta) + c (speed - omega)), \
                     positive along the gear's nominal rotation (connect it to the neighbour's \
                     flange.torque)",
                    p.name,
                    gear_named(&scene.gears[p.gear].name)
                ),
            ));
        }
    }
    Err(format!(
        "output '{name}' has no description in the FMU variable table"
    ))
}

/// The variable table of a scene (start values from the scene) for the simulation's outputs.
pub(super) fn variables(scene: &Scene, outputs: &[String]) -> Result<Vec<Variable>, String> {
    if scene.gears.len() > BLOCK || scene.meshes.len() > BLOCK {
        return Err(format!(
            "{} gears and {} meshes: the FMU variable table holds at most {BLOCK} of each",
            scene.gears.len(),
            scene.meshes.len()
        ));
    }
    let mut v = vec![
        param(
            "model.modal_damping_ratio",
            VR_MODAL_DAMPING,
            scene.modal_damping_ratio,
            None,
            "Modal damping ratio on the mean-stiffness modes",
        ),
        param(
            &format!("{}.initial_phase", scene.meshes[0].name),
            VR_INITIAL_PHASE,
            scene.meshes[0].initial_phase,
            Some("cycle"),
            "Mesh phase of the first mesh at the start time; the other meshes follow with their phasing",
        ),
    ];
    for (g, gear) in scene.gears.iter().enumerate() {
        v.push(param(
            &format!("{}.inertia", gear.name),
            VR_GEAR_INERTIA0 + g as u32,
            gear.inertia,
            Some("kg.m2"),
            &format!("Polar mass moment of inertia of {}", gear_named(&gear.name)),
        ));
    }
    for (n, mesh) in scene.meshes.iter().enumerate() {
        v.push(param(
            &format!("{}.damping", mesh.name),
            VR_MESH_DAMPING0 + n as u32,
            mesh.damping,
            Some("N.s/m"),
            "Viscous mesh damping (a damping_ratio in the scene is resolved with the scene's inertias and not recomputed when they change)",
        ));
    }
    for (n, mesh) in scene.meshes.iter().enumerate() {
        v.push(calculated(
            &format!("{}.mean_stiffness", mesh.name),
            VR_MEAN_STIFFNESS0 + n as u32,
            "N/m",
            "Mean mesh stiffness over one mesh period",
        ));
    }
    let start = super::start_inputs(scene);
    let mut rows = inputs(&INPUTS, [start[0], start[1], start[2]]);
    if !scene.ports.is_empty() {
        port_inputs(scene, &mut rows);
    }
    // A speed port's torque is an output: its torque input does not exist.
    let [speed, input, load] = rows;
    let torque_input = |end| !(scene.ports.iter()).any(|p| p.end == end && p.coupling.is_some());
    v.push(speed);
    v.extend(torque_input(PortEnd::Input).then_some(input));
    v.extend(torque_input(PortEnd::Output).then_some(load));
    let port_rows = speed_port_inputs(scene, &start);
    let direct: Vec<u32> = (v.iter().chain(&port_rows))
        .filter(|x| x.causality == Causality::Input && x.value_reference != VR_INPUT_SPEED)
        .map(|x| x.value_reference)
        .collect();
    v.extend(port_rows);
    for (i, name) in outputs.iter().enumerate() {
        let (unit, integer, desc) = describe_output(scene, name)?;
        let mut o = output(name, VR_OUTPUT0 + i as u32, unit, &desc, integer);
        // Direct feedthrough (ModelStructure/Outputs, FMI 2.0.x §2.2.8): the damping term of
        // a mesh force holds the rate of the STE, which scales with the speed; a Model-2
        // mesh's excitation is the loaded STE at the static load of the torques.
        if !scene.ports.is_empty() {
            // Carried rotation: the accelerations follow the port torques at once, and with
            // speed ports the couplings' torques, which read the neighbours' angles and speeds
            // (stiffness and damping); nothing else reads an input directly (the phase rate is
            // a state).
            if name.ends_with("acceleration") {
                o.depends_on.clone_from(&direct);
            }
            if let Some(p) = (scene.ports.iter())
                .find(|p| p.coupling.is_some() && *name == format!("{}.torque", p.name))
            {
                let base = match p.end {
                    PortEnd::Input => VR_INPUT_PORT_ANGLE,
                    PortEnd::Output => VR_OUTPUT_PORT_ANGLE,
                };
                o.depends_on = vec![base, base + 1];
            }
        } else if let Some(mesh) = scene
            .meshes
            .iter()
            .find(|m| *name == format!("{}.force", m.name))
        {
            o.depends_on = vec![VR_INPUT_SPEED];
            if matches!(
                mesh.force,
                MeshForceModel::Pairs {
                    model: PairModel::LoadedSte,
                    ..
                }
            ) {
                o.depends_on.extend([VR_INPUT_TORQUE, VR_LOAD_TORQUE]);
            }
        }
        v.push(o);
    }
    Ok(v)
}

/// The inputs of the speed ports (`docs/ports.md`): the neighbour's angle and speed, start
/// values from `start` (the `INPUTS` order of the kernel).
fn speed_port_inputs(scene: &Scene, start: &[f64]) -> Vec<Variable> {
    let mut rows = Vec::new();
    for p in scene.ports.iter().filter(|p| p.coupling.is_some()) {
        let (vr, end) = match p.end {
            PortEnd::Input => (VR_INPUT_PORT_ANGLE, "input"),
            PortEnd::Output => (VR_OUTPUT_PORT_ANGLE, "output"),
        };
        let k = (vr - VR_INPUT_PORT_ANGLE) as usize;
        let gear = gear_named(&scene.gears[p.gear].name);
        rows.push(crate::fmu::table::input(
            &format!("{}.angle", p.name),
            vr,
            start[3 + k],
            "rad",
            &format!(
                "Port {} ({end} shaft of {gear}, speed causality): angle of the neighbour's \
                 flange, positive along the gear's nominal rotation; between communication \
                 points it follows the speed unless given a rate",
                p.name
            ),
        ));
        rows.push(crate::fmu::table::input(
            &format!("{}.speed", p.name),
            vr + 1,
            start[4 + k],
            "rad/s",
            &format!(
                "Port {} ({end} shaft of {gear}, speed causality): speed of the neighbour's \
                 flange, positive along the gear's nominal rotation",
                p.name
            ),
        ));
    }
    rows
}

/// With torque ports (`docs/ports.md`) the torque inputs are the ports' `<port>.torque` (the
/// neighbour's torque on the shaft, positive along the gear's nominal rotation; value
/// references unchanged) and the speed is the start speed of the carried rotation, a
/// parameter fixed at initialization.
fn port_inputs(scene: &Scene, rows: &mut [Variable; 3]) {
    use crate::fmi::model::{Initial, Variability};
    let speed = &mut rows[0];
    speed.causality = Causality::Parameter;
    speed.variability = Variability::Fixed;
    speed.initial = Some(Initial::Exact);
    speed.description = "Speed of the input gear at the start time; every body starts at its \
                         nominal speed, and the carried angles are counted from this reference \
                         rotation"
        .into();
    for p in scene.ports.iter().filter(|p| p.coupling.is_none()) {
        let (row, end) = match p.end {
            PortEnd::Input => (&mut rows[1], "input"),
            PortEnd::Output => (&mut rows[2], "output"),
        };
        row.name = format!("{}.torque", p.name);
        row.description = format!(
            "Port {} ({end} shaft of {}): torque applied to the gear stage by its neighbour, \
             positive along the gear's nominal rotation",
            p.name,
            gear_named(&scene.gears[p.gear].name)
        );
    }
}
