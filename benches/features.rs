//! Benchmark (not a test): what each model feature costs, and how close the exact propagator
//! comes to its floor.
//!
//! `cargo bench --bench features [-- --quick] [-- --periods N]` prints markdown tables:
//!
//! 1. **1e6 mesh periods** of the built-in `spur_pair` example (rectangular stiffness,
//!    backlash, STE; it separates every period) with the exact propagator: final state only
//!    (with and without the decisions from recurring segments) and with the outputs on a
//!    per-period grid; the same for a backlash scene that stays in
//!    contact and for `contact = linear`. The floor is one `n × n` mat-vec per segment
//!    (`n` = augmented state size), measured with the propagator's own mat-vec in the same
//!    run; the ratio to it says how much the event work and bookkeeping add.
//! 2. **Feature on/off table**: from a plain pair (rectangular stiffness, `contact = linear`,
//!    no STE) one feature at a time (backlash with contact loss, STE harmonics, damping
//!    variation, cubic springs, torque ripple, outputs every period) and all smooth terms
//!    together, with DOP853 (rtol 1e-9) using the specialised right-hand-side kernel and the
//!    generic one that evaluates every term, and with the exact propagator where the scene is
//!    piecewise LTI. Cost per mesh period, RHS and root-function evaluations, events.
//! 3. The RHS kernels alone: ns per evaluation, specialised vs generic.
//!
//! All timings are the medians of interleaved runs in one process (load from other processes
//! hits all configurations alike); ratios are the meaningful numbers.

use std::hint::black_box;
use std::time::Instant;

use geardyn::scene::{MethodChoice, PairScene};
use geardyn::simulation::Simulation;
use geardyn::solve::exact::mat_vec::mat_vec;
use geardyn::solve::rk::Method;
use geardyn::solve::{HybridSystem, SolverStats};

#[path = "common/stats.rs"]
mod stats;
use stats::median;

/// The shipped example (the same text `geardyn simulate --example spur_pair` uses).
const SPUR_PAIR: &str = include_str!("../fmu/spur_pair/scene.toml");

/// Which terms a bench scene carries (all on top of the plain spur pair).
#[derive(Clone, Copy, Default)]
struct Features {
    backlash: bool,
    ste: bool,
    damping_variation: bool,
    cubic: bool,
    torque_ripple: bool,
}

/// The spur pair of `fmu/spur_pair/scene.toml` (same gears, stiffness, speed, load) with
/// exactly the requested terms.
fn scene_text(f: Features) -> String {
    let contact = if f.backlash {
        "contact = \"backlash\"\nbacklash = 1.0e-4"
    } else {
        "contact = \"linear\""
    };
    let mut mesh = String::new();
    if f.damping_variation {
        mesh += "damping_variation = 20.0\n";
    }
    if f.cubic {
        mesh += "[mesh.cubic]\nstiffness_factor = 1.0e9\nspring = 1.0e15\n";
    }
    let ste = if f.ste {
        "[mesh.ste]\ncos = [1.0e-6, 2.0e-7]\nsin = [0.0, 1.0e-7]\n"
    } else {
        ""
    };
    let ripple = if f.torque_ripple {
        "torque_ripple = 10.0\n"
    } else {
        ""
    };
    format!(
        r#"name = "features"
[[gear]]
name = "pinion"
teeth = 38
base_radius = 0.04535
inertia = 0.002621
[[gear]]
name = "gear"
teeth = 55
base_radius = 0.06564
inertia = 0.01091
[mesh]
pinion = "pinion"
gear = "gear"
{contact}
damping_ratio = 0.05
{mesh}
[mesh.stiffness]
kind = "rectangular"
mean = 2.9831e8
peak_to_peak_ratio = 0.35
contact_ratio = 1.504
{ste}
[operating]
pinion_speed = 471.238898038469
input_torque = 100.0
{ripple}"#
    )
}

fn scene(text: &str, method: Option<Method>) -> PairScene {
    let mut scene = PairScene::from_toml_str(text, "bench").expect("bench scene is valid");
    match method {
        None => scene.solver.method = MethodChoice::Exact,
        Some(m) => {
            scene.solver.method = MethodChoice::Rk;
            scene.solver.rk_method = m;
            scene.solver.rtol = 1e-9;
        }
    }
    scene
}

fn mesh_frequency(scene: &PairScene) -> f64 {
    scene.pinion.teeth as f64 * scene.operating.pinion_speed / std::f64::consts::TAU
}

/// How a run is driven.
#[derive(Clone, Copy, PartialEq)]
enum Drive {
    /// One `advance_to` to the end: the final state only.
    FinalOnly,
    /// The same with the exact propagator's recurring-segment decisions off (the full
    /// crossing search in every segment).
    FinalOnlyFullSearch,
    /// `advance_to` every mesh period and all outputs there.
    EveryPeriod,
}

/// One run over `periods` mesh periods; returns (seconds, counters, final state).
fn run(
    scene: &PairScene,
    periods: u64,
    drive: Drive,
    generic: bool,
) -> (f64, SolverStats, [f64; 2]) {
    let t_mesh = 1.0 / mesh_frequency(scene);
    let mut sim = Simulation::new(scene).expect("simulation assembles");
    if generic {
        sim.model_mut().use_generic_kernel();
    }
    if matches!(drive, Drive::FinalOnlyFullSearch) {
        sim.use_recurrences(false);
    }
    let started = Instant::now();
    match drive {
        Drive::FinalOnly | Drive::FinalOnlyFullSearch => sim
            .advance_to(periods as f64 * t_mesh)
            .expect("integration succeeds"),
        Drive::EveryPeriod => {
            for k in 1..=periods {
                sim.advance_to(k as f64 * t_mesh)
                    .expect("integration succeeds");
                black_box(sim.outputs());
            }
        }
    }
    let seconds = started.elapsed().as_secs_f64();
    (seconds, sim.stats(), sim.state())
}

/// Median time of `rounds` interleaved runs of every configuration (one run of each per
/// round, so that load from other processes on the shared cores hits all of them alike).
fn median_of<T>(configs: &[T], rounds: usize, mut once: impl FnMut(&T) -> f64) -> Vec<f64> {
    let mut times = vec![Vec::with_capacity(rounds); configs.len()];
    for _ in 0..rounds {
        for (c, t) in configs.iter().zip(times.iter_mut()) {
            t.push(once(c));
        }
    }
    times.iter_mut().map(|t| median(t)).collect()
}

/// ns per `n × n` mat-vec with the propagator's kernel, in a dependent chain (as segments are).
fn mat_vec_ns(n: usize) -> f64 {
    // A rotation-like matrix keeps the chain bounded.
    let mut m = vec![0.0; n * n];
    for i in 0..n {
        m[i * n + i] = 0.6;
        m[i * n + (i + 1) % n] = 0.8;
    }
    let mut z = vec![1.0; n];
    let mut out = vec![0.0; n];
    let iterations = 20_000_000u64;
    let mut times = Vec::new();
    for _ in 0..3 {
        let started = Instant::now();
        for _ in 0..iterations {
            mat_vec(black_box(&m), &z, &mut out);
            std::mem::swap(&mut z, &mut out);
        }
        black_box(&z);
        times.push(started.elapsed().as_secs_f64() * 1e9 / iterations as f64);
    }
    median(&mut times)
}

fn per(v: u64, periods: u64) -> f64 {
    v as f64 / periods as f64
}

fn main() {
    let mut quick = false;
    let mut periods: u64 = 1_000_000;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--bench" => {}
            "--quick" => quick = true,
            "--periods" => {
                periods = args
                    .next()
                    .and_then(|v| v.parse().ok())
                    .expect("--periods N (an integer)")
            }
            other => panic!("unknown argument {other:?} (--quick, --periods N)"),
        }
    }
    if quick {
        periods = periods.min(100_000);
    }
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!("geardyn features benchmark (load average: {})", load.trim());
    println!();
    long_runs(periods, quick);
    feature_table(quick);
    kernel_table();
}

/// Section 1: 1e6 mesh periods with the exact propagator.
fn long_runs(periods: u64, quick: bool) {
    let in_contact = SPUR_PAIR.replace("pinion_speed = 471.238898038469", "pinion_speed = 300.0");
    let linear = SPUR_PAIR
        .replace("contact = \"backlash\"", "contact = \"linear\"")
        .replace("backlash = 1.0e-4", "");
    let cases: Vec<(&str, PairScene, Drive)> = vec![
        (
            "spur_pair (separates every period)",
            scene(SPUR_PAIR, None),
            Drive::FinalOnly,
        ),
        (
            "spur_pair, full crossing search in every segment",
            scene(SPUR_PAIR, None),
            Drive::FinalOnlyFullSearch,
        ),
        (
            "spur_pair, outputs every period",
            scene(SPUR_PAIR, None),
            Drive::EveryPeriod,
        ),
        (
            "backlash, 2865 rpm (stays in contact)",
            scene(&in_contact, None),
            Drive::FinalOnly,
        ),
        ("contact = linear", scene(&linear, None), Drive::FinalOnly),
    ];
    let n = Simulation::new(&cases[0].1)
        .map(|s| geardyn::solve::exact::PiecewiseLti::lti_dim(s.model()))
        .expect("assembles");
    let matvec = mat_vec_ns(n);
    // Warm-up and counters (short), then the timed full runs.
    let rounds = if quick { 2 } else { 3 };
    let mut counters = Vec::new();
    for (_, s, d) in &cases {
        counters.push(run(s, periods, *d, false).1);
    }
    let times = median_of(&cases, rounds, |(_, s, d)| run(s, periods, *d, false).0);
    println!("### {periods} mesh periods, exact propagator\n");
    println!(
        "| scene | time (s) | ns/period | segments/period | events/period | root-fn evals/period | excluded segments/period | recurring segments/period | floor: {n}×{n} mat-vec/segment (s) | ratio to floor |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for ((name, _, _), (time, st)) in cases.iter().zip(times.iter().zip(&counters)) {
        let segments = st.steps;
        let floor = segments as f64 * matvec * 1e-9;
        println!(
            "| {name} | {time:.3} | {:.0} | {:.2} | {:.2} | {:.1} | {:.2} | {:.2} | {floor:.4} | {:.1}× |",
            time * 1e9 / periods as f64,
            per(segments, periods),
            per(st.events, periods),
            per(st.guard_evals, periods),
            per(st.guard_exclusions, periods),
            per(st.recurring_segments, periods),
            time / floor
        );
    }
    println!("\n{n}×{n} mat-vec: {matvec:.2} ns (the propagator's kernel, dependent chain)\n");
}

/// One row of the feature table.
struct Row {
    label: &'static str,
    features: Features,
    drive: Drive,
}

/// Section 2: feature on/off.
fn feature_table(quick: bool) {
    let plain = Features::default();
    let rows = [
        Row {
            label: "plain (linear contact, no STE)",
            features: plain,
            drive: Drive::FinalOnly,
        },
        Row {
            label: "+ backlash (contact loss)",
            features: Features {
                backlash: true,
                ..plain
            },
            drive: Drive::FinalOnly,
        },
        Row {
            label: "+ STE (2 harmonics)",
            features: Features { ste: true, ..plain },
            drive: Drive::FinalOnly,
        },
        Row {
            label: "+ damping variation",
            features: Features {
                damping_variation: true,
                ..plain
            },
            drive: Drive::FinalOnly,
        },
        Row {
            label: "+ cubic springs",
            features: Features {
                cubic: true,
                ..plain
            },
            drive: Drive::FinalOnly,
        },
        Row {
            label: "+ torque ripple",
            features: Features {
                torque_ripple: true,
                ..plain
            },
            drive: Drive::FinalOnly,
        },
        Row {
            label: "+ outputs every period",
            features: plain,
            drive: Drive::EveryPeriod,
        },
        Row {
            label: "+ STE, damping var., cubic, ripple",
            features: Features {
                ste: true,
                damping_variation: true,
                cubic: true,
                torque_ripple: true,
                ..plain
            },
            drive: Drive::FinalOnly,
        },
    ];
    let rk_periods: u64 = if quick { 500 } else { 2000 };
    let exact_periods: u64 = if quick { 20_000 } else { 100_000 };
    let rounds = if quick { 3 } else { 5 };
    // Configurations: (row, method, generic kernel).
    let mut configs = Vec::new();
    for (i, row) in rows.iter().enumerate() {
        let text = scene_text(row.features);
        configs.push((
            i,
            Some(Method::Dop853),
            false,
            scene(&text, Some(Method::Dop853)),
        ));
        configs.push((
            i,
            Some(Method::Dop853),
            true,
            scene(&text, Some(Method::Dop853)),
        ));
        let exact = scene(&text, None);
        if Simulation::new(&exact).is_ok() {
            configs.push((i, None, false, exact));
        }
    }
    let periods_of = |m: &Option<Method>| {
        if m.is_some() {
            rk_periods
        } else {
            exact_periods
        }
    };
    let outcomes: Vec<_> = configs
        .iter()
        .map(|(i, m, g, s)| run(s, periods_of(m), rows[*i].drive, *g))
        .collect();
    let times = median_of(&configs, rounds, |(i, m, g, s)| {
        run(s, periods_of(m), rows[*i].drive, *g).0
    });
    println!("### Feature on/off (cost per mesh period)\n");
    println!("| scene | method | kernel | ns/period | generic/specialised | rhs evals/period | root-fn evals/period | events/period |");
    println!("|---|---|---|---:|---:|---:|---:|---:|");
    for (c, ((i, m, generic, _), (time, (_, st, y)))) in
        configs.iter().zip(times.iter().zip(&outcomes)).enumerate()
    {
        let p = periods_of(m);
        let ns = time * 1e9 / p as f64;
        let (method, kernel, ratio) = match (m, generic) {
            (None, _) => ("exact", "—".to_string(), "—".to_string()),
            (Some(_), false) => {
                let sim = Simulation::new(&configs[c].3).expect("assembles");
                (
                    "dop853 1e-9",
                    sim.model().kernel_name().to_string(),
                    String::new(),
                )
            }
            (Some(_), true) => {
                // The specialised run of the same row is the previous configuration; the two
                // must agree bit for bit (same equations, zero terms skipped exactly).
                assert_eq!(
                    outcomes[c - 1].2,
                    *y,
                    "generic and specialised kernels differ"
                );
                let specialised = times[c - 1] * 1e9 / p as f64;
                (
                    "dop853 1e-9",
                    "generic".to_string(),
                    format!("{:.2}×", ns / specialised),
                )
            }
        };
        println!(
            "| {} | {method} | {kernel} | {ns:.0} | {ratio} | {:.1} | {:.1} | {:.2} |",
            rows[*i].label,
            per(st.rhs_evals, p),
            per(st.guard_evals, p),
            per(st.events, p),
        );
    }
    println!(
        "\nDOP853 runs {rk_periods} mesh periods, exact runs {exact_periods}; `generic` evaluates every term (STE series, cos 2πp for damping variation and torque ripple, cubic products) with the scene's zero coefficients.\n"
    );
}

/// Section 3: the RHS kernels alone.
fn kernel_table() {
    let plain = Features::default();
    let cases = [
        ("plain", plain),
        ("STE", Features { ste: true, ..plain }),
        (
            "cubic",
            Features {
                cubic: true,
                ..plain
            },
        ),
        (
            "all smooth terms",
            Features {
                ste: true,
                damping_variation: true,
                cubic: true,
                torque_ripple: true,
                ..plain
            },
        ),
    ];
    println!("### RHS kernel alone (ns per evaluation)\n");
    println!("| scene | specialised kernel | specialised ns | generic ns | generic/specialised |");
    println!("|---|---|---:|---:|---:|");
    let evaluations = 5_000_000u64;
    for (label, f) in cases {
        let s = scene(&scene_text(f), Some(Method::Dop853));
        let special = Simulation::new(&s).expect("assembles");
        let mut generic = Simulation::new(&s).expect("assembles");
        generic.model_mut().use_generic_kernel();
        let pairs = [special.model().clone(), generic.model().clone()];
        let time = median_of(&pairs, 5, |pair| {
            let mut dy = [0.0; 2];
            let mut y = [7e-6, 0.01];
            let started = Instant::now();
            for k in 0..evaluations {
                let t = k as f64 * 1e-7;
                black_box(pair).rhs(t, &y, &mut dy);
                y[0] += 1e-12 * dy[1];
            }
            black_box(y);
            started.elapsed().as_secs_f64() * 1e9 / evaluations as f64
        });
        println!(
            "| {label} | {} | {:.1} | {:.1} | {:.2}× |",
            pairs[0].kernel_name(),
            time[0],
            time[1],
            time[1] / time[0]
        );
    }
    println!();
}
