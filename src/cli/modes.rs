//! `geardyn modes`: natural frequencies and mode shapes of any scene's mean system, and its
//! statics (the report is written by `geardyn::commands::modes`).

use clap::Args;

use super::SceneArg;

#[derive(Args)]
pub struct ModesArgs {
    #[command(flatten)]
    pub scene: SceneArg,
    /// Remove the bearing translations (purely rotational model).
    #[arg(long)]
    pub rigid_bearings: bool,
}

pub fn run(args: ModesArgs) -> Result<(), String> {
    let scene = args.scene.load()?;
    geardyn::commands::modes::modes(&scene, args.rigid_bearings, &mut std::io::stdout().lock())?;
    Ok(())
}
