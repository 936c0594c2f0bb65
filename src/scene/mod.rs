//! Scene description: TOML via serde, defaults, validation with located messages.
//!
//! Data flow: [`spec`] mirrors the file (one description for every scene); [`kernel`] chooses
//! the kernel that runs it; [`validate`] checks it into the one resolved [`Scene`], in the
//! drivetrain's terms and SI units (a single-mesh file is a train with one mesh), which
//! records the kernel choice. [`load`] is the one path from text to a resolved scene. The
//! single-pair kernel reads its scene as a [`PairScene`] ([`Scene::pair`]). The format is
//! specified in `docs/model.md` and `docs/train.md`.

pub mod kernel;
mod load;
pub mod profile;
mod resolved;
pub mod schema;
pub mod spec;
pub mod train;
pub(crate) mod validate;

use std::fmt;
use std::path::{Path, PathBuf};

pub use kernel::{KernelChoice, PairGear, PairMesh, PairOperating, PairScene};
pub use load::{is_train_text, load};
pub use profile::{Profile, Profiles};
pub use resolved::{Gear, Mesh, Operating, Scene};
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

impl From<SceneError> for String {
    fn from(e: SceneError) -> String {
        e.0
    }
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

impl ContactLaw {
    /// The law as the scene file spells it (`contact = "backlash"`), for messages.
    pub fn file_name(&self) -> &'static str {
        match self {
            ContactLaw::Linear => "linear",
            ContactLaw::ContactLoss => "contact_loss",
            ContactLaw::Backlash { .. } => "backlash",
        }
    }
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
    /// `solver.exact_memory_mb`: the heap the exact propagator's mode cache may hold, in
    /// bytes ([`crate::solve::exact::ExactPropagator::set_memory_budget`]); `None`: 512 MiB.
    pub exact_memory: Option<usize>,
}

impl SolverSettings {
    /// Chooses the propagator by one name: `auto`, `exact`, `rk` (with the RK method already
    /// set), or an RK method (`dp5`, `dop853`, `rodas4`), which also selects `rk`. Benchmarks
    /// and tests that compare the propagators side by side name them this way.
    pub fn set_propagator(&mut self, name: &str) -> Result<(), String> {
        match name.parse::<MethodChoice>() {
            Ok(method) => self.method = method,
            Err(_) => {
                self.rk_method = name.parse().map_err(|_| {
                    format!(
                        "'{name}' is not a propagator (auto | rk | exact | dp5 | dop853 | rodas4)"
                    )
                })?;
                self.method = MethodChoice::Rk;
            }
        }
        Ok(())
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn set_propagator_takes_a_method_or_an_rk_method_and_names_a_bad_one() {
        let mut s = Scene::example("spur_pair").unwrap().solver;
        s.set_propagator("dop853").unwrap();
        assert_eq!(
            (s.method, s.rk_method),
            (MethodChoice::Rk, crate::solve::rk::Method::Dop853)
        );
        s.set_propagator("exact").unwrap();
        assert_eq!(
            (s.method, s.rk_method),
            (MethodChoice::Exact, crate::solve::rk::Method::Dop853)
        );
        let e = s.set_propagator("rk45").unwrap_err();
        assert!(e.contains("'rk45'"), "{e}");
        assert_eq!(
            s.method,
            MethodChoice::Exact,
            "a refused name changes nothing"
        );
    }
}
