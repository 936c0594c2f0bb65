//! `geardyn modes`: natural frequencies and mode shapes of a drivetrain's mean system, and
//! its statics (the report is written by `geardyn::commands::modes`).

use std::path::PathBuf;

use clap::Args;

use geardyn::scene::train::TrainScene;

#[derive(Args)]
pub struct ModesArgs {
    /// Scene file or folder (e.g. `fmu/idler_gearset`).
    pub scene: PathBuf,
    /// Remove the bearing translations (purely rotational model).
    #[arg(long)]
    pub rigid_bearings: bool,
}

pub fn run(args: ModesArgs) -> Result<(), String> {
    let scene = TrainScene::from_path(&args.scene).map_err(|e| e.to_string())?;
    geardyn::commands::modes::modes(&scene, args.rigid_bearings, &mut std::io::stdout().lock())?;
    Ok(())
}
