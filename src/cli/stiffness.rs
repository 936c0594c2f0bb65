//! `geardyn stiffness`: mesh stiffness from gear geometry (docs/stiffness.md).

use std::path::PathBuf;

use clap::Args;

use geardyn::commands::stiffness::{stiffness_command, StiffnessFiles};

#[derive(Args)]
pub struct StiffnessArgs {
    /// Gears file (TOML: module, pressure_angle, face_width, [pinion], [gear], [model]).
    gears: PathBuf,
    /// Pinion torque, N·m.
    #[arg(long, allow_negative_numbers = true)]
    torque: f64,
    /// Extended tooth contact.
    #[arg(long, value_parser = ["on", "off"], default_value = "on")]
    etc: String,
    /// Output CSV file (one row per knot of the curve).
    #[arg(long)]
    out: PathBuf,
    /// Also plot the curve, PNG or SVG by the extension (with ETC on, the ETC-off curve is drawn too).
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Number of Fourier harmonics in the summary.
    #[arg(long, default_value_t = 4)]
    harmonics: usize,
    /// Do not print the summary.
    #[arg(long)]
    quiet: bool,
    /// Also write the per-tooth-pair curve of Model-1 (`[mesh.pairs] kind = "geometry"`):
    /// xi (mesh cycles of the pair window), position (m from T1), the compliance terms (m/N)
    /// and the pair stiffness (N/m).
    #[arg(long)]
    pairs: Option<PathBuf>,
    /// Write each column's unit into the CSV header, `dte [m]` (default: bare names).
    #[arg(long)]
    units: bool,
}

pub fn run(args: StiffnessArgs) -> Result<(), String> {
    let files = StiffnessFiles {
        out: &args.out,
        plot: args.plot.as_deref(),
        harmonics: args.harmonics,
        quiet: args.quiet,
        units: args.units,
        pairs: args.pairs.as_deref(),
    };
    print!(
        "{}",
        stiffness_command(&args.gears, args.torque, args.etc == "on", &files)?
    );
    Ok(())
}
