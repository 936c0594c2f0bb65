//! Harmonic balance of any drivetrain ([`Drivetrain`]): Galerkin projection with alternating
//! frequency/time evaluation of the mesh forces and pseudo-arclength continuation in the input
//! speed (Cameron & Griffin 1989, J. Appl. Mech. 56:149–154; Krack & Gross, *Harmonic Balance
//! for Nonlinear Vibration Problems*, 2019, ch. 2–4; Liu 2007 §3.2.2, eqs. 3.3–3.8, with the
//! Newton sign of eq. 3.8 corrected and the tanh-smoothed contact of eqs. 3.5–3.6 replaced by
//! the exact law, as the notes §2.8 explain). The single pair is the one-coordinate case of
//! the same code.
//!
//! **Unknowns.** The orbit is periodic over the HB period `T = K·T_r`: the response period
//! `T_r` (the least common multiple of the mesh periods, [`crate::model::response_period`]) times
//! the subharmonic order `K`. In the phase `θ = t/T ∈ [0, 1)` every elastic coordinate is a
//! trigonometric polynomial `ξ(θ) = X_0 + Σ_{j∈J} A_j cos 2πjθ + B_j sin 2πjθ`. The retained
//! orders `J` are the combination tones `|Σ_n a_n Q_n|`, `Σ|a_n| ≤ H`, of the mesh frequencies
//! divided by `K` (`Q_n` mesh-n cycles per response period): for one mesh frequency (the single
//! pair, the idler train) the harmonics `1…H` of `f_m/K`; for the countershaft (`f_2/f_1 =
//! 19/72`) the tones `a f_1 + b f_2` up to order `H` instead of the 72·H harmonics of the
//! response frequency a full basis would need (harmonic selection, Krack & Gross §3.5).
//!
//! **Condensation.** The mesh forces depend on the state only through the mesh deflections
//! `S_n = a_n·ξ` ([`Drivetrain::mesh_law`]); the linear part, with each mesh's mean stiffness
//! and damping moved into it, is diagonal in the harmonics. Per order `j` the coordinates are
//! therefore `X_j = Z_j⁻¹ (F̂_j − Σ v_{n,k} G_{n,k,j})` with the dynamic stiffness
//! `Z_j = K̄ − (2πjf)² M + i 2πjf C̄` (`f = 1/T`), and the harmonic-balance equations reduce
//! exactly (no approximation) to the Fourier coefficients `s` of the mesh deflections:
//! `r(s) = s − Aᵀ Z⁻¹ F̂ + Aᵀ Z⁻¹ V g(s) = 0` (receptance condensation onto the nonlinear
//! coordinates, Krack & Gross §3.6). The Newton system is `n_mesh (2|J| − 1)` square instead of
//! `m (2|J| − 1)`: 16× smaller for the 8-DOF idler, whose two meshes carry all nonlinearity.
//! The coefficients of every coordinate are recovered from the converged `s`.
//!
//! **Galerkin projection.** `g = P[F(θ, S, Ṡ)] − k̄ s − c̄ Ṡ` is integrated by composite
//! 3-point Gauss rules on cells split at every stiffness/gap breakpoint of every mesh
//! ([`Drivetrain::mesh_breakpoints`]), so the jumps of a rectangular stiffness fall between
//! nodes; plain AFT (uniform samples, FFT) would alias them with an O(1/N) error no number of
//! harmonics removes. The contact law is evaluated exactly at the nodes (no tanh smoothing);
//! a cell in which a tooth pair's contact changes is split at the switching instants (roots of
//! [`Drivetrain::contact_gaps`] on the trigonometric polynomial) and each part integrated by
//! its own rule, so the residual stays continuous in `s` although the mesh damping jumps at
//! total contact loss; the moving split point adds the boundary term `ΔF/δ_θ · φ(θ*) φ(θ*)ᵀ`
//! to the Jacobian (Leibniz rule, `∂θ*/∂s = −φ(θ*)/δ_θ`). The contact kinks make the
//! coefficients decay algebraically, which the error tables against shooting show.
//!
//! **Jacobian.** `∂P[k(θ)S]/∂s` is the Toeplitz-plus-Hankel matrix of the quadrature Fourier
//! coefficients of `k(θ) = ∂F/∂S` at the sums and differences of the retained orders (the
//! product-to-sum identities hold node by node, so it is exact for the discrete residual): one
//! pass over the nodes per signal instead of a dense `PΓ` product.
//!
//! **Stability.** Floquet multipliers of each continued orbit are the eigenvalues of the
//! shooting monodromy (with saltation at contact changes, [`PeriodMap`]) started from the HB
//! state at `t = 0`; they are accurate to the truncation error of the orbit.

use std::collections::BTreeSet;
use std::f64::consts::TAU;

use nalgebra::{Complex, DMatrix, DVector, Dyn, LU};

use super::shooting::PeriodMap;
use crate::model::drivetrain::response_period_in_mesh_periods;
use crate::model::{Drivetrain, MeshLaw, SceneSource};
use crate::scene::SolverSettings;
use crate::simulation::Driver;
use crate::with_drivetrain;

/// Settings of the harmonic balance.
#[derive(Debug, Clone)]
pub struct HbOptions {
    /// Order H of the retained combination tones of the mesh frequencies (divided by the
    /// subharmonic order): for one mesh frequency the harmonics `1…H` of `f_m/K`.
    pub harmonics: usize,
    /// Subharmonic order K: the HB period in response periods.
    pub subharmonic: u32,
    /// Quadrature nodes per HB period (about); default `max(16·(2j_max + 1), 256)`, `j_max`
    /// the highest retained order.
    pub samples: Option<usize>,
    /// Newton stops when the update is below `tolerance` × the displacement scale.
    pub tolerance: f64,
    pub max_iterations: usize,
}

impl HbOptions {
    pub fn new(harmonics: usize) -> Self {
        HbOptions {
            harmonics,
            subharmonic: 1,
            samples: None,
            tolerance: 1e-12,
            max_iterations: 50,
        }
    }

    fn validate(&self) -> Result<(), String> {
        if self.harmonics == 0 {
            return Err("harmonics = 0: at least one harmonic is needed".into());
        }
        if self.subharmonic == 0 {
            return Err("subharmonic = 0: the response period is at least one mesh period".into());
        }
        if !(self.tolerance > 0.0) {
            return Err(format!("tolerance = {}: must be > 0", self.tolerance));
        }
        Ok(())
    }
}

/// The steady-state response of one mesh on a harmonic-balance orbit.
#[derive(Debug, Clone, PartialEq)]
pub struct HbMesh {
    /// Column prefix ([`Drivetrain::mesh_prefix`]).
    pub prefix: String,
    /// Mesh frequency, Hz.
    pub mesh_frequency: f64,
    /// Mean DTE, m (from the coefficients through the DTE row).
    pub dte_mean: f64,
    /// RMS of the DTE with the mean removed, m (Parseval).
    pub dte_rms: f64,
    /// Amplitudes of the first and second harmonics of this mesh's frequency in its DTE, m
    /// (0 when the order is not retained).
    pub harmonics: [f64; 2],
    /// Largest |mesh force| at the quadrature nodes, N.
    pub peak_force: f64,
    /// RMS of the mesh force with its mean removed (quadrature), N.
    pub force_rms: f64,
    /// Peak force over the static mesh force ([`Drivetrain::static_mesh_forces`]).
    pub dynamic_factor: f64,
    /// Fraction of the HB period with no tooth pair in contact (quadrature of the node
    /// samples, the cells split at the switching instants).
    pub contact_loss_fraction: f64,
}

/// A harmonic-balance orbit.
#[derive(Debug, Clone)]
pub struct HbSolution {
    /// Mesh frequency of the first mesh, Hz.
    pub mesh_frequency: f64,
    pub subharmonic: u32,
    /// The HB period in mesh periods of the first mesh (response period × subharmonic).
    pub mesh_periods: u64,
    /// Retained orders `j` (multiples of `1/T`), the first 0.
    pub orders: Vec<usize>,
    /// Fourier coefficients of every elastic coordinate, one block per coordinate:
    /// `[X_0, A_{j1}, B_{j1}, …]` over [`HbSolution::orders`]. For the single pair one block,
    /// `[a_0, a_1, b_1, …, a_H, b_H]` of the DTE, m.
    pub coefficients: Vec<f64>,
    pub iterations: usize,
    /// Results per mesh.
    pub meshes: Vec<HbMesh>,
    /// DTE row of each mesh over the coordinates ([`Drivetrain::mesh_dte_row`]).
    pub dte_rows: Vec<Vec<f64>>,
}

impl HbSolution {
    fn block(&self) -> usize {
        2 * self.orders.len() - 1
    }

    /// Number of elastic coordinates.
    pub fn coordinates(&self) -> usize {
        self.coefficients.len() / self.block()
    }

    /// Coordinate `i` and its derivative in `τ` at `τ` mesh cycles of the first mesh after
    /// `t = 0`.
    pub fn coordinate(&self, i: usize, tau: f64) -> (f64, f64) {
        let k = self.mesh_periods as f64;
        let theta = tau / k;
        let c = &self.coefficients[i * self.block()..(i + 1) * self.block()];
        let mut x = c[0];
        let mut dx = 0.0;
        for (q, &j) in self.orders.iter().enumerate().skip(1) {
            let w = TAU * j as f64;
            let (s, co) = (w * theta).sin_cos();
            let (a, b) = (c[2 * q - 1], c[2 * q]);
            x += a * co + b * s;
            dx += w * (-a * s + b * co);
        }
        (x, dx / k)
    }

    /// Mesh `n`'s DTE `τ` mesh cycles of the first mesh after `t = 0`, m.
    pub fn dte(&self, n: usize, tau: f64) -> f64 {
        (self.dte_rows[n].iter().enumerate())
            .filter(|(_, &d)| d != 0.0)
            .map(|(i, d)| d * self.coordinate(i, tau).0)
            .sum()
    }

    /// `(x, dx/dτ)` of the first coordinate (the DTE of a single pair).
    pub fn displacement(&self, tau: f64) -> (f64, f64) {
        self.coordinate(0, tau)
    }

    /// The state `[ξ, ξ']` (ξ' per second) `τ` mesh cycles of the first mesh after `t = 0`.
    pub fn state_at(&self, tau: f64) -> Vec<f64> {
        let m = self.coordinates();
        let mut y = vec![0.0; 2 * m];
        for i in 0..m {
            let (x, dx) = self.coordinate(i, tau);
            y[i] = x;
            y[m + i] = dx * self.mesh_frequency;
        }
        y
    }
}

/// One mesh of the discretised problem.
#[derive(Debug, Clone)]
struct MeshData {
    prefix: String,
    dte: Vec<f64>,
    /// Index of its first force output among all outputs, and how many it has.
    first: usize,
    outputs: usize,
    k_mean: f64,
    c_mean: f64,
    /// Mesh cycles per HB period.
    cycles: f64,
    static_force: f64,
}

/// Per-order data of the condensed linear part at one frequency.
struct Receptance {
    f: f64,
    lus: Vec<LU<Complex<f64>, Dyn, Dyn>>,
    /// `Aᵀ Z_j⁻¹ V` (meshes × outputs) and its frequency derivative.
    r: Vec<DMatrix<Complex<f64>>>,
    dr: Vec<DMatrix<Complex<f64>>>,
    /// `Aᵀ Z_j⁻¹ F̂_j` and its derivative.
    lin: Vec<DVector<Complex<f64>>>,
    dlin: Vec<DVector<Complex<f64>>>,
}

/// What an evaluation computes besides the residual.
#[derive(Debug, Clone, Copy, Default)]
struct Want {
    jacobian: bool,
    frequency: bool,
    samples: bool,
}

/// Sums over the quadrature nodes.
struct Accumulator {
    /// `Σ w F φ` per output.
    gal: Vec<Vec<f64>>,
    /// `Σ w F_viscous φ` per output.
    visc: Vec<Vec<f64>>,
    /// `Σ w ∂F/∂S (cos, sin)(2πdθ)` and the same of `∂F/∂Ṡ`, per output, over the orders of
    /// [`Problem::sums`].
    kap_s: Vec<Vec<f64>>,
    kap_v: Vec<Vec<f64>>,
    /// Boundary terms `(output, coefficient, φ(θ*))` of the split points.
    boundary: Vec<(usize, f64, Vec<f64>)>,
    /// Node samples for the results: weight, and per mesh the mesh force and whether it has
    /// lost contact on every tooth pair.
    sample_w: Vec<f64>,
    sample_force: Vec<f64>,
    sample_lost: Vec<bool>,
    /// Scratch: `(cos, sin)(2πdθ)` of the node over [`Problem::sums`].
    trig: Vec<f64>,
}

/// The result of one evaluation.
struct Evaluation {
    residual: DVector<f64>,
    jacobian: Option<DMatrix<f64>>,
    /// `∂r/∂f`.
    d_frequency: Option<DVector<f64>>,
    /// `g` per output (the Galerkin coefficients of the force minus the moved linear part).
    g: Vec<DVector<f64>>,
    /// Node samples ([`Accumulator::sample_w`]), when asked for.
    sample_w: Vec<f64>,
    sample_force: Vec<f64>,
    sample_lost: Vec<bool>,
}

/// The discretised harmonic-balance problem of a drivetrain.
struct Problem<M: Drivetrain> {
    model: M,
    settings: SolverSettings,
    /// HB fundamental frequency the model is set to, Hz.
    f: f64,
    /// Input speed per Hz of `f`.
    speed_per_f: f64,
    m: usize,
    meshes: Vec<MeshData>,
    /// Mesh deflection rows (m × meshes) and force directions (m × outputs).
    a: DMatrix<f64>,
    v: DMatrix<f64>,
    mass: DMatrix<f64>,
    damping: DMatrix<f64>,
    stiffness: DMatrix<f64>,
    orders: Vec<usize>,
    /// `2|J| − 1`.
    len: usize,
    cells: Vec<(f64, f64)>,
    nodes: Vec<f64>,
    weights: Vec<f64>,
    /// Basis rows `[1, cos 2πjθ, sin 2πjθ, …]` of the nodes and of two probes per cell (just
    /// inside its ends), when they fit in [`TABLE_ENTRIES`]; else rows are computed as needed.
    table: Option<Vec<f64>>,
    /// Whether a cell starts at a breakpoint (where the engaged tooth pairs change).
    cell_at_break: Vec<bool>,
    /// Whether any mesh's contact law switches (else no cell is ever split).
    switching: bool,
    /// Scratch: every mesh's law at every node.
    node_laws: Vec<MeshLaw>,
    /// Largest gap between consecutive retained orders.
    max_step: usize,
    /// Orders `d` of the sums and differences of retained orders, each with a pair `(q, p, +)`
    /// of retained-order indices whose sum (`+`) or difference it is.
    sums: Vec<(usize, usize, usize, bool)>,
    /// Per (q, p): positions in `sums` of `j_q + j_p` and `|j_q − j_p|`.
    plus: Vec<usize>,
    minus: Vec<usize>,
    /// Galerkin coefficients of `F̂` (m × len).
    external: DMatrix<f64>,
    /// HB period in mesh periods of the first mesh.
    mesh_periods: u64,
    x_scale: f64,
    receptance: Option<Receptance>,
}

/// 3-point Gauss–Legendre rule on [−1, 1]: (node, weight).
const GAUSS3: [(f64, f64); 3] = [
    (-0.774_596_669_241_483_4, 5.0 / 9.0),
    (0.0, 8.0 / 9.0),
    (0.774_596_669_241_483_4, 5.0 / 9.0),
];

/// Largest number of tabulated basis entries (32 MB); larger problems (a
/// countershaft's many combination tones over 72 mesh periods) compute rows as needed.
const TABLE_ENTRIES: usize = 1 << 22;

/// Probes sit this fraction of a cell inside its ends (the ends are breakpoints, where the
/// engaged tooth pairs change).
const PROBE: f64 = 1e-9;

/// The retained orders: 0 and the combination tones `|Σ a_n b_n|` of the distinct base orders
/// `b_n` whose constituent frequencies add up to at most `h` times the highest base:
/// `Σ |a_n| b_n ≤ h·max b`. For one base order `b` these are the harmonics `b, 2b, …, hb`; a
/// slow mesh keeps as many harmonics as fit below `h` times the fastest mesh frequency (the
/// countershaft's second stage, at 19/72 of the first, keeps `3.8h`: its high harmonics are
/// what excites the modes above it).
fn combination_orders(bases: &[usize], h: usize) -> Vec<usize> {
    fn walk(bases: &[usize], budget: usize, acc: i64, out: &mut BTreeSet<usize>) {
        match bases.split_first() {
            None => {
                out.insert(acc.unsigned_abs() as usize);
            }
            Some((&b, rest)) => {
                let most = (budget / b) as i64;
                for a in -most..=most {
                    let used = a.unsigned_abs() as usize * b;
                    walk(rest, budget - used, acc + a * b as i64, out);
                }
            }
        }
    }
    let mut distinct: Vec<usize> = bases.to_vec();
    distinct.sort_unstable();
    distinct.dedup();
    let top = *distinct.last().expect("one mesh at least");
    let mut out = BTreeSet::new();
    walk(&distinct, h * top, 0, &mut out);
    out.into_iter().collect()
}

/// `(cos, sin)` of order index `q` from a basis row.
#[inline]
fn cs(phi: &[f64], q: usize) -> (f64, f64) {
    if q == 0 {
        (1.0, 0.0)
    } else {
        (phi[2 * q - 1], phi[2 * q])
    }
}

/// Projection factor of coefficient row `r`: 1 for the mean, 2 for a harmonic.
#[inline]
fn factor(r: usize) -> f64 {
    if r == 0 {
        1.0
    } else {
        2.0
    }
}

/// `R·(a − ib)` in the real layout `(a, b)` → `(a', b')`.
#[inline]
fn cmul(r: Complex<f64>, a: f64, b: f64) -> (f64, f64) {
    (r.re * a + r.im * b, -r.im * a + r.re * b)
}

impl<M: Drivetrain> Problem<M> {
    fn new(model: M, settings: SolverSettings, options: &HbOptions) -> Result<Self, String> {
        options.validate()?;
        let meshes_n = model.mesh_count();
        let freqs: Vec<f64> = (0..meshes_n).map(|n| model.mesh_frequency(n)).collect();
        if !(freqs[0] > 0.0 && freqs[0].is_finite()) {
            return Err(format!(
                "input speed {} rad/s: harmonic balance needs a finite speed > 0",
                model.input_speed()
            ));
        }
        let k_resp = response_period_in_mesh_periods(&freqs)?;
        let mesh_periods = k_resp * options.subharmonic as u64;
        let period = mesh_periods as f64 / freqs[0];
        let f = 1.0 / period;
        let m = model.dim() / 2;
        let statics = model.static_mesh_forces();
        let mut meshes = Vec::with_capacity(meshes_n);
        let mut a = DMatrix::zeros(m, meshes_n);
        let mut directions: Vec<Vec<f64>> = Vec::new();
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
            let dirs = model.mesh_force_directions(n);
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
            });
            directions.extend(dirs);
            bases.push(rounded as usize / options.subharmonic as usize);
        }
        let v = DMatrix::from_fn(m, directions.len(), |i, k| directions[k][i]);
        let lin = model.linear_part();
        let (mut stiffness, mut damping) = (lin.stiffness, lin.damping);
        for (n, mesh) in meshes.iter().enumerate() {
            let col = a.column(n);
            stiffness += mesh.k_mean * col * col.transpose();
            damping += mesh.c_mean * col * col.transpose();
        }

        let orders = combination_orders(&bases, options.harmonics);
        let j_max = *orders.last().expect("order 0");
        let len = 2 * orders.len() - 1;
        let samples = options.samples.unwrap_or((16 * (2 * j_max + 1)).max(256));
        if samples <= 2 * j_max {
            return Err(format!(
                "samples = {samples}: must exceed twice the highest retained order {j_max} \
                 (sampling theorem)"
            ));
        }

        // Breakpoints of every mesh in θ: p_n(θ) = p_n(0) + c_n θ ≡ b (mod 1).
        let mut breaks = vec![0.0, 1.0];
        for (n, mesh) in meshes.iter().enumerate() {
            let p0 = model.mesh_phase(n, 0.0);
            for b in model.mesh_breakpoints(n) {
                let first = crate::mesh::cycle_fraction(b - p0);
                for k in 0..mesh.cycles as u64 {
                    let theta = (first + k as f64) / mesh.cycles;
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
            x_scale: 0.0,
            receptance: None,
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
        // External force: sampled once (it depends on the mesh phase only, not on the speed).
        let mut ext = vec![0.0; m];
        let mut external = DMatrix::zeros(m, len);
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
        problem.external = external;
        Ok(problem)
    }

    /// Probe `k` (0: start, 1: end) of cell `c`, just inside the cell.
    fn probe(&self, c: usize, k: usize) -> f64 {
        let (lo, hi) = self.cells[c];
        let eps = PROBE * (hi - lo);
        if k == 0 {
            lo + eps
        } else {
            hi - eps
        }
    }

    /// The basis row of node `i` (tabulated, or computed into `buf`).
    fn node_row<'a>(&'a self, i: usize, buf: &'a mut [f64]) -> &'a [f64] {
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
    fn basis_fast(&self, theta: f64, out: &mut [f64]) {
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
    fn basis(&self, theta: f64, out: &mut [f64]) {
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

    fn outputs(&self) -> usize {
        self.v.ncols()
    }

    /// Sets the HB fundamental frequency (and the model's input speed).
    fn set_frequency(&mut self, f: f64) -> Result<(), String> {
        if f != self.f {
            self.model.set_input_speed(0.0, f * self.speed_per_f)?;
            self.f = f;
        }
        Ok(())
    }

    fn speed(&self, f: f64) -> f64 {
        f * self.speed_per_f
    }

    fn frequency(&self, speed: f64) -> f64 {
        speed / self.speed_per_f
    }

    /// The condensed linear part at `f` (cached).
    fn receptance(&mut self, f: f64) -> Result<(), String> {
        if self.receptance.as_ref().is_some_and(|r| r.f == f) {
            return Ok(());
        }
        let m = self.m;
        let outs = self.outputs();
        let nm = self.meshes.len();
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

    /// `(S, dS/dθ)` of mesh `n` from the basis row.
    #[inline]
    fn deflection(&self, s: &DVector<f64>, n: usize, phi: &[f64]) -> (f64, f64) {
        let base = n * self.len;
        let mut x = s[base];
        let mut dx = 0.0;
        for (q, &j) in self.orders.iter().enumerate().skip(1) {
            let (a, b) = (s[base + 2 * q - 1], s[base + 2 * q]);
            let (c, sn) = (phi[2 * q - 1], phi[2 * q]);
            x += a * c + b * sn;
            dx += TAU * j as f64 * (b * c - a * sn);
        }
        (x, dx)
    }

    /// Every mesh's law at `θ` for the coefficients `s` (`phi` the basis row at `θ`).
    fn laws_at(&self, theta: f64, phi: &[f64], s: &DVector<f64>, out: &mut [MeshLaw]) {
        let t = theta / self.f;
        for (n, law) in out.iter_mut().enumerate() {
            let (x, dx) = self.deflection(s, n, phi);
            *law = self.model.mesh_law(n, t, x, self.f * dx);
        }
    }

    /// Adds one quadrature node (weight `w`, basis row `phi`, every mesh's law) to the sums.
    fn accumulate(&self, w: f64, phi: &[f64], laws: &[MeshLaw], want: Want, acc: &mut Accumulator) {
        let mut trig_ready = false;
        if want.samples {
            acc.sample_w.push(w);
            acc.sample_force.extend(laws.iter().map(|l| l.force[0]));
            acc.sample_lost
                .extend(laws.iter().map(|l| l.in_contact == 0));
        }
        for (mesh, law) in self.meshes.iter().zip(laws) {
            for k in 0..mesh.outputs {
                let out = mesh.first + k;
                let fw = w * law.force[k];
                if fw != 0.0 {
                    for (g, p) in acc.gal[out].iter_mut().zip(phi) {
                        *g += fw * p;
                    }
                }
                if want.frequency && law.viscous[k] != 0.0 {
                    let vw = w * law.viscous[k];
                    for (g, p) in acc.visc[out].iter_mut().zip(phi) {
                        *g += vw * p;
                    }
                }
                if !want.jacobian {
                    continue;
                }
                let (ks, kv) = (w * law.stiffness[k], w * law.damping[k]);
                if (ks != 0.0 || kv != 0.0) && !trig_ready {
                    // (cos, sin)(2πdθ) of the sums and differences from the row.
                    for (i, &(_, q, p, plus)) in self.sums.iter().enumerate() {
                        let (cq, sq) = cs(phi, q);
                        let (cp, sp) = cs(phi, p);
                        let (c, s) = if plus {
                            (cq * cp - sq * sp, sq * cp + cq * sp)
                        } else {
                            (cq * cp + sq * sp, sq * cp - cq * sp)
                        };
                        acc.trig[2 * i] = c;
                        acc.trig[2 * i + 1] = s;
                    }
                    trig_ready = true;
                }
                if ks != 0.0 {
                    for (g, c) in acc.kap_s[out].iter_mut().zip(&acc.trig) {
                        *g += ks * c;
                    }
                }
                if kv != 0.0 {
                    for (g, c) in acc.kap_v[out].iter_mut().zip(&acc.trig) {
                        *g += kv * c;
                    }
                }
            }
        }
    }

    /// Gap `q` of mesh `n` and its θ-derivative at `θ`.
    fn gap(
        &self,
        s: &DVector<f64>,
        (n, q): (usize, usize),
        theta: f64,
        phi: &mut [f64],
        buf: &mut Vec<(f64, f64)>,
    ) -> (f64, f64) {
        self.basis_fast(theta, phi);
        let (x, dx) = self.deflection(s, n, phi);
        self.model
            .contact_gaps(n, theta / self.f, x, self.f * dx, buf);
        buf.get(q).map_or((0.0, 0.0), |g| (g.0, g.1 / self.f))
    }

    /// The root of gap `q` of mesh `n` in `(lo, hi)`, where it changes sign (Illinois variant
    /// of regula falsi: superlinear and bracketing).
    fn root(
        &self,
        s: &DVector<f64>,
        which: (usize, usize),
        (mut lo, mut hi): (f64, f64),
        phi: &mut [f64],
        buf: &mut Vec<(f64, f64)>,
    ) -> f64 {
        let mut glo = self.gap(s, which, lo, phi, buf).0;
        let mut ghi = self.gap(s, which, hi, phi, buf).0;
        let positive_lo = glo > 0.0;
        let mut side = 0i8;
        for _ in 0..200 {
            if hi - lo <= 4.0 * f64::EPSILON * hi.abs().max(1e-3) {
                break;
            }
            let mut mid = if glo != ghi {
                (lo * ghi - hi * glo) / (ghi - glo)
            } else {
                0.5 * (lo + hi)
            };
            if !(mid > lo && mid < hi) {
                mid = 0.5 * (lo + hi);
            }
            let g = self.gap(s, which, mid, phi, buf).0;
            if g == 0.0 {
                return mid;
            }
            if (g > 0.0) == positive_lo {
                lo = mid;
                glo = g;
                if side == -1 {
                    ghi *= 0.5;
                }
                side = -1;
            } else {
                hi = mid;
                ghi = g;
                if side == 1 {
                    glo *= 0.5;
                }
                side = 1;
            }
        }
        0.5 * (lo + hi)
    }

    /// A cell in which some contact changes: split at the switching instants, each part
    /// integrated by its own Gauss rule, boundary terms recorded for the Jacobian.
    fn split_cell(&self, c: usize, s: &DVector<f64>, want: Want, acc: &mut Accumulator) {
        let (lo, hi) = self.cells[c];
        let len = self.len;
        let nm = self.meshes.len();
        let mut points = [self.probe(c, 0), 0.0, 0.0, 0.0, self.probe(c, 1)];
        points[1..4].copy_from_slice(&self.nodes[3 * c..3 * c + 3]);
        let mut phi = vec![0.0; len];
        let mut buf = Vec::new();
        let mut cuts: Vec<(f64, usize, usize)> = Vec::new();
        let mut gaps: Vec<Vec<f64>> = vec![Vec::new(); points.len()];
        for n in 0..nm {
            for (k, &theta) in points.iter().enumerate() {
                self.basis_fast(theta, &mut phi);
                let (x, dx) = self.deflection(s, n, &phi);
                self.model
                    .contact_gaps(n, theta / self.f, x, self.f * dx, &mut buf);
                gaps[k].clear();
                gaps[k].extend(buf.iter().map(|g| g.0));
            }
            for k in 0..points.len() - 1 {
                for (q, (a, b)) in gaps[k].iter().zip(&gaps[k + 1]).enumerate() {
                    if (*a > 0.0) != (*b > 0.0) {
                        let bracket = (points[k], points[k + 1]);
                        let root = self.root(s, (n, q), bracket, &mut phi, &mut buf);
                        cuts.push((root, n, q));
                    }
                }
            }
        }
        cuts.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut laws = vec![MeshLaw::default(); nm];
        let mut start = lo;
        for end in cuts.iter().map(|c| c.0).chain(std::iter::once(hi)) {
            let half = 0.5 * (end - start);
            if half > 0.0 {
                for (x, wt) in GAUSS3 {
                    let theta = start + half * (1.0 + x);
                    self.basis_fast(theta, &mut phi);
                    self.laws_at(theta, &phi, s, &mut laws);
                    self.accumulate(half * wt, &phi, &laws, want, acc);
                }
            }
            start = end;
        }
        if !want.jacobian {
            return;
        }
        let eps = PROBE * (hi - lo);
        for &(theta, n, q) in &cuts {
            let mesh = &self.meshes[n];
            let delta_theta = self.gap(s, (n, q), theta, &mut phi, &mut buf).1;
            if delta_theta == 0.0 {
                continue;
            }
            let h = 1e-3 * eps.max(1e-14);
            let mut law_at = |theta: f64| {
                self.basis_fast(theta, &mut phi);
                let (x, dx) = self.deflection(s, n, &phi);
                self.model.mesh_law(n, theta / self.f, x, self.f * dx)
            };
            let (left, right) = (law_at(theta - h), law_at(theta + h));
            self.basis_fast(theta, &mut phi);
            for k in 0..mesh.outputs {
                // Only the jump counts: remove the continuous part's change over 2h.
                let slope = 0.5 * (right.stiffness[k] + left.stiffness[k]) * delta_theta;
                let jump = right.force[k] - left.force[k] - slope * 2.0 * h;
                if jump.abs() <= 1e-9 * (right.force[k].abs() + left.force[k].abs()) {
                    continue;
                }
                acc.boundary
                    .push((mesh.first + k, jump / delta_theta, phi.clone()));
            }
        }
    }

    /// Residual and what `want` asks for at coefficients `s` and frequency `f`.
    fn evaluate(&mut self, s: &DVector<f64>, f: f64, want: Want) -> Result<Evaluation, String> {
        self.set_frequency(f)?;
        self.receptance(f)?;
        let len = self.len;
        let outs = self.outputs();
        let nm = self.meshes.len();
        let ns = self.sums.len();
        let zeros = |n: usize, on: bool| {
            if on {
                vec![vec![0.0; n]; outs]
            } else {
                Vec::new()
            }
        };
        let mut acc = Accumulator {
            gal: zeros(len, true),
            visc: zeros(len, want.frequency),
            kap_s: zeros(2 * ns, want.jacobian),
            kap_v: zeros(2 * ns, want.jacobian),
            boundary: Vec::new(),
            sample_w: Vec::new(),
            sample_force: Vec::new(),
            sample_lost: Vec::new(),
            trig: vec![0.0; 2 * ns],
        };
        // Pass 1: every mesh's law at every node.
        let nodes = self.nodes.len();
        let mut laws = std::mem::take(&mut self.node_laws);
        laws.resize(nodes * nm, MeshLaw::default());
        let mut row = vec![0.0; len];
        for i in 0..nodes {
            let phi = self.node_row(i, &mut row);
            self.laws_at(self.nodes[i], phi, s, &mut laws[i * nm..(i + 1) * nm]);
        }
        // Cells in which a contact pattern changes: between two nodes of a cell, between the
        // last node of a cell and the first of the next (both cells are split; the one without
        // the switch integrates as before), or between a breakpoint and its nearest node (a
        // probe just inside the cell).
        let cells = self.cells.len();
        let mut split = vec![false; cells];
        if self.switching {
            let differ = |i: usize, j: usize| {
                (0..nm).any(|n| laws[i * nm + n].pattern != laws[j * nm + n].pattern)
            };
            let mut probe = vec![MeshLaw::default(); nm];
            for c in 0..cells {
                if differ(3 * c, 3 * c + 1) || differ(3 * c + 1, 3 * c + 2) {
                    split[c] = true;
                }
                if c + 1 < cells && !self.cell_at_break[c + 1] && differ(3 * c + 2, 3 * c + 3) {
                    split[c] = true;
                    split[c + 1] = true;
                }
                for (k, node, at_break) in [
                    (0, 3 * c, self.cell_at_break[c]),
                    (1, 3 * c + 2, c + 1 == cells || self.cell_at_break[c + 1]),
                ] {
                    if at_break && !split[c] {
                        let theta = self.probe(c, k);
                        self.basis_fast(theta, &mut row);
                        self.laws_at(theta, &row, s, &mut probe);
                        if (0..nm).any(|n| probe[n].pattern != laws[node * nm + n].pattern) {
                            split[c] = true;
                        }
                    }
                }
            }
        }
        // Pass 2: the sums.
        for (c, &split) in split.iter().enumerate() {
            if split {
                self.split_cell(c, s, want, &mut acc);
                continue;
            }
            for i in 3 * c..3 * c + 3 {
                let phi = self.node_row(i, &mut row);
                self.accumulate(
                    self.weights[i],
                    phi,
                    &laws[i * nm..(i + 1) * nm],
                    want,
                    &mut acc,
                );
            }
        }
        self.node_laws = laws;

        // g per output: P[F] minus the moved linear part (exact in the coefficients).
        let mut g: Vec<DVector<f64>> = acc
            .gal
            .iter()
            .map(|gal| DVector::from_fn(len, |r, _| factor(r) * gal[r]))
            .collect();
        let derivative = |x: &[f64]| -> DVector<f64> {
            // d/dθ on the coefficients: (a, b) → 2πj (b, −a).
            let mut d = DVector::zeros(len);
            for (q, &j) in self.orders.iter().enumerate().skip(1) {
                let w = TAU * j as f64;
                d[2 * q - 1] = w * x[2 * q];
                d[2 * q] = -w * x[2 * q - 1];
            }
            d
        };
        let mut ds = Vec::with_capacity(nm);
        for (n, mesh) in self.meshes.iter().enumerate() {
            let sn = s.rows(n * len, len);
            let d = derivative(sn.as_slice());
            g[mesh.first] -= sn * mesh.k_mean + &d * (mesh.c_mean * f);
            ds.push(d);
        }
        let rec = self.receptance.as_ref().expect("computed above");
        let apply = |r: &[DMatrix<Complex<f64>>],
                     n: usize,
                     out: usize,
                     x: &DVector<f64>,
                     y: &mut DVector<f64>| {
            y[0] += r[0][(n, out)].re * x[0];
            for q in 1..self.orders.len() {
                let (a, b) = cmul(r[q][(n, out)], x[2 * q - 1], x[2 * q]);
                y[2 * q - 1] += a;
                y[2 * q] += b;
            }
        };
        let lin_of = |lin: &[DVector<Complex<f64>>], n: usize| {
            let mut y = DVector::zeros(len);
            y[0] = lin[0][n].re;
            for q in 1..self.orders.len() {
                y[2 * q - 1] = lin[q][n].re;
                y[2 * q] = -lin[q][n].im;
            }
            y
        };
        let mut residual = DVector::zeros(nm * len);
        for n in 0..nm {
            let mut y = s.rows(n * len, len).into_owned() - lin_of(&rec.lin, n);
            for (out, go) in g.iter().enumerate() {
                apply(&rec.r, n, out, go, &mut y);
            }
            residual.rows_mut(n * len, len).copy_from(&y);
        }

        let d_frequency = want.frequency.then(|| {
            let mut dg: Vec<DVector<f64>> = acc
                .visc
                .iter()
                .map(|v| DVector::from_fn(len, |r, _| factor(r) * v[r] / f))
                .collect();
            for (n, mesh) in self.meshes.iter().enumerate() {
                dg[mesh.first] -= &ds[n] * mesh.c_mean;
            }
            let mut d = DVector::zeros(nm * len);
            for n in 0..nm {
                let mut y = -lin_of(&rec.dlin, n);
                for out in 0..outs {
                    apply(&rec.dr, n, out, &g[out], &mut y);
                    apply(&rec.r, n, out, &dg[out], &mut y);
                }
                d.rows_mut(n * len, len).copy_from(&y);
            }
            d
        });

        let jacobian = want.jacobian.then(|| {
            let no = self.orders.len();
            let mut jac = DMatrix::<f64>::identity(nm * len, nm * len);
            let mut gs = DMatrix::<f64>::zeros(len, len);
            for (n, mesh) in self.meshes.iter().enumerate() {
                for k in 0..mesh.outputs {
                    let out = mesh.first + k;
                    gs.fill(0.0);
                    let (kc, kv) = (&acc.kap_s[out], &acc.kap_v[out]);
                    // Toeplitz + Hankel of ∂F/∂S, and of ∂F/∂Ṡ times f d/dθ.
                    for (kap, scale, rate) in [(kc, 1.0, false), (kv, f, true)] {
                        if kap.iter().all(|&x| x == 0.0) {
                            continue;
                        }
                        for q in 0..no {
                            let fq = factor(q) * 0.5 * scale;
                            let rows: &[usize] = if q == 0 { &[0] } else { &[2 * q - 1, 2 * q] };
                            for p in 0..no {
                                let (jq, jp) = (self.orders[q], self.orders[p]);
                                let (ip, im) = (self.plus[q * no + p], self.minus[q * no + p]);
                                let (cp, sp) = (kap[2 * ip], kap[2 * ip + 1]);
                                let (cm, smag) = (kap[2 * im], kap[2 * im + 1]);
                                // sin of (j_q − j_p) and of (j_p − j_q).
                                let s_qp = if jq >= jp { smag } else { -smag };
                                let s_pq = -s_qp;
                                // [cos_q cos_p, cos_q sin_p; sin_q cos_p, sin_q sin_p] sums.
                                let cc = cm + cp;
                                let c_s = sp + s_pq;
                                let s_c = sp + s_qp;
                                let ss = cm - cp;
                                let cols: &[usize] =
                                    if p == 0 { &[0] } else { &[2 * p - 1, 2 * p] };
                                let mut block = [[0.0; 2]; 2];
                                block[0][0] = cc;
                                if cols.len() == 2 {
                                    block[0][1] = c_s;
                                }
                                if rows.len() == 2 {
                                    block[1][0] = s_c;
                                    if cols.len() == 2 {
                                        block[1][1] = ss;
                                    }
                                }
                                if !rate {
                                    for (ri, &r) in rows.iter().enumerate() {
                                        for (ci, &cl) in cols.iter().enumerate() {
                                            gs[(r, cl)] += fq * block[ri][ci];
                                        }
                                    }
                                } else if p > 0 {
                                    // (T D)[:, a_p] = −2πj_p T[:, b_p]; (T D)[:, b_p] = 2πj_p T[:, a_p].
                                    let w = TAU * jp as f64;
                                    for (ri, &r) in rows.iter().enumerate() {
                                        gs[(r, 2 * p - 1)] -= fq * w * block[ri][1];
                                        gs[(r, 2 * p)] += fq * w * block[ri][0];
                                    }
                                }
                            }
                        }
                    }
                    if k == 0 {
                        for r in 0..len {
                            gs[(r, r)] -= mesh.k_mean;
                        }
                        if mesh.c_mean != 0.0 {
                            for (q, &j) in self.orders.iter().enumerate().skip(1) {
                                let w = TAU * j as f64 * mesh.c_mean * f;
                                gs[(2 * q - 1, 2 * q)] -= w;
                                gs[(2 * q, 2 * q - 1)] += w;
                            }
                        }
                    }
                    for (o, coefficient, phi) in &acc.boundary {
                        if *o != out {
                            continue;
                        }
                        for r in 0..len {
                            let row = coefficient * factor(r) * phi[r];
                            for cl in 0..len {
                                gs[(r, cl)] += row * phi[cl];
                            }
                        }
                    }
                    // J[n', n] += R[n', out] ⊙ gs (per order, on the rows).
                    for n2 in 0..nm {
                        let mut block = jac.view_mut((n2 * len, n * len), (len, len));
                        let r0 = rec.r[0][(n2, out)].re;
                        for cl in 0..len {
                            block[(0, cl)] += r0 * gs[(0, cl)];
                        }
                        for q in 1..no {
                            let rq = rec.r[q][(n2, out)];
                            for cl in 0..len {
                                let (a, b) = cmul(rq, gs[(2 * q - 1, cl)], gs[(2 * q, cl)]);
                                block[(2 * q - 1, cl)] += a;
                                block[(2 * q, cl)] += b;
                            }
                        }
                    }
                }
            }
            jac
        });

        Ok(Evaluation {
            residual,
            jacobian,
            d_frequency,
            g,
            sample_w: acc.sample_w,
            sample_force: acc.sample_force,
            sample_lost: acc.sample_lost,
        })
    }

    /// Newton at frequency `f` from `s`.
    /// Newton at frequency `f` from `s`: the iterate at which the Newton update falls below the
    /// tolerance, with its evaluation (node samples included), and the iteration count.
    fn newton(
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
        for iteration in 1..=options.max_iterations {
            let mut e = self.evaluate(&s, f, want)?;
            let delta = e
                .jacobian
                .take()
                .expect("asked for")
                .lu()
                .solve(&(-&e.residual))
                .ok_or_else(|| format!("harmonic balance at {speed} rad/s: singular Jacobian"))?;
            if delta.amax() <= options.tolerance * self.x_scale {
                return Ok((s, e, iteration));
            }
            s += &delta;
        }
        Err(format!(
            "harmonic balance at {speed} rad/s did not converge in {} Newton iterations",
            options.max_iterations
        ))
    }

    /// Mesh-deflection coefficients of full coordinate coefficients (one block per coordinate).
    fn condense(&self, coefficients: &[f64]) -> Result<DVector<f64>, String> {
        let len = self.len;
        if coefficients.len() != self.m * len {
            return Err(format!(
                "guess has {} coefficients, expected {} ({} coordinates × {len})",
                coefficients.len(),
                self.m * len,
                self.m
            ));
        }
        let nm = self.meshes.len();
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
    fn seed(&self, mut sim: Driver<M>) -> Result<DVector<f64>, String> {
        let period = 1.0 / self.f;
        let k = self.mesh_periods;
        let warm = (SEED_WARMUP_PERIODS.div_ceil(k) * k) as f64 / self.mesh_periods as f64 * period;
        let t0 = sim.t();
        let mut order: Vec<usize> = (0..self.nodes.len()).collect();
        order.sort_by(|&a, &b| self.nodes[a].total_cmp(&self.nodes[b]));
        let len = self.len;
        let nm = self.meshes.len();
        let mut s = DVector::zeros(nm * len);
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

    /// The orbit of a converged `s` at `f` from its evaluation (with samples).
    fn solution(&self, s: &DVector<f64>, f: f64, e: &Evaluation, iterations: usize) -> HbSolution {
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
        let _ = s;
        let meshes = self
            .meshes
            .iter()
            .enumerate()
            .map(|(n, mesh)| {
                let mut dte = vec![0.0; len];
                for i in 0..m {
                    let d = mesh.dte[i];
                    if d != 0.0 {
                        for r in 0..len {
                            dte[r] += d * coefficients[i * len + r];
                        }
                    }
                }
                let harmonic = |h: usize| {
                    let j = h * mesh.cycles as usize;
                    self.orders
                        .iter()
                        .position(|&o| o == j)
                        .filter(|&q| q > 0)
                        .map_or(0.0, |q| dte[2 * q - 1].hypot(dte[2 * q]))
                };
                let nm = self.meshes.len();
                let force = |i: usize| e.sample_force[i * nm + n];
                let w = &e.sample_w;
                let total = w.iter().fold(0.0, |a, b| a + b);
                let mean = (0..w.len()).fold(0.0, |a, i| a + w[i] * force(i)) / total;
                let var =
                    (0..w.len()).fold(0.0, |a, i| a + w[i] * (force(i) - mean).powi(2)) / total;
                let peak = (0..w.len()).fold(0.0, |a: f64, i| a.max(force(i).abs()));
                let lost = (0..w.len())
                    .filter(|&i| e.sample_lost[i * nm + n])
                    .fold(0.0, |a, i| a + w[i])
                    / total;
                HbMesh {
                    prefix: mesh.prefix.clone(),
                    mesh_frequency: mesh.cycles * f,
                    dte_mean: dte[0],
                    dte_rms: (dte[1..].iter().map(|c| c * c).sum::<f64>() / 2.0).sqrt(),
                    harmonics: [harmonic(1), harmonic(2)],
                    peak_force: peak,
                    force_rms: var.sqrt(),
                    dynamic_factor: peak / mesh.static_force,
                    contact_loss_fraction: lost,
                }
            })
            .collect();
        HbSolution {
            mesh_frequency: self.meshes[0].cycles * f,
            subharmonic: (self.mesh_periods / self.response_periods()) as u32,
            mesh_periods: self.mesh_periods,
            orders: self.orders.clone(),
            coefficients,
            iterations,
            meshes,
            dte_rows: self.meshes.iter().map(|mesh| mesh.dte.clone()).collect(),
        }
    }

    fn response_periods(&self) -> u64 {
        let freqs: Vec<f64> = (0..self.meshes.len())
            .map(|n| self.meshes[n].cycles)
            .collect();
        response_period_in_mesh_periods(&freqs).unwrap_or(1)
    }
}

/// Floquet multipliers of an orbit of `model` (at the orbit's speed) over `period` seconds from
/// its state at `t = 0`: the shooting monodromy with saltation at contact changes
/// ([`PeriodMap`]); `None` when the period map fails.
fn multipliers<M: Drivetrain>(
    model: M,
    settings: &SolverSettings,
    period: f64,
    solution: &HbSolution,
) -> Option<Vec<Complex<f64>>> {
    let mut map = PeriodMap::new(model, settings, period).ok()?;
    let (_, monodromy) = map.eval(&solution.state_at(0.0)).ok()?;
    Some(monodromy.complex_eigenvalues().iter().copied().collect())
}

/// The multipliers of every point of a branch. The period maps are independent of each
/// other and dominate the cost of a continuation (each is a shooting integration with
/// sensitivities), so they run on all available cores; each point's result is the same on any
/// number of threads.
fn branch_stability<M: Drivetrain + Send>(problem: &Problem<M>, points: &mut [BranchPoint]) {
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .clamp(1, points.len().max(1));
    let jobs: Vec<(usize, M, f64, &HbSolution)> = points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let mut model = problem.model.clone();
            let f = problem.frequency(p.speed);
            let ok = model.set_input_speed(0.0, p.speed).is_ok();
            (i, model, if ok { 1.0 / f } else { f64::NAN }, &p.solution)
        })
        .collect();
    let settings = &problem.settings;
    let mut results: Vec<(usize, Option<Vec<Complex<f64>>>)> = Vec::with_capacity(jobs.len());
    let mut queues: Vec<Vec<_>> = (0..threads).map(|_| Vec::new()).collect();
    for (k, job) in jobs.into_iter().enumerate() {
        queues[k % threads].push(job);
    }
    std::thread::scope(|scope| {
        let handles: Vec<_> = queues
            .into_iter()
            .map(|queue| {
                scope.spawn(move || {
                    queue
                        .into_iter()
                        .map(|(i, model, period, solution)| {
                            (i, multipliers(model, settings, period, solution))
                        })
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        for h in handles {
            results.extend(h.join().expect("stability thread"));
        }
    });
    for (i, m) in results {
        points[i].multipliers = m;
    }
}

/// Mesh periods integrated before a time-domain seed is sampled (rounded up to whole HB
/// periods).
const SEED_WARMUP_PERIODS: u64 = 60;

/// Solves the harmonic balance at one input speed by Newton, from `guess` (the coefficients
/// of [`HbSolution::coefficients`] with the same orders) or from a time-domain seed.
pub fn solve(
    scene: &impl SceneSource,
    speed: f64,
    guess: Option<&[f64]>,
    options: &HbOptions,
) -> Result<HbSolution, String> {
    if !(speed > 0.0 && speed.is_finite()) {
        return Err(format!("speed = {speed}: must be a finite speed > 0"));
    }
    let mut scene = scene.to_any();
    scene.set_input_speed(speed);
    let settings = scene.solver().clone();
    with_drivetrain!(scene.simulation()?, sim => {
        let mut problem = Problem::new(sim.model().clone(), settings, options)?;
        let f = problem.f;
        let s = match guess {
            Some(g) => problem.condense(g)?,
            None => problem.seed(sim)?,
        };
        let (s, e, iterations) = problem.newton(s, f, options)?;
        Ok(problem.solution(&s, f, &e, iterations))
    })
}

/// Settings of the continuation.
#[derive(Debug, Clone)]
pub struct ContinuationOptions {
    /// Input-speed interval, rad/s: the branch starts at `from` and ends when it leaves the
    /// interval.
    pub from: f64,
    pub to: f64,
    /// Initial and largest arclength step (scaled units).
    pub initial_step: f64,
    pub max_step: f64,
    pub max_points: usize,
    /// Compute the Floquet multipliers of each point (shooting monodromy from the HB state).
    pub stability: bool,
}

impl ContinuationOptions {
    pub fn new(from: f64, to: f64) -> Self {
        ContinuationOptions {
            from,
            to,
            initial_step: 0.01,
            max_step: 0.05,
            max_points: 2000,
            stability: true,
        }
    }
}

/// One point of a continued branch.
#[derive(Debug, Clone)]
pub struct BranchPoint {
    pub solution: HbSolution,
    /// Input speed, rad/s.
    pub speed: f64,
    /// Floquet multipliers (None when not computed): eigenvalues of the monodromy (with
    /// saltation) from the HB state at `t = 0`, accurate to the HB truncation error.
    pub multipliers: Option<Vec<Complex<f64>>>,
    /// Whether the step to this point passed a fold (turning point in speed).
    pub fold: bool,
}

impl BranchPoint {
    /// Largest |μ| (None when the multipliers were not computed).
    pub fn spectral_radius(&self) -> Option<f64> {
        self.multipliers
            .as_ref()
            .map(|m| m.iter().map(|c| c.norm()).fold(0.0, f64::max))
    }

    /// Stable when every multiplier lies inside the unit circle.
    pub fn stable(&self) -> Option<bool> {
        self.spectral_radius().map(|r| r < 1.0)
    }
}

/// Pseudo-arclength continuation of the HB orbit in input speed (Keller 1977; Krack & Gross
/// §4.2): predictor along the tangent of `r(s, λ) = 0`, corrector orthogonal to it, step size
/// adapted to the Newton effort. Turning points (folds) are passed and marked.
pub fn continuation(
    scene: &impl SceneSource,
    hb: &HbOptions,
    options: &ContinuationOptions,
) -> Result<Vec<BranchPoint>, String> {
    if !(options.from > 0.0 && options.to.is_finite() && options.from.is_finite())
        || options.from == options.to
    {
        return Err(format!(
            "continuation range {}..{} rad/s: need two different finite speeds > 0",
            options.from, options.to
        ));
    }
    let mut scene = scene.to_any();
    scene.set_input_speed(options.from);
    let settings = scene.solver().clone();
    with_drivetrain!(scene.simulation()?, sim => {
        let problem = Problem::new(sim.model().clone(), settings, hb)?;
        continue_branch(problem, sim, hb, options)
    })
}

fn continue_branch<M: Drivetrain + Send>(
    mut problem: Problem<M>,
    sim: Driver<M>,
    hb: &HbOptions,
    options: &ContinuationOptions,
) -> Result<Vec<BranchPoint>, String> {
    let f_ref = problem.f;
    let (f_lo, f_hi) = (
        problem.frequency(options.from.min(options.to)),
        problem.frequency(options.from.max(options.to)),
    );
    let xs = problem.x_scale;
    let dim = problem.meshes.len() * problem.len;

    let seed = problem.seed(sim)?;
    let (start, _, iterations) = problem.newton(seed, f_ref, hb)?;
    // Scaled unknowns w = [s/x_s, f/f_ref].
    let mut w = DVector::zeros(dim + 1);
    w.rows_mut(0, dim).copy_from(&(&start / xs));
    w[dim] = 1.0;
    let all = Want {
        jacobian: true,
        frequency: true,
        samples: false,
    };
    // Scaled residual r/x_s and its Jacobian [∂r/∂s, ∂r/∂λ · f_ref/x_s].
    let scaled = |problem: &mut Problem<M>,
                  w: &DVector<f64>,
                  want: Want|
     -> Result<(DVector<f64>, DMatrix<f64>, Evaluation), String> {
        let s = w.rows(0, dim) * xs;
        let f = w[dim] * f_ref;
        let mut e = problem.evaluate(&s, f, want)?;
        let mut j = DMatrix::zeros(dim, dim + 1);
        j.view_mut((0, 0), (dim, dim))
            .copy_from(e.jacobian.as_ref().expect("asked for"));
        j.set_column(
            dim,
            &(e.d_frequency.take().expect("asked for") * (f_ref / xs)),
        );
        Ok((&e.residual / xs, j, e))
    };
    let tangent_of = |j: &DMatrix<f64>, previous: &DVector<f64>| -> Option<DVector<f64>> {
        let mut a = DMatrix::zeros(dim + 1, dim + 1);
        a.view_mut((0, 0), (dim, dim + 1)).copy_from(j);
        a.set_row(dim, &previous.transpose());
        let mut rhs = DVector::zeros(dim + 1);
        rhs[dim] = 1.0;
        let t = a.lu().solve(&rhs)?;
        Some(t.normalize())
    };
    let direction = if options.to > options.from { 1.0 } else { -1.0 };
    let mut seed = DVector::zeros(dim + 1);
    seed[dim] = direction;
    let (_, j0, e0) = scaled(
        &mut problem,
        &w,
        Want {
            samples: true,
            ..all
        },
    )?;
    let mut tangent = tangent_of(&j0, &seed).ok_or("continuation: singular start")?;
    if tangent[dim] * direction < 0.0 {
        tangent = -tangent;
    }
    let mut points = vec![make_point(&problem, &start, f_ref, &e0, iterations, false)];
    let mut step = options.initial_step;
    while points.len() < options.max_points {
        let predicted = &w + &tangent * step;
        let mut candidate = predicted.clone();
        let mut iterations = 0;
        // The corrector: Newton on [r; tᵀ(w − w_pred)] = 0. It stops at the iterate whose
        // update is below the tolerance and keeps that iterate's evaluation (Jacobian for the
        // next tangent, node samples for the results): no extra evaluation per point.
        let mut last = None;
        for it in 1..=12 {
            iterations = it;
            let with_samples = Want {
                samples: true,
                ..all
            };
            let Ok((r, j, e)) = scaled(&mut problem, &candidate, with_samples) else {
                break;
            };
            let mut a = DMatrix::zeros(dim + 1, dim + 1);
            a.view_mut((0, 0), (dim, dim + 1)).copy_from(&j);
            a.set_row(dim, &tangent.transpose());
            let mut g = DVector::zeros(dim + 1);
            g.rows_mut(0, dim).copy_from(&r);
            g[dim] = tangent.dot(&(&candidate - &predicted));
            let Some(delta) = a.lu().solve(&(-g)) else {
                break;
            };
            if delta.amax() <= hb.tolerance.max(1e-13) * 10.0 {
                last = Some((j, e));
                break;
            }
            candidate += &delta;
        }
        let Some((j, e)) = last else {
            step *= 0.5;
            if step < 1e-8 {
                return Err(format!(
                    "continuation stalled near {:.3} rad/s (step below 1e-8)",
                    points.last().map_or(options.from, |p| p.speed)
                ));
            }
            continue;
        };
        let mut next = tangent_of(&j, &tangent).ok_or("continuation: singular tangent")?;
        if next.dot(&tangent) < 0.0 {
            next = -next;
        }
        let fold = next[dim] * tangent[dim] < 0.0;
        w = candidate;
        tangent = next;
        let f = w[dim] * f_ref;
        let s = w.rows(0, dim) * xs;
        points.push(make_point(
            &problem,
            &s.into_owned(),
            f,
            &e,
            iterations,
            fold,
        ));
        if f < f_lo || f > f_hi {
            break;
        }
        step = if iterations <= 3 {
            (step * 1.5).min(options.max_step)
        } else if iterations > 6 {
            step * 0.5
        } else {
            step
        };
    }
    if options.stability {
        branch_stability(&problem, &mut points);
    }
    Ok(points)
}

/// A branch point without its multipliers (computed for the whole branch at the end).
fn make_point<M: Drivetrain>(
    problem: &Problem<M>,
    s: &DVector<f64>,
    f: f64,
    e: &Evaluation,
    iterations: usize,
    fold: bool,
) -> BranchPoint {
    BranchPoint {
        speed: problem.speed(f),
        solution: problem.solution(s, f, e, iterations),
        multipliers: None,
        fold,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Scene;

    #[test]
    fn projection_inverts_sampling_of_band_limited_signals() {
        let scene = Scene::example("spur_pair").unwrap();
        let model = crate::model::GearPair::new(&scene);
        let p = Problem::new(model, scene.solver.clone(), &HbOptions::new(5)).unwrap();
        let u: Vec<f64> = (0..p.len).map(|i| (i as f64 + 1.0).sin()).collect();
        let mut back = vec![0.0; p.len];
        for (i, &w) in p.weights.iter().enumerate() {
            let phi = &p.table.as_ref().unwrap()[i * p.len..(i + 1) * p.len];
            let x: f64 = phi.iter().zip(&u).map(|(a, b)| a * b).sum();
            for r in 0..p.len {
                back[r] += factor(r) * w * x * phi[r];
            }
        }
        let err = back
            .iter()
            .zip(&u)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-9, "{err}");
    }

    #[test]
    fn combination_tones() {
        assert_eq!(combination_orders(&[1], 3), vec![0, 1, 2, 3]);
        assert_eq!(combination_orders(&[1, 1], 2), vec![0, 1, 2]);
        // 72a + 19b with 72|a| + 19|b| ≤ 144.
        assert_eq!(
            combination_orders(&[72, 19], 2),
            vec![0, 15, 19, 34, 38, 53, 57, 72, 76, 91, 95, 110, 114, 129, 133, 144]
        );
    }
}
