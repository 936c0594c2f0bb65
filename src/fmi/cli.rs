//! The `geardyn fmu` subcommand: packaging and the checked-in model descriptions. `main.rs`
//! only forwards to [`run`].

use std::path::PathBuf;

use clap::{Args, Subcommand};

use super::{description, package};

#[derive(Args)]
pub struct FmuArgs {
    #[command(subcommand)]
    command: FmuCommand,
}

#[derive(Subcommand)]
enum FmuCommand {
    /// Build `<out>/<modelIdentifier>.fmu` from a scene (`scene.toml` or a folder holding one,
    /// e.g. `fmu/spur_pair`). A bad scene is reported and no FMU is written.
    Build {
        scene: PathBuf,
        /// Output folder (created if missing).
        #[arg(long)]
        out: PathBuf,
        /// The cdylib to ship (default: `libgeardyn.so` next to this executable).
        #[arg(long)]
        cdylib: Option<PathBuf>,
    },
    /// Print the modelDescription.xml of a scene.
    Description { scene: PathBuf },
    /// Check that `modelDescription/<name>.xml` matches the generator for every `fmu/*`
    /// scene; with `--write`, regenerate them.
    Descriptions {
        /// Folder holding one folder per shipped FMU.
        #[arg(long, default_value = "fmu")]
        scenes: PathBuf,
        /// Folder of the checked-in descriptions.
        #[arg(long, default_value = "modelDescription")]
        dir: PathBuf,
        #[arg(long)]
        write: bool,
    },
}

pub fn run(args: FmuArgs) -> Result<(), String> {
    match args.command {
        FmuCommand::Build { scene, out, cdylib } => {
            let lib = match cdylib {
                Some(p) => p,
                None => package::find_cdylib()?,
            };
            let fmu = package::build_fmu(&scene, &out, &lib)?;
            println!("{}", fmu.display());
            Ok(())
        }
        FmuCommand::Description { scene } => {
            let (scene, _) = package::resolve_scene(&scene)?;
            let (xml, _) = description::for_scene(&scene)?;
            print!("{xml}");
            Ok(())
        }
        FmuCommand::Descriptions { scenes, dir, write } => {
            let problems = description::check_checked_in(&scenes, &dir, write)?;
            if problems.is_empty() {
                let what = if write { "refreshed" } else { "up to date" };
                println!("{}: {what}", dir.display());
                Ok(())
            } else {
                Err(problems.join("\n"))
            }
        }
    }
}
