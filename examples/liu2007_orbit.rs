//! Time series on a sweep branch, for the Liu (2007) reproduction report
//! (`scripts/liu2007_report.py`, `docs/validation/liu-2007.md`).
//!
//! `geardyn simulate` starts from the scene's static state, which near a jump lands on
//! whichever branch attracts it; the report needs the orbit the *sweep* is on (Fig. 2.12's
//! upper branch at the jump-down, Fig. 4.9's contact losses per response period). So this runs
//! the warm-start sweep of `geardyn sweep` (`geardyn::analysis::sweep`) over the given range
//! and direction, and at every speed in `--at` starts a new run of the same scene at that
//! speed from the state the sweep recorded (`SweepPoint::recording_state`, at the first mesh's
//! `recording_phase`), and records a time series of all drivetrain outputs over the sweep's
//! recording span (`--samples` per mesh period of the first mesh).
//!
//! Writes `<out>_<i>.csv` (time, then the outputs of `geardyn simulate`) per target and
//! `<out>_summary.csv`: per target and mesh the sweep's sampled contact-loss fraction, the
//! exact time fraction of the time series (contact-state events, `GearTrain::
//! contact_loss_fraction`), the sampled fraction of the time series, the number of separate
//! contact losses per response period, and the sweep's and the series' DTE RMS.
//!
//! Run: `cargo run --release --example liu2007_orbit -- <scene.toml> --speed a:b:n
//! --direction down --at s1,s2 --out target/liu2007/orbit`.
//!
//! `--states` also writes the targets' recording states (the `geardyn sweep --states`
//! format). `--pinned FILE` (that format) replaces the sweep by the points of the file: each is
//! recorded again from its pinned state (`<out>_replay.csv`: the sweep's statistics columns
//! and the scaled residual between the state at the recording's end and at its start), and the
//! `--at` targets are picked among them. This is the report's fast check
//! (`scripts/liu2007_report.py --check`): the branch a point is on is pinned by its state,
//! so a point next to a jump is recomputed on the branch the report printed.

use std::fmt::Write as _;
use std::path::PathBuf;

use clap::Parser;
use geardyn::analysis::orbit_statistics::record;
use geardyn::analysis::shooting::state_scale;
use geardyn::analysis::sweep::{mesh_columns, Periodicity};
use geardyn::analysis::{sweep, Direction, SweepOptions, SweepPoint};
use geardyn::commands::steady::{state_table, STATE_COLUMNS};
use geardyn::model::{response_period, AnySimulation, Drivetrain};
use geardyn::scene::Scene;

#[derive(Parser)]
struct Args {
    /// Drivetrain scene file.
    scene: PathBuf,
    /// Input-gear speeds `from:to:points`, rad/s (as `geardyn sweep --speed`).
    #[arg(long, required_unless_present = "pinned")]
    speed: Option<String>,
    /// up | down.
    #[arg(long, required_unless_present = "pinned")]
    direction: Option<String>,
    /// Speeds (rad/s, comma separated) at which to record: the nearest sweep point each.
    #[arg(long, default_value = "")]
    at: String,
    /// Points pinned by their recording states (`geardyn sweep --states` format) instead of a
    /// sweep: each is recorded again (`<out>_replay.csv`).
    #[arg(long, conflicts_with_all = ["speed", "direction"])]
    pinned: Option<PathBuf>,
    /// Also write the targets' recording states (`geardyn sweep --states` format) here.
    #[arg(long)]
    states: Option<PathBuf>,
    /// Output prefix.
    #[arg(long)]
    out: PathBuf,
    /// As `geardyn sweep --max-periods`.
    #[arg(long, default_value_t = 3000)]
    max_periods: u32,
    /// As `geardyn sweep --tolerance`.
    #[arg(long, default_value_t = 1e-7)]
    tolerance: f64,
    /// Samples per mesh period of the first mesh in the time series.
    #[arg(long, default_value_t = 256)]
    samples: u32,
}

fn main() {
    if let Err(e) = run(Args::parse()) {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

fn run(args: Args) -> Result<(), String> {
    let scene = Scene::from_path(&args.scene)?;
    let (points, record_periods) = if let Some(pinned) = &args.pinned {
        replay(&scene, pinned, &args.out)?
    } else {
        let direction: Direction = args.direction.as_deref().unwrap_or_default().parse()?;
        if direction == Direction::Both {
            return Err("--direction: up or down (one branch)".into());
        }
        let range = args.speed.as_deref().unwrap_or_default();
        let options = SweepOptions {
            tolerance: args.tolerance,
            max_transient_periods: args.max_periods,
            ..SweepOptions::new(SweepOptions::parse_range(range)?, direction)
        };
        let points = sweep(&scene, &options, &|_, _| {})?.points;
        (points, options.record_periods)
    };
    if points.is_empty() {
        return Err("no points".into());
    }
    let targets: Vec<usize> = args
        .at
        .split(',')
        .filter(|s| !s.trim().is_empty())
        .map(|s| {
            let v: f64 = s.trim().parse().map_err(|e| format!("--at '{s}': {e}"))?;
            Ok(points
                .iter()
                .enumerate()
                .min_by(|a, b| (a.1.speed - v).abs().total_cmp(&(b.1.speed - v).abs()))
                .map(|(i, _)| i)
                .expect("a sweep has points"))
        })
        .collect::<Result<_, String>>()?;
    let names: Vec<String> = match scene.simulation()? {
        AnySimulation::Train(sim) => sim.output_names().to_vec(),
        AnySimulation::Pair(_) => {
            return Err("a drivetrain scene is needed (outputs of the train model)".into())
        }
    };
    if let Some(path) = &args.states {
        let picked = geardyn::analysis::sweep::Sweep {
            prefixes: Vec::new(),
            points: targets.iter().map(|&i| points[i].clone()).collect(),
        };
        let (columns, rows) = state_table(&picked, record_periods);
        geardyn::output::write_table(path, &columns, rows)?;
    }
    let meshes = points[0].meshes.len();
    let mut summary = String::from("target,speed,mesh_frequency,response_period,periods");
    for mesh in &points[0].meshes {
        let p = &mesh.prefix;
        for c in [
            "sweep_loss",
            "series_loss_exact",
            "series_loss_sampled",
            "losses_per_response_period",
            "sweep_dte_rms",
            "series_dte_rms",
        ] {
            let _ = write!(summary, ",{p}{c}");
        }
    }
    summary.push('\n');
    for (target, &i) in targets.iter().enumerate() {
        let point = &points[i];
        if point.failure.is_some() {
            return Err(format!(
                "the sweep failed at {describe}",
                describe = describe(point)
            ));
        }
        let mut at = scene.clone();
        at.set_input_speed(point.speed);
        let AnySimulation::Train(mut sim) = at.simulation()? else {
            unreachable!("checked above")
        };
        let period = response_period(sim.model())?;
        let f1 = sim.model().mesh_frequency(0);
        let per_response = (period * f1).round().max(1.0) as usize;
        // The sweep records a periodic response over one period, anything else over
        // `record_periods`.
        let record = point.response_periods.unwrap_or(record_periods);
        let t_start = (point.recording_phase - sim.model().mesh_phase(0, 0.0))
            .rem_euclid(per_response as f64)
            / f1;
        // A time series from the sweep's state over the sweep's recording span.
        sim.set_y(t_start, &point.recording_state);
        let per = args.samples as usize;
        let n = record as usize * per_response * per;
        let dt = period / (per_response * per) as f64;
        let mut csv = String::from("time");
        for name in &names {
            let _ = write!(csv, ",{name}");
        }
        csv.push('\n');
        let mut row = Vec::new();
        let state_col: Vec<usize> = (0..meshes)
            .map(|m| {
                let want = format!("{}contact_state", sim.model().mesh_prefix(m));
                names.iter().position(|c| *c == want).expect("column")
            })
            .collect();
        let dte_col: Vec<usize> = (0..meshes)
            .map(|m| {
                let want = format!("{}dte", sim.model().mesh_prefix(m));
                names.iter().position(|c| *c == want).expect("column")
            })
            .collect();
        let mut lost = vec![0usize; meshes];
        // Onsets of total contact loss (contact → lost between two samples); the series spans
        // whole response periods, so it is periodic and the wrap (last → first) counts too.
        let mut onsets = vec![0usize; meshes];
        let mut first = vec![false; meshes];
        let mut last = vec![false; meshes];
        let mut dte: Vec<Vec<f64>> = vec![Vec::with_capacity(n); meshes];
        for s in 1..=n {
            let t = t_start + s as f64 * dt;
            sim.advance_to(t).map_err(|e| e.to_string())?;
            sim.outputs(&mut row);
            let _ = write!(csv, "{:.12e}", t - t_start);
            for v in &row {
                let _ = write!(csv, ",{v:e}");
            }
            csv.push('\n');
            for m in 0..meshes {
                let l = row[state_col[m]] == 0.0;
                lost[m] += usize::from(l);
                if s == 1 {
                    first[m] = l;
                } else if l && !last[m] {
                    onsets[m] += 1;
                }
                last[m] = l;
                dte[m].push(row[dte_col[m]]);
            }
        }
        for m in 0..meshes {
            if first[m] && !last[m] {
                onsets[m] += 1;
            }
        }
        let file = args.out.with_file_name(format!(
            "{}_{target}.csv",
            args.out
                .file_name()
                .and_then(|s| s.to_str())
                .unwrap_or("orbit")
        ));
        std::fs::write(&file, csv).map_err(|e| format!("{}: {e}", file.display()))?;
        let t_end = sim.t();
        let _ = write!(
            summary,
            "{target},{:e},{:e},{:e},{record}",
            point.speed, point.mesh_frequency, period
        );
        for m in 0..meshes {
            let exact = sim.model().contact_loss_fraction(m, t_end);
            let mean = dte[m].iter().sum::<f64>() / n as f64;
            let rms = (dte[m].iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n as f64).sqrt();
            let mesh = &point.meshes[m];
            let _ = write!(
                summary,
                ",{:e},{exact:e},{:e},{:e},{:e},{rms:e}",
                mesh.contact_loss_fraction,
                lost[m] as f64 / n as f64,
                onsets[m] as f64 / record as f64,
                mesh.dte_rms
            );
        }
        summary.push('\n');
        eprintln!("{}: recorded {}", file.display(), describe(point));
    }
    let file = args.out.with_file_name(format!(
        "{}_summary.csv",
        args.out
            .file_name()
            .and_then(|s| s.to_str())
            .unwrap_or("orbit")
    ));
    std::fs::write(&file, summary).map_err(|e| format!("{}: {e}", file.display()))
}

fn describe(p: &SweepPoint) -> String {
    format!(
        "speed {:.3} rad/s, mesh frequency {:.1} Hz, {} transient periods, period {:?}",
        p.speed, p.mesh_frequency, p.transient_periods, p.response_periods
    )
}

/// The points of a `geardyn sweep --states` file, each recorded again from its pinned state
/// over its recorded periods (as the sweep records, `orbit_statistics::record`); writes
/// `<out>_replay.csv` and returns the points (a pinned point with 0 periods, a failed one, is
/// refused) and the record length of a point that is not periodic.
fn replay(
    scene: &Scene,
    pinned: &PathBuf,
    out: &std::path::Path,
) -> Result<(Vec<SweepPoint>, u32), String> {
    let text = std::fs::read_to_string(pinned).map_err(|e| format!("{}: {e}", pinned.display()))?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
    if header.len() < STATE_COLUMNS.len() || header[..STATE_COLUMNS.len()] != STATE_COLUMNS {
        return Err(format!(
            "{}: not a `geardyn sweep --states` file",
            pinned.display()
        ));
    }
    let mut points = Vec::new();
    let mut csv = String::new();
    for (n, line) in lines.enumerate() {
        let v: Vec<f64> = line
            .split(',')
            .map(|s| {
                s.trim()
                    .parse::<f64>()
                    .map_err(|e| format!("{}: row {}: '{s}': {e}", pinned.display(), n + 1))
            })
            .collect::<Result<_, _>>()?;
        let (direction, speed, periods, phase) = (v[0], v[1], v[2] as u32, v[3]);
        if periods == 0 {
            return Err(format!(
                "{}: row {}: a failed point has no state",
                pinned.display(),
                n + 1
            ));
        }
        let state = v[STATE_COLUMNS.len()..].to_vec();
        let mut at = scene.clone();
        at.set_input_speed(speed);
        let AnySimulation::Train(mut sim) = at.simulation()? else {
            return Err("a drivetrain scene is needed (outputs of the train model)".into());
        };
        let period = response_period(sim.model())?;
        let f1 = sim.model().mesh_frequency(0);
        let per_response = (period * f1).round().max(1.0) as usize;
        let t_start = (phase - sim.model().mesh_phase(0, 0.0)).rem_euclid(per_response as f64) / f1;
        sim.set_y(t_start, &state);
        let meshes = record(&mut sim, &at.solver, f64::from(periods) * period, false)
            .map_err(|e| format!("speed {speed} rad/s: {e}"))?;
        let scale = state_scale(sim.model(), &state);
        let residual = sim
            .y()
            .iter()
            .zip(&state)
            .zip(&scale)
            .map(|((a, b), s)| ((a - b) / s).abs())
            .fold(0.0, f64::max);
        if csv.is_empty() {
            let prefixes: Vec<String> = (0..sim.model().mesh_count())
                .map(|m| sim.model().mesh_prefix(m))
                .collect();
            csv = format!(
                "direction,speed,recorded_periods,residual,mesh_frequency,{}\n",
                mesh_columns(&prefixes).join(",")
            );
        }
        let _ = write!(csv, "{direction:?},{speed:?},{periods},{residual:?},{f1:?}");
        for m in &meshes {
            for x in m.values() {
                let _ = write!(csv, ",{x:?}");
            }
        }
        csv.push('\n');
        points.push(SweepPoint {
            direction: if direction > 0.0 {
                Direction::Up
            } else {
                Direction::Down
            },
            speed,
            mesh_frequency: f1,
            response_period: period,
            converged: true,
            periodicity: Periodicity::Periodic(periods),
            response_periods: Some(periods),
            residual,
            transient_periods: 0,
            newton_iterations: 0,
            spectral_radius: f64::NAN,
            spectral_radius_periods: None,
            meshes,
            recording_phase: phase,
            recording_state: state,
            failure: None,
        });
    }
    let file = out.with_file_name(format!(
        "{}_replay.csv",
        out.file_name().and_then(|s| s.to_str()).unwrap_or("orbit")
    ));
    std::fs::write(&file, csv).map_err(|e| format!("{}: {e}", file.display()))?;
    // Every pinned point records its own periods (`response_periods`).
    Ok((points, 1))
}
