//! `geardyn floquet` and `geardyn band`: the arguments of the monodromy of any linear scene
//! and of its parametric instability bands over speed; the commands are in
//! `geardyn::commands::floquet`.

use clap::Args;

use geardyn::commands::floquet as floquet_commands;
use geardyn::scene::Scene;

use super::SceneArg;

#[derive(Args)]
pub struct FloquetArgs {
    #[command(flatten)]
    pub scene: SceneArg,
    /// Input-gear speed: `19000rpm` or `1989.7rad/s`; a bare number is rad/s (default: the
    /// scene's `operating.pinion_speed` or `operating.input_speed`).
    #[arg(long, allow_hyphen_values = true)]
    speed: Option<String>,
    /// Friction coefficient μ of a `helical` stiffness (default: the scene's).
    #[arg(long, allow_negative_numbers = true)]
    mu: Option<f64>,
    /// Print JSON (monodromy, multipliers, load response, stiffness segments) instead of text.
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
pub struct BandArgs {
    #[command(flatten)]
    pub scene: SceneArg,
    /// Scanned input-gear speeds `from:to`, e.g. `15000rpm:25000rpm`; a bare number is
    /// rad/s.
    #[arg(long, allow_hyphen_values = true)]
    speed: String,
    /// Scan points (band edges are then bisected); narrower bands than the spacing are missed.
    #[arg(long, default_value_t = 400)]
    points: usize,
    /// Friction coefficient μ of a `helical` stiffness (default: the scene's).
    #[arg(long, allow_negative_numbers = true)]
    mu: Option<f64>,
}

fn scene_with(scene: &SceneArg, mu: Option<f64>) -> Result<Scene, String> {
    floquet_commands::with_friction(scene.load()?, mu)
}

pub fn floquet(args: FloquetArgs) -> Result<(), String> {
    let scene = scene_with(&args.scene, args.mu)?;
    print!(
        "{}",
        floquet_commands::floquet(scene, args.speed.as_deref(), args.json)?
    );
    Ok(())
}

pub fn band(args: BandArgs) -> Result<(), String> {
    let scene = scene_with(&args.scene, args.mu)?;
    print!(
        "{}",
        floquet_commands::band(&scene, &args.speed, args.points)?
    );
    Ok(())
}
