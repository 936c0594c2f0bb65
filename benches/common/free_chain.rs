//! The free chains of issue 37 (`ChainSpec::free`: 38/55-tooth gears alternating, no ground
//! coupling, 2000 Hz) under the three conditions of its acceptance 1, and their timing in
//! alternated blocks after the settling transient: shared by `benches/scaling.rs` and
//! `examples/free_chain_cost.rs` (included by each with `#[path]`).
//!
//! The free chains start away from their steady state and the transient decays slowly (about
//! 10× per 300 periods at 16 meshes), so a window inside it times the guarded sequences'
//! certificates rebuilt for the transient, not the steady state: the exact simulation is
//! warmed up for at least `P` periods (2000 by default) and on until 5 periods in a row build
//! no mode and no composite product. An RK simulation of the same chain starts from the
//! warmed exact state (`set_state`), so every method times the same stretch of the motion.
//! Times are CPU time of this thread (`CLOCK_THREAD_CPUTIME_ID`): a loaded machine changes
//! them less than wall time. The VM's speed still jumps by up to 1.6× from one second to the
//! next, so the cells of one chain are timed side by side in short alternated blocks and
//! ratios are taken within a block round ([`paired`]).
#![allow(dead_code)] // each user takes the parts it needs

use geardyn::model::train::TrainSimulation;
use geardyn::scene::train::{ChainBearings, ChainContact, ChainSpec};
use geardyn::scene::Scene;

#[path = "cpu.rs"]
mod cpu;

/// The three conditions of issue 37's acceptance 1.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Condition {
    /// The linear contact law: no guards, no events.
    Linear,
    /// The contact-loss law while contact holds: the chain without its STE, so no loaded mesh
    /// separates.
    Holds,
    /// Contact loss: the contact-loss law with the free chain's 15 µm STE.
    Loss,
}

impl Condition {
    pub const ALL: [Condition; 3] = [Condition::Linear, Condition::Holds, Condition::Loss];

    pub fn name(self) -> &'static str {
        match self {
            Condition::Linear => "linear",
            Condition::Holds => "holds",
            Condition::Loss => "loss",
        }
    }
}

/// A propagator: the exact one or an RK pair, at rtol 1e-9, atol 1e-15 (the scene defaults).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Method {
    Exact,
    Dp5,
    Dop853,
    Rodas4,
}

impl Method {
    pub const ALL: [Method; 4] = [Method::Exact, Method::Dp5, Method::Dop853, Method::Rodas4];

    pub fn name(self) -> &'static str {
        match self {
            Method::Exact => "exact",
            Method::Dp5 => "dp5",
            Method::Dop853 => "dop853",
            Method::Rodas4 => "rodas4",
        }
    }
}

/// The free chain of `meshes` meshes with `bearings` under `condition`, with `method`.
pub fn scene(
    meshes: usize,
    bearings: ChainBearings,
    condition: Condition,
    method: Method,
) -> Scene {
    let contact = match condition {
        Condition::Linear => ChainContact::Linear,
        Condition::Holds => ChainContact::ContactHolds,
        Condition::Loss => ChainContact::ContactLoss,
    };
    let text = ChainSpec::free(meshes, bearings, contact)
        .toml()
        .expect("a free chain");
    let mut s = Scene::from_toml_str(&text, "free_chain").expect("a free chain scene");
    s.solver
        .set_propagator(method.name())
        .expect("exact or an RK method");
    s.solver.rtol = 1e-9;
    s.solver.atol = 1e-15;
    s
}

/// CPU seconds of this thread.
pub fn cpu_seconds() -> f64 {
    cpu::thread_cpu()
}

/// `median (min–max)` of `v`, with `digits` decimals.
pub fn spread(v: &[f64], digits: usize) -> String {
    if v.is_empty() {
        return "–".into();
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    format!(
        "{:.digits$} ({:.digits$}–{:.digits$})",
        s[s.len() / 2],
        s[0],
        s[s.len() - 1]
    )
}

/// Ratios `a[i] / b[i]` of the blocks both cells timed in the same round.
pub fn paired(a: &Cell, b: &Cell) -> Vec<f64> {
    a.times.iter().zip(&b.times).map(|(x, y)| x / y).collect()
}

/// The median of `v` (NaN for none).
pub fn median_of(v: &[f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s[s.len() / 2]
}

/// One simulation (a chain, a condition, a method) past its warm-up, and its timed blocks.
pub struct Cell {
    pub condition: Condition,
    pub method: Method,
    pub sim: TrainSimulation,
    period: f64,
    /// Periods simulated so far.
    pub done: usize,
    /// CPU seconds of the last untimed period (the estimate of a timed one).
    last: f64,
    /// Warm-up: periods and CPU seconds.
    pub warm_periods: usize,
    pub warm_seconds: f64,
    modes0: u64,
    products0: u64,
    hits0: u64,
    events0: u64,
    /// CPU µs per period of each timed block.
    pub times: Vec<f64>,
    /// Periods timed so far.
    pub timed: usize,
}

impl Cell {
    /// The exact simulation of `scene` warmed up: at least `warm_up` periods, on until 5
    /// periods in a row build no mode and no composite product (at most `warm_up + 1000`
    /// periods or `cpu_limit` CPU seconds).
    pub fn warm(
        scene: &Scene,
        condition: Condition,
        warm_up: usize,
        cpu_limit: f64,
    ) -> Result<Cell, String> {
        let period = 1.0 / scene.mesh_frequency(0, scene.operating.input_speed);
        let start = cpu_seconds();
        let mut sim = TrainSimulation::new(scene)?;
        let (mut done, mut settled) = (0usize, 0usize);
        let mut last;
        loop {
            let before = (sim.mode_counts().0, sim.composite_counts().0);
            let t0 = cpu_seconds();
            done += 1;
            sim.advance_to(done as f64 * period)
                .map_err(|e| format!("{e} (period {done})"))?;
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
        Ok(Cell::started(
            condition,
            Method::Exact,
            sim,
            period,
            done,
            last,
            cpu_seconds() - start,
        ))
    }

    /// `scene` (the chain of `from` with another method) started from `from`'s current state,
    /// and one untimed period (its RK step size settles, and it estimates a timed period).
    pub fn follow(scene: &Scene, method: Method, from: &Cell) -> Result<Cell, String> {
        let start = cpu_seconds();
        let mut sim = TrainSimulation::new(scene)?;
        sim.set_state(from.done as f64 * from.period, from.sim.state());
        let done = from.done + 1;
        sim.advance_to(done as f64 * from.period)
            .map_err(|e| format!("{e} (period {done})"))?;
        let seconds = cpu_seconds() - start;
        Ok(Cell::started(
            from.condition,
            method,
            sim,
            from.period,
            done,
            seconds,
            seconds,
        ))
    }

    fn started(
        condition: Condition,
        method: Method,
        sim: TrainSimulation,
        period: f64,
        done: usize,
        last: f64,
        warm_seconds: f64,
    ) -> Cell {
        let (products0, hits0) = sim.composite_counts();
        Cell {
            condition,
            method,
            modes0: sim.mode_counts().0,
            events0: sim.stats().events,
            products0,
            hits0,
            sim,
            period,
            done,
            last,
            warm_periods: done,
            warm_seconds,
            times: Vec::new(),
            timed: 0,
        }
    }

    /// CPU seconds of one period, as last measured.
    pub fn seconds_per_period(&self) -> f64 {
        self.times.last().map_or(self.last, |&us| us * 1e-6)
    }

    /// One timed block: up to 20 periods, about `cpu_target` seconds where a period is
    /// slower (at least one period).
    pub fn block(&mut self, cpu_target: f64) -> Result<(), String> {
        let count = ((cpu_target / self.last) as usize).clamp(1, 20);
        let t0 = cpu_seconds();
        for _ in 0..count {
            self.done += 1;
            self.sim
                .advance_to(self.done as f64 * self.period)
                .map_err(|e| format!("{e} (period {})", self.done))?;
        }
        self.times.push((cpu_seconds() - t0) / count as f64 * 1e6);
        self.timed += count;
        Ok(())
    }

    /// Events per timed period.
    pub fn events_per_period(&self) -> f64 {
        (self.sim.stats().events - self.events0) as f64 / self.timed.max(1) as f64
    }

    /// What the exact propagator did in the timed periods: `modes built / products built /
    /// product hits per period` (the products held, so negative where a full cache was
    /// cleared).
    pub fn reuse(&self) -> String {
        let (products, hits) = self.sim.composite_counts();
        format!(
            "{} / {} / {:.2}",
            self.sim.mode_counts().0 - self.modes0,
            products as i64 - self.products0 as i64,
            (hits - self.hits0) as f64 / self.timed.max(1) as f64
        )
    }
}
