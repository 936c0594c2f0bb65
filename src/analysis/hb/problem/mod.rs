//! The discretised harmonic-balance problem of a drivetrain: the retained orders, the
//! quadrature split at every breakpoint, the condensed linear part (receptances per order),
//! Newton at a fixed speed, the time-domain seed and the orbit of a converged solution.

use std::collections::{BTreeMap, BTreeSet};
use std::f64::consts::TAU;

use nalgebra::{Complex, DMatrix, DVector, Dyn, LU};

use super::blocked_lu::{Factorised, FrozenJacobian};
use super::scan::{uniform_coefficients, uniform_points, ScanGrid};
use super::{Basis, HbOptions, HbSolution};
use crate::model::drivetrain::{response_frequencies, response_period_in_mesh_periods};
use crate::model::{Drivetrain, MeshLaw};
use crate::scene::SolverSettings;
use crate::simulation::Driver;
use torus::Torus;

// The two-frequency quadrature (issue 38): a child, since it works on the problem's own
// accumulator and node rules.
mod torus;

/// One mesh of the discretised problem.
#[derive(Debug, Clone)]
pub(super) struct MeshData {
    pub(super) prefix: String,
    pub(super) dte: Vec<f64>,
    /// Index of its first force output among all outputs, and how many it has.
    pub(super) first: usize,
    pub(super) outputs: usize,
    pub(super) k_mean: f64,
    pub(super) c_mean: f64,
    /// Mesh cycles per HB period.
    pub(super) cycles: f64,
    pub(super) static_force: f64,
    /// The coordinate of the back flanks' own deflection `S̃_n = ã_n·ξ` (after the meshes'),
    /// for a mesh with a back row ([`Drivetrain::mesh_back_row`]): the last of its outputs
    /// is the back flanks' force along `ã_n`, which depends on `S̃_n`.
    pub(super) back: Option<usize>,
}

/// Per-order data of the condensed linear part at one frequency.
pub(super) struct Receptance {
    pub(super) f: f64,
    pub(super) lus: Vec<LU<Complex<f64>, Dyn, Dyn>>,
    /// `Aᵀ Z_j⁻¹ V` (meshes × outputs) and its frequency derivative.
    pub(super) r: Vec<DMatrix<Complex<f64>>>,
    pub(super) dr: Vec<DMatrix<Complex<f64>>>,
    /// `Aᵀ Z_j⁻¹ F̂_j` and its derivative.
    pub(super) lin: Vec<DVector<Complex<f64>>>,
    pub(super) dlin: Vec<DVector<Complex<f64>>>,
}

/// What an evaluation computes besides the residual.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Want {
    pub(super) jacobian: bool,
    pub(super) frequency: bool,
    pub(super) samples: bool,
    /// Keep the torus linearisation for matrix-free Jacobian products (`torus::Torus::product`;
    /// the torus quadrature only).
    pub(super) linear: bool,
}

/// Sums over the quadrature nodes.
pub(super) struct Accumulator {
    /// `Σ w F φ` per output.
    pub(super) gal: Vec<Vec<f64>>,
    /// `Σ w F_viscous φ` per output.
    pub(super) visc: Vec<Vec<f64>>,
    /// `Σ w ∂F/∂S (cos, sin)(2πdθ)` and the same of `∂F/∂Ṡ`, per output, over the orders of
    /// [`Problem::sums`].
    pub(super) kap_s: Vec<Vec<f64>>,
    pub(super) kap_v: Vec<Vec<f64>>,
    /// Boundary terms `(output, coefficient, φ(θ*))` of the split points.
    pub(super) boundary: Vec<(usize, f64, Vec<f64>)>,
    /// Boundary terms of split points on another coordinate than the output's own (a mesh
    /// with a back row: a drive gap's root moving the back force, or the converse):
    /// `(output, coordinate, coefficient, φ(θ*))`.
    pub(super) cross_boundary: Vec<(usize, usize, f64, Vec<f64>)>,
    /// Node samples for the results: per mesh the node's weight (zero for a torus node of
    /// another mesh, [`torus`]), the mesh force and whether it has lost contact on
    /// every tooth pair.
    pub(super) sample_w: Vec<f64>,
    pub(super) sample_force: Vec<f64>,
    pub(super) sample_lost: Vec<bool>,
    /// Scratch: `(cos, sin)(2πdθ)` of the node over [`Problem::sums`].
    pub(super) trig: Vec<f64>,
}

/// The result of one evaluation.
pub(super) struct Evaluation {
    pub(super) residual: DVector<f64>,
    pub(super) jacobian: Option<DMatrix<f64>>,
    /// `∂r/∂f`.
    pub(super) d_frequency: Option<DVector<f64>>,
    /// `g` per output (the Galerkin coefficients of the force minus the moved linear part).
    pub(super) g: Vec<DVector<f64>>,
    /// Node samples ([`Accumulator::sample_w`]), when asked for.
    pub(super) sample_w: Vec<f64>,
    pub(super) sample_force: Vec<f64>,
    pub(super) sample_lost: Vec<bool>,
}

/// The discretised harmonic-balance problem of a drivetrain.
pub(super) struct Problem<M: Drivetrain> {
    pub(super) model: M,
    pub(super) settings: SolverSettings,
    /// HB fundamental frequency the model is set to, Hz.
    pub(super) f: f64,
    /// Input speed per Hz of `f`.
    pub(super) speed_per_f: f64,
    pub(super) m: usize,
    pub(super) meshes: Vec<MeshData>,
    /// Mesh deflection rows (m × coordinates: the meshes', then the back flanks' own rows of
    /// the meshes that have one, [`MeshData::back`]) and force directions (m × outputs).
    pub(super) a: DMatrix<f64>,
    pub(super) v: DMatrix<f64>,
    pub(super) mass: DMatrix<f64>,
    pub(super) damping: DMatrix<f64>,
    pub(super) stiffness: DMatrix<f64>,
    pub(super) orders: Vec<usize>,
    /// `2π j` of every retained order `j` (as `TAU * j as f64`, so the same bits), read at every
    /// quadrature node by [`Problem::deflection`].
    pub(super) order_rates: Vec<f64>,
    /// `2|J| − 1`.
    pub(super) len: usize,
    pub(super) cells: Vec<(f64, f64)>,
    pub(super) nodes: Vec<f64>,
    pub(super) weights: Vec<f64>,
    /// Basis rows `[1, cos 2πjθ, sin 2πjθ, …]` of the nodes, when they fit in
    /// [`TABLE_ENTRIES`]; else rows are computed as needed ([`Problem::basis_fast`]).
    pub(super) table: Option<Vec<f64>>,
    /// Whether a cell starts at a breakpoint (where the engaged tooth pairs change).
    pub(super) cell_at_break: Vec<bool>,
    /// Whether any mesh's contact law switches (else no cell is ever split).
    pub(super) switching: bool,
    /// Scratch: every mesh's law at every node.
    pub(super) node_laws: Vec<MeshLaw>,
    /// Largest gap between consecutive retained orders.
    pub(super) max_step: usize,
    /// Orders `d` of the sums and differences of retained orders, each with a pair `(q, p, +)`
    /// of retained-order indices whose sum (`+`) or difference it is.
    pub(super) sums: Vec<(usize, usize, usize, bool)>,
    /// Per (q, p): positions in `sums` of `j_q + j_p` and `|j_q − j_p|`.
    pub(super) plus: Vec<usize>,
    pub(super) minus: Vec<usize>,
    /// Galerkin coefficients of `F̂` (m × len).
    pub(super) external: DMatrix<f64>,
    /// HB period in mesh periods of the first mesh.
    pub(super) mesh_periods: u64,
    /// HB period in response periods.
    pub(super) subharmonic: u32,
    pub(super) x_scale: f64,
    pub(super) receptance: Option<Receptance>,
    /// The results' scan grid ([`ScanGrid`]).
    pub(super) scan: ScanGrid,
    /// The torus quadrature of a two-frequency train ([`torus`]), while it applies.
    pub(super) torus: Option<Torus>,
}

/// 3-point Gauss–Legendre rule on [−1, 1]: (node, weight).
pub(super) const GAUSS3: [(f64, f64); 3] = [
    (-0.774_596_669_241_483_4, 5.0 / 9.0),
    (0.0, 8.0 / 9.0),
    (0.774_596_669_241_483_4, 5.0 / 9.0),
];

/// Unknowns above which Newton and the continuation's corrector keep a factorised Jacobian
/// over several iterates (the chord method): below, a Jacobian and its LU per iterate cost
/// little, and Newton's iterates (so the branch points) stay those they have always been.
pub(super) const CHORD_UNKNOWNS: usize = 512;

/// Largest Newton system (its dense Jacobian is 128 MB and one LU ~4e10 flops).
pub(super) const MAX_UNKNOWNS: usize = 4096;

/// Most mesh periods of the first mesh one harmonic-balance orbit may span (subharmonic
/// order times the response period): the time grid holds each cycle's stiffness breakpoints.
pub(super) const MAX_PERIOD_MESH_CYCLES: u64 = 100_000;

/// Largest number of tabulated basis entries (32 MB); larger problems (a
/// countershaft's many combination tones over 72 mesh periods) compute rows as needed.
pub(super) const TABLE_ENTRIES: usize = 1 << 22;

/// Probes sit this fraction of a cell inside its ends (the ends are breakpoints, where the
/// engaged tooth pairs change).
pub(super) const PROBE: f64 = 1e-9;

/// The retained orders of `basis` for the base orders `bases` (the mesh and error
/// frequencies in multiples of `1/T`) at order `h` ([`Basis`]).
pub(super) fn retained_orders(basis: Basis, bases: &[usize], h: usize) -> Vec<usize> {
    match basis {
        Basis::TotalOrder => combination_orders(bases, h),
        Basis::Full => {
            let top = bases.iter().copied().max().expect("one mesh at least");
            (0..=h * top).collect()
        }
    }
}

/// The retained orders: 0 and the combination tones `|Σ a_n b_n|` of the distinct base orders
/// `b_n` of total order `Σ |a_n| ≤ h` (Krack & Gross 2019 §2.5, multi-frequency HB with a
/// total-order truncation). For one base order `b` these are the harmonics `b, 2b, …, hb`;
/// for the countershaft (`b = (72, 19)`) the tones `72a + 19b` with `|a| + |b| ≤ h`:
/// `h² + h + 1` orders (421 at `h = 20`) instead of the `72h + 1` multiples of `1/T` up to
/// `h f_1` (1441), with every harmonic up to `h` of each mesh and their intermodulation.
pub(super) fn combination_orders(bases: &[usize], h: usize) -> Vec<usize> {
    let mut distinct: Vec<usize> = bases.to_vec();
    distinct.sort_unstable();
    distinct.dedup();
    // The least total order that reaches each tone, base by base: the work is bounded by the
    // number of tones (at most 2h·Σb + 1), not by the lattice points (exponential in the bases).
    let mut least: BTreeMap<i64, usize> = BTreeMap::from([(0, 0)]);
    for &b in &distinct {
        let mut next = least.clone();
        for (&tone, &used) in &least {
            for a in 1..=(h - used) as i64 {
                for t in [tone + a * b as i64, tone - a * b as i64] {
                    let total = used + a as usize;
                    let entry = next.entry(t).or_insert(total);
                    *entry = (*entry).min(total);
                }
            }
        }
        least = next;
    }
    let set: BTreeSet<usize> = least.keys().map(|t| t.unsigned_abs() as usize).collect();
    set.into_iter().collect()
}

/// `(cos, sin)` of order index `q` from a basis row.
#[inline]
pub(super) fn cs(phi: &[f64], q: usize) -> (f64, f64) {
    if q == 0 {
        (1.0, 0.0)
    } else {
        (phi[2 * q - 1], phi[2 * q])
    }
}

/// Projection factor of coefficient row `r`: 1 for the mean, 2 for a harmonic.
#[inline]
pub(super) fn factor(r: usize) -> f64 {
    if r == 0 {
        1.0
    } else {
        2.0
    }
}

/// `R·(a − ib)` in the real layout `(a, b)` → `(a', b')`.
#[inline]
pub(super) fn cmul(r: Complex<f64>, a: f64, b: f64) -> (f64, f64) {
    (r.re * a + r.im * b, -r.im * a + r.re * b)
}

/// Mesh periods integrated before a time-domain seed is sampled (rounded up to whole HB
/// periods).
const SEED_WARMUP_PERIODS: u64 = 60;

impl<M: Drivetrain> Problem<M> {
    pub(super) fn new(
        model: M,
        settings: SolverSettings,
        options: &HbOptions,
    ) -> Result<Self, String> {
        options.validate()?;
        let meshes_n = model.mesh_count();
        let freqs: Vec<f64> = (0..meshes_n).map(|n| model.mesh_frequency(n)).collect();
        if !(freqs[0] > 0.0 && freqs[0].is_finite()) {
            return Err(format!(
                "input speed {} rad/s: harmonic balance needs a finite speed > 0",
                model.input_speed()
            ));
        }
        let k_resp = response_period_in_mesh_periods(&response_frequencies(&model))?;
        let mesh_periods = k_resp.saturating_mul(options.subharmonic as u64);
        // The time grid holds every mesh cycle's stiffness breakpoints: bounded before it is
        // built (issue 34: subharmonic = 4e9 aborted on a 32 GB allocation).
        if mesh_periods > MAX_PERIOD_MESH_CYCLES {
            return Err(format!(
                "subharmonic = {} with a response period of {k_resp} mesh periods: {mesh_periods} \
                 mesh periods per orbit, more than the {MAX_PERIOD_MESH_CYCLES} the time grid \
                 may hold (lower subharmonic)",
                options.subharmonic
            ));
        }
        let period = mesh_periods as f64 / freqs[0];
        let f = 1.0 / period;
        let m = model.dim() / 2;
        let statics = model.static_mesh_forces();
        let mut meshes = Vec::with_capacity(meshes_n);
        let mut a = DMatrix::zeros(m, meshes_n);
        let mut directions: Vec<Vec<f64>> = Vec::new();
        let mut back_rows: Vec<Vec<f64>> = Vec::new();
        let mut bases = Vec::new();
        for (n, &frequency) in freqs.iter().enumerate() {
            let cycles = frequency * period;
            let rounded = cycles.round();
            if (cycles - rounded).abs() > 1e-6 * cycles.max(1.0) || rounded < 1.0 {
                return Err(format!(
                    "mesh {} makes {cycles} cycles per response period: not a whole number",
                    n + 1
                ));
            }
            a.set_column(n, &DVector::from_vec(model.mesh_deflection_row(n)));
            let mut dirs = model.mesh_force_directions(n);
            // The back flanks on their own row: a second coordinate and force of the mesh.
            let back = model.mesh_back_row(n).map(|row| {
                dirs.push(row.clone());
                back_rows.push(row);
                meshes_n + back_rows.len() - 1
            });
            let (k_mean, c_mean) = model.mean_mesh_law(n);
            meshes.push(MeshData {
                prefix: model.mesh_prefix(n),
                dte: model.mesh_dte_row(n),
                first: directions.len(),
                outputs: dirs.len(),
                k_mean,
                c_mean,
                cycles: rounded,
                static_force: statics.get(n).copied().unwrap_or(f64::NAN),
                back,
            });
            directions.extend(dirs);
            bases.push(rounded as usize / options.subharmonic as usize);
        }
        // Gear errors force at the revolution frequencies of their gears (`docs/errors.md`):
        // those are base orders too, or the basis would miss the shaft orders and sidebands.
        for f_rev in model.error_frequencies() {
            let cycles = (f_rev * period).round() as usize;
            bases.push(cycles / options.subharmonic as usize);
        }
        if !back_rows.is_empty() {
            a = a.resize_horizontally(meshes_n + back_rows.len(), 0.0);
            for (b, row) in back_rows.iter().enumerate() {
                a.set_column(meshes_n + b, &DVector::from_column_slice(row));
            }
        }
        let coordinates = a.ncols();
        let v = DMatrix::from_fn(m, directions.len(), |i, k| directions[k][i]);
        let lin = model.linear_part();
        let (mut stiffness, mut damping) = (lin.stiffness, lin.damping);
        for (n, mesh) in meshes.iter().enumerate() {
            let col = a.column(n);
            stiffness += mesh.k_mean * col * col.transpose();
            damping += mesh.c_mean * col * col.transpose();
        }

        let orders = retained_orders(options.basis, &bases, options.harmonics);
        let j_max = *orders.last().expect("order 0");
        let len = 2 * orders.len() - 1;
        if coordinates * len > MAX_UNKNOWNS {
            return Err(format!(
                "harmonics = {}: {} retained orders give {} unknowns over {meshes_n} meshes{}, \
                 more than the {MAX_UNKNOWNS} a dense Newton system takes (lower harmonics)",
                options.harmonics,
                orders.len(),
                coordinates * len,
                match coordinates - meshes_n {
                    0 => String::new(),
                    b => format!(" and {b} back-flank deflections"),
                }
            ));
        }
        let samples = options.samples.unwrap_or((16 * (2 * j_max + 1)).max(256));
        if samples <= 2 * j_max {
            return Err(format!(
                "samples = {samples}: must exceed twice the highest retained order {j_max} \
                 (sampling theorem)"
            ));
        }

        // Breakpoints of every mesh in θ: p_n(θ) = p_n(0) + c_n θ ≡ b (mod 1), each cycle's
        // knot where it really lies (a runout moves it by a fraction of a cell:
        // [`Drivetrain::mesh_knot_phase`]; a rule across a jump errs by the jump times the
        // part of the cell beyond it).
        let mut breaks = vec![0.0, 1.0];
        for (n, mesh) in meshes.iter().enumerate() {
            let p0 = model.mesh_phase(n, 0.0);
            for b in model.mesh_breakpoints(n) {
                let first = crate::mesh::cycle_fraction(b - p0);
                for k in 0..mesh.cycles as u64 {
                    let nominal = p0 + first + k as f64;
                    let shift = model.mesh_knot_phase(n, nominal) - nominal;
                    let theta = ((first + k as f64 + shift) / mesh.cycles).rem_euclid(1.0);
                    if theta > 0.0 && theta < 1.0 {
                        breaks.push(theta);
                    }
                }
            }
        }
        breaks.sort_by(f64::total_cmp);
        breaks.dedup_by(|x, y| (*x - *y).abs() < 1e-14);
        let mut cells = Vec::new();
        let mut cell_at_break = Vec::new();
        let mut nodes = Vec::with_capacity(samples + 3 * breaks.len());
        let mut weights = Vec::with_capacity(samples + 3 * breaks.len());
        for w in breaks.windows(2) {
            let (lo, hi) = (w[0], w[1]);
            let count = ((samples as f64 / 3.0) * (hi - lo)).ceil().max(1.0) as usize;
            let h = (hi - lo) / count as f64;
            for c in 0..count {
                let mid = lo + (c as f64 + 0.5) * h;
                cells.push((mid - 0.5 * h, mid + 0.5 * h));
                cell_at_break.push(c == 0);
                for (x, wt) in GAUSS3 {
                    nodes.push(mid + 0.5 * h * x);
                    weights.push(0.5 * h * wt);
                }
            }
        }

        let mut problem = Problem {
            model,
            settings,
            f,
            speed_per_f: 0.0,
            m,
            meshes,
            a,
            v,
            mass: lin.mass,
            damping,
            stiffness,
            order_rates: orders.iter().map(|&j| TAU * j as f64).collect(),
            orders,
            len,
            cells,
            nodes,
            weights,
            table: None,
            cell_at_break,
            switching: false,
            node_laws: Vec::new(),
            max_step: 1,
            sums: Vec::new(),
            plus: Vec::new(),
            minus: Vec::new(),
            external: DMatrix::zeros(m, len),
            mesh_periods,
            subharmonic: options.subharmonic,
            x_scale: 0.0,
            receptance: None,
            scan: ScanGrid::new(&[0]),
            torus: None,
        };
        problem.speed_per_f = problem.model.input_speed() / f;
        // Displacement scale of convergence tests and of the arclength metric: the largest
        // static mesh deflection (static mesh force over mean stiffness), or the model's
        // displacement scale for an unloaded drivetrain.
        let deflection = problem
            .meshes
            .iter()
            .map(|mesh| (mesh.static_force / mesh.k_mean).abs())
            .filter(|x| x.is_finite())
            .fold(0.0, f64::max);
        problem.x_scale = if deflection > 0.0 {
            deflection
        } else {
            problem.model.displacement_scale()
        };
        problem.max_step = problem
            .orders
            .windows(2)
            .map(|w| w[1] - w[0])
            .max()
            .unwrap_or(1);
        if problem.nodes.len() * len <= TABLE_ENTRIES {
            let mut table = vec![0.0; problem.nodes.len() * len];
            for (i, &theta) in problem.nodes.iter().enumerate() {
                problem.basis(theta, &mut table[i * len..(i + 1) * len]);
            }
            problem.table = Some(table);
        }
        let mut buf = Vec::new();
        problem.switching = (0..meshes_n).any(|n| {
            problem.model.contact_gaps(n, 0.0, 0.0, 0.0, &mut buf);
            !buf.is_empty()
        });
        problem.build_sums();
        // Two mesh frequencies and nothing else: the sums on the torus (issue 38).
        if options.subharmonic == 1
            && options.basis == Basis::TotalOrder
            && options.samples.is_none()
            && bases.len() == meshes_n
        {
            problem.torus = Torus::new(&problem, &bases, options.harmonics);
        }
        problem.scan = ScanGrid::new(&problem.orders);
        // External force: sampled once (it depends on the mesh phase only, not on the speed).
        // On the torus (a two-frequency train, whose external force is its constant torques)
        // by uniform samples, not along the line grid's nodes, whose every basis row costs
        // `2|J|` entries (46 000 nodes × 841 on the countershaft at H = 20).
        let mut ext = vec![0.0; m];
        let mut external = DMatrix::zeros(m, len);
        if problem.torus.is_some() {
            let points = uniform_points(&problem.orders);
            let mut samples = vec![vec![0.0; points]; m];
            let instants = (0..points).map(|i| i as f64 / points as f64 / f);
            for (i, t) in instants.enumerate() {
                problem.model.external_force(t, &mut ext);
                for (k, e) in ext.iter().enumerate() {
                    samples[k][i] = *e;
                }
            }
            for (k, samples) in samples.iter().enumerate() {
                let c = uniform_coefficients(&problem.orders, samples);
                external.row_mut(k).copy_from_slice(&c);
            }
        } else {
            let mut row = vec![0.0; len];
            for (i, (&theta, &w)) in problem.nodes.iter().zip(&problem.weights).enumerate() {
                problem.model.external_force(theta / f, &mut ext);
                let phi = problem.node_row(i, &mut row);
                for (k, e) in ext.iter().enumerate() {
                    for r in 0..len {
                        external[(k, r)] += factor(r) * w * e * phi[r];
                    }
                }
            }
        }
        problem.external = external;
        Ok(problem)
    }

    /// Probe `k` (0: start, 1: end) of cell `c`, just inside the cell.
    pub(super) fn probe(&self, c: usize, k: usize) -> f64 {
        let (lo, hi) = self.cells[c];
        let eps = PROBE * (hi - lo);
        if k == 0 {
            lo + eps
        } else {
            hi - eps
        }
    }

    /// The basis row of node `i` (tabulated, or computed into `buf`).
    pub(super) fn node_row<'a>(&'a self, i: usize, buf: &'a mut [f64]) -> &'a [f64] {
        let len = self.len;
        match &self.table {
            Some(t) => &t[i * len..(i + 1) * len],
            None => {
                self.basis_fast(self.nodes[i], buf);
                buf
            }
        }
    }

    /// Basis row at `θ` by the angle-addition recurrence from one `sin_cos` (powers of
    /// `e^{2πiθ}` stepped through the sorted orders; rounding grows like the number of orders,
    /// ~1e-14 for hundreds).
    pub(super) fn basis_fast(&self, theta: f64, out: &mut [f64]) {
        let (s1, c1) = (TAU * theta.fract()).sin_cos();
        let z = Complex::new(c1, s1);
        let mut steps = [Complex::new(1.0, 0.0); 64];
        let mut pw = Vec::new();
        let powers: &mut [Complex<f64>] = if self.max_step < 64 {
            &mut steps[..=self.max_step]
        } else {
            pw.resize(self.max_step + 1, Complex::new(1.0, 0.0));
            &mut pw
        };
        for d in 1..powers.len() {
            powers[d] = powers[d - 1] * z;
        }
        out[0] = 1.0;
        let mut x = Complex::new(1.0, 0.0);
        let mut prev = 0;
        for (q, &j) in self.orders.iter().enumerate().skip(1) {
            x *= powers[j - prev];
            prev = j;
            out[2 * q - 1] = x.re;
            out[2 * q] = x.im;
        }
    }

    /// Basis row at `θ` (one `sin_cos` per order: exact to rounding).
    pub(super) fn basis(&self, theta: f64, out: &mut [f64]) {
        out[0] = 1.0;
        for (q, &j) in self.orders.iter().enumerate().skip(1) {
            let (s, c) = (TAU * (j as f64 * theta).fract()).sin_cos();
            out[2 * q - 1] = c;
            out[2 * q] = s;
        }
    }

    fn build_sums(&mut self) {
        let n = self.orders.len();
        let top = 2 * self.orders[n - 1] + 1;
        let mut position = vec![usize::MAX; top];
        let mut sums = Vec::new();
        let mut add = |d: usize, q: usize, p: usize, plus: bool, sums: &mut Vec<_>| {
            if position[d] == usize::MAX {
                position[d] = sums.len();
                sums.push((d, q, p, plus));
            }
            position[d]
        };
        // Orders that are retained themselves first (d = j + 0), exact from the table.
        for q in 0..n {
            add(self.orders[q], q, 0, true, &mut sums);
        }
        let mut plus = vec![0; n * n];
        let mut minus = vec![0; n * n];
        for q in 0..n {
            for p in 0..n {
                let (j, k) = (self.orders[q], self.orders[p]);
                plus[q * n + p] = add(j + k, q, p, true, &mut sums);
                minus[q * n + p] = if j >= k {
                    add(j - k, q, p, false, &mut sums)
                } else {
                    add(k - j, p, q, false, &mut sums)
                };
            }
        }
        self.sums = sums;
        self.plus = plus;
        self.minus = minus;
    }

    pub(super) fn outputs(&self) -> usize {
        self.v.ncols()
    }

    /// The condensed coordinates: every mesh's deflection `S_n`, then the back flanks' own
    /// deflections `S̃_n` ([`MeshData::back`]).
    pub(super) fn coordinates(&self) -> usize {
        self.a.ncols()
    }

    /// The coordinate output `k` of mesh `n` depends on: the back flanks' force (the last
    /// output of a mesh with a back row) on `S̃_n`, every other on `S_n`.
    pub(super) fn output_coordinate(&self, n: usize, k: usize) -> usize {
        let mesh = &self.meshes[n];
        match mesh.back {
            Some(c) if k + 1 == mesh.outputs => c,
            _ => n,
        }
    }

    /// The coordinate gap `q` of mesh `n` ([`Drivetrain::contact_gaps_with_back`]) is a
    /// function of: for a mesh with a back row the back gaps `δ̃_j + 2b` (odd `q`) of `S̃_n`,
    /// every other gap of `S_n`.
    pub(super) fn gap_coordinate(&self, n: usize, q: usize) -> usize {
        match self.meshes[n].back {
            Some(c) if q % 2 == 1 => c,
            _ => n,
        }
    }

    /// The mesh's total force from its law: the drive row's force, plus the back flanks'
    /// of a mesh with a back row (`<mesh>.force` of the time-domain outputs).
    #[inline]
    pub(super) fn total_force(&self, n: usize, law: &MeshLaw) -> f64 {
        let mesh = &self.meshes[n];
        match mesh.back {
            Some(_) => law.force[0] + law.force[mesh.outputs - 1],
            None => law.force[0],
        }
    }

    /// Sets the HB fundamental frequency (and the model's input speed).
    pub(super) fn set_frequency(&mut self, f: f64) -> Result<(), String> {
        if f != self.f {
            self.model.set_input_speed(0.0, f * self.speed_per_f)?;
            self.f = f;
        }
        Ok(())
    }

    pub(super) fn speed(&self, f: f64) -> f64 {
        f * self.speed_per_f
    }

    pub(super) fn frequency(&self, speed: f64) -> f64 {
        speed / self.speed_per_f
    }

    /// The condensed linear part at `f` (cached).
    pub(super) fn receptance(&mut self, f: f64) -> Result<(), String> {
        if self.receptance.as_ref().is_some_and(|r| r.f == f) {
            return Ok(());
        }
        let m = self.m;
        let outs = self.outputs();
        let nm = self.coordinates();
        let cm = |a: &DMatrix<f64>| a.map(|x| Complex::new(x, 0.0));
        let (mass, damping, stiffness) = (cm(&self.mass), cm(&self.damping), cm(&self.stiffness));
        let at = cm(&self.a.transpose());
        let mut rec = Receptance {
            f,
            lus: Vec::new(),
            r: Vec::new(),
            dr: Vec::new(),
            lin: Vec::new(),
            dlin: Vec::new(),
        };
        for (q, &j) in self.orders.iter().enumerate() {
            let w = TAU * j as f64;
            let i = Complex::new(0.0, 1.0);
            let z = &stiffness - &mass * Complex::from(w * w * f * f) + &damping * (i * w * f);
            let dz = &mass * Complex::from(-2.0 * w * w * f) + &damping * (i * w);
            let lu = z.lu();
            let mut rhs = DMatrix::zeros(m, outs + 1);
            for i in 0..m {
                for k in 0..outs {
                    rhs[(i, k)] = Complex::new(self.v[(i, k)], 0.0);
                }
                let (a, b) = if q == 0 {
                    (self.external[(i, 0)], 0.0)
                } else {
                    (self.external[(i, 2 * q - 1)], self.external[(i, 2 * q)])
                };
                rhs[(i, outs)] = Complex::new(a, -b);
            }
            let y = lu.solve(&rhs).ok_or_else(|| {
                format!(
                    "harmonic balance: the dynamic stiffness of order {j} at {:.6} Hz is \
                     singular (an undamped mode at that frequency)",
                    j as f64 * f
                )
            })?;
            let dy = -lu.solve(&(&dz * &y)).expect("same matrix");
            let ry = &at * &y;
            let rdy = &at * &dy;
            rec.r.push(ry.columns(0, outs).into_owned());
            rec.dr.push(rdy.columns(0, outs).into_owned());
            rec.lin.push(ry.column(outs).into_owned());
            rec.dlin.push(rdy.column(outs).into_owned());
            rec.lus.push(lu);
            debug_assert_eq!(ry.nrows(), nm);
        }
        self.receptance = Some(rec);
        Ok(())
    }

    /// Newton at frequency `f` from `s`: the iterate at which the Newton update falls below the
    /// tolerance, with its evaluation (node samples included), and the iteration count.
    pub(super) fn newton(
        &mut self,
        mut s: DVector<f64>,
        f: f64,
        options: &HbOptions,
    ) -> Result<(DVector<f64>, Evaluation, usize), String> {
        let speed = self.speed(f);
        let want = Want {
            jacobian: true,
            samples: true,
            ..Want::default()
        };
        // Large systems: on the torus Newton–Krylov (krylov.rs), else the chord method (the LU
        // kept while the updates shrink by ½ or more per iterate; docs/harmonic-balance.md
        // "Solver"); small ones: Newton as always.
        let chord = s.len() > CHORD_UNKNOWNS;
        let mut factored: Option<Factorised> = None;
        let mut frozen = FrozenJacobian::default();
        let mut previous = f64::INFINITY;
        for iteration in 1..=options.max_iterations {
            let krylov = chord && self.torus.is_some();
            let refresh = !krylov && (!chord || factored.is_none());
            let mut e = self.evaluate(
                &s,
                f,
                Want {
                    jacobian: refresh || (krylov && frozen.refresh),
                    linear: krylov,
                    ..want
                },
            )?;
            let delta = if krylov && self.torus.is_some() {
                if let Some(jacobian) = e.jacobian.take() {
                    frozen.factorise(jacobian);
                }
                self.krylov_solve(&(-&e.residual), &mut frozen)
                    .ok_or_else(|| {
                        format!("harmonic balance at {speed} rad/s: GMRES did not converge")
                    })?
            } else {
                if krylov {
                    // The torus declined (a contact switch it cannot bracket): the line
                    // quadrature's Jacobian from here on.
                    e = self.evaluate(&s, f, want)?;
                }
                if refresh || krylov {
                    factored = Some(Factorised::new(
                        e.jacobian.take().expect("asked for"),
                        chord,
                    ));
                }
                (factored.as_ref().expect("factorised"))
                    .solve(&(-&e.residual))
                    .ok_or_else(|| {
                        format!("harmonic balance at {speed} rad/s: singular Jacobian")
                    })?
            };
            let size = delta.amax();
            if size <= options.tolerance * self.x_scale {
                return Ok((s, e, iteration));
            }
            if !(size <= 0.5 * previous) {
                factored = None;
            }
            previous = size;
            s += &delta;
        }
        Err(format!(
            "harmonic balance at {speed} rad/s did not converge in {} Newton iterations",
            options.max_iterations
        ))
    }

    /// Mesh-deflection coefficients of full coordinate coefficients (one block per coordinate).
    pub(super) fn condense(&self, coefficients: &[f64]) -> Result<DVector<f64>, String> {
        let len = self.len;
        if coefficients.len() != self.m * len {
            return Err(format!(
                "guess has {} coefficients, expected {} ({} coordinates × {len})",
                coefficients.len(),
                self.m * len,
                self.m
            ));
        }
        let nm = self.coordinates();
        let mut s = DVector::zeros(nm * len);
        for n in 0..nm {
            for i in 0..self.m {
                let a = self.a[(i, n)];
                if a != 0.0 {
                    for r in 0..len {
                        s[n * len + r] += a * coefficients[i * len + r];
                    }
                }
            }
        }
        Ok(s)
    }

    /// A starting guess from the time domain: the response after a warm-up (at least
    /// [`SEED_WARMUP_PERIODS`] mesh periods, whole HB periods), sampled at the nodes and
    /// projected. Newton from the static deflection often stalls on the piecewise-smooth residual
    /// near resonance; the seed only selects the basin, the converged orbit is HB's own.
    pub(super) fn seed(&self, mut sim: Driver<M>) -> Result<DVector<f64>, String> {
        let period = 1.0 / self.f;
        let k = self.mesh_periods;
        let warm = (SEED_WARMUP_PERIODS.div_ceil(k) * k) as f64 / self.mesh_periods as f64 * period;
        let t0 = sim.t();
        let len = self.len;
        let nm = self.coordinates();
        let mut s = DVector::zeros(nm * len);
        if self.torus.is_some() {
            // On the torus: uniform samples and one FFT per coordinate, not the line grid's
            // nodes (each with a basis row of 2|J| entries).
            let points = uniform_points(&self.orders);
            let mut samples = vec![vec![0.0; points]; nm];
            for i in 0..points {
                sim.advance_to(t0 + warm + i as f64 / points as f64 * period)
                    .map_err(|e| format!("harmonic balance seed: {e}"))?;
                let y = sim.y();
                for (n, samples) in samples.iter_mut().enumerate() {
                    samples[i] = (0..self.m).map(|k| self.a[(k, n)] * y[k]).sum();
                }
            }
            for (n, samples) in samples.iter().enumerate() {
                let c = uniform_coefficients(&self.orders, samples);
                s.rows_mut(n * len, len).copy_from_slice(&c);
            }
            return Ok(s);
        }
        let mut order: Vec<usize> = (0..self.nodes.len()).collect();
        order.sort_by(|&a, &b| self.nodes[a].total_cmp(&self.nodes[b]));
        let mut row = vec![0.0; len];
        for i in order {
            sim.advance_to(t0 + warm + self.nodes[i] * period)
                .map_err(|e| format!("harmonic balance seed: {e}"))?;
            let y = sim.y();
            let phi = self.node_row(i, &mut row);
            for n in 0..nm {
                let x: f64 = (0..self.m).map(|k| self.a[(k, n)] * y[k]).sum();
                let w = self.weights[i] * x;
                for r in 0..len {
                    s[n * len + r] += factor(r) * w * phi[r];
                }
            }
        }
        Ok(s)
    }

    /// The orbit at `f` from the evaluation `e` (with node samples) of its converged mesh
    /// coefficients: every coordinate's coefficients `X_j = Z_j⁻¹ (F̂_j − Σ v g_j)`, and each
    /// mesh's results.
    pub(super) fn solution(&self, f: f64, e: &Evaluation, iterations: usize) -> HbSolution {
        let len = self.len;
        let m = self.m;
        let no = self.orders.len();
        let rec = self.receptance.as_ref().expect("evaluated");
        let mut coefficients = vec![0.0; m * len];
        for q in 0..no {
            // X_q = Z_q⁻¹ (F̂_q − Σ v g_q).
            let mut rhs = DVector::<Complex<f64>>::zeros(m);
            for i in 0..m {
                let (mut a, mut b) = if q == 0 {
                    (self.external[(i, 0)], 0.0)
                } else {
                    (self.external[(i, 2 * q - 1)], self.external[(i, 2 * q)])
                };
                for (out, g) in e.g.iter().enumerate() {
                    let v = self.v[(i, out)];
                    if q == 0 {
                        a -= v * g[0];
                    } else {
                        a -= v * g[2 * q - 1];
                        b -= v * g[2 * q];
                    }
                }
                rhs[i] = Complex::new(a, -b);
            }
            let x = rec.lus[q].solve(&rhs).expect("regular at this frequency");
            for i in 0..m {
                if q == 0 {
                    coefficients[i * len] = x[i].re;
                } else {
                    coefficients[i * len + 2 * q - 1] = x[i].re;
                    coefficients[i * len + 2 * q] = -x[i].im;
                }
            }
        }
        // The mesh-deflection coefficients S_n = a_n·ξ of the orbit (and S̃_n = ã_n·ξ).
        let mut s = DVector::zeros(self.coordinates() * len);
        for n in 0..self.coordinates() {
            for i in 0..m {
                let a = self.a[(i, n)];
                if a != 0.0 {
                    for r in 0..len {
                        s[n * len + r] += a * coefficients[i * len + r];
                    }
                }
            }
        }
        let meshes = (0..self.meshes.len())
            .map(|n| {
                let mut dte = vec![0.0; len];
                for i in 0..m {
                    let d = self.meshes[n].dte[i];
                    if d != 0.0 {
                        for r in 0..len {
                            dte[r] += d * coefficients[i * len + r];
                        }
                    }
                }
                self.mesh_response(n, f, &s, &dte, e)
            })
            .collect();
        HbSolution {
            mesh_frequency: self.meshes[0].cycles * f,
            subharmonic: self.subharmonic,
            mesh_periods: self.mesh_periods,
            orders: self.orders.clone(),
            coefficients,
            iterations,
            meshes,
            dte_rows: self.meshes.iter().map(|mesh| mesh.dte.clone()).collect(),
        }
    }
}
