//! The drivetrain scene file as written by the user (serde, unknown keys rejected).
//!
//! A superset of the single-mesh format of `docs/model.md`: `[mesh]` may be one table (the
//! single-mesh scene, read as a train with one mesh) or an array `[[mesh]]`; `[[gear]]` gains
//! bearings, masses and ground couplings; `[[shaft]]` couples coaxial gears. The format is
//! specified in `docs/train.md`; meaning and ranges are checked in [`super::validate`].

use serde::Deserialize;

use crate::scene::spec::{ContactLawSpec, FourierSpec, SolverSpec, StiffnessSpec};

/// A whole drivetrain scene.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrainSpec {
    pub name: String,
    #[serde(default)]
    pub description: String,
    #[serde(default)]
    pub model: ModelSpec,
    pub gear: Vec<TrainGearSpec>,
    #[serde(default)]
    pub shaft: Vec<ShaftSpec>,
    pub mesh: OneOrMany<TrainMeshSpec>,
    pub operating: TrainOperatingSpec,
    #[serde(default)]
    pub initial: TrainInitialSpec,
    #[serde(default)]
    pub solver: SolverSpec,
    /// Mechanical ports (`docs/ports.md`): with any, the rigid-body rotation is carried.
    #[serde(default)]
    pub port: Vec<super::ports::PortSpec>,
    /// Drivetrain elements (`docs/ports.md`, "Elements in the scene"): with any, the rotation
    /// is carried.
    #[serde(default)]
    pub motor: Vec<super::elements::MotorBodySpec>,
    #[serde(default)]
    pub load: Vec<super::elements::LoadBodySpec>,
    #[serde(default)]
    pub inertia: Vec<super::elements::InertiaBodySpec>,
}

/// `[mesh]` (one table) or `[[mesh]]` (an array of tables).
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
pub enum OneOrMany<T> {
    One(T),
    Many(Vec<T>),
}

impl<T> OneOrMany<T> {
    pub fn into_vec(self) -> Vec<T> {
        match self {
            OneOrMany::One(t) => vec![t],
            OneOrMany::Many(v) => v,
        }
    }
}

/// Scene-wide model switches.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelSpec {
    /// `"compliant"`: gears with `bearing_stiffness` get translational DOFs; `"rigid"`: none.
    #[serde(default = "ModelSpec::default_bearings")]
    pub bearings: String,
    /// Nominal rotation sense of the input gear, `"ccw"` or `"cw"` (sets the line-of-action
    /// directions from the centre-line angles).
    #[serde(default = "ModelSpec::default_rotation")]
    pub input_rotation: String,
    /// Modal damping ratio on the mean-stiffness modes.
    #[serde(default)]
    pub modal_damping_ratio: f64,
}

impl ModelSpec {
    fn default_bearings() -> String {
        "compliant".into()
    }
    fn default_rotation() -> String {
        "ccw".into()
    }
}

impl Default for ModelSpec {
    fn default() -> Self {
        ModelSpec {
            bearings: Self::default_bearings(),
            input_rotation: Self::default_rotation(),
            modal_damping_ratio: 0.0,
        }
    }
}

/// One gear body.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrainGearSpec {
    pub name: String,
    pub teeth: i64,
    /// Base-circle radius, m (default: from a `geometry` mesh stiffness).
    pub base_radius: Option<f64>,
    /// Polar moment of inertia, kg·m² (default: from a `geometry` mesh stiffness with a
    /// density).
    pub inertia: Option<f64>,
    /// Mass, kg (needed when the gear has translational DOFs; default as `inertia`).
    pub mass: Option<f64>,
    /// Bearing stiffness `[k_x, k_y]`, N/m: the gear gets translational DOFs.
    pub bearing_stiffness: Option<[f64; 2]>,
    /// Bearing damping `[c_x, c_y]`, N·s/m.
    pub bearing_damping: Option<[f64; 2]>,
    /// Torsional coupling to ground `k_s`, N·m/rad (Liu 2007 Table 2.1).
    #[serde(default)]
    pub ground_stiffness: f64,
    /// Torsional damping to ground, N·m·s/rad.
    #[serde(default)]
    pub ground_damping: f64,
    /// Runout (eccentricity) of the gear (`docs/errors.md`).
    pub runout: Option<RunoutSpec>,
    /// Individual (single) pitch deviations, one per tooth, m (`docs/errors.md`).
    pub pitch_errors: Option<Vec<f64>>,
    /// Cumulative pitch deviations, one per tooth, m (instead of `pitch_errors`).
    pub cumulative_pitch_errors: Option<Vec<f64>>,
}

/// `runout = { amplitude = …, phase = … }`: eccentricity of a gear's geometric centre, m, and
/// its direction at t = 0 in the scene frame, rad.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunoutSpec {
    pub amplitude: f64,
    #[serde(default)]
    pub phase: f64,
}

/// A shaft between two coaxial gears.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShaftSpec {
    /// Name of a shaft to an element (its output column `<name>_torque`; default
    /// `<gears[0]>_<gears[1]>`).
    pub name: Option<String>,
    pub gears: [String; 2],
    /// Torsional stiffness, N·m/rad (omit with `rigid = true`).
    pub stiffness: Option<f64>,
    #[serde(default)]
    pub rigid: bool,
    /// Torsional damping, N·m·s/rad.
    #[serde(default)]
    pub damping: f64,
}

/// One mesh between a driving and a driven gear.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrainMeshSpec {
    /// Name used in output columns (default `mesh1`, `mesh2`, …).
    pub name: Option<String>,
    /// Driving gear.
    pub pinion: String,
    /// Driven gear.
    pub gear: String,
    pub contact: ContactLawSpec,
    pub backlash: Option<f64>,
    pub damping: Option<f64>,
    pub damping_ratio: Option<f64>,
    /// Mesh phase at t = 0 (first mesh only), mesh cycles.
    pub initial_phase: Option<f64>,
    /// Mesh phasing φ relative to the first mesh (meshes 2, 3, …), cycles of this mesh.
    pub phase: Option<f64>,
    /// Operating pressure angle, degrees (needed with translational DOFs).
    pub pressure_angle: Option<f64>,
    /// Direction of the centre line from the pinion's to the gear's centre, rad.
    pub centre_angle: Option<f64>,
    /// `"lumped"` (default), `"pairs"` (Model-1), `"loaded_ste"` (Model-2), `"nlte"` (Model-3).
    pub model: Option<String>,
    /// Mesh stiffness source (lumped model).
    pub stiffness: Option<StiffnessSpec>,
    /// Static transmission error `e(p)` (lumped model).
    pub ste: Option<FourierSpec>,
    /// Single tooth-pair stiffness (pair-based models).
    pub pairs: Option<PairStiffnessSpec>,
    /// Linear tip relief (pair-based models).
    pub tip_relief: Option<TipReliefSpec>,
    /// Tabulated pair gap over the engagement window (instead of tip_relief).
    pub gaps: Option<GapTableSpec>,
    /// Coulomb tooth friction of the tooth pairs (Model-1 only; Liu 2007 Ch. 5).
    pub friction: Option<FrictionSpec>,
}

/// `[mesh.friction]`: Coulomb sliding friction on every tooth pair (Liu 2007 Ch. 5).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FrictionSpec {
    /// Friction coefficient μ (>= 0).
    pub coefficient: f64,
    /// Friction-bending factor β̃ of eq. (4.42): pair stiffness `k(1 ± β̃μ)` (default 0).
    #[serde(default)]
    pub bending_factor: f64,
    /// Position of the pitch point in the pair's engagement window, mesh cycles
    /// (default: from the gear geometry with standard addenda).
    pub pitch_point: Option<f64>,
}

/// A pair gap table: `points` from 0 to the contact ratio (mesh cycles), `values` in m.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GapTableSpec {
    pub points: Vec<f64>,
    pub values: Vec<f64>,
}

/// Stiffness of one tooth pair over its engagement window `ξ ∈ [0, c)` (mesh cycles).
#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum PairStiffnessSpec {
    /// Liu 2007 §2.5 rectangular idealisation: the mesh has mean `mean` and peak-to-peak
    /// `peak_to_peak_ratio·mean`; each pair carries `K_d/2` in double contact, `K_s` alone.
    Rectangular {
        mean: f64,
        peak_to_peak_ratio: f64,
        contact_ratio: f64,
        /// Liu 2007 §5.2: share α of `K_d` the leaving pair carries when double contact
        /// starts, falling linearly to `1 − α` (default ½: the constant halves of §2.5).
        load_share: Option<f64>,
    },
    /// Helical pair of He & Singh (2007): a constant stiffness density along the contact lines
    /// of the helical geometry (`src/mesh/helical`, `docs/helical.md`); the pair stiffness is
    /// `k cos β_b Δz(ξ)`, its window the total contact ratio ε_α + ε_β.
    Helical {
        /// Stiffness density k per unit contact-line length projected on the face, N/m².
        density: f64,
        geometry: crate::mesh::helical::HelicalPairSpec,
    },
    /// Piecewise-linear table over `ξ ∈ [0, contact_ratio]`.
    Table {
        contact_ratio: f64,
        points: Vec<f64>,
        values: Vec<f64>,
    },
}

/// Linear tip relief of driver and driven teeth: magnitude (m) and length (mesh cycles).
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TipReliefSpec {
    #[serde(default)]
    pub driver_magnitude: f64,
    pub driver_length: Option<f64>,
    #[serde(default)]
    pub driven_magnitude: f64,
    pub driven_length: Option<f64>,
}

/// Operating point; every field is an input.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrainOperatingSpec {
    /// Gear whose speed and torque are inputs (default: the first mesh's pinion).
    pub input_gear: Option<String>,
    /// Gear carrying the load torque (default: the last mesh's gear).
    pub output_gear: Option<String>,
    /// Nominal speed of the input gear, rad/s.
    #[serde(alias = "pinion_speed")]
    pub input_speed: Option<f64>,
    /// Torque driving the input gear, N·m (or `torque_profile`).
    pub input_torque: Option<f64>,
    /// Input-gear speed over time, rad/s (a run-up; `docs/runup.md`).
    pub speed_profile: Option<crate::scene::profile::ProfileSpec>,
    /// Input torque over time, N·m.
    pub torque_profile: Option<crate::scene::profile::ProfileSpec>,
    /// Load torque magnitude on the output gear, N·m; default: balanced by the kinematics.
    pub load_torque: Option<f64>,
}

/// Initial conditions.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrainInitialSpec {
    #[serde(default = "TrainInitialSpec::default_dte")]
    pub dte: crate::scene::spec::InitialDteSpec,
    #[serde(default)]
    pub dte_rate: f64,
}

impl TrainInitialSpec {
    fn default_dte() -> crate::scene::spec::InitialDteSpec {
        crate::scene::spec::InitialDteSpec::Keyword("static".to_owned())
    }
}

impl Default for TrainInitialSpec {
    fn default() -> Self {
        TrainInitialSpec {
            dte: Self::default_dte(),
            dte_rate: 0.0,
        }
    }
}
