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
    /// Also draw the Campbell diagram: these natural frequencies over the input speed, with
    /// the mesh orders 1–3 and the input shaft order as rays (PNG or SVG by the extension).
    #[arg(long)]
    pub campbell: Option<std::path::PathBuf>,
    /// Speed range of the Campbell diagram, `LO:HI` in rpm (default: 0 to the run-up's
    /// highest speed, or to twice the operating speed).
    #[arg(long)]
    pub rpm: Option<String>,
}

pub fn run(args: ModesArgs) -> Result<(), String> {
    let scene = args.scene.load()?;
    let rpm = (args.rpm.as_deref())
        .map(|r| geardyn::commands::runup::parse_range("--rpm", r))
        .transpose()?;
    if let Some(path) = &args.campbell {
        geardyn::plot::Format::of(path)?;
    } else if rpm.is_some() {
        return Err("--rpm sets the Campbell diagram's range: give --campbell FILE".into());
    }
    let modes = geardyn::commands::modes::modes(
        &scene,
        args.rigid_bearings,
        &mut std::io::stdout().lock(),
    )?;
    if let Some(path) = &args.campbell {
        print!(
            "{}",
            geardyn::commands::campbell::campbell(&scene, &modes, rpm, path)?
        );
    }
    Ok(())
}
