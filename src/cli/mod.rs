//! The subcommands of the `geardyn` binary: argument structs and thin handlers over the
//! library (one file per family of subcommands).

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};

use geardyn::scene::Scene;

pub mod analysis;
pub mod floquet;
pub mod modes;
pub mod runup;
pub mod simulate;
pub mod spectrum;
pub mod stiffness;

pub use geardyn::commands::positive;

/// Whether `--verbose` was given (set once by `main` before the command runs).
static VERBOSE: AtomicBool = AtomicBool::new(false);

pub fn set_verbose(on: bool) {
    VERBOSE.store(on, Ordering::Relaxed);
}

/// The scene named on the command line, in either format (single pair or drivetrain); with
/// `--verbose` the kernel chosen for it, and why, goes to stderr.
pub fn load_any_scene(path: &Option<PathBuf>, example: &Option<String>) -> Result<Scene, String> {
    let scene = match (path, example) {
        (_, Some(name)) => Scene::example(name),
        (Some(path), None) => Scene::from_path(path),
        (None, None) => unreachable!("clap requires a scene or --example"),
    }
    .map_err(|e| e.to_string())?;
    if VERBOSE.load(Ordering::Relaxed) {
        eprintln!("scene {}: {}", scene.name, scene.kernel.describe());
    }
    Ok(scene)
}
