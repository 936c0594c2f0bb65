//! The waterfall of a run-up (`geardyn waterfall`, `docs/runup.md`): the scene's run-up
//! simulated on its output grid, one mesh signal (DTE or force) cut into short-time spectra by
//! [`crate::analysis::spectrum::waterfall`], each window tagged with the input gear's speed
//! from the speed profile. Mesh order k of a mesh with `z` pinion teeth per input revolution
//! lies on `f = k·z·n/60`; a resonance is where it meets a natural frequency.

use std::f64::consts::TAU;

use crate::analysis::spectrum::{waterfall, Waterfall, WaterfallOptions};
use crate::analysis::Report;
use crate::model::Drivetrain;
use crate::scene::Scene;
use crate::simulation::stream::{Progress, ProgressDisplay};
use crate::simulation::{DrivenModel, OutputGrid};
use crate::with_drivetrain;

/// Which signal the waterfall analyses: a mesh signal, or a planetary stage's central member
/// seen from the fixed frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RunupSignal {
    /// Dynamic transmission error, m.
    Dte,
    /// Dynamic mesh force, N.
    Force,
    /// The translation of central member `member` (gear index) of a planetary stage along the
    /// fixed frame's X (`axis` 0) or Y (1), m: `X = x cos θ_c − y sin θ_c`,
    /// `Y = x sin θ_c + y cos θ_c` with `θ_c` the carrier's nominal angle over the run-up
    /// (`docs/planetary.md`, "Fixed-frame spectra"; [`RunupSignal::parse_for`]).
    FixedFrame { member: usize, axis: usize },
}

impl RunupSignal {
    /// The signal's unit (the amplitude column of the CSV).
    pub fn unit(self) -> &'static str {
        match self {
            RunupSignal::Dte | RunupSignal::FixedFrame { .. } => "m",
            RunupSignal::Force => "N",
        }
    }

    /// `dte`, `force`, or `<member>.x_fixed` / `<member>.y_fixed` of a central member (sun,
    /// ring, carrier) of a planetary stage of `scene` with a bearing.
    pub fn parse_for(scene: &Scene, text: &str) -> Result<RunupSignal, String> {
        let fixed = (text.strip_suffix(".x_fixed").map(|m| (m, 0)))
            .or_else(|| text.strip_suffix(".y_fixed").map(|m| (m, 1)));
        let Some((name, axis)) = fixed else {
            return text.parse();
        };
        match scene.gear_index(name) {
            Some(member)
                if scene.planetary.iter().any(|st| st.is_central(member))
                    && (scene.gears[member].bearing.is_some()
                        || scene.planetary.iter().any(|st| st.carrier == member)) =>
            {
                Ok(RunupSignal::FixedFrame { member, axis })
            }
            _ => Err(format!(
                "'{text}': a fixed-frame signal names a central member (sun, ring or carrier) of \
                 a planetary stage with a bearing (translations x, y)"
            )),
        }
    }
}

/// How one sample of the analysed signal is read from an output row at time `t`.
enum Reader {
    Column(usize),
    /// Columns `x`, `y` rotated by the carrier's nominal angle `turns · φ_in(t)` (φ_in the
    /// input gear's nominal angle, [`ShaftClock`]).
    Fixed {
        x: usize,
        y: usize,
        axis: usize,
        turns: f64,
        clock: crate::analysis::spectrum::ShaftClock,
    },
}

impl Reader {
    /// The reader of `signal` of mesh `mesh` of `model` (the scene's drivetrain), the mesh
    /// index checked.
    fn for_mesh<M: Drivetrain>(
        model: &M,
        scene: &Scene,
        signal: RunupSignal,
        mesh: usize,
        speed: &crate::scene::Profile,
    ) -> Result<Reader, String> {
        let count = model.mesh_count();
        if mesh >= count {
            return Err(format!("mesh {mesh}: the scene has {count} mesh(es)"));
        }
        Reader::new(
            scene,
            signal,
            &model.row_names(),
            model.mesh_columns(mesh),
            speed,
        )
    }

    fn new(
        scene: &Scene,
        signal: RunupSignal,
        names: &[String],
        columns: crate::model::MeshColumns,
        speed: &crate::scene::Profile,
    ) -> Result<Reader, String> {
        Ok(match signal {
            RunupSignal::Dte => Reader::Column(columns.dte),
            RunupSignal::Force => Reader::Column(columns.force),
            RunupSignal::FixedFrame { member, axis } => {
                let name = &scene.gears[member].name;
                let column = |c: &str| {
                    let want = format!("{name}.{c}");
                    names
                        .iter()
                        .position(|n| *n == want)
                        .ok_or_else(|| format!("{name}.{c}_fixed: the scene has no column {want}"))
                };
                let st = scene
                    .planetary
                    .iter()
                    .find(|st| st.is_central(member))
                    .ok_or_else(|| format!("{name}: not a central member of a planetary stage"))?;
                let c = st.carrier;
                Reader::Fixed {
                    x: column("x")?,
                    y: column("y")?,
                    axis,
                    turns: scene.rotation[c] * scene.speed_ratio[c],
                    clock: crate::analysis::spectrum::ShaftClock::new(speed),
                }
            }
        })
    }

    fn value(&self, t: f64, row: &[f64]) -> f64 {
        match self {
            Reader::Column(c) => row[*c],
            Reader::Fixed {
                x,
                y,
                axis,
                turns,
                clock,
            } => {
                let (sin, cos) = (turns * clock.angle_at(t)).sin_cos();
                let (x, y) = (row[*x], row[*y]);
                if *axis == 0 {
                    x * cos - y * sin
                } else {
                    x * sin + y * cos
                }
            }
        }
    }
}

impl std::str::FromStr for RunupSignal {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "dte" => Ok(RunupSignal::Dte),
            "force" => Ok(RunupSignal::Force),
            _ => Err(format!("'{s}': expected dte or force")),
        }
    }
}

/// A run-up's waterfall and what locates its orders.
#[derive(Debug, Clone)]
pub struct RunupWaterfall {
    pub map: Waterfall,
    /// Mesh cycles per input-gear revolution of the analysed mesh (its mesh order 1 in input
    /// shaft orders).
    pub mesh_order: f64,
}

/// Simulates the run-up of `scene` (it must have `operating.speed_profile`) over its
/// `solver.stop_time` on its `output_interval` grid and returns the waterfall of mesh `mesh`'s
/// `signal` (the 0 Hz line is the window mean), with the input gear's speed in rpm.
pub fn runup_waterfall(
    scene: &Scene,
    mesh: usize,
    signal: RunupSignal,
    options: &WaterfallOptions,
) -> Result<RunupWaterfall, String> {
    runup_waterfall_reporting(scene, mesh, signal, options, &|_, _| {})
}

/// [`runup_waterfall`], reporting the run-up's time reached to `report`.
pub fn runup_waterfall_reporting(
    scene: &Scene,
    mesh: usize,
    signal: RunupSignal,
    options: &WaterfallOptions,
    report: Report,
) -> Result<RunupWaterfall, String> {
    let Some(speed) = scene.profiles.speed.clone() else {
        return Err(format!(
            "scene {}: a waterfall needs a run-up (operating.speed_profile, docs/runup.md)",
            scene.name
        ));
    };
    let (stop, interval) = (scene.solver.stop_time, scene.solver.output_interval);
    with_drivetrain!(scene.simulation()?, sim => {
        let mut sim = sim;
        crate::simulation::RunLimits::default().check(&sim.model().run_scales(), stop, interval)?;
        let reader = Reader::for_mesh(sim.model(), scene, signal, mesh, &speed)?;
        let mut t = Vec::new();
        let mut x = Vec::new();
        let mut row = Vec::new();
        sim.sample(OutputGrid::new(stop, interval), |sim, time| {
            if t.len().is_multiple_of(1024) {
                report(time / stop, &|| {
                    format!("waterfall: run-up at t = {time:.6e} s of {stop} s, {} rows", t.len())
                });
            }
            sim.model().output_row(time, sim.y(), &mut row);
            t.push(time);
            x.push(reader.value(time, &row));
            Ok(())
        })?;
        // The last grid point may be the stop time off the grid: the spectrum needs one interval.
        if t.len() > 2 && ((t[t.len() - 1] - t[t.len() - 2]) - interval).abs() > 1e-9 * interval {
            t.pop();
            x.pop();
        }
        let rpm: Vec<f64> = t.iter().map(|&ti| speed.value_at(ti) * 60.0 / TAU).collect();
        // Mesh cycles per input revolution: the mesh frequency at 1 rad/s times 2π.
        let mut probe = sim.model().clone();
        probe.set_input_speed(0.0, 1.0)?;
        let mesh_order = probe.mesh_frequency(mesh) * TAU;
        let map = waterfall(&t, &x, &rpm, options)?;
        Ok(RunupWaterfall { map, mesh_order })
    })
}

/// How a run-up is order-tracked ([`runup_order_cuts`]).
#[derive(Debug, Clone, PartialEq)]
pub struct OrderTrackRequest {
    /// Samples per cycle of the analysed mesh (the samples per input revolution are this
    /// times the mesh order, rounded): the angle-domain Nyquist order is half of that.
    pub samples_per_mesh_cycle: usize,
    /// Whole input revolutions per block: the order resolution is `1/revolutions`.
    pub revolutions: usize,
    /// Fraction of a block shared with the next, in `[0, 1)`.
    pub overlap: f64,
    pub window: crate::analysis::spectrum::Window,
    /// Orders of the analysed mesh's frequency (1 = mesh order 1).
    pub mesh_orders: Vec<f64>,
    /// Input-shaft orders (cycles per input revolution).
    pub shaft_orders: Vec<f64>,
}

impl Default for OrderTrackRequest {
    fn default() -> Self {
        OrderTrackRequest {
            samples_per_mesh_cycle: 64,
            revolutions: 8,
            overlap: 0.5,
            window: crate::analysis::spectrum::Window::Hann,
            mesh_orders: vec![1.0, 2.0, 3.0],
            shaft_orders: Vec::new(),
        }
    }
}

/// A run-up's order cuts and what locates their orders.
#[derive(Debug, Clone)]
pub struct RunupOrderCuts {
    /// Orders in input-shaft orders, in the order of [`OrderTrackRequest`]: the mesh orders
    /// first, then the shaft orders.
    pub cuts: crate::analysis::spectrum::OrderCuts,
    /// A name per order: `mesh order k` or `shaft order o`.
    pub names: Vec<String>,
    /// Mesh cycles per input revolution of the analysed mesh.
    pub mesh_order: f64,
    pub samples_per_revolution: usize,
}

/// Most angle-domain samples of one order-tracked run-up (128 MB).
pub const MAX_ORDER_SAMPLES: f64 = 16_777_216.0;

/// Order tracking of mesh `mesh`'s `signal` over the run-up of `scene`: the run is sampled
/// at equal increments of the input gear's nominal angle `φ(t) = ∫Ω dt` (the profile's exact
/// integral, [`ShaftClock`]; the mesh phase is `z·φ/2π` of it), the driver stopping at each
/// of those instants on the continuous solution ([`runup_angle_record`]), and the record is
/// cut into blocks of whole revolutions ([`crate::analysis::spectrum::order_cuts`]).
pub fn runup_order_cuts(
    scene: &Scene,
    mesh: usize,
    signal: RunupSignal,
    request: &OrderTrackRequest,
    report: Report,
) -> Result<RunupOrderCuts, String> {
    let record = runup_angle_record(scene, mesh, signal, request, report)?;
    let cuts =
        crate::analysis::spectrum::order_cuts(&record.samples, 0, &record.clock, &record.options)?;
    Ok(RunupOrderCuts {
        cuts,
        names: record.names,
        mesh_order: record.mesh_order,
        samples_per_revolution: record.options.samples_per_revolution,
    })
}

/// A run-up's signal in the angle domain and what its order tracking needs.
#[derive(Debug, Clone)]
pub struct AngleRecord {
    /// The signal at the input angles `k·2π/samples_per_revolution`, `k = 0, 1, …`.
    pub samples: Vec<f64>,
    pub clock: crate::analysis::spectrum::ShaftClock,
    /// The request in input-shaft orders, checked.
    pub options: crate::analysis::spectrum::OrderTrackOptions,
    /// A name per order of `options.orders`: `mesh order k` or `shaft order o`.
    pub names: Vec<String>,
    /// Mesh cycles per input revolution of the analysed mesh.
    pub mesh_order: f64,
}

/// Mesh `mesh`'s `signal` over the run-up of `scene`, sampled at equal increments of the
/// input gear's nominal angle on the continuous solution (see [`runup_order_cuts`]).
pub fn runup_angle_record(
    scene: &Scene,
    mesh: usize,
    signal: RunupSignal,
    request: &OrderTrackRequest,
    report: Report,
) -> Result<AngleRecord, String> {
    use crate::analysis::spectrum::{OrderTrackOptions, ShaftClock};
    let Some(speed) = scene.profiles.speed.clone() else {
        return Err(format!(
            "scene {}: order tracking needs a run-up (operating.speed_profile, docs/runup.md)",
            scene.name
        ));
    };
    if request.samples_per_mesh_cycle < 4 {
        return Err(format!(
            "--order-samples = {}: need at least 4 samples per mesh cycle",
            request.samples_per_mesh_cycle
        ));
    }
    let clock = ShaftClock::new(&speed);
    let stop = scene.solver.stop_time;
    with_drivetrain!(scene.simulation()?, sim => {
        let mut sim = sim;
        crate::simulation::RunLimits::default().check_work(&sim.model().run_scales(), stop)?;
        let reader = Reader::for_mesh(sim.model(), scene, signal, mesh, &speed)?;
        let mut probe = sim.model().clone();
        probe.set_input_speed(0.0, 1.0)?;
        let mesh_order = probe.mesh_frequency(mesh) * TAU;
        let per_rev = (request.samples_per_mesh_cycle as f64 * mesh_order).round().max(8.0);
        let turned = clock.angle_at(stop);
        let total = (turned / TAU * per_rev).floor() + 1.0;
        if !(total <= MAX_ORDER_SAMPLES) {
            return Err(format!(
                "order tracking: {:.4} input revolutions at {per_rev} samples each are                  {total:e} samples, more than the {MAX_ORDER_SAMPLES:e} a run-up may take                  (lower --order-samples)",
                turned / TAU
            ));
        }
        let per_rev = per_rev as usize;
        let total = total as u64;
        let mut names = Vec::new();
        let mut orders = Vec::new();
        for &k in &request.mesh_orders {
            names.push(format!("mesh order {k}"));
            orders.push(k * mesh_order);
        }
        for &o in &request.shaft_orders {
            names.push(format!("shaft order {o}"));
            orders.push(o);
        }
        let options = OrderTrackOptions {
            samples_per_revolution: per_rev,
            revolutions: request.revolutions,
            overlap: request.overlap,
            window: request.window,
            orders,
        };
        options.check().map_err(|e| {
            format!("{e} (mesh order 1 = shaft order {mesh_order}, {per_rev} samples per revolution)")
        })?;
        let dphi = TAU / per_rev as f64;
        let times = (0..total).map_while(|k| clock.time_at_angle(k as f64 * dphi).filter(|&t| t <= stop));
        let mut x = Vec::with_capacity(total as usize);
        let mut row = Vec::new();
        sim.sample(times, |sim, time| {
            if x.len().is_multiple_of(4096) {
                report(time / stop, &|| {
                    format!("order tracking: run-up at t = {time:.6e} s of {stop} s, {} samples", x.len())
                });
            }
            sim.model().output_row(time, sim.y(), &mut row);
            x.push(reader.value(time, &row));
            Ok(())
        })?;
        Ok(AngleRecord { samples: x, clock, options, names, mesh_order })
    })
}

impl RunupOrderCuts {
    /// One row per block: `time_s, revolutions, speed_rad_s, speed_rpm`, then per order
    /// `order_<o>_amplitude_<unit>` and `order_<o>_phase_rad` (`o` in input-shaft orders).
    pub fn write_csv(&self, path: &std::path::Path, unit: &str) -> Result<(), String> {
        let mut header: Vec<String> = ["time_s", "revolutions", "speed_rad_s", "speed_rpm"]
            .map(String::from)
            .to_vec();
        for o in &self.cuts.orders {
            header.push(format!("order_{}_amplitude_{unit}", order_text(*o)));
            header.push(format!("order_{}_phase_rad", order_text(*o)));
        }
        let names: Vec<&str> = header.iter().map(String::as_str).collect();
        let mut csv = crate::output::CsvWriter::create(path, &names)?;
        let c = &self.cuts;
        for b in 0..c.time.len() {
            let mut row = vec![
                c.time[b],
                c.angle[b] / TAU,
                c.speed[b],
                c.speed[b] * 60.0 / TAU,
            ];
            for k in 0..c.orders.len() {
                row.push(c.amplitude[b][k]);
                row.push(c.phase[b][k]);
            }
            csv.row(row)?;
        }
        csv.finish()
    }

    /// Amplitude of each order over the input speed (rpm), log or dB re the largest value,
    /// to PNG or SVG by the extension.
    pub fn save_plot(
        &self,
        path: &std::path::Path,
        title: &str,
        unit: &str,
        db: bool,
    ) -> Result<(), String> {
        use crate::plot::{Axis, Plot, Series};
        const COLORS: [&str; 6] = [
            "#2471a3", "#c0392b", "#16a085", "#8e44ad", "#d68910", "#566573",
        ];
        let c = &self.cuts;
        let peak = c
            .amplitude
            .iter()
            .flatten()
            .fold(0.0, |m: f64, &v| m.max(v));
        let labels: Vec<String> = (0..c.orders.len())
            .map(|k| format!("{} ({} × shaft)", self.names[k], order_text(c.orders[k])))
            .collect();
        let series = (0..c.orders.len())
            .map(|k| Series {
                label: &labels[k],
                color: COLORS[k % COLORS.len()],
                points: (0..c.time.len())
                    .map(|b| {
                        let a = c.amplitude[b][k];
                        let y = if db { 20.0 * (a / peak).log10() } else { a };
                        (c.speed[b] * 60.0 / TAU, y)
                    })
                    .collect(),
                dashed: false,
                markers: false,
                line: true,
            })
            .collect();
        let db_title = format!("level (dB re {})", crate::plot::engineering(peak, unit));
        let y = if db {
            Axis::new(&db_title, "")
        } else {
            Axis::log("amplitude", unit)
        };
        Plot {
            title,
            x: Axis::new("input speed", "rpm"),
            y,
            series,
            bands: Vec::new(),
            band_label: "",
            markers: Vec::new(),
        }
        .save(path)
    }
}

impl RunupOrderCuts {
    /// What `waterfall --order-cuts` prints: where the cuts went, their resolution, and each
    /// order's largest amplitude with the speed where it occurs.
    pub fn summary(&self, path: &std::path::Path, unit: &str) -> String {
        let c = &self.cuts;
        let revolutions = if c.angle.len() > 1 {
            // Blocks are whole revolutions; the spacing of their centres is the step.
            (c.angle[1] - c.angle[0]) / TAU
        } else {
            f64::NAN
        };
        let mut text = format!(
            "order cuts → {} ({} blocks, {} samples per input revolution from the continuous \
             solution, blocks every {revolutions:.3} revolutions)\n",
            path.display(),
            c.time.len(),
            self.samples_per_revolution
        );
        for k in 0..c.orders.len() {
            let best =
                (0..c.time.len()).max_by(|&a, &b| c.amplitude[a][k].total_cmp(&c.amplitude[b][k]));
            if let Some(b) = best {
                text.push_str(&format!(
                    "  {:<18} (shaft order {:>9}): largest {} at {:.0} rpm\n",
                    self.names[k],
                    order_text(c.orders[k]),
                    crate::plot::engineering(c.amplitude[b][k], unit),
                    c.speed[b] * 60.0 / TAU
                ));
            }
        }
        text
    }
}

/// The orders a fixed sensor sees on a planetary stage's central member, in input-shaft
/// orders, for a [`RunupSignal::FixedFrame`] (none for a mesh signal): the planet-pass orders
/// `k×<carrier>_planet_pass`, `k N |o_c − o_r|` (k = 1…3, the planets passing a point of the
/// ring), and the sidebands `1×mesh ± 1×<carrier>` of mesh order 1 (McFadden & Smith 1985;
/// `docs/planetary.md`, "Fixed-frame spectra"), with `o_g` a member's signed speed over the
/// input speed.
fn fixed_frame_orders(scene: &Scene, signal: RunupSignal, mesh_order: f64) -> Vec<(String, f64)> {
    let RunupSignal::FixedFrame { member, .. } = signal else {
        return Vec::new();
    };
    let Some(st) = scene.planetary.iter().find(|st| st.is_central(member)) else {
        return Vec::new();
    };
    let order = |g: usize| scene.rotation[g] * scene.speed_ratio[g];
    let carrier = &scene.gears[st.carrier].name;
    let pass = st.planets.len() as f64 * (order(st.carrier) - order(st.ring)).abs();
    let mut orders: Vec<(String, f64)> = (1..=3)
        .map(|k| (format!("{k}×{carrier}_planet_pass"), k as f64 * pass))
        .collect();
    let c = order(st.carrier).abs();
    orders.push((format!("1×mesh-1×{carrier}"), mesh_order - c));
    orders.push((format!("1×mesh+1×{carrier}"), mesh_order + c));
    orders
}

/// An order as a column name takes it: `38`, `26.272727`.
pub fn order_text(o: f64) -> String {
    let s = format!("{o:.6}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// The mesh names of a scene as `--mesh` takes them (`mesh` for the single pair).
pub fn mesh_names(scene: &Scene) -> Result<Vec<String>, String> {
    with_drivetrain!(scene.simulation()?, sim => {
        Ok((0..sim.model().mesh_count())
            .map(|n| {
                let p = sim.model().mesh_prefix(n);
                if p.is_empty() { "mesh".to_owned() } else { p.trim_end_matches('.').to_owned() }
            })
            .collect())
    })
}

/// What `geardyn waterfall` analyses, as the command line gives it.
#[derive(Debug, Clone)]
pub struct WaterfallRequest<'a> {
    /// The mesh by name (a drivetrain); `None`: the first mesh.
    pub mesh: Option<&'a str>,
    /// `dte` or `force`.
    pub signal: &'a str,
    /// Samples per short-time window.
    pub segment: usize,
    /// Fraction of a window shared with the next.
    pub overlap: f64,
    /// `hann` or `flattop`.
    pub window: &'a str,
    /// Frequency range of the map (CSV and plot), Hz.
    pub frequency_range: Option<(f64, f64)>,
    /// Order range of the map (CSV and plot), input-shaft orders; the plot is then drawn
    /// over order.
    pub order_range: Option<(f64, f64)>,
    /// Colour range of the map's plot below its largest value, dB.
    pub dynamic_range: f64,
    /// Order cuts of the run-up (angle-domain order tracking) to this CSV.
    pub order_cuts: Option<&'a std::path::Path>,
    /// Plot of the order cuts.
    pub order_plot: Option<&'a std::path::Path>,
    /// The order-cut plot in dB re its largest value (else a log amplitude axis).
    pub db: bool,
    pub tracking: OrderTrackRequest,
}

impl Default for WaterfallRequest<'_> {
    fn default() -> Self {
        WaterfallRequest {
            mesh: None,
            signal: "dte",
            segment: 1000,
            overlap: 0.5,
            window: "hann",
            frequency_range: None,
            order_range: None,
            dynamic_range: crate::plot::DYNAMIC_RANGE_DB,
            order_cuts: None,
            order_plot: None,
            db: false,
            tracking: OrderTrackRequest::default(),
        }
    }
}

/// `LO:HI` as two numbers with `LO < HI` (the message names `flag`).
pub fn parse_range(flag: &str, text: &str) -> Result<(f64, f64), String> {
    let parts: Vec<&str> = text.split(':').collect();
    let numbers: Option<Vec<f64>> = (parts.len() == 2)
        .then(|| parts.iter().map(|p| p.trim().parse::<f64>().ok()).collect())
        .flatten();
    match numbers.as_deref() {
        Some(&[lo, hi]) if lo.is_finite() && hi.is_finite() && lo < hi => Ok((lo, hi)),
        _ => Err(format!(
            "{flag} {text:?}: expected LO:HI, two finite numbers with LO < HI"
        )),
    }
}

/// A mesh of `scene` by its `--mesh` name (`None`: the first).
fn mesh_index(scene: &Scene, name: Option<&str>) -> Result<usize, String> {
    match name {
        None => Ok(0),
        Some(name) => {
            let names = mesh_names(scene)?;
            names.iter().position(|n| n == name).ok_or_else(|| {
                format!(
                    "--mesh '{name}': no such mesh (meshes: {})",
                    names.join(", ")
                )
            })
        }
    }
}

/// `geardyn waterfall`: the order map of the scene's run-up to the CSV `out` (and its plot),
/// the order cuts when asked, and the report of what was written.
/// The run-up shows on stderr as `progress` says ([`Progress`]).
pub fn waterfall_command(
    scene: &Scene,
    request: &WaterfallRequest,
    out: &std::path::Path,
    plot: Option<&std::path::Path>,
    progress: ProgressDisplay,
) -> Result<String, String> {
    use crate::analysis::spectrum::{WaterfallPlot, Window};
    for path in [plot, request.order_plot].into_iter().flatten() {
        crate::plot::Format::of(path)?;
    }
    if request.order_plot.is_some() && request.order_cuts.is_none() {
        return Err("--order-plot needs --order-cuts FILE (the CSV of the cuts it draws)".into());
    }
    if !(request.dynamic_range.is_finite() && request.dynamic_range > 0.0) {
        return Err(format!(
            "--dynamic-range = {}: must be a positive number of dB",
            request.dynamic_range
        ));
    }
    let signal =
        RunupSignal::parse_for(scene, request.signal).map_err(|e| format!("--signal {e}"))?;
    let window = match request.window {
        "hann" => Window::Hann,
        "flattop" => Window::FlatTop,
        other => return Err(format!("--window '{other}': expected hann or flattop")),
    };
    let mesh = mesh_index(scene, request.mesh)?;
    let options = WaterfallOptions {
        segment: request.segment,
        overlap: request.overlap,
        window,
    };
    let mut shown = Progress::of_analysis("waterfall: starting", progress);
    let w = runup_waterfall_reporting(scene, mesh, signal, &options, &shown.reporter());
    let cuts = match (request.order_cuts, &w) {
        (Some(_), Ok(_)) => Some(runup_order_cuts(
            scene,
            mesh,
            signal,
            &request.tracking,
            &shown.reporter(),
        )),
        _ => None,
    };
    shown.finish();
    let w = w?;
    let cuts = cuts.transpose()?;
    w.map.write_csv_within(
        out,
        signal.unit(),
        request.frequency_range,
        request.order_range,
    )?;
    let stage_orders = fixed_frame_orders(scene, signal, w.mesh_order);
    if let Some(path) = plot {
        let mut orders: Vec<(String, f64)> = (1..=3)
            .map(|k| (format!("{k}×mesh"), k as f64 * w.mesh_order))
            .collect();
        // The planet pass is far from the mesh orders; the sidebands would cover 1×mesh.
        orders.extend(stage_orders.iter().take(1).cloned());
        let title = format!("{}: waterfall of the {}", scene.name, request.signal);
        let drawn = WaterfallPlot {
            orders,
            order_axis: request.order_range.is_some(),
            x_range: request.order_range.or(request.frequency_range),
            dynamic_range: request.dynamic_range,
            unit: signal.unit().to_string(),
        };
        w.map.save_plot_with(path, &title, &drawn)?;
    }
    let map = &w.map;
    let (lo, hi) = (
        map.rpm.iter().copied().fold(f64::INFINITY, f64::min),
        map.rpm.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    );
    let mut text = format!(
        "scene {} → {} ({} windows × {} frequencies, {:.0}–{:.0} rpm, {:.1} Hz resolution)\n  \
         mesh order 1 = shaft order {:.4} of the input gear: f = {:.4}·n/60 Hz\n",
        scene.name,
        out.display(),
        map.rpm.len(),
        map.frequency.len(),
        lo,
        hi,
        map.frequency.get(1).copied().unwrap_or(f64::NAN),
        w.mesh_order,
        w.mesh_order
    );
    for (name, order) in &stage_orders {
        text.push_str(&format!(
            "  {name} = shaft order {} of the input gear (fixed frame)\n",
            order_text(*order)
        ));
    }
    if let (Some(c), Some(path)) = (&cuts, request.order_cuts) {
        c.write_csv(path, signal.unit())?;
        if let Some(plot) = request.order_plot {
            let title = format!("{}: order cuts of the {}", scene.name, request.signal);
            c.save_plot(plot, &title, signal.unit(), request.db)?;
        }
        text.push_str(&c.summary(path, signal.unit()));
    }
    Ok(text)
}
