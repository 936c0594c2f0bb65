//! The subcommands of the `geardyn` binary: argument structs and thin handlers over the
//! library (one file per family of subcommands).

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};

use geardyn::scene::Scene;
use geardyn::simulation::ProgressDisplay;

pub mod analysis;
pub mod floquet;
pub mod fmu;
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

/// `--work-budget` of the analysis commands (`periodic`, `sweep`, `hb`, `spectrum`,
/// `waterfall`): overrides the scene's `solver.work_budget` for each run the analysis makes
/// (a shooting orbit, a sweep point, a run-up), as `simulate --work-budget` does for one run.
#[derive(clap::Args)]
pub struct WorkBudgetArg {
    /// Work budget of each run of the analysis, in work units (default: the scene's
    /// solver.work_budget, else 2e9; docs/fmu.md "Work budget"). A run beyond it stops with a
    /// message naming the likely cause.
    #[arg(long, allow_hyphen_values = true)]
    work_budget: Option<f64>,
}

/// `--progress` of the analysis commands (`periodic`, `sweep`, `hb`, `spectrum`,
/// `waterfall`), as `simulate --progress` asks for the one progress display
/// (`geardyn::simulation::Progress`).
#[derive(clap::Args)]
pub struct ProgressArg {
    /// Show the progress on stderr also when it is not a terminal (a plain `progress: …` line
    /// every 2 s and at the end); on a terminal it shows anyway.
    #[arg(long)]
    progress: bool,
}

impl ProgressArg {
    /// Where the progress shows ([`ProgressDisplay`]).
    pub fn display(&self) -> ProgressDisplay {
        if self.progress {
            ProgressDisplay::Always
        } else {
            ProgressDisplay::Terminal
        }
    }
}

impl WorkBudgetArg {
    /// Sets the scene's `solver.work_budget` from `--work-budget`, refusing a value the scene
    /// would refuse (not finite, or below 1).
    pub fn apply(&self, scene: &mut Scene) -> Result<(), String> {
        if let Some(x) = self.work_budget {
            scene.solver.work_budget = Some(geardyn::simulation::budget::check_limit(
                "--work-budget",
                x,
            )?);
        }
        Ok(())
    }
}

/// The scene of a command: a file or folder, or a built-in example (every scene command takes
/// it the same way).
#[derive(clap::Args)]
pub struct SceneArg {
    /// Scene file (`scene.toml`) or a folder holding one (e.g. `fmu/spur_pair`), single pair
    /// or drivetrain.
    #[arg(required_unless_present = "example", conflicts_with = "example")]
    scene: Option<PathBuf>,
    /// A built-in example scene instead of a file (e.g. `spur_pair`, `idler_gearset`,
    /// `runup_spur`).
    #[arg(long)]
    example: Option<String>,
}

impl SceneArg {
    /// The scene, in either format (single pair or drivetrain); with `--verbose` the kernel
    /// chosen for it, and why, goes to stderr.
    pub fn load(&self) -> Result<Scene, String> {
        load_any_scene(&self.scene, &self.example)
    }
}

fn load_any_scene(path: &Option<PathBuf>, example: &Option<String>) -> Result<Scene, String> {
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
