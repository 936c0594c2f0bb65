//! `geardyn waterfall`: the order map of a run-up scene (`docs/runup.md`, "Waterfall"); the
//! work is `geardyn::commands::runup`.

use std::path::PathBuf;

use clap::Args;
use geardyn::commands::runup::{
    parse_range, waterfall_command, OrderTrackRequest, WaterfallRequest,
};

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
    /// The signal: dte (m) or force (N) of the mesh, or `<member>.x_fixed` / `<member>.y_fixed`
    /// (m): a planetary stage's sun, ring or carrier translation seen from the fixed frame,
    /// with the planet-pass orders labelled.
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
    /// Also draw the map (frequency or order over speed, colour in dB re its largest value,
    /// with a colour bar) with mesh orders 1–3 overlaid (PNG or SVG by the extension).
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Frequency range of the map, `LO:HI` in Hz (CSV rows and plot).
    #[arg(long)]
    pub frequency_range: Option<String>,
    /// Order range of the map, `LO:HI` in input-shaft orders (CSV rows and plot; the plot is
    /// then drawn over order).
    #[arg(long)]
    pub order_range: Option<String>,
    /// Colour range of the map's plot below its largest value, dB.
    #[arg(long, default_value_t = 60.0)]
    pub dynamic_range: f64,
    /// Order tracking in the angle domain: the amplitude and phase of each order against
    /// speed, one row per block, to this CSV (time_s, revolutions, speed_rad_s, speed_rpm,
    /// order_<o>_amplitude_<unit>, order_<o>_phase_rad).
    #[arg(long)]
    pub order_cuts: Option<PathBuf>,
    /// Orders of the analysed mesh to track (1 = mesh order 1).
    #[arg(long, value_delimiter = ',', default_value = "1,2,3")]
    pub mesh_orders: Vec<f64>,
    /// Input-shaft orders to track as well, e.g. sidebands `37,39` (cycles per revolution).
    #[arg(long, value_delimiter = ',')]
    pub shaft_orders: Vec<f64>,
    /// Whole input revolutions per order-tracking block (order resolution 1/revolutions).
    #[arg(long, default_value_t = 8)]
    pub revolutions: usize,
    /// Angle-domain samples per mesh cycle for order tracking.
    #[arg(long, default_value_t = 64)]
    pub order_samples: usize,
    /// Plot of the order cuts against speed (PNG or SVG by the extension).
    #[arg(long)]
    pub order_plot: Option<PathBuf>,
    /// The order-cut plot in dB re its largest value.
    #[arg(long)]
    pub db: bool,
    #[command(flatten)]
    pub budget: super::WorkBudgetArg,
    #[command(flatten)]
    pub progress: super::ProgressArg,
}

pub fn run(args: WaterfallArgs) -> Result<(), String> {
    let mut scene = args.scene.load()?;
    args.budget.apply(&mut scene)?;
    // A bad --window is refused by the waterfall, which names it.
    let window = geardyn::analysis::spectrum::Window::parse(&args.window)
        .unwrap_or(geardyn::analysis::spectrum::Window::Hann);
    let request = WaterfallRequest {
        mesh: args.mesh.as_deref(),
        signal: &args.signal,
        segment: args.segment,
        overlap: args.overlap,
        window: &args.window,
        frequency_range: (args.frequency_range.as_deref())
            .map(|r| parse_range("--frequency-range", r))
            .transpose()?,
        order_range: (args.order_range.as_deref())
            .map(|r| parse_range("--order-range", r))
            .transpose()?,
        dynamic_range: args.dynamic_range,
        order_cuts: args.order_cuts.as_deref(),
        order_plot: args.order_plot.as_deref(),
        db: args.db,
        tracking: OrderTrackRequest {
            samples_per_mesh_cycle: args.order_samples,
            revolutions: args.revolutions,
            overlap: args.overlap,
            window,
            mesh_orders: args.mesh_orders,
            shaft_orders: args.shaft_orders,
        },
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
