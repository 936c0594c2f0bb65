//! `geardyn spectrum`: the exact spectrum of a scene's periodic steady state.

use std::path::PathBuf;

use clap::Args;

use geardyn::commands::spectrum::{spectrum_command, SpectrumRequest};

use super::SceneArg;

#[derive(Args)]
pub struct SpectrumArgs {
    #[command(flatten)]
    pub scene: SceneArg,
    /// Output CSV: frequency (Hz), amplitude and phase per signal, order label.
    #[arg(long)]
    out: PathBuf,
    /// Plot of the amplitude spectrum (PNG, or SVG by the extension).
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Output columns to transform, comma-separated (default: every mesh's DTE).
    #[arg(long, value_delimiter = ',')]
    signal: Vec<String>,
    /// Samples per period of the fastest mesh (the spectrum reaches half of it, in mesh orders).
    #[arg(long, default_value_t = 64)]
    samples: usize,
    /// Response periods spanned (finer resolution: 1/(periods·T)).
    #[arg(long, default_value_t = 1)]
    periods: u32,
    #[command(flatten)]
    budget: super::WorkBudgetArg,
    #[command(flatten)]
    progress: super::ProgressArg,
}

pub fn run(args: SpectrumArgs) -> Result<(), String> {
    let mut scene = args.scene.load()?;
    args.budget.apply(&mut scene)?;
    let request = SpectrumRequest {
        signals: args.signal,
        samples_per_mesh_period: args.samples,
        periods: args.periods,
    };
    print!(
        "{}",
        spectrum_command(
            &scene,
            &request,
            &args.out,
            args.plot.as_deref(),
            args.progress.display()
        )?
    );
    Ok(())
}
