//! CPU cost per mesh period of the exact propagator on the free compliant chains of issue 37
//! (`ChainSpec::free`: 38/55-tooth gears alternating, no ground coupling, 2000 Hz), under the
//! three conditions of its acceptance 1: the linear contact law, the contact-loss law while
//! contact holds (the same chain without its STE, so no mesh separates), and contact loss
//! (15 µm STE). A probe for `docs/scaling.md` ("Memory") beside the scaling benchmark, which
//! does not cover the free chains yet.
//!
//! `cargo run --release --example free_chain_cost -- [--warm-up P] [--cpu S] [--only C,..]
//! [MESHES ...]` (default 1 8 16 64, P = 2000, S = 60, all three conditions). Each cell is
//! one simulation, warmed up for at least P periods: the free chains start away from their
//! steady state and the transient decays slowly (about 10× per 300 periods at 16 meshes), so
//! a timed window inside it times the guarded sequences' certificates rebuilt for the
//! transient, not the steady state. The warm-up goes on until 5 periods in a row build no
//! mode and no composite product (at most P + 1000 periods or S seconds of CPU). The cells of
//! one chain are then timed side by side in alternated blocks (10 rounds of up to 20 periods,
//! about 2 s of CPU where a period is slower), and each condition's ratio to the linear law
//! is taken within a round.
//! Times are CPU time of this thread (`CLOCK_THREAD_CPUTIME_ID`), so a loaded machine
//! changes them less than wall time; compare cells of one run only.

use geardyn::model::train::TrainSimulation;
use geardyn::scene::train::{ChainBearings, ChainContact, ChainSpec};
use geardyn::scene::{MethodChoice, Scene};

#[path = "../tests/common/cpu.rs"]
mod cpu;

fn cpu_seconds() -> f64 {
    cpu::thread_cpu().as_secs_f64()
}

/// The free compliant chain of `meshes` meshes under `condition`, exact.
fn scene(meshes: usize, condition: &str) -> Scene {
    let contact = match condition {
        "linear" => ChainContact::Linear,
        _ => ChainContact::ContactLoss,
    };
    let mut text = ChainSpec::free(meshes, ChainBearings::Compliant, contact)
        .toml()
        .expect("a free chain");
    if condition == "holds" {
        // Without the STE the loaded meshes never separate.
        text = text
            .lines()
            .filter(|l| !l.starts_with("ste ="))
            .map(|l| format!("{l}\n"))
            .collect();
    }
    let mut s = Scene::from_toml_str(&text, "free_chain").expect("a free chain scene");
    s.solver.method = MethodChoice::Exact;
    s
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut warm_up = 2000usize;
    let mut cpu_limit = 60.0;
    let mut conditions = vec!["linear", "holds", "loss"];
    let mut sizes = Vec::new();
    let mut k = 0;
    while k < args.len() {
        if args[k] == "--warm-up" {
            k += 1;
            warm_up = args
                .get(k)
                .and_then(|a| a.parse().ok())
                .expect("--warm-up takes a number of periods");
            // A guarded mode builds its recurring-segment references after 128 full searches.
            warm_up = warm_up.max(100);
        } else if args[k] == "--cpu" {
            k += 1;
            cpu_limit = args
                .get(k)
                .and_then(|a| a.parse().ok())
                .expect("--cpu takes a number of seconds");
        } else if args[k] == "--only" {
            k += 1;
            let only = args
                .get(k)
                .expect("--only takes conditions, e.g. linear,holds");
            conditions.retain(|c| only.split(',').any(|o| o == *c));
        } else {
            sizes.push(
                args[k]
                    .parse()
                    .unwrap_or_else(|_| panic!("not a mesh count: {:?}", args[k])),
            );
        }
        k += 1;
    }
    let sizes = if sizes.is_empty() {
        vec![1, 8, 16, 64]
    } else {
        sizes
    };
    println!(
        "| meshes | condition | exact CPU µs/period, median (range) | ÷ linear, paired median \
         (range) | timed periods | events/period | modes built / products built / product hits \
         (timed) | warm-up periods (CPU s) | cache held / peak MiB |"
    );
    println!("|---:|---|---:|---:|---:|---:|---|---|---|");
    for &meshes in &sizes {
        let mut cells: Vec<Cell> = conditions
            .iter()
            .map(|&condition| Cell::warm(meshes, condition, warm_up, cpu_limit))
            .collect();
        // The conditions alternate in short blocks, so a change of the machine's speed
        // (up to 1.6× from one second to the next on the shared VM) hits each of them alike
        // and the ratios are taken within a round.
        for _ in 0..ROUNDS {
            for cell in cells.iter_mut() {
                cell.block();
            }
        }
        let linear = cells.iter().position(|c| c.condition == "linear");
        for i in 0..cells.len() {
            let ratio = linear.map(|l| {
                let r: Vec<f64> = (cells[i].times.iter().zip(&cells[l].times))
                    .map(|(a, b)| a / b)
                    .collect();
                spread(&r, 2)
            });
            let cell = &mut cells[i];
            let memory = cell.sim.cache_memory().expect("the exact path");
            let mib = |b: usize| b as f64 / f64::from(1u32 << 20);
            let (products1, hits1) = cell.sim.composite_counts();
            println!(
                "| {meshes} | {} | {} | {} | {} | {:.2} | {} / {} / {:.2} | {} ({:.1}) | {:.1} / \
                 {:.1} |",
                cell.condition,
                spread(&cell.times, 1),
                ratio.map_or("–".into(), |r| format!("{r}×")),
                cell.timed,
                (cell.sim.stats().events - cell.events0) as f64 / cell.timed as f64,
                cell.sim.mode_counts().0 - cell.modes0,
                products1 - cell.products0,
                (hits1 - cell.hits0) as f64 / cell.timed as f64,
                cell.done - cell.timed,
                cell.warm,
                mib(memory.held),
                mib(memory.peak)
            );
        }
    }
}

/// Timed rounds per cell.
const ROUNDS: usize = 10;

/// `median (min–max)` of `v`, with `digits` decimals.
fn spread(v: &[f64], digits: usize) -> String {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    format!(
        "{:.digits$} ({:.digits$}–{:.digits$})",
        s[s.len() / 2],
        s[0],
        s[s.len() - 1]
    )
}

/// One condition's simulation, warmed up, and its timed blocks.
struct Cell {
    condition: &'static str,
    sim: TrainSimulation,
    period: f64,
    /// Periods simulated so far.
    done: usize,
    /// CPU seconds of the last warm-up period.
    last: f64,
    warm: f64,
    modes0: u64,
    products0: u64,
    hits0: u64,
    events0: u64,
    /// CPU µs per period of each timed block.
    times: Vec<f64>,
    timed: usize,
}

impl Cell {
    /// The free chain of `meshes` meshes under `condition`, warmed up: at least `warm_up`
    /// periods, on until 5 periods in a row build no mode and no composite product (at most
    /// `warm_up + 1000` periods or `cpu_limit` CPU seconds).
    fn warm(meshes: usize, condition: &'static str, warm_up: usize, cpu_limit: f64) -> Cell {
        let s = scene(meshes, condition);
        let period = 1.0 / s.mesh_frequency(0, s.operating.input_speed);
        let start = cpu_seconds();
        let mut sim = TrainSimulation::new(&s).expect("a simulation");
        let (mut done, mut settled) = (0usize, 0usize);
        let mut last;
        loop {
            let before = (sim.mode_counts().0, sim.composite_counts().0);
            let t0 = cpu_seconds();
            done += 1;
            sim.advance_to(done as f64 * period).expect("a period");
            last = cpu_seconds() - t0;
            let after = (sim.mode_counts().0, sim.composite_counts().0);
            settled = if after == before { settled + 1 } else { 0 };
            if (done >= warm_up && settled >= 5)
                || done >= warm_up + 1000
                || cpu_seconds() - start > cpu_limit
            {
                break;
            }
        }
        let warm = cpu_seconds() - start;
        let (products0, hits0) = sim.composite_counts();
        Cell {
            condition,
            modes0: sim.mode_counts().0,
            events0: sim.stats().events,
            products0,
            hits0,
            sim,
            period,
            done,
            last,
            warm,
            times: Vec::new(),
            timed: 0,
        }
    }

    /// One timed block: up to 20 periods, about 2 s of CPU where a period is slower.
    fn block(&mut self) {
        let count = ((2.0 / self.last) as usize).clamp(1, 20);
        let t0 = cpu_seconds();
        for _ in 0..count {
            self.done += 1;
            self.sim
                .advance_to(self.done as f64 * self.period)
                .expect("a period");
        }
        self.times.push((cpu_seconds() - t0) / count as f64 * 1e6);
        self.timed += count;
    }
}
