//! Alias-free lines of a periodic orbit (issue 31 item 2): the Fourier coefficients
//! `c_k = (1/T) ∫₀ᵀ x(t) e^{−iω_k t} dt`, `ω_k = 2πk/T`, of each output column, integrated
//! over each segment of the run rather than taken from samples (`docs/spectrum.md`).
//!
//! The exact propagator hands each segment `[t_s, t_e]` of one mode with its lifted start and
//! end states and the mode's balanced matrix `B = D⁻¹AD` ([`Driver::advance_observed`],
//! [`crate::solve::exact::segment_series`]). Inside it `u(t) = D⁻¹z(t) = e^{B(t−t_s)} u_s`, so
//! `d/dt [e^{−iωt} u] = e^{−iωt} (B − iωI) u` and
//!
//! `∫_{t_s}^{t_e} e^{−iωt} u(t) dt = (B − iωI)⁻¹ (e^{−iωt_e} u_e − e^{−iωt_s} u_s)`:
//!
//! an output column that is linear in the lifted state in this mode, `x = w·z = (w∘D)·u`
//! ([`Drivetrain::lifted_output_row`]; the forcing states, STE harmonics, ramps and the
//! constant, are part of `z`, so the particular response is included), has the line
//! `(w∘D)·(B − iω_kI)⁻¹ Σ_segments (e^{−iω_k t_e} u_e − e^{−iω_k t_s} u_s)`, the sum taken per
//! mode, and one solve per mode and line. This is exact (to rounding) whatever the number of
//! lines, and costs `segments × lines × n_z` for the sums plus `modes × lines × n_z³/3`.
//!
//! Where `iω_k` is (within `1/T`) an eigenvalue of a mode's matrix, `B − iω_kI` is singular or
//! nearly so: line 0 always (the constant state), and e.g. the STE harmonics' lines. Those
//! lines, on that mode's segments, and every line of a column without a lifted row, are
//! integrated by quadrature instead: each segment is cut into pieces with `h·(ω_max + ω) ≤ 3`
//! (`ω_max` the fastest mode, `ω` the highest line integrated so) and each piece is
//! integrated by the 10-point Gauss–Legendre rule on the state from the segment's series,
//! whose error on `e^{iωt}` at `h·ω ≤ 3` is below 1e-14 of the integrand (the bound in
//! [`crate::analysis::orbit_statistics`]). A segment ends at every stop and contact event, so
//! a force that jumps there (contact loss) folds nothing back from above the highest line.

use std::f64::consts::TAU;

use nalgebra::{Complex, DMatrix};

use super::dft::Spectrum;
use super::window::Window;
use crate::model::Drivetrain;
use crate::simulation::Driver;
use crate::solve::exact::segment_series::{Segment, SegmentObserver};
use crate::solve::exact::ModeKey;

/// 10-point Gauss–Legendre rule on [−1, 1] (Abramowitz & Stegun, Table 25.4), half of it: the
/// nodes `±x` share a weight.
const GAUSS10_HALF: [(f64, f64); 5] = [
    (0.148_874_338_981_631_2, 0.295_524_224_714_752_9),
    (0.433_395_394_129_247_2, 0.269_266_719_309_996_4),
    (0.679_409_568_299_024_4, 0.219_086_362_515_982),
    (0.865_063_366_688_984_5, 0.149_451_349_150_580_6),
    (0.973_906_528_517_171_7, 0.066_671_344_308_688_1),
];

/// Largest `h·ω` of one quadrature piece.
const PIECE_OMEGA: f64 = 3.0;

/// Most node-line products of the quadrature of columns without a lifted row (about 0.2 s).
const MAX_PRODUCTS: f64 = 2e8;

/// Most complex multiply-adds of the closed form (the per-segment sums and the per-mode
/// solves; about 2–4 s), beyond which the lines are integrated by quadrature if that stays
/// within [`MAX_PRODUCTS`], else sampled by the caller.
const MAX_CLOSED_WORK: f64 = 1e9;

/// Most bytes of the per-mode sums of the closed form.
const MAX_CLOSED_BYTES: f64 = 1.0e9;

/// A line is integrated by quadrature on a mode's segments where `|λ − iω_k|·T` is below
/// this for an eigenvalue `λ` of the mode: there `(B − iω_kI)⁻¹` would amplify the rounding
/// of the boundary terms by `1/(|λ − iω_k| h)` (the lines are `2π/T` apart, so at most one
/// line per eigenvalue).
const RESONANCE: f64 = 1.0;

/// Relative mismatch between a lifted row and the model's output at a segment's ends beyond
/// which the rows are not trusted (the closed form is then given up for quadrature).
const ROW_CHECK: f64 = 1e-9;

/// One mode's part of the closed form.
struct ModeLines {
    key: ModeKey,
    /// `B = Q H Qᵀ` with `H` upper Hessenberg and `Q` orthogonal (reduced once per mode), so
    /// each line's system `(H − iωI) y = Qᵀ b` costs `n_z²`.
    h: DMatrix<f64>,
    q: DMatrix<f64>,
    /// Per closed column, `Qᵀ(w∘D)`: its row over the balanced state in `Q`'s coordinates.
    rows: Vec<Vec<f64>>,
    /// Per closed column, `w`: its row over `z` (checked against the model's outputs).
    plain_rows: Vec<Vec<f64>>,
    /// Lines integrated by quadrature on this mode's segments (line 0 always).
    resonant: Vec<bool>,
    resonant_lines: Vec<usize>,
    /// `Σ (e^{−iω_k (t_e − t₀)} u_e − e^{−iω_k (t_s − t₀)} u_s)` over the mode's segments,
    /// `[k·n_z + i]`.
    sums: Vec<Complex<f64>>,
}

struct Integrator<'a> {
    columns: &'a [usize],
    /// Whether column `c` is in closed form (it has a lifted row in every mode).
    closed: Vec<bool>,
    t0: f64,
    duration: f64,
    lines: usize,
    /// The fastest mode's angular frequency bound, rad/s.
    omega_max: f64,
    /// `∫ x e^{−iω_k (t − t0)} dt` per column and line, `[c·(lines+1) + k]`.
    sums: Vec<(f64, f64)>,
    /// Each column's value at the first node, taken out of the quadrature's integrand: a line
    /// far below the mean (a DTE's harmonics beside its static deflection) would otherwise
    /// carry the rounding of the mean's integral (added back to line 0). For closed columns
    /// only line 0 (integrated by quadrature on every segment) uses it.
    reference: Vec<f64>,
    modes: Vec<ModeLines>,
    key: ModeKey,
    /// Why the closed form was given up (the caller then integrates by quadrature).
    failure: Option<String>,
    /// Per column, the largest `|w_i z_i|` or output met so far (the scale of the row check).
    check_scale: Vec<f64>,
    /// Complex multiply-adds of the closed form so far and bytes of its sums.
    work: f64,
    bytes: f64,
    y: Vec<f64>,
    row: Vec<f64>,
    u_start: Vec<f64>,
    u_end: Vec<f64>,
}

impl Integrator<'_> {
    /// Adds `weight ·` the columns at `t` to the quadrature sums: for closed columns the lines
    /// `resonant`, for the others every line.
    fn node<M: Drivetrain>(
        &mut self,
        model: &M,
        segment: &mut Segment,
        t: f64,
        weight: f64,
        resonant: &[usize],
    ) {
        segment.state(t, &mut self.y);
        model.output_row(t, &self.y, &mut self.row);
        let theta = TAU * (t - self.t0) / self.duration;
        // e^{−ikθ} by rotation, renormalised every few lines so rounding does not build up.
        let (s1, c1) = (-theta).sin_cos();
        let stride = self.lines + 1;
        if self.reference.is_empty() {
            self.reference = self.columns.iter().map(|&col| self.row[col]).collect();
        }
        for (c, &col) in self.columns.iter().enumerate() {
            let sums = &mut self.sums[c * stride..(c + 1) * stride];
            if self.closed[c] {
                let value = self.row[col];
                for &k in resonant {
                    if k == 0 {
                        sums[0].0 += weight * (value - self.reference[c]);
                    } else {
                        let (s, co) = (-(k as f64) * theta).sin_cos();
                        sums[k].0 += weight * value * co;
                        sums[k].1 += weight * value * s;
                    }
                }
                continue;
            }
            let x = weight * (self.row[col] - self.reference[c]);
            let (mut re, mut im) = (1.0, 0.0);
            for (k, acc) in sums.iter_mut().enumerate() {
                if k % 32 == 0 && k > 0 {
                    let (s, c) = (-(k as f64) * theta).sin_cos();
                    (re, im) = (c, s);
                }
                acc.0 += x * re;
                acc.1 += x * im;
                (re, im) = (re * c1 - im * s1, re * s1 + im * c1);
            }
        }
    }

    /// The closed form's data of the model's current mode (built at its first segment), or
    /// why it cannot be.
    fn mode_index<M: Drivetrain>(&mut self, model: &M, segment: &Segment) -> Result<usize, String> {
        self.key.clear();
        model.mode_key(&mut self.key);
        if let Some(i) = self.modes.iter().position(|m| m.key == self.key) {
            return Ok(i);
        }
        let b = segment.balanced_matrix().clone();
        let nz = b.nrows();
        let scale = segment.balance();
        let mut rows = Vec::new();
        let mut plain_rows = Vec::new();
        for (c, &col) in self.columns.iter().enumerate() {
            if !self.closed[c] {
                continue;
            }
            let mut w = vec![0.0; nz];
            if !model.lifted_output_row(col, &mut w) {
                return Err(format!(
                    "output column {col} has no lifted row in a later mode"
                ));
            }
            rows.push(
                w.iter()
                    .zip(scale)
                    .map(|(w, d)| w * d)
                    .collect::<Vec<f64>>(),
            );
            plain_rows.push(w);
        }
        let (q, h) = nalgebra::linalg::Hessenberg::new(b.clone()).unpack();
        let rows = (rows.iter())
            .map(|r| {
                (0..nz)
                    .map(|j| (0..nz).map(|i| q[(i, j)] * r[i]).sum())
                    .collect()
            })
            .collect();
        let schur = nalgebra::linalg::Schur::try_new(b.clone(), f64::EPSILON, 100_000)
            .ok_or("the eigenvalues of a mode matrix did not converge")?;
        let mut resonant = vec![false; self.lines + 1];
        resonant[0] = true;
        let spacing = TAU / self.duration;
        for lambda in schur.complex_eigenvalues().iter() {
            if !(lambda.re.is_finite() && lambda.im.is_finite()) {
                return Err("a mode matrix has non-finite eigenvalues".into());
            }
            // The nearest line to the eigenvalue's frequency.
            let k = (lambda.im / spacing).round();
            if k < 0.0 || k > self.lines as f64 {
                continue;
            }
            let distance = lambda.re.hypot(lambda.im - k * spacing);
            if distance * self.duration < RESONANCE {
                resonant[k as usize] = true;
            }
        }
        let resonant_lines = (0..=self.lines).filter(|&k| resonant[k]).collect();
        let entries = (self.lines + 1) * nz;
        self.bytes += 16.0 * entries as f64;
        if self.bytes > MAX_CLOSED_BYTES {
            return Err(format!(
                "the closed form's sums would take {:e} bytes",
                self.bytes
            ));
        }
        // The solves of this mode's lines at the end.
        self.work += (self.lines + 1) as f64 * (2 * nz * nz) as f64;
        self.modes.push(ModeLines {
            key: self.key.clone(),
            h,
            q,
            rows,
            plain_rows,
            resonant,
            resonant_lines,
            sums: vec![Complex::new(0.0, 0.0); entries],
        });
        Ok(self.modes.len() - 1)
    }

    /// The closed form's boundary terms of one segment; `Err` where its rows do not give the
    /// model's outputs at the segment's ends.
    fn closed_segment<M: Drivetrain>(
        &mut self,
        model: &M,
        segment: &Segment,
        index: usize,
    ) -> Result<(), String> {
        let (z_start, z_end) = (segment.start_state(), segment.end_state());
        let n = self.y.len();
        let mode = &mut self.modes[index];
        for (t, z) in [(segment.start(), z_start), (segment.end(), z_end)] {
            model.output_row(t, &z[..n], &mut self.row);
            let mut closed = 0;
            for (c, &col) in self.columns.iter().enumerate() {
                if !self.closed[c] {
                    continue;
                }
                let w = &mode.plain_rows[closed];
                closed += 1;
                let (value, size) = w
                    .iter()
                    .zip(z)
                    .fold((0.0, 0.0), |(v, s), (w, z)| (v + w * z, s + (w * z).abs()));
                let out = self.row[col];
                // Against the column's largest magnitude so far: a row whose terms cancel
                // (a separated mesh's force) leaves rounding of that size, not of its own.
                let scale = &mut self.check_scale[c];
                *scale = scale.max(size).max(out.abs());
                if !((value - out).abs() <= ROW_CHECK * *scale) {
                    return Err(format!(
                        "the lifted row of output column {col} gives {value:e}, the model \
                         {out:e} at t = {t:e} s"
                    ));
                }
            }
        }
        let nz = z_start.len();
        let scale = segment.balance();
        for i in 0..nz {
            self.u_start[i] = z_start[i] / scale[i];
            self.u_end[i] = z_end[i] / scale[i];
        }
        let theta_start = TAU * (segment.start() - self.t0) / self.duration;
        let theta_end = TAU * (segment.end() - self.t0) / self.duration;
        let (s1, c1) = (-theta_start).sin_cos();
        let (s2, c2) = (-theta_end).sin_cos();
        let (step_start, step_end) = (Complex::new(c1, s1), Complex::new(c2, s2));
        let (mut e_start, mut e_end) = (Complex::new(1.0, 0.0), Complex::new(1.0, 0.0));
        for k in 0..=self.lines {
            if k % 32 == 0 && k > 0 {
                let (s, c) = (-(k as f64) * theta_start).sin_cos();
                e_start = Complex::new(c, s);
                let (s, c) = (-(k as f64) * theta_end).sin_cos();
                e_end = Complex::new(c, s);
            }
            if !mode.resonant[k] {
                let sums = &mut mode.sums[k * nz..(k + 1) * nz];
                for ((acc, &us), &ue) in sums.iter_mut().zip(&self.u_start).zip(&self.u_end) {
                    *acc += e_end * ue - e_start * us;
                }
            }
            e_start *= step_start;
            e_end *= step_end;
        }
        self.work += ((self.lines + 1) * nz) as f64;
        if self.work > MAX_CLOSED_WORK {
            return Err(format!(
                "the closed form would take {:e} operations",
                self.work
            ));
        }
        Ok(())
    }

    /// Adds the closed form's lines (every mode's non-resonant lines) to the sums.
    fn solve_modes(&mut self) -> Result<(), String> {
        let stride = self.lines + 1;
        let closed: Vec<usize> = (0..self.columns.len())
            .filter(|&c| self.closed[c])
            .collect();
        let mut m = Vec::new();
        let mut x = Vec::new();
        for mode in &self.modes {
            let nz = mode.h.nrows();
            for k in 0..=self.lines {
                if mode.resonant[k] {
                    continue;
                }
                let omega = TAU * k as f64 / self.duration;
                m.clear();
                m.extend(mode.h.iter().map(|&v| Complex::new(v, 0.0)));
                for i in 0..nz {
                    m[i * nz + i] -= Complex::new(0.0, omega);
                }
                // Qᵀ times the mode's boundary sum.
                let sums = &mode.sums[k * nz..(k + 1) * nz];
                x.clear();
                x.extend((0..nz).map(|j| {
                    (0..nz).fold(Complex::new(0.0, 0.0), |s, i| s + sums[i] * mode.q[(i, j)])
                }));
                solve_hessenberg(&mut m, nz, &mut x)?;
                for (r, &c) in closed.iter().enumerate() {
                    let line: Complex<f64> = (mode.rows[r].iter().zip(&x))
                        .fold(Complex::new(0.0, 0.0), |s, (w, x)| s + x * *w);
                    let acc = &mut self.sums[c * stride + k];
                    acc.0 += line.re;
                    acc.1 += line.im;
                }
            }
        }
        Ok(())
    }
}

/// Solves `M x = b` in place for an upper Hessenberg `M` (`m` column-major, `n × n`,
/// overwritten) by Gaussian elimination with partial pivoting, which has only the one
/// subdiagonal entry of each column to eliminate (`n²` operations); `Err` where a pivot
/// vanishes against the matrix's size.
fn solve_hessenberg(
    m: &mut [Complex<f64>],
    n: usize,
    b: &mut [Complex<f64>],
) -> Result<(), String> {
    let size = m.iter().map(|v| v.norm()).fold(0.0, f64::max);
    let at = |i: usize, j: usize| j * n + i;
    for col in 0..n {
        if col + 1 < n && m[at(col + 1, col)].norm() > m[at(col, col)].norm() {
            for j in col..n {
                m.swap(at(col + 1, j), at(col, j));
            }
            b.swap(col + 1, col);
        }
        let p = m[at(col, col)];
        if !(p.norm() > 1e-14 * size) {
            return Err("a line's system B − iωI is singular".into());
        }
        if col + 1 < n {
            let f = m[at(col + 1, col)] / p;
            if f != Complex::new(0.0, 0.0) {
                for j in col + 1..n {
                    let v = m[at(col, j)];
                    m[at(col + 1, j)] -= f * v;
                }
                let v = b[col];
                b[col + 1] -= f * v;
            }
        }
    }
    for i in (0..n).rev() {
        let mut s = b[i];
        for j in i + 1..n {
            s -= m[at(i, j)] * b[j];
        }
        b[i] = s / m[at(i, i)];
    }
    Ok(())
}

impl<M: Drivetrain> SegmentObserver<M> for Integrator<'_> {
    fn segment(&mut self, model: &M, segment: &mut Segment) {
        let (lo, hi) = (segment.start(), segment.end());
        if !(hi > lo) {
            return;
        }
        // The lines this segment integrates by quadrature for the closed columns.
        let mut resonant = Vec::new();
        if self.closed.iter().any(|&c| c) && self.failure.is_none() {
            let seen: &Segment = segment;
            let done = match self.mode_index(model, seen) {
                Ok(index) => self.closed_segment(model, seen, index).map(|()| index),
                Err(e) => Err(e),
            };
            match done {
                Ok(index) => resonant.clone_from(&self.modes[index].resonant_lines),
                Err(e) => self.failure = Some(e),
            }
        }
        if self.failure.is_some() {
            return;
        }
        let all_closed = self.closed.iter().all(|&c| c);
        if all_closed && resonant.is_empty() {
            return;
        }
        let top = if all_closed {
            resonant.last().copied().unwrap_or(0)
        } else {
            self.lines
        };
        let omega = self.omega_max + TAU * top as f64 / self.duration;
        let pieces = ((hi - lo) * omega / PIECE_OMEGA).ceil().max(1.0) as usize;
        let h = (hi - lo) / pieces as f64;
        for p in 0..pieces {
            let a = lo + p as f64 * h;
            let b = if p + 1 == pieces { hi } else { a + h };
            let (mid, half) = (0.5 * (a + b), 0.5 * (b - a));
            for &(x, w) in &GAUSS10_HALF {
                self.node(model, segment, mid - half * x, w * half, &resonant);
                self.node(model, segment, mid + half * x, w * half, &resonant);
            }
        }
    }
}

/// The lines `k/duration`, k = 0..=`lines`, of each output column in `columns` over
/// `duration` from the run's current state (an integer number of periods of the orbit it is
/// on), which the run advances to its end; `None` (nothing advanced) where the run's segments
/// are not observable (RK, profiles) or neither the closed form nor the quadrature stays
/// within its cost (many lines over a long period of a column without a lifted row): the
/// caller then samples. The amplitude of line 0 is the magnitude of the mean, of line k ≥ 1
/// `2|c_k|`; the phase is that of the cosine at the record's start, as [`super::exact_dft`]
/// gives them.
pub fn orbit_lines<M: Drivetrain>(
    sim: &mut Driver<M>,
    columns: &[usize],
    duration: f64,
    lines: usize,
) -> Result<Option<Vec<Spectrum>>, String> {
    if !sim.observes_segments() {
        return Ok(None);
    }
    let nz = sim.model().lti_dim();
    let mut w = vec![0.0; nz];
    let closed: Vec<bool> = (columns.iter())
        .map(|&col| sim.model().lifted_output_row(col, &mut w))
        .collect();
    let (t0, y0) = (sim.t(), sim.y().to_vec());
    if closed.iter().any(|&c| c) && prefer_closed(sim, columns.len(), duration, lines) {
        match integrate(sim, columns, duration, lines, closed.clone())? {
            Ok(spectra) => return Ok(Some(spectra)),
            // Back to the start, for the quadrature of every column.
            Err(_) => sim.set_y(t0, &y0),
        }
    }
    if nodes(sim, duration, lines) * (lines + 1) as f64 * columns.len() as f64 > MAX_PRODUCTS {
        return Ok(None);
    }
    let quadrature = vec![false; columns.len()];
    match integrate(sim, columns, duration, lines, quadrature)? {
        Ok(spectra) => Ok(Some(spectra)),
        Err(e) => Err(e),
    }
}

/// Whether the closed form is expected to cost less than the quadrature of every line (or the
/// quadrature would exceed [`MAX_PRODUCTS`]), by a rough model in nanoseconds measured on
/// `idler_gearset` (n_z = 19) and the 16-mesh chain (n_z = 103): a quadrature node costs the
/// state from the series and the output row (about `200·n_z`) plus a product per line and
/// column; a mode of the closed form its eigenvalues and Hessenberg form (about `8·n_z³`)
/// and a solve per line (`2·n_z²`), a segment a product per line and state entry. Segments
/// are estimated as two per stiffness piece of each mesh, modes as two per piece of a mesh
/// cycle. With many state entries and few lines (the chain: 32 modes of `n_z = 103`, 33
/// lines) the eigenvalues cost more than the quadrature (0.41 s against 0.08 s).
fn prefer_closed<M: Drivetrain>(
    sim: &Driver<M>,
    columns: usize,
    duration: f64,
    lines: usize,
) -> bool {
    let model = sim.model();
    let nz = model.lti_dim() as f64;
    let lines = (lines + 1) as f64;
    let nodes = nodes(sim, duration, (lines - 1.0) as usize);
    if nodes * lines * columns as f64 > MAX_PRODUCTS {
        return true;
    }
    let pieces: Vec<f64> = (0..model.mesh_count())
        .map(|n| model.mesh_breakpoints(n).len().max(1) as f64)
        .collect();
    let segments: f64 = (0..model.mesh_count())
        .map(|n| 2.0 * pieces[n] * (duration * model.mesh_frequency(n)).ceil())
        .sum();
    let modes = segments.min(2.0 * pieces.iter().sum::<f64>());
    let closed = modes * (8.0 * nz.powi(3) + lines * 2.0 * nz * nz) + segments * lines * nz;
    let quadrature = nodes * (200.0 * nz + lines * columns as f64);
    closed <= quadrature
}

/// Quadrature nodes of all lines over `duration`.
fn nodes<M: Drivetrain>(sim: &Driver<M>, duration: f64, lines: usize) -> f64 {
    let omega = sim.model().max_frequency() + TAU * lines as f64 / duration;
    10.0 * (duration * omega / PIECE_OMEGA).ceil()
}

/// One observed advance over `duration`: `Ok(Err(why))` where the closed form was given up
/// (the run has advanced).
fn integrate<M: Drivetrain>(
    sim: &mut Driver<M>,
    columns: &[usize],
    duration: f64,
    lines: usize,
    closed: Vec<bool>,
) -> Result<Result<Vec<Spectrum>, String>, String> {
    let quadrature_columns = closed.iter().filter(|&&c| !c).count();
    if quadrature_columns > 0
        && nodes(sim, duration, lines) * (lines + 1) as f64 * quadrature_columns as f64
            > MAX_PRODUCTS
    {
        return Ok(Err(
            "the quadrature of the columns without a lifted row costs too much".into(),
        ));
    }
    let nz = sim.model().lti_dim();
    let mut integrator = Integrator {
        columns,
        closed,
        t0: sim.t(),
        duration,
        lines,
        omega_max: sim.model().max_frequency(),
        sums: vec![(0.0, 0.0); columns.len() * (lines + 1)],
        reference: Vec::new(),
        modes: Vec::new(),
        key: ModeKey::default(),
        failure: None,
        check_scale: vec![0.0; columns.len()],
        work: 0.0,
        bytes: 0.0,
        y: vec![0.0; sim.y().len()],
        row: Vec::new(),
        u_start: vec![0.0; nz],
        u_end: vec![0.0; nz],
    };
    let t_end = sim.t() + duration;
    sim.advance_observed(t_end, &mut integrator)
        .map_err(|e| format!("integration failed: {e}"))?;
    if let Some(why) = integrator.failure.take() {
        return Ok(Err(why));
    }
    if let Err(why) = integrator.solve_modes() {
        return Ok(Err(why));
    }
    let resolution = 1.0 / duration;
    let stride = lines + 1;
    let spectra = (0..columns.len())
        .map(|c| {
            let sums = &integrator.sums[c * stride..(c + 1) * stride];
            let mut spectrum = Spectrum {
                frequency: Vec::with_capacity(stride),
                amplitude: Vec::with_capacity(stride),
                phase: Vec::with_capacity(stride),
                resolution,
                window: Window::Rectangular,
            };
            let reference = integrator.reference.get(c).copied().unwrap_or(0.0);
            for (k, &(re, im)) in sums.iter().enumerate() {
                let (mut re, im) = (re / duration, im / duration);
                if k == 0 {
                    re += reference;
                }
                spectrum.frequency.push(k as f64 * resolution);
                let scale = if k == 0 { 1.0 } else { 2.0 };
                spectrum.amplitude.push(scale * re.hypot(im));
                spectrum.phase.push(im.atan2(re));
            }
            spectrum
        })
        .collect();
    Ok(Ok(spectra))
}
