//! `geardyn spectrum`: the exact spectrum of a scene's periodic steady state.

use std::path::PathBuf;

use clap::Args;

use geardyn::commands::runup::parse_range;
use geardyn::commands::spectrum::{spectrum_command_with, SpectrumPlot, SpectrumRequest};

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
    /// Frequency range of the plot, `LO:HI` in Hz.
    #[arg(long)]
    frequency_range: Option<String>,
    /// Order range of the plot, `LO:HI` in input-shaft orders (the plot is then drawn over
    /// order).
    #[arg(long)]
    order_range: Option<String>,
    /// The plot in dB re each signal's largest line.
    #[arg(long)]
    db: bool,
    /// How many of each signal's largest lines the plot names.
    #[arg(long, default_value_t = 8)]
    labels: usize,
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
    let frequency_range = (args.frequency_range.as_deref())
        .map(|r| parse_range("--frequency-range", r))
        .transpose()?;
    let order_range = (args.order_range.as_deref())
        .map(|r| parse_range("--order-range", r))
        .transpose()?;
    if frequency_range.is_some() && order_range.is_some() {
        return Err("--frequency-range and --order-range: give one of the two".into());
    }
    let drawn = SpectrumPlot {
        order_axis: order_range.is_some(),
        range: order_range.or(frequency_range),
        db: args.db,
        labelled: args.labels,
        ..SpectrumPlot::default()
    };
    print!(
        "{}",
        spectrum_command_with(
            &scene,
            &request,
            &args.out,
            args.plot.as_deref(),
            &drawn,
            args.progress.display()
        )?
    );
    Ok(())
}
