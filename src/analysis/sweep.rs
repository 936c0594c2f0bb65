//! Frequency-response sweeps with warm start, for any scene: the steady state at each speed
//! starts from the final state at the previous speed, so coexisting branches are followed and
//! jumps show up as the difference between the up and the down sweep (Liu 2007 §2.4.1, §3.2,
//! §4.2; numerics-notes §3).
//!
//! The speed is the input gear's; every mesh follows with its own ratio (the countershaft's
//! second stage at `ω2 = ρ ω1`). At each speed the transient is integrated one *response
//! period* at a time: the least common multiple of the mesh periods
//! ([`crate::model::response_period`]; the mesh period of a single pair). The state is
//! periodic when it repeats after `k` response periods (a scaled residual below the tolerance,
//! `k ≤ max_subharmonic`, so period-k responses are recognised); a response whose residual
//! stalls instead of decaying is flagged aperiodic (quasi-periodic or chaotic), never silently
//! averaged. Then an integer number of response periods is recorded (no spectral leakage) for
//! the statistics of every mesh.

pub use super::mesh_response::{mesh_columns, MeshResponse, MESH_COLUMNS};
use super::shooting::{newton, state_scale, PeriodMap, ShootingOptions};
use crate::model::{response_period, Drivetrain, SceneSource};
use crate::scene::SolverSettings;
use crate::simulation::Driver;
use crate::with_drivetrain;

/// Sweep direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    Up,
    Down,
    Both,
}

impl std::str::FromStr for Direction {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "up" => Ok(Direction::Up),
            "down" => Ok(Direction::Down),
            "both" => Ok(Direction::Both),
            other => Err(format!("direction '{other}': expected up, down or both")),
        }
    }
}

/// Response periods a period-k (k > 1) candidate must persist before it is accepted.
const CONFIRM: u32 = 10;

/// Settings of a sweep.
#[derive(Debug, Clone)]
pub struct SweepOptions {
    /// Input-gear speeds, rad/s, in increasing order.
    pub speeds: Vec<f64>,
    pub direction: Direction,
    /// Response periods always discarded at each speed before the periodicity test.
    pub min_transient_periods: u32,
    /// Give up (and mark the point not converged) after this many response periods.
    pub max_transient_periods: u32,
    /// Scaled periodicity residual accepted as steady state.
    pub tolerance: f64,
    /// Longest period looked for, in response periods.
    pub max_subharmonic: u32,
    /// Response periods recorded for the statistics (rounded up to a multiple of the period
    /// found).
    pub record_periods: u32,
    /// Keep each mesh's DTE at the start of every mesh period of the recording (Poincaré
    /// section of the first mesh).
    pub poincare: bool,
    /// Try Newton shooting from the previous point's state first (exact monodromy): a stable
    /// period-1 orbit found so is the steady state, with no transient to integrate. Off, or
    /// when Newton fails or finds an unstable orbit, the transient is integrated.
    pub shooting: bool,
}

impl SweepOptions {
    pub fn new(speeds: Vec<f64>, direction: Direction) -> Self {
        SweepOptions {
            speeds,
            direction,
            min_transient_periods: 20,
            max_transient_periods: 3000,
            tolerance: 1e-7,
            max_subharmonic: 4,
            record_periods: 8,
            poincare: false,
            shooting: true,
        }
    }

    /// `from:to:points`, evenly spaced, each end `4500rpm`, `471.24rad/s` or a bare number
    /// in rad/s ([`crate::units::parse_speed_range`]).
    pub fn parse_range(range: &str) -> Result<Vec<f64>, String> {
        crate::units::parse_speed_range("--speed", range)
    }

    fn validate(&self) -> Result<(), String> {
        if self.speeds.is_empty() {
            return Err("sweep: no speeds (zero points)".into());
        }
        if let Some(bad) = self.speeds.iter().find(|v| !(**v > 0.0 && v.is_finite())) {
            return Err(format!("sweep speed {bad}: must be a finite speed > 0"));
        }
        if self.speeds.windows(2).any(|w| !(w[1] > w[0])) {
            return Err("sweep speeds must be strictly increasing".into());
        }
        if !(self.tolerance > 0.0) {
            return Err(format!("sweep tolerance = {}: must be > 0", self.tolerance));
        }
        if self.max_subharmonic == 0 || self.record_periods == 0 {
            return Err("sweep: max_subharmonic and record_periods must be ≥ 1".into());
        }
        if self.max_transient_periods < self.min_transient_periods {
            return Err(format!(
                "sweep: max_transient_periods = {} below min_transient_periods = {}",
                self.max_transient_periods, self.min_transient_periods
            ));
        }
        Ok(())
    }
}

/// How a sweep point's steady state was classified.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Periodicity {
    /// Repeats after `k` response periods.
    Periodic(u32),
    /// Still decaying at `max_transient_periods`: a slow transient (more periods may settle).
    Unsettled,
    /// The residual stopped decreasing without reaching the tolerance: quasi-periodic or
    /// chaotic (or periodic beyond `max_subharmonic`). The statistics are of the recorded
    /// stretch, marked, not an average over a period.
    Aperiodic,
}

/// One point of a sweep.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepPoint {
    pub direction: Direction,
    /// Input-gear speed, rad/s.
    pub speed: f64,
    /// Mesh frequency of the first mesh, Hz.
    pub mesh_frequency: f64,
    /// Response period (least common multiple of the mesh periods), s.
    pub response_period: f64,
    /// Whether a periodic steady state was found; if not, the statistics are of the last
    /// recorded stretch (kept, marked, never dropped).
    pub converged: bool,
    pub periodicity: Periodicity,
    /// Period in response periods (when converged).
    pub response_periods: Option<u32>,
    /// Periodicity residual at the end of the transient.
    pub residual: f64,
    /// Response periods integrated as transient (0 when Newton shooting found the orbit).
    pub transient_periods: u32,
    /// Newton iterations of the shooting warm start (0 when not used or not converged).
    pub newton_iterations: u32,
    /// Largest Floquet multiplier modulus of the last periodic orbit shooting found at this
    /// speed (above 1: the orbit exists but is unstable); NaN when shooting found none. It is
    /// the radius of the map over [`SweepPoint::spectral_radius_periods`] response periods:
    /// at a period-2 or aperiodic point, where the last shooting was for a period-2 orbit,
    /// that of the period-2 map (the square of the period-1 multipliers of that orbit, were it
    /// period-1).
    pub spectral_radius: f64,
    /// The response periods of the orbit whose spectral radius is given (None when shooting
    /// found none).
    pub spectral_radius_periods: Option<u32>,
    /// One entry per mesh.
    pub meshes: Vec<MeshResponse>,
    /// Where the recording started: the first mesh's phase in cycles, reduced modulo the
    /// response period's cycles, and the state. A run of the same scene at this speed, set to
    /// this state when its first mesh has this phase, continues on the recorded response.
    pub recording_phase: f64,
    pub recording_state: Vec<f64>,
    /// Why the run failed at this speed (then every statistic is NaN).
    pub failure: Option<String>,
}

/// Columns shared by every scene; then per mesh [`MESH_COLUMNS`], prefixed.
pub const POINT_COLUMNS: [&str; 11] = [
    "direction",
    "speed",
    "speed_rpm",
    "mesh_frequency",
    "converged",
    "response_periods",
    "residual",
    "transient_periods",
    "aperiodic",
    "spectral_radius",
    "spectral_radius_periods",
];

/// The column names of a sweep of a model with the given mesh prefixes.
pub fn sweep_columns(prefixes: &[String]) -> Vec<String> {
    let mut names: Vec<String> = POINT_COLUMNS.iter().map(|s| s.to_string()).collect();
    names.extend(mesh_columns(prefixes));
    names
}

impl SweepPoint {
    /// Values in [`sweep_columns`] order (direction as +1 up / −1 down).
    pub fn row(&self) -> Vec<f64> {
        let mut row = vec![
            if self.direction == Direction::Up {
                1.0
            } else {
                -1.0
            },
            self.speed,
            crate::units::rpm(self.speed),
            self.mesh_frequency,
            if self.converged { 1.0 } else { 0.0 },
            self.response_periods.map_or(0.0, f64::from),
            self.residual,
            self.transient_periods as f64,
            f64::from(u8::from(self.periodicity == Periodicity::Aperiodic)),
            self.spectral_radius,
            self.spectral_radius_periods.map_or(0.0, f64::from),
        ];
        for m in &self.meshes {
            row.extend(m.values());
        }
        row
    }
}

/// A finished sweep: its points and the mesh prefixes of the scene's columns.
#[derive(Debug, Clone)]
pub struct Sweep {
    pub prefixes: Vec<String>,
    pub points: Vec<SweepPoint>,
}

impl Sweep {
    pub fn columns(&self) -> Vec<String> {
        sweep_columns(&self.prefixes)
    }
}

/// Runs the sweep on any scene; `Both` runs the up and the down branch on two threads.
/// `progress` is called after every point with (points done, points total).
pub fn sweep(
    scene: &impl SceneSource,
    options: &SweepOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Sweep, String> {
    options.validate()?;
    let first = scene.to_scene();
    first.profiles.require_constant("a speed sweep")?;
    crate::model::train::planetary::require_fixed_frame_speed(&first, "a speed sweep")?;
    let speeds = options.speeds.clone();
    let start = |d: Direction| {
        if d == Direction::Down {
            *speeds.last().expect("validated")
        } else {
            speeds[0]
        }
    };
    let total = match options.direction {
        Direction::Both => 2 * options.speeds.len(),
        _ => options.speeds.len(),
    };
    let done = std::sync::atomic::AtomicUsize::new(0);
    let tick = || {
        let d = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        progress(d, total);
    };
    let run = |d: Direction| -> Result<Sweep, String> {
        let mut at = first.clone();
        at.set_input_speed(start(d));
        with_drivetrain!(at.simulation()?, sim => {
            let prefixes = (0..sim.model().mesh_count()).map(|n| sim.model().mesh_prefix(n)).collect();
            let points = branch(sim, &at.solver, options, d, &tick)?;
            Ok(Sweep { prefixes, points })
        })
    };
    match options.direction {
        Direction::Up | Direction::Down => run(options.direction),
        Direction::Both => {
            let deadline = crate::simulation::budget::Deadline::current();
            let (up, down) = std::thread::scope(|s| {
                let up = s.spawn(|| deadline.run(|| run(Direction::Up)));
                let down = run(Direction::Down);
                (up.join().expect("sweep thread"), down)
            });
            let mut sweep = up?;
            sweep.points.extend(down?.points);
            Ok(sweep)
        }
    }
}

fn branch<M: Drivetrain>(
    mut sim: Driver<M>,
    settings: &SolverSettings,
    options: &SweepOptions,
    direction: Direction,
    tick: &(dyn Fn() + Sync),
) -> Result<Vec<SweepPoint>, String> {
    let mut speeds = options.speeds.clone();
    if direction == Direction::Down {
        speeds.reverse();
    }
    // The start, for a restart after a point whose run failed.
    let (start_model, start_state) = (sim.model().clone(), sim.y().to_vec());
    let mut points = Vec::with_capacity(speeds.len());
    for &speed in &speeds {
        sim.new_run_scope();
        sim.change_model(|model, t| model.set_input_speed(t, speed))
            .map_err(|e| format!("speed {speed} rad/s: {e}"))?;
        match steady_state(&mut sim, settings, options, direction, speed) {
            Ok(point) => points.push(point),
            Err(failure) => {
                // A run that breaks down at one speed (a response that diverges) is kept as a
                // marked point with its reason; the branch goes on from the scene's start at
                // the next speed instead of losing the points already computed.
                points.push(failed_point(direction, speed, sim.model(), failure));
                let mut model = start_model.clone();
                model.set_input_speed(0.0, speed)?;
                sim = Driver::with_model(model, &start_state, settings)?;
                sim.default_work_budget(crate::simulation::budget::DEFAULT_RUN_BUDGET);
            }
        }
        tick();
    }
    Ok(points)
}

/// A point whose run failed: NaN statistics, not converged, and the reason.
fn failed_point<M: Drivetrain>(
    direction: Direction,
    speed: f64,
    model: &M,
    failure: String,
) -> SweepPoint {
    let meshes = (0..model.mesh_count())
        .map(|m| MeshResponse::failed(model.mesh_prefix(m), model.mesh_frequency(m)))
        .collect();
    SweepPoint {
        direction,
        speed,
        mesh_frequency: model.mesh_frequency(0),
        response_period: f64::NAN,
        converged: false,
        periodicity: Periodicity::Unsettled,
        response_periods: None,
        residual: f64::NAN,
        transient_periods: 0,
        newton_iterations: 0,
        spectral_radius: f64::NAN,
        spectral_radius_periods: None,
        meshes,
        recording_phase: f64::NAN,
        recording_state: Vec::new(),
        failure: Some(failure),
    }
}

/// Response periods over which a stalled residual marks a response aperiodic: the best
/// residual of the last window must have fallen below [`STALL_RATIO`] of the window before.
const STALL_WINDOW: u32 = 200;

/// A residual that falls by less than this over a [`STALL_WINDOW`] has stalled. A slowly
/// decaying transient (a multiplier of 0.997 falls to 0.55 over 200 periods, the idler's
/// grounded 69.5 Hz mode at ζ = 2 %) is not flagged; a quasi-periodic or chaotic response,
/// whose residual does not decay at all, is.
const STALL_RATIO: f64 = 0.9;

/// Integrates to the periodic steady state at the current inputs and records its statistics.
fn steady_state<M: Drivetrain>(
    sim: &mut Driver<M>,
    settings: &SolverSettings,
    options: &SweepOptions,
    direction: Direction,
    speed: f64,
) -> Result<SweepPoint, String> {
    let at = |e: String| format!("speed {speed} rad/s: {e}");
    let period = response_period(sim.model()).map_err(at)?;
    let scale = state_scale(sim.model(), sim.y());
    // The radius and the response periods of its map (see `shoot_here`).
    let mut spectral_radius = (f64::NAN, None);
    let newton_iterations = if options.shooting {
        shoot_here(sim, settings, options, period, 1, &mut spectral_radius)
    } else {
        0
    };
    let kmax = options.max_subharmonic as usize;
    let mut history: Vec<Vec<f64>> = vec![sim.y().to_vec()];
    let t0 = sim.t();
    let mut found = None;
    let mut residual = f64::INFINITY;
    let mut candidate: Option<(usize, u32)> = None;
    // Best residual of the current and the previous stall window.
    let (mut window_best, mut previous_best) = (f64::INFINITY, f64::INFINITY);
    let mut stalled = false;
    let mut j = 0u32;
    if newton_iterations > 0 {
        found = Some(1);
        residual = 0.0;
    }
    while found.is_none() && j < options.max_transient_periods {
        j += 1;
        sim.advance_to(t0 + j as f64 * period)
            .map_err(|e| at(e.to_string()))?;
        // Retries after 50, 100, 200, 400, … periods: a settled transient is finished early,
        // and a response that never settles (an unstable orbit, quasi-periodic motion) costs
        // a logarithmic number of failed Newton runs.
        if options.shooting
            && j >= NEWTON_RETRY
            && (j / NEWTON_RETRY).is_power_of_two()
            && j.is_multiple_of(NEWTON_RETRY)
        {
            // Period 1, then period 2 (the period-doubled orbits near the second-harmonic
            // and subharmonic resonances).
            let k = (1..=2u32.min(options.max_subharmonic))
                .find(|&k| shoot_here(sim, settings, options, period, k, &mut spectral_radius) > 0);
            if let Some(k) = k {
                found = Some(k);
                residual = 0.0;
                break;
            }
        }
        history.push(sim.y().to_vec());
        if history.len() > kmax + 1 {
            history.remove(0);
        }
        if j < options.min_transient_periods || history.len() <= kmax {
            continue;
        }
        let now = &history[kmax];
        let residuals: Vec<f64> = (1..=kmax)
            .map(|k| {
                let then = &history[kmax - k];
                now.iter()
                    .zip(then)
                    .zip(&scale)
                    .map(|((a, b), s)| ((a - b) / s).abs())
                    .fold(0.0, f64::max)
            })
            .collect();
        residual = residuals.iter().copied().fold(f64::INFINITY, f64::min);
        window_best = window_best.min(residual);
        if j.is_multiple_of(STALL_WINDOW) {
            stalled = window_best > STALL_RATIO * previous_best;
            previous_best = window_best;
            window_best = f64::INFINITY;
        }
        // The shortest period that repeats is the response period. A decaying transient
        // whose multiplier is close to a k-th root of unity also makes the k-residual small,
        // so k > 1 is accepted only after it has held for `CONFIRM` response periods while
        // the shorter periods kept failing.
        let best = residuals.iter().position(|&r| r <= options.tolerance);
        match (best, candidate) {
            (Some(0), _) => {
                found = Some(1);
                residual = residuals[0];
                break;
            }
            (Some(i), Some((k, since))) if k == i + 1 => {
                if j - since >= CONFIRM * k as u32 {
                    found = Some(k as u32);
                    residual = residuals[i];
                    break;
                }
            }
            (Some(i), _) => candidate = Some((i + 1, j)),
            (None, _) => candidate = None,
        }
    }
    // A period found by the transient test repeats to the periodicity tolerance only: Newton
    // from there (its last step polishes the orbit far below the tolerance, `newton`) puts
    // the run on the orbit (when it is stable and the run's).
    if let (Some(k), true, 0) = (found, options.shooting, newton_iterations) {
        if k <= 2 {
            shoot_here(sim, settings, options, period, k, &mut spectral_radius);
        }
    }
    let periodicity = match found {
        Some(k) => Periodicity::Periodic(k),
        None if stalled => Periodicity::Aperiodic,
        None => Periodicity::Unsettled,
    };
    let k = found.unwrap_or(1);
    // A periodic response is recorded over one period exactly; anything else over
    // `record_periods`.
    let record = if found.is_some() {
        k
    } else {
        options.record_periods
    };
    let model = sim.model();
    let f1 = model.mesh_frequency(0);
    // Mesh periods of the first mesh per response period (an integer by construction).
    let per_response = (period * f1).round().max(1.0) as usize;
    let recording_phase = model.mesh_phase(0, sim.t()).rem_euclid(per_response as f64);
    let recording_state = sim.y().to_vec();
    let mesh_responses =
        super::orbit_statistics::record(sim, settings, record as f64 * period, options.poincare)
            .map_err(at)?;
    Ok(SweepPoint {
        direction,
        speed,
        mesh_frequency: f1,
        response_period: period,
        converged: found.is_some(),
        periodicity,
        response_periods: found,
        residual,
        transient_periods: j,
        newton_iterations,
        spectral_radius: spectral_radius.0,
        spectral_radius_periods: spectral_radius.1,
        meshes: mesh_responses,
        recording_phase,
        recording_state,
        failure: None,
    })
}

/// Response periods of transient before the first further shooting attempt (the next ones
/// after twice as many each time): a transient that has settled into the basin of a stable
/// orbit is finished by Newton.
const NEWTON_RETRY: u32 = 50;

/// Largest scaled periodicity residual of the run's state at which a shooting orbit is
/// accepted: Newton polishes a state that nearly repeats (after a small speed step, or after
/// some transient), but from a state far from periodic it may converge to an attractor whose
/// basin the run is not in.
const NEAR_PERIODIC: f64 = 0.25;

/// Safety factor on the distance bound `r0/(1 − ρ)` within which a shooting orbit is
/// accepted as the run's attractor (the bound holds for a linear contraction in the norm the
/// residual uses; the factor covers non-normal monodromies and the nonlinearity).
const ATTRACTION_MARGIN: f64 = 3.0;

/// Newton iterations allowed to the shooting warm start before the transient is integrated.
const NEWTON_ITERATIONS: usize = 8;

/// Newton shooting for a period-`k` orbit from the run's current state over `k` response
/// periods; on a stable orbit the run restarts on it and the iterations used are returned, else
/// 0 and the run is unchanged. The spectral radius of any orbit found (stable or not) is kept
/// in `spectral_radius` with `k`, the response periods of its map: an unstable orbit there
/// explains a response that does not settle.
fn shoot_here<M: Drivetrain>(
    sim: &mut Driver<M>,
    settings: &SolverSettings,
    options: &SweepOptions,
    period: f64,
    k: u32,
    spectral_radius: &mut (f64, Option<u32>),
) -> u32 {
    let t = sim.t();
    let Ok(map) = PeriodMap::new(sim.model().clone(), settings, period * k as f64) else {
        return 0;
    };
    let mut map = map.starting_at(t);
    let shooting = ShootingOptions {
        periods: k,
        warmup_periods: 0,
        tolerance: options.tolerance,
        max_iterations: NEWTON_ITERATIONS,
    };
    let y = sim.y().to_vec();
    let scale = state_scale(sim.model(), &y);
    match newton(&mut map, y.clone(), &shooting) {
        Ok(orbit) => {
            let rho = orbit.spectral_radius();
            *spectral_radius = (rho, Some(k));
            // The orbit is the attractor the run is heading for only if the run is already in
            // its neighbourhood: for a contracting period map the distance to the fixed point
            // is at most r0/(1 − ρ), r0 the first residual. An orbit farther away is another
            // attractor (Newton can converge to any of them), which a slow physical sweep
            // would not reach from here: then the transient is integrated instead.
            let distance = y
                .iter()
                .zip(&orbit.y0)
                .zip(&scale)
                .map(|((a, b), s)| ((a - b) / s).abs())
                .fold(0.0, f64::max);
            let reach = ATTRACTION_MARGIN * orbit.residuals[0] / (1.0 - rho).max(1e-12);
            if rho < 1.0 && distance <= reach && orbit.residuals[0] <= NEAR_PERIODIC {
                sim.set_y(t, &orbit.y0);
                (orbit.residuals.len() as u32).max(1)
            } else {
                0
            }
        }
        Err(_) => 0,
    }
}
