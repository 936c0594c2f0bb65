//! The resolved scene: one type for every scene and every tool, in the drivetrain's terms
//! (`docs/train.md`; a single-mesh scene of `docs/model.md` is a train with one mesh). It is
//! made by [`super::load`] from the one description ([`super::spec`]) through the one
//! validation tree ([`super::validate`]); [`super::kernel`] chose the kernel that runs it.

use super::train::{
    elements, Bearing, HelicalPair, MeshForceModel, MeshFriction, PlanetaryStage, Port, Shaft,
};
use super::{ContactLaw, InitialDte, Profiles, SmoothTerms, SolverSettings};

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

/// A gear body.
#[derive(Debug, Clone, PartialEq)]
pub struct Gear {
    pub name: String,
    pub teeth: u32,
    pub base_radius: f64,
    pub inertia: f64,
    /// Mass, kg (present whenever `bearing` is).
    pub mass: Option<f64>,
    /// Bearing with translational DOFs (`None`: rigidly supported, or bearings = "rigid").
    pub bearing: Option<Bearing>,
    /// Torsional coupling to ground, N·m/rad.
    pub ground_stiffness: f64,
    pub ground_damping: f64,
    /// Runout and pitch errors (`docs/errors.md`).
    pub errors: crate::mesh::errors::GearErrors,
}

/// A mesh between a driving gear (`pinion`) and a driven gear (`gear`).
#[derive(Debug, Clone, PartialEq)]
pub struct Mesh {
    pub name: String,
    pub pinion: usize,
    pub gear: usize,
    pub contact: ContactLaw,
    /// Viscous mesh damping, N·s/m.
    pub damping: f64,
    /// Mesh phase at t = 0 of the first mesh, mesh cycles (0 for the others).
    pub initial_phase: f64,
    /// Mesh phasing φ relative to the first mesh, cycles of this mesh (0 for the first).
    pub phase: f64,
    /// Operating pressure angle, rad (0 when no translation is coupled; the scene key is in
    /// degrees).
    pub pressure_angle: f64,
    /// Centre-line direction from pinion to gear, rad.
    pub centre_angle: f64,
    pub force: MeshForceModel,
    /// Damping also acts while the teeth are separated (`damping_acts = "always"`; single-pair
    /// kernel only).
    pub damping_always: bool,
    /// Smooth additions to the mesh force (Bugaru 2006), with `operating.torque_ripple`; all
    /// zero unless the scene runs on the single-pair kernel.
    pub smooth: SmoothTerms,
    /// Coulomb tooth friction (Model-1 meshes only).
    pub friction: Option<MeshFriction>,
    /// Helical pairs (`kind = "helical"`): contact-line geometry for the distributed friction.
    pub helical: Option<HelicalPair>,
    /// Mesh cycles per revolution of the input gear: `z_pinion·ω_pinion/ω_input`.
    pub cycles_per_input_rev: f64,
}

impl Mesh {
    /// Mean mesh stiffness `k̄`, N/m.
    pub fn mean_stiffness(&self) -> f64 {
        match &self.force {
            MeshForceModel::Lumped { stiffness, .. } => stiffness.mean(),
            MeshForceModel::Pairs { pair, .. } => pair.mesh_mean(),
        }
    }
}

/// Operating point (inputs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Operating {
    /// Nominal speed of the input gear, rad/s (>= 0).
    pub input_speed: f64,
    /// Torque driving the input gear, N·m.
    pub input_torque: f64,
    /// Load torque magnitude on the output gear, N·m.
    pub load_torque: f64,
}

/// The resolved scene: what every tool takes, in the drivetrain's terms (gears, shafts,
/// meshes, ports, elements), in SI units, with the kinematics resolved (nominal speed ratio and
/// rotation sense of every gear). A single-mesh file of `docs/model.md` resolves to a train
/// with one mesh between two rigidly supported gears; `kernel` says which kernel runs it
/// ([`crate::scene::kernel`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    pub name: String,
    pub description: String,
    /// The kernel that runs the scene, and why: chosen once, when the file is read.
    pub kernel: KernelChoice,
    pub gears: Vec<Gear>,
    pub shafts: Vec<Shaft>,
    pub meshes: Vec<Mesh>,
    /// Modal damping ratio on the mean-stiffness modes.
    pub modal_damping_ratio: f64,
    pub input_gear: usize,
    pub output_gear: usize,
    /// Nominal speed of each gear over the input speed (0 for a grounded, undriven part).
    pub speed_ratio: Vec<f64>,
    /// Nominal rotation sense of each gear: +1 as the input gear's `input_rotation` says
    /// counter-clockwise, −1 clockwise.
    pub rotation: Vec<f64>,
    /// The operating point at t = 0 (with profiles: their values at t = 0).
    pub operating: Operating,
    /// Speed and torque over time (a run-up), `docs/runup.md`.
    pub profiles: Profiles,
    pub initial_dte: InitialDte,
    pub initial_dte_rate: f64,
    pub solver: SolverSettings,
    /// The TOML text the scene was read from (the FMU GUID is derived from it).
    pub source: String,
    /// Mechanical ports (`docs/ports.md`); empty: the nominal-speed form.
    pub ports: Vec<Port>,
    /// Drivetrain elements coupled to the train (`docs/ports.md`); empty: none.
    pub elements: elements::Elements,
    /// Planetary stages (`docs/planetary.md`); their members are entries of `gears`.
    pub planetary: Vec<PlanetaryStage>,
}

impl Scene {
    /// Whether the rigid-body rotation is carried: the scene has ports or elements.
    pub fn carries_rotation(&self) -> bool {
        !self.ports.is_empty() || !self.elements.is_empty()
    }

    /// Index of a gear by name.
    pub fn gear_index(&self, name: &str) -> Option<usize> {
        self.gears.iter().position(|g| g.name == name)
    }

    /// Mesh frequency of mesh `n` at the input speed `omega`, Hz.
    pub fn mesh_frequency(&self, n: usize, omega: f64) -> f64 {
        self.meshes[n].cycles_per_input_rev * omega / std::f64::consts::TAU
    }

    /// The same scene with every bearing rigid (translational DOFs removed).
    pub fn with_rigid_bearings(&self) -> Scene {
        let mut s = self.clone();
        for g in &mut s.gears {
            g.bearing = None;
        }
        s
    }
}
