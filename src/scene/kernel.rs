//! Which kernel runs a scene: the one place that decides it.
//!
//! Every scene file is read by one description ([`super::spec`]). The single-pair kernel
//! ([`crate::model::GearPair`], the DTE coordinate of `docs/model.md`) runs a scene that has
//! one mesh between two gears and uses only what that kernel implements; every other scene
//! runs on the drivetrain kernel (`docs/train.md`). Both give the same physics where they
//! overlap (`tests/pair_as_drivetrain.rs`); the pair kernel is the fast path and the only one
//! with the smooth terms of Bugaru (2006) (`cubic`, `damping_variation`, `damping_acts`,
//! `torque_ripple`).
//!
//! The choice is recorded in the resolved [`Scene`] (`Scene::kernel`); the pair kernel reads
//! such a scene through its view [`PairScene`] ([`Scene::pair`]), which lifts back without
//! loss ([`Scene::from`]).

use super::resolved::{Gear, Mesh, Operating, Scene};
use super::spec::{GearSpec, MeshForm, ParsedScene, SceneSpec};
use super::train::{elements::Elements, MeshForceModel};
use super::{ContactLaw, InitialDte, Profiles, SmoothTerms, SolverSettings};
use crate::mesh::{MeshStiffness, PhaseSeries};

pub use super::resolved::KernelChoice;

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
    let tables: [(&str, bool); 7] = [
        ("[model]", spec.model.is_some()),
        ("[[shaft]]", !spec.shaft.is_empty()),
        ("[[port]]", !spec.port.is_empty()),
        ("[[motor]]", !spec.motor.is_empty()),
        ("[[load]]", !spec.load.is_empty()),
        ("[[inertia]]", !spec.inertia.is_empty()),
        ("[[carrier]] (a planetary stage)", !spec.carrier.is_empty()),
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
        // The validation names the count (a single-mesh scene has two gears); nothing here
        // needs the drivetrain.
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
    } else if g.internal {
        Some("internal")
    } else if g.carrier.is_some() {
        Some("carrier")
    } else if g.position_angle.is_some() {
        Some("position_angle")
    } else if g.pin_error.is_some() {
        Some("pin_error")
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

/// The resolved scene as the single-pair kernel reads it ([`crate::model::GearPair`], the DTE
/// coordinate of `docs/model.md`): the pinion, the gear and their one lumped mesh. It is the
/// pair kernel's view of a [`Scene`] whose kernel is [`KernelChoice::Pair`] ([`Scene::pair`]),
/// and lifts back without loss ([`Scene::from`]). The one validation (`validate/drivetrain.rs`)
/// makes the [`Scene`]; this view is read from it.
#[derive(Debug, Clone, PartialEq)]
pub struct PairScene {
    pub name: String,
    pub description: String,
    pub pinion: PairGear,
    pub gear: PairGear,
    pub mesh: PairMesh,
    /// The operating point at t = 0 (with profiles: their values at t = 0).
    pub operating: PairOperating,
    /// Speed and torque over time (a run-up), `docs/runup.md`.
    pub profiles: Profiles,
    pub initial_dte: InitialDte,
    pub initial_dte_rate: f64,
    pub solver: SolverSettings,
    /// The TOML text the scene was read from (the FMU GUID is derived from it).
    pub source: String,
}

/// A gear body of the pair.
#[derive(Debug, Clone, PartialEq)]
pub struct PairGear {
    pub name: String,
    pub teeth: u32,
    pub base_radius: f64,
    pub inertia: f64,
}

/// The single mesh between the pinion and the gear.
#[derive(Debug, Clone, PartialEq)]
pub struct PairMesh {
    pub contact: ContactLaw,
    pub stiffness: MeshStiffness,
    /// Static transmission error `e(p)`, m.
    pub ste: PhaseSeries,
    /// Viscous mesh damping `c_m`, N·s/m (resolved from a ratio if given so).
    pub damping: f64,
    /// Damping also acts while the teeth are separated (`damping_acts = "always"`).
    pub damping_always: bool,
    /// Smooth additions to the mesh force (Bugaru 2006); all zero by default.
    pub smooth: SmoothTerms,
    /// Mesh phase at t = 0, mesh cycles.
    pub initial_phase: f64,
}

/// Operating point of the pair (inputs of the FMU).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairOperating {
    /// Nominal pinion speed Ω, rad/s.
    pub pinion_speed: f64,
    /// T1, N·m.
    pub input_torque: f64,
    /// T2 (magnitude, resisting), N·m.
    pub load_torque: f64,
}

impl PairScene {
    /// Equivalent mass on the line of action, `m_e = 1/(r_b1²/I1 + r_b2²/I2)`, kg.
    pub fn equivalent_mass(&self) -> f64 {
        equivalent_mass(&self.pinion, &self.gear)
    }
}

pub(crate) fn equivalent_mass(pinion: &PairGear, gear: &PairGear) -> f64 {
    1.0 / (pinion.base_radius.powi(2) / pinion.inertia + gear.base_radius.powi(2) / gear.inertia)
}

impl Scene {
    /// The scene as the single-pair kernel reads it, when the kernel choice put it there.
    pub fn pair(&self) -> Option<PairScene> {
        if self.kernel != KernelChoice::Pair {
            return None;
        }
        let [m] = self.meshes.as_slice() else {
            return None;
        };
        let MeshForceModel::Lumped { stiffness, ste } = &m.force else {
            return None;
        };
        let body = |g: &Gear| PairGear {
            name: g.name.clone(),
            teeth: g.teeth,
            base_radius: g.base_radius,
            inertia: g.inertia,
        };
        Some(PairScene {
            name: self.name.clone(),
            description: self.description.clone(),
            pinion: body(&self.gears[m.pinion]),
            gear: body(&self.gears[m.gear]),
            mesh: PairMesh {
                contact: m.contact,
                stiffness: stiffness.clone(),
                ste: ste.clone(),
                damping: m.damping,
                damping_always: m.damping_always,
                smooth: m.smooth,
                initial_phase: m.initial_phase,
            },
            operating: PairOperating {
                pinion_speed: self.operating.input_speed,
                input_torque: self.operating.input_torque,
                load_torque: self.operating.load_torque,
            },
            profiles: self.profiles.clone(),
            initial_dte: self.initial_dte,
            initial_dte_rate: self.initial_dte_rate,
            solver: self.solver.clone(),
            source: self.source.clone(),
        })
    }
}

impl Scene {
    /// The same scene on the drivetrain kernel, to compare the two kernels where they overlap
    /// (`tests/pair_as_drivetrain.rs`). A term only the pair kernel carries is refused by
    /// name rather than dropped.
    pub fn on_drivetrain_kernel(&self) -> Result<Scene, String> {
        for (n, m) in self.meshes.iter().enumerate() {
            if !m.smooth.is_zero() {
                return Err(format!(
                    "mesh[{n}]: the smooth terms (cubic, damping_variation, torque_ripple) are \
                     the single-pair kernel's; the drivetrain kernel does not carry them"
                ));
            }
            if m.damping_always {
                return Err(format!(
                    "mesh[{n}].damping_acts = \"always\": the single-pair kernel's; the \
                     drivetrain kernel does not carry it"
                ));
            }
        }
        let mut scene = self.clone();
        scene.kernel = KernelChoice::Drivetrain("asked for by the caller".into());
        Ok(scene)
    }
}

impl From<&PairScene> for Scene {
    /// The pair as the one-mesh drivetrain it is: two rotating gears on rigid supports (the
    /// pinion first) and one lumped mesh, on the single-pair kernel. The drivetrain kernel
    /// runs it too (`tests/pair_as_drivetrain.rs`) without the terms only the pair kernel
    /// carries (Bugaru's smooth terms, `damping_acts`).
    fn from(pair: &PairScene) -> Scene {
        let gear = |g: &PairGear| Gear {
            name: g.name.clone(),
            teeth: g.teeth,
            base_radius: g.base_radius,
            inertia: g.inertia,
            mass: None,
            bearing: None,
            ground_stiffness: 0.0,
            ground_damping: 0.0,
            errors: Default::default(),
        };
        let ratio = pair.pinion.teeth as f64 / pair.gear.teeth as f64;
        Scene {
            name: pair.name.clone(),
            description: pair.description.clone(),
            kernel: KernelChoice::Pair,
            gears: vec![gear(&pair.pinion), gear(&pair.gear)],
            shafts: Vec::new(),
            meshes: vec![Mesh {
                name: "mesh".into(),
                pinion: 0,
                gear: 1,
                contact: pair.mesh.contact,
                damping: pair.mesh.damping,
                initial_phase: pair.mesh.initial_phase,
                phase: 0.0,
                pressure_angle: 0.0,
                centre_angle: 0.0,
                force: MeshForceModel::Lumped {
                    stiffness: pair.mesh.stiffness.clone(),
                    ste: pair.mesh.ste.clone(),
                },
                damping_always: pair.mesh.damping_always,
                smooth: pair.mesh.smooth,
                friction: None,
                helical: None,
                cycles_per_input_rev: pair.pinion.teeth as f64,
            }],
            modal_damping_ratio: 0.0,
            input_gear: 0,
            output_gear: 1,
            speed_ratio: vec![1.0, ratio],
            rotation: vec![1.0, -1.0],
            operating: Operating {
                input_speed: pair.operating.pinion_speed,
                input_torque: pair.operating.input_torque,
                load_torque: pair.operating.load_torque,
            },
            profiles: pair.profiles.clone(),
            initial_dte: pair.initial_dte,
            initial_dte_rate: pair.initial_dte_rate,
            solver: pair.solver.clone(),
            source: pair.source.clone(),
            ports: Vec::new(),
            elements: Elements::default(),
            planetary: Vec::new(),
        }
    }
}

impl From<PairScene> for Scene {
    fn from(pair: PairScene) -> Scene {
        Scene::from(&pair)
    }
}
