//! Benchmark (not a test): cost per mesh period of the exact piecewise-LTI propagator and the
//! RK path (DP5 and DOP853 at rtol 1e-9) on `spur_pair`, with and without contact loss.
//!
//! Run with `scripts/bench.sh` (or `cargo bench --bench spur_pair`). Every configuration is
//! measured in the same process, side by side, through the library API
//! (`PairScene` → `Simulation::advance_to` on an output grid → `Simulation::outputs`), the way
//! `geardyn simulate` and the FMU drive it.
//!
//! Scenes, all derived from the shipped `fmu/spur_pair/scene.toml` by editing single lines:
//! * `linear`    — contact law `linear`: no contact loss, no guards, no events;
//! * `spur_pair` — as shipped (backlash 0.1 mm): near the primary resonance the pair separates
//!   once per mesh period (two contact events per period);
//! * `rattle`    — light load (20 N·m) and 50 µm STE: separation *and* back-side impacts
//!   every period (a well-conditioned, period-1 rattle: with 30 µm the response is chaotic).
//!
//! Output grids: 10 µs (the scene's CLI default, ~35 samples per mesh period: every sample is
//! a stop of the integrator) and 1 ms (e.g. an FMU communication step: few stops).
//!
//! Options (after `--`): `--quick` (shorter runs), `--csv FILE` (machine-readable results),
//! `--write-scenes DIR` (the scene files, so that `scripts/bench_scipy.py` times the scipy
//! reference on exactly the same scenes).

use std::hint::black_box;
use std::path::PathBuf;
use std::time::Instant;

use geardyn::scene::{MethodChoice, PairScene};
use geardyn::simulation::{output_grid, Simulation};
use geardyn::solve::rk::Method;

#[path = "common/stats.rs"]
mod stats;
use stats::median;

/// The shipped example, compiled in (the same text `geardyn simulate --example` uses).
const SPUR_PAIR: &str = include_str!("../fmu/spur_pair/scene.toml");

/// Replaces the single line starting with `key =` (or deletes it when `value` is `None`).
fn edit_line(text: &str, key: &str, value: Option<&str>) -> String {
    let mut found = 0;
    let lines: Vec<String> = text
        .lines()
        .filter_map(|line| {
            let matches = line
                .split_once('=')
                .is_some_and(|(k, _)| k.trim() == key && !line.trim_start().starts_with('#'));
            if !matches {
                return Some(line.to_string());
            }
            found += 1;
            value.map(|v| format!("{key} = {v}"))
        })
        .collect();
    assert_eq!(found, 1, "spur_pair scene: expected one line '{key} = …'");
    lines.join("\n") + "\n"
}

struct Case {
    name: &'static str,
    what: &'static str,
    toml: String,
}

fn cases() -> Vec<Case> {
    let linear = edit_line(
        &edit_line(SPUR_PAIR, "contact", Some("\"linear\"")),
        "backlash",
        None,
    );
    let rattle = edit_line(
        &edit_line(SPUR_PAIR, "input_torque", Some("20.0")),
        "cos",
        Some("[5.0e-5]"),
    );
    vec![
        Case {
            name: "linear",
            what: "spur_pair, contact = linear (no contact loss)",
            toml: linear,
        },
        Case {
            name: "spur_pair",
            what: "spur_pair as shipped (backlash, separates every period)",
            toml: SPUR_PAIR.to_string(),
        },
        Case {
            name: "rattle",
            what: "spur_pair, 20 N·m, 50 µm STE (separation + back-side impacts)",
            toml: rattle,
        },
    ]
}

#[derive(Clone, Copy, PartialEq)]
enum Prop {
    Exact,
    Rk(Method),
}

impl Prop {
    fn label(self) -> &'static str {
        match self {
            Prop::Exact => "exact",
            Prop::Rk(Method::Dp5) => "dp5 1e-9",
            Prop::Rk(Method::Dop853) => "dop853 1e-9",
            Prop::Rk(Method::Rodas4) => "rodas4 1e-9",
        }
    }
}

const PROPS: [Prop; 3] = [Prop::Exact, Prop::Rk(Method::Dp5), Prop::Rk(Method::Dop853)];
const GRIDS: [f64; 2] = [1e-5, 1e-3];
const RTOL: f64 = 1e-9;

fn scene_for(case: &Case, prop: Prop) -> PairScene {
    let mut scene = PairScene::from_toml_str(&case.toml, case.name).expect("bench scene is valid");
    match prop {
        Prop::Exact => scene.solver.method = MethodChoice::Exact,
        Prop::Rk(m) => {
            scene.solver.method = MethodChoice::Rk;
            scene.solver.rk_method = m;
            scene.solver.rtol = RTOL;
        }
    }
    scene
}

/// One run over `grid`; returns the DTE samples and the solver counters.
fn run_once(scene: &PairScene, grid: &[f64]) -> (Vec<f64>, geardyn::solve::SolverStats) {
    let mut sim = Simulation::new(scene).expect("simulation assembles");
    let mut dte = Vec::with_capacity(grid.len());
    for &t in grid {
        sim.advance_to(t).expect("integration succeeds");
        let out = black_box(sim.outputs());
        dte.push(out[0]);
    }
    (dte, sim.stats())
}

struct Measurement {
    case: &'static str,
    prop: Prop,
    grid: f64,
    ns_per_period: f64,
    steps_per_period: f64,
    rhs_per_period: f64,
    events_per_period: f64,
    /// Guard (root-function) evaluations per period: the event search's work.
    guards_per_period: f64,
    /// Max |DTE − DTE_exact| / static deflection on the grid (RK rows only).
    err_vs_exact: Option<f64>,
}

fn main() {
    let mut quick = false;
    let mut csv: Option<PathBuf> = None;
    let mut scene_dir: Option<PathBuf> = None;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--bench" => {} // passed by `cargo bench`
            "--quick" => quick = true,
            "--csv" => csv = Some(args.next().expect("--csv FILE").into()),
            "--write-scenes" => scene_dir = Some(args.next().expect("--write-scenes DIR").into()),
            other => panic!("unknown argument {other:?} (--quick, --csv FILE, --write-scenes DIR)"),
        }
    }
    // Simulated time per run, least wall time per configuration, least number of rounds.
    let (stop_time, min_wall, min_reps) = if quick {
        (0.05, 0.05, 2)
    } else {
        (0.2, 0.5, 7)
    };

    let cases = cases();
    let load_before = load_average();
    if let Some(dir) = &scene_dir {
        std::fs::create_dir_all(dir).expect("create scene directory");
        for case in &cases {
            std::fs::write(dir.join(format!("{}.toml", case.name)), &case.toml)
                .expect("write scene");
        }
    }

    let mut results: Vec<Measurement> = Vec::new();
    for case in &cases {
        let probe = scene_for(case, Prop::Exact);
        let f_m = probe.pinion.teeth as f64 * probe.operating.pinion_speed / std::f64::consts::TAU;
        let periods = stop_time * f_m;
        let sim = Simulation::new(&probe).expect("assembles");
        let static_deflection = sim.model().static_deflection();
        for &h in &GRIDS {
            let grid = output_grid(stop_time, h);
            let scenes: Vec<PairScene> = PROPS.iter().map(|&p| scene_for(case, p)).collect();
            // Warm-up run of every propagator (also the accuracy sample and the counters).
            let samples: Vec<_> = scenes.iter().map(|s| run_once(s, &grid)).collect();
            // Timed rounds, interleaved (one run of each propagator per round) so that load
            // from other processes on shared cores hits all of them alike; the median per
            // propagator is reported.
            let mut times: Vec<Vec<f64>> = vec![Vec::new(); PROPS.len()];
            let mut rounds = 0;
            let started = Instant::now();
            while rounds < min_reps
                || started.elapsed().as_secs_f64() < min_wall * PROPS.len() as f64
            {
                for (scene, t) in scenes.iter().zip(times.iter_mut()) {
                    let t0 = Instant::now();
                    black_box(run_once(black_box(scene), &grid));
                    t.push(t0.elapsed().as_secs_f64());
                }
                rounds += 1;
            }
            let median_time: Vec<f64> = times.iter_mut().map(|t| median(t)).collect();
            let exact_dte = &samples[0].0;
            for (i, &prop) in PROPS.iter().enumerate() {
                let (dte, stats) = &samples[i];
                let err_vs_exact = match prop {
                    Prop::Exact => None,
                    Prop::Rk(_) => Some(
                        dte.iter()
                            .zip(exact_dte)
                            .map(|(a, b)| (a - b).abs())
                            .fold(0.0, f64::max)
                            / static_deflection,
                    ),
                };
                results.push(Measurement {
                    case: case.name,
                    prop,
                    grid: h,
                    ns_per_period: median_time[i] * 1e9 / periods,
                    steps_per_period: stats.steps as f64 / periods,
                    rhs_per_period: stats.rhs_evals as f64 / periods,
                    events_per_period: stats.events as f64 / periods,
                    guards_per_period: stats.guard_evals as f64 / periods,
                    err_vs_exact,
                });
            }
        }
    }

    print_table(&cases, &results, stop_time, &load_before);
    if let Some(path) = csv {
        let mut text = String::from(
            "case,method,grid_s,ns_per_period,steps_per_period,rhs_per_period,events_per_period,guards_per_period,err_vs_exact\n",
        );
        for m in &results {
            text += &format!(
                "{},{},{},{:.1},{:.3},{:.3},{:.3},{:.3},{}\n",
                m.case,
                m.prop.label(),
                m.grid,
                m.ns_per_period,
                m.steps_per_period,
                m.rhs_per_period,
                m.events_per_period,
                m.guards_per_period,
                m.err_vs_exact.map_or(String::new(), |e| format!("{e:.3e}"))
            );
        }
        std::fs::write(&path, text).expect("write csv");
    }
}

fn find<'a>(results: &'a [Measurement], case: &str, prop: Prop, grid: f64) -> &'a Measurement {
    results
        .iter()
        .find(|m| m.case == case && m.prop == prop && m.grid == grid)
        .expect("measured")
}

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "n/a".into())
}

fn print_table(cases: &[Case], results: &[Measurement], stop_time: f64, load_before: &str) {
    println!(
        "geardyn benchmark: spur_pair, {stop_time} s simulated per run, median of interleaved runs after a warm-up"
    );
    println!(
        "load average before/after: {load_before} / {} (timings compare only on an idle machine)",
        load_average()
    );
    for case in cases {
        println!("  {:10} {}", case.name, case.what);
    }
    println!();
    println!(
        "{:10} {:12} {:>7} {:>12} {:>9} {:>10} {:>9} {:>8} {:>9} {:>10}",
        "scene",
        "method",
        "grid",
        "ns/period",
        "vs exact",
        "steps/per",
        "rhs/per",
        "ev/per",
        "guard/per",
        "err/x_st"
    );
    for &grid in &GRIDS {
        for case in cases {
            let exact = find(results, case.name, Prop::Exact, grid).ns_per_period;
            for &prop in &PROPS {
                let m = find(results, case.name, prop, grid);
                println!(
                    "{:10} {:12} {:>5.0}µs {:>12.0} {:>8.2}x {:>10.2} {:>9.1} {:>8.2} {:>9.1} {:>10}",
                    m.case,
                    prop.label(),
                    grid * 1e6,
                    m.ns_per_period,
                    m.ns_per_period / exact,
                    m.steps_per_period,
                    m.rhs_per_period,
                    m.events_per_period,
                    m.guards_per_period,
                    m.err_vs_exact
                        .map_or("-".to_string(), |e| format!("{e:.1e}"))
                );
            }
        }
        println!();
    }
    println!("cost of contact loss (ns/period of the scene / ns/period of `linear`, same method):");
    for &grid in &GRIDS {
        for &prop in &PROPS {
            let base = find(results, "linear", prop, grid).ns_per_period;
            let mut line = format!("  {:12} grid {:>5.0}µs:", prop.label(), grid * 1e6);
            for case in cases.iter().filter(|c| c.name != "linear") {
                let m = find(results, case.name, prop, grid);
                line += &format!("  {} {:.2}x", case.name, m.ns_per_period / base);
            }
            println!("{line}");
        }
    }
    println!();
    println!("err/x_st: max |DTE(RK) − DTE(exact)| on the grid, in units of the static deflection");
}
