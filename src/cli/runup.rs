//! `geardyn waterfall`: the order map of a run-up scene (`docs/runup.md`, "Waterfall"); the
//! work is `geardyn::commands::runup`.

use std::path::PathBuf;

use clap::Args;
use geardyn::analysis::spectrum::{WaterfallOptions, Window};
use geardyn::commands::runup::{runup_waterfall, RunupSignal};
use geardyn::plot::Format;

use super::load_any_scene;

#[derive(Args)]
pub struct WaterfallArgs {
    /// PairScene file with `[operating.speed_profile]` (single pair or drivetrain).
    #[arg(required_unless_present = "example", conflicts_with = "example")]
    pub scene: Option<PathBuf>,
    /// A built-in example scene instead of a file (e.g. `runup_spur`).
    #[arg(long)]
    pub example: Option<String>,
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
}

pub fn run(args: WaterfallArgs) -> Result<(), String> {
    let scene = load_any_scene(&args.scene, &args.example)?;
    if let Some(path) = &args.plot {
        Format::of(path)?;
    }
    let signal: RunupSignal = args.signal.parse().map_err(|e| format!("--signal {e}"))?;
    let window = match args.window.as_str() {
        "hann" => Window::Hann,
        "flattop" => Window::FlatTop,
        other => return Err(format!("--window '{other}': expected hann or flattop")),
    };
    let mesh = match &args.mesh {
        None => 0,
        Some(name) => {
            let names = geardyn::commands::runup::mesh_names(&scene)?;
            names.iter().position(|n| n == name).ok_or_else(|| {
                format!(
                    "--mesh '{name}': no such mesh (meshes: {})",
                    names.join(", ")
                )
            })?
        }
    };
    let options = WaterfallOptions {
        segment: args.segment,
        overlap: args.overlap,
        window,
    };
    let w = runup_waterfall(&scene, mesh, signal, &options)?;
    w.map.write_csv(&args.out, signal.unit())?;
    if let Some(path) = &args.plot {
        let orders: Vec<(String, f64)> = (1..=3)
            .map(|k| (format!("{k}×mesh"), k as f64 * w.mesh_order))
            .collect();
        let title = format!("{}: waterfall of the {}", scene.name, args.signal);
        w.map.save_plot(path, &title, &orders)?;
    }
    let map = &w.map;
    let (lo, hi) = (
        map.rpm.iter().copied().fold(f64::INFINITY, f64::min),
        map.rpm.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    );
    println!(
        "scene {} → {} ({} windows × {} frequencies, {:.0}–{:.0} rpm, {:.1} Hz resolution)",
        scene.name,
        args.out.display(),
        map.rpm.len(),
        map.frequency.len(),
        lo,
        hi,
        map.frequency.get(1).copied().unwrap_or(f64::NAN)
    );
    println!(
        "  mesh order 1 = shaft order {:.4} of the input gear: f = {:.4}·n/60 Hz",
        w.mesh_order, w.mesh_order
    );
    Ok(())
}
