//! The scene file as written by the user: serde types that mirror the TOML one to one.
//!
//! These types only describe *syntax* (unknown keys are rejected here). Meaning and ranges are
//! checked in [`super::validate`], which turns a [`SceneSpec`] into a validated
//! [`super::Scene`]. The format is specified in `docs/model.md`.

use serde::Deserialize;

pub use crate::mesh::geometry::GearPairSpec;
pub use crate::mesh::helical::HelicalPairSpec;

/// A whole scene file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneSpec {
    pub name: String,
    #[serde(default)]
    pub description: String,
    pub gear: Vec<GearSpec>,
    pub mesh: MeshSpec,
    pub operating: OperatingSpec,
    #[serde(default)]
    pub initial: InitialSpec,
    #[serde(default)]
    pub solver: SolverSpec,
}

/// One gear body.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GearSpec {
    pub name: String,
    pub teeth: i64,
    /// Base-circle radius, m (default: from a `geometry` mesh stiffness).
    pub base_radius: Option<f64>,
    /// Polar mass moment of inertia, kg·m² (default: from a `geometry` mesh stiffness with a
    /// density).
    pub inertia: Option<f64>,
    /// Manufacturing errors (`docs/errors.md`); non-zero ones make the scene run as its
    /// one-mesh drivetrain (`crate::scene::train::is_train_text`).
    pub runout: Option<crate::scene::train::spec::RunoutSpec>,
    pub pitch_errors: Option<Vec<f64>>,
    pub cumulative_pitch_errors: Option<Vec<f64>>,
}

/// The mesh between the two gears.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshSpec {
    /// Name of the driving gear (its nominal speed sets the mesh phase).
    pub pinion: String,
    /// Name of the driven gear.
    pub gear: String,
    pub contact: ContactLawSpec,
    /// Total clearance 2b, m (only with `contact = "backlash"`).
    pub backlash: Option<f64>,
    /// Viscous mesh damping, N·s/m.
    pub damping: Option<f64>,
    /// Damping ratio on the mean stiffness and the equivalent mass.
    pub damping_ratio: Option<f64>,
    /// Amplitude `c̃` of a mesh-damping variation `c(p) = c + c̃ cos 2πp`, N·s/m (Bugaru 2006
    /// eq. 8; only with `contact = "linear"`).
    pub damping_variation: Option<f64>,
    /// Cubic spring terms (Bugaru 2006 eq. 13; only with `contact = "linear"`).
    pub cubic: Option<CubicSpec>,
    /// Where the viscous damping acts: `in_contact` (default) or `always` (the
    /// Kahraman–Singh form `x'' + 2ζx' + k f(x) = F`, damping also during separation).
    pub damping_acts: Option<String>,
    /// Mesh phase at t = 0, mesh cycles.
    #[serde(default)]
    pub initial_phase: f64,
    pub stiffness: StiffnessSpec,
    #[serde(default)]
    pub ste: Option<FourierSpec>,
}

/// Contact law of a mesh (`docs/model.md`, "Mesh force and contact law").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ContactLawSpec {
    Linear,
    ContactLoss,
    Backlash,
}

/// Mesh-stiffness source, a function of mesh phase.
#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum StiffnessSpec {
    Constant {
        value: f64,
    },
    Rectangular {
        mean: f64,
        peak_to_peak_ratio: f64,
        contact_ratio: f64,
        #[serde(default)]
        phase: f64,
    },
    Trapezoidal {
        mean: f64,
        peak_to_peak_ratio: f64,
        contact_ratio: f64,
        transition: f64,
        #[serde(default)]
        phase: f64,
    },
    Fourier {
        mean: f64,
        #[serde(default)]
        cos: Vec<f64>,
        #[serde(default)]
        sin: Vec<f64>,
        #[serde(default)]
        phase: f64,
    },
    Table {
        phase_points: Vec<f64>,
        values: Vec<f64>,
        #[serde(default)]
        phase: f64,
    },
    /// Computed at scene load from gear geometry (`docs/stiffness.md`).
    Geometry {
        /// Pinion torque of the load-dependent curve, N·m (default `operating.input_torque`).
        torque: Option<f64>,
        /// Extended tooth contact (default on).
        #[serde(default = "default_true")]
        etc: bool,
        /// `table` (piecewise linear through the knots, default) or `fourier`.
        #[serde(default)]
        form: GeometryForm,
        /// Harmonics of the `fourier` form (default 4, as Liao et al. 2025 §3).
        harmonics: Option<i64>,
        #[serde(default)]
        phase: f64,
        /// The gear pair, as in a gears file.
        geometry: Box<GearPairSpec>,
    },
    /// Helical pair with sliding friction, constant stiffness density along the contact lines
    /// (He & Singh 2007; `docs/helical.md`): the paper's piecewise-linear K_e(t), eq. (25).
    Helical {
        /// Stiffness density k per unit contact-line length (projected on the face), N/m².
        stiffness_density: f64,
        /// Coulomb friction coefficient μ >= 0 (default 0).
        #[serde(default)]
        friction_coefficient: f64,
        #[serde(default)]
        phase: f64,
        /// The helical gear pair.
        helical: Box<HelicalPairSpec>,
    },
}

fn default_true() -> bool {
    true
}

/// How a `geometry` stiffness enters the model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GeometryForm {
    #[default]
    Table,
    Fourier,
}

/// A Fourier series in mesh phase without mean (static transmission error), m.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FourierSpec {
    #[serde(default)]
    pub cos: Vec<f64>,
    #[serde(default)]
    pub sin: Vec<f64>,
}

/// Operating point; every field is an input of the FMU.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OperatingSpec {
    /// Nominal pinion speed, rad/s (or `speed_profile`).
    pub pinion_speed: Option<f64>,
    /// Torque driving the pinion, N·m (or `torque_profile`).
    pub input_torque: Option<f64>,
    /// Pinion speed over time, rad/s (a run-up; `docs/runup.md`).
    pub speed_profile: Option<super::profile::ProfileSpec>,
    /// Input torque over time, N·m.
    pub torque_profile: Option<super::profile::ProfileSpec>,
    /// Load torque magnitude on the gear, N·m; `None` means balanced (`T1·r_b2/r_b1`).
    pub load_torque: Option<f64>,
    /// Amplitude of an input-torque ripple at mesh frequency, `T1 + T̃1 cos 2πp`, N·m.
    pub torque_ripple: Option<f64>,
}

/// Cubic terms of the mesh force: `k(p)(δ + stiffness_factor·δ³) + spring·δ³`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CubicSpec {
    /// δ̄, 1/m²: the cubic "backlash spring" scaled by the time-varying stiffness.
    #[serde(default)]
    pub stiffness_factor: f64,
    /// γ, N/m³: a constant cubic spring (e.g. the input/output linkage).
    #[serde(default)]
    pub spring: f64,
}

/// Initial DTE: the mean static deflection or a value in metres.
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
pub enum InitialDteSpec {
    Value(f64),
    Keyword(String),
}

/// Initial conditions.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InitialSpec {
    #[serde(default = "InitialSpec::default_dte")]
    pub dte: InitialDteSpec,
    #[serde(default)]
    pub dte_rate: f64,
}

impl InitialSpec {
    fn default_dte() -> InitialDteSpec {
        InitialDteSpec::Keyword("static".to_owned())
    }
}

impl Default for InitialSpec {
    fn default() -> Self {
        InitialSpec {
            dte: Self::default_dte(),
            dte_rate: 0.0,
        }
    }
}

/// Solver settings and the default experiment.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SolverSpec {
    #[serde(default = "SolverSpec::default_method")]
    pub method: String,
    #[serde(default = "SolverSpec::default_rk_method")]
    pub rk_method: String,
    #[serde(default = "SolverSpec::default_rtol")]
    pub rtol: f64,
    #[serde(default = "SolverSpec::default_atol")]
    pub atol: f64,
    #[serde(default = "SolverSpec::default_stop_time")]
    pub stop_time: f64,
    pub output_interval: Option<f64>,
    /// The work budget (docs/fmu.md "Work budget"); default per scope.
    pub work_budget: Option<f64>,
}

impl SolverSpec {
    fn default_method() -> String {
        "auto".to_owned()
    }
    fn default_rk_method() -> String {
        "dop853".to_owned()
    }
    fn default_rtol() -> f64 {
        1e-9
    }
    fn default_atol() -> f64 {
        1e-15
    }
    fn default_stop_time() -> f64 {
        0.05
    }
}

impl Default for SolverSpec {
    fn default() -> Self {
        SolverSpec {
            method: Self::default_method(),
            rk_method: Self::default_rk_method(),
            rtol: Self::default_rtol(),
            atol: Self::default_atol(),
            stop_time: Self::default_stop_time(),
            output_interval: None,
            work_budget: None,
        }
    }
}
