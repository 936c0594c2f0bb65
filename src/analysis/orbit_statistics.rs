//! Each mesh's response over a recorded stretch of a run ([`MeshResponse`]), from the
//! continuous solution rather than from a sample grid (issue 31): the statistics `sweep` and
//! `periodic` report.
//!
//! The stretch is cut into cells at every known switching instant (each mesh's stiffness and
//! gap breakpoints, [`Drivetrain::mesh_breakpoints`], where a runout moves them:
//! [`Drivetrain::mesh_knot_phase`]) and at a grid short enough for the
//! fastest mode (`h·ω_max ≤ 3`, at least four cells per period of the first mesh). Between
//! switching instants the solution is smooth (analytic on an exact segment), so:
//!
//! - **contact loss**: the fraction of the stretch, and the separation phase, come from the
//!   located event times (the mode, hence the contact state, is constant between them);
//! - **mean, RMS, harmonics** of DTE and force: a 10-point Gauss–Legendre rule on each smooth
//!   piece; with `h·ω_max ≤ 3` its error on `e^{iωt}` and its square is below 1e-14 of the
//!   integrand's size (`(n!)⁴/((2n+1)((2n)!)³)·(2hω)^{2n}`, n = 10);
//! - **extremes** (peak |force|, DTE peak to peak): the largest sample of each smooth piece
//!   (its nodes and its ends, where the force may jump), refined between its neighbours by
//!   successive parabolas or Brent's maximisation ([`crate::solve::roots::brent_maximum`]).
//!
//! **On the exact propagator** ([`record_observed`]) the run advances cell by cell and hands
//! over every segment it takes, with the model still in the segment's mode
//! ([`Driver::advance_observed`]): a segment's ends are the run's own stops and located
//! events (located by the propagator to a few ulps of the time), and every value inside it —
//! nodes, one-sided limits at its ends, the evaluations of the refinement — comes from the
//! segment's start state and its mode's matrix by a Taylor series
//! ([`crate::solve::exact::segment_series`]), exact to rounding, with no probe run and no
//! copy of the model. Every piece's maximum is refined.
//!
//! **Elsewhere** (RK, speed or torque profiles: [`record_probed`]) the run counts its state
//! events; a cell in which any occurred is searched for them with a probe run restarted at the
//! cell's start ([`Driver::restart`]): the k-th event is bracketed by the event count, then
//! located by Brent's method on the guard that crossed
//! ([`crate::solve::roots::brent_bracket`]), to about 1e-13 of the cell; the extremes whose
//! samples come within 2 % of the quantity's spread of the best are refined on the probe, and
//! one-sided limits are taken 1e-11 of a cell inside a switching instant. The values are those
//! of the RK solution, which stops at the nodes: its error is the integration tolerance
//! (`solver.rtol`, `solver.atol`), not a sampling error (`docs/sweep.md`).

use std::f64::consts::TAU;

use super::mesh_response::MeshResponse;
use crate::model::Drivetrain;
use crate::scene::SolverSettings;
use crate::simulation::Driver;
use crate::solve::exact::segment_series::{Segment, SegmentObserver};
use crate::solve::rk::{DenseStep, StepObserver};
use crate::solve::roots::{brent_bracket, brent_maximum};

/// 10-point Gauss–Legendre rule on [−1, 1] (Abramowitz & Stegun, Table 25.4).
const GAUSS10: [(f64, f64); 10] = [
    (-0.973_906_528_517_171_7, 0.066_671_344_308_688_1),
    (-0.865_063_366_688_984_5, 0.149_451_349_150_580_6),
    (-0.679_409_568_299_024_4, 0.219_086_362_515_982),
    (-0.433_395_394_129_247_2, 0.269_266_719_309_996_4),
    (-0.148_874_338_981_631_2, 0.295_524_224_714_752_9),
    (0.148_874_338_981_631_2, 0.295_524_224_714_752_9),
    (0.433_395_394_129_247_2, 0.269_266_719_309_996_4),
    (0.679_409_568_299_024_4, 0.219_086_362_515_982),
    (0.865_063_366_688_984_5, 0.149_451_349_150_580_6),
    (0.973_906_528_517_171_7, 0.066_671_344_308_688_1),
];

/// Largest `h·ω_max` of a cell (see the module documentation).
const CELL_OMEGA: f64 = 3.0;

/// Fewest cells per period of the first mesh.
const MIN_CELLS: usize = 4;

/// One-sided limits of the probed path are taken this fraction of a cell inside a switching
/// instant.
const ONE_SIDED: f64 = 1e-11;

/// Boundaries closer than this fraction of a cell are merged.
const MERGE: f64 = 1e-9;

/// Event times are located to this fraction of their cell.
const EVENT_TOL: f64 = 1e-13;

/// Extremes are located to this fraction of their bracket.
const PEAK_TOL: f64 = 1e-9;

/// A sampled maximum within this fraction of the quantity's spread of the best is refined.
const REFINE_MARGIN: f64 = 0.02;

/// The run's state at the start of a cell.
struct Start<R> {
    t: f64,
    y: Vec<f64>,
    run: R,
}

/// One mesh's values at one instant.
#[derive(Clone, Copy)]
struct Value {
    dte: f64,
    force: f64,
    lost: bool,
    /// [`crate::model::MeshSample::separated_pairs`].
    separated: u64,
}

fn values<M: Drivetrain>(sim: &Driver<M>, meshes: usize) -> Vec<Value> {
    let (t, y) = (sim.t(), sim.y());
    (0..meshes)
        .map(|m| {
            let s = sim.model().mesh_sample(m, t, y);
            Value {
                dte: s.dte,
                force: s.force,
                lost: s.lost,
                separated: s.separated_pairs,
            }
        })
        .collect()
}

/// A candidate extreme: its sampled value, the bracket around it and its cell.
#[derive(Clone, Copy)]
struct Candidate {
    value: f64,
    /// Where the sampled maximum is, and the samples beside it (`None` where the bracket
    /// reaches a piece's end without a sample there).
    at: f64,
    below: Option<f64>,
    above: Option<f64>,
    lo: f64,
    hi: f64,
    cell: usize,
}

/// The three extremes kept per mesh: |force|, DTE, −DTE.
const EXTREMES: usize = 3;

fn quantity(v: &Value, which: usize) -> f64 {
    match which {
        0 => v.force.abs(),
        1 => v.dte,
        _ => -v.dte,
    }
}

/// Running sums of one mesh.
struct Sums {
    force_ref: f64,
    dte_ref: f64,
    force: f64,
    force2: f64,
    dte: f64,
    dte2: f64,
    /// `∫ (d − d_ref) e^{−i2πh f_m (t − t0)} dt`, h = 1, 2, 3.
    harmonics: [(f64, f64); 3],
    lost_time: f64,
    /// Per tooth-pair slot ([`Drivetrain::mesh_pair_slots`]), the time it was engaged and out
    /// of contact.
    pair_lost_time: Vec<f64>,
    separation: f64,
    lost: bool,
    candidates: [Vec<Candidate>; EXTREMES],
    poincare: Vec<f64>,
}

/// A smooth piece `[lo, hi]` of a cell: its samples (time, values), of which the Gauss nodes
/// are `nodes`.
struct Piece<'a> {
    lo: f64,
    hi: f64,
    samples: &'a [(f64, Vec<Value>)],
    nodes: std::ops::Range<usize>,
}

/// The sample times of a smooth piece `[lo, hi]`: a one-sided limit inside each end where the
/// solution switches (`jump_lo`, `jump_hi`), and the Gauss nodes between; returns the times
/// and the range of the nodes among them.
fn piece_times(
    lo: f64,
    hi: f64,
    jump_lo: bool,
    jump_hi: bool,
    inset: f64,
) -> (Vec<f64>, std::ops::Range<usize>) {
    // A piece too short for an inset has no one-sided samples (its nodes are as close).
    let room = hi - lo > 4.0 * inset;
    let mut times = Vec::with_capacity(GAUSS10.len() + 2);
    if jump_lo && room {
        times.push(lo + inset);
    }
    let first = times.len();
    let (mid, half) = (0.5 * (lo + hi), 0.5 * (hi - lo));
    times.extend(GAUSS10.iter().map(|(x, _)| mid + half * x));
    let nodes = first..times.len();
    if jump_hi && room {
        times.push(hi - inset);
    }
    (times, nodes)
}

/// The cells of a recorded stretch: `(time, switches there, ends a period of the first mesh)`
/// per boundary, and the grid step.
struct Cells {
    bounds: Vec<(f64, bool, bool)>,
    h: f64,
}

fn cells<M: Drivetrain>(model: &M, t0: f64, duration: f64) -> Cells {
    let meshes = model.mesh_count();
    let f1 = model.mesh_frequency(0);
    let cycles = (duration * f1).round().max(1.0) as usize;
    let t_end = t0 + duration;
    let period1 = duration / cycles as f64;
    let per_cycle = ((period1 * model.max_frequency() / CELL_OMEGA).ceil() as usize).max(MIN_CELLS);
    // The cell boundaries: the grid, then every mesh's breakpoints (flagged: the solution
    // switches there).
    let mut bounds: Vec<(f64, bool, bool)> = (0..=cycles * per_cycle)
        .map(|i| {
            let t = t0 + duration * i as f64 / (cycles * per_cycle) as f64;
            (t, false, i % per_cycle == 0 && i > 0)
        })
        .collect();
    for m in 0..meshes {
        let fm = model.mesh_frequency(m);
        let p0 = model.mesh_phase(m, t0);
        let mesh_cycles = (duration * fm).round() as i64;
        for b in model.mesh_breakpoints(m) {
            let first = (p0 - b).ceil() as i64;
            // One cycle either side: a runout moves a knot across the stretch's ends.
            for k in first - 1..=first + mesh_cycles + 1 {
                let nominal = k as f64 + b;
                let shift = model.mesh_knot_phase(m, nominal) - nominal;
                let t = t0 + (k as f64 + b - p0 + shift) / fm;
                if t > t0 && t < t_end {
                    bounds.push((t, true, false));
                }
            }
        }
    }
    bounds.sort_by(|a, b| a.0.total_cmp(&b.0));
    // A breakpoint within `MERGE` of a cell of a grid point is one boundary, at the
    // breakpoint (the start and the end of the stretch stay where they are).
    let h = duration / (cycles * per_cycle) as f64;
    let mut merged: Vec<(f64, bool, bool)> = Vec::with_capacity(bounds.len());
    for b in bounds {
        match merged.last_mut() {
            Some(a) if b.0 - a.0 <= MERGE * h => {
                let pinned = a.0 == t0 || b.0 == t_end;
                if b.0 == t_end || (!pinned && b.1 && !a.1) {
                    a.0 = b.0;
                }
                a.1 |= b.1;
                a.2 |= b.2;
            }
            _ => merged.push(b),
        }
    }
    Cells { bounds: merged, h }
}

fn new_sums<M: Drivetrain>(model: &M, first: &[Value]) -> Vec<Sums> {
    first
        .iter()
        .enumerate()
        .map(|(m, v)| Sums {
            force_ref: v.force,
            dte_ref: v.dte,
            force: 0.0,
            force2: 0.0,
            dte: 0.0,
            dte2: 0.0,
            harmonics: [(0.0, 0.0); 3],
            lost_time: 0.0,
            pair_lost_time: vec![0.0; model.mesh_pair_slots(m)],
            separation: f64::NAN,
            lost: v.lost,
            candidates: Default::default(),
            poincare: Vec::new(),
        })
        .collect()
}

/// Each mesh's response from its sums and refined extremes (`[|force|, DTE, −DTE]`).
fn responses<M: Drivetrain>(
    model: &M,
    sums: &mut [Sums],
    extremes: &[[f64; EXTREMES]],
    duration: f64,
) -> Vec<MeshResponse> {
    let statics = model.static_mesh_forces();
    let mut out = Vec::with_capacity(sums.len());
    for (m, s) in sums.iter_mut().enumerate() {
        let extremes = extremes[m];
        let force_mean = s.force / duration;
        let dte_mean = s.dte / duration;
        let harmonic = |h: usize| {
            let (re, im) = s.harmonics[h];
            2.0 * re.hypot(im) / duration
        };
        out.push(MeshResponse {
            prefix: model.mesh_prefix(m),
            mesh_frequency: model.mesh_frequency(m),
            dte_mean: s.dte_ref + dte_mean,
            dte_rms: (s.dte2 / duration - dte_mean * dte_mean).max(0.0).sqrt(),
            dte_peak_to_peak: extremes[1] + extremes[2],
            harmonics: [harmonic(0), harmonic(1), harmonic(2)],
            contact_loss_fraction: s.lost_time / duration,
            pair_contact_loss_fractions: s.pair_lost_time.iter().map(|t| t / duration).collect(),
            separation_phase: s.separation,
            peak_force: extremes[0],
            force_rms: (s.force2 / duration - force_mean * force_mean)
                .max(0.0)
                .sqrt(),
            dynamic_factor: extremes[0] / statics[m].abs(),
            poincare: std::mem::take(&mut s.poincare),
        });
    }
    out
}

/// Each mesh's response over `duration` seconds from the run's current state, which the run
/// advances to its end. `duration` spans whole periods of the first mesh; with `poincare` the
/// DTE at the start of every period of the first mesh is kept. `settings` are the run's
/// solver settings (for the probe run of the RK path).
pub fn record<M: Drivetrain>(
    sim: &mut Driver<M>,
    settings: &SolverSettings,
    duration: f64,
    poincare: bool,
) -> Result<Vec<MeshResponse>, String> {
    let cells = cells(sim.model(), sim.t(), duration);
    if sim.observes_segments() {
        record_observed(sim, &cells, duration, poincare)
    } else {
        record_probed(sim, settings, &cells, duration, poincare)
    }
}

/// The observer of [`record_observed`] and [`RunStatistics`]: adds each segment of the run
/// as smooth pieces.
struct Recorder {
    sums: Vec<Sums>,
    frequencies: Vec<f64>,
    t0: f64,
    /// Each mesh's refined maxima of `[|force|, DTE, −DTE]` so far.
    peaks: Vec<[f64; EXTREMES]>,
    /// Longest piece: a segment longer than this is cut into equal pieces (a run whose
    /// advances are not cut at the cells' grid: [`RunStatistics`]); infinite where the
    /// advances already end at every cell boundary ([`record_observed`]).
    max_piece: f64,
    samples: Vec<(f64, Vec<Value>)>,
    y: Vec<f64>,
}

impl Recorder {
    fn new<M: Drivetrain>(sim: &Driver<M>, max_piece: f64) -> Recorder {
        let meshes = sim.model().mesh_count();
        Recorder {
            sums: new_sums(sim.model(), &values(sim, meshes)),
            frequencies: (0..meshes).map(|m| sim.model().mesh_frequency(m)).collect(),
            t0: sim.t(),
            peaks: vec![[f64::NEG_INFINITY; EXTREMES]; meshes],
            max_piece,
            samples: Vec::new(),
            y: vec![0.0; sim.y().len()],
        }
    }
}

/// A stretch of one mode whose state is known anywhere inside it: a segment of the exact
/// propagator, or an accepted RK step with its dense output.
trait Span {
    fn start(&self) -> f64;
    fn end(&self) -> f64;
    fn state(&mut self, t: f64, y: &mut [f64]);
    fn charge_evaluations(&mut self, count: usize);
}

impl Span for Segment<'_> {
    fn start(&self) -> f64 {
        Segment::start(self)
    }
    fn end(&self) -> f64 {
        Segment::end(self)
    }
    fn state(&mut self, t: f64, y: &mut [f64]) {
        Segment::state(self, t, y)
    }
    fn charge_evaluations(&mut self, count: usize) {
        Segment::charge_evaluations(self, count)
    }
}

impl Span for DenseStep<'_> {
    fn start(&self) -> f64 {
        DenseStep::start(self)
    }
    fn end(&self) -> f64 {
        DenseStep::end(self)
    }
    fn state(&mut self, t: f64, y: &mut [f64]) {
        DenseStep::state(self, t, y)
    }
    fn charge_evaluations(&mut self, count: usize) {
        DenseStep::charge_evaluations(self, count)
    }
}

impl<M: Drivetrain> SegmentObserver<M> for Recorder {
    fn segment(&mut self, model: &M, segment: &mut Segment) {
        self.observe(model, segment);
    }
}

impl<M: Drivetrain> StepObserver<M> for Recorder {
    fn step(&mut self, model: &M, step: &mut DenseStep) {
        self.observe(model, step);
    }
}

impl Recorder {
    /// Adds a segment or step as smooth pieces.
    fn observe<M: Drivetrain, P: Span>(&mut self, model: &M, segment: &mut P) {
        let (lo, hi) = (segment.start(), segment.end());
        if !(hi > lo) {
            return;
        }
        // Equal pieces no longer than `max_piece` (a margin keeps a segment of exactly that
        // length one piece).
        let pieces = ((hi - lo) / self.max_piece * (1.0 - 1e-12)).ceil().max(1.0);
        if pieces > 1.0 && pieces.is_finite() {
            let n = pieces as usize;
            let h = (hi - lo) / pieces;
            for p in 0..n {
                let a = lo + p as f64 * h;
                let b = if p + 1 == n {
                    hi
                } else {
                    lo + (p + 1) as f64 * h
                };
                self.piece(model, segment, a, b);
            }
        } else {
            self.piece(model, segment, lo, hi);
        }
    }

    /// Adds `[lo, hi]` of `segment` as one smooth piece.
    fn piece<M: Drivetrain, P: Span>(&mut self, model: &M, segment: &mut P, lo: f64, hi: f64) {
        let meshes = self.sums.len();
        // The piece's samples: its ends (the one-sided limits of the mode there) and the
        // Gauss nodes between.
        let (mid, half) = (0.5 * (lo + hi), 0.5 * (hi - lo));
        let times = std::iter::once(lo)
            .chain(GAUSS10.iter().map(|(x, _)| mid + half * x))
            .chain(std::iter::once(hi));
        let mut y = std::mem::take(&mut self.y);
        let mut samples = std::mem::take(&mut self.samples);
        samples.resize_with(GAUSS10.len() + 2, || (0.0, Vec::new()));
        for (t, sample) in times.zip(samples.iter_mut()) {
            segment.state(t, &mut y);
            sample.0 = t;
            sample.1.clear();
            sample.1.extend((0..meshes).map(|m| value(model, m, t, &y)));
        }
        // The run's work budget pays for the observation too (the series' terms and
        // evaluations are charged by the segment itself).
        segment.charge_evaluations(samples.len() * meshes);
        let piece = Piece {
            lo,
            hi,
            samples: &samples,
            nodes: 1..GAUSS10.len() + 1,
        };
        add_piece(&mut self.sums, &piece, 0, &self.frequencies, self.t0, model);
        for (m, s) in self.sums.iter_mut().enumerate() {
            for which in 0..EXTREMES {
                let c = s.candidates[which]
                    .pop()
                    .expect("add_piece adds one per quantity");
                // Every piece's maximum is refined: the series makes an evaluation cheap, and
                // a margin over the pieces seen so far would skip a piece whose maximum lies
                // between its samples before the spread of the stretch is known.
                let mut evaluations = 0;
                let mut g = |t: f64| {
                    evaluations += 1;
                    segment.state(t, &mut y);
                    quantity(&value(model, m, t, &y), which)
                };
                let peak = &mut self.peaks[m][which];
                *peak = peak.max(c.value).max(refine_candidate(&mut g, &c));
                segment.charge_evaluations(evaluations);
            }
        }
        self.y = y;
        self.samples = samples;
    }
}

fn value<M: Drivetrain>(model: &M, m: usize, t: f64, y: &[f64]) -> Value {
    let s = model.mesh_sample(m, t, y);
    Value {
        dte: s.dte,
        force: s.force,
        lost: s.lost,
        separated: s.separated_pairs,
    }
}

/// [`record`] on the exact propagator: the run advances cell by cell and its segments are
/// the smooth pieces.
fn record_observed<M: Drivetrain>(
    sim: &mut Driver<M>,
    cells: &Cells,
    duration: f64,
    poincare: bool,
) -> Result<Vec<MeshResponse>, String> {
    let meshes = sim.model().mesh_count();
    let mut recorder = Recorder::new(sim, f64::INFINITY);
    for &(b, _, cycle_end) in &cells.bounds[1..] {
        let observed = sim
            .advance_observed(b, &mut recorder)
            .map_err(|e| e.to_string())?;
        debug_assert!(
            observed,
            "record_observed on a run without observable segments"
        );
        if poincare && cycle_end {
            for (s, v) in recorder.sums.iter_mut().zip(values(sim, meshes)) {
                s.poincare.push(v.dte);
            }
        }
    }
    let extremes = std::mem::take(&mut recorder.peaks);
    Ok(responses(
        sim.model(),
        &mut recorder.sums,
        &extremes,
        duration,
    ))
}

/// Each mesh's response over a whole run, accumulated while the run advances to its output
/// times (issue 31: the `simulate` summary): the same observer as [`record_observed`], whose
/// segments end at the run's own stops and located events; a segment longer than
/// `h·ω_max ≤ 3` (or a quarter period of the fastest mesh) is cut into equal pieces, so the
/// 10-point Gauss rule and the refined extremes carry the accuracy of [`record`] whatever the
/// output interval. On the RK propagator the pieces are its accepted steps with their dense
/// output ([`crate::solve::rk::DenseStep`]): the events are the stepper's own located events,
/// and the values those of the RK solution (a polynomial of degree ≤ 7 in each step, which
/// the Gauss rule integrates exactly with its square), accurate to the integration
/// tolerance. Not with speed or torque profiles: [`RunStatistics::new`] is `None` there.
///
/// The observation's work (the series' terms, the dense and model evaluations) is charged to
/// the run's work budget like the propagator's own, so a run with statistics stops at its
/// budget too.
pub struct RunStatistics {
    recorder: Recorder,
}

impl RunStatistics {
    /// Statistics from the run's current state on, or `None` where the run is not
    /// observable (speed or torque profiles).
    pub fn new<M: Drivetrain>(sim: &Driver<M>) -> Option<RunStatistics> {
        if !sim.observes_steps() {
            return None;
        }
        let model = sim.model();
        let f_mesh = (0..model.mesh_count())
            .map(|m| model.mesh_frequency(m).abs())
            .fold(0.0, f64::max);
        let max_piece = (CELL_OMEGA / model.max_frequency())
            .min(1.0 / (MIN_CELLS as f64 * f_mesh))
            .min(f64::MAX);
        Some(RunStatistics {
            recorder: Recorder::new(sim, max_piece),
        })
    }

    /// Advances the run to `t`, adding its segments.
    pub fn advance<M: Drivetrain>(
        &mut self,
        sim: &mut Driver<M>,
        t: f64,
    ) -> Result<(), crate::solve::SolveError> {
        let observed = sim.advance_observed_steps(t, &mut self.recorder)?;
        debug_assert!(observed, "RunStatistics on a run that is not observable");
        Ok(())
    }

    /// Each mesh's response from the statistics' start to the run's current time.
    pub fn finish<M: Drivetrain>(mut self, sim: &Driver<M>) -> Vec<MeshResponse> {
        let duration = sim.t() - self.recorder.t0;
        // The harmonics were integrated with each mesh's first DTE taken out (a line far below
        // the mean would otherwise carry the rounding of the mean's integral); over a run that
        // is not a whole number of mesh periods the constant has lines of its own:
        // `d_ref ∫₀ᴰ e^{−iωτ} dτ = d_ref (sin ωD, cos ωD − 1)/ω`.
        for (s, &f) in self
            .recorder
            .sums
            .iter_mut()
            .zip(&self.recorder.frequencies)
        {
            for (h, acc) in s.harmonics.iter_mut().enumerate() {
                let omega = TAU * (h + 1) as f64 * f;
                if omega != 0.0 {
                    let (sn, cs) = (omega * duration).sin_cos();
                    acc.0 += s.dte_ref * sn / omega;
                    acc.1 += s.dte_ref * (cs - 1.0) / omega;
                }
            }
        }
        let extremes = std::mem::take(&mut self.recorder.peaks);
        responses(sim.model(), &mut self.recorder.sums, &extremes, duration)
    }
}

/// [`record`] by a probe run restarted at a cell's start (the RK propagator, profiles).
fn record_probed<M: Drivetrain>(
    sim: &mut Driver<M>,
    settings: &SolverSettings,
    cells: &Cells,
    duration: f64,
    poincare: bool,
) -> Result<Vec<MeshResponse>, String> {
    let model = sim.model().clone();
    let meshes = model.mesh_count();
    let t0 = sim.t();
    let bounds = &cells.bounds;
    let inset = ONE_SIDED * cells.h;
    let mut probe = Driver::with_model(model.clone(), sim.y(), settings)?;
    let mut sums = new_sums(&model, &values(sim, meshes));
    let frequencies: Vec<f64> = (0..meshes).map(|m| model.mesh_frequency(m)).collect();
    let mut starts: Vec<Start<M::RunState>> = Vec::with_capacity(bounds.len());
    // A located event can land the propagator a few rounding units past a sample time that
    // the event search put just before it; that sample is then taken where the state is.
    let advance =
        |sim: &mut Driver<M>, t: f64| sim.advance_to(t.max(sim.t())).map_err(|e| e.to_string());
    for c in 0..bounds.len() - 1 {
        let ((a, jump_a, _), (b, jump_b, cycle_end)) = (bounds[c], bounds[c + 1]);
        share_budget(&mut probe, sim)?;
        starts.push(Start {
            t: sim.t(),
            y: sim.y().to_vec(),
            run: sim.model().run_state(),
        });
        let events_before = sim.stats().events;
        let (times, nodes) = piece_times(a, b, jump_a, jump_b, inset);
        let mut samples = Vec::with_capacity(times.len());
        for &t in &times {
            advance(sim, t)?;
            samples.push((t, values(sim, meshes)));
        }
        advance(sim, b)?;
        let events = sim.stats().events - events_before;
        if events == 0 {
            let piece = Piece {
                lo: a,
                hi: b,
                samples: &samples,
                nodes,
            };
            add_piece(&mut sums, &piece, c, &frequencies, t0, &model);
        } else {
            let found = locate_events(&mut probe, &starts[c], b, events)?;
            let mut ends = vec![a];
            ends.extend(found);
            ends.push(b);
            // Every piece's samples, in one pass of the probe from the cell's start.
            let mut all = Vec::new();
            let mut spans = Vec::new();
            for i in 0..ends.len() - 1 {
                let (lo, hi) = (ends[i], ends[i + 1]);
                let (times, nodes) =
                    piece_times(lo, hi, jump_a || i > 0, jump_b || i + 2 < ends.len(), inset);
                let base = all.len();
                all.extend(times);
                spans.push((lo, hi, base, nodes.start + base..nodes.end + base));
            }
            let start = &starts[c];
            probe.restart(start.t, &start.y, &start.run)?;
            let mut samples = Vec::with_capacity(all.len());
            for &t in &all {
                advance(&mut probe, t)?;
                samples.push((t, values(&probe, meshes)));
            }
            for (i, (lo, hi, base, nodes)) in spans.iter().enumerate() {
                let end = spans.get(i + 1).map_or(samples.len(), |s| s.2);
                let piece = Piece {
                    lo: *lo,
                    hi: *hi,
                    samples: &samples[*base..end],
                    nodes: nodes.start - base..nodes.end - base,
                };
                add_piece(&mut sums, &piece, c, &frequencies, t0, &model);
            }
        }
        if poincare && cycle_end {
            for (s, v) in sums.iter_mut().zip(values(sim, meshes)) {
                s.poincare.push(v.dte);
            }
        }
    }
    share_budget(&mut probe, sim)?;
    let mut extremes = Vec::with_capacity(meshes);
    for s in &sums {
        let mut e = [0.0; EXTREMES];
        for (which, extreme) in e.iter_mut().enumerate() {
            *extreme = refine(
                &mut probe,
                &starts,
                &s.candidates[which],
                extremes.len(),
                which,
            )?;
        }
        extremes.push(e);
    }
    Ok(responses(&model, &mut sums, &extremes, duration))
}

/// Bounds the probe run by what the run's work budget has left: the run and its probe share
/// one budget (the probe's work since its start and the run's in its scope stay within the
/// run's limit), so a recording cannot run unbounded on the probe's side either.
fn share_budget<M: Drivetrain>(probe: &mut Driver<M>, sim: &Driver<M>) -> Result<(), String> {
    match sim.work_limit() {
        Some(limit) => probe.set_work_budget((limit - sim.work_spent()).max(1.0)),
        None => Ok(()),
    }
}

/// Adds a smooth piece of cell `cell` to every mesh's sums and candidates.
fn add_piece<M: Drivetrain>(
    sums: &mut [Sums],
    piece: &Piece,
    cell: usize,
    frequencies: &[f64],
    t0: f64,
    model: &M,
) {
    let half = 0.5 * (piece.hi - piece.lo);
    for (m, s) in sums.iter_mut().enumerate() {
        for (k, (_, weight)) in GAUSS10.iter().enumerate() {
            let (t, v) = &piece.samples[piece.nodes.start + k];
            let w = weight * half;
            let (f, d) = (v[m].force - s.force_ref, v[m].dte - s.dte_ref);
            s.force += w * f;
            s.force2 += w * f * f;
            s.dte += w * d;
            s.dte2 += w * d * d;
            // `e^{i2πh f_m (t − t0)}`, h = 1, 2, 3, as powers of the first.
            let (sn, cs) = (TAU * frequencies[m] * (t - t0)).sin_cos();
            let (mut c, mut sh) = (cs, sn);
            for acc in s.harmonics.iter_mut() {
                acc.0 += w * d * c;
                acc.1 -= w * d * sh;
                (c, sh) = (c * cs - sh * sn, c * sn + sh * cs);
            }
        }
        // The contact state is constant on the piece: read it at its middle node.
        let middle = &piece.samples[piece.nodes.start + GAUSS10.len() / 2].1[m];
        let lost = middle.lost;
        for (j, time) in s.pair_lost_time.iter_mut().enumerate() {
            if middle.separated >> j & 1 == 1 {
                *time += piece.hi - piece.lo;
            }
        }
        if lost {
            s.lost_time += piece.hi - piece.lo;
            if !s.lost && s.separation.is_nan() {
                s.separation = model.mesh_phase(m, piece.lo).rem_euclid(1.0);
            }
        }
        s.lost = lost;
        let n = piece.samples.len();
        for which in 0..EXTREMES {
            let (best, at) = (0..n)
                .map(|i| (quantity(&piece.samples[i].1[m], which), i))
                .fold((f64::NEG_INFINITY, 0), |a, b| if b.0 > a.0 { b } else { a });
            // The bracket reaches a piece's end only where the solution is smooth across it;
            // where it switches, the one-sided sample is the bracket's end.
            let lo = match at {
                0 if piece.nodes.start == 0 => piece.lo,
                0 => piece.samples[0].0,
                _ => piece.samples[at - 1].0,
            };
            let hi = if at + 1 < n {
                piece.samples[at + 1].0
            } else if piece.nodes.end == n {
                piece.hi
            } else {
                piece.samples[n - 1].0
            };
            let sample = |i: usize| quantity(&piece.samples[i].1[m], which);
            s.candidates[which].push(Candidate {
                value: best,
                at: piece.samples[at].0,
                below: (lo == piece.samples[at.max(1) - 1].0 && at > 0).then(|| sample(at - 1)),
                above: (at + 1 < n).then(|| sample(at + 1)),
                lo,
                hi,
                cell,
            });
        }
    }
}

/// The refined maximum of extreme `which` of mesh `m` over its candidates.
fn refine<M: Drivetrain>(
    probe: &mut Driver<M>,
    starts: &[Start<M::RunState>],
    candidates: &[Candidate],
    m: usize,
    which: usize,
) -> Result<f64, String> {
    let best = candidates
        .iter()
        .map(|c| c.value)
        .fold(f64::NEG_INFINITY, f64::max);
    let worst = candidates.iter().map(|c| c.value).fold(best, f64::min);
    let margin = REFINE_MARGIN * (best - worst).max(1e-300);
    let mut result = best;
    for c in candidates.iter().filter(|c| c.value >= best - margin) {
        let start = &starts[c.cell];
        let mut failure = None;
        let mut g = |t: f64| -> f64 {
            let run = probe
                .restart(start.t, &start.y, &start.run)
                .and_then(|_| probe.advance_to(t).map_err(|e| e.to_string()));
            match run {
                Ok(()) => {
                    let s = probe.model().mesh_sample(m, probe.t(), probe.y());
                    quantity(
                        &Value {
                            dte: s.dte,
                            force: s.force,
                            lost: s.lost,
                            separated: s.separated_pairs,
                        },
                        which,
                    )
                }
                Err(e) => {
                    failure = Some(e);
                    f64::NEG_INFINITY
                }
            }
        };
        let v = refine_candidate(&mut g, c);
        if let Some(e) = failure {
            return Err(e);
        }
        result = result.max(v);
    }
    Ok(result)
}

/// The maximum of `g` around candidate `c`: parabolic steps from its samples, else Brent.
///
/// A best sample at the end of its bracket (a piece's end, where the solution switches) is
/// the maximum when `g` does not rise into the bracket from it: one evaluation a tolerance
/// inside tells, where Brent would spend ~40 on converging to the end. If `g` does rise, that
/// evaluation is the middle of three points around an inner maximum, refined by parabolas.
fn refine_candidate(g: &mut dyn FnMut(f64) -> f64, c: &Candidate) -> f64 {
    let tol = (PEAK_TOL * (c.hi - c.lo)).max(8.0 * f64::EPSILON * c.hi.abs());
    let end = |g: &mut dyn FnMut(f64) -> f64, inside: f64, far: (f64, f64)| {
        let v = g(inside);
        if v <= c.value {
            return Some(c.value);
        }
        let mut points = [(c.at, c.value), (inside, v), far];
        points.sort_by(|a, b| a.0.total_cmp(&b.0));
        parabolic_maximum(g, points, tol).map(|p| p.max(v))
    };
    match (c.below, c.above) {
        (Some(fl), Some(fh)) => {
            parabolic_maximum(g, [(c.lo, fl), (c.at, c.value), (c.hi, fh)], tol)
        }
        (None, Some(fh)) if c.at == c.lo && c.hi - c.lo > 2.0 * tol => {
            end(g, c.lo + tol, (c.hi, fh))
        }
        (Some(fl), None) if c.at == c.hi && c.hi - c.lo > 2.0 * tol => {
            end(g, c.hi - tol, (c.lo, fl))
        }
        _ => None,
    }
    .unwrap_or_else(|| brent_maximum(g, c.lo, c.hi, tol).1)
}

/// Successive parabolic interpolation from three samples `lo < at < hi` with the largest value
/// at `at` (the samples are already known, so a smooth maximum needs a few evaluations, not
/// Brent's fresh start): the vertex of the parabola through the three best points bracketing
/// the maximum, until it moves by less than `tol` or would raise the value by less than a
/// rounding unit (`g` is analytic on a piece: the parabola then tells the value's remaining
/// gain). `None` when a step leaves the bracket or does not settle within
/// [`PARABOLIC_STEPS`] (the caller falls back to Brent).
fn parabolic_maximum(
    g: &mut dyn FnMut(f64) -> f64,
    points: [(f64, f64); 3],
    tol: f64,
) -> Option<f64> {
    let [mut a, mut b, mut c] = points;
    for _ in 0..PARABOLIC_STEPS {
        let (p, q) = (b.0 - a.0, b.0 - c.0);
        let (r, t) = (b.1 - c.1, b.1 - a.1);
        let den = p * r - q * t;
        if den == 0.0 || !den.is_finite() {
            return None;
        }
        let x = b.0 - 0.5 * (p * p * r - q * q * t) / den;
        if !(x > a.0 && x < c.0) {
            return None;
        }
        // Settled when the step is below `tol`, or when the parabola's vertex lies less than a
        // rounding unit of the value above the best point (`−A d²`, `A` the second divided
        // difference): further steps would chase rounding, not the maximum.
        let curvature = (r / q - t / p) / (c.0 - a.0);
        let gain = -curvature * (x - b.0) * (x - b.0);
        if (x - b.0).abs() <= tol || gain <= f64::EPSILON * b.1.abs() {
            return Some(b.1.max(g(x)));
        }
        let fx = g(x);
        if fx >= b.1 {
            if x < b.0 {
                c = b;
            } else {
                a = b;
            }
            b = (x, fx);
        } else if x < b.0 {
            a = (x, fx);
        } else {
            c = (x, fx);
        }
    }
    None
}

/// Most steps of [`parabolic_maximum`].
const PARABOLIC_STEPS: usize = 12;

/// The times of the `count` state events the run met between `start` and `b`, located with
/// the probe: each bracketed by the probe's event count, then refined by Brent's method on the
/// guard that crossed (in the mode before it).
fn locate_events<M: Drivetrain>(
    probe: &mut Driver<M>,
    start: &Start<M::RunState>,
    b: f64,
    count: u64,
) -> Result<Vec<f64>, String> {
    let a = start.t;
    // Evaluations restart from `base`, the latest state known before the next event (the
    // cell's start, then the lower end of the last bracket), and count the events after it.
    let capture = |probe: &Driver<M>| Start {
        t: probe.t(),
        y: probe.y().to_vec(),
        run: probe.model().run_state(),
    };
    let run_to =
        |probe: &mut Driver<M>, base: &Start<M::RunState>, t: f64| -> Result<u64, String> {
            probe.restart(base.t, &base.y, &base.run)?;
            let before = probe.stats().events;
            probe.advance_to(t.max(base.t)).map_err(|e| e.to_string())?;
            Ok(probe.stats().events - before)
        };
    // Not below a few rounding units of the time itself (a sweep's clock runs on).
    let tol = (EVENT_TOL * (b - a)).max(8.0 * f64::EPSILON * b.abs());
    let mut times = Vec::with_capacity(count as usize);
    probe.restart(start.t, &start.y, &start.run)?;
    let mut base = capture(probe);
    for _ in 0..count {
        let mut lo = base.t;
        let mut hi = b;
        // Bracket the next event to 1/64 of the cell by the event count.
        while hi - lo > (b - a) / 64.0 {
            let mid = 0.5 * (lo + hi);
            if run_to(probe, &base, mid)? >= 1 {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        // The guards of the mode at `lo`: the one that crossed is negative at `hi`.
        run_to(probe, &base, lo)?;
        base = capture(probe);
        let before = probe.model().clone();
        let guards = before.guard_count();
        let mut g_lo = vec![0.0; guards];
        before.guards(lo, probe.y(), &mut g_lo);
        let mut g = vec![0.0; guards];
        run_to(probe, &base, hi)?;
        before.guards(hi, probe.y(), &mut g);
        let crossed: Vec<usize> = (0..guards)
            .filter(|&i| g_lo[i] >= 0.0 && g[i] < 0.0)
            .collect();
        let mut event = f64::INFINITY;
        let mut failure = None;
        let mut scratch = vec![0.0; guards];
        for &i in &crossed {
            let mut guard = |t: f64| -> f64 {
                match run_to(probe, &base, t) {
                    Ok(_) => {
                        before.guards(t, probe.y(), &mut scratch);
                        scratch[i]
                    }
                    Err(e) => {
                        failure = Some(e);
                        0.0
                    }
                }
            };
            let (_, after) = brent_bracket(&mut guard, lo, hi, g_lo[i], g[i], tol);
            event = event.min(after);
        }
        if let Some(e) = failure {
            return Err(e);
        }
        if crossed.is_empty() {
            // No guard of the mode before it stays crossed (the mode's guards do not
            // describe the switch): bisect the count to the tolerance instead.
            while hi - lo > tol {
                let mid = 0.5 * (lo + hi);
                if mid <= lo || mid >= hi {
                    break;
                }
                if run_to(probe, &base, mid)? >= 1 {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            event = hi;
        }
        times.push(event);
        // The next search starts after this event.
        if run_to(probe, &base, event)? == 0 {
            // The located time fell a rounding before the run's own event time.
            run_to(probe, &base, event + tol)?;
        }
        base = capture(probe);
    }
    Ok(times)
}

/// Each mesh's response along a periodic orbit of `scene` (the scene at the orbit's speed),
/// from `orbit.y0` at `t = 0` over one orbit period.
pub fn orbit_responses(
    scene: &crate::scene::Scene,
    orbit: &super::shooting::PeriodicOrbit,
) -> Result<Vec<MeshResponse>, String> {
    crate::with_drivetrain!(scene.simulation()?, sim => {
        let mut sim = sim;
        let period = crate::model::response_period(sim.model())? * f64::from(orbit.periods);
        sim.set_y(0.0, &orbit.y0);
        record(&mut sim, &scene.solver, period, false)
            .map_err(|e| format!("periodic orbit: {e}"))
    })
}
