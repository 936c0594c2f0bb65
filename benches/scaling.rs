//! Scaling benchmark of issue 20 (acceptance 1 and 3): µs per mesh period against DOF for the
//! benchmark chains (`Scene::chain`, `src/scene/train/chain.rs`) of 1, 2, 4, 8, 16, 32
//! and 64 meshes, rigid and compliant bearings, with and without contact loss, for the exact
//! propagator, DP5, DOP853 and the stiff RODAS4 (rtol 1e-9, atol 1e-15), all in one run.
//!
//! `cargo bench --bench scaling` (full: 200 timed mesh periods, median of 3 alternated rounds)
//! or `SCALING_QUICK=1 cargo bench --bench scaling` (20 periods, median of 3 rounds: one
//! round of 20 periods is a few µs on the small chains, and one preemption of the shared
//! machine then decides the cell);
//! `SCALING_MAX_MESHES=16` stops at 16 meshes.
//!
//! Set-up and steady state are measured apart. Each (chain, method) first runs an untimed
//! warm-up, advanced one mesh period at a time: at least a tenth of the timed periods (the
//! start-up transient), and for the exact propagator on until a period builds no new mode and
//! no new composite product (`mode_counts`, `composite_counts`), i.e. until everything it
//! reuses is built; capped at the timed period count or [`MAX_WARM_UP_SECONDS`]. Its wall time
//! is printed as the one-off set-up. The same simulations then time their periods in
//! alternated rounds (one mesh period per `advance_to`): the steady-state cost per period,
//! on which the growth exponent is fitted.
//!
//! Nothing is skipped on a compliant chain: a method whose timed run would exceed
//! [`MAX_RUN_SECONDS`] (estimated from its last warm-up period) times fewer periods (at
//! least one, after at least one warm-up period), in the first round only, and its cell says
//! how many, e.g. `123456.7 (2 p)`. On rigid chains a method whose cost per period,
//! extrapolated from the previous size (DOF³ for exact and RODAS4, DOF² for the explicit
//! pairs), puts its run above `5 ·` [`MAX_RUN_SECONDS`] is skipped with that estimate.
//! Timings are comparable only within one run (the machine is shared).
//!
//! Last, the two contact-loss goals of acceptance 1 (the 8-mesh rigid chain and the shipped
//! idler, exact at least 3× faster than the best RK) as whole runs from the start
//! (`common/whole_run.rs`, the protocol of `exact_chain`): with contact loss a chain meets new
//! contact combinations for thousands of periods, so the table's windows after a short warm-up
//! still pay for new modes in every period.

use std::time::Instant;

use geardyn::model::train::TrainSimulation;
use geardyn::scene::train::{ChainBearings, ChainContact, ChainSpec};
use geardyn::scene::MethodChoice;
use geardyn::scene::Scene;

#[path = "common/stats.rs"]
mod stats;
use stats::median;
#[path = "common/whole_run.rs"]
mod whole_run;

/// Longest timed run of one (chain, method) per round; slower methods time fewer periods.
const MAX_RUN_SECONDS: f64 = 20.0;
/// The warm-up stops after this long even if the exact propagator still builds (contact
/// loss: contact combinations that do not recur keep building modes in every period).
const MAX_WARM_UP_SECONDS: f64 = 60.0;

#[derive(Clone, Copy, PartialEq)]
enum Method {
    Exact,
    Dp5,
    Dop853,
    Rodas4,
}

const METHODS: [Method; 4] = [Method::Exact, Method::Dp5, Method::Dop853, Method::Rodas4];

impl Method {
    fn name(self) -> &'static str {
        match self {
            Method::Exact => "exact",
            Method::Dp5 => "dp5",
            Method::Dop853 => "dop853",
            Method::Rodas4 => "rodas4",
        }
    }

    /// Growth of the cost per period with DOF for the skip estimate: an `n_z²` mat-vec per
    /// segment and `2M ∝ DOF` segments (exact, before the composites), an LU per step
    /// (RODAS4), `O(DOF)` right-hand sides of `O(DOF)` per step (explicit pairs).
    fn growth_power(self) -> i32 {
        match self {
            Method::Exact | Method::Rodas4 => 3,
            Method::Dp5 | Method::Dop853 => 2,
        }
    }
}

fn configure(mut s: Scene, method: Method) -> Scene {
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

/// What the exact propagator built and reused (all zero on the RK path).
#[derive(Clone, Copy, Default, PartialEq, Debug)]
struct Reuse {
    modes_built: u64,
    products_built: u64,
    product_hits: u64,
}

impl Reuse {
    fn of(sim: &TrainSimulation) -> Reuse {
        let (modes_built, _) = sim.mode_counts();
        let (products_built, product_hits) = sim.composite_counts();
        Reuse {
            modes_built,
            products_built,
            product_hits,
        }
    }

    fn since(self, before: Reuse) -> Reuse {
        Reuse {
            modes_built: self.modes_built - before.modes_built,
            products_built: self.products_built - before.products_built,
            product_hits: self.product_hits - before.product_hits,
        }
    }
}

/// A simulation after its warm-up, ready to time periods.
struct Warmed {
    sim: TrainSimulation,
    period: f64,
    /// Mesh periods advanced so far.
    done: usize,
    set_up_seconds: f64,
    warm_up_periods: usize,
    /// Wall time of the last warm-up period (the estimate of a timed one).
    last_period_seconds: f64,
}

impl Warmed {
    fn advance_period(&mut self) -> Result<(), String> {
        let k = self.done + 1;
        self.sim
            .advance_to(k as f64 * self.period)
            .map_err(|e| format!("{e} (period {k})"))?;
        self.done = k;
        Ok(())
    }

    /// Seconds for `count` further periods, events in them and what the exact propagator
    /// built and reused meanwhile.
    fn time(&mut self, count: usize) -> Result<(f64, u64, Reuse), String> {
        let events = self.sim.stats().events;
        let before = Reuse::of(&self.sim);
        let start = Instant::now();
        for _ in 0..count {
            self.advance_period()?;
        }
        let seconds = start.elapsed().as_secs_f64();
        Ok((
            seconds,
            self.sim.stats().events - events,
            Reuse::of(&self.sim).since(before),
        ))
    }
}

/// Consecutive periods that must build nothing before the exact propagator counts as warm.
/// One is not enough: where a mesh switches at the period boundary itself (mesh 0 of the
/// chains), the rounding of that stop against `k·T` decides whether a period starts just
/// before or just after it, so two or three sequence variants recur irregularly, and a
/// variant first met in period 4 gets its product in period 6 (`composite.rs`:
/// products are built on the second sighting).
const SETTLED_PERIODS: usize = 5;

/// A fresh simulation warmed up: at least `min_periods` periods, and on until
/// [`SETTLED_PERIODS`] periods in a row build nothing the exact propagator reuses, up to
/// `max_periods` or [`MAX_WARM_UP_SECONDS`] (at least one period); an RK method whose first
/// period shows that `max_periods` would take above [`MAX_RUN_SECONDS`] stops after it (its
/// timed run is shortened anyway). The set-up time includes the assembly.
fn warm_up(scene: &Scene, min_periods: usize, max_periods: usize) -> Result<Warmed, String> {
    let settle = if scene.solver.method == MethodChoice::Exact {
        SETTLED_PERIODS
    } else {
        1
    };
    let start = Instant::now();
    let period = 1.0 / scene.mesh_frequency(0, scene.operating.input_speed);
    let sim = TrainSimulation::new(scene)?;
    let mut warmed = Warmed {
        sim,
        period,
        done: 0,
        set_up_seconds: 0.0,
        warm_up_periods: 0,
        last_period_seconds: 0.0,
    };
    let mut settled_run = 0;
    loop {
        let before = Reuse::of(&warmed.sim);
        let period_start = Instant::now();
        warmed.advance_period()?;
        warmed.last_period_seconds = period_start.elapsed().as_secs_f64();
        let built = Reuse::of(&warmed.sim).since(before);
        settled_run = if built.modes_built == 0 && built.products_built == 0 {
            settled_run + 1
        } else {
            0
        };
        // An RK method too slow for a full timed run has seen its start-up after one period.
        let slow = settle == 1 && warmed.last_period_seconds * max_periods as f64 > MAX_RUN_SECONDS;
        if (warmed.done >= min_periods && settled_run >= settle)
            || slow
            || warmed.done >= max_periods
            || start.elapsed().as_secs_f64() > MAX_WARM_UP_SECONDS
        {
            break;
        }
    }
    warmed.set_up_seconds = start.elapsed().as_secs_f64();
    warmed.warm_up_periods = warmed.done;
    Ok(warmed)
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

/// One method's cell of a row.
enum Cell {
    Skipped(f64),
    Failed(String),
    Timed {
        warmed: Box<Warmed>,
        /// Periods per timed round.
        periods: usize,
        samples: Vec<f64>,
        events: u64,
        reuse: Reuse,
    },
}

impl Cell {
    fn steady(&mut self, full_periods: usize) -> String {
        match self {
            Cell::Skipped(est) => format!("skipped (est. {est:.0} s)"),
            Cell::Failed(e) => format!("failed: {e}"),
            Cell::Timed {
                periods, samples, ..
            } => {
                let per = median(samples) / *periods as f64 * 1e6;
                if *periods < full_periods {
                    format!("{per:.1} ({periods} p)")
                } else {
                    format!("{per:.1}")
                }
            }
        }
    }

    fn seconds_per_period(&mut self) -> Option<f64> {
        match self {
            Cell::Timed {
                periods, samples, ..
            } => Some(median(samples) / *periods as f64),
            _ => None,
        }
    }

    fn set_up(&self) -> String {
        match self {
            Cell::Timed { warmed, .. } => {
                format!("{:.2} ({})", warmed.set_up_seconds, warmed.warm_up_periods)
            }
            _ => "-".into(),
        }
    }
}

/// The steady-state exact cost and set-up time of a chain without contact loss.
struct ExactPoint {
    bearings: ChainBearings,
    dof: f64,
    steady: f64,
    set_up: f64,
}

fn label(bearings: ChainBearings) -> String {
    format!("{bearings:?}").to_lowercase()
}

fn print_growth(points: &[ExactPoint], what: &str, value: impl Fn(&ExactPoint) -> f64) {
    for bearings in [ChainBearings::Rigid, ChainBearings::Compliant] {
        let all: Vec<(f64, f64)> = points
            .iter()
            .filter(|p| p.bearings == bearings)
            .map(|p| (p.dof, value(p)))
            .collect();
        // The smallest chains are dominated by fixed costs; also fit from 4 meshes on.
        let four_meshes = ChainSpec::new(4, bearings, ChainContact::Linear).dof() as f64;
        let big: Vec<(f64, f64)> = all
            .iter()
            .copied()
            .filter(|&(dof, _)| dof >= four_meshes)
            .collect();
        let fmt = |e: Option<f64>| e.map_or("-".to_string(), |e| format!("DOF^{e:.2}"));
        println!(
            "exact {what} growth without contact loss, {} bearings: {} (all sizes), {} (4 meshes \
             and up)",
            label(bearings),
            fmt(growth_exponent(&all)),
            fmt(growth_exponent(&big))
        );
    }
}

fn main() {
    let run_start = Instant::now();
    let quick = std::env::var_os("SCALING_QUICK").is_some();
    let max_meshes: usize = std::env::var("SCALING_MAX_MESHES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(64);
    let (periods, rounds) = if quick { (20, 3) } else { (200, 3) };
    let min_warm = (periods / 10).max(1);
    println!(
        "geardyn scaling benchmark: benchmark chains at 2000 Hz, rtol 1e-9; steady state: µs per \
         mesh period over {periods} timed periods, median of {rounds} alternated round(s), \
         `(k p)`: only k periods timed, one round (run above {MAX_RUN_SECONDS} s); set-up: \
         seconds of the untimed warm-up (periods), at least {min_warm} periods, exact until \
         {SETTLED_PERIODS} periods in a row build no mode and no product (cap {periods} periods or {MAX_WARM_UP_SECONDS} \
         s); exact reuse in the timed periods: modes built / products built / product hits per \
         period"
    );
    println!(
        "{:<10} {:<12} {:>3} {:>4}  {:>16} {:>16} {:>16} {:>16}  {:>6}  {:>12} {:>12} {:>12} \
         {:>12}  exact reuse",
        "bearings",
        "contact",
        "M",
        "DOF",
        "exact µs",
        "dp5 µs",
        "dop853 µs",
        "rodas4 µs",
        "ev/p",
        "exact set-up",
        "dp5 set-up",
        "dop853 set-up",
        "rodas4 set-up"
    );
    let mut exact_linear: Vec<ExactPoint> = Vec::new();
    let mut ratio_51_dof: Option<(f64, f64)> = None;
    for bearings in [ChainBearings::Rigid, ChainBearings::Compliant] {
        for contact in [ChainContact::Linear, ChainContact::ContactLoss] {
            // Cost per period at the previous size, per method (for the rigid skip estimate).
            let mut previous: [Option<(f64, f64)>; 4] = [None; 4];
            for meshes in [1, 2, 4, 8, 16, 32, 64] {
                if meshes > max_meshes {
                    continue;
                }
                let spec = ChainSpec::new(meshes, bearings, contact);
                let dof = spec.dof() as f64;
                let base = Scene::chain(spec).expect("benchmark chain");
                let mut cells: Vec<Cell> = Vec::new();
                for (i, &method) in METHODS.iter().enumerate() {
                    if bearings == ChainBearings::Rigid {
                        if let Some((cost, prev_dof)) = previous[i] {
                            let est = cost
                                * (dof / prev_dof).powi(method.growth_power())
                                * periods as f64;
                            if est > 5.0 * MAX_RUN_SECONDS {
                                cells.push(Cell::Skipped(est));
                                previous[i] = Some((est / periods as f64, dof));
                                continue;
                            }
                        }
                    }
                    let scene = configure(base.clone(), method);
                    let cell = match warm_up(&scene, min_warm, periods) {
                        Err(e) => Cell::Failed(e),
                        Ok(warmed) => {
                            let fit = (MAX_RUN_SECONDS / warmed.last_period_seconds) as usize;
                            Cell::Timed {
                                warmed: Box::new(warmed),
                                periods: fit.clamp(1, periods),
                                samples: Vec::new(),
                                events: 0,
                                reuse: Reuse::default(),
                            }
                        }
                    };
                    cells.push(cell);
                }
                for round in 0..rounds {
                    for cell in cells.iter_mut() {
                        let Cell::Timed {
                            warmed,
                            periods: count,
                            samples,
                            events,
                            reuse,
                        } = cell
                        else {
                            continue;
                        };
                        if round > 0 && *count < periods {
                            continue;
                        }
                        match warmed.time(*count) {
                            Ok((seconds, ev, r)) => {
                                samples.push(seconds);
                                if round == 0 {
                                    *events = ev;
                                    *reuse = r;
                                }
                            }
                            Err(e) => *cell = Cell::Failed(e),
                        }
                    }
                }
                for (i, cell) in cells.iter_mut().enumerate() {
                    if let Some(per) = cell.seconds_per_period() {
                        previous[i] = Some((per, dof));
                    }
                }
                let steady: Vec<String> = cells.iter_mut().map(|c| c.steady(periods)).collect();
                let set_up: Vec<String> = cells.iter().map(Cell::set_up).collect();
                let events = cells
                    .iter()
                    .find_map(|c| match c {
                        Cell::Timed {
                            periods, events, ..
                        } => Some(format!("{:.2}", *events as f64 / *periods as f64)),
                        _ => None,
                    })
                    .unwrap_or_default();
                let reuse = match &cells[0] {
                    Cell::Timed { periods, reuse, .. } => format!(
                        "{} / {} / {:.2}",
                        reuse.modes_built,
                        reuse.products_built,
                        reuse.product_hits as f64 / *periods as f64
                    ),
                    _ => String::new(),
                };
                println!(
                    "{:<10} {:<12} {:>3} {:>4}  {:>16} {:>16} {:>16} {:>16}  {:>6}  {:>12} \
                     {:>12} {:>12} {:>12}  {}",
                    label(bearings),
                    match contact {
                        ChainContact::Linear => "linear",
                        ChainContact::ContactLoss => "contact loss",
                    },
                    meshes,
                    dof,
                    steady[0],
                    steady[1],
                    steady[2],
                    steady[3],
                    events,
                    set_up[0],
                    set_up[1],
                    set_up[2],
                    set_up[3],
                    reuse
                );
                if contact == ChainContact::Linear {
                    if let (
                        Some(steady),
                        Cell::Timed {
                            warmed, periods: n, ..
                        },
                    ) = (cells[0].seconds_per_period(), &cells[0])
                    {
                        if *n == periods {
                            exact_linear.push(ExactPoint {
                                bearings,
                                dof,
                                steady,
                                set_up: warmed.set_up_seconds,
                            });
                        }
                    }
                    if bearings == ChainBearings::Compliant && meshes == 16 {
                        if let (Some(exact), Some(dop853)) =
                            (cells[0].seconds_per_period(), cells[2].seconds_per_period())
                        {
                            ratio_51_dof = Some((exact, dop853));
                        }
                    }
                }
            }
        }
    }
    print_growth(&exact_linear, "steady-state cost", |p| p.steady);
    print_growth(&exact_linear, "set-up time", |p| p.set_up);
    if let Some((exact, dop853)) = ratio_51_dof {
        println!(
            "DOP853/exact on the 16-mesh compliant linear chain (51 DOF), steady state: {:.1}x \
             ({:.1} against {:.1} µs per period; goal >= 30x)",
            dop853 / exact,
            dop853 * 1e6,
            exact * 1e6
        );
    }
    contact_loss_goals(rounds);
    println!("total wall time {:.0} s", run_start.elapsed().as_secs_f64());
}

/// The two contact-loss rows of acceptance 1 (exact at least 3× faster than the best RK): the
/// 8-mesh rigid chain with contact loss on every mesh and the shipped `idler_gearset` at
/// 2000 Hz, each timed as whole runs from the start (`common/whole_run.rs`: 2000 mesh periods
/// exact, 400 per RK method; the table's 20-period windows still meet new contact
/// combinations in every period, which a run pays once), median of `rounds` alternated rounds
/// after a warm-up run.
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
        ("8-mesh rigid chain with contact loss (9 DOF)", chain),
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
            "best RK/exact on the {label}, whole runs: {:.1}x (exact {exact:.1}, DOP853 \
             {dop853:.1}, DP5 {dp5:.1} µs per period; goal >= 3x)",
            dop853.min(dp5) / exact
        );
    }
}
