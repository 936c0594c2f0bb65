//! `geardyn spectrum`: the exact spectrum of a scene's periodic steady state, with its lines
//! named in mesh and shaft orders (`docs/spectrum.md`).

use std::path::Path;

use crate::analysis::spectrum::{
    exact_dft, fixed_frame_lines, label_lines, model_aliasing_warning, orbit_lines, windowed_fft,
    OrderLabel, Spectrum, Window,
};
use crate::analysis::{shoot_reporting, Report, ShootingOptions};
use crate::model::{response_period, Drivetrain};
use crate::scene::Scene;
use crate::simulation::stream::{Progress, ProgressDisplay};
use crate::with_drivetrain;

/// What to transform and how finely.
#[derive(Debug, Clone)]
pub struct SpectrumRequest {
    /// Output columns (as `simulate` names them); empty: every mesh's DTE.
    pub signals: Vec<String>,
    /// Samples per period of the fastest mesh: the spectrum reaches half of it in mesh orders.
    pub samples_per_mesh_period: usize,
    /// Response periods spanned (the resolution is `1/(periods·T)`).
    pub periods: u32,
}

impl Default for SpectrumRequest {
    fn default() -> Self {
        SpectrumRequest {
            signals: Vec::new(),
            samples_per_mesh_period: 64,
            periods: 1,
        }
    }
}

/// One signal's spectrum with its order labels.
#[derive(Debug, Clone)]
pub struct SignalSpectrum {
    pub column: String,
    /// Unit of the amplitudes (the column's unit).
    pub unit: String,
    pub spectrum: Spectrum,
    pub labels: Vec<Option<OrderLabel>>,
}

/// The spectra of one periodic steady state.
#[derive(Debug, Clone)]
pub struct SpectrumReport {
    pub scene: String,
    /// Time spanned by the samples (an integer number of response periods), s.
    pub duration: f64,
    pub samples: usize,
    /// How the lines were obtained.
    pub method: Lines,
    pub signals: Vec<SignalSpectrum>,
}

/// How a [`SpectrumReport`]'s lines were obtained.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Lines {
    /// Integrated over each exact segment of the orbit ([`orbit_lines`]): alias-free, the
    /// same whatever `--samples` (which then sets only how many lines, `samples / 2`).
    Integrated,
    /// The DFT of `samples` uniform samples (the RK propagator, or a record that is not an
    /// orbit): exact for a band-limited signal, aliased otherwise.
    Sampled,
    /// The flat-top windowed FFT of a record that does not span an integer number of response
    /// periods (`simulate --spectrum`): each line within the window's amplitude error, the
    /// leakage of the window around it.
    Windowed,
}

impl Lines {
    /// How the lines were obtained, as the plot title and the command line say it.
    pub fn describe(self) -> &'static str {
        match self {
            Lines::Integrated => "integrated over each segment, alias-free",
            Lines::Sampled => "exact DFT of integer periods",
            Lines::Windowed => "flat-top windowed FFT: not an integer number of periods",
        }
    }
}

/// The unit of an output column, from the naming convention of `simulate`'s columns.
pub fn column_unit(name: &str) -> &'static str {
    if name.ends_with("force") || name.contains("force_") {
        "N"
    } else if name.ends_with("_rate") || name.ends_with("velocity") {
        "m/s"
    } else if name.contains("dte")
        || name.ends_with(".x")
        || name.ends_with(".y")
        || name.ends_with("_fixed")
    {
        "m"
    } else {
        "1"
    }
}

/// Most samples per signal of `geardyn spectrum` (8 MB each): 2^24, a million mesh periods
/// at 16 samples each.
pub const MAX_SPECTRUM_SAMPLES: f64 = 16_777_216.0;

/// `--samples` per mesh period over `mesh_cycles` periods of the fastest mesh within
/// [`MAX_SPECTRUM_SAMPLES`], checked before anything is allocated (issue 34: `--periods 4e9`
/// aborted on a 2 TB allocation).
fn check_spectrum_samples(request: &SpectrumRequest, mesh_cycles: f64) -> Result<(), String> {
    let n = mesh_cycles * request.samples_per_mesh_period as f64;
    if !(n <= MAX_SPECTRUM_SAMPLES) {
        return Err(format!(
            "--samples = {} per mesh period over --periods = {} ({mesh_cycles:e} mesh periods): \
             {n:e} samples per signal, more than the {MAX_SPECTRUM_SAMPLES:e} a spectrum may take",
            request.samples_per_mesh_period, request.periods
        ));
    }
    Ok(())
}

/// Shoots the periodic steady state at the scene's speed, samples `periods` response periods
/// at `N` uniform instants from the orbit's start and takes the exact DFT of each signal.
pub fn periodic_spectrum(
    scene: &Scene,
    request: &SpectrumRequest,
) -> Result<SpectrumReport, String> {
    periodic_spectrum_reporting(scene, request, &|_, _| {})
}

/// [`periodic_spectrum`], reporting the shooting and the sampling to `report`.
pub fn periodic_spectrum_reporting(
    scene: &Scene,
    request: &SpectrumRequest,
    report: Report,
) -> Result<SpectrumReport, String> {
    if request.samples_per_mesh_period < 4 {
        return Err(format!(
            "--samples = {}: need at least 4 samples per mesh period",
            request.samples_per_mesh_period
        ));
    }
    if request.periods == 0 {
        return Err("--periods = 0: need at least one response period".into());
    }
    // A first bound before the orbit is shot: one mesh period per response period at least.
    check_spectrum_samples(request, request.periods as f64)?;
    let orbit = shoot_reporting(scene, &ShootingOptions::default(), report)?;
    with_drivetrain!(scene.simulation()?, sim => {
        let mut sim = sim;
        let model = sim.model();
        let names = model.row_names();
        let fixed = fixed_frame_signals(scene, &request.signals, &names)?;
        let columns: Vec<usize> = if request.signals.is_empty() {
            (0..model.mesh_count()).map(|n| model.mesh_columns(n).dte).collect()
        } else {
            let mut wanted: Vec<&str> = Vec::new();
            for (s, f) in request.signals.iter().zip(&fixed) {
                match f {
                    Some(f) => wanted.extend([f.x.as_str(), f.y.as_str()]),
                    None => wanted.push(s),
                }
            }
            let mut columns: Vec<usize> = Vec::new();
            for s in wanted {
                let col = names.iter().position(|n| n == s).ok_or_else(|| {
                    format!("--signal {s:?}: no such output column (columns: {}; and \
                             <member>.x_fixed, <member>.y_fixed of a planetary stage's \
                             central members)", names.join(", "))
                })?;
                if !columns.contains(&col) {
                    columns.push(col);
                }
            }
            columns
        };
        let period = response_period(model)?;
        // Fixed-frame signals: a whole number of carrier revolutions in the record, so their
        // lines `f ± f_c` fall on its bins.
        let carrier_hz: Vec<f64> = fixed.iter().flatten().map(|f| f.carrier_hz).collect();
        let revolutions = match carrier_hz.iter().map(|f| f.abs()).fold(0.0, f64::max) {
            f if f > 0.0 => {
                let mut with = vec![1.0 / period];
                with.extend(carrier_hz.iter().map(|f| f.abs()).filter(|&f| f > 0.0));
                crate::model::drivetrain::response_period_in_mesh_periods(&with).map_err(|e| {
                    format!("fixed-frame signals need a record of whole carrier revolutions and \
                             response periods: {e}")
                })?
            }
            _ => 1,
        };
        let duration = period * (request.periods as u64 * revolutions) as f64;
        let f_max = (0..model.mesh_count()).map(|n| model.mesh_frequency(n)).fold(0.0, f64::max);
        let mesh_cycles = (duration * f_max).round().max(1.0);
        check_spectrum_samples(request, mesh_cycles)?;
        let mesh_cycles = mesh_cycles as usize;
        let n = mesh_cycles * request.samples_per_mesh_period;
        let mut meshes = stage_mesh_lines(scene, mesh_lines(model));
        if fixed.iter().any(Option::is_some) {
            meshes.extend(planet_pass_lines(scene));
        }
        let shafts = model.shafts();
        sim.set_y(0.0, &orbit.y0);
        // On the exact propagator the lines are integrated over each segment (alias-free);
        // elsewhere the exact DFT of the samples.
        report(0.0, &|| "spectrum: integrating the orbit's lines".to_owned());
        let integrated = orbit_lines(&mut sim, &columns, duration, n / 2)?;
        let method = if integrated.is_some() { Lines::Integrated } else { Lines::Sampled };
        let spectra = match integrated {
            Some(spectra) => spectra,
            None => {
                let mut samples = vec![Vec::with_capacity(n); columns.len()];
                let mut row = Vec::new();
                let mut taken = 0usize;
                sim.sample((0..n).map(|j| j as f64 * duration / n as f64), |s, t| {
                    if taken.is_multiple_of(1024) {
                        report(taken as f64 / n as f64, &|| {
                            format!("spectrum: sampling the orbit, {taken} of {n} samples")
                        });
                    }
                    taken += 1;
                    s.model().output_row(t, s.y(), &mut row);
                    for (c, &col) in columns.iter().enumerate() {
                        samples[c].push(row[col]);
                    }
                    Ok(())
                })?;
                samples.iter().map(|x| exact_dft(x, duration)).collect::<Result<_, _>>()?
            }
        };
        let mut signals = Vec::new();
        let of = |name: &str| -> &Spectrum {
            let c = columns.iter().position(|&c| names[c] == name).expect("column requested");
            &spectra[c]
        };
        let picked: Vec<(String, Spectrum)> = if request.signals.is_empty() {
            columns.iter().zip(&spectra).map(|(&c, s)| (names[c].clone(), s.clone())).collect()
        } else {
            (request.signals.iter().zip(&fixed)).map(|(name, f)| match f {
                None => Ok((name.clone(), of(name).clone())),
                Some(f) => {
                    let turns = f.carrier_hz * duration;
                    let shift = turns.round();
                    if (turns - shift).abs() > 1e-6 {
                        return Err(format!("--signal {name:?}: the record spans {turns} carrier \
                                            revolutions, not a whole number"));
                    }
                    let (fx, fy) = fixed_frame_lines(of(&f.x), of(&f.y), shift as i64);
                    Ok((name.clone(), if f.axis == 0 { fx } else { fy }))
                }
            }).collect::<Result<_, String>>()?
        };
        for (column, spectrum) in picked {
            let labels = label_lines(&spectrum.frequency, &meshes, &shafts, 0.25 * spectrum.resolution);
            signals.push(SignalSpectrum {
                unit: column_unit(&column).to_string(),
                column,
                spectrum,
                labels,
            });
        }
        Ok(SpectrumReport { scene: scene.name.to_string(), duration, samples: n, method, signals })
    })
}

impl SpectrumReport {
    /// One row per frequency bin: `frequency_Hz`, then per signal `<column>_amplitude_<unit>`,
    /// `<column>_phase_rad`; a last column `order` names the bin's mesh/shaft order (empty
    /// when no simple order lies within a quarter bin).
    pub fn write_csv(&self, path: &Path) -> Result<(), String> {
        let mut header = vec!["frequency_Hz".to_string()];
        for s in &self.signals {
            header.push(format!("{}_amplitude_{}", s.column, s.unit));
            header.push(format!("{}_phase_rad", s.column));
        }
        // The label column is text (CsvWriter writes numbers only): the table is formatted
        // here and written atomically, so an error leaves no partial file.
        let mut text = header.join(",") + ",order\n";
        let first = &self.signals[0];
        for k in 0..first.spectrum.frequency.len() {
            text.push_str(&format!("{:?}", first.spectrum.frequency[k]));
            for s in &self.signals {
                text.push_str(&format!(
                    ",{:?},{:?}",
                    s.spectrum.amplitude[k], s.spectrum.phase[k]
                ));
            }
            let label = first.labels[k].as_ref().map_or("", |l| l.text.as_str());
            text.push_str(&format!(",{label}\n"));
        }
        crate::output::write_text(path, &text)
    }

    /// Amplitude over frequency (log scale), one stem per line and signal, the largest lines
    /// named, to PNG or SVG by the extension of `path`.
    pub fn save_plot(&self, path: &Path) -> Result<(), String> {
        self.save_plot_with(path, &SpectrumPlot::default())
    }

    /// The stem plot as `plot` says: over frequency or input-shaft order, within a range, on
    /// a log amplitude axis or in dB re each signal's largest line.
    pub fn save_plot_with(&self, path: &Path, plot: &SpectrumPlot) -> Result<(), String> {
        use crate::plot::{StemSeries, Stems};
        const COLORS: [&str; 4] = ["#2471a3", "#c0392b", "#16a085", "#8e44ad"];
        let to_x = |f: f64| {
            if plot.order_axis {
                f / plot.input_frequency
            } else {
                f
            }
        };
        // Signals of different units share no amplitude axis: then levels in dB re each
        // signal's largest line.
        let mixed = self.signals.iter().any(|s| s.unit != self.signals[0].unit);
        let plot = &SpectrumPlot {
            db: plot.db || mixed,
            ..plot.clone()
        };
        if plot.order_axis && !(plot.input_frequency.is_finite() && plot.input_frequency > 0.0) {
            return Err(format!(
                "--order-range: the input shaft turns at {} Hz, so the spectrum has no orders",
                plot.input_frequency
            ));
        }
        // Bins below 1e-6 of the largest line (−120 dB) are rounding (exact DFT) and are
        // left out so they do not set the axis range.
        let peaks: Vec<f64> = (self.signals.iter())
            .map(|s| {
                s.spectrum
                    .amplitude
                    .iter()
                    .skip(1)
                    .fold(0.0, |m: f64, &v| m.max(v))
            })
            .collect();
        let series: Vec<StemSeries> = (self.signals.iter().enumerate())
            .map(|(i, s)| {
                let a = &s.spectrum.amplitude;
                let kept: Vec<usize> = (1..a.len()).filter(|&k| a[k] > 1e-6 * peaks[i]).collect();
                StemSeries {
                    label: &s.column,
                    color: COLORS[i % COLORS.len()],
                    points: (kept.iter())
                        .map(|&k| {
                            let y = if plot.db {
                                20.0 * (a[k] / peaks[i]).log10()
                            } else {
                                a[k]
                            };
                            (to_x(s.spectrum.frequency[k]), y)
                        })
                        .collect(),
                    names: (kept.iter())
                        .map(|&k| s.labels[k].as_ref().map(|l| l.text.clone()))
                        .collect(),
                }
            })
            .collect();
        let f_max = (self.signals.iter())
            .flat_map(|s| s.spectrum.frequency.last().copied())
            .fold(0.0, f64::max);
        let x_range = plot.range.unwrap_or((0.0, to_x(f_max)));
        let smallest = (series.iter())
            .flat_map(|s| s.points.iter())
            .filter(|p| p.0 >= x_range.0 && p.0 <= x_range.1)
            .map(|p| p.1)
            .fold(f64::INFINITY, f64::min);
        let unit = match self.signals[0].unit.as_str() {
            "1" => "",
            u => u,
        };
        let (y_title, y_floor) = if plot.db {
            let floor = if smallest.is_finite() {
                (smallest / 10.0).floor() * 10.0 - 10.0
            } else {
                -120.0
            };
            (
                "level (dB re the signal's largest line)".to_string(),
                floor.max(-130.0),
            )
        } else {
            let floor = if smallest.is_finite() {
                smallest / 3.0
            } else {
                1e-12
            };
            // One unit for every signal on a log axis: the first signal's.
            (
                format!("amplitude ({})", if unit.is_empty() { "-" } else { unit }),
                floor,
            )
        };
        let (y_title, scale) = if plot.db {
            (y_title, 1.0)
        } else {
            let largest = peaks.iter().copied().fold(0.0, f64::max);
            let (scale, title) = crate::plot::Axis::new("amplitude", unit).scaled(largest);
            (title, scale)
        };
        let series: Vec<StemSeries> = series
            .into_iter()
            .map(|mut s| {
                for p in &mut s.points {
                    p.1 *= scale;
                }
                s
            })
            .collect();
        let title = format!(
            "{}: amplitude spectrum ({}, mean omitted)",
            self.scene,
            self.method.describe()
        );
        Stems {
            title: &title,
            x_title: if plot.order_axis {
                "order (cycles per input revolution)"
            } else {
                "frequency (Hz)"
            },
            y_title: &y_title,
            x_range,
            db: plot.db,
            y_floor: y_floor * scale,
            series,
            labelled: plot.labelled,
        }
        .save(path)
    }
}

/// How `spectrum --plot` draws ([`SpectrumReport::save_plot_with`]).
#[derive(Debug, Clone, PartialEq)]
pub struct SpectrumPlot {
    /// The x axis in input-shaft orders (cycles per input revolution) instead of Hz.
    pub order_axis: bool,
    /// The input shaft's rotation frequency, Hz (for the order axis).
    pub input_frequency: f64,
    /// The x range drawn: Hz, or orders with `order_axis`; `None`: from 0 to the last line.
    pub range: Option<(f64, f64)>,
    /// Levels in dB re each signal's largest line (else amplitudes on a log axis).
    pub db: bool,
    /// How many of each signal's largest lines are named.
    pub labelled: usize,
}

impl Default for SpectrumPlot {
    fn default() -> Self {
        SpectrumPlot {
            order_axis: false,
            input_frequency: f64::NAN,
            range: None,
            db: false,
            labelled: 8,
        }
    }
}

/// The aliasing warning for `scene`'s outputs every `interval` s at its constant speed
/// ([`crate::analysis::spectrum::model_aliasing_warning`]); a run whose speed varies passes
/// its highest speed through that function's `speed_factor`.
pub fn aliasing(scene: &Scene, interval: f64) -> Result<Option<String>, String> {
    // At the start speed for a scene with ports (docs/ports.md).
    with_drivetrain!(scene.run()?, sim => {
        Ok(model_aliasing_warning(sim.model(), interval, 1.0))
    })
}

/// The spectrum of a simulated record (`simulate --spectrum`): `time` uniform from the run's
/// start, `columns` (name, values) the outputs to transform. When the record spans an integer
/// number of response periods (to 1e-9) the last sample (the first of the next period) is
/// dropped and the exact DFT is taken; otherwise the flat-top windowed FFT, whose line
/// amplitudes are within [`crate::analysis::spectrum::Window::amplitude_error`].
/// `simulate --spectrum`: the spectrum of every mesh's DTE and force of the run `report`
/// wrote to `csv`, written to `out`.
pub fn spectrum_of_run(
    scene: &Scene,
    report: &crate::commands::simulate_run::SimulateReport,
    csv: &Path,
    out: &Path,
) -> Result<Lines, String> {
    let header = std::fs::read_to_string(csv)
        .ok()
        .and_then(|t| t.lines().next().map(str::to_owned))
        .unwrap_or_default();
    let names: Vec<&str> = header.split(',').collect();
    let wanted: Vec<usize> = (report.meshes.iter())
        .flat_map(|m| [m.dte_column, m.force_column])
        .collect();
    let mut time = Vec::new();
    let mut columns: Vec<(String, Vec<f64>)> = wanted
        .iter()
        .map(|&i| (names.get(i).copied().unwrap_or("?").to_string(), Vec::new()))
        .collect();
    crate::commands::simulate_run::for_each_row(csv, |_, v| {
        time.push(v[0]);
        for (c, &i) in wanted.iter().enumerate() {
            columns[c].1.push(v.get(i).copied().unwrap_or(f64::NAN));
        }
    })?;
    let report = record_spectrum(scene, &time, &columns)?;
    report.write_csv(out)?;
    Ok(report.method)
}

pub fn record_spectrum(
    scene: &Scene,
    time: &[f64],
    columns: &[(String, Vec<f64>)],
) -> Result<SpectrumReport, String> {
    let n = time.len();
    if n < 8 {
        return Err(format!("--spectrum: {n} output rows (need at least 8)"));
    }
    let dt = (time[n - 1] - time[0]) / (n - 1) as f64;
    let span = time[n - 1] - time[0];
    // Both transforms assume uniform samples: a row off the grid would make the record's last
    // interval another length (issue 31 item 4).
    if let Some((j, t)) =
        (time.iter().enumerate()).find(|&(j, &t)| (t - time[0] - j as f64 * dt).abs() > 1e-6 * dt)
    {
        return Err(format!(
            "--spectrum: row {j} at t = {t:e} s is off the uniform grid of {dt:e} s from \
             {:e} s; the spectrum needs uniform samples",
            time[0]
        ));
    }
    with_drivetrain!(scene.simulation()?, sim => {
        let model = sim.model();
        let periods = span / response_period(model)?;
        let exact = periods >= 1.0 && (periods - periods.round()).abs() <= 1e-9 * periods;
        let meshes = stage_mesh_lines(scene, mesh_lines(model));
        let shafts = model.shafts();
        let mut signals = Vec::new();
        for (name, values) in columns {
            let spectrum = if exact {
                exact_dft(&values[..n - 1], span)?
            } else {
                // The mean is taken out before windowing, or its main lobe and sidelobes would
                // cover the low orders; bin 0 then reports it.
                let mean = values.iter().sum::<f64>() / n as f64;
                let centred: Vec<f64> = values.iter().map(|v| v - mean).collect();
                let mut sp = windowed_fft(&centred, dt, Window::FlatTop)?;
                sp.amplitude[0] = mean.abs();
                sp
            };
            let mut labels = label_lines(&spectrum.frequency, &meshes, &shafts, 0.5 * spectrum.resolution);
            if !exact {
                // A window spreads each line over its main lobe: only the lobe's peak is a line,
                // and only above the flat-top's sidelobes (−95 dB), with margin (−80 dB).
                let a = &spectrum.amplitude;
                let floor = 1e-4 * a.iter().skip(1).fold(0.0, |m: f64, &v| m.max(v));
                for k in 1..a.len() {
                    if a[k] < floor || a[k] < a[k - 1] || a.get(k + 1).is_some_and(|&next| a[k] < next) {
                        labels[k] = None;
                    }
                }
            }
            signals.push(SignalSpectrum {
                column: name.clone(),
                unit: column_unit(name).to_string(),
                spectrum,
                labels,
            });
        }
        let samples = if exact { n - 1 } else { n };
        Ok(SpectrumReport {
            scene: scene.name.to_string(),
            duration: span,
            samples,
            method: if exact { Lines::Sampled } else { Lines::Windowed },
            signals,
        })
    })
}

/// Each mesh's label name (`mesh` for the single pair, the mesh name in a drivetrain) and its
/// frequency, Hz: the mesh orders the lines are named after.
fn mesh_lines<M: Drivetrain>(model: &M) -> Vec<(String, f64)> {
    (0..model.mesh_count())
        .map(|m| {
            let prefix = model.mesh_prefix(m);
            let name = if prefix.is_empty() {
                "mesh".to_string()
            } else {
                prefix.trim_end_matches('.').to_string()
            };
            (name, model.mesh_frequency(m))
        })
        .collect()
}

/// The meshes of a planetary stage all run at one frequency (`docs/planetary.md`, eq. P2): they
/// name their lines as one mesh, `<carrier>_mesh` (else a 12th harmonic reads as
/// `2×sp1+10×rp1`). Other meshes are kept as they are.
fn stage_mesh_lines(scene: &Scene, meshes: Vec<(String, f64)>) -> Vec<(String, f64)> {
    if scene.planetary.is_empty() {
        return meshes;
    }
    let mut lines = Vec::new();
    for (n, line) in meshes.into_iter().enumerate() {
        let stage = (scene.planetary.iter()).find(|st| {
            st.planets
                .iter()
                .any(|p| p.sun_mesh == n || p.ring_mesh == n)
        });
        match stage {
            None => lines.push(line),
            Some(st) => {
                let name = format!("{}_mesh", scene.gears[st.carrier].name);
                if !lines.iter().any(|(l, _)| *l == name) {
                    lines.push((name, line.1));
                }
            }
        }
    }
    lines
}

/// A requested fixed-frame signal `<member>.x_fixed` / `<member>.y_fixed`: the carrier-frame
/// columns it is made of and the carrier's signed rotation frequency, Hz.
struct FixedFrameSignal {
    x: String,
    y: String,
    /// 0: X, 1: Y.
    axis: usize,
    carrier_hz: f64,
}

/// For each requested signal, its fixed-frame recipe when it names one (`docs/planetary.md`,
/// "Fixed-frame spectra"): the central members (sun, ring, carrier) of a planetary stage with
/// translations, seen from the ground at the carrier's nominal angle.
fn fixed_frame_signals(
    scene: &Scene,
    signals: &[String],
    names: &[String],
) -> Result<Vec<Option<FixedFrameSignal>>, String> {
    signals
        .iter()
        .map(|s| {
            let Some((member, axis)) = (s.strip_suffix(".x_fixed").map(|m| (m, 0)))
                .or_else(|| s.strip_suffix(".y_fixed").map(|m| (m, 1)))
            else {
                return Ok(None);
            };
            let g = scene.gear_index(member);
            let stage = g.and_then(|g| scene.planetary.iter().find(|st| st.is_central(g)));
            let (Some(st), true) = (stage, names.iter().any(|n| *n == format!("{member}.x")))
            else {
                return Err(format!(
                    "--signal {s:?}: a fixed-frame signal names a central member (sun, ring or \
                     carrier) of a planetary stage with a bearing (translations x, y)"
                ));
            };
            Ok(Some(FixedFrameSignal {
                x: format!("{member}.x"),
                y: format!("{member}.y"),
                axis,
                carrier_hz: crate::model::train::planetary::carrier_speed(scene, st)
                    / std::f64::consts::TAU,
            }))
        })
        .collect()
}

/// The planet-pass frequency of every stage, `N |f_c − f_r|` (the planets passing a point of
/// the ring), named `<carrier>_planet_pass`: with the stage's mesh frequency the orders of a
/// fixed sensor's lines (McFadden & Smith 1985: sidebands `k f_mesh ± m N f_c` with the ring
/// held).
fn planet_pass_lines(scene: &Scene) -> Vec<(String, f64)> {
    let hz = |g: usize| {
        scene.rotation[g] * scene.speed_ratio[g] * scene.operating.input_speed
            / std::f64::consts::TAU
    };
    (scene.planetary.iter())
        .map(|st| {
            (
                format!("{}_planet_pass", scene.gears[st.carrier].name),
                st.planets.len() as f64 * (hz(st.carrier) - hz(st.ring)).abs(),
            )
        })
        .collect()
}

/// `geardyn spectrum`: the spectrum of the scene's periodic steady state to the CSV `out`
/// (and the plot), and the report: where it went and the five largest lines of each signal.
/// The shooting and the sampling show on stderr as `progress` says ([`Progress`]).
pub fn spectrum_command(
    scene: &Scene,
    request: &SpectrumRequest,
    out: &Path,
    plot: Option<&Path>,
    progress: ProgressDisplay,
) -> Result<String, String> {
    spectrum_command_with(
        scene,
        request,
        out,
        plot,
        &SpectrumPlot::default(),
        progress,
    )
}

/// [`spectrum_command`] with the plot drawn as `drawn` says (its input frequency is the
/// scene's).
pub fn spectrum_command_with(
    scene: &Scene,
    request: &SpectrumRequest,
    out: &Path,
    plot: Option<&Path>,
    drawn: &SpectrumPlot,
    progress: ProgressDisplay,
) -> Result<String, String> {
    use std::fmt::Write;
    if let Some(path) = plot {
        crate::plot::Format::of(path)?;
    }
    let mut shown = Progress::of_analysis("spectrum: starting", progress);
    let report = periodic_spectrum_reporting(scene, request, &shown.reporter());
    shown.finish();
    let report = report?;
    report.write_csv(out)?;
    if let Some(path) = plot {
        let drawn = SpectrumPlot {
            input_frequency: scene.operating.input_speed / std::f64::consts::TAU,
            ..drawn.clone()
        };
        report.save_plot_with(path, &drawn)?;
    }
    let mut text = String::new();
    match report.method {
        Lines::Integrated => writeln!(
            text,
            "scene {}: {} lines integrated over each segment of the orbit (alias-free) over \
             {:.6e} s (integer response periods) -> {}",
            report.scene,
            report.samples / 2 + 1,
            report.duration,
            out.display()
        ),
        Lines::Sampled => writeln!(
            text,
            "scene {}: exact DFT of {} samples over {:.6e} s (integer response periods) -> {}",
            report.scene,
            report.samples,
            report.duration,
            out.display()
        ),
        Lines::Windowed => writeln!(
            text,
            "scene {}: flat-top windowed FFT of {} samples over {:.6e} s -> {}",
            report.scene,
            report.samples,
            report.duration,
            out.display()
        ),
    }
    .map_err(|e| e.to_string())?;
    for s in &report.signals {
        // The five largest lines, with their orders.
        let mut k: Vec<usize> = (1..s.spectrum.amplitude.len()).collect();
        k.sort_by(|a, b| s.spectrum.amplitude[*b].total_cmp(&s.spectrum.amplitude[*a]));
        let _ = writeln!(text, "  {} (amplitude, {}):", s.column, s.unit);
        for &i in k.iter().take(5) {
            let label = s.labels[i].as_ref().map_or("", |l| l.text.as_str());
            let _ = writeln!(
                text,
                "    {:>12.3} Hz  {:.4e}  {label}",
                s.spectrum.frequency[i], s.spectrum.amplitude[i]
            );
        }
    }
    Ok(text)
}
