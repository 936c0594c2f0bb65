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

use std::fmt::Write as _;
use std::path::PathBuf;

use clap::Parser;
use geardyn::analysis::{sweep, Direction, SweepOptions, SweepPoint};
use geardyn::model::{response_period, AnySimulation, Drivetrain};
use geardyn::scene::Scene;

#[derive(Parser)]
struct Args {
    /// Drivetrain scene file.
    scene: PathBuf,
    /// Input-gear speeds `from:to:points`, rad/s (as `geardyn sweep --speed`).
    #[arg(long)]
    speed: String,
    /// up | down.
    #[arg(long)]
    direction: String,
    /// Speeds (rad/s, comma separated) at which to record: the nearest sweep point each.
    #[arg(long)]
    at: String,
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
    let direction: Direction = args.direction.parse()?;
    if direction == Direction::Both {
        return Err("--direction: up or down (one branch)".into());
    }
    let options = SweepOptions {
        tolerance: args.tolerance,
        max_transient_periods: args.max_periods,
        ..SweepOptions::new(SweepOptions::parse_range(&args.speed)?, direction)
    };
    let points = sweep(&scene, &options, &|_, _| {})?.points;
    let targets: Vec<usize> = args
        .at
        .split(',')
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
        let record = point.response_periods.unwrap_or(options.record_periods);
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
