//! Scene description: TOML via serde, defaults, validation with located messages.
//!
//! Data flow: [`spec`] mirrors the file (one description for every scene); [`kernel`] chooses
//! the kernel that runs it; [`validate`] checks it into the resolved scene of that kernel, in
//! SI units: [`Scene`] for the single-pair kernel, [`train::TrainScene`] for the drivetrain
//! kernel. [`load`] is the one path from text to a resolved scene. The format is specified in
//! `docs/model.md` and `docs/train.md`.

pub mod kernel;
mod load;
pub mod profile;
pub mod spec;
pub mod train;
pub(crate) mod validate;

use std::fmt;
use std::path::{Path, PathBuf};

use crate::mesh::{MeshStiffness, PhaseSeries};

pub use kernel::KernelChoice;
pub use load::{is_train_text, load, Loaded};
pub use profile::{Profile, Profiles};
pub use spec::SceneSpec;

/// A scene error: the message names the field (as a TOML path) and the offending value, or
/// the file position where the TOML parser gives one.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneError(pub String);

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for SceneError {}

/// A gear body.
#[derive(Debug, Clone, PartialEq)]
pub struct Gear {
    pub name: String,
    pub teeth: u32,
    pub base_radius: f64,
    pub inertia: f64,
}

/// Contact law of a mesh with its clearance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ContactLaw {
    /// The mesh spring acts in tension too: no contact loss, no events.
    Linear,
    /// Single-sided contact: the force vanishes when the deflection is negative.
    ContactLoss,
    /// Drive side, separation and back side with total clearance `clearance` (= 2b), m.
    Backlash { clearance: f64 },
}

/// The single mesh between the pinion and the gear.
#[derive(Debug, Clone, PartialEq)]
pub struct Mesh {
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

/// Smooth terms of the mesh force and excitation (Bugaru et al. 2006, eqs. 8 and 13):
/// `c(p) = c + c̃ cos 2πp`, `F = k(p)(δ + δ̄ δ³) + γ δ³ + c(p) δ'`, and an input-torque ripple.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SmoothTerms {
    /// δ̄, 1/m².
    pub cubic_factor: f64,
    /// γ, N/m³.
    pub cubic_spring: f64,
    /// c̃, N·s/m.
    pub damping_variation: f64,
    /// T̃1, N·m.
    pub torque_ripple: f64,
}

impl SmoothTerms {
    pub fn is_zero(&self) -> bool {
        *self == SmoothTerms::default()
    }
}

/// Operating point (inputs of the FMU).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Operating {
    /// Nominal pinion speed Ω, rad/s.
    pub pinion_speed: f64,
    /// T1, N·m.
    pub input_torque: f64,
    /// T2 (magnitude, resisting), N·m.
    pub load_torque: f64,
}

/// Initial DTE choice.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum InitialDte {
    /// The mean static deflection plus the STE at the initial phase.
    Static,
    Value(f64),
}

/// How to integrate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MethodChoice {
    /// The exact propagator when the scene is piecewise LTI, RK otherwise.
    Auto,
    Rk,
    Exact,
}

impl std::str::FromStr for MethodChoice {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "auto" => Ok(MethodChoice::Auto),
            "rk" => Ok(MethodChoice::Rk),
            "exact" => Ok(MethodChoice::Exact),
            other => Err(format!("'{other}' is not a method (auto | rk | exact)")),
        }
    }
}

/// Solver settings and the default experiment.
#[derive(Debug, Clone, PartialEq)]
pub struct SolverSettings {
    pub method: MethodChoice,
    pub rk_method: crate::solve::rk::Method,
    pub rtol: f64,
    pub atol: f64,
    pub stop_time: f64,
    pub output_interval: f64,
    /// `solver.work_budget`: the most work one run (or one FMI call) may do, in work units
    /// ([`crate::simulation::budget`]); `None`: the default of the scope.
    pub work_budget: Option<f64>,
}

/// A validated scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    pub name: String,
    pub description: String,
    pub pinion: Gear,
    pub gear: Gear,
    pub mesh: Mesh,
    /// The operating point at t = 0 (with profiles: their values at t = 0).
    pub operating: Operating,
    /// Speed and torque over time (a run-up), `docs/runup.md`.
    pub profiles: Profiles,
    pub initial_dte: InitialDte,
    pub initial_dte_rate: f64,
    pub solver: SolverSettings,
    /// The TOML text the scene was read from (the FMU GUID is derived from it).
    pub source: String,
}

/// Built-in single-pair scenes (`fmu/<name>/scene.toml`, `examples/<name>.toml`), compiled
/// into the binary.
pub const EXAMPLES: &[(&str, &str)] = &[
    ("spur_pair", include_str!("../../fmu/spur_pair/scene.toml")),
    (
        "geometry_pair",
        include_str!("../../fmu/geometry_pair/scene.toml"),
    ),
    (
        "bugaru_pair",
        include_str!("../../fmu/bugaru_pair/scene.toml"),
    ),
    (
        "helical_pair_friction",
        include_str!("../../fmu/helical_pair_friction/scene.toml"),
    ),
    // A run-up (docs/runup.md); not an FMU: an FMU takes its speed from the host.
    ("runup_spur", include_str!("../../examples/runup_spur.toml")),
];

impl Scene {
    /// Equivalent mass on the line of action, `m_e = 1/(r_b1²/I1 + r_b2²/I2)`, kg.
    pub fn equivalent_mass(&self) -> f64 {
        equivalent_mass(&self.pinion, &self.gear)
    }
}

/// A scene argument as a file: the path itself, or the `scene.toml` inside a folder.
pub fn scene_file(path: &Path) -> PathBuf {
    if path.is_dir() {
        path.join("scene.toml")
    } else {
        path.to_path_buf()
    }
}

/// The text of a scene file and its name for messages.
pub fn read_scene_file(file: &Path) -> Result<(String, String), SceneError> {
    let text = std::fs::read_to_string(file)
        .map_err(|e| SceneError(format!("cannot read scene file '{}': {e}", file.display())))?;
    Ok((text, file.display().to_string()))
}

pub(crate) fn equivalent_mass(pinion: &Gear, gear: &Gear) -> f64 {
    1.0 / (pinion.base_radius.powi(2) / pinion.inertia + gear.base_radius.powi(2) / gear.inertia)
}
