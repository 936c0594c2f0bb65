//! The one path from scene text to a resolved scene: read the one description
//! ([`super::spec`]), choose the kernel ([`super::kernel`]), validate for that kernel
//! ([`super::validate`]). Messages start with the origin (the file, or `example 'name'`).

use std::path::Path;

use super::kernel::{choose, KernelChoice};
use super::spec::ParsedScene;
use super::train::{TrainScene, TRAIN_EXAMPLES};
use super::validate::{drivetrain, pair};
use super::{read_scene_file, scene_file, Scene, SceneError, EXAMPLES};

/// A resolved scene, as the kernel chosen for it takes it.
#[derive(Debug, Clone)]
pub enum Loaded {
    Pair(Box<Scene>),
    Drivetrain(Box<TrainScene>),
}

/// Reads, chooses and validates: the resolved scene and the kernel choice (with its reason,
/// printed by `--verbose`).
pub fn load(text: &str, origin: &str) -> Result<(Loaded, KernelChoice), SceneError> {
    let parsed = parse(text, origin)?;
    let choice = choose(&parsed);
    let loaded = match &choice {
        KernelChoice::Pair => pair::validate(parsed, text).map(|s| Loaded::Pair(Box::new(s))),
        KernelChoice::Drivetrain(_) => {
            drivetrain::validate(parsed, text).map(|s| Loaded::Drivetrain(Box::new(s)))
        }
    }
    .map_err(|e| located(origin, e))?;
    Ok((loaded, choice))
}

/// Whether scene text runs on the drivetrain kernel ([`super::kernel::choose`]); text that
/// does not parse is left to the single-pair reader's messages.
pub fn is_train_text(text: &str) -> bool {
    ParsedScene::parse(text, "")
        .is_ok_and(|parsed| matches!(choose(&parsed), KernelChoice::Drivetrain(_)))
}

fn parse(text: &str, origin: &str) -> Result<ParsedScene, SceneError> {
    ParsedScene::parse(text, origin)
}

fn located(origin: &str, e: SceneError) -> SceneError {
    SceneError(format!("{origin}: {}", e.0))
}

impl Scene {
    /// Parses and validates scene text for the single-pair kernel; a scene that needs the
    /// drivetrain kernel is refused with the field that needs it. `origin` names the source
    /// in messages.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Scene, SceneError> {
        pair::validate(parse(text, origin)?, text).map_err(|e| located(origin, e))
    }

    /// Reads and validates a scene file.
    pub fn from_file(path: &Path) -> Result<Scene, SceneError> {
        let (text, origin) = read_scene_file(path)?;
        Self::from_toml_str(&text, &origin)
    }

    /// A built-in example by name.
    pub fn example(name: &str) -> Result<Scene, SceneError> {
        let (_, text) = EXAMPLES.iter().find(|(n, _)| *n == name).ok_or_else(|| {
            let names: Vec<_> = EXAMPLES.iter().map(|(n, _)| *n).collect();
            SceneError(format!(
                "no built-in example named '{name}' (available: {})",
                names.join(", ")
            ))
        })?;
        Self::from_toml_str(text, &format!("example '{name}'"))
    }

    /// Resolves a scene argument: a `.toml` file, or a folder holding `scene.toml`
    /// (such as `fmu/spur_pair`).
    pub fn from_path(path: &Path) -> Result<Scene, SceneError> {
        Self::from_file(&scene_file(path))
    }
}

impl TrainScene {
    /// Parses and validates scene text for the drivetrain kernel (a single-mesh scene reads
    /// as a train with one mesh); `origin` names the source in messages.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<TrainScene, SceneError> {
        drivetrain::validate(parse(text, origin)?, text).map_err(|e| located(origin, e))
    }

    /// Reads a scene file, or the `scene.toml` inside a folder.
    pub fn from_path(path: &Path) -> Result<TrainScene, SceneError> {
        let (text, origin) = read_scene_file(&scene_file(path))?;
        Self::from_toml_str(&text, &origin)
    }

    /// A built-in drivetrain scene by name.
    pub fn example(name: &str) -> Result<TrainScene, SceneError> {
        let (_, text) = TRAIN_EXAMPLES
            .iter()
            .find(|(n, _)| *n == name)
            .ok_or_else(|| SceneError(format!("no built-in drivetrain example named '{name}'")))?;
        Self::from_toml_str(text, &format!("example '{name}'"))
    }
}
