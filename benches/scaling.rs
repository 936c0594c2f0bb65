//! Scaling benchmark of issue 37 (acceptance 1): CPU µs per mesh period of the free
//! (ungrounded) chains (`ChainSpec::free`) of 1, 2, 4, 8, 16, 32 and 64 meshes, rigid and
//! compliant bearings, under the three conditions (the linear contact law, the contact-loss
//! law while contact holds, contact loss), for the exact propagator, DP5, DOP853 and RODAS4
//! (rtol 1e-9, atol 1e-15), all in one run, and the four goal lines of the acceptance.
//!
//! `cargo bench --bench scaling` (full: 1–64 meshes; about 30–40 min CPU on a quiet machine),
//! or `SCALING_QUICK=1 cargo bench --bench scaling` (1–16 meshes, 5 rounds of blocks of about
//! 0.2 s CPU, exact warm-ups of up to 30 s CPU, a few minutes); `SCALING_MAX_MESHES=N` stops
//! at N meshes. The full run's settings ([`Settings::full`]) keep it within about 45 min CPU
//! while every cell is still timed past its warm-up: 1–16 meshes 10 rounds of blocks of about
//! 0.5 s and warm-ups of up to 60 s CPU; 32 and 64 meshes 5 rounds of 0.5 s and warm-ups of up
//! to 120 and 240 s (a cap that grows with the chain: only the contact-loss cells reach it,
//! which never settle there, so a longer warm-up would only time later in the same
//! transient). Estimated from the quick runs: the timed blocks about 16 min (12 cells × rounds
//! × blocks, or one period where that is longer), the warm-ups of the four contact-loss cells
//! of 32 and 64 meshes 12 min, the other warm-ups, the RK starts and the issue-20 rows a few
//! minutes.
//!
//! The chains, conditions, warm-up and timing are those of `examples/free_chain_cost.rs`
//! (`benches/common/free_chain.rs`): each exact simulation is warmed up past the free chain's
//! settling transient (at least 2000 periods and on until 5 periods in a row build no mode
//! and no composite product, or the CPU limit: with contact loss at 32 and 64 meshes the limit
//! ends it and the window still meets new contact combinations), and each RK simulation starts
//! from the warmed exact state, so all methods time the same stretch of the motion. The cells
//! of one chain (3 conditions × 4 methods) are timed side by side in alternated blocks (CPU
//! time of this thread), and every ratio is paired within a round. A cell whose one period
//! takes more than 5 blocks' CPU is timed in the first round only (marked `(k p)`: k periods
//! timed). An RK cell whose cost, extrapolated from the previous size (DOF² for the explicit
//! pairs, DOF³ for RODAS4), exceeds [`MAX_PERIOD_SECONDS`] per period is skipped with that
//! estimate. Timings are comparable only within one run (the machine is shared).
//!
//! Last, the two contact-loss rows of issue 20 (the grounded 8-mesh rigid chain and the
//! shipped idler, exact at least 3× faster than the best RK) as whole runs from the start
//! (`common/whole_run.rs`, the protocol of `exact_chain`).

use std::time::Instant;

use geardyn::scene::train::{ChainBearings, ChainContact, ChainSpec};
use geardyn::scene::MethodChoice;
use geardyn::scene::Scene;

#[path = "common/free_chain.rs"]
mod free_chain;
use free_chain::{median_of, paired, scene, spread, Cell, Condition, Method};
#[path = "common/stats.rs"]
mod stats;
use stats::median;
#[path = "common/whole_run.rs"]
mod whole_run;

/// An RK cell whose extrapolated cost per period is above this is skipped.
const MAX_PERIOD_SECONDS: f64 = 60.0;

/// Growth of an RK method's cost per period with DOF, for the skip estimate: `O(DOF)` right-
/// hand sides of `O(DOF)` per period (explicit pairs), an LU per step (RODAS4).
fn growth_power(method: Method) -> i32 {
    match method {
        Method::Rodas4 => 3,
        _ => 2,
    }
}

/// The settings of one chain.
struct Settings {
    rounds: usize,
    /// CPU seconds per timed block.
    block: f64,
    warm_up: usize,
    /// CPU limit of an exact warm-up, s.
    warm_cpu: f64,
}

impl Settings {
    /// The quick run's: 5 rounds of 0.2 s, warm-ups of up to 30 s CPU.
    fn quick() -> Settings {
        Settings {
            rounds: 5,
            block: 0.2,
            warm_up: 2000,
            warm_cpu: 30.0,
        }
    }

    /// The full run's for a chain of `meshes` meshes (module doc: about 45 min CPU at most).
    fn full(meshes: usize) -> Settings {
        if meshes <= 16 {
            Settings {
                rounds: 10,
                block: 0.5,
                warm_up: 2000,
                warm_cpu: 60.0,
            }
        } else {
            Settings {
                rounds: 5,
                block: 0.5,
                warm_up: 2000,
                warm_cpu: 120.0 * (meshes as f64 / 32.0),
            }
        }
    }
}

/// One chain's cells, by condition then method (`Err`: skipped or failed, with the reason).
struct Chain {
    bearings: ChainBearings,
    meshes: usize,
    dof: f64,
    cells: Vec<(Condition, Vec<Result<Cell, String>>)>,
}

impl Chain {
    fn slot(&self, condition: Condition, method: Method) -> Option<&Result<Cell, String>> {
        let (_, cells) = self.cells.iter().find(|(c, _)| *c == condition)?;
        let i = Method::ALL.iter().position(|&m| m == method)?;
        cells.get(i)
    }

    fn cell(&self, condition: Condition, method: Method) -> Option<&Cell> {
        self.slot(condition, method)?.as_ref().ok()
    }

    /// Median of `a`'s block times over `b`'s, paired within rounds.
    fn ratio(&self, a: (Condition, Method), b: (Condition, Method)) -> Option<f64> {
        let r = paired(self.cell(a.0, a.1)?, self.cell(b.0, b.1)?);
        (!r.is_empty()).then(|| median_of(&r))
    }

    /// The best RK method's time over exact's under `condition` (the smallest paired median).
    fn best_rk_ratio(&self, condition: Condition) -> Option<(f64, Method)> {
        Method::ALL[1..]
            .iter()
            .filter_map(|&m| {
                self.ratio((condition, m), (condition, Method::Exact))
                    .map(|r| (r, m))
            })
            .min_by(|a, b| a.0.total_cmp(&b.0))
    }
}

/// The chain of `meshes` meshes with `bearings`: its exact cells warmed up, its RK cells
/// started from them (or skipped by the estimate from `previous`, the last chain with these
/// bearings), then all timed in alternated rounds.
fn run_chain(
    bearings: ChainBearings,
    meshes: usize,
    previous: Option<&Chain>,
    settings: &Settings,
) -> Chain {
    let dof = ChainSpec::free(meshes, bearings, ChainContact::Linear).dof() as f64;
    let mut chain = Chain {
        bearings,
        meshes,
        dof,
        cells: Vec::new(),
    };
    for condition in Condition::ALL {
        let exact = Cell::warm(
            &scene(meshes, bearings, condition, Method::Exact),
            condition,
            settings.warm_up,
            settings.warm_cpu,
        );
        let mut cells = Vec::new();
        for &method in &Method::ALL[1..] {
            let estimate = previous
                .and_then(|p| p.cell(condition, method).map(|c| (c, p.dof)))
                .map(|(c, prev_dof)| {
                    c.seconds_per_period() * (dof / prev_dof).powi(growth_power(method))
                });
            let skipped_before = previous.is_some_and(
                |p| matches!(p.slot(condition, method), Some(Err(e)) if e.starts_with("skipped")),
            );
            let cell = match (&exact, estimate) {
                (Err(e), _) => Err(format!("no warm exact state: {e}")),
                _ if skipped_before => Err("skipped (skipped at the last size)".into()),
                (_, Some(est)) if est > MAX_PERIOD_SECONDS => {
                    Err(format!("skipped (est. {est:.0} s/p)"))
                }
                (Ok(from), _) => {
                    Cell::follow(&scene(meshes, bearings, condition, method), method, from)
                }
            };
            cells.push(cell);
        }
        cells.insert(0, exact);
        chain.cells.push((condition, cells));
    }
    for round in 0..settings.rounds {
        for (_, cells) in chain.cells.iter_mut() {
            for slot in cells.iter_mut() {
                let Ok(cell) = slot else { continue };
                let slow = cell.seconds_per_period() > 5.0 * settings.block;
                if round > 0 && slow {
                    continue;
                }
                if let Err(e) = cell.block(settings.block) {
                    *slot = Err(format!("failed: {e}"));
                }
            }
        }
    }
    chain
}

fn print_chain(chain: &Chain, settings: &Settings) {
    let label = format!("{:?}", chain.bearings).to_lowercase();
    for (condition, cells) in &chain.cells {
        let us: Vec<String> = cells
            .iter()
            .map(|c| match c {
                Err(e) => e.clone(),
                Ok(c) if c.times.len() < settings.rounds => {
                    format!("{:.1} ({} p)", median_of(&c.times), c.timed)
                }
                Ok(c) => format!("{:.1}", median_of(&c.times)),
            })
            .collect();
        let exact = cells[0].as_ref().ok();
        let holds = match condition {
            Condition::Holds => chain
                .cell(Condition::Holds, Method::Exact)
                .zip(chain.cell(Condition::Linear, Method::Exact))
                .map_or("–".into(), |(h, l)| {
                    format!("{}×", spread(&paired(h, l), 2))
                }),
            _ => String::new(),
        };
        let best = chain
            .best_rk_ratio(*condition)
            .map_or("–".into(), |(r, m)| format!("{r:.2}× {}", m.name()));
        println!(
            "{label:<9} {:<6} {:>3} {:>4}  {:>14} {:>18} {:>18} {:>18}  {:>6}  {:>22}  {:>13}  {:>16}  {}",
            condition.name(),
            chain.meshes,
            chain.dof,
            us[0],
            us[1],
            us[2],
            us[3],
            exact.map_or("–".into(), |c| format!("{:.2}", c.events_per_period())),
            holds,
            best,
            exact.map_or("–".into(), |c| format!(
                "{} ({:.1})",
                c.warm_periods, c.warm_seconds
            )),
            exact.map_or(String::new(), Cell::reuse),
        );
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

/// The four goal lines of acceptance 1.
fn print_goals(chains: &[Chain]) {
    println!("\ngoals of issue 37, acceptance 1 (paired medians of this run):");
    for bearings in [ChainBearings::Rigid, ChainBearings::Compliant] {
        let label = format!("{bearings:?}").to_lowercase();
        let of = || chains.iter().filter(move |c| c.bearings == bearings);
        let ratios: Vec<(usize, f64)> = of()
            .filter_map(|c| {
                c.ratio(
                    (Condition::Holds, Method::Exact),
                    (Condition::Linear, Method::Exact),
                )
                .map(|r| (c.meshes, r))
            })
            .collect();
        let worst = ratios.iter().map(|r| r.1).fold(0.0, f64::max);
        println!(
            "1. contact-loss law while contact holds ÷ linear law, {label}: {} (goal <= 2x at \
             every N: {})",
            ratios
                .iter()
                .map(|(m, r)| format!("{m}: {r:.2}x"))
                .collect::<Vec<_>>()
                .join(", "),
            if ratios.is_empty() {
                "-"
            } else if worst <= 2.0 {
                "met"
            } else {
                "NOT met"
            }
        );
    }
    for bearings in [ChainBearings::Rigid, ChainBearings::Compliant] {
        let label = format!("{bearings:?}").to_lowercase();
        for condition in [Condition::Linear, Condition::Holds] {
            // The smallest chains are dominated by fixed costs: fitted from 4 meshes on.
            let points: Vec<(f64, f64)> = chains
                .iter()
                .filter(|c| c.bearings == bearings && c.meshes >= 4)
                .filter_map(|c| {
                    let cell = c.cell(condition, Method::Exact)?;
                    (cell.times.len() > 1).then(|| (c.dof, median_of(&cell.times)))
                })
                .collect();
            println!(
                "2. exact cost growth, {label}, {} (4 meshes and up): {} (goal <= DOF^2)",
                condition.name(),
                growth_exponent(&points).map_or("-".into(), |e| format!(
                    "DOF^{e:.2}{}",
                    if e <= 2.0 { ", met" } else { ", NOT met" }
                ))
            );
        }
    }
    if let Some(c) = chains
        .iter()
        .find(|c| c.bearings == ChainBearings::Compliant && c.meshes == 16)
    {
        let r = c.ratio(
            (Condition::Holds, Method::Dop853),
            (Condition::Holds, Method::Exact),
        );
        println!(
            "3. DOP853 ÷ exact, 16-mesh compliant chain (51 DOF), contact-loss law while contact \
             holds: {} (goal >= 30x)",
            r.map_or("-".into(), |r| format!(
                "{r:.1}x{}",
                if r >= 30.0 { ", met" } else { ", NOT met" }
            ))
        );
    }
    for bearings in [ChainBearings::Rigid, ChainBearings::Compliant] {
        let label = format!("{bearings:?}").to_lowercase();
        let rows: Vec<String> = chains
            .iter()
            .filter(|c| c.bearings == bearings && c.meshes <= 32)
            .map(|c| {
                let goal = if c.meshes <= 8 { 3.0 } else { 1.0 };
                c.best_rk_ratio(Condition::Loss)
                    .map_or(format!("{}: -", c.meshes), |(r, m)| {
                        format!(
                            "{}: {r:.2}x {} ({})",
                            c.meshes,
                            m.name(),
                            if r >= goal { "met" } else { "NOT met" }
                        )
                    })
            })
            .collect();
        println!(
            "4. best RK ÷ exact with contact loss, {label}: {} (goal >= 3x up to 8 meshes, >= 1x \
             up to 32)",
            rows.join(", ")
        );
    }
}

fn main() {
    let run_start = Instant::now();
    let quick = std::env::var_os("SCALING_QUICK").is_some();
    let max_meshes: usize = std::env::var("SCALING_MAX_MESHES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(if quick { 16 } else { 64 });
    let settings = |meshes| {
        if quick {
            Settings::quick()
        } else {
            Settings::full(meshes)
        }
    };
    let (small, large) = (settings(16), settings(64));
    println!(
        "geardyn scaling benchmark (issue 37, acceptance 1): free chains at 2000 Hz, rtol 1e-9; \
         CPU µs per mesh period, median of {} alternated rounds of blocks of about {} s CPU \
         ({} rounds from 32 meshes on; `(k p)`: a slow cell timed in the first round only, k \
         periods); exact warmed up for at least {} periods and until 5 periods build nothing \
         (CPU limit {} s, {} s at 64 meshes), RK from the warmed exact state; holds÷linear and \
         best RK÷exact paired within rounds; exact reuse in the timed periods: modes built / \
         products built / product hits per period",
        small.rounds, small.block, large.rounds, small.warm_up, small.warm_cpu, large.warm_cpu
    );
    println!(
        "{:<9} {:<6} {:>3} {:>4}  {:>14} {:>18} {:>18} {:>18}  {:>6}  {:>22}  {:>13}  {:>16}  exact reuse",
        "bearings",
        "cond.",
        "M",
        "DOF",
        "exact µs",
        "dp5 µs",
        "dop853 µs",
        "rodas4 µs",
        "ev/p",
        "holds÷linear",
        "best RK÷exact",
        "warm-up p (CPU s)",
    );
    let mut chains: Vec<Chain> = Vec::new();
    for bearings in [ChainBearings::Rigid, ChainBearings::Compliant] {
        for meshes in [1, 2, 4, 8, 16, 32, 64] {
            if meshes > max_meshes {
                continue;
            }
            let previous = chains.iter().rev().find(|c| c.bearings == bearings);
            let settings = settings(meshes);
            let chain = run_chain(bearings, meshes, previous, &settings);
            print_chain(&chain, &settings);
            chains.push(chain);
        }
    }
    print_goals(&chains);
    contact_loss_goals(3);
    println!("total wall time {:.0} s", run_start.elapsed().as_secs_f64());
}

/// The two contact-loss rows of issue 20 (exact at least 3× faster than the best RK): the
/// grounded 8-mesh rigid chain with contact loss on every mesh and the shipped
/// `idler_gearset` at 2000 Hz, each timed as whole runs from the start
/// (`common/whole_run.rs`: 2000 mesh periods exact, 400 per RK method), median of `rounds`
/// alternated rounds after a warm-up run.
fn contact_loss_goals(rounds: usize) {
    use geardyn::solve::rk::Method as Rk;
    use whole_run::micros_per_period;
    let chain = Scene::chain(ChainSpec::new(
        8,
        ChainBearings::Rigid,
        ChainContact::ContactLoss,
    ))
    .unwrap();
    let mut idler = Scene::example("idler_gearset").unwrap();
    idler.operating.input_speed = std::f64::consts::TAU * 2000.0 / 38.0;
    for (label, scene) in [
        (
            "grounded 8-mesh rigid chain with contact loss (9 DOF)",
            chain,
        ),
        ("idler_gearset with contact loss (8 DOF)", idler),
    ] {
        let run = |method, rk, periods| {
            micros_per_period(&scene, method, rk, true, periods).map_or(f64::NAN, |(us, _)| us)
        };
        run(MethodChoice::Exact, Rk::Dop853, 200.0);
        let (mut exact, mut dop853, mut dp5) = (Vec::new(), Vec::new(), Vec::new());
        for _ in 0..rounds {
            exact.push(run(MethodChoice::Exact, Rk::Dop853, 2000.0));
            dop853.push(run(MethodChoice::Rk, Rk::Dop853, 400.0));
            dp5.push(run(MethodChoice::Rk, Rk::Dp5, 400.0));
        }
        let (exact, dop853, dp5) = (median(&mut exact), median(&mut dop853), median(&mut dp5));
        println!(
            "issue 20: best RK/exact on the {label}, whole runs (wall time): {:.1}x (exact \
             {exact:.1}, DOP853 {dop853:.1}, DP5 {dp5:.1} µs per period; goal >= 3x)",
            dop853.min(dp5) / exact
        );
    }
}
