//! The scene file as written by the user: serde types that mirror the TOML one to one, one
//! description for every scene (`docs/model.md`, `docs/train.md`).
//!
//! A single-mesh scene (`[mesh]`, one table) and a drivetrain (`[[mesh]]`, an array) are read
//! by the same types; [`SceneFile`] is generic over the form of `mesh` only so that a serde
//! message keeps its line and column in either form. These types describe *syntax* (unknown
//! keys are rejected here); meaning and ranges are checked in [`super::validate`], and the
//! kernel that runs the scene is chosen from them in [`super::kernel`].

mod elements;
mod mesh;
mod planetary;

use schemars::JsonSchema;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use super::schema::{non_negative, positive};

use super::SceneError;

pub use elements::{InertiaBodySpec, LoadBodySpec, MotorBodySpec};
pub use mesh::{
    ContactLawSpec, CubicSpec, FourierSpec, FrictionSpec, GapTableSpec, GearPairSpec, GeometryForm,
    HelicalPairSpec, MeshSpec, PairStiffnessSpec, StiffnessSpec, TipReliefSpec,
};
pub use planetary::CarrierSpec;

/// A whole scene file with its meshes in the form `M`: `MeshSpec` for `[mesh]`,
/// `Vec<MeshSpec>` for `[[mesh]]`.
#[derive(Debug, Clone, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SceneFile<M> {
    /// Scene name (output file names, FMU model name).
    pub name: String,
    /// Free text shown in the FMU's model description.
    #[serde(default)]
    pub description: String,
    /// Scene-wide model switches of a drivetrain (`docs/train.md`).
    pub model: Option<ModelSpec>,
    /// The gear bodies (`[[gear]]`).
    pub gear: Vec<GearSpec>,
    /// Torsional shafts between coaxial gears (`[[shaft]]`).
    #[serde(default)]
    pub shaft: Vec<ShaftSpec>,
    /// The meshes: `[mesh]` (one) or `[[mesh]]` (a drivetrain).
    pub mesh: M,
    /// The operating point (`[operating]`).
    pub operating: OperatingSpec,
    /// Initial conditions (`[initial]`).
    #[serde(default)]
    pub initial: InitialSpec,
    /// Solver settings and the default experiment (`[solver]`).
    #[serde(default)]
    pub solver: SolverSpec,
    /// Mechanical ports (`docs/ports.md`): with any, the rigid-body rotation is carried.
    #[serde(default)]
    pub port: Vec<crate::scene::train::ports::PortSpec>,
    /// Drivetrain elements (`docs/ports.md`, "Elements in the scene"): with any, the rotation
    /// is carried.
    #[serde(default)]
    pub motor: Vec<MotorBodySpec>,
    #[serde(default)]
    pub load: Vec<LoadBodySpec>,
    #[serde(default)]
    pub inertia: Vec<InertiaBodySpec>,
    /// Carriers of planetary stages (`docs/planetary.md`).
    #[serde(default)]
    pub carrier: Vec<CarrierSpec>,
}

/// How the file wrote its meshes; messages name a mesh field as the user wrote it
/// (`mesh.damping` for `[mesh]`, `mesh[1].damping` for `[[mesh]]`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MeshForm {
    /// `[mesh]`: one table.
    One,
    /// `[[mesh]]`: an array of tables.
    Many,
}

/// A scene file, its meshes as a list whatever the form.
pub type SceneSpec = SceneFile<Vec<MeshSpec>>;

/// A parsed scene file and the form of its meshes.
#[derive(Debug, Clone)]
pub struct ParsedScene {
    pub spec: SceneSpec,
    pub form: MeshForm,
    /// The key the file gave the input speed under (`pinion_speed` is an alias of
    /// `input_speed`), for messages that name the field as the user wrote it.
    pub speed_key: Option<&'static str>,
}

impl ParsedScene {
    /// Parses scene text; messages start with `origin` and carry the parser's line and column.
    pub fn parse(text: &str, origin: &str) -> Result<ParsedScene, SceneError> {
        let fail =
            |e: toml::de::Error| SceneError(format!("{origin}: {}", e.to_string().trim_end()));
        // The form decides the type the text is read into; text that is not TOML at all is
        // reported by the single-mesh reading, as before the two formats were one.
        let table = text.parse::<toml::Table>().ok();
        let many = matches!(
            table.as_ref().and_then(|t| t.get("mesh")),
            Some(toml::Value::Array(_))
        );
        let operating = table.as_ref().and_then(|t| t.get("operating"));
        let speed_key = ["input_speed", "pinion_speed"]
            .into_iter()
            .find(|key| operating.and_then(|o| o.get(key)).is_some());
        if many {
            let spec: SceneSpec = read(text).map_err(fail)?;
            Ok(ParsedScene {
                spec,
                form: MeshForm::Many,
                speed_key,
            })
        } else {
            let one: SceneFile<MeshSpec> = read(text).map_err(fail)?;
            Ok(ParsedScene {
                spec: one.with_meshes(|m| vec![m]),
                form: MeshForm::One,
                speed_key,
            })
        }
    }

    /// The TOML path of mesh `i`'s field `key`, as the file wrote it.
    pub fn mesh_field(&self, i: usize, key: &str) -> String {
        mesh_field(self.form, i, key)
    }
}

/// See [`ParsedScene::mesh_field`].
pub fn mesh_field(form: MeshForm, i: usize, key: &str) -> String {
    format!("{}.{key}", mesh_table(form, i))
}

/// The TOML path of mesh `i`'s table, as the file wrote it (`mesh`, `mesh[1]`).
pub fn mesh_table(form: MeshForm, i: usize) -> String {
    match form {
        MeshForm::One => "mesh".into(),
        MeshForm::Many => format!("mesh[{i}]"),
    }
}

fn read<T: DeserializeOwned>(text: &str) -> Result<T, toml::de::Error> {
    toml::from_str(text)
}

impl<M> SceneFile<M> {
    fn with_meshes<N>(self, f: impl FnOnce(M) -> N) -> SceneFile<N> {
        SceneFile {
            name: self.name,
            description: self.description,
            model: self.model,
            gear: self.gear,
            shaft: self.shaft,
            mesh: f(self.mesh),
            operating: self.operating,
            initial: self.initial,
            solver: self.solver,
            port: self.port,
            motor: self.motor,
            load: self.load,
            inertia: self.inertia,
            carrier: self.carrier,
        }
    }
}

/// Scene-wide model switches.
#[derive(Debug, Clone, Deserialize, JsonSchema)]
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
    #[schemars(transform = non_negative, extend("x-unit" = "1"))]
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

/// One gear body (`[[gear]]`).
#[derive(Debug, Clone, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct GearSpec {
    /// Gear name (meshes, shafts and output columns refer to it).
    pub name: String,
    /// Number of teeth.
    #[schemars(range(min = 1, max = 100_000), extend("x-unit" = "1"))]
    pub teeth: i64,
    /// Base-circle radius, m (default: from a `geometry` mesh stiffness).
    #[schemars(transform = positive, extend("x-unit" = "m"))]
    pub base_radius: Option<f64>,
    /// Polar moment of inertia, kg·m² (default: from a `geometry` mesh stiffness with a
    /// density).
    #[schemars(transform = positive, extend("x-unit" = "kg.m^2"))]
    pub inertia: Option<f64>,
    /// Mass, kg (needed when the gear has translational DOFs; default as `inertia`).
    #[schemars(transform = positive, extend("x-unit" = "kg"))]
    pub mass: Option<f64>,
    /// Bearing stiffness `[k_x, k_y]`, N/m: the gear gets translational DOFs.
    #[schemars(transform = positive, extend("x-unit" = "N/m"))]
    pub bearing_stiffness: Option<[f64; 2]>,
    /// Bearing damping `[c_x, c_y]`, N·s/m.
    #[schemars(transform = non_negative, extend("x-unit" = "N.s/m"))]
    pub bearing_damping: Option<[f64; 2]>,
    /// Torsional coupling to ground `k_s`, N·m/rad (Liu 2007 Table 2.1).
    #[serde(default)]
    #[schemars(transform = non_negative, extend("x-unit" = "N.m/rad"))]
    pub ground_stiffness: f64,
    /// Torsional damping to ground, N·m·s/rad.
    #[serde(default)]
    #[schemars(transform = non_negative, extend("x-unit" = "N.m.s/rad"))]
    pub ground_damping: f64,
    /// Runout (eccentricity) of the gear (`docs/errors.md`).
    pub runout: Option<RunoutSpec>,
    /// Individual (single) pitch deviations, one per tooth, m (`docs/errors.md`).
    #[schemars(extend("x-unit" = "m"))]
    pub pitch_errors: Option<Vec<f64>>,
    /// Cumulative pitch deviations, one per tooth, m (instead of `pitch_errors`).
    #[schemars(extend("x-unit" = "m"))]
    pub cumulative_pitch_errors: Option<Vec<f64>>,
    /// Internal teeth: the ring of a planetary stage (`docs/planetary.md`).
    #[serde(default)]
    pub internal: bool,
    /// A planet: the `[[carrier]]` whose pin holds it; its `bearing_stiffness` is then
    /// `[k_radial, k_tangential]` of the pin in the carrier frame.
    pub carrier: Option<String>,
    /// A planet's position angle ψ on its carrier, degrees, ccw from the carrier's x axis.
    #[schemars(extend("x-unit" = "degree"))]
    pub position_angle: Option<f64>,
    /// A planet's pin position error `[radial, tangential]`, m (load sharing).
    #[schemars(extend("x-unit" = "m"))]
    pub pin_error: Option<[f64; 2]>,
}

/// `runout = { amplitude = …, phase = … }`: eccentricity of a gear's geometric centre, m, and
/// its direction at t = 0 in the scene frame, rad.
#[derive(Debug, Clone, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RunoutSpec {
    /// Eccentricity of the gear's geometric centre, m.
    #[schemars(transform = non_negative, extend("x-unit" = "m"))]
    pub amplitude: f64,
    /// Direction of the eccentricity at t = 0 in the scene frame, rad.
    #[serde(default)]
    #[schemars(extend("x-unit" = "rad"))]
    pub phase: f64,
}

/// A shaft between two coaxial gears.
#[derive(Debug, Clone, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ShaftSpec {
    /// Name of a shaft to an element (its output column `<name>_torque`; default
    /// `<gears[0]>_<gears[1]>`).
    pub name: Option<String>,
    /// The two gears (or element bodies) the shaft joins.
    pub gears: [String; 2],
    /// Torsional stiffness, N·m/rad (omit with `rigid = true`).
    #[schemars(transform = positive, extend("x-unit" = "N.m/rad"))]
    pub stiffness: Option<f64>,
    /// A rigid joint: the two gears turn as one body.
    #[serde(default)]
    pub rigid: bool,
    /// Torsional damping, N·m·s/rad.
    #[serde(default)]
    #[schemars(transform = non_negative, extend("x-unit" = "N.m.s/rad"))]
    pub damping: f64,
}

/// Operating point; every field is an input.
#[derive(Debug, Clone, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct OperatingSpec {
    /// Gear whose speed and torque are inputs (default: the first mesh's pinion).
    pub input_gear: Option<String>,
    /// Gear carrying the load torque (default: the last mesh's gear).
    pub output_gear: Option<String>,
    /// Nominal speed of the input gear, rad/s (`pinion_speed` in a single-mesh scene).
    #[serde(alias = "pinion_speed")]
    #[schemars(transform = non_negative, extend("x-unit" = "rad/s", "x-aliases" = ["pinion_speed"]))]
    pub input_speed: Option<f64>,
    /// Torque driving the input gear, N·m (or `torque_profile`).
    #[schemars(extend("x-unit" = "N.m"))]
    pub input_torque: Option<f64>,
    /// Input-gear speed over time, rad/s (a run-up; `docs/runup.md`).
    pub speed_profile: Option<super::profile::ProfileSpec>,
    /// Input torque over time, N·m.
    pub torque_profile: Option<super::profile::ProfileSpec>,
    /// Load torque magnitude on the output gear, N·m; default: balanced by the kinematics.
    #[schemars(extend("x-unit" = "N.m"))]
    pub load_torque: Option<f64>,
    /// Amplitude of an input-torque ripple at mesh frequency, `T1 + T̃1 cos 2πp`, N·m (pair
    /// kernel).
    #[schemars(extend("x-unit" = "N.m"))]
    pub torque_ripple: Option<f64>,
}

/// Initial DTE: the mean static deflection or a value in metres.
#[derive(Debug, Clone, Deserialize, Serialize, JsonSchema)]
#[serde(untagged)]
pub enum InitialDteSpec {
    Value(f64),
    Keyword(String),
}

/// Initial conditions.
#[derive(Debug, Clone, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct InitialSpec {
    /// Initial DTE: `"static"` (the mean static deflection) or a value in m. (No unit is
    /// declared: a string here is the keyword, not a quantity to convert.)
    #[serde(default = "InitialSpec::default_dte")]
    pub dte: InitialDteSpec,
    /// Initial DTE rate, m/s.
    #[serde(default)]
    #[schemars(extend("x-unit" = "m/s"))]
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
#[derive(Debug, Clone, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SolverSpec {
    /// `"auto"` (exact where the scene allows it, else RK), `"exact"` or `"rk"`.
    #[serde(default = "SolverSpec::default_method")]
    #[schemars(extend("enum" = ["auto", "exact", "rk"]))]
    pub method: String,
    /// The Runge–Kutta pair of the RK path: `"dop853"` or `"dp5"` (`docs/performance.md`).
    #[serde(default = "SolverSpec::default_rk_method")]
    pub rk_method: String,
    /// Relative tolerance of the RK path and of event location.
    #[serde(default = "SolverSpec::default_rtol")]
    #[schemars(transform = positive, extend("exclusiveMaximum" = 1.0, "x-unit" = "1"))]
    pub rtol: f64,
    /// Absolute tolerance of the RK path, in the state's units (m, m/s, rad).
    #[serde(default = "SolverSpec::default_atol")]
    #[schemars(transform = positive)]
    pub atol: f64,
    /// End of the run, s.
    #[serde(default = "SolverSpec::default_stop_time")]
    #[schemars(transform = positive, extend("x-unit" = "s"))]
    pub stop_time: f64,
    /// Interval of the output rows, s (default: `stop_time / 500`).
    #[schemars(transform = positive, extend("x-unit" = "s"))]
    pub output_interval: Option<f64>,
    /// The work budget (docs/fmu.md "Work budget"); default per scope.
    #[schemars(range(min = 1.0))]
    pub work_budget: Option<f64>,
    /// The exact propagator's mode-cache bound in MiB (`docs/scaling.md`, "Memory");
    /// default 512.
    #[schemars(range(min = 1.0, max = 1_048_576.0), extend("x-unit" = "MiB", "default" = crate::solve::exact::MEMORY_BUDGET_MB as f64))]
    pub exact_memory_mb: Option<f64>,
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
            exact_memory_mb: None,
        }
    }
}
