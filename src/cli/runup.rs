//! `geardyn waterfall`: the order map of a run-up scene (`docs/runup.md`, "Waterfall"); the
//! work is `geardyn::commands::runup`.

use std::path::PathBuf;

use clap::Args;
use geardyn::commands::runup::{waterfall_command, WaterfallRequest};

use super::SceneArg;

#[derive(Args)]
pub struct WaterfallArgs {
    #[command(flatten)]
    pub scene: SceneArg,
    /// Output CSV, long form: time_s, rpm, frequency_Hz, order, amplitude_<unit>.
    #[arg(long)]
    pub out: PathBuf,
    /// Mesh to analyse: its name in a drivetrain (default: the first mesh).
    #[arg(long)]
    pub mesh: Option<String>,
    /// The signal: dte (m) or force (N).
    #[arg(long, default_value = "dte")]
    pub signal: String,
    /// Samples per short-time window (frequency resolution 1/(segment·output_interval)).
    #[arg(long, default_value_t = 1000)]
    pub segment: usize,
    /// Fraction of a window shared with the next, in [0, 1).
    #[arg(long, default_value_t = 0.5)]
    pub overlap: f64,
    /// Window: hann (fine resolution) or flattop (amplitudes within 0.1 %).
    #[arg(long, default_value = "hann")]
    pub window: String,
    /// Also draw the map as a Campbell diagram (frequency over speed, amplitude in dB) with
    /// mesh orders 1–3 overlaid (PNG or SVG by the extension).
    #[arg(long)]
    pub plot: Option<PathBuf>,
    #[command(flatten)]
    pub budget: super::WorkBudgetArg,
    #[command(flatten)]
    pub progress: super::ProgressArg,
}

pub fn run(args: WaterfallArgs) -> Result<(), String> {
    let mut scene = args.scene.load()?;
    args.budget.apply(&mut scene)?;
    let request = WaterfallRequest {
        mesh: args.mesh.as_deref(),
        signal: &args.signal,
        segment: args.segment,
        overlap: args.overlap,
        window: &args.window,
    };
    print!(
        "{}",
        waterfall_command(
            &scene,
            &request,
            &args.out,
            args.plot.as_deref(),
            args.progress.display()
        )?
    );
    Ok(())
}
