//! The one path from scene text to the resolved [`Scene`]: read the one description
//! ([`super::spec`]), choose the kernel ([`super::kernel`]), validate ([`super::validate`]).
//! Messages start with the origin (the file, or `example 'name'`).

use std::path::Path;

use super::kernel::{choose, KernelChoice, PairScene};
use super::spec::ParsedScene;
use super::train::TRAIN_EXAMPLES;
use super::validate::drivetrain;
use super::{read_scene_file, scene_file, Scene, SceneError, EXAMPLES};

/// Reads, chooses and validates: the resolved scene, which records the kernel choice (with
/// its reason, printed by `--verbose`).
pub fn load(text: &str, origin: &str) -> Result<Scene, SceneError> {
    let parsed = parse(text, origin)?;
    drivetrain::validate(parsed, text).map_err(|e| located(origin, e))
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
    /// Parses and validates scene text of any form; `origin` names the source in messages.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Scene, SceneError> {
        load(text, origin)
    }

    /// Reads a scene file, or the `scene.toml` inside a folder. An `[element]` file is a
    /// co-simulation element, not a scene: the message says where it goes.
    pub fn from_path(path: &Path) -> Result<Scene, SceneError> {
        let (text, origin) = read_scene_file(&scene_file(path))?;
        if crate::fmu::element::is_element_text(&text) {
            return Err(SceneError(format!(
                "{origin}: an [element] scene is a co-simulation element (docs/elements.md): \
                 build it with `geardyn fmu build` and run it with `geardyn run` or any FMI master"
            )));
        }
        load(&text, &origin)
    }

    /// A built-in example by name (single pair or drivetrain).
    pub fn example(name: &str) -> Result<Scene, SceneError> {
        let text = TRAIN_EXAMPLES
            .iter()
            .chain(EXAMPLES)
            .find(|(n, _)| *n == name)
            .map(|(_, text)| *text);
        let Some(text) = text else {
            let names = |list: &[(&str, &str)]| -> String {
                list.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
            };
            return Err(SceneError(format!(
                "no built-in example named '{name}' (single pairs: {}; drivetrains: {})",
                names(EXAMPLES),
                names(TRAIN_EXAMPLES)
            )));
        };
        load(text, &format!("example '{name}'"))
    }
}

impl PairScene {
    /// Parses and validates scene text for the single-pair kernel; a scene that needs the
    /// drivetrain kernel is refused with the field that needs it. `origin` names the source
    /// in messages.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<PairScene, SceneError> {
        let parsed = parse(text, origin)?;
        if let KernelChoice::Drivetrain(why) = choose(&parsed) {
            return Err(located(
                origin,
                SceneError(format!(
                    "{why}: only the drivetrain kernel carries this; read the scene as a \
                     drivetrain (geardyn does so for every command)"
                )),
            ));
        }
        let scene = drivetrain::validate(parsed, text).map_err(|e| located(origin, e))?;
        // A scene on the pair kernel always has the pair's view (`Scene::pair`).
        scene
            .pair()
            .ok_or_else(|| located(origin, SceneError("not a single-pair scene".into())))
    }

    /// Reads and validates a scene file.
    pub fn from_file(path: &Path) -> Result<PairScene, SceneError> {
        let (text, origin) = read_scene_file(path)?;
        Self::from_toml_str(&text, &origin)
    }

    /// A built-in single-pair example by name.
    pub fn example(name: &str) -> Result<PairScene, SceneError> {
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
    pub fn from_path(path: &Path) -> Result<PairScene, SceneError> {
        Self::from_file(&scene_file(path))
    }
}
