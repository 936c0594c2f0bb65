//! Scaling benchmark of issue 20 (acceptance 1): µs per mesh period against DOF for the
//! benchmark chains (`TrainScene::chain`, `src/scene/train/chain.rs`) of 1, 2, 4, 8, 16, 32
//! and 64 meshes, rigid and compliant bearings, with and without contact loss, for the exact
//! propagator, DP5, DOP853 and the stiff RODAS4 (rtol 1e-9, atol 1e-15), all in one run.
//!
//! `cargo bench --bench scaling` (full: 200 mesh periods per run, one warm-up run, median of
//! 3 alternated rounds) or `SCALING_QUICK=1 cargo bench --bench scaling` (20 periods, one
//! round). `SCALING_MAX_MESHES=16` stops at 16 meshes. Each run first advances a tenth of
//! its periods untimed (start-up transient, first use of the exact propagator's mode
//! operators), then times the periods, advanced one mesh period at a time: the numbers are
//! steady-state costs per period. A method is skipped at a size where one run
//! is estimated to take more than 20 s (from the second period of a probe run, or without a
//! probe when its cost per period at the previous size, grown as DOF³ for exact and RODAS4
//! (an LU per step) and DOF² for the explicit pairs, exceeds 100 s); the line says
//! "skipped (est. X s)".
//! Timings are comparable only within one run (the machine is shared).

use std::time::Instant;

use geardyn::model::train::TrainSimulation;
use geardyn::scene::train::{ChainBearings, ChainContact, ChainSpec, TrainScene};
use geardyn::scene::MethodChoice;

const MAX_RUN_SECONDS: f64 = 20.0;

#[derive(Clone, Copy, PartialEq)]
enum Method {
    Exact,
    Dp5,
    Dop853,
    Rodas4,
}

impl Method {
    fn name(self) -> &'static str {
        match self {
            Method::Exact => "exact",
            Method::Dp5 => "dp5",
            Method::Dop853 => "dop853",
            Method::Rodas4 => "rodas4",
        }
    }
}

fn configure(mut s: TrainScene, method: Method) -> TrainScene {
    match method {
        Method::Exact => s.solver.method = MethodChoice::Exact,
        Method::Dp5 | Method::Dop853 | Method::Rodas4 => {
            s.solver.method = MethodChoice::Rk;
            s.solver.rk_method = method.name().parse().unwrap();
        }
    }
    s.solver.rtol = 1e-9;
    s.solver.atol = 1e-15;
    s
}

/// One run: `warm` untimed mesh periods (the start-up transient and the first use of each
/// mode's operators), then `periods` timed ones. Seconds and events of the timed part.
fn run(scene: &TrainScene, warm: usize, periods: usize) -> Result<(f64, u64), String> {
    let period = 1.0 / scene.mesh_frequency(0, scene.operating.input_speed);
    let mut sim = TrainSimulation::new(scene)?;
    for k in 1..=warm {
        sim.advance_to(k as f64 * period)
            .map_err(|e| format!("{e} (period {k})"))?;
    }
    let events = sim.stats().events;
    let start = Instant::now();
    for k in warm + 1..=warm + periods {
        sim.advance_to(k as f64 * period)
            .map_err(|e| format!("{e} (period {k})"))?;
    }
    Ok((start.elapsed().as_secs_f64(), sim.stats().events - events))
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Least-squares slope of `ln y` against `ln x`.
fn growth_exponent(points: &[(f64, f64)]) -> Option<f64> {
    if points.len() < 2 {
        return None;
    }
    let n = points.len() as f64;
    let (sx, sy) = points
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x.ln(), b + y.ln()));
    let (mx, my) = (sx / n, sy / n);
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (x, y) in points {
        sxy += (x.ln() - mx) * (y.ln() - my);
        sxx += (x.ln() - mx).powi(2);
    }
    Some(sxy / sxx)
}

fn main() {
    let quick = std::env::var_os("SCALING_QUICK").is_some();
    let max_meshes: usize = std::env::var("SCALING_MAX_MESHES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(64);
    let (periods, rounds) = if quick { (20, 1) } else { (200, 3) };
    let warm = periods / 10;
    let methods = [Method::Exact, Method::Dp5, Method::Dop853, Method::Rodas4];
    println!(
        "geardyn scaling benchmark: benchmark chains at 2000 Hz, {periods} timed mesh periods \
         per run after {warm} untimed, rtol 1e-9, median of {rounds} alternated round(s) after a \
         warm-up; µs per mesh period"
    );
    println!(
        "{:<13} {:<12} {:>6} {:>4}  {:>14} {:>14} {:>14} {:>14}   events/period",
        "bearings", "contact", "meshes", "DOF", "exact", "dp5", "dop853", "rodas4"
    );
    let mut exact_linear: Vec<(ChainBearings, f64, f64)> = Vec::new();
    for bearings in [ChainBearings::Rigid, ChainBearings::Compliant] {
        for contact in [ChainContact::Linear, ChainContact::ContactLoss] {
            // Cost per period at the previous size, per method (for the skip estimate).
            let mut previous: [Option<(f64, f64)>; 4] = [None; 4];
            for meshes in [1, 2, 4, 8, 16, 32, 64] {
                if meshes > max_meshes {
                    continue;
                }
                let spec = ChainSpec::new(meshes, bearings, contact);
                let dof = spec.dof() as f64;
                let base = TrainScene::chain(spec).expect("benchmark chain");
                let mut cells: Vec<String> = Vec::new();
                let mut events = String::new();
                let mut samples: Vec<Vec<f64>> = vec![Vec::new(); methods.len()];
                let mut active = [true; 4];
                for (i, &method) in methods.iter().enumerate() {
                    let scene = configure(base.clone(), method);
                    // Skip estimate from the previous size, grown as DOF³ (exact) or DOF²
                    // (RK); only a clear excess skips without a probe.
                    if let Some((cost, prev_dof)) = previous[i] {
                        let power = match method {
                            Method::Exact | Method::Rodas4 => 3,
                            Method::Dp5 | Method::Dop853 => 2,
                        };
                        let est = cost * (dof / prev_dof).powi(power) * periods as f64;
                        if est > 5.0 * MAX_RUN_SECONDS {
                            cells.push(format!("skipped (est. {est:.0} s)"));
                            active[i] = false;
                            previous[i] = Some((est / periods as f64, dof));
                            continue;
                        }
                    }
                    // Probe: the second mesh period of a fresh run (the first one builds
                    // the modes) times the periods, then the warm-up run.
                    match run(&scene, 1, 1) {
                        Ok((t1, _)) if t1 * periods as f64 > MAX_RUN_SECONDS => {
                            let est = t1 * periods as f64;
                            cells.push(format!("skipped (est. {est:.0} s)"));
                            active[i] = false;
                            previous[i] = Some((t1, dof));
                            continue;
                        }
                        Ok(_) => {}
                        Err(e) => {
                            cells.push(format!("failed: {e}"));
                            active[i] = false;
                            continue;
                        }
                    }
                    match run(&scene, warm, periods) {
                        Ok((t, ev)) if t > MAX_RUN_SECONDS => {
                            cells.push(format!("skipped (took {t:.0} s)"));
                            active[i] = false;
                            previous[i] = Some((t / periods as f64, dof));
                            let _ = ev;
                        }
                        Ok((t, ev)) => {
                            cells.push(String::new());
                            samples[i].push(t);
                            if events.is_empty() {
                                events = format!("{:.2}", ev as f64 / periods as f64);
                            }
                        }
                        Err(e) => {
                            cells.push(format!("failed: {e}"));
                            active[i] = false;
                        }
                    }
                }
                for _ in 1..rounds {
                    for (i, &method) in methods.iter().enumerate() {
                        if active[i] {
                            if let Ok((t, _)) = run(&configure(base.clone(), method), warm, periods)
                            {
                                samples[i].push(t);
                            }
                        }
                    }
                }
                for i in 0..methods.len() {
                    if active[i] && !samples[i].is_empty() {
                        let per = median(&mut samples[i]) / periods as f64;
                        cells[i] = format!("{:.1}", per * 1e6);
                        previous[i] = Some((per, dof));
                        if methods[i] == Method::Exact && contact == ChainContact::Linear {
                            exact_linear.push((bearings, dof, per));
                        }
                    }
                }
                println!(
                    "{:<13} {:<12} {:>6} {:>4}  {:>14} {:>14} {:>14} {:>14}   {}",
                    format!("{bearings:?}").to_lowercase(),
                    match contact {
                        ChainContact::Linear => "linear",
                        ChainContact::ContactLoss => "contact loss",
                    },
                    meshes,
                    dof,
                    cells[0],
                    cells[1],
                    cells[2],
                    cells[3],
                    events
                );
            }
        }
    }
    for bearings in [ChainBearings::Rigid, ChainBearings::Compliant] {
        let points: Vec<(f64, f64)> = exact_linear
            .iter()
            .filter(|p| p.0 == bearings)
            .map(|p| (p.1, p.2))
            .collect();
        // The smallest chains are dominated by fixed costs; fit from 4 meshes on.
        let big: Vec<(f64, f64)> = points
            .iter()
            .copied()
            .filter(|&(dof, _)| {
                dof >= if bearings == ChainBearings::Rigid {
                    5.0
                } else {
                    15.0
                }
            })
            .collect();
        match (growth_exponent(&points), growth_exponent(&big)) {
            (Some(all), Some(large)) => println!(
                "exact cost growth without contact loss, {} bearings: DOF^{all:.2} (all sizes), \
                 DOF^{large:.2} (4 meshes and up)",
                format!("{bearings:?}").to_lowercase()
            ),
            (Some(all), None) => println!(
                "exact cost growth without contact loss, {} bearings: DOF^{all:.2}",
                format!("{bearings:?}").to_lowercase()
            ),
            _ => {}
        }
    }
}
