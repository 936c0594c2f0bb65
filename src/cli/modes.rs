//! `geardyn modes`: natural frequencies and mode shapes of any scene's mean system, and its
//! statics (the report is written by `geardyn::commands::modes`).

use std::path::PathBuf;

use clap::Args;

use super::load_any_scene;

#[derive(Args)]
pub struct ModesArgs {
    /// Scene file or folder (e.g. `fmu/idler_gearset`), single pair or drivetrain.
    #[arg(required_unless_present = "example", conflicts_with = "example")]
    pub scene: Option<PathBuf>,
    /// A built-in example scene instead of a file (e.g. `idler_gearset`).
    #[arg(long)]
    pub example: Option<String>,
    /// Remove the bearing translations (purely rotational model).
    #[arg(long)]
    pub rigid_bearings: bool,
}

pub fn run(args: ModesArgs) -> Result<(), String> {
    let scene = load_any_scene(&args.scene, &args.example)?;
    geardyn::commands::modes::modes(&scene, args.rigid_bearings, &mut std::io::stdout().lock())?;
    Ok(())
}
