//! CPU cost per mesh period of the exact propagator on the free compliant chains of issue 37
//! under the three conditions of its acceptance 1 (the linear contact law, the contact-loss
//! law while contact holds, contact loss), cell by cell with its reuse counters and memory: a
//! probe for `docs/scaling.md` beside the scaling benchmark (`cargo bench --bench scaling`),
//! whose chains, conditions and timing it shares (`benches/common/free_chain.rs`).
//!
//! `cargo run --release --example free_chain_cost -- [--warm-up P] [--cpu S] [--only C,..]
//! [--rigid] [MESHES ...]` (default 1 8 16 64, P = 2000, S = 60, all three conditions
//! `linear`, `holds`, `loss`; compliant bearings unless `--rigid`). Each cell is one
//! simulation warmed up for at least P periods and on until 5 periods in a row build no mode
//! and no composite product (at most P + 1000 periods or S seconds of CPU). The cells of one
//! chain are then timed side by side in alternated blocks (10 rounds of up to 20 periods,
//! about 2 s of CPU where a period is slower), and each
//! condition's ratio to the linear law is taken within a round.

use geardyn::scene::train::ChainBearings;

#[path = "../benches/common/free_chain.rs"]
mod free_chain;
use free_chain::{paired, scene, spread, Cell, Condition, Method};

/// Timed rounds per cell.
const ROUNDS: usize = 10;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut warm_up = 2000usize;
    let mut cpu_limit = 60.0;
    let mut conditions = Condition::ALL.to_vec();
    let mut sizes = Vec::new();
    let mut bearings = ChainBearings::Compliant;
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
        } else if args[k] == "--rigid" {
            bearings = ChainBearings::Rigid;
        } else if args[k] == "--only" {
            k += 1;
            let only = args
                .get(k)
                .expect("--only takes conditions, e.g. linear,holds");
            conditions.retain(|c| only.split(',').any(|o| o == c.name()));
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
            .map(|&condition| {
                let s = scene(meshes, bearings, condition, Method::Exact);
                Cell::warm(&s, condition, warm_up, cpu_limit).expect("a warm-up")
            })
            .collect();
        for _ in 0..ROUNDS {
            for cell in cells.iter_mut() {
                cell.block(2.0).expect("a timed block");
            }
        }
        let linear = cells.iter().position(|c| c.condition == Condition::Linear);
        for i in 0..cells.len() {
            let ratio = linear.map(|l| spread(&paired(&cells[i], &cells[l]), 2));
            let cell = &mut cells[i];
            let memory = cell.sim.cache_memory().expect("the exact path");
            let mib = |b: usize| b as f64 / f64::from(1u32 << 20);
            println!(
                "| {meshes} | {} | {} | {} | {} | {:.2} | {} | {} ({:.1}) | {:.1} / {:.1} |",
                cell.condition.name(),
                spread(&cell.times, 1),
                ratio.map_or("–".into(), |r| format!("{r}×")),
                cell.timed,
                cell.events_per_period(),
                cell.reuse(),
                cell.warm_periods,
                cell.warm_seconds,
                mib(memory.held),
                mib(memory.peak)
            );
        }
    }
}
