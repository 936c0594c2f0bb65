//! `geardyn fmu`: the arguments of packaging and the checked-in model descriptions; the work
//! is `geardyn::commands::fmu`.

use std::path::PathBuf;

use clap::{Args, Subcommand};

use geardyn::commands::fmu;

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
            fmu::build(&scene, &out, cdylib.as_deref()).map(|_| ())
        }
        FmuCommand::Description { scene } => fmu::description(&scene),
        FmuCommand::Descriptions { scenes, dir, write } => fmu::descriptions(&scenes, &dir, write),
    }
}

/// The one FMU of `geardyn info` and `geardyn validate`.
#[derive(Args, Debug)]
pub struct FmuArg {
    /// The FMU (.fmu file or an extracted FMU folder).
    pub fmu: PathBuf,
}

/// `geardyn info`.
pub fn info(args: FmuArg) -> Result<(), String> {
    geardyn::commands::inspect::info(&args.fmu)
}

/// `geardyn validate`.
pub fn validate(args: FmuArg) -> Result<(), String> {
    geardyn::commands::inspect::validate(&args.fmu)
}
