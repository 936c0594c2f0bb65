//! Benchmark (not a test) of issue 33, acceptance 7: the exact propagator against the RK
//! methods on the 3-planet stage `examples/planetary/ev_reducer_3p.toml` (27 DOF, 6 phased
//! rectangular-stiffness meshes), without and with contact loss, next to the spur pair
//! (`fmu/spur_pair`) with the same contact laws, all in one run.
//!
//! `cargo bench --bench planetary_stage [-- --quick] [-- --grid N | --output-interval S]
//! [-- --stage-periods N]` (`--profile ROW`: the exact propagator alone on the rows whose label
//! contains ROW, once, with its mode and product counts; for callgrind)
//!
//! Rows (scenes edited from the shipped files by single lines):
//! * `spur_pair, linear` / `stage, linear`: `contact = "linear"`, no contact loss, no events;
//! * `stage, linear, 20 N·m + 1 µm STE`: the contact-loss row's scene with `contact = "linear"`
//!   (what the contact loss itself costs, beside what the STE's forcing states cost);
//! * `spur_pair, contact loss`: as shipped (backlash 0.1 mm, separates every mesh period);
//! * `stage, contact loss`: as shipped (`contact = "contact_loss"` on every mesh) with the
//!   edits [`LOSS_EDITS`] (light load, 1 µm STE, 740 rad/s) under which its sun meshes lose
//!   contact every mesh period in the steady state;
//! * dense output (with the default grid; a grid given on the command line applies to every
//!   row instead): `spur_pair, linear` and `stage, linear` with a row every 10 µs (the output
//!   interval `fmu/spur_pair` ships, not locked to the mesh period), `spur_pair, contact
//!   loss` and `stage, contact loss` with 32 rows per mesh period (locked to it). Acceptance 7
//!   is read from the stage's rows on both grids.
//!
//! Methods: the exact propagator, DOP853, DP5 and RODAS4 (rtol 1e-9, atol 1e-15: the
//! protocol of `benches/common/whole_run.rs`). Each run is a whole run from the scene's start
//! (start-up transient, the exact propagator's mode and product builds included), advanced
//! `--grid N` times per mesh period (default 1: an FMU master's communication step of one mesh
//! period; `--grid 32` writes 32 rows per period) or every `--output-interval S` seconds (a
//! grid not locked to the mesh period, as `geardyn simulate` writes at a scene's
//! `output_interval`), reading every output at each stop. Runs are 20 000 mesh periods for the
//! pair and 1000 (`--stage-periods`) for the stage (`--quick`: 2000 and 200); every method of
//! a row runs the same number of periods, except RODAS4 (a tenth but at least 100, once;
//! [`periods_of`]). The exact propagator's start-up (its modes and composite products are
//! built in the first periods) weighs more in shorter runs, so its cost per period falls with
//! the run length. Results: `docs/planetary.md`, "Cost".
//!
//! Timing: CPU time of the thread (`CLOCK_THREAD_CPUTIME_ID`, not wall time: the machine is
//! shared); one warm-up run of every configuration, then rounds that run every configuration
//! once each (alternated, so a change of load hits all alike); the median per configuration.
//! The load average is printed at the start and the end. Ratios are only meaningful within
//! one run. Also printed: the largest DTE difference between each RK run and the exact run
//! over the stops (relative to the largest |DTE|), so that the methods are seen to compute the
//! same motion.

use std::hint::black_box;

use geardyn::model::train::TrainSimulation;
use geardyn::scene::{MethodChoice, PairScene, Scene};
use geardyn::simulation::Simulation;
use geardyn::solve::rk::Method as Rk;
use geardyn::solve::SolverStats;

#[path = "common/cpu.rs"]
mod cpu;
#[path = "common/stats.rs"]
mod stats;
use cpu::thread_cpu;
use stats::median;

const SPUR_PAIR: &str = include_str!("../fmu/spur_pair/scene.toml");
const STAGE: &str = include_str!("../examples/planetary/ev_reducer_3p.toml");
/// The contact-loss row's edits of the stage: at its shipped load the stage's response is
/// parametric only (proportional to the load) and keeps contact at every speed (200–1400 rad/s
/// swept); a light load (20 N·m) with a 1 µm STE on every mesh (as `spur_pair` has) near the
/// 740 rad/s resonance makes the sun meshes lose contact a third of the time, every period.
const LOSS_EDITS: [(&str, &str); 3] = [
    ("input_speed = 1047.1975511965977", "input_speed = 740.0"),
    ("input_torque = 150.0", "input_torque = 20.0"),
    (
        "stiffness = { kind = \"rectangular\"",
        "ste = { cos = [1.0e-6] }\nstiffness = { kind = \"rectangular\"",
    ),
];

#[derive(Clone, Copy, PartialEq)]
enum Method {
    Exact,
    Rk(Rk),
}

const METHODS: [Method; 4] = [
    Method::Exact,
    Method::Rk(Rk::Dop853),
    Method::Rk(Rk::Dp5),
    Method::Rk(Rk::Rodas4),
];

impl Method {
    fn label(self) -> &'static str {
        match self {
            Method::Exact => "exact",
            Method::Rk(Rk::Dop853) => "DOP853",
            Method::Rk(Rk::Dp5) => "DP5",
            Method::Rk(Rk::Rodas4) => "RODAS4",
        }
    }

    fn apply(self, solver: &mut geardyn::scene::SolverSettings) {
        match self {
            Method::Exact => solver.method = MethodChoice::Exact,
            Method::Rk(m) => {
                solver.method = MethodChoice::Rk;
                solver.rk_method = m;
            }
        }
        solver.rtol = 1e-9;
        solver.atol = 1e-15;
    }
}

/// A scene of one row: the pair kernel or the drivetrain kernel.
#[derive(Clone)]
enum Model {
    Pair(PairScene),
    Stage(Scene),
}

struct Row {
    label: String,
    /// Whether the row loses contact (the spur pair row it is set against has the same).
    contact_loss: bool,
    /// `Some(contact_loss)`: the row an acceptance line of issue 33 item 7 is read from.
    acceptance: Option<bool>,
    model: Model,
    periods: u64,
    /// Where its runs stop: `None` for the command line's grid (one stop per mesh period by
    /// default), else the dense-output grid of the row.
    stops: Option<Stops>,
}

/// What one run measured.
struct Run {
    seconds: f64,
    stats: SolverStats,
    /// DTE of every mesh at every stop.
    dte: Vec<f64>,
    /// Largest contact-loss fraction of a mesh over the run (drivetrain rows).
    loss_fraction: f64,
    /// The exact propagator's (modes built, cache clears) and (products built, hits).
    counts: Option<((u64, u64), (u64, u64))>,
}

fn replace_once(text: &str, from: &str, to: &str) -> String {
    assert_eq!(text.matches(from).count(), 1, "expected one '{from}'");
    text.replace(from, to)
}

fn rows(quick: bool, stage_periods: Option<u64>, dense_rows: bool) -> Vec<Row> {
    let pair_linear = replace_once(
        &replace_once(SPUR_PAIR, "contact = \"backlash\"", "contact = \"linear\""),
        "backlash = 1.0e-4",
        "",
    );
    let linear = |text: &str| text.replace("contact = \"contact_loss\"", "contact = \"linear\"");
    let mut stage_loss = STAGE.to_string();
    for (from, to) in LOSS_EDITS {
        assert!(stage_loss.contains(from), "expected '{from}' in the stage");
        stage_loss = stage_loss.replace(from, to);
    }
    let pair = |text: &str| Model::Pair(PairScene::from_toml_str(text, "spur_pair").unwrap());
    let stage = |text: &str| Model::Stage(Scene::from_toml_str(text, "ev_reducer_3p").unwrap());
    let (pair_periods, default_periods) = if quick { (2000, 200) } else { (20_000, 1000) };
    let stage_periods = stage_periods.unwrap_or(default_periods);
    let row = |label: &str, contact_loss, acceptance, model, periods| Row {
        label: label.to_string(),
        contact_loss,
        acceptance,
        model,
        periods,
        stops: None,
    };
    let dense = |row: Row, stops: Stops| Row {
        label: format!("{}, {}", row.label, stops.label()),
        stops: Some(stops),
        ..row
    };
    let mut rows = vec![
        row(
            "spur_pair, linear",
            false,
            None,
            pair(&pair_linear),
            pair_periods,
        ),
        row(
            "spur_pair, contact loss",
            true,
            None,
            pair(SPUR_PAIR),
            pair_periods,
        ),
        row(
            "3-planet stage, linear",
            false,
            Some(false),
            stage(&linear(STAGE)),
            stage_periods,
        ),
        row(
            "3-planet stage, linear, 20 N·m + 1 µm STE, 740 rad/s",
            false,
            None,
            stage(&linear(&stage_loss)),
            stage_periods,
        ),
        row(
            "3-planet stage, contact loss (20 N·m + 1 µm STE, 740 rad/s)",
            true,
            Some(true),
            stage(&stage_loss),
            stage_periods,
        ),
    ];
    if dense_rows {
        // Dense output, as users write it: a row every 10 µs (the output interval
        // `fmu/spur_pair` ships, not locked to the mesh period) without contact loss, and 32
        // rows per mesh period with contact loss; each against the spur pair on the same grid.
        let grid = Stops::Interval(1e-5);
        let rows_per_period = Stops::PerPeriod(32);
        rows.extend([
            dense(
                row(
                    "spur_pair, linear",
                    false,
                    None,
                    pair(&pair_linear),
                    pair_periods,
                ),
                grid,
            ),
            dense(
                row(
                    "spur_pair, contact loss",
                    true,
                    None,
                    pair(SPUR_PAIR),
                    pair_periods,
                ),
                rows_per_period,
            ),
            dense(
                row(
                    "3-planet stage, linear",
                    false,
                    Some(false),
                    stage(&linear(STAGE)),
                    stage_periods,
                ),
                grid,
            ),
            dense(
                row(
                    "3-planet stage, contact loss (20 N·m + 1 µm STE, 740 rad/s)",
                    true,
                    Some(true),
                    stage(&stage_loss),
                    stage_periods,
                ),
                rows_per_period,
            ),
        ]);
    }
    rows
}

/// Where a run stops (and reads every output).
#[derive(Clone, Copy)]
enum Stops {
    /// `N` stops per mesh period.
    PerPeriod(u64),
    /// Every `h` seconds (an output interval not locked to the mesh period).
    Interval(f64),
}

impl Stops {
    fn label(self) -> String {
        match self {
            Stops::PerPeriod(1) => "1 stop per mesh period".to_string(),
            Stops::PerPeriod(n) => format!("{n} rows per mesh period"),
            Stops::Interval(h) => format!("a row every {} µs", h * 1e6),
        }
    }
}

/// One whole run of `periods` mesh periods of `row` with `method`.
/// `metered`: under a work budget (never reached), so that the exact propagator counts the
/// duration bins it builds (`SolverStats::transitions`); the timed runs are unbounded.
fn run(row: &Row, method: Method, periods: u64, stops: Stops, metered: bool) -> Run {
    let stops = row.stops.unwrap_or(stops);
    let mut dte = Vec::new();
    let times = |t_mesh: f64| -> Vec<f64> {
        let t_end = periods as f64 * t_mesh;
        match stops {
            Stops::PerPeriod(n) => (1..=periods * n)
                .map(|k| k as f64 * t_mesh / n as f64)
                .collect(),
            Stops::Interval(h) => {
                let count = (t_end / h).floor() as u64;
                let mut v: Vec<f64> = (1..=count).map(|k| k as f64 * h).collect();
                if v.last() != Some(&t_end) {
                    v.push(t_end);
                }
                v
            }
        }
    };
    match &row.model {
        Model::Pair(scene) => {
            let mut scene = scene.clone();
            method.apply(&mut scene.solver);
            let t_mesh =
                std::f64::consts::TAU / (scene.pinion.teeth as f64 * scene.operating.pinion_speed);
            let grid = times(t_mesh);
            let mut sim = Simulation::new(&scene).expect("pair assembles");
            if metered {
                sim.set_work_budget(1e15).expect("a valid budget");
            }
            let started = thread_cpu();
            for &t in &grid {
                sim.advance_to(t).expect("pair run succeeds");
                let out = black_box(sim.outputs());
                dte.push(out[0]);
            }
            Run {
                seconds: thread_cpu() - started,
                stats: sim.stats(),
                dte,
                loss_fraction: f64::NAN,
                counts: None,
            }
        }
        Model::Stage(scene) => {
            let mut scene = scene.clone();
            method.apply(&mut scene.solver);
            let mut sim = TrainSimulation::new(&scene).expect("stage assembles");
            if metered {
                sim.set_work_budget(1e15).expect("a valid budget");
            }
            let grid = times(sim.model().mesh_period(0));
            let names = sim.output_names().to_vec();
            let dte_columns: Vec<usize> = (0..names.len())
                .filter(|&c| names[c].ends_with(".dte"))
                .collect();
            let loss_columns: Vec<usize> = (0..names.len())
                .filter(|&c| names[c].ends_with(".contact_loss_fraction"))
                .collect();
            let mut out = Vec::new();
            let started = thread_cpu();
            for &t in &grid {
                sim.advance_to(t).expect("stage run succeeds");
                sim.outputs(&mut out);
                dte.extend(dte_columns.iter().map(|&c| out[c]));
            }
            let seconds = thread_cpu() - started;
            let loss_fraction = loss_columns.iter().map(|&c| out[c]).fold(0.0, f64::max);
            Run {
                seconds,
                stats: sim.stats(),
                dte,
                loss_fraction,
                counts: (method == Method::Exact)
                    .then(|| (sim.mode_counts(), sim.composite_counts())),
            }
        }
    }
}

/// Largest |a − b| over the largest |b|, over the samples both have.
fn relative_difference(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let scale = b[..n].iter().fold(0.0f64, |m, v| m.max(v.abs()));
    a[..n]
        .iter()
        .zip(&b[..n])
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
        / scale
}

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .unwrap_or_default()
        .split_whitespace()
        .take(3)
        .collect::<Vec<_>>()
        .join(" ")
}

/// Periods of a configuration's runs: RODAS4 (an implicit method, 10–40× DOP853's cost on
/// these non-stiff scenes, never the best) runs a tenth of the row's periods but at least 100
/// (past the start-up transient), once.
fn periods_of(row: &Row, method: Method) -> u64 {
    match method {
        Method::Rk(Rk::Rodas4) => (row.periods / 10).max(100).min(row.periods),
        _ => row.periods,
    }
}

fn main() {
    let mut quick = false;
    let mut stops = Stops::PerPeriod(1);
    let mut grid_given = false;
    let mut profile: Option<String> = None;
    let mut stage_periods: Option<u64> = None;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--bench" => {}
            "--quick" => quick = true,
            "--grid" => {
                grid_given = true;
                stops = Stops::PerPeriod(
                    args.next()
                        .and_then(|v| v.parse().ok())
                        .filter(|&g| g >= 1)
                        .expect("--grid N (stops per mesh period, an integer ≥ 1)"),
                )
            }
            "--output-interval" => {
                grid_given = true;
                stops = Stops::Interval(
                    args.next()
                        .and_then(|v| v.parse().ok())
                        .filter(|&h: &f64| h > 0.0)
                        .expect("--output-interval SECONDS (> 0)"),
                )
            }
            "--stage-periods" => {
                stage_periods = Some(
                    args.next()
                        .and_then(|v| v.parse().ok())
                        .filter(|&p| p >= 10)
                        .expect("--stage-periods N (an integer ≥ 10)"),
                )
            }
            "--profile" => profile = Some(args.next().expect("--profile ROW (part of a label)")),
            other => panic!(
                "unknown argument {other:?} (--quick, --grid N, --output-interval S, \
                 --stage-periods N, --profile ROW)"
            ),
        }
    }
    let rounds = if quick { 3 } else { 5 };
    // The dense-output rows come with the default grid (a grid given on the command line
    // applies to every row instead).
    let rows = rows(quick, stage_periods, !grid_given);
    if let Some(filter) = profile {
        // For callgrind: the exact propagator alone on the matching rows, one run each.
        for row in rows.iter().filter(|r| r.label.contains(filter.as_str())) {
            let r = run(row, Method::Exact, row.periods, stops, true);
            let p = row.periods as f64;
            println!(
                "{}: {:.2} µs/period (metered), segments {:.1}, duration bins built {:.2} per \
                 period, (modes built, cache clears), (products built, hits): {:?}",
                row.label,
                r.seconds / p * 1e6,
                r.stats.steps as f64 / p,
                r.stats.transitions as f64 / p,
                r.counts
            );
        }
        return;
    }
    let configs: Vec<(usize, Method)> = (0..rows.len())
        .flat_map(|r| METHODS.iter().map(move |&m| (r, m)))
        .collect();
    let stops_text = if grid_given {
        stops.label()
    } else {
        format!(
            "{} (the rows without a grid in their label), a row every 10 µs (linear) and 32 \
             rows per mesh period (contact loss) in the dense-output rows",
            stops.label()
        )
    };
    println!(
        "geardyn planetary-stage benchmark (issue 33, acceptance 7): {stops_text}, CPU time of \
         the thread, median of {rounds} alternated rounds after a warm-up (RODAS4: one run of a \
         tenth of the periods, at least 100)"
    );
    println!("load average at the start: {}", load_average());
    // Warm-up: every configuration once (its counters and samples are the reported ones).
    let warm: Vec<Run> = configs
        .iter()
        .map(|&(r, m)| run(&rows[r], m, periods_of(&rows[r], m), stops, false))
        .collect();
    let mut times: Vec<Vec<f64>> = warm.iter().map(|w| vec![w.seconds]).collect();
    for round in 0..rounds {
        for (c, &(r, m)) in configs.iter().enumerate() {
            if m == Method::Rk(Rk::Rodas4) {
                continue;
            }
            let seconds = run(&rows[r], m, periods_of(&rows[r], m), stops, false).seconds;
            // The warm-up's time is replaced by the timed rounds'.
            if round == 0 {
                times[c].clear();
            }
            times[c].push(seconds);
        }
    }
    let load_end = load_average();
    let micros: Vec<f64> = configs
        .iter()
        .zip(times.iter_mut())
        .map(|(&(r, m), t)| median(t) / periods_of(&rows[r], m) as f64 * 1e6)
        .collect();

    println!("\n| scene | method | periods | µs/period | min–max | segments or steps/period | events/period | rhs/period | DTE difference to exact | largest contact-loss fraction |");
    println!("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for (c, &(r, m)) in configs.iter().enumerate() {
        let row = &rows[r];
        let p = periods_of(row, m) as f64;
        let exact = &warm[c - METHODS.iter().position(|&x| x == m).unwrap()];
        let t = &times[c];
        let spread = |v: f64| v / p * 1e6;
        let diff = if m == Method::Exact {
            "—".to_string()
        } else {
            format!("{:.1e}", relative_difference(&warm[c].dte, &exact.dte))
        };
        let loss = if warm[c].loss_fraction.is_nan() {
            "—".to_string()
        } else {
            format!("{:.3}", warm[c].loss_fraction)
        };
        let st = &warm[c].stats;
        println!(
            "| {} | {} | {p} | {:.2} | {:.2}–{:.2} | {:.1} | {:.2} | {:.0} | {diff} | {loss} |",
            row.label,
            m.label(),
            micros[c],
            spread(t[0]),
            spread(t[t.len() - 1]),
            st.steps as f64 / p,
            st.events as f64 / p,
            st.rhs_evals as f64 / p,
        );
    }

    println!("\n| scene | exact µs/period | DOP853 | DP5 | RODAS4 | DOP853/exact | best RK/exact | exact µs/period against the spur pair's |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|");
    let per_row = |r: usize| -> [f64; 4] {
        let c0 = r * METHODS.len();
        [micros[c0], micros[c0 + 1], micros[c0 + 2], micros[c0 + 3]]
    };
    let mut verdicts = Vec::new();
    for (r, row) in rows.iter().enumerate() {
        let [exact, dop853, dp5, rodas4] = per_row(r);
        let best = dop853.min(dp5).min(rodas4);
        let same_grid = |p: &Row| p.stops.map(Stops::label) == row.stops.map(Stops::label);
        let pair_row = rows
            .iter()
            .position(|p| {
                matches!(p.model, Model::Pair(_))
                    && p.contact_loss == row.contact_loss
                    && same_grid(p)
            })
            .unwrap();
        let versus_pair = exact / per_row(pair_row)[0];
        println!(
            "| {} | {exact:.2} | {dop853:.1} | {dp5:.1} | {rodas4:.1} | {:.1}× | {:.1}× | {versus_pair:.1}× ({}) |",
            row.label,
            dop853 / exact,
            best / exact,
            rows[pair_row].label,
        );
        if let (Model::Stage(_), Some(contact_loss)) = (&row.model, row.acceptance) {
            let grid = row.stops.unwrap_or(stops).label();
            verdicts.push(if contact_loss {
                let ratio = best / exact;
                format!(
                    "- with contact loss, {grid}: best RK / exact = {ratio:.1}× (required ≥ 3): {}",
                    if ratio >= 3.0 { "met" } else { "NOT met" }
                )
            } else {
                let ratio = dop853 / exact;
                format!(
                    "- without contact loss, {grid}: DOP853 / exact = {ratio:.1}× (required ≥ \
                     10): {}",
                    if ratio >= 10.0 { "met" } else { "NOT met" }
                )
            });
        }
    }
    println!("\nAcceptance 7 of issue 33 (3-planet stage, this run):");
    for v in verdicts {
        println!("{v}");
    }
    println!("\nload average at the end: {load_end}");
}
