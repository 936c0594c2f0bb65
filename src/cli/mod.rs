//! The subcommands of the `geardyn` binary: argument structs and thin handlers over the
//! library (one file per family of subcommands).

use std::path::PathBuf;

use geardyn::model::AnyScene;

pub mod analysis;
pub mod floquet;
pub mod modes;
pub mod runup;
pub mod simulate;
pub mod spectrum;
pub mod stiffness;

pub use geardyn::commands::positive;

/// The scene named on the command line, in either format (single pair or drivetrain).
pub fn load_any_scene(
    path: &Option<PathBuf>,
    example: &Option<String>,
) -> Result<AnyScene, String> {
    match (path, example) {
        (_, Some(name)) => AnyScene::example(name),
        (Some(path), None) => AnyScene::from_path(path),
        (None, None) => unreachable!("clap requires a scene or --example"),
    }
}
