//! `e^{Aτ}` of one mode through its balanced matrix, balanced once per mode.
//!
//! The augmented gear states differ by many orders of magnitude (metres, m/s, unit
//! harmonics), so `‖Aτ‖₁` is ~10⁴× the spectral radius; unbalanced, the scaling-and-squaring
//! takes ~14 extra squarings and loses ~10⁻¹⁴ relative accuracy — harmless once, but a cached
//! transition reused on a periodic orbit would drift systematically (e.g. the energy of an
//! undamped rattle). So `e^{Aτ} = D e^{Bτ} D⁻¹` with `B = D⁻¹ A D` (Parlett & Reinsch 1969, as
//! LAPACK `gebal`; `D` a diagonal of powers of two, so the scaling is exact). Balancing is
//! invariant under `A → Aτ` (it compares row and column sums), so `D` and `B` belong to the
//! mode and every duration costs only the exponential itself: on the stack
//! ([`super::expm`]) for the small augmented sizes, nalgebra's `exp` otherwise. The modes of a
//! free train met once each share one `D` instead ([`BandFrame`]).

use std::cell::{Cell, OnceCell};
use std::ops::Range;
use std::sync::Arc;

use nalgebra::DMatrix;

use super::expm::{expm, Square};

thread_local! {
    /// This thread's meter of matrix-exponential work, in the driver's work units
    /// ([`crate::simulation::budget`]). An exponential's cost grows with its squarings,
    /// `log₂ ‖Bτ‖₁`, which a state or input near the top of the double range drives to ~1000
    /// (issue 34: a load torque of 1e300 made every segment cost milliseconds). The exact
    /// propagator reads differences within one advance, which runs on one thread, so the
    /// count is deterministic.
    static EXP_WORK: Cell<f64> = const { Cell::new(0.0) };
}

/// Meters one exponential of an `n × n` matrix of one-norm `norm`: a Padé-13 (about 6
/// products and a solve) and one product per squaring, `log₂(norm/θ₁₃)` of them (all the
/// squarings a double allows when the norm is not finite).
fn meter_exp(n: usize, norm: f64) {
    let squarings = if norm.is_finite() {
        (norm / 5.37).log2().ceil().clamp(0.0, 2100.0)
    } else {
        2100.0
    };
    // Vectorised dense products: about 16 flops per work unit.
    let cube = (n * n * n) as f64;
    EXP_WORK.with(|w| w.set(w.get() + cube * (squarings + 8.0) / 8.0 + 256.0));
}

/// nalgebra's `e^M`, metered ([`exp_work`]).
pub(super) fn metered_exp(m: &DMatrix<f64>) -> DMatrix<f64> {
    let norm = m
        .column_iter()
        .map(|c| c.iter().map(|x| x.abs()).sum::<f64>())
        .fold(0.0, f64::max);
    meter_exp(m.nrows(), norm);
    m.clone().exp()
}

/// The matrix-exponential work metered on this thread so far (work units).
pub fn exp_work() -> f64 {
    EXP_WORK.with(Cell::get)
}

/// Sizes with a stack-allocated exponential (the single pair's `3 + 2H` up to four STE
/// harmonics; small drivetrains).
const MAX_FIXED: usize = 11;

/// States from which [`BalancedMatrix::exp_times`] takes its products by
/// [`BalancedMatrix::times`] (dense rows blocked, sparse rows compressed) instead of the dense
/// product: a chain's mode with a new contact combination meets its durations once, so its
/// one-off durations go by this series (the free 16-mesh rigid chain with contact loss, 65
/// states: 2.74–2.87 against 3.07–3.84 s CPU for 400 periods, `docs/scaling.md`). Below it,
/// the single pair's unrolled products and the small drivetrains keep the dense product
/// they were measured with (acceptance 4 of issue 37).
const SERIES_ROWS_FROM: usize = 32;

/// Most Taylor terms a series is summed to: `θ ≤ 8` settles within ~40.
pub const MAX_TERMS: usize = 60;

/// Buffers of [`BalancedMatrix::exp_times`] (no allocation per segment).
#[derive(Default, Clone)]
pub struct TaylorWork {
    term: Vec<f64>,
    next: Vec<f64>,
}

/// The balanced form of one mode matrix.
#[derive(Clone)]
pub struct BalancedMatrix {
    /// `B = D⁻¹ A D`: at once for a mode balanced on its own, at its first use for a mode
    /// of a [`BandFrame`] (its series needs only [`BalancedMatrix::times`]).
    b: OnceCell<DMatrix<f64>>,
    /// The diagonal of `D`.
    scale: Vec<f64>,
    /// `‖B‖₁`, for the remainder bound of [`BalancedMatrix::exp_times`].
    norm: f64,
    /// `B` by rows, the non-zeros of its sparse rows and the runs of its dense rows, when that
    /// pays ([`BalancedMatrix::times`]).
    sparse: Option<SparseRows>,
    /// A mode of a [`BandFrame`]: its band of rows of `B`, the rest the frame's.
    band: Option<Band>,
}

/// The rows of `B` in which a mode of a [`BandFrame`] differs from the others.
#[derive(Clone)]
struct Band {
    frame: Arc<BandFrame>,
    /// The band's rows of `B`, column-major (columns of the band's height).
    rows: Vec<f64>,
}

/// The modes of a system that differ only in a band of rows of `A`
/// ([`super::PiecewiseLti::lti_band`]: a free gear train's accelerations, where a contact
/// combination adds or drops a mesh's rank-one terms), balanced by one `D`. A mode of the
/// frame costs the writing and scaling of its band, `O(band · n)`, instead of its whole
/// matrix written, scanned and balanced, `O(n²)` several times over; its series products
/// take the frame's shared rows by their non-zeros and the band by the blocked kernel. Any
/// `D` of powers of two gives `e^{Aτ} = D e^{Bτ} D⁻¹` exactly; what `D` decides is `‖B‖₁`,
/// and with it the series' terms. `D` is that of the envelope `max |A|` of the modes built
/// whole since the frame began (the mode cache's `widen_frame`), so every mode within the
/// envelope has `‖B‖₁` at most the envelope's; on the free chains of issue 37 that is within
/// 1.6× of each mode's own balancing (`docs/scaling.md`, "One balancing for the contact
/// combinations"). A mode whose `‖B‖₁` exceeds [`BandFrame::NORM_LIMIT`] times the
/// envelope's is built whole and widens the envelope.
pub struct BandFrame {
    /// `D` of every mode of the frame.
    scale: Vec<f64>,
    /// The rows written per mode.
    band: Range<usize>,
    /// The other rows of `B` by their non-zeros (the band's rows empty).
    shared: SparseRows,
    /// Per column, `Σ |b_ij|` over the shared rows.
    column_sums: Vec<f64>,
    /// `‖B‖₁` of the envelope the frame was balanced by.
    norm: f64,
}

impl BandFrame {
    /// Largest `‖B‖₁` of a mode of the frame over the envelope's: beyond it the mode is built
    /// whole and balanced on its own (a contact combination outside the envelope would pay
    /// the difference in series terms on every segment).
    pub const NORM_LIMIT: f64 = 4.0;

    /// The frame of the modes whose rows outside `band` are those of `a`, balanced by the
    /// `D` of `envelope` (a matrix that bounds the modes' entries, balanced on its own, whose
    /// `‖B‖₁` the modes are compared with); `None` if `envelope` is not finite.
    pub fn of(
        a: &DMatrix<f64>,
        envelope: &BalancedMatrix,
        band: Range<usize>,
    ) -> Option<BandFrame> {
        if !envelope.norm.is_finite() {
            return None;
        }
        let n = a.nrows();
        let scale = &envelope.scale;
        let mut shared = SparseRows {
            starts: Vec::with_capacity(n + 1),
            columns: Vec::new(),
            values: Vec::new(),
            dense: Vec::new(),
        };
        let mut column_sums = vec![0.0; n];
        shared.starts.push(0);
        for i in 0..n {
            if !band.contains(&i) {
                for j in 0..n {
                    // A ratio of powers of two: the scaling is exact.
                    let v = a[(i, j)] * (scale[j] / scale[i]);
                    if v != 0.0 {
                        shared.columns.push(j as u32);
                        shared.values.push(v);
                        column_sums[j] += v.abs();
                    }
                }
            }
            shared.starts.push(shared.columns.len() as u32);
        }
        Some(BandFrame {
            scale: scale.clone(),
            band,
            shared,
            column_sums,
            norm: envelope.norm,
        })
    }

    /// Heap bytes of the frame.
    pub fn heap_bytes(&self) -> usize {
        (self.scale.capacity() + self.column_sums.capacity()) * 8 + self.shared.heap_bytes()
    }

    /// The rows written per mode.
    pub fn band(&self) -> Range<usize> {
        self.band.clone()
    }

    /// The balanced mode whose band of `A` is `rows` (column-major, columns of the band's
    /// height; scaled in place to `B`'s), or `None` if an entry is not finite or its `‖B‖₁`
    /// exceeds [`BandFrame::NORM_LIMIT`] times the envelope's.
    pub fn balance(self: &Arc<Self>, mut rows: Vec<f64>) -> Option<BalancedMatrix> {
        let height = self.band.len();
        let mut norm = 0.0f64;
        for (j, column) in rows.chunks_exact_mut(height).enumerate() {
            let dj = self.scale[j];
            let mut sum = self.column_sums[j];
            for (v, &di) in column.iter_mut().zip(&self.scale[self.band.clone()]) {
                // A ratio of powers of two: the scaling is exact.
                *v *= dj / di;
                sum += v.abs();
            }
            // (A NaN fails the comparison.)
            if !(sum <= self.norm * Self::NORM_LIMIT) {
                return None;
            }
            norm = norm.max(sum);
        }
        Some(BalancedMatrix {
            b: OnceCell::new(),
            scale: self.scale.clone(),
            norm,
            sparse: None,
            band: Some(Band {
                frame: Arc::clone(self),
                rows,
            }),
        })
    }
}

/// A matrix by rows: the rows with few non-zeros as their non-zeros only (compressed sparse
/// rows), the others as runs of dense rows for the blocked kernel
/// ([`super::mat_vec::mat_vec_rows`]). A gear mode's matrix is mostly sparse rows (the
/// identity block of the velocities, the harmonics' rotations) around one band of dense rows
/// (the accelerations, dense over the elastic coordinates of a free train).
#[derive(Clone)]
struct SparseRows {
    /// Row `i`'s entries are `[starts[i], starts[i + 1])` (none for a dense row).
    starts: Vec<u32>,
    columns: Vec<u32>,
    values: Vec<f64>,
    /// The runs `[start, end)` of dense rows.
    dense: Vec<(u32, u32)>,
}

impl SparseRows {
    /// Row `i`'s stored entries `(column, value)`, ascending (none for a dense row).
    fn row(&self, i: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let range = self.starts[i] as usize..self.starts[i + 1] as usize;
        (self.columns[range.clone()].iter())
            .zip(&self.values[range])
            .map(|(&j, &v)| (j as usize, v))
    }

    /// `out[i] = Σ_j b_ij u_j` over every row's stored entries, in ascending column order
    /// (a dense row's is `0`, overwritten by the caller).
    fn sparse_products(&self, u: &[f64], out: &mut [f64]) {
        for (i, o) in out.iter_mut().enumerate() {
            let mut sum = 0.0;
            for (j, v) in self.row(i) {
                sum += v * u[j];
            }
            *o = sum;
        }
    }

    fn heap_bytes(&self) -> usize {
        self.starts.capacity() * 4
            + self.columns.capacity() * 4
            + self.values.capacity() * 8
            + self.dense.capacity() * 8
    }

    /// The rows of `b` if that is cheaper than the dense product: a row with more than a
    /// third of its entries non-zero is dense (the blocked kernel's cost per entry is about
    /// a third of a compressed row's per non-zero: the threshold at which the whole matrix
    /// went by its sparse rows before), and the split is taken when its cost, `3 ×` the
    /// sparse rows' non-zeros plus `n ×` the dense rows, is below the dense product's `n²`.
    /// `rows` holds every off-diagonal non-zero of `b` by row (it may hold entries that are
    /// zero now: they are skipped), so the rows are read at their non-zeros only.
    fn of(b: &DMatrix<f64>, rows: &Pattern) -> Option<SparseRows> {
        let n = b.nrows();
        if n < 8 {
            return None;
        }
        let data = b.as_slice();
        // Row `i`'s non-zeros in ascending column order, its diagonal in its place.
        let row_entries = |i: usize| {
            let line = rows.of_line(i);
            let split = line.partition_point(|&j| (j as usize) < i);
            let columns = line[..split]
                .iter()
                .map(|&j| j as usize)
                .chain(std::iter::once(i))
                .chain(line[split..].iter().map(|&j| j as usize));
            columns
                .map(move |j| (j, data[j * n + i]))
                .filter(|&(_, v)| v != 0.0)
        };
        let counts: Vec<usize> = (0..n).map(|i| row_entries(i).count()).collect();
        let is_dense = |i: usize| 3 * counts[i] > n;
        let dense_rows = (0..n).filter(|&i| is_dense(i)).count();
        let sparse_nonzeros: usize = (0..n).filter(|&i| !is_dense(i)).map(|i| counts[i]).sum();
        if dense_rows == n || 3 * sparse_nonzeros + n * dense_rows > n * n {
            return None;
        }
        let mut sparse = SparseRows {
            starts: Vec::with_capacity(n + 1),
            columns: Vec::with_capacity(sparse_nonzeros),
            values: Vec::with_capacity(sparse_nonzeros),
            dense: Vec::new(),
        };
        sparse.starts.push(0);
        for i in 0..n {
            if is_dense(i) {
                match sparse.dense.last_mut() {
                    Some((_, end)) if *end as usize == i => *end += 1,
                    _ => sparse.dense.push((i as u32, i as u32 + 1)),
                }
            } else {
                for (j, v) in row_entries(i) {
                    sparse.columns.push(j as u32);
                    sparse.values.push(v);
                }
            }
            sparse.starts.push(sparse.columns.len() as u32);
        }
        Some(sparse)
    }
}

/// The positions of a square matrix's non-zeros by line (row or column), ascending.
struct Pattern {
    /// Line `i`'s positions are `indices[starts[i]..starts[i + 1]]`.
    starts: Vec<u32>,
    indices: Vec<u32>,
}

impl Pattern {
    /// The off-diagonal non-zeros of `b` by column and by row, both ascending, from one pass
    /// over its columns (contiguous in the column-major `b`; the rows are sorted by counting);
    /// `None` if an entry is not finite.
    fn off_diagonal(b: &DMatrix<f64>) -> Option<(Pattern, Pattern)> {
        let n = b.nrows();
        let data = b.as_slice();
        let mut by_column = Pattern {
            starts: Vec::with_capacity(n + 1),
            indices: Vec::new(),
        };
        by_column.starts.push(0);
        let mut row_counts = vec![0u32; n];
        for j in 0..n {
            let column = &data[j * n..(j + 1) * n];
            // Without an early exit, so that the check vectorises.
            if !column.iter().fold(true, |finite, v| finite & v.is_finite()) {
                return None;
            }
            for (i, &v) in column.iter().enumerate() {
                if v != 0.0 && i != j {
                    by_column.indices.push(i as u32);
                    row_counts[i] += 1;
                }
            }
            by_column.starts.push(by_column.indices.len() as u32);
        }
        let mut by_row = Pattern {
            starts: Vec::with_capacity(n + 1),
            indices: vec![0; by_column.indices.len()],
        };
        by_row.starts.push(0);
        for (i, &count) in row_counts.iter().enumerate() {
            by_row.starts.push(by_row.starts[i] + count);
        }
        // The columns in ascending order, so each row's list comes out ascending.
        let mut next = by_row.starts[..n].to_vec();
        for j in 0..n {
            for &i in by_column.of_line(j) {
                by_row.indices[next[i as usize] as usize] = j as u32;
                next[i as usize] += 1;
            }
        }
        Some((by_column, by_row))
    }

    fn of_line(&self, i: usize) -> &[u32] {
        &self.indices[self.starts[i] as usize..self.starts[i + 1] as usize]
    }
}

impl BalancedMatrix {
    pub fn new(a: &DMatrix<f64>) -> BalancedMatrix {
        let n = a.nrows();
        let mut b = a.clone();
        let mut scale = vec![1.0f64; n];
        // The off-diagonal non-zeros by column and by row, ascending: a sum over them is the
        // sum over the whole column or row (the terms skipped are exact zeros, and the sums
        // start at +0), and a scaling by a power of two keeps a zero the same zero, so the
        // sweeps below give the dense sweeps' `D` and `B` bit for bit at the cost of the
        // non-zeros (a drivetrain's `A` is mostly zeros; every new contact combination of a
        // long chain balances a new mode, `docs/scaling.md`). The norm and the sparse rows
        // after the sweeps are read through the same lists, so `A` is read whole only once.
        let Some((by_column, by_row)) = Pattern::off_diagonal(&b) else {
            // Nothing to balance; the exponential is non-finite and the caller detects the
            // non-finite state.
            return BalancedMatrix {
                b: OnceCell::from(b),
                scale,
                norm: f64::INFINITY,
                sparse: None,
                band: None,
            };
        };
        let data = b.as_mut_slice();
        // LAPACK gebal converges in a few sweeps; the cap only guards against cycling.
        for _sweep in 0..32 {
            let mut converged = true;
            for i in 0..n {
                let (mut c, mut r) = (0.0f64, 0.0f64);
                for &j in by_column.of_line(i) {
                    c += data[i * n + j as usize].abs();
                }
                for &j in by_row.of_line(i) {
                    r += data[j as usize * n + i].abs();
                }
                if c == 0.0 || r == 0.0 {
                    continue;
                }
                let mut f = 1.0f64;
                let (mut cc, mut rr) = (c, r);
                // Scaling stops before a sum under- or overflows (LAPACK gebal's sfmin/sfmax
                // guards): with entries of very different magnitude (a damping of 1.8e308)
                // the halved sum reached 0, `cc >= 0 · 2` held for ever and the mode was
                // never built (issue 17). Normal magnitudes never come near these limits.
                let (low, high) = (4.0 * f64::MIN_POSITIVE, f64::MAX / 4.0);
                while cc < rr / 2.0 && rr > low && cc < high {
                    cc *= 2.0;
                    rr /= 2.0;
                    f *= 2.0;
                }
                while cc >= rr * 2.0 && cc > low && rr < high {
                    cc /= 2.0;
                    rr *= 2.0;
                    f /= 2.0;
                }
                if (cc + rr) < 0.95 * (c + r) {
                    converged = false;
                    scale[i] *= f;
                    // B ← F⁻¹ B F with F = diag(.., f, ..): column i times f, row i over f
                    // (the diagonal entry both, in that order, as the dense update).
                    for &j in by_column.of_line(i) {
                        data[i * n + j as usize] *= f;
                    }
                    for &j in by_row.of_line(i) {
                        data[j as usize * n + i] /= f;
                    }
                    data[i * n + i] *= f;
                    data[i * n + i] /= f;
                }
            }
            if converged {
                break;
            }
        }
        // Each column's sum in ascending row order, its diagonal in its place (the entries
        // not listed are zeros, whose `+0` leaves a sum of absolute values as it is).
        let data = b.as_slice();
        let norm = (0..n)
            .map(|j| {
                let column = &data[j * n..(j + 1) * n];
                let line = by_column.of_line(j);
                let split = line.partition_point(|&i| (i as usize) < j);
                let mut sum = 0.0f64;
                for &i in &line[..split] {
                    sum += column[i as usize].abs();
                }
                sum += column[j].abs();
                for &i in &line[split..] {
                    sum += column[i as usize].abs();
                }
                sum
            })
            .fold(0.0, f64::max);
        let sparse = SparseRows::of(&b, &by_row);
        BalancedMatrix {
            b: OnceCell::from(b),
            scale,
            norm,
            sparse,
            band: None,
        }
    }

    /// The number of states.
    pub fn dim(&self) -> usize {
        self.scale.len()
    }

    /// Whether the mode is one of a [`BandFrame`].
    pub fn in_band_frame(&self) -> bool {
        self.band.is_some()
    }

    /// `A = D B D⁻¹` (exact: `D` holds powers of two).
    pub fn unbalanced(&self) -> DMatrix<f64> {
        self.unbalance(self.matrix().clone())
    }

    /// `out = B u`. The sparse rows' products in ascending column order, as the dense
    /// product sums them (the skipped terms are exact zeros), and the dense rows by the dense
    /// product's own kernel, so the result is the same bit for bit; without sparse rows the
    /// dense product.
    pub fn times(&self, u: &[f64], out: &mut [f64]) {
        if let Some(band) = &self.band {
            band.frame.shared.sparse_products(u, out);
            super::mat_vec::mat_vec_band(&band.rows, u, &mut out[band.frame.band.clone()]);
            return;
        }
        match &self.sparse {
            Some(rows) => {
                rows.sparse_products(u, out);
                for &(start, end) in &rows.dense {
                    super::mat_vec::mat_vec_rows(
                        self.matrix().as_slice(),
                        u,
                        start as usize..end as usize,
                        out,
                    );
                }
            }
            None => super::mat_vec::mat_vec(self.matrix().as_slice(), u, out),
        }
    }

    /// Heap bytes of `B` (as far as it is built), its sparse rows and its band (a frame's
    /// shared rows are counted once, by the cache).
    pub fn heap_bytes(&self) -> usize {
        self.b.get().map_or(0, |b| b.len() * 8)
            + self.sparse.as_ref().map_or(0, SparseRows::heap_bytes)
            + self
                .band
                .as_ref()
                .map_or(0, |band| band.rows.capacity() * 8)
    }

    /// `B = D⁻¹ A D` (assembled at its first use for a mode of a [`BandFrame`]).
    pub fn matrix(&self) -> &DMatrix<f64> {
        self.b.get_or_init(|| {
            let band = self.band.as_ref().expect("a mode without B is in a frame");
            let (frame, n) = (&band.frame, self.scale.len());
            let mut b = DMatrix::zeros(n, n);
            for i in 0..n {
                for (j, v) in frame.shared.row(i) {
                    b[(i, j)] = v;
                }
            }
            let height = frame.band.len();
            for (j, column) in band.rows.chunks_exact(height).enumerate() {
                b.column_mut(j).as_mut_slice()[frame.band.clone()].copy_from_slice(column);
            }
            b
        })
    }

    /// The diagonal of `D`.
    pub fn scale(&self) -> &[f64] {
        &self.scale
    }

    /// `‖B‖₁`.
    pub fn norm(&self) -> f64 {
        self.norm
    }

    /// `out = e^{Aτ} z` without a matrix exponential: the Taylor series of `e^{Bτ}` applied to
    /// `D⁻¹z` term by term (one mat-vec each), until the rigorous bound of the remaining terms
    /// in the 1-norm, `θ^{K+1}/(K+1)! · 1/(1 − θ/(K+2)) · ‖D⁻¹z‖₁` with `θ = ‖B‖₁ τ`, is below
    /// `2⁻⁵⁴ ‖D⁻¹z‖₁` (the truncation is then below the rounding of the sum itself; the
    /// truncated-Taylor `expmv` of Al-Mohy & Higham 2011, SIAM J. Sci. Comput. 33(2), §3,
    /// with one step and the exact tail bound instead of their backward-error θ_m). `false`
    /// (and `out` unspecified) when `θ > MAX_THETA`, where the terms would grow too large for
    /// the sum to stay accurate: the caller then takes the Padé matrix.
    ///
    /// The sum is accumulated in place, two vectors and no stored terms: this is the single
    /// pair's hot path for durations met once, where [`BalancedMatrix::taylor_terms`] (which
    /// keeps every term for the guards' polynomials and bounds the tail from the last term)
    /// measured 10–20 % slower per mesh period on the 1 ms grid of `spur_pair --quick`.
    pub fn exp_times(&self, tau: f64, z: &[f64], out: &mut [f64], work: &mut TaylorWork) -> bool {
        /// Largest `‖Bτ‖₁` summed: the largest term is below `e^θ/√(2πθ) ≈ 380 ×` the first,
        /// so the sum loses less than ~9 bits to cancellation (the Padé exponential of the
        /// same duration squares about as often).
        const MAX_THETA: f64 = 8.0;
        let theta = self.norm * tau.abs();
        if !(theta <= MAX_THETA) {
            return false;
        }
        let n = z.len();
        work.term.resize(n, 0.0);
        work.next.resize(n, 0.0);
        for ((t, o), (&zj, &d)) in work
            .term
            .iter_mut()
            .zip(out.iter_mut())
            .zip(z.iter().zip(&self.scale))
        {
            *t = zj / d;
            *o = *t;
        }
        // θ^k / k!, the bound of term k relative to ‖D⁻¹z‖₁.
        let mut bound = 1.0;
        // The split rows where they pay most ([`SERIES_ROWS_FROM`]), the dense product below:
        // the same bits either way.
        let by_rows = n >= SERIES_ROWS_FROM || self.band.is_some();
        let b = if by_rows {
            &[][..]
        } else {
            self.matrix().as_slice()
        };
        for k in 1..=MAX_TERMS {
            let tail = bound * theta / k as f64 / (1.0 - theta / (k + 1) as f64);
            if theta < (k + 1) as f64 && tail <= f64::EPSILON / 4.0 {
                break;
            }
            if k == MAX_TERMS {
                return false;
            }
            if by_rows {
                self.times(&work.term, &mut work.next);
            } else {
                super::mat_vec::mat_vec(b, &work.term, &mut work.next);
            }
            let factor = tau / k as f64;
            for ((t, o), &x) in work.term.iter_mut().zip(out.iter_mut()).zip(&work.next) {
                *t = x * factor;
                *o += *t;
            }
            bound *= theta / k as f64;
        }
        for (o, &d) in out.iter_mut().zip(&self.scale) {
            *o *= d;
        }
        true
    }

    /// Fills `terms[k n..(k+1) n]` with `u_k = (B w)^k u_0 / k!` from `u_0` in `terms[..n]`
    /// until the rigorous bound of the remaining terms is below `2⁻⁵⁴ ‖u_0‖₁`, and returns the
    /// number of terms (`u_1` always: a caller reads slopes from it); more than
    /// `terms.len() / n − 1` if the series did not settle in the storage (a non-finite `θ`).
    /// With `θ = ‖B‖₁ |w|`, `‖u_{k+j}‖₁ ≤ ‖u_k‖₁ θ^j k!/(k+j)!`, so the terms after `u_k` sum
    /// to at most `‖u_k‖₁ (θ/(k+1)) / (1 − θ/(k+2))` for `θ < k + 2`: the bound from the last
    /// term itself rather than from `θ^k/k! ‖u_0‖₁`, which saves the terms a state near its
    /// mode's equilibrium does not need (the constant forcing component does not grow). The
    /// truncated-Taylor `expmv` of Al-Mohy & Higham 2011 (SIAM J. Sci. Comput. 33(2), §3) with
    /// one step and this exact tail bound instead of their backward-error `θ_m`.
    pub fn taylor_terms(&self, w: f64, n: usize, terms: &mut [f64]) -> usize {
        self.taylor_terms_within(w, n, terms, f64::EPSILON / 4.0)
    }

    /// [`BalancedMatrix::taylor_terms`] until the bound of the remaining terms is below
    /// `tail ‖u_0‖₁`.
    pub fn taylor_terms_within(&self, w: f64, n: usize, terms: &mut [f64], tail: f64) -> usize {
        let theta = self.norm * w.abs();
        let max_terms = terms.len() / n - 1;
        let one_norm = |u: &[f64]| u.iter().map(|x| x.abs()).sum::<f64>();
        let goal = tail * one_norm(&terms[..n]);
        let mut last_norm = one_norm(&terms[..n]);
        for k in 0..max_terms {
            let (next_ratio, after_ratio) = (theta / (k + 1) as f64, theta / (k + 2) as f64);
            if k >= 1 && after_ratio < 1.0 && last_norm * next_ratio / (1.0 - after_ratio) <= goal {
                return k + 1;
            }
            let (done, rest) = terms.split_at_mut((k + 1) * n);
            let next = &mut rest[..n];
            self.times(&done[k * n..], next);
            let factor = w / (k + 1) as f64;
            for x in next.iter_mut() {
                *x *= factor;
            }
            last_norm = one_norm(next);
        }
        max_terms + 1
    }

    /// `e^{Aτ}`: Padé on the stack for the small sizes, nalgebra's `exp` otherwise.
    pub fn exp(&self, tau: f64) -> DMatrix<f64> {
        let n = self.dim();
        let fixed = match n {
            1 => self.fixed::<1>(tau),
            2 => self.fixed::<2>(tau),
            3 => self.fixed::<3>(tau),
            4 => self.fixed::<4>(tau),
            5 => self.fixed::<5>(tau),
            6 => self.fixed::<6>(tau),
            7 => self.fixed::<7>(tau),
            8 => self.fixed::<8>(tau),
            9 => self.fixed::<9>(tau),
            10 => self.fixed::<10>(tau),
            MAX_FIXED => self.fixed::<MAX_FIXED>(tau),
            _ => None,
        };
        match fixed {
            Some(e) => {
                meter_exp(n, self.norm * tau.abs());
                e
            }
            // nalgebra's exponential (also where the stack one found no finite result: its
            // cost then follows the actual norm, not the balanced one).
            None => self.unbalance(metered_exp(&(self.matrix() * tau))),
        }
    }

    /// `D M D⁻¹`.
    fn unbalance(&self, mut m: DMatrix<f64>) -> DMatrix<f64> {
        for j in 0..m.ncols() {
            for i in 0..m.nrows() {
                m[(i, j)] *= self.scale[i] / self.scale[j];
            }
        }
        m
    }

    fn fixed<const N: usize>(&self, tau: f64) -> Option<DMatrix<f64>> {
        let mut bt: Square<N> = [[0.0; N]; N];
        for (j, column) in bt.iter_mut().enumerate() {
            for (i, x) in column.iter_mut().enumerate() {
                *x = self.matrix()[(i, j)] * tau;
            }
        }
        let e = expm(&bt)?;
        Some(DMatrix::from_fn(N, N, |i, j| {
            e[j][i] * (self.scale[i] / self.scale[j])
        }))
    }
}

/// `out = Σ_k u_k σ^k` of the terms `u_k` at `terms[k n..(k+1) n]` (Horner from the last),
/// for the first `out.len() ≤ n` entries (each entry's sum is its own, so a prefix costs only
/// its share and is bit-identical to the same entries of the whole sum).
pub fn sum_terms(terms: &[f64], n: usize, sigma: f64, out: &mut [f64]) {
    let count = terms.len() / n;
    let m = out.len();
    if m == 1 || m == 2 {
        // A few entries (a single mesh's state): each entry's sum on its own, both in one pass
        // over the terms, the same operations per entry as below.
        let (rest, last) = terms[..count * n].split_at((count - 1) * n);
        let (mut a, mut b) = (last[0], last.get(1).copied().unwrap_or(0.0));
        for row in rest.chunks_exact(n).rev() {
            a = a * sigma + row[0];
            if m == 2 {
                b = b * sigma + row[1];
            }
        }
        out[0] = a;
        if m == 2 {
            out[1] = b;
        }
        return;
    }
    out.copy_from_slice(&terms[(count - 1) * n..(count - 1) * n + m]);
    for k in (0..count - 1).rev() {
        for (o, &u) in out.iter_mut().zip(&terms[k * n..k * n + m]) {
            *o = *o * sigma + u;
        }
    }
}
