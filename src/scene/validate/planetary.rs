//! Validation of planetary stages (`docs/planetary.md`): the `[[carrier]]` tables become
//! bodies of the scene (entries of `Scene::gears` without teeth), the gears that name a
//! carrier become its planets, and the meshes between them the stage's sun → planet and
//! planet → ring meshes. Kinematics (Willis) and the balanced load of a stage are resolved
//! here; what the planetary kernel does not carry yet is refused with the reason.

use super::checks::{bounded, err, finite, valid_identifier as identifier};
use crate::scene::spec::{
    mesh_field, CarrierSpec, GearSpec, MeshForm, MeshSpec, PairStiffnessSpec, StiffnessSpec,
};
use crate::scene::train::planetary::{
    assembly_residual, mesh_phases, planet_speed, torque_weights, willis_third,
};
use crate::scene::train::{Bearing, MeshForceModel, Planet, PlanetaryStage};
use crate::scene::{Gear, Mesh, SceneError};

type Result<T> = std::result::Result<T, SceneError>;

/// Relative tolerance of Willis' equation between speeds given by two paths.
const WILLIS_TOL: f64 = 1e-9;

/// Appends the carriers of `[[carrier]]` to `gears` (after the `[[gear]]` tables, so a carrier
/// is named like a gear by shafts, ports and `operating`).
pub(crate) fn carriers(
    specs: &[CarrierSpec],
    compliant: bool,
    gears: &mut Vec<Gear>,
) -> Result<()> {
    for (i, c) in specs.iter().enumerate() {
        let f = |key: &str| format!("carrier[{i}].{key}");
        if !identifier(&c.name) {
            return err(format!(
                "{} = {:?}: must be an identifier (it names output columns)",
                f("name"),
                c.name
            ));
        }
        if let Some(j) = gears.iter().position(|g| g.name == c.name) {
            return err(format!(
                "{} = {:?}: a gear or carrier has that name already (body {j})",
                f("name"),
                c.name
            ));
        }
        let radius = bounded(&f("radius"), c.radius)?;
        let inertia = bounded(&f("inertia"), c.inertia)?;
        super::checks::gear_compliance(&format!("carrier[{i}]"), radius, inertia)?;
        let mass = c.mass.map(|m| bounded(&f("mass"), m)).transpose()?;
        let bearing = match (c.bearing_stiffness, compliant) {
            (Some(k), true) => Some(central_bearing(
                &f("bearing_stiffness"),
                &f("bearing_damping"),
                k,
                c.bearing_damping,
                mass,
                &f("mass"),
            )?),
            (None, _) if c.bearing_damping.is_some() => {
                return err(format!(
                    "{}: given without bearing_stiffness",
                    f("bearing_damping")
                ))
            }
            _ => None,
        };
        gears.push(Gear {
            name: c.name.clone(),
            teeth: 0,
            base_radius: radius,
            inertia,
            mass,
            bearing,
            ground_stiffness: bounded(&f("ground_stiffness"), c.ground_stiffness)?,
            ground_damping: bounded(&f("ground_damping"), c.ground_damping)?,
            errors: Default::default(),
        });
    }
    Ok(())
}

/// The bearing of a central member (sun, ring, carrier): its translations are in the rotating
/// carrier frame (Lin & Parker 1999), where an anisotropic support would turn with the frame
/// and make the stiffness time-varying; it must be isotropic.
fn central_bearing(
    field: &str,
    damping_field: &str,
    k: [f64; 2],
    c: Option<[f64; 2]>,
    mass: Option<f64>,
    mass_field: &str,
) -> Result<Bearing> {
    for (axis, v) in ["x", "y"].iter().zip(k) {
        if !(v.is_finite() && v > 0.0) {
            return err(format!(
                "{field}[{axis}] = {v}: bearing stiffness must be > 0"
            ));
        }
    }
    let c = c.unwrap_or([0.0, 0.0]);
    bounded(&format!("{damping_field}[x]"), c[0])?;
    bounded(&format!("{damping_field}[y]"), c[1])?;
    if k[0] != k[1] || c[0] != c[1] {
        return err(format!(
            "{field} = [{}, {}] (damping [{}, {}]): a central member of a planetary stage \
             translates in the rotating carrier frame (Lin & Parker 1999), where an anisotropic \
             support turns with the frame; give equal x and y values",
            k[0], k[1], c[0], c[1]
        ));
    }
    if mass.is_none() {
        return err(format!(
            "{mass_field}: missing; the bearing's translations need a mass in kg"
        ));
    }
    Ok(Bearing {
        stiffness: k,
        damping: c,
    })
}

/// Whether mesh `m` of the file joins a planet (a gear with a `carrier` key): its line of
/// action follows from the planet's position angle, not from `centre_angle`.
pub(crate) fn is_planet_mesh(gears: &[GearSpec], m: &MeshSpec) -> bool {
    gears
        .iter()
        .any(|g| g.carrier.is_some() && (g.name == m.pinion || g.name == m.gear))
}

/// The planetary stages of a scene: one per carrier, its planets the gears naming it, its sun
/// and ring the gears those planets mesh with. `gears` holds the `[[gear]]` tables first, then
/// the carriers; `meshes` are resolved. Checks the stage topology and what the first stage of
/// the planetary model carries.
pub(crate) fn stages(
    specs: &[GearSpec],
    carrier_specs: &[CarrierSpec],
    gears: &[Gear],
    meshes: &[Mesh],
    mesh_specs: &[MeshSpec],
    form: MeshForm,
    compliant: bool,
) -> Result<Vec<PlanetaryStage>> {
    let index = |name: &str| gears.iter().position(|g| g.name == name);
    for (i, g) in specs.iter().enumerate() {
        let f = |key: &str| format!("gear[{i}].{key}");
        if g.carrier.is_none() {
            for (key, given) in [
                ("position_angle", g.position_angle.is_some()),
                ("pin_error", g.pin_error.is_some()),
            ] {
                if given {
                    return err(format!(
                        "{}: only a planet (a gear with `carrier`) has it",
                        f(key)
                    ));
                }
            }
        }
        if g.internal && !meshes.iter().any(|m| m.gear == i) {
            return err(format!(
                "{} = true: an internal gear is the ring of a planetary stage, driven by its \
                 planets (mesh gear = {:?}); no mesh has it as gear",
                f("internal"),
                g.name
            ));
        }
    }
    let mut stages = Vec::new();
    for (ci, c) in carrier_specs.iter().enumerate() {
        let carrier = index(&c.name).expect("carriers are bodies");
        let mut planets: Vec<Planet> = Vec::new();
        let (mut sun, mut ring) = (None::<usize>, None::<usize>);
        for (i, g) in specs.iter().enumerate() {
            if g.carrier.as_deref() != Some(c.name.as_str()) {
                continue;
            }
            let f = |key: &str| format!("gear[{i}].{key}");
            if g.internal {
                return err(format!("{}: a planet has external teeth", f("internal")));
            }
            if g.ground_stiffness != 0.0 || g.ground_damping != 0.0 {
                return err(format!(
                    "{}: a planet turns freely on its pin; it has no ground coupling",
                    f("ground_stiffness")
                ));
            }
            if !compliant || gears[i].bearing.is_none() {
                return err(format!(
                    "{}: missing; a planet sits on its carrier's pin through a bearing \
                     [k_radial, k_tangential] (N/m), and model.bearings must be \"compliant\"",
                    f("bearing_stiffness")
                ));
            }
            let angle = match g.position_angle {
                Some(a) => finite(&f("position_angle"), a)?.to_radians(),
                None => {
                    return err(format!(
                        "{}: missing; a planet's position on its carrier (degrees)",
                        f("position_angle")
                    ))
                }
            };
            let pin_error = match g.pin_error {
                Some(e) => [
                    finite(&format!("{}[radial]", f("pin_error")), e[0])?,
                    finite(&format!("{}[tangential]", f("pin_error")), e[1])?,
                ],
                None => [0.0, 0.0],
            };
            let mut sun_mesh = None;
            let mut ring_mesh = None;
            for (n, m) in meshes.iter().enumerate() {
                let field = |key: &str| mesh_field(form, n, key);
                // The planet's mesh `n` with its sun or ring `member`: one of each per planet,
                // and one sun and one ring for all the carrier's planets.
                let record_central = |stage_member: &mut Option<usize>,
                                      planet_mesh: &mut Option<usize>,
                                      member: usize,
                                      what: &str,
                                      key: &str|
                 -> Result<()> {
                    if planet_mesh.replace(n).is_some() {
                        return err(format!(
                            "{}: planet {:?} meshes with a second {what}",
                            field(key),
                            g.name
                        ));
                    }
                    match *stage_member {
                        None => *stage_member = Some(member),
                        Some(s) if s != member => {
                            return err(format!(
                                "{} = {:?}: the planets of carrier {:?} mesh with one {what}, {:?}",
                                field(key),
                                gears[member].name,
                                c.name,
                                gears[s].name
                            ))
                        }
                        _ => {}
                    }
                    Ok(())
                };
                if m.gear == i {
                    if specs
                        .get(m.pinion)
                        .is_some_and(|p| p.internal || p.carrier.is_some())
                    {
                        return err(format!(
                            "{} = {:?}: a planet is driven by the sun (an external gear without \
                             carrier)",
                            field("pinion"),
                            gears[m.pinion].name
                        ));
                    }
                    record_central(&mut sun, &mut sun_mesh, m.pinion, "sun", "pinion")?;
                } else if m.pinion == i {
                    if !specs.get(m.gear).is_some_and(|r| r.internal) {
                        return err(format!(
                            "{} = {:?}: a planet drives the ring, a gear with internal = true",
                            field("gear"),
                            gears[m.gear].name
                        ));
                    }
                    record_central(&mut ring, &mut ring_mesh, m.gear, "ring", "gear")?;
                }
            }
            let (Some(sun_mesh), Some(ring_mesh)) = (sun_mesh, ring_mesh) else {
                return err(format!(
                    "gear[{i}] ({:?}): a planet meshes with the sun (mesh pinion = sun, gear = \
                     planet) and with the ring (mesh pinion = planet, gear = ring)",
                    g.name
                ));
            };
            planets.push(Planet {
                gear: i,
                angle,
                pin_error,
                sun_mesh,
                ring_mesh,
            });
        }
        let (Some(sun), Some(ring)) = (sun, ring) else {
            return err(format!(
                "carrier[{ci}] ({:?}): no planet names it (a planet is a [[gear]] with carrier = \
                 {:?})",
                c.name, c.name
            ));
        };
        for (member, what) in [(sun, "sun"), (ring, "ring")] {
            if let Some(b) = gears[member].bearing {
                if b.stiffness[0] != b.stiffness[1] || b.damping[0] != b.damping[1] {
                    return err(format!(
                        "gear[{member}].bearing_stiffness = [{}, {}]: the {what} of a planetary \
                         stage translates in the rotating carrier frame (Lin & Parker 1999), \
                         where an anisotropic support turns with the frame; give equal x and y \
                         values",
                        b.stiffness[0], b.stiffness[1]
                    ));
                }
            }
        }
        for p in &planets {
            for n in [p.sun_mesh, p.ring_mesh] {
                check_geometry_source(form, n, &mesh_specs[n], n == p.ring_mesh)?;
                check_mesh(form, n, &mesh_specs[n])?;
            }
        }
        same_pressure_angles(form, &planets, meshes)?;
        // Other meshes on a stage member would mix the carrier frame with the scene frame.
        for (n, m) in meshes.iter().enumerate() {
            let in_stage = planets.iter().any(|p| p.sun_mesh == n || p.ring_mesh == n);
            let touches =
                [sun, ring, carrier].contains(&m.pinion) || [sun, ring, carrier].contains(&m.gear);
            if touches && !in_stage {
                return err(format!(
                    "{}: gears {:?} and {:?}: a member of the planetary stage of carrier {:?} \
                     meshes only inside the stage (its translations are in the carrier frame); \
                     couple other stages through a [[shaft]]",
                    mesh_field(form, n, "pinion"),
                    gears[m.pinion].name,
                    gears[m.gear].name,
                    c.name
                ));
            }
        }
        let fixed = match &c.fixed {
            Some(name) => match index(name) {
                Some(g) if [sun, ring, carrier].contains(&g) => g,
                _ => {
                    return err(format!(
                        "carrier[{ci}].fixed = {name:?}: must name the stage's sun {:?}, ring {:?} \
                         or carrier {:?}",
                        gears[sun].name, gears[ring].name, c.name
                    ))
                }
            },
            None => {
                let held: Vec<usize> = [sun, ring, carrier]
                    .into_iter()
                    .filter(|&g| gears[g].ground_stiffness > 0.0)
                    .collect();
                match held[..] {
                    [g] => g,
                    _ => {
                        return err(format!(
                            "carrier[{ci}].fixed: missing; {} of the central members (sun {:?}, \
                             ring {:?}, carrier {:?}) have a ground_stiffness, so name the one \
                             whose nominal speed is zero",
                            held.len(),
                            gears[sun].name,
                            gears[ring].name,
                            c.name
                        ))
                    }
                }
            }
        };
        stages.push(PlanetaryStage {
            carrier,
            sun,
            ring,
            fixed,
            planets,
            sense: 1.0,
            relative_sense: 1.0,
            gyroscopic: c.gyroscopic,
        });
    }
    Ok(stages)
}

/// The stiffness sources from the gear geometry on a stage mesh (`docs/planetary.md`,
/// "Geometry stiffness"):
///
/// - ring (internal) mesh: refused with the reason. The potential-energy method of
///   `crate::mesh::geometry` (Liu 2007 Ch. 2 / Liao et al. 2025 eq. (1)–(3) with the Sainsot
///   et al. 2004 fillet foundation) is written for an external tooth: its bending, shear and
///   compression energies integrate an involute flank from the base circle out to the tip of a
///   tooth that narrows outwards, on a full-disc body whose fillet-foundation coefficients were
///   fitted for external gears. An internal tooth is the space of such a tooth: its flank is
///   concave, the tooth widens towards its root outside the pitch circle, and its rim is a thin
///   ring whose bending (Chen & Shao 2013, "Mesh stiffness of an internal spur gear pair with
///   ring gear rim deformation", Mech. Mach. Theory 69) is not a fillet foundation. None of
///   those terms is in the method here;
/// - sun (external) mesh: `geometry` runs, its cycle origin moved to the pitch point
///   ([`geometry_origins`], eq. PL5); `helical` pairs are refused (a helical pair's axial
///   forces and sliding friction are outside the stage's planar model).
fn check_geometry_source(form: MeshForm, n: usize, m: &MeshSpec, ring: bool) -> Result<()> {
    let (field, kind) = match (&m.stiffness, &m.pairs) {
        (Some(StiffnessSpec::Geometry { .. }), _) => ("stiffness", "geometry"),
        (Some(StiffnessSpec::Helical { .. }), _) => ("stiffness", "helical"),
        (_, Some(PairStiffnessSpec::Geometry { .. })) => ("pairs", "geometry"),
        (_, Some(PairStiffnessSpec::Helical { .. })) => ("pairs", "helical"),
        _ => return Ok(()),
    };
    let why = match (ring, kind) {
        (true, _) => {
            "an internal (ring) mesh: the potential-energy method here integrates an external \
             tooth (an involute flank narrowing from the base circle to the tip, Sainsot's \
             fillet foundation of a full gear body); the ring's concave tooth, which widens \
             towards its root, and its thin rim (Chen & Shao 2013) are not in it"
        }
        (false, "geometry") => return Ok(()),
        (false, _) => {
            "a sun mesh of a planetary stage: a helical pair's axial forces and sliding \
             friction are outside the stage's planar model (tooth friction is not available on \
             stage meshes)"
        }
    };
    err(format!(
        "{}: kind = \"{kind}\" on {why}; give the stiffness by values (constant, rectangular, \
         trapezoidal, fourier, table, or [mesh.pairs] rectangular/table)",
        mesh_field(form, n, field)
    ))
}

/// Whether a mesh's stiffness comes from the gear geometry (either source).
fn geometry_source(m: &MeshSpec) -> bool {
    matches!(m.stiffness, Some(StiffnessSpec::Geometry { .. }))
        || matches!(m.pairs, Some(PairStiffnessSpec::Geometry { .. }))
}

/// Moves the cycle origin of every stage sun mesh with a geometry stiffness to the pitch point
/// (`docs/planetary.md`, "Geometry stiffness", eq. PL5). The stage phase `γ` of a mesh
/// (PL1–PL3, or its override) counts from a loaded pair passing the pitch point P; the
/// geometry curve counts from its own origin: the lumped curve from a pair leaving at the
/// pinion tip E (pair `k` at `x_E + p_b(s + k)`), the tooth-pair window from `e` mesh cycles
/// before the path start A (slot `j` at `ξ = s + c + 2e − 1 − j`, `x = x_A + p_b(ξ − e)`). A
/// pair is at P when `s ≡ s_P`, `s_P = (x_P − x_E)/p_b − e` (e = 0 for the lumped curve), so
/// the mesh runs at `γ + s_P`.
pub(crate) fn geometry_origins(
    stages: &[PlanetaryStage],
    meshes: &mut [Mesh],
    mesh_specs: &[MeshSpec],
    form: MeshForm,
) -> Result<()> {
    for n in stages
        .iter()
        .flat_map(|st| st.planets.iter().map(|p| p.sun_mesh))
    {
        let m = &mesh_specs[n];
        let (geometry, field, extension) = match (&m.stiffness, &m.pairs) {
            (Some(StiffnessSpec::Geometry { geometry, .. }), _) => (geometry, "stiffness", 0.0),
            (_, Some(PairStiffnessSpec::Geometry { geometry, etc, .. })) => {
                let e = if *etc {
                    crate::mesh::geometry::pairs::ETC_EXTENSION
                } else {
                    0.0
                };
                (geometry, "pairs", e)
            }
            _ => continue,
        };
        let prefix = format!("{}.geometry.", mesh_field(form, n, field));
        let pair = crate::mesh::geometry::Pair::new(geometry, &prefix).map_err(SceneError)?;
        let phase = meshes[n].phase + pair.pitch_point_phase() - extension;
        meshes[n].phase = phase - phase.floor();
    }
    Ok(())
}

/// The static pinion torque of a stage's sun mesh, the default load of its geometry stiffness
/// (`docs/planetary.md`, "Geometry stiffness"): the sun's static torque shared by the stage's
/// N planets, `T_s/N`, with `T_s = T_in |w_s/w_h|` (eq. P9) when the input gear `h` is a
/// central member of the stage. `None` for any other mesh; `Some(0.0)` when the input is
/// elsewhere (the mesh then names its `torque`).
pub(crate) fn sun_mesh_torque(
    specs: &[GearSpec],
    gears: &[Gear],
    mesh_specs: &[MeshSpec],
    n: usize,
    input: usize,
    input_torque: f64,
) -> Option<f64> {
    let m = &mesh_specs[n];
    let planet = specs
        .iter()
        .find(|g| g.name == m.gear && g.carrier.is_some())?;
    let carrier = planet.carrier.as_deref()?;
    let planets = specs
        .iter()
        .filter(|g| g.carrier.as_deref() == Some(carrier))
        .count();
    let ring_mesh = mesh_specs.iter().find(|r| r.pinion == planet.name)?;
    let index = |name: &str| gears.iter().position(|g| g.name == name);
    let (sun, ring, carrier) = (index(&m.pinion)?, index(&ring_mesh.gear)?, index(carrier)?);
    let alpha_s = match m.pressure_angle {
        Some(deg) => deg.to_radians(),
        None => match &m.stiffness {
            Some(spec) => super::geometry::working_pressure_angle(spec, "").ok()??.0,
            None => {
                super::geometry::pair_working_pressure_angle(m.pairs.as_ref()?, "")
                    .ok()??
                    .0
            }
        },
    };
    let alpha_r = ring_mesh.pressure_angle.map_or(alpha_s, f64::to_radians);
    let w = torque_weights(
        gears[sun].base_radius,
        gears[ring].base_radius,
        gears[carrier].base_radius,
        alpha_s,
        alpha_r,
    );
    let sun_torque = match [sun, ring, carrier].iter().position(|&h| h == input) {
        Some(h) => input_torque * (w[0] / w[h]).abs(),
        None => 0.0,
    };
    Some(sun_torque / planets as f64)
}

/// What the first stage of the planetary model carries on a stage mesh besides its stiffness
/// source ([`check_geometry_source`]): the pressure angle, and no tooth friction yet.
fn check_mesh(form: MeshForm, n: usize, m: &MeshSpec) -> Result<()> {
    // A geometry source gives its working pressure angle.
    if m.pressure_angle.is_none() && !geometry_source(m) {
        return err(format!(
            "{}: missing; a planetary mesh's line of action is set by the planet's position \
             angle and the pressure angle (degrees)",
            mesh_field(form, n, "pressure_angle")
        ));
    }
    if m.friction.is_some() {
        return err(format!(
            "{}: tooth friction on a planetary mesh is not available yet",
            mesh_field(form, n, "friction")
        ));
    }
    Ok(())
}

/// One step of the stage kinematics inside the walk of the drivetrain's kinematics: for every
/// stage with two central speeds known (the fixed member counts, at zero), the third by
/// Willis (eq. P1) and the planets (eq. P2). `speed` holds signed nominal speeds over the input
/// speed. Returns the gears it set, or the message of a stage whose known speeds contradict
/// Willis.
pub(crate) fn kinematic_step(
    stages: &[PlanetaryStage],
    gears: &[Gear],
    speed: &mut [Option<f64>],
) -> Result<Vec<usize>> {
    let mut set = Vec::new();
    for st in stages {
        if let Some(v) = speed[st.fixed].filter(|&v| v != 0.0) {
            return err(format!(
                "carrier {:?}: its fixed member {:?} would turn at {v} × the input speed (it is \
                 the input gear or is driven through a shaft); a fixed member stands still",
                gears[st.carrier].name, gears[st.fixed].name
            ));
        }
        let members = [st.sun, st.ring, st.carrier];
        let known = members.map(|g| {
            if g == st.fixed {
                Some(speed[g].unwrap_or(0.0))
            } else {
                speed[g]
            }
        });
        let z_s = gears[st.sun].teeth as f64;
        let z_r = gears[st.ring].teeth as f64;
        let Some(all) = willis_third(z_s, z_r, known) else {
            continue;
        };
        let residual = z_s * (all[0] - all[2]) + z_r * (all[1] - all[2]);
        let scale = z_s * all[0].abs() + z_r * all[1].abs() + (z_s + z_r) * all[2].abs();
        if residual.abs() > WILLIS_TOL * scale.max(f64::MIN_POSITIVE) {
            return err(format!(
                "carrier {:?}: inconsistent kinematics: the sun {:?}, ring {:?} and carrier turn \
                 at {}, {}, {} × the input speed, which breaks Willis' equation \
                 Z_s(ω_s − ω_c) + Z_r(ω_r − ω_c) = 0 (teeth {}, {})",
                gears[st.carrier].name,
                gears[st.sun].name,
                gears[st.ring].name,
                all[0],
                all[1],
                all[2],
                z_s,
                z_r
            ));
        }
        for (g, v) in members.into_iter().zip(all) {
            if speed[g].is_none() {
                speed[g] = Some(v);
                set.push(g);
            }
        }
        for p in &st.planets {
            if speed[p.gear].is_none() {
                let z_p = gears[p.gear].teeth as f64;
                speed[p.gear] = Some(planet_speed(z_s, z_p, all[0], all[2]));
                set.push(p.gear);
            }
        }
    }
    Ok(set)
}

/// After the kinematics: each stage's sense σ and the mesh cycles per input revolution of its
/// meshes, `Z_s |ω_s − ω_c|` (eq. P2). σ is the sense of the sun's static torque (eq. P3):
/// the flanks it loads are the drive flanks of every stage mesh, so the static mesh forces are
/// positive whichever member drives. With the input on a central member and an input torque,
/// the sun's torque follows from the torque weights (eq. P9); otherwise σ is the sun's
/// rotation sense relative to the carrier (the sun driving).
pub(crate) fn finish_kinematics(
    stages: &mut [PlanetaryStage],
    gears: &[Gear],
    meshes: &mut [Mesh],
    (speed_ratio, rotation): (&[f64], &[f64]),
    (input, input_torque): (usize, f64),
) {
    for st in stages.iter_mut() {
        let signed = |g: usize| speed_ratio[g] * rotation[g];
        let relative = signed(st.sun) - signed(st.carrier);
        let w = stage_torque_weights(st, gears, meshes);
        let sun_torque = [st.sun, st.ring, st.carrier]
            .iter()
            .position(|&g| g == input)
            .map(|a| input_torque * rotation[input] * w[0] / w[a])
            .filter(|&t| t != 0.0);
        st.relative_sense = if relative < 0.0 { -1.0 } else { 1.0 };
        st.sense = match sun_torque {
            Some(t) => t.signum(),
            None => st.relative_sense,
        };
        let cycles = gears[st.sun].teeth as f64 * relative.abs();
        for p in &st.planets {
            meshes[p.sun_mesh].cycles_per_input_rev = cycles;
            meshes[p.ring_mesh].cycles_per_input_rev = cycles;
        }
    }
}

/// Every planet of a stage meshes at the same pressure angles: the torque weights (eq. P9),
/// the stage's rigid-body motion and the phasing rules (eq. PL1–PL3) are written for one sun
/// and one ring pressure angle.
fn same_pressure_angles(form: MeshForm, planets: &[Planet], meshes: &[Mesh]) -> Result<()> {
    let first = &planets[0];
    for p in &planets[1..] {
        for (n, reference, what) in [
            (p.sun_mesh, first.sun_mesh, "sun"),
            (p.ring_mesh, first.ring_mesh, "ring"),
        ] {
            let (a, b) = (meshes[n].pressure_angle, meshes[reference].pressure_angle);
            if a != b {
                return err(format!(
                    "{} = {}: every planet's {what} mesh has the same pressure angle; {} has {}                      (the stage's torque balance and mesh phasing are written for one angle)",
                    mesh_field(form, n, "pressure_angle"),
                    a.to_degrees(),
                    mesh_field(form, reference, "pressure_angle"),
                    b.to_degrees()
                ));
            }
        }
    }
    Ok(())
}

/// The mesh phases of every stage mesh whose `phase` the file does not give, by the rules of
/// Parker & Lin (2004) ([`mesh_phases`], eq. PL1–PL3), anchored at the first scene mesh when
/// it belongs to the stage (its phase is 0 by definition) and else at the phase of the first
/// planet's sun mesh. Where a derived phase matters (a stage mesh whose stiffness, STE or tooth
/// pairs vary with the phase), every planet must sit where it fits between sun and ring,
/// `(Z_s + Z_r) Δψ/2π` an integer, or PL1 and PL2 contradict each other.
pub(crate) fn phasing(
    stages: &[PlanetaryStage],
    gears: &[Gear],
    meshes: &mut [Mesh],
    mesh_specs: &[MeshSpec],
) -> Result<()> {
    for st in stages {
        let z = |g: usize| gears[g].teeth as f64;
        let first = &st.planets[0];
        let mut derived = Vec::new();
        for p in &st.planets {
            let dpsi = p.angle - first.angle;
            let (sun, ring) =
                mesh_phases((z(st.sun), z(st.ring), z(p.gear)), dpsi, st.relative_sense);
            derived.push((p.sun_mesh, sun));
            derived.push((p.ring_mesh, ring));
        }
        let base = match derived.iter().find(|(n, _)| *n == 0) {
            Some(&(_, d)) => -d,
            None => meshes[first.sun_mesh].phase,
        };
        let given = |n: usize| n == 0 || mesh_specs[n].phase.is_some();
        if derived.iter().all(|&(n, _)| given(n)) {
            continue;
        }
        let varies = st
            .planets
            .iter()
            .flat_map(|p| [p.sun_mesh, p.ring_mesh])
            .any(|n| varies_with_phase(&meshes[n]));
        if varies {
            for p in &st.planets {
                let residual = assembly_residual(z(st.sun), z(st.ring), p.angle - first.angle);
                if residual > ASSEMBLY_TOL {
                    let i = p.gear;
                    return err(format!(
                        "gear[{i}].position_angle = {}: a planet fits between the sun ({} teeth)                          and the ring ({} teeth) only where (Z_s + Z_r)·Δψ/360° is an integer                          (Δψ from the first planet, {}°); here it is {} off. The stage's mesh                          phases follow from the planet positions (Parker & Lin 2004,                          docs/planetary.md): move the planet, or give every stage mesh's `phase`",
                        p.angle.to_degrees(),
                        z(st.sun),
                        z(st.ring),
                        first.angle.to_degrees(),
                        residual
                    ));
                }
            }
        }
        for (n, d) in derived {
            if !given(n) {
                let phase = base + d;
                meshes[n].phase = phase - phase.floor();
            }
        }
    }
    Ok(())
}

/// Planet positions within this many "teeth" of `(Z_s + Z_r)Δψ/2π` to an integer fit (the
/// angles are given in degrees with finite digits).
const ASSEMBLY_TOL: f64 = 1e-6;

/// Whether a mesh's excitation depends on its phase: a varying stiffness, an STE, tooth pairs.
fn varies_with_phase(m: &Mesh) -> bool {
    match &m.force {
        MeshForceModel::Lumped { stiffness, ste } => {
            stiffness.maximum() != stiffness.minimum().0 || !ste.is_zero()
        }
        MeshForceModel::Pairs { .. } => true,
    }
}

/// The stage's [`torque_weights`] from its members' radii and its first planet's pressure
/// angles (the kinematics and the balanced load both read them there).
fn stage_torque_weights(st: &PlanetaryStage, gears: &[Gear], meshes: &[Mesh]) -> [f64; 3] {
    let p = &st.planets[0];
    torque_weights(
        gears[st.sun].base_radius,
        gears[st.ring].base_radius,
        gears[st.carrier].base_radius,
        meshes[p.sun_mesh].pressure_angle,
        meshes[p.ring_mesh].pressure_angle,
    )
}

/// The balanced load of a scene with planetary stages (eq. P9): the input and the output are
/// central members of one stage, the third member reacts. Torques counted in the stage's
/// sense σ are `T̃_h = λ w_h` ([`torque_weights`]); with `ρ_h = σ·rotation_h` the input torque
/// is `T̃_a = ρ_a T_in` and the load (a magnitude resisting the output's nominal rotation)
/// `T̃_b = −ρ_b T_load`, so `T_load = −ρ_a ρ_b T_in w_b / w_a`.
pub(crate) fn balanced_load(
    stages: &[PlanetaryStage],
    gears: &[Gear],
    meshes: &[Mesh],
    rotation: &[f64],
    (input, output): (usize, usize),
    input_torque: f64,
) -> Result<f64> {
    for st in stages {
        let members = [st.sun, st.ring, st.carrier];
        let (Some(a), Some(b)) = (
            members.iter().position(|&g| g == input),
            members.iter().position(|&g| g == output),
        ) else {
            continue;
        };
        let w = stage_torque_weights(st, gears, meshes);
        let rho = |g: usize| st.sense * rotation[g];
        return Ok(-rho(input) * rho(output) * input_torque * w[b] / w[a]);
    }
    err(format!(
        "operating.load_torque: missing; the input gear {:?} and the output gear {:?} are not \
         two central members of one planetary stage, so give the load torque (N·m)",
        gears[input].name, gears[output].name
    ))
}
