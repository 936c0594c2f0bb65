//! Validation of a scene, whichever kernel runs it: ranges, topology, kinematics and every
//! mesh option, into the one resolved [`Scene`]. A single-mesh file goes through the same
//! functions as a train ([`validate`] for the scene, [`mesh`] for each mesh); what only one
//! kernel carries is checked where it is read, on the kernel's choice ([`super::super::kernel`]).
//! Every message names the field as the file wrote it (`mesh.damping` for `[mesh]`,
//! `mesh[1].damping` for `[[mesh]]`) and its value; nothing is clamped.

use std::collections::VecDeque;

use super::checks::{bounded, err, finite, initial_dte, solver, valid_identifier as identifier};
use crate::mesh::PhaseSeries;
use crate::scene::kernel::{choose, pair_only_field};
use crate::scene::spec::{
    mesh_field, mesh_table, MeshForm, MeshSpec as TrainMeshSpec, PairStiffnessSpec, ParsedScene,
    ShaftSpec,
};
use crate::scene::train::{
    Bearing, GapFunction, GapTable, HelicalPair, MeshForceModel, PairGap, PairModel, PairStiffness,
    PlanetaryStage, Shaft, ShaftCoupling, TipRelief,
};
use crate::scene::{
    ContactLaw, Gear, KernelChoice, Mesh, MethodChoice, Operating, Scene, SceneError, SmoothTerms,
};

type Result<T> = std::result::Result<T, SceneError>;

/// Relative tolerance of the kinematic consistency checks (speed ratios around loops).
const KINEMATIC_TOL: f64 = 1e-9;
/// Largest relative difference of the base pitches `2π r_b/z` of two meshing gears.
const BASE_PITCH_TOL: f64 = 0.01;

/// Validates a scene of any form into the resolved scene, with the kernel
/// [`crate::scene::kernel::choose`] picks for it recorded.
pub(crate) fn validate(parsed: ParsedScene, source: &str) -> Result<Scene> {
    let kernel = choose(&parsed);
    let on_pair = kernel == KernelChoice::Pair;
    if let (false, Some(field)) = (on_pair, pair_only_field(&parsed)) {
        return err(format!(
            "{field}: a term of the single-pair kernel (Bugaru 2006), which runs a scene with one \
             mesh between two gears and no drivetrain feature; the drivetrain kernel does not \
             carry it"
        ));
    }
    let form = parsed.form;
    // The input speed's key as the file wrote it; unwritten, as each kernel's docs name it.
    let speed_field = format!(
        "operating.{}",
        parsed.speed_key.unwrap_or(if on_pair {
            "pinion_speed"
        } else {
            "input_speed"
        })
    );
    let spec = parsed.spec;
    let model = spec.model.clone().unwrap_or_default();
    if !identifier(&spec.name) {
        return err(format!(
            "name = {:?}: must be an identifier ([A-Za-z_][A-Za-z0-9_]*), it names the FMU",
            spec.name
        ));
    }
    let compliant = match model.bearings.as_str() {
        "compliant" => true,
        "rigid" => false,
        other => {
            return err(format!(
                "model.bearings = {other:?}: must be \"compliant\" or \"rigid\""
            ))
        }
    };
    let input_sense = match model.input_rotation.as_str() {
        "ccw" => 1.0,
        "cw" => -1.0,
        other => {
            return err(format!(
                "model.input_rotation = {other:?}: must be \"ccw\" or \"cw\""
            ))
        }
    };
    let modal = bounded("model.modal_damping_ratio", model.modal_damping_ratio)?;

    if on_pair && spec.gear.len() != 2 {
        return err(format!(
            "gear: {} [[gear]] tables given; a single-mesh scene needs exactly 2",
            spec.gear.len()
        ));
    }
    if spec.gear.is_empty() {
        return err("gear: no [[gear]] given; a train needs at least 2".into());
    }
    let mesh_specs = spec.mesh;
    // Geometry meshes define the bodies of their gears (docs/train.md, "Gears and geometry
    // meshes"); the first geometry mesh naming a gear defines it, later ones are checked
    // against its base radius.
    let mut bodies: Vec<(String, super::geometry::GearBody)> = Vec::new();
    for (i, m) in mesh_specs.iter().enumerate() {
        let Some(stiffness) = &m.stiffness else {
            continue;
        };
        if let Some([p, g]) = super::geometry::bodies(stiffness, &mesh_field(form, i, "stiffness"))?
        {
            for (name, body) in [(&m.pinion, p), (&m.gear, g)] {
                if !bodies.iter().any(|(n, _)| n == name) {
                    bodies.push((name.clone(), body));
                }
            }
        }
    }
    let mut gears = Vec::with_capacity(spec.gear.len());
    for (i, g) in spec.gear.iter().enumerate() {
        let f = |name: &str| format!("gear[{i}].{name}");
        if !identifier(&g.name) {
            return err(format!(
                "{} = {:?}: must be an identifier (it names output columns)",
                f("name"),
                g.name
            ));
        }
        if let Some(j) = spec.gear[..i].iter().position(|o| o.name == g.name) {
            return err(format!(
                "{} = {:?}: duplicates gear[{j}].name",
                f("name"),
                g.name
            ));
        }
        let teeth = super::checks::teeth(&f("teeth"), g.teeth)?;
        let table = format!("gear[{i}]");
        let derived = bodies.iter().find(|(n, _)| *n == g.name).map(|(_, b)| b);
        let mass = match (g.mass, derived) {
            (Some(m), _) => Some(bounded(&f("mass"), m)?),
            // A derived mass only where the translations need one.
            (None, Some(d)) if compliant && g.bearing_stiffness.is_some() => Some(
                super::geometry::body_value(&table, "mass", None, Some((d, d.mass)))?,
            ),
            (None, _) => None,
        };
        let bearing = match (g.bearing_stiffness, compliant) {
            (Some(k), true) => {
                for (axis, v) in ["x", "y"].iter().zip(k) {
                    if !(v.is_finite() && v > 0.0) {
                        return err(format!(
                            "{}[{axis}] = {v}: bearing stiffness must be > 0 when translations are \
                             enabled (model.bearings = \"compliant\"); omit bearing_stiffness for a \
                             rigidly supported gear",
                            f("bearing_stiffness")
                        ));
                    }
                }
                let c = g.bearing_damping.unwrap_or([0.0, 0.0]);
                bounded(&format!("{}[x]", f("bearing_damping")), c[0])?;
                bounded(&format!("{}[y]", f("bearing_damping")), c[1])?;
                if mass.is_none() {
                    return err(format!(
                        "{}: missing; gear {:?} has bearing_stiffness, so its translations need a mass in kg",
                        f("mass"),
                        g.name
                    ));
                }
                Some(Bearing {
                    stiffness: k,
                    damping: c,
                })
            }
            (None, _) if g.bearing_damping.is_some() => {
                return err(format!(
                    "{}: given without bearing_stiffness",
                    f("bearing_damping")
                ))
            }
            _ => None,
        };
        gears.push(Gear {
            name: g.name.clone(),
            teeth,
            base_radius: super::geometry::base_radius(&table, g.base_radius, derived)?,
            inertia: super::geometry::body_value(
                &table,
                "inertia",
                g.inertia,
                derived.map(|d| (d, d.inertia)),
            )?,
            mass,
            bearing,
            ground_stiffness: bounded(&f("ground_stiffness"), g.ground_stiffness)?,
            ground_damping: bounded(&f("ground_damping"), g.ground_damping)?,
            errors: super::errors::gear_errors(&f, &g.name, teeth, g)?,
        });
        let gear = &gears[gears.len() - 1];
        super::checks::gear_compliance(&format!("gear[{i}]"), gear.base_radius, gear.inertia)?;
    }
    super::planetary::carriers(&spec.carrier, compliant, &mut gears)?;
    mass_spread(&gears)?;
    // A train without any ground stiffness turns freely; its rigid-body rotation is removed
    // from the state (docs/train.md), which is exact only if nothing couples it to the
    // elastic motion. A ground damper does.
    if !gears.iter().any(|g| g.ground_stiffness > 0.0) {
        if let Some((i, g)) = gears
            .iter()
            .enumerate()
            .find(|(_, g)| g.ground_damping > 0.0)
        {
            return err(format!(
                "gear[{i}].ground_damping = {}: the train has no ground stiffness, so it turns \
                 freely; a ground damper couples that free rotation to the elastic motion, which \
                 the reduced model omits (add a ground_stiffness or remove the damper)",
                g.ground_damping
            ));
        }
    }
    let find = |field: &str, name: &str| -> Result<usize> {
        gears.iter().position(|g| g.name == name).ok_or_else(|| {
            let names: Vec<_> = gears.iter().map(|g| g.name.as_str()).collect();
            SceneError(format!(
                "{field} = {name:?}: no gear of that name (gears: {})",
                names.join(", ")
            ))
        })
    };

    // A shaft that reaches an element ([[motor]], [[load]], [[inertia]]) is an element
    // shaft (`super::elements`); the others couple coaxial gears of the train.
    let element_names =
        crate::scene::train::elements::body_names(&spec.motor, &spec.load, &spec.inertia);
    for (table, name) in
        crate::scene::train::elements::body_tables(&spec.motor, &spec.load, &spec.inertia)
    {
        if gears.iter().any(|g| g.name == name) {
            return err(format!(
                "{table}.name = {name:?}: a gear has that name already"
            ));
        }
    }
    let (element_shafts, train_shafts): (Vec<_>, Vec<_>) = spec
        .shaft
        .iter()
        .enumerate()
        .partition(|(_, s)| s.gears.iter().any(|g| element_names.contains(g)));
    let shafts = train_shafts
        .iter()
        .map(|&(i, s)| {
            if let Some(name) = &s.name {
                return err(format!(
                    "shaft[{i}].name = {name:?}: only a shaft to an element has a name \
                     (its torque column)"
                ));
            }
            shaft(i, s, &find)
        })
        .collect::<Result<Vec<_>>>()?;

    if mesh_specs.is_empty() {
        return err("mesh: no mesh given; a train needs at least one".into());
    }
    // The static pinion torque of every mesh (the default load of a geometry stiffness):
    // the input torque carried along the base circles, as the balanced load below.
    let op = &spec.operating;
    let ends = mesh_specs
        .iter()
        .enumerate()
        .map(|(i, m)| {
            Ok((
                find(&mesh_field(form, i, "pinion"), &m.pinion)?,
                find(&mesh_field(form, i, "gear"), &m.gear)?,
            ))
        })
        .collect::<Result<Vec<_>>>()?;
    let input_gear = match &op.input_gear {
        Some(name) => find("operating.input_gear", name)?,
        None => ends[0].0,
    };
    let mut profiles = crate::scene::profile::profiles(&op.speed_profile, &op.torque_profile)?;
    let input_speed = crate::scene::profile::resolve(
        &speed_field,
        op.input_speed,
        "operating.speed_profile",
        profiles.speed.as_ref(),
    )?;
    // A torque port on the input gear gives its torque (docs/ports.md).
    let port_on = |gear: usize| {
        spec.port
            .iter()
            .find(|p| find("", &p.gear).ok() == Some(gear))
            .map(|p| p.torque)
    };
    let input_port = port_on(input_gear);
    let input_torque = match (input_port, op.input_torque) {
        (Some(t), None) if profiles.torque.is_none() => t,
        _ => crate::scene::profile::resolve(
            "operating.input_torque",
            op.input_torque,
            "operating.torque_profile",
            profiles.torque.as_ref(),
        )?,
    };
    let input_speed = bounded(&speed_field, input_speed)?;
    let input_torque = finite("operating.input_torque", input_torque)?;
    let torque_ripple = match op.torque_ripple {
        Some(t) => finite("operating.torque_ripple", t)?,
        None => 0.0,
    };
    // The torque each mesh's pinion carries (of the input torque, along the base circles).
    let pinion_ratio: Vec<f64> = ends
        .iter()
        .map(|&(pinion, _)| radius_ratio(&gears, &shafts, &ends, input_gear, pinion))
        .collect();
    let mut meshes = Vec::with_capacity(mesh_specs.len());
    for (i, m) in mesh_specs.iter().enumerate() {
        let at = MeshAt {
            i,
            form,
            on_pair,
            pinion_torque: super::planetary::sun_mesh_torque(
                &spec.gear,
                &gears,
                &mesh_specs,
                i,
                input_gear,
                input_torque,
            )
            .unwrap_or(input_torque * pinion_ratio[i]),
            pinion_is_input: ends[i].0 == input_gear,
            planetary: super::planetary::is_planet_mesh(&spec.gear, m),
        };
        let mut mesh = mesh(&at, m, &gears, &find)?;
        mesh.smooth.torque_ripple = torque_ripple;
        meshes.push(mesh);
    }
    for (i, m) in meshes.iter().enumerate() {
        if let Some(j) = meshes[..i].iter().position(|o: &Mesh| {
            (o.pinion, o.gear) == (m.pinion, m.gear) || (o.pinion, o.gear) == (m.gear, m.pinion)
        }) {
            return err(format!(
                "mesh[{i}]: gears {:?} and {:?} already mesh in mesh[{j}]",
                gears[m.pinion].name, gears[m.gear].name
            ));
        }
    }
    errors_geometry(&gears, &mesh_specs)?;
    runout_pressure_angle(&gears, &meshes, form)?;
    for (i, m) in meshes.iter().enumerate() {
        if let Some(j) = meshes[..i].iter().position(|o| o.name == m.name) {
            return err(format!(
                "mesh[{i}].name = {:?}: duplicates mesh[{j}].name",
                m.name
            ));
        }
    }

    let mut stages = super::planetary::stages(
        &spec.gear,
        &spec.carrier,
        &gears,
        &meshes,
        &mesh_specs,
        form,
        compliant,
    )?;
    let (speed_ratio, rotation) =
        kinematics(&gears, &shafts, &meshes, &stages, input_gear, input_sense)?;
    let output_gear = match &op.output_gear {
        Some(name) => find("operating.output_gear", name)?,
        None => meshes[meshes.len() - 1].gear,
    };
    if input_gear == output_gear {
        return err(format!(
            "operating.output_gear = {:?}: the same gear as the input gear",
            gears[output_gear].name
        ));
    }

    for m in meshes.iter_mut() {
        m.cycles_per_input_rev = gears[m.pinion].teeth as f64 * speed_ratio[m.pinion];
    }
    super::planetary::finish_kinematics(
        &mut stages,
        &gears,
        &mut meshes,
        (&speed_ratio, &rotation),
        (input_gear, input_torque),
    );
    super::planetary::phasing(&stages, &gears, &mut meshes, &mesh_specs)?;
    super::planetary::geometry_origins(&stages, &mut meshes, &mesh_specs, form)?;
    if speed_ratio[output_gear] == 0.0 {
        return err(format!(
            "operating.output_gear = {:?}: not connected to the input gear {:?}",
            gears[output_gear].name, gears[input_gear].name
        ));
    }

    // Balanced load: the moment balance along the base circles, T_out = T_in·Π r_gear/r_pinion
    // over the meshes from input to output (Liu 2007 Table 2.1: T_3 = −T_1 r_3/r_1; Table 4.1
    // corrected to −542.4 N·m, notes §3.5 [C]). With exact involute data this is the speed
    // ratio; the radii are used so that the rigid-body mode is not driven by rounding of the
    // tabulated radii (Table 2.1: r/z differs by 1e-5 between the gears).
    let output_port = port_on(output_gear);
    let load_torque = match (output_port, op.load_torque) {
        (Some(t), None) => -t,
        (_, Some(t)) => finite("operating.load_torque", t)?,
        // The single-pair kernel has always rounded its balanced load as T1·r_b2/r_b1; the
        // product order is kept so that its results stay bit for bit (tests/every_command.rs).
        (None, None) if on_pair => {
            let (pinion, gear) = (&gears[meshes[0].pinion], &gears[meshes[0].gear]);
            input_torque * gear.base_radius / pinion.base_radius
        }
        (None, None) if !stages.is_empty() => super::planetary::balanced_load(
            &stages,
            &gears,
            &meshes,
            &rotation,
            (input_gear, output_gear),
            input_torque,
        )?,
        (None, None) => {
            input_torque * radius_ratio(&gears, &shafts, &ends, input_gear, output_gear)
        }
    };
    let ports = crate::scene::train::ports::ports(
        &spec.port,
        &find,
        input_gear,
        output_gear,
        op.input_torque.is_some() || op.torque_profile.is_some(),
        op.load_torque.is_some(),
    )?;
    let elements = crate::scene::train::elements::elements(
        &spec.motor,
        &spec.load,
        &spec.inertia,
        &element_shafts,
        &|name| gears.iter().position(|g| g.name == name),
        input_gear,
        output_gear,
        input_torque,
        load_torque,
    )?;
    if !elements.is_empty() {
        if let Some(p) = spec.port.first() {
            return err(format!(
                "port[0] ({:?}) with elements ([[motor]], [[load]], [[inertia]]): the elements' \
                 shafts give the train's torques; ports beside them are not available yet",
                p.name
            ));
        }
        if profiles.speed.is_some() || profiles.torque.is_some() {
            return err(
                "operating.speed_profile / operating.torque_profile: a scene with elements \
                 takes its torques from the element shafts and carries its speed \
                 (docs/ports.md)"
                    .into(),
            );
        }
    }
    if !ports.is_empty() && (profiles.speed.is_some() || profiles.torque.is_some()) {
        return err(
            "operating.speed_profile / operating.torque_profile: a scene with [[port]] \
                    takes its torques at the ports and carries its speed; profiles need the \
                    nominal-speed form (docs/ports.md)"
                .into(),
        );
    }
    if op.load_torque.is_none() && profiles.torque.is_some() {
        profiles.load_ratio = Some(radius_ratio(
            &gears,
            &shafts,
            &ends,
            input_gear,
            output_gear,
        ));
    }

    let deflection = StaticLoad {
        input_torque,
        torque_ripple,
        load_torque,
        profiles: &profiles,
    };
    // The single-pair kernel refuses such a load when the file is read; on the drivetrain
    // kernel (ports, elements, unbalanced loads) the run limits and the work budget stop it at
    // the start of the run, naming the cause (`tests/port_stages.rs`, `tests/robust_cli.rs`).
    if on_pair {
        for (i, m) in meshes.iter().enumerate() {
            deflection.check(form, i, m, &gears, pinion_ratio[i], m.gear == output_gear)?;
        }
    }

    let initial_dte = initial_dte(&spec.initial.dte)?;

    let solver = solver(&spec.solver)?;
    if solver.method == MethodChoice::Exact {
        for (i, (m, m_spec)) in meshes.iter().zip(&mesh_specs).enumerate() {
            if !piecewise_constant(m) {
                let source = match &m_spec.stiffness {
                    Some(s) => format!(
                        "{} ({})",
                        mesh_field(form, i, "stiffness"),
                        super::stiffness::stiffness_kind(s)
                    ),
                    None => format!("{} (with sloped pieces)", mesh_field(form, i, "pairs")),
                };
                return err(format!(
                    "solver.method = \"exact\": {source} is not piecewise constant, so its \
                     segments are not time-invariant; use \"rk\" or \"auto\""
                ));
            }
        }
    }

    Ok(Scene {
        name: spec.name,
        description: spec.description,
        kernel,
        gears,
        shafts,
        meshes,
        modal_damping_ratio: modal,
        input_gear,
        output_gear,
        speed_ratio,
        rotation,
        operating: Operating {
            input_speed,
            input_torque,
            load_torque,
        },
        profiles,
        initial_dte,
        initial_dte_rate: finite("initial.dte_rate", spec.initial.dte_rate)?,
        solver,
        source: source.to_owned(),
        ports,
        elements,
        planetary: stages,
    })
}

/// Whether the mesh's stiffness is piecewise constant in mesh phase (exact propagation).
pub(crate) fn piecewise_constant(m: &Mesh) -> bool {
    match &m.force {
        MeshForceModel::Lumped { stiffness, .. } => stiffness.is_piecewise_constant(),
        MeshForceModel::Pairs { pair, .. } => pair.pieces.iter().all(|p| p.slope == 0.0),
    }
}

fn shaft(i: usize, s: &ShaftSpec, find: &dyn Fn(&str, &str) -> Result<usize>) -> Result<Shaft> {
    let a = find(&format!("shaft[{i}].gears[0]"), &s.gears[0])?;
    let b = find(&format!("shaft[{i}].gears[1]"), &s.gears[1])?;
    if a == b {
        return err(format!(
            "shaft[{i}].gears = [{:?}, {:?}]: a shaft joins two different gears",
            s.gears[0], s.gears[1]
        ));
    }
    let coupling = match (s.rigid, s.stiffness) {
        (true, None) => {
            if s.damping != 0.0 {
                return err(format!(
                    "shaft[{i}].damping = {}: a rigid shaft has no damping",
                    s.damping
                ));
            }
            ShaftCoupling::Rigid
        }
        (false, Some(k)) => ShaftCoupling::Elastic {
            stiffness: bounded(&format!("shaft[{i}].stiffness"), k)?,
            damping: bounded(&format!("shaft[{i}].damping"), s.damping)?,
        },
        (true, Some(k)) => {
            return err(format!(
                "shaft[{i}].stiffness = {k}: not allowed with rigid = true"
            ))
        }
        (false, None) => {
            return err(format!(
                "shaft[{i}].stiffness: missing; give the torsional stiffness in N·m/rad or rigid = true"
            ))
        }
    };
    Ok(Shaft {
        gears: [a, b],
        coupling,
    })
}

/// Where a mesh sits in its scene, for [`mesh`].
struct MeshAt {
    /// Index in the file's meshes.
    i: usize,
    /// How the file wrote its meshes (messages name the fields as written).
    form: MeshForm,
    /// The scene runs on the single-pair kernel.
    on_pair: bool,
    /// The static torque on the pinion (the input torque carried along the base circles).
    pinion_torque: f64,
    /// The pinion is the input gear (its torque is `operating.input_torque` itself).
    pinion_is_input: bool,
    /// A mesh of a planetary stage: its line of action follows from the planet's position.
    planetary: bool,
}

impl MeshAt {
    /// The field a geometry stiffness' static torque comes from, as the user wrote it.
    fn torque_field(&self, pinion_field: &str) -> String {
        if self.planetary {
            format!("operating.input_torque (the sun's torque per planet, {pinion_field})")
        } else if self.pinion_is_input {
            "operating.input_torque".to_owned()
        } else {
            format!("operating.input_torque (carried to {pinion_field})")
        }
    }
}

/// One mesh, every option of it: the one function a new mesh option is checked in.
fn mesh(
    at: &MeshAt,
    m: &TrainMeshSpec,
    gears: &[Gear],
    find: &dyn Fn(&str, &str) -> Result<usize>,
) -> Result<Mesh> {
    let i = at.i;
    let f = |name: &str| mesh_field(at.form, i, name);
    let table = mesh_table(at.form, i);
    let pinion = find(&f("pinion"), &m.pinion)?;
    let gear = find(&f("gear"), &m.gear)?;
    if pinion == gear {
        return err(format!(
            "{} = {:?}: the same gear as {}",
            f("gear"),
            m.gear,
            f("pinion")
        ));
    }
    let (gp, gg) = (&gears[pinion], &gears[gear]);

    let model = match m.model.as_deref() {
        None | Some("lumped") => None,
        Some("pairs") => Some(PairModel::PerPair),
        Some("loaded_ste") => Some(PairModel::LoadedSte),
        Some("nlte") => Some(PairModel::Nlte),
        Some(other) => {
            return err(format!(
                "{} = {other:?}: must be lumped | pairs | loaded_ste | nlte",
                f("model")
            ))
        }
    };
    let force = match model {
        None => {
            if m.pairs.is_some() || m.tip_relief.is_some() || m.gaps.is_some() {
                return err(format!(
                    "{}: pairs/tip_relief need model = \"pairs\", \"loaded_ste\" or \"nlte\" (model is lumped)",
                    f("model")
                ));
            }
            let Some(spec) = &m.stiffness else {
                return err(format!("{}: missing (lumped mesh)", f("stiffness")));
            };
            let stiffness = match spec {
                crate::scene::spec::StiffnessSpec::Geometry { .. } => {
                    let body = |which: &str, g: usize| super::geometry::MeshGear {
                        which: f(which),
                        name: &gears[g].name,
                        teeth: gears[g].teeth,
                        base_radius: gears[g].base_radius,
                    };
                    super::geometry::stiffness(
                        spec,
                        &f("stiffness"),
                        [body("pinion", pinion), body("gear", gear)],
                        (&at.torque_field(&f("pinion")), at.pinion_torque),
                    )?
                }
                // He & Singh's lumped helical stiffness is a pair's (its friction term takes
                // the two inertias); a train's helical meshes take [mesh.pairs].
                crate::scene::spec::StiffnessSpec::Helical { .. } if at.on_pair => {
                    super::helical::stiffness(spec, gp, gg)?
                }
                crate::scene::spec::StiffnessSpec::Helical { .. } => {
                    return err(format!(
                        "{}.kind = \"helical\": not available as a lumped drivetrain mesh \
                         stiffness; for helical tooth pairs with friction use model = \"pairs\" \
                         with [mesh.pairs] kind = \"helical\"",
                        f("stiffness")
                    ));
                }
                _ => super::stiffness::stiffness(spec)
                    .map_err(|e| SceneError(e.0.replacen("mesh.", &format!("{table}."), 1)))?,
            };
            let (k_min, s_min) = stiffness.minimum();
            if !(k_min > 0.0) {
                return err(format!(
                    "{}: the stiffness reaches {k_min:e} N/m at shifted phase {s_min}; it must stay > 0",
                    f("stiffness")
                ));
            }
            let ste = match &m.ste {
                Some(s) => {
                    super::checks::harmonic_list(&f("ste.cos"), &s.cos)?;
                    super::checks::harmonic_list(&f("ste.sin"), &s.sin)?;
                    PhaseSeries::new(&s.cos, &s.sin)
                }
                None => PhaseSeries::default(),
            };
            MeshForceModel::Lumped { stiffness, ste }
        }
        Some(model) => {
            if m.stiffness.is_some() || m.ste.is_some() {
                return err(format!(
                    "{}: stiffness/ste belong to model = \"lumped\"; a pair-based mesh takes [mesh.pairs]",
                    f("model")
                ));
            }
            let Some(spec) = &m.pairs else {
                return err(format!(
                    "{}: missing; model = {:?} needs the single-pair stiffness",
                    f("pairs"),
                    m.model.as_deref().unwrap_or("")
                ));
            };
            let (pair, curve) = match spec {
                PairStiffnessSpec::Geometry { .. } => {
                    let body = |which: &str, g: usize| super::geometry::MeshGear {
                        which: f(which),
                        name: &gears[g].name,
                        teeth: gears[g].teeth,
                        base_radius: gears[g].base_radius,
                    };
                    let (curve, _) = super::geometry::pair_curve(
                        spec,
                        &f("pairs"),
                        [body("pinion", pinion), body("gear", gear)],
                        (&at.torque_field(&f("pinion")), at.pinion_torque),
                    )?;
                    let pair = PairStiffness::table(curve.window(), &curve.points, &curve.values);
                    (pair, Some(curve))
                }
                _ => (pair_stiffness(&f("pairs"), spec)?, None),
            };
            // Profile modifications are given on the theoretical window [0, c).
            let c = curve
                .as_ref()
                .map_or(pair.contact_ratio, |k| k.contact_ratio);
            let relief = match (&m.tip_relief, &m.gaps) {
                (Some(_), Some(_)) => {
                    return err(format!("{}: give tip_relief or gaps, not both", f("gaps")))
                }
                (_, Some(g)) => PairGap::Table(gap_table(&f("gaps"), g, c)?),
                _ => PairGap::Relief(tip_relief(&f("tip_relief"), m, c)?),
            };
            let relief = match &curve {
                Some(k) if k.extension > 0.0 => PairGap::Table(extended_gap(k, &relief)),
                _ => relief,
            };
            MeshForceModel::Pairs {
                model,
                pair,
                relief,
            }
        }
    };

    // After the stiffness: a geometry or helical source names the gear that disagrees with it.
    let pitch_p = gp.base_radius / gp.teeth as f64;
    let pitch_g = gg.base_radius / gg.teeth as f64;
    if (pitch_p - pitch_g).abs() > BASE_PITCH_TOL * pitch_p.max(pitch_g) {
        return err(format!(
            "{table}: base pitches differ ({:?}: base_radius/teeth = {pitch_p:e} m, {:?}: {pitch_g:e} m, \
             more than {} %), so these gears cannot mesh",
            gp.name,
            gg.name,
            BASE_PITCH_TOL * 100.0
        ));
    }

    let contact = super::mesh::contact_law(&f, m)?;

    let k_mean = match &force {
        MeshForceModel::Lumped { stiffness, .. } => stiffness.mean(),
        MeshForceModel::Pairs { pair, .. } => pair.mesh_mean(),
    };
    // Equivalent mass of the two gears alone, as for the single pair (docs/model.md).
    let m_e = 1.0 / (gp.base_radius.powi(2) / gp.inertia + gg.base_radius.powi(2) / gg.inertia);
    let k_max = match &force {
        MeshForceModel::Lumped { stiffness, .. } => stiffness.maximum(),
        MeshForceModel::Pairs { pair, .. } => pair.mesh_mean(),
    };
    let damping = super::mesh::damping(&f, m, k_mean, k_max, m_e)?;
    let (damping_always, smooth) = pair_terms(&f, m, contact, damping)?;

    let initial_phase = match (i, m.initial_phase) {
        (0, p) => finite(&f("initial_phase"), p.unwrap_or(0.0))?,
        (_, None) => 0.0,
        (_, Some(p)) => {
            return err(format!(
                "{} = {p}: only the first mesh has an initial phase; give this mesh's phasing \
                 relative to the first mesh as `phase`",
                f("initial_phase")
            ))
        }
    };
    let phase = match (i, m.phase) {
        (_, None) => 0.0,
        (0, Some(p)) => {
            return err(format!(
                "{} = {p}: the first mesh is the phase reference; use initial_phase",
                f("phase")
            ))
        }
        (_, Some(p)) => finite(&f("phase"), p)?,
    };

    let translations = gp.bearing.is_some() || gg.bearing.is_some();
    // A geometry mesh defines its operating pressure angle α_w (docs/train.md, "Gears and
    // geometry meshes").
    let working = match (&m.stiffness, &m.pairs) {
        (Some(s), _) => super::geometry::working_pressure_angle(s, &f("stiffness"))?,
        (None, Some(p)) => super::geometry::pair_working_pressure_angle(p, &f("pairs"))?,
        (None, None) => None,
    };
    let pressure_angle = match (m.pressure_angle, working) {
        (Some(deg), Some((alpha_w, field))) => {
            let given = pressure_angle(&f("pressure_angle"), deg)?;
            if ((given - alpha_w) / alpha_w).abs() > super::geometry::BASE_RADIUS_TOL {
                return err(format!(
                    "{} = {deg}: differs from the working pressure angle {:.6}° of {field} by more \
                     than {:e} (relative); omit pressure_angle to use the geometry's",
                    f("pressure_angle"),
                    alpha_w.to_degrees(),
                    super::geometry::BASE_RADIUS_TOL
                ));
            }
            given
        }
        (Some(deg), None) => pressure_angle(&f("pressure_angle"), deg)?,
        (None, Some((alpha_w, _))) => alpha_w,
        (None, None) if translations => {
            return err(format!(
                "{}: missing; gear {:?} or {:?} has translational DOFs, so the line of action \
                 needs the operating pressure angle (degrees)",
                f("pressure_angle"),
                gp.name,
                gg.name
            ))
        }
        (None, None) => 0.0,
    };
    let centre_angle = match m.centre_angle {
        Some(a) if at.planetary => {
            return err(format!(
                "{} = {a}: a planetary mesh's line of action follows from the planet's \
                 position_angle and the pressure angle (docs/planetary.md); omit centre_angle",
                f("centre_angle")
            ))
        }
        Some(a) => finite(&f("centre_angle"), a)?,
        None if translations && !at.planetary => {
            return err(format!(
                "{}: missing; translational DOFs need the centre-line direction (rad)",
                f("centre_angle")
            ))
        }
        None => 0.0,
    };

    if m.friction.is_some() && matches!(contact, ContactLaw::Backlash { .. }) {
        return err(format!(
            "{}: tooth friction is modelled on the drive flanks only; contact = \"backlash\" \
             (back-side contact on the other line of action) is not supported with it",
            f("friction")
        ));
    }
    let helical = match &m.pairs {
        Some(PairStiffnessSpec::Helical { density, geometry }) => {
            let h = helical_pair(&f("pairs"), *density, geometry)?;
            check_helical(&f("pairs"), &h, gp, gg, pressure_angle)?;
            Some(h)
        }
        _ => None,
    };
    let friction = match (&m.friction, &force) {
        (None, _) => None,
        (Some(_), _) if matches!(m.pairs, Some(PairStiffnessSpec::Geometry { .. })) => {
            return err(format!(
                "{}: tooth friction is not available with [mesh.pairs] kind = \"geometry\" \
                 (its pitch point would have to follow the ETC-extended window); use \
                 kind = \"table\" with the geometry's pair curve",
                f("friction")
            ))
        }
        (
            Some(spec),
            MeshForceModel::Pairs {
                model: PairModel::PerPair,
                pair,
                ..
            },
        ) => Some(super::friction::validate(
            &f("friction"),
            spec,
            gp,
            gg,
            pressure_angle,
            pair.contact_ratio,
            helical.as_ref(),
        )?),
        (Some(_), _) => {
            return err(format!(
            "{}: tooth friction acts per tooth pair and needs model = \"pairs\" (model is {:?})",
            f("friction"),
            m.model.as_deref().unwrap_or("lumped")
        ))
        }
    };

    // A single-pair kernel's mesh is `mesh`, as its FMU variables name it (`mesh.damping`); a
    // drivetrain's meshes are numbered as its columns (`mesh1.dte`). A given name prefixes the
    // mesh's output columns, so it must be an identifier.
    let name = match &m.name {
        Some(name) if identifier(name) => name.clone(),
        Some(name) => return err(format!("{} = {name:?}: must be an identifier", f("name"))),
        None if at.on_pair => "mesh".to_owned(),
        None => format!("mesh{}", i + 1),
    };
    Ok(Mesh {
        name,
        pinion,
        gear,
        contact,
        damping,
        initial_phase,
        phase,
        pressure_angle,
        centre_angle,
        force,
        damping_always,
        smooth,
        friction,
        helical,
        cycles_per_input_rev: 0.0,
    })
}

/// The terms only the single-pair kernel carries (Bugaru et al. 2006, eqs. 8 and 13):
/// `damping_acts` and the smooth additions to the mesh force (the input-torque ripple is the
/// scene's, set by [`validate`]). On the drivetrain kernel [`validate`] has refused them by
/// name already.
fn pair_terms(
    f: &dyn Fn(&str) -> String,
    m: &TrainMeshSpec,
    contact: ContactLaw,
    damping: f64,
) -> Result<(bool, SmoothTerms)> {
    let damping_always = match m.damping_acts.as_deref() {
        None | Some("in_contact") => false,
        Some("always") => true,
        Some(other) => {
            return err(format!(
                "{} = \"{other}\": expected \"in_contact\" or \"always\"",
                f("damping_acts")
            ))
        }
    };
    let smooth = SmoothTerms {
        cubic_factor: match &m.cubic {
            Some(c) => bounded(&f("cubic.stiffness_factor"), c.stiffness_factor)?,
            None => 0.0,
        },
        cubic_spring: match &m.cubic {
            Some(c) => bounded(&f("cubic.spring"), c.spring)?,
            None => 0.0,
        },
        damping_variation: match m.damping_variation {
            Some(v) => {
                let v = finite(&f("damping_variation"), v)?;
                if v.abs() > damping {
                    return err(format!(
                        "{} = {v}: |c̃| must not exceed the damping {damping} N·s/m (the damping \
                         would turn negative)",
                        f("damping_variation")
                    ));
                }
                v
            }
            None => 0.0,
        },
        torque_ripple: 0.0,
    };
    if (m.cubic.is_some() || m.damping_variation.is_some()) && contact != ContactLaw::Linear {
        return err(format!(
            "{} / {}: only with contact = \"linear\" (the cubic spring models the backlash, \
             Bugaru 2006); contact is {contact:?}",
            f("cubic"),
            f("damping_variation")
        ));
    }
    Ok((damping_always, smooth))
}

/// The static load of the operating point, for the check that no mesh deflects by a whole
/// tooth under it: a deflection beyond the base pitch means the load or the stiffness is not
/// physical (and a cubic spring would stiffen the mesh without bound).
struct StaticLoad<'a> {
    input_torque: f64,
    torque_ripple: f64,
    load_torque: f64,
    profiles: &'a crate::scene::Profiles,
}

impl StaticLoad<'_> {
    /// Checks mesh `i`, whose pinion carries `ratio` × the input torque; the load acts on its
    /// gear when `at_output`.
    fn check(
        &self,
        form: MeshForm,
        i: usize,
        m: &Mesh,
        gears: &[Gear],
        ratio: f64,
        at_output: bool,
    ) -> Result<()> {
        let (pinion, gear) = (&gears[m.pinion], &gears[m.gear]);
        let (input_torque, load_torque) = (self.input_torque, self.load_torque);
        let ripple = self.torque_ripple.abs();
        // A profile's extremes are at its knots: the bound holds at every torque it reaches.
        let (t_abs, load_abs) = match (&self.profiles.torque, self.profiles.load_ratio) {
            (Some(p), r) => {
                let t = p.values().iter().fold(0.0f64, |a, v| a.max(v.abs()));
                (t, r.map_or(load_torque.abs(), |r| t * r))
            }
            (None, _) => (input_torque.abs(), load_torque.abs()),
        };
        let from_pinion = (t_abs + ripple) * ratio / pinion.base_radius;
        let force = if at_output {
            from_pinion.max(load_abs / gear.base_radius)
        } else {
            from_pinion
        };
        let k_mean = m.mean_stiffness();
        let deflection = force / k_mean;
        let base_pitch = std::f64::consts::TAU * pinion.base_radius / f64::from(pinion.teeth);
        if deflection <= base_pitch {
            return Ok(());
        }
        let which = match form {
            MeshForm::One => "mesh".to_owned(),
            MeshForm::Many => format!("mesh[{i}]"),
        };
        err(format!(
            "operating.input_torque = {input_torque:e} N·m (torque_ripple {ripple:e} N·m), load torque \
             {load_torque:e} N·m: the static {which} deflection {deflection:e} m (mesh force {force:e} N \
             on the mean stiffness {k_mean:e} N/m, base radii {:e} and {:e} m) exceeds the base pitch \
             {base_pitch:e} m, a whole tooth",
            pinion.base_radius, gear.base_radius
        ))
    }
}

/// Smallest operating pressure angle accepted, degrees. Real spur and helical stages run at
/// 14.5°–35°; a value below this is almost surely an angle in radians from a scene written
/// before `pressure_angle` changed to degrees (0.349 rad = 20°).
const MIN_PRESSURE_ANGLE_DEG: f64 = 5.0;

/// A mesh's operating pressure angle, given in degrees (as in the gears file), in radians.
fn pressure_angle(field: &str, deg: f64) -> Result<f64> {
    if deg.is_finite() && deg > 0.0 && deg < MIN_PRESSURE_ANGLE_DEG {
        return err(format!(
            "{field} = {deg}: pressure angles are in degrees (as in the gears file); this looks \
             like an angle in radians ({deg} rad = {:.4}°), write pressure_angle = {:.4}",
            deg.to_degrees(),
            deg.to_degrees()
        ));
    }
    if !(deg.is_finite() && (MIN_PRESSURE_ANGLE_DEG..90.0).contains(&deg)) {
        return err(format!(
            "{field} = {deg}: must lie in [{MIN_PRESSURE_ANGLE_DEG}, 90) degrees"
        ));
    }
    Ok(deg.to_radians())
}

/// The helical pair of `kind = "helical"` (geometry checks by [`HelicalGeometry::new`]).
fn helical_pair(
    field: &str,
    density: f64,
    geometry: &crate::mesh::helical::HelicalPairSpec,
) -> Result<HelicalPair> {
    bounded(&format!("{field}.density"), density)?;
    let geometry =
        crate::mesh::helical::HelicalGeometry::new(geometry, &format!("{field}.geometry."))
            .map_err(SceneError)?;
    Ok(HelicalPair { geometry, density })
}

/// A helical pair must be the gears of the mesh: teeth, base radii and pressure angle agree.
fn check_helical(
    field: &str,
    h: &HelicalPair,
    pinion: &Gear,
    gear: &Gear,
    pressure_angle: f64,
) -> Result<()> {
    for (name, g, hg) in [
        ("pinion", pinion, &h.geometry.pinion),
        ("gear", gear, &h.geometry.gear),
    ] {
        if g.teeth != hg.teeth {
            return err(format!(
                "{field}.geometry.{name}.teeth = {}: gear {:?} has {} teeth",
                hg.teeth, g.name, g.teeth
            ));
        }
        if (g.base_radius - hg.base_radius).abs() > 1e-9 * hg.base_radius {
            return err(format!(
                "{field}.geometry: the {name}'s base radius is {:e} m, gear {:?} has base_radius = {:e} m",
                hg.base_radius, g.name, g.base_radius
            ));
        }
    }
    if pressure_angle != 0.0 && (pressure_angle - h.geometry.pressure_angle).abs() > 1e-12 {
        return err(format!(
            "{field}.geometry.transverse_pressure_angle: {}°, but the mesh's pressure_angle = {}°",
            h.geometry.pressure_angle.to_degrees(),
            pressure_angle.to_degrees()
        ));
    }
    Ok(())
}

/// The gap of a geometry pair over its ETC-extended window `[0, c + 2e]`: the profile
/// modification `relief` (given on the theoretical window `[0, c]`, shifted by `e`) plus the
/// ETC gap beyond the path ends ([`crate::mesh::geometry::PairCurve::extension_gap`]); both
/// are piecewise linear, so the table through their kinks is exact.
fn extended_gap(curve: &crate::mesh::geometry::PairCurve, relief: &PairGap) -> GapTable {
    let (c, e) = (curve.contact_ratio, curve.extension);
    let mut xi: Vec<f64> = vec![0.0, c];
    xi.extend(relief.kinks(c).into_iter().filter(|&k| k > 0.0 && k < c));
    xi.sort_by(f64::total_cmp);
    xi.dedup();
    let mut points = vec![0.0];
    points.extend(xi.iter().map(|&k| k + e));
    points.push(c + 2.0 * e);
    let values = points
        .iter()
        .map(|&p| relief.gap_and_slope(c, (p - e).clamp(0.0, c)).0 + curve.extension_gap(p).0)
        .collect();
    GapTable { points, values }
}

fn pair_stiffness(field: &str, spec: &PairStiffnessSpec) -> Result<PairStiffness> {
    match spec {
        PairStiffnessSpec::Geometry { .. } => {
            unreachable!("geometry pairs are resolved with their gears (mesh)")
        }
        PairStiffnessSpec::Helical { density, geometry } => {
            Ok(helical_pair(field, *density, geometry)?.pair_stiffness())
        }
        PairStiffnessSpec::Rectangular {
            mean,
            peak_to_peak_ratio,
            contact_ratio,
            load_share,
        } => {
            bounded(&format!("{field}.mean"), *mean)?;
            bounded(&format!("{field}.peak_to_peak_ratio"), *peak_to_peak_ratio)?;
            let c = *contact_ratio;
            if !(c.is_finite() && c > 1.0 && c < 2.0) {
                return err(format!(
                    "{field}.contact_ratio = {c}: the rectangular pair idealisation (Liu 2007 §2.5) \
                     needs 1 < c < 2; use kind = \"table\" otherwise"
                ));
            }
            let k_single = mean * (1.0 + peak_to_peak_ratio * (1.0 - c));
            if !(k_single > 0.0) {
                return err(format!(
                    "{field}.peak_to_peak_ratio = {peak_to_peak_ratio}: gives a single-pair stiffness \
                     K_s = {k_single:e} N/m <= 0 for contact_ratio = {c}"
                ));
            }
            match *load_share {
                None => Ok(PairStiffness::rectangular(*mean, *peak_to_peak_ratio, c)),
                Some(a) if a.is_finite() && (0.0..=1.0).contains(&a) => Ok(
                    PairStiffness::rectangular_shared(*mean, *peak_to_peak_ratio, c, a),
                ),
                Some(a) => err(format!(
                    "{field}.load_share = {a}: the leaving pair's share of K_d must lie in [0, 1]"
                )),
            }
        }
        PairStiffnessSpec::Table {
            contact_ratio,
            points,
            values,
        } => {
            let c = *contact_ratio;
            if !(c.is_finite() && c >= 1.0) {
                return err(format!("{field}.contact_ratio = {c}: must be >= 1"));
            }
            if points.len() != values.len() || points.len() < 2 {
                return err(format!(
                    "{field}.values: {} values for {} points; need the same number, at least 2",
                    values.len(),
                    points.len()
                ));
            }
            if points[0] != 0.0 {
                return err(format!(
                    "{field}.points[0] = {}: the engagement window starts at 0",
                    points[0]
                ));
            }
            let last = points[points.len() - 1];
            if last != c {
                return err(format!(
                    "{field}.points[{}] = {last}: the window ends at contact_ratio = {c}",
                    points.len() - 1
                ));
            }
            for k in 1..points.len() {
                if !(points[k] > points[k - 1]) {
                    return err(format!(
                        "{field}.points[{k}] = {}: must be greater than points[{}] = {}",
                        points[k],
                        k - 1,
                        points[k - 1]
                    ));
                }
            }
            for (k, v) in values.iter().enumerate() {
                bounded(&format!("{field}.values[{k}]"), *v)?;
            }
            let pair = PairStiffness::table(c, points, values);
            if !(pair.mesh_mean() > 0.0) {
                return err(format!(
                    "{field}.values: all zero; the mesh has no stiffness"
                ));
            }
            Ok(pair)
        }
    }
}

fn gap_table(field: &str, g: &crate::scene::spec::GapTableSpec, c: f64) -> Result<GapTable> {
    if g.points.len() != g.values.len() || g.points.len() < 2 {
        return err(format!(
            "{field}.values: {} values for {} points; need the same number, at least 2",
            g.values.len(),
            g.points.len()
        ));
    }
    if g.points[0] != 0.0 {
        return err(format!(
            "{field}.points[0] = {}: the engagement window starts at 0",
            g.points[0]
        ));
    }
    let last = g.points.len() - 1;
    if g.points[last] != c {
        return err(format!(
            "{field}.points[{last}] = {}: the window ends at the pair contact_ratio = {c}",
            g.points[last]
        ));
    }
    for k in 1..g.points.len() {
        if !(g.points[k] > g.points[k - 1]) {
            return err(format!(
                "{field}.points[{k}] = {}: must be greater than points[{}] = {}",
                g.points[k],
                k - 1,
                g.points[k - 1]
            ));
        }
    }
    for (k, v) in g.values.iter().enumerate() {
        finite(&format!("{field}.values[{k}]"), *v)?;
    }
    Ok(GapTable {
        points: g.points.clone(),
        values: g.values.clone(),
    })
}

fn tip_relief(field: &str, m: &TrainMeshSpec, c: f64) -> Result<TipRelief> {
    let Some(spec) = &m.tip_relief else {
        return Ok(TipRelief::default());
    };
    let side = |name: &str, mag: f64, len: Option<f64>| -> Result<(f64, f64)> {
        let mag = bounded(&format!("{field}.{name}_magnitude"), mag)?;
        match (mag > 0.0, len) {
            (false, None) => Ok((0.0, 1.0)),
            (false, Some(l)) => Ok((0.0, bounded(&format!("{field}.{name}_length"), l)?)),
            (true, None) => err(format!(
                "{field}.{name}_length: missing; a relief of magnitude {mag:e} m needs its length \
                 in mesh cycles (c − 1 starts it at the highest point of single contact)"
            )),
            (true, Some(l)) => {
                if !(l.is_finite() && l > 0.0 && l <= c) {
                    return err(format!(
                        "{field}.{name}_length = {l}: must lie in (0, contact_ratio = {c}]"
                    ));
                }
                Ok((mag, l))
            }
        }
    };
    let (dm, dl) = side("driver", spec.driver_magnitude, spec.driver_length)?;
    let (nm, nl) = side("driven", spec.driven_magnitude, spec.driven_length)?;
    Ok(TipRelief {
        driver_magnitude: dm,
        driver_length: dl,
        driven_magnitude: nm,
        driven_length: nl,
    })
}

/// `Π r_gear/r_pinion` along the path from `input` to `output` (torque amplification).
fn radius_ratio(
    gears: &[Gear],
    shafts: &[Shaft],
    meshes: &[(usize, usize)],
    input: usize,
    output: usize,
) -> f64 {
    let mut ratio: Vec<Option<f64>> = vec![None; gears.len()];
    ratio[input] = Some(1.0);
    let mut queue = VecDeque::from([input]);
    while let Some(a) = queue.pop_front() {
        let ra = ratio[a].expect("queued");
        let mut visit = |b: usize, factor: f64, queue: &mut VecDeque<usize>| {
            if ratio[b].is_none() {
                ratio[b] = Some(ra * factor);
                queue.push_back(b);
            }
        };
        for &(pinion, gear) in meshes {
            let (rp, rg) = (gears[pinion].base_radius, gears[gear].base_radius);
            if pinion == a {
                visit(gear, rg / rp, &mut queue);
            } else if gear == a {
                visit(pinion, rp / rg, &mut queue);
            }
        }
        for s in shafts {
            if s.gears[0] == a {
                visit(s.gears[1], 1.0, &mut queue);
            } else if s.gears[1] == a {
                visit(s.gears[0], 1.0, &mut queue);
            }
        }
    }
    ratio[output].unwrap_or(0.0)
}

/// Nominal speed ratios and rotation senses by a walk from the input gear: a mesh reverses
/// the sense and scales the speed by `z_pinion/z_gear`; a shaft keeps both. A second path to a
/// gear must agree (otherwise the kinematics are inconsistent). Parts not reached from the
/// input must be held by a ground coupling (they then stand still); a floating part without
/// drive or ground has no defined motion.
fn kinematics(
    gears: &[Gear],
    shafts: &[Shaft],
    meshes: &[Mesh],
    stages: &[PlanetaryStage],
    input: usize,
    input_sense: f64,
) -> Result<(Vec<f64>, Vec<f64>)> {
    let n = gears.len();
    // A planetary stage's meshes turn with its carrier: Willis' equation links its members
    // (`super::planetary::kinematic_step`), not a fixed-axis ratio.
    let planetary_mesh = |i: usize| {
        stages.iter().any(|s| {
            s.planets
                .iter()
                .any(|p| p.sun_mesh == i || p.ring_mesh == i)
        })
    };
    // Edges: (other gear, speed factor, sense factor, description).
    let mut edges: Vec<Vec<(usize, f64, f64, String)>> = vec![Vec::new(); n];
    for (i, m) in meshes
        .iter()
        .enumerate()
        .filter(|(i, _)| !planetary_mesh(*i))
    {
        let zp = gears[m.pinion].teeth as f64;
        let zg = gears[m.gear].teeth as f64;
        edges[m.pinion].push((m.gear, zp / zg, -1.0, format!("mesh[{i}]")));
        edges[m.gear].push((m.pinion, zg / zp, -1.0, format!("mesh[{i}]")));
    }
    for (i, s) in shafts.iter().enumerate() {
        let [a, b] = s.gears;
        edges[a].push((b, 1.0, 1.0, format!("shaft[{i}]")));
        edges[b].push((a, 1.0, 1.0, format!("shaft[{i}]")));
    }
    let mut ratio: Vec<Option<f64>> = vec![None; n];
    let mut sense = vec![0.0; n];
    // The connection through which each gear is first reached from the input (power flow).
    let mut reached_via: Vec<Option<String>> = vec![None; n];
    ratio[input] = Some(1.0);
    sense[input] = input_sense;
    let mut queue = VecDeque::from([input]);
    loop {
        while let Some(a) = queue.pop_front() {
            let ra = ratio[a].expect("queued gears have a ratio");
            for (b, factor, flip, what) in &edges[a] {
                let rb = ra * factor;
                let sb = sense[a] * flip;
                match ratio[*b] {
                    None => {
                        ratio[*b] = Some(rb);
                        sense[*b] = sb;
                        reached_via[*b] = Some(what.clone());
                        queue.push_back(*b);
                    }
                    Some(r) => {
                        if (r - rb).abs() > KINEMATIC_TOL * r.max(rb) || sense[*b] != sb {
                            return err(format!(
                            "{what}: inconsistent kinematics: gear {:?} would turn at {rb} × the input \
                             speed ({}) through {what}, but at {r} × ({}) through another path",
                            gears[*b].name,
                            if sb > 0.0 { "ccw" } else { "cw" },
                            if sense[*b] > 0.0 { "ccw" } else { "cw" },
                        ));
                        }
                    }
                }
            }
        }
        let mut signed: Vec<Option<f64>> = ratio
            .iter()
            .zip(&sense)
            .map(|(r, s)| r.map(|r| r * s))
            .collect();
        let set = super::planetary::kinematic_step(stages, gears, &mut signed)?;
        if set.is_empty() {
            break;
        }
        for g in set {
            let v = signed[g].expect("set by the stage");
            ratio[g] = Some(v.abs());
            sense[g] = v.signum() * (v != 0.0) as u8 as f64;
            reached_via[g] = Some(format!("the planetary stage of {:?}", gears[g].name));
            queue.push_back(g);
        }
    }
    // The mesh deflection compresses the pinion's drive flanks (docs/train.md), so the pinion
    // must be the member that drives the mesh: one reached from the input through that very
    // mesh is driven by it and could never carry load.
    for (i, m) in meshes.iter().enumerate() {
        if reached_via[m.pinion].as_deref() == Some(format!("mesh[{i}]").as_str()) {
            return err(format!(
                "mesh[{i}].pinion = {:?}: this gear is driven through mesh[{i}] by {:?} (power \
                 flows from the input gear {:?}); swap pinion and gear",
                gears[m.pinion].name, gears[m.gear].name, gears[input].name
            ));
        }
    }
    // Parts not driven by the input: each connected part needs a ground coupling.
    let mut part: Vec<Option<usize>> = vec![None; n];
    for start in 0..n {
        if ratio[start].is_some() || part[start].is_some() {
            continue;
        }
        let mut members = vec![start];
        part[start] = Some(start);
        let mut k = 0;
        while k < members.len() {
            for (b, ..) in &edges[members[k]] {
                if part[*b].is_none() {
                    part[*b] = Some(start);
                    members.push(*b);
                }
            }
            k += 1;
        }
        if !members.iter().any(|&g| gears[g].ground_stiffness > 0.0) {
            let names: Vec<_> = members.iter().map(|&g| gears[g].name.as_str()).collect();
            return err(format!(
                "gear {:?}: disconnected from the input gear {:?} and not held by a ground coupling \
                 (ground_stiffness) — the part [{}] would float freely",
                gears[start].name,
                gears[input].name,
                names.join(", ")
            ));
        }
    }
    Ok((
        ratio.iter().map(|r| r.unwrap_or(0.0)).collect(),
        sense
            .iter()
            .map(|&s| if s == 0.0 { 1.0 } else { s })
            .collect(),
    ))
}

/// Largest ratio between the masses of a train on the line of action (`J/r_b²` of every gear,
/// and `m` of every translating gear): far beyond any real train (a watch gear against a ship
/// gear is about 1e9), and small enough that the rigid-body rotation can still be told apart
/// from the elastic modes in double precision (the reduction works with `M`-orthonormal
/// modes, whose separation degrades with the square root of this ratio).
const MAX_MASS_SPREAD: f64 = 1e10;

/// The checks of the gears' settable values (inertias) that reading a scene makes, for a
/// scene changed after validation: an FMU's rebuild after `fmi2SetReal` applies the checks of
/// `simulate` (issue 34: an inertia of 1e-158 hung the reduction's SVD).
pub(crate) fn recheck_gears(gears: &[Gear]) -> std::result::Result<(), String> {
    for (i, g) in gears.iter().enumerate() {
        super::checks::gear_compliance(&format!("gear[{i}]"), g.base_radius, g.inertia)
            .map_err(|e| e.to_string())?;
    }
    mass_spread(gears).map_err(|e| e.to_string())
}

/// Checks that the train's masses lie within [`MAX_MASS_SPREAD`] of each other.
fn mass_spread(gears: &[Gear]) -> Result<()> {
    let masses = gears.iter().enumerate().flat_map(|(i, g)| {
        let rotation = (
            format!("gear[{i}].inertia = {:e}", g.inertia),
            g.inertia / g.base_radius.powi(2),
        );
        let translation = g.mass.map(|m| (format!("gear[{i}].mass = {m:e}"), m));
        std::iter::once(rotation).chain(translation)
    });
    let mut low: Option<(String, f64)> = None;
    let mut high: Option<(String, f64)> = None;
    for (field, m) in masses {
        if low.as_ref().is_none_or(|l| m < l.1) {
            low = Some((field.clone(), m));
        }
        if high.as_ref().is_none_or(|h| m > h.1) {
            high = Some((field, m));
        }
    }
    if let (Some((lf, l)), Some((hf, h))) = (low, high) {
        if !(h <= MAX_MASS_SPREAD * l) {
            return err(format!(
                "{hf} against {lf}: the train's masses on the line of action (J/r_b² and m) span \
                 {l:e} to {h:e} kg, a ratio above {MAX_MASS_SPREAD:e}; the rigid-body rotation \
                 cannot be separated from the elastic modes in double precision"
            ));
        }
    }
    Ok(())
}

/// A runout moves the operating centre distance, and with it the pressure angle, the
/// contact ratio, the backlash and the mesh position (`docs/errors.md`): every mesh of a gear
/// with runout needs its operating pressure angle.
fn runout_pressure_angle(gears: &[Gear], meshes: &[Mesh], form: MeshForm) -> Result<()> {
    for (i, m) in meshes.iter().enumerate() {
        let runout = [m.pinion, m.gear]
            .into_iter()
            .find(|&g| (gears[g].errors.runout).is_some_and(|r| r.amplitude != 0.0));
        if let (Some(g), true) = (runout, m.pressure_angle == 0.0) {
            return err(format!(
                "{}: missing; gear {:?} has a runout, which moves the operating centre distance \
                 and with it the pressure angle, contact ratio and backlash, so the mesh needs \
                 its operating pressure angle (degrees)",
                mesh_field(form, i, "pressure_angle"),
                gears[g].name
            ));
        }
    }
    Ok(())
}

/// A gear with errors in several meshes sees them at different places around its rim: the
/// runout phase and the tooth in mesh follow from the lines of action, so each of its meshes
/// must give `centre_angle` and `pressure_angle` (`docs/errors.md`).
fn errors_geometry(gears: &[Gear], meshes: &[TrainMeshSpec]) -> Result<()> {
    for g in gears.iter().filter(|g| !g.errors.is_zero()) {
        let mine: Vec<(usize, &TrainMeshSpec)> = meshes
            .iter()
            .enumerate()
            .filter(|(_, m)| m.pinion == g.name || m.gear == g.name)
            .collect();
        if mine.len() < 2 {
            continue;
        }
        for (i, m) in mine {
            for (key, given) in [
                ("centre_angle", m.centre_angle.is_some()),
                ("pressure_angle", m.pressure_angle.is_some()),
            ] {
                if !given {
                    return err(format!(
                        "mesh[{i}].{key}: missing; gear {:?} has runout or pitch errors and takes \
                         part in several meshes, so where each mesh sits around it must be given",
                        g.name
                    ));
                }
            }
        }
    }
    Ok(())
}
