//! The `geometry` stiffness source of both scene formats (the single pair's `[mesh]` and a
//! drivetrain's `[[mesh]]`): the gear pair defines the bodies of its gears (base radius, and
//! with a density the inertia and mass of the solid disc), is checked against the scene's
//! gears, and its stiffness curve is computed once, at scene load, then handed to the model as
//! an existing form (piecewise-linear `table` pieces or a `fourier` series), so the dynamic
//! model, the solvers and the FMU see nothing new. Keys: `docs/model.md` ("Gears"),
//! `docs/train.md` ("Gears and geometry meshes"), `docs/stiffness.md`.

use super::checks::{bounded, finite};
use crate::mesh::geometry::{CurveOptions, MeshModel, Pair, PairCurve};
use crate::mesh::MeshStiffness;
use crate::scene::spec::{GeometryForm, PairStiffnessSpec, StiffnessSpec};
use crate::scene::SceneError;

type Result<T> = std::result::Result<T, SceneError>;

/// Largest relative difference between a given base radius and the geometry's
/// `m z cos α / 2` (the given value is kept when within it, so that rounded radii typed from
/// a drawing still load; beyond it the file describes two different gears).
pub(crate) const BASE_RADIUS_TOL: f64 = 1e-4;

/// What the geometry of one gear defines for the dynamic model: its base radius, and, with a
/// density (from `density` or a `material`), the inertia and mass of a solid disc between
/// bore and pitch circle ([`crate::mesh::geometry::Gear::inertia`]).
#[derive(Debug, Clone)]
pub(crate) struct GearBody {
    /// TOML path of the geometry's gear table, for messages.
    pub field: String,
    pub base_radius: f64,
    pub inertia: Option<f64>,
    pub mass: Option<f64>,
}

impl GearBody {
    fn new(field: String, g: &crate::mesh::geometry::Gear) -> GearBody {
        GearBody {
            field,
            base_radius: g.r_base,
            inertia: g.inertia(),
            mass: g.mass(),
        }
    }
}

/// The bodies of pinion and gear of a geometry stiffness spec, `None` for other sources;
/// `prefix` is the TOML path of the stiffness table (`mesh.stiffness` or `mesh[i].stiffness`).
pub(crate) fn bodies(spec: &StiffnessSpec, prefix: &str) -> Result<Option<[GearBody; 2]>> {
    let StiffnessSpec::Geometry { geometry, .. } = spec else {
        return Ok(None);
    };
    let geo = format!("{prefix}.geometry.");
    let pair = Pair::new(geometry, &geo).map_err(SceneError)?;
    Ok(Some([
        GearBody::new(format!("{geo}pinion"), &pair.pinion),
        GearBody::new(format!("{geo}gear"), &pair.gear),
    ]))
}

/// The working (operating) pressure angle α_w of a geometry stiffness spec, rad, with the
/// TOML path of its gear-pair table; `None` for other sources. The pair sits at its
/// zero-backlash centre distance, `inv α_w = inv α + 2 tan α (x1 + x2)/(z1 + z2)`
/// ([`Pair`]), so α_w = α for unshifted gears.
pub(crate) fn working_pressure_angle(
    spec: &StiffnessSpec,
    prefix: &str,
) -> Result<Option<(f64, String)>> {
    let StiffnessSpec::Geometry { geometry, .. } = spec else {
        return Ok(None);
    };
    let geo = format!("{prefix}.geometry.");
    let pair = Pair::new(geometry, &geo).map_err(SceneError)?;
    Ok(Some((pair.alpha_w, format!("{prefix}.geometry"))))
}

/// The working pressure angle α_w of `[mesh.pairs] kind = "geometry"`, as
/// [`working_pressure_angle`] for the stiffness source; `None` for other pair kinds.
pub(crate) fn pair_working_pressure_angle(
    spec: &PairStiffnessSpec,
    prefix: &str,
) -> Result<Option<(f64, String)>> {
    let PairStiffnessSpec::Geometry { geometry, .. } = spec else {
        return Ok(None);
    };
    let pair = Pair::new(geometry, &format!("{prefix}.geometry.")).map_err(SceneError)?;
    Ok(Some((pair.alpha_w, format!("{prefix}.geometry"))))
}

/// A gear's base radius: the given value (checked against the geometry's within
/// [`BASE_RADIUS_TOL`]) or the geometry's. `field` is the gear table, e.g. `gear[0]`.
pub(crate) fn base_radius(
    field: &str,
    given: Option<f64>,
    derived: Option<&GearBody>,
) -> Result<f64> {
    match (given, derived) {
        (Some(b), Some(d)) => {
            let b = bounded(&format!("{field}.base_radius"), b)?;
            if ((b - d.base_radius) / d.base_radius).abs() > BASE_RADIUS_TOL {
                return Err(SceneError(format!(
                    "{field}.base_radius = {b}: differs from the base radius m·z·cos α/2 = {} m of \
                     {} by more than {BASE_RADIUS_TOL:e} (relative); omit base_radius to use the \
                     geometry's",
                    d.base_radius, d.field
                )));
            }
            Ok(b)
        }
        (Some(b), None) => bounded(&format!("{field}.base_radius"), b),
        (None, Some(d)) => Ok(d.base_radius),
        (None, None) => Err(SceneError(format!(
            "{field}.base_radius: missing; give the base-circle radius in m (it is derived only \
             for a gear of a kind = \"geometry\" mesh stiffness)"
        ))),
    }
}

/// A gear's inertia (`key = "inertia"`) or mass (`key = "mass"`): the given value wins (a real
/// gear body with web, hub and shaft is not the solid disc); otherwise the geometry's disc.
pub(crate) fn body_value(
    field: &str,
    key: &str,
    given: Option<f64>,
    derived: Option<(&GearBody, Option<f64>)>,
) -> Result<f64> {
    let unit = if key == "mass" { "kg" } else { "kg·m²" };
    match (given, derived) {
        (Some(v), _) => bounded(&format!("{field}.{key}"), v),
        (None, Some((_, Some(v)))) => Ok(v),
        (None, Some((d, None))) => Err(SceneError(format!(
            "{field}.{key}: missing; give it in {unit}, or a density (or material = \"steel\") in \
             {} so that it is derived from the geometry",
            d.field
        ))),
        (None, None) => Err(SceneError(format!(
            "{field}.{key}: missing; give it in {unit} (it is derived only for a gear of a \
             kind = \"geometry\" mesh stiffness)"
        ))),
    }
}

/// One gear of a mesh as the dynamic model sees it, for the checks against the geometry.
pub(crate) struct MeshGear<'a> {
    /// TOML path naming the gear in the mesh (`mesh.pinion`, `mesh[1].gear`).
    pub which: String,
    pub name: &'a str,
    pub teeth: u32,
    pub base_radius: f64,
}

/// The mesh model of the gear pair `geometry` (the `geometry` table of `field`), checked
/// against the dynamic model's gears: they must be the geometry's gears.
fn mesh_model(
    geometry: &crate::mesh::geometry::GearPairSpec,
    field: &str,
    gears: &[MeshGear; 2],
) -> Result<MeshModel> {
    let prefix = format!("{field}.geometry.");
    let model = MeshModel::new(geometry, &prefix).map_err(SceneError)?;
    for (body, derived, table) in [
        (&gears[0], &model.pair.pinion, "pinion"),
        (&gears[1], &model.pair.gear, "gear"),
    ] {
        let which = &body.which;
        if body.teeth != derived.teeth {
            return Err(SceneError(format!(
                "{which} ({:?}).teeth = {}: differs from {prefix}{table}.teeth = {}",
                body.name, body.teeth, derived.teeth
            )));
        }
        if ((body.base_radius - derived.r_base) / derived.r_base).abs() > BASE_RADIUS_TOL {
            return Err(SceneError(format!(
                "{which} ({:?}).base_radius = {}: differs from the geometry's base radius m·z·cos α/2 = {} m \
                 by more than {BASE_RADIUS_TOL:e} (relative)",
                body.name, body.base_radius, derived.r_base
            )));
        }
    }
    Ok(model)
}

/// The pinion torque of a load-dependent geometry stiffness: `given` (`field.torque`) or the
/// scene's static pinion torque `(source, value)`.
fn geometry_torque(given: Option<f64>, field: &str, torque: (&str, f64)) -> Result<f64> {
    match given {
        Some(t) => bounded(&format!("{field}.torque"), t),
        None => {
            let (source, t) = torque;
            let t = finite(source, t)?;
            if !(t > 0.0) {
                return Err(SceneError(format!(
                    "{source} = {t}: the geometry stiffness is load dependent and needs a \
                     positive pinion torque (or set {field}.torque)"
                )));
            }
            Ok(t)
        }
    }
}

/// The per-tooth-pair curve of `[mesh.pairs] kind = "geometry"` (`field` = `mesh[i].pairs`):
/// the pair's stiffness over its window, with the ETC extension when `etc`
/// ([`crate::mesh::geometry::pairs`]).
pub(crate) fn pair_curve(
    spec: &PairStiffnessSpec,
    field: &str,
    gears: [MeshGear; 2],
    torque: (&str, f64),
) -> Result<(PairCurve, f64)> {
    let PairStiffnessSpec::Geometry {
        torque: given_torque,
        etc,
        geometry,
    } = spec
    else {
        unreachable!("called for the geometry pairs only");
    };
    let model = mesh_model(geometry, field, &gears)?;
    let torque = geometry_torque(*given_torque, field, torque)?;
    let extension = if *etc {
        crate::mesh::geometry::pairs::ETC_EXTENSION
    } else {
        0.0
    };
    let curve = model
        .pair_curve(torque, extension)
        .map_err(|e| SceneError(format!("{field}: {e}")))?;
    Ok((curve, model.pair.alpha_w))
}

/// Resolves a `StiffnessSpec::Geometry` of the mesh whose stiffness table is `field`
/// (`mesh.stiffness` or `mesh[i].stiffness`), for both scene formats. `torque` is the default
/// pinion torque of the load-dependent curve, with the field it comes from.
pub(crate) fn stiffness(
    spec: &StiffnessSpec,
    field: &str,
    gears: [MeshGear; 2],
    torque: (&str, f64),
) -> Result<MeshStiffness> {
    let StiffnessSpec::Geometry {
        torque: given_torque,
        etc,
        form,
        harmonics,
        phase,
        geometry,
    } = spec
    else {
        unreachable!("called for the geometry source only");
    };
    let model = mesh_model(geometry, field, &gears)?;
    let torque = geometry_torque(*given_torque, field, torque)?;
    let phase = finite(&format!("{field}.phase"), *phase)?;
    let curve = model
        .curve(CurveOptions { torque, etc: *etc })
        .map_err(|e| SceneError(format!("{field}: {e}")))?;
    Ok(match (form, harmonics) {
        (GeometryForm::Table, None) => curve.to_table(phase),
        (GeometryForm::Table, Some(h)) => {
            return Err(SceneError(format!(
                "{field}.harmonics = {h}: only allowed with form = \"fourier\""
            )))
        }
        (GeometryForm::Fourier, h) => {
            let h = h.unwrap_or(4);
            if !(1..=256).contains(&h) {
                return Err(SceneError(format!(
                    "{field}.harmonics = {h}: must be an integer in 1..=256"
                )));
            }
            curve.to_fourier(h as usize, phase)
        }
    })
}
