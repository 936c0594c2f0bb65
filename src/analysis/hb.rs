//! Harmonic balance with alternating frequency/time evaluation (AFT) and pseudo-arclength
//! continuation in speed (Cameron & Griffin 1989, J. Appl. Mech. 56:149–154; Krack & Gross,
//! *Harmonic Balance for Nonlinear Vibration Problems*, 2019, ch. 2–4; Liu 2007 §3.2.2,
//! eqs. 3.3–3.8 with the Newton sign corrected as the notes explain).
//!
//! The orbit is written in the mesh phase `τ` (mesh cycles) over a response period of `K`
//! mesh periods: `x(τ) = a_0 + Σ_{j=1}^{H} a_j cos(2πjτ/K) + b_j sin(2πjτ/K)`. Since
//! `d/dt = f_m d/dτ`, stiffness and STE samples do not depend on the speed; only the inertia
//! and damping terms do. The contact law is evaluated exactly at `N` samples per period
//! (no tanh smoothing); its kinks make the coefficients decay algebraically, which the error
//! table against shooting shows.

use std::f64::consts::TAU;

use nalgebra::{DMatrix, DVector};

use crate::model::GearPair;
use crate::scene::Scene;

use super::shooting::period_map;

/// Settings of the harmonic balance.
#[derive(Debug, Clone)]
pub struct HbOptions {
    /// Harmonics H of the response frequency.
    pub harmonics: usize,
    /// Response period K in mesh periods (sub-harmonic orbits for K > 1).
    pub subharmonic: u32,
    /// Quadrature nodes per response period (about); default `max(16·(2H+1), 256)`.
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
        if let Some(n) = self.samples {
            if n <= 2 * self.harmonics {
                return Err(format!(
                    "samples = {n}: must exceed 2·harmonics = {} (sampling theorem)",
                    2 * self.harmonics
                ));
            }
        }
        if !(self.tolerance > 0.0) {
            return Err(format!("tolerance = {}: must be > 0", self.tolerance));
        }
        Ok(())
    }
}

/// A harmonic-balance orbit.
#[derive(Debug, Clone)]
pub struct HbSolution {
    /// Mesh frequency, Hz.
    pub mesh_frequency: f64,
    pub subharmonic: u32,
    /// `[a_0, a_1, b_1, …, a_H, b_H]`, m.
    pub coefficients: Vec<f64>,
    pub iterations: usize,
}

impl HbSolution {
    pub fn harmonics(&self) -> usize {
        (self.coefficients.len() - 1) / 2
    }

    /// `(x, dx/dτ)` at `τ` mesh cycles after `t = 0` (mesh phase `p0 + τ`).
    pub fn displacement(&self, tau: f64) -> (f64, f64) {
        let k = self.subharmonic as f64;
        let mut x = self.coefficients[0];
        let mut dx = 0.0;
        for j in 1..=self.harmonics() {
            let w = TAU * j as f64 / k;
            let (s, c) = (w * tau).sin_cos();
            let (a, b) = (self.coefficients[2 * j - 1], self.coefficients[2 * j]);
            x += a * c + b * s;
            dx += w * (-a * s + b * c);
        }
        (x, dx)
    }

    /// The state `[x, x']` (x' per second) `τ` mesh cycles after `t = 0`.
    pub fn state_at(&self, tau: f64) -> [f64; 2] {
        let (x, dx) = self.displacement(tau);
        [x, dx * self.mesh_frequency]
    }

    /// RMS of the DTE with the mean removed (Parseval).
    pub fn dte_rms(&self) -> f64 {
        (self.coefficients[1..].iter().map(|c| c * c).sum::<f64>() / 2.0).sqrt()
    }

    /// Amplitude of the `h`-th mesh harmonic (response harmonic `h·K`).
    pub fn mesh_harmonic(&self, h: usize) -> f64 {
        let j = h * self.subharmonic as usize;
        if j == 0 || j > self.harmonics() {
            return 0.0;
        }
        self.coefficients[2 * j - 1].hypot(self.coefficients[2 * j])
    }
}

/// The discretised problem: sample matrices and the model's force law.
struct Problem {
    pair: GearPair,
    mass: f64,
    /// Galerkin projection of the external force (mean and torque ripple).
    external: DVector<f64>,
    /// Mesh phases of the quadrature nodes.
    phases: Vec<f64>,
    /// The nodes in mesh cycles since p0, three per cell.
    nodes: Vec<f64>,
    /// Quadrature cells `[a, b]`.
    cells: Vec<(f64, f64)>,
    k_sub: f64,
    /// `x_n = Γ u`.
    gamma: DMatrix<f64>,
    /// `dx/dτ_n = Γ' u`.
    gamma_d: DMatrix<f64>,
    /// `u = P F` for band-limited samples (DFT).
    projection: DMatrix<f64>,
    /// `d²/dτ²` of the basis (diagonal).
    second: DVector<f64>,
}

impl Problem {
    fn new(scene: &Scene, options: &HbOptions) -> Result<Problem, String> {
        options.validate()?;
        let pair = GearPair::new(scene);
        let h = options.harmonics;
        let n = options.samples.unwrap_or((16 * (2 * h + 1)).max(256));
        let dim = 2 * h + 1;
        let k_sub = options.subharmonic as f64;
        let p0 = scene.mesh.initial_phase;
        let (cells, nodes, weights) = quadrature(&scene.mesh.stiffness, p0, options.subharmonic, n);
        let phases: Vec<f64> = nodes.iter().map(|tau| p0 + tau).collect();
        let m = nodes.len();
        let mut gamma = DMatrix::zeros(m, dim);
        let mut gamma_d = DMatrix::zeros(m, dim);
        let mut projection = DMatrix::zeros(dim, m);
        let mut second = DVector::zeros(dim);
        for (i, (&tau, &wq)) in nodes.iter().zip(&weights).enumerate() {
            gamma[(i, 0)] = 1.0;
            projection[(0, i)] = wq / k_sub;
            // Basis in the phase since p0, so that the coefficients describe the orbit from
            // t = 0.
            for j in 1..=h {
                let w = TAU * j as f64 / k_sub;
                let (s, c) = (w * tau).sin_cos();
                gamma[(i, 2 * j - 1)] = c;
                gamma[(i, 2 * j)] = s;
                gamma_d[(i, 2 * j - 1)] = -w * s;
                gamma_d[(i, 2 * j)] = w * c;
                projection[(2 * j - 1, i)] = 2.0 * wq * c / k_sub;
                projection[(2 * j, i)] = 2.0 * wq * s / k_sub;
            }
        }
        for j in 1..=h {
            let w = TAU * j as f64 / k_sub;
            second[2 * j - 1] = -w * w;
            second[2 * j] = -w * w;
        }
        let external_samples = DVector::from_iterator(
            phases.len(),
            phases.iter().map(|&p| pair.external_force_at_phase(p)),
        );
        Ok(Problem {
            mass: pair.equivalent_mass(),
            external: &projection * external_samples,
            pair,
            phases,
            nodes,
            cells,
            k_sub,
            gamma,
            gamma_d,
            projection,
            second,
        })
    }

    /// Basis values and τ-derivatives at `τ` (mesh cycles since p0).
    fn basis(&self, tau: f64) -> (DVector<f64>, DVector<f64>) {
        let dim = self.dim();
        let h = (dim - 1) / 2;
        let mut b = DVector::zeros(dim);
        let mut d = DVector::zeros(dim);
        b[0] = 1.0;
        for j in 1..=h {
            let w = TAU * j as f64 / self.k_sub;
            let (s, c) = (w * tau).sin_cos();
            b[2 * j - 1] = c;
            b[2 * j] = s;
            d[2 * j - 1] = -w * s;
            d[2 * j] = w * c;
        }
        (b, d)
    }

    /// Projection factors: `1/K` for the mean, `2/K` for the harmonics.
    fn factors(&self) -> DVector<f64> {
        DVector::from_fn(self.dim(), |j, _| {
            if j == 0 {
                1.0 / self.k_sub
            } else {
                2.0 / self.k_sub
            }
        })
    }

    /// Residual `R(u, f)`, `∂R/∂u` and `∂R/∂f` (f = mesh frequency, Hz).
    ///
    /// Cells in which the contact side changes are split at the switching instants (roots of
    /// `δ(τ)` or `δ(τ) + 2b` on the trigonometric polynomial), each part integrated by its own
    /// Gauss rule, so the residual is continuous in `u` although the damping force jumps at
    /// separation; the moving split point adds the boundary term
    /// `∓ c f P b(τ*) b(τ*)ᵀ` to the Jacobian (Leibniz rule, `∂τ*/∂u = −b(τ*)/δ_τ`).
    fn evaluate(&self, u: &DVector<f64>, f: f64) -> (DVector<f64>, DMatrix<f64>, DVector<f64>) {
        let x = &self.gamma * u;
        let dx = &self.gamma_d * u;
        let n = self.phases.len();
        let p0 = self.phases[0] - self.nodes[0];
        let mut force = DVector::zeros(n);
        let mut dfdx = DVector::zeros(n);
        let mut dfdv = DVector::zeros(n);
        let mut sides = vec![0i8; n];
        for i in 0..n {
            let (fi, kx, cv) = self.pair.force_law(self.phases[i], f, x[i], f * dx[i]);
            force[i] = fi;
            dfdx[i] = kx;
            dfdv[i] = cv;
            sides[i] = self.pair.contact_side(self.phases[i], x[i]).0;
        }
        let x_at = |tau: f64| self.basis(tau).0.dot(u);
        let side_at = |tau: f64| self.pair.contact_side(p0 + tau, x_at(tau));
        let clearance = self.pair.contact_clearance();
        let dim = self.dim();
        let factors = self.factors();
        let mut r_extra = DVector::zeros(dim);
        let mut ju_extra = DMatrix::zeros(dim, dim);
        let mut jf_extra = DVector::zeros(dim);
        for (c, &(a, b)) in self.cells.iter().enumerate() {
            let nodes = 3 * c..3 * c + 3;
            let (side_a, _) = side_at(a);
            let (side_b, _) = side_at(b);
            if nodes.clone().all(|i| sides[i] == side_a) && side_b == side_a {
                continue;
            }
            // Split the cell: drop its fixed nodes, integrate the parts between roots.
            for i in nodes {
                force[i] = 0.0;
                dfdx[i] = 0.0;
                dfdv[i] = 0.0;
            }
            let mut points = vec![a];
            points.extend(self.nodes[3 * c..3 * c + 3].iter().copied());
            points.push(b);
            let mut cuts = vec![a];
            for pair in points.windows(2) {
                let (l, rr) = (pair[0], pair[1]);
                let (sl, dl) = side_at(l);
                let (sr, dr) = side_at(rr);
                if sl == sr {
                    continue;
                }
                // Surfaces δ = 0 and δ = −2b between l and rr.
                for surface in [0.0, -clearance] {
                    let (gl, gr) = (dl - surface, dr - surface);
                    if (gl > 0.0) != (gr > 0.0) {
                        let (mut lo, mut hi) = (l, rr);
                        let g = |t: f64| side_at(t).1 - surface;
                        let positive_lo = gl > 0.0;
                        for _ in 0..60 {
                            let mid = 0.5 * (lo + hi);
                            if (g(mid) > 0.0) == positive_lo {
                                lo = mid;
                            } else {
                                hi = mid;
                            }
                        }
                        cuts.push(0.5 * (lo + hi));
                    }
                }
            }
            cuts.push(b);
            cuts.sort_by(f64::total_cmp);
            for part in cuts.windows(2) {
                let (l, rr) = (part[0], part[1]);
                let half = 0.5 * (rr - l);
                if half <= 0.0 {
                    continue;
                }
                for (xi, wt) in GAUSS3 {
                    let tau = l + half * (1.0 + xi);
                    let (bv, bd) = self.basis(tau);
                    let (xv, dxv) = (bv.dot(u), bd.dot(u));
                    let (fi, kx, cv) = self.pair.force_law(p0 + tau, f, xv, f * dxv);
                    let w = half * wt;
                    let weighted = bv.component_mul(&factors) * w;
                    r_extra += &weighted * fi;
                    ju_extra += &weighted * (bv * kx + bd * (f * cv)).transpose();
                    jf_extra += &weighted * (cv * dxv);
                }
            }
            // Boundary terms of the interior cuts.
            // Only damping switched off in separation jumps at a cut.
            let damping = self.pair.damping();
            if damping != 0.0 && !self.pair.damping_always() {
                for &cut in &cuts[1..cuts.len() - 1] {
                    let eps = 1e-9 * (b - a);
                    let left = side_at(cut - eps).0 != 0;
                    let right = side_at(cut + eps).0 != 0;
                    let sign = match (left, right) {
                        (true, false) => -1.0,
                        (false, true) => 1.0,
                        _ => continue,
                    };
                    let (bv, _) = self.basis(cut);
                    ju_extra +=
                        (bv.component_mul(&factors) * (sign * damping * f)) * bv.transpose();
                }
            }
        }
        let inertia = self.second.component_mul(u) * (self.mass * f * f);
        let mut r = inertia + &self.projection * &force + r_extra;
        r -= &self.external;
        // ∂(P F)/∂u = P diag(∂F/∂x) Γ + f P diag(∂F/∂v) Γ'.
        let mut weighted = self.gamma.clone();
        for i in 0..n {
            for j in 0..dim {
                weighted[(i, j)] =
                    dfdx[i] * self.gamma[(i, j)] + f * dfdv[i] * self.gamma_d[(i, j)];
            }
        }
        let mut ju = &self.projection * weighted + ju_extra;
        for j in 0..dim {
            ju[(j, j)] += self.mass * f * f * self.second[j];
        }
        let jf = self.second.component_mul(u) * (2.0 * self.mass * f)
            + &self.projection * dfdv.component_mul(&dx)
            + jf_extra;
        (r, ju, jf)
    }

    /// Displacement scale for convergence tests.
    fn x_scale(&self) -> f64 {
        self.pair
            .static_deflection()
            .abs()
            .max(self.pair.ste_amplitude_bound())
            .max(1e-9)
    }

    /// Force scale `k̄ · x_scale`.
    fn force_scale(&self) -> f64 {
        self.pair.mean_stiffness() * self.x_scale()
    }

    fn dim(&self) -> usize {
        self.gamma.ncols()
    }
}

/// Mesh periods integrated before a time-domain seed is sampled.
const SEED_WARMUP_PERIODS: u32 = 60;

/// A starting guess from the time domain: the response after a warm-up, projected onto the
/// basis. Newton from the static deflection often stalls on the piecewise-smooth residual
/// near resonance; the seed only selects the basin, the converged orbit is HB's own.
fn seed_from_simulation(
    scene: &Scene,
    speed: f64,
    problem: &Problem,
    k_sub: u32,
) -> Result<DVector<f64>, String> {
    let mut at = scene.clone();
    at.operating.pinion_speed = speed;
    let mut sim = crate::simulation::Simulation::new(&at)?;
    let period = sim.model().mesh_period();
    let warm = (SEED_WARMUP_PERIODS.div_ceil(k_sub) * k_sub) as f64;
    let mut order: Vec<usize> = (0..problem.phases.len()).collect();
    let p0 = scene.mesh.initial_phase;
    order.sort_by(|&a, &b| problem.phases[a].total_cmp(&problem.phases[b]));
    let mut x = DVector::zeros(problem.phases.len());
    for i in order {
        let tau = problem.phases[i] - p0;
        sim.advance_to((warm + tau) * period)
            .map_err(|e| format!("harmonic balance seed: {e}"))?;
        x[i] = sim.state()[0];
    }
    Ok(&problem.projection * x)
}

/// 3-point Gauss–Legendre rule on [−1, 1]: (node, weight).
const GAUSS3: [(f64, f64); 3] = [
    (-0.774_596_669_241_483_4, 5.0 / 9.0),
    (0.0, 8.0 / 9.0),
    (0.774_596_669_241_483_4, 5.0 / 9.0),
];

/// Quadrature cells, nodes (mesh cycles since `p0`) and weights over `K` mesh periods for the
/// Galerkin projection. The period is split at the stiffness breakpoints, so its jumps fall
/// between nodes and are integrated exactly; inside each piece composite 3-point
/// Gauss–Legendre rules (about `n` nodes in all) integrate the smooth parts and leave an
/// O(h²) error at the contact kinks. Uniform sampling (plain AFT) would alias the jumps with an
/// O(1/n) error that no number of harmonics removes.
fn quadrature(
    stiffness: &crate::mesh::MeshStiffness,
    p0: f64,
    k_sub: u32,
    n: usize,
) -> (Vec<(f64, f64)>, Vec<f64>, Vec<f64>) {
    let k = k_sub as f64;
    let mut breaks = vec![0.0, k];
    if let Some(pieces) = stiffness.pieces() {
        // Piece starts are in the shifted phase s = frac(p + phase); τ = p − p0.
        for cycle in -1..=k_sub as i64 {
            for piece in pieces {
                let tau = piece.start - stiffness.phase() - p0 + cycle as f64;
                if tau > 0.0 && tau < k {
                    breaks.push(tau);
                }
            }
        }
    }
    breaks.sort_by(f64::total_cmp);
    breaks.dedup_by(|a, b| (*a - *b).abs() < 1e-14);
    let mut cells = Vec::new();
    let mut nodes = Vec::with_capacity(n + 3 * breaks.len());
    let mut weights = Vec::with_capacity(n + 3 * breaks.len());
    for w in breaks.windows(2) {
        let (a, b) = (w[0], w[1]);
        let count = ((n as f64 / 3.0) * (b - a) / k).ceil().max(1.0) as usize;
        let h = (b - a) / count as f64;
        for c in 0..count {
            let mid = a + (c as f64 + 0.5) * h;
            cells.push((mid - 0.5 * h, mid + 0.5 * h));
            for (x, wt) in GAUSS3 {
                nodes.push(mid + 0.5 * h * x);
                weights.push(0.5 * h * wt);
            }
        }
    }
    (cells, nodes, weights)
}

/// Solves the harmonic balance at one speed by Newton, from `guess` (coefficients of a
/// solution with the same H) or from the static deflection.
pub fn solve(
    scene: &Scene,
    speed: f64,
    guess: Option<&[f64]>,
    options: &HbOptions,
) -> Result<HbSolution, String> {
    if !(speed > 0.0 && speed.is_finite()) {
        return Err(format!("speed = {speed}: must be a finite speed > 0"));
    }
    let problem = Problem::new(scene, options)?;
    let f = scene.pinion.teeth as f64 * speed / TAU;
    let mut u = match guess {
        Some(g) if g.len() == problem.dim() => DVector::from_column_slice(g),
        Some(g) => {
            return Err(format!(
                "guess has {} coefficients, expected {}",
                g.len(),
                problem.dim()
            ))
        }
        None => seed_from_simulation(scene, speed, &problem, options.subharmonic)?,
    };
    let scale = problem.x_scale();
    let (mut r, mut ju, _) = problem.evaluate(&u, f);
    for iteration in 1..=options.max_iterations {
        let delta = ju
            .lu()
            .solve(&(-&r))
            .ok_or_else(|| format!("harmonic balance at {speed} rad/s: singular Jacobian"))?;
        u += &delta;
        (r, ju, _) = problem.evaluate(&u, f);
        if delta.amax() <= options.tolerance * scale {
            return Ok(HbSolution {
                mesh_frequency: f,
                subharmonic: options.subharmonic,
                coefficients: u.as_slice().to_vec(),
                iterations: iteration,
            });
        }
    }
    Err(format!(
        "harmonic balance at {speed} rad/s did not converge in {} Newton iterations",
        options.max_iterations
    ))
}

/// Settings of the continuation.
#[derive(Debug, Clone)]
pub struct ContinuationOptions {
    /// Pinion-speed interval, rad/s: the branch starts at `from` and ends when it leaves the
    /// interval.
    pub from: f64,
    pub to: f64,
    /// Initial and largest arclength step (scaled units).
    pub initial_step: f64,
    pub max_step: f64,
    pub max_points: usize,
    /// Compute Floquet multipliers of each point (piecewise-LTI scenes: exact monodromy from
    /// the HB state; skipped otherwise).
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
    /// Pinion speed, rad/s.
    pub speed: f64,
    /// Floquet multipliers (None when not computed): eigenvalues of the exact monodromy
    /// (with saltation) from the HB state at `t = 0`, accurate to the HB truncation error.
    pub multipliers: Option<Vec<nalgebra::Complex<f64>>>,
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

/// Pseudo-arclength continuation of the HB orbit in pinion speed (Keller 1977; Krack & Gross
/// §4.2): predictor along the tangent of `R(u, f) = 0`, corrector orthogonal to it, step size
/// adapted to the Newton effort. Turning points (folds) are passed and marked.
pub fn continuation(
    scene: &Scene,
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
    let problem = Problem::new(scene, hb)?;
    let teeth = scene.pinion.teeth as f64;
    let to_f = |speed: f64| teeth * speed / TAU;
    let (f_lo, f_hi) = (
        to_f(options.from.min(options.to)),
        to_f(options.from.max(options.to)),
    );
    let f_ref = to_f(options.from);
    let xs = problem.x_scale();
    let fs = problem.force_scale();
    let dim = problem.dim();

    let start = solve(scene, options.from, None, hb)?;
    // Scaled unknowns w = [u/x_s, f/f_ref].
    let mut w = DVector::zeros(dim + 1);
    for j in 0..dim {
        w[j] = start.coefficients[j] / xs;
    }
    w[dim] = 1.0;
    let scaled_jacobian = |w: &DVector<f64>| {
        let u = w.rows(0, dim) * xs;
        let f = w[dim] * f_ref;
        let (r, ju, jf) = problem.evaluate(&u.into_owned(), f);
        let mut j = DMatrix::zeros(dim, dim + 1);
        j.view_mut((0, 0), (dim, dim)).copy_from(&(ju * (xs / fs)));
        j.set_column(dim, &(jf * (f_ref / fs)));
        (r / fs, j)
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
    let (_, j0) = scaled_jacobian(&w);
    let mut tangent = tangent_of(&j0, &seed).ok_or("continuation: singular start")?;
    if tangent[dim] * direction < 0.0 {
        tangent = -tangent;
    }
    let mut points = vec![make_point(scene, start, options, teeth, false)?];
    let mut step = options.initial_step;
    while points.len() < options.max_points {
        let predicted = &w + &tangent * step;
        let mut candidate = predicted.clone();
        let mut converged = false;
        let mut iterations = 0;
        for it in 1..=12 {
            iterations = it;
            let (r, j) = scaled_jacobian(&candidate);
            let mut a = DMatrix::zeros(dim + 1, dim + 1);
            a.view_mut((0, 0), (dim, dim + 1)).copy_from(&j);
            a.set_row(dim, &tangent.transpose());
            let mut g = DVector::zeros(dim + 1);
            g.rows_mut(0, dim).copy_from(&r);
            g[dim] = tangent.dot(&(&candidate - &predicted));
            let Some(delta) = a.lu().solve(&(-g)) else {
                break;
            };
            candidate += &delta;
            if delta.amax() <= hb.tolerance.max(1e-13) * 10.0 {
                converged = true;
                break;
            }
        }
        if !converged {
            step *= 0.5;
            if step < 1e-8 {
                return Err(format!(
                    "continuation stalled near {:.3} rad/s (step below 1e-8)",
                    points.last().map_or(options.from, |p| p.speed)
                ));
            }
            continue;
        }
        let (_, j) = scaled_jacobian(&candidate);
        let mut next = tangent_of(&j, &tangent).ok_or("continuation: singular tangent")?;
        if next.dot(&tangent) < 0.0 {
            next = -next;
        }
        let fold = next[dim] * tangent[dim] < 0.0;
        w = candidate;
        tangent = next;
        let f = w[dim] * f_ref;
        let solution = HbSolution {
            mesh_frequency: f,
            subharmonic: hb.subharmonic,
            coefficients: (w.rows(0, dim) * xs).iter().copied().collect(),
            iterations,
        };
        points.push(make_point(scene, solution, options, teeth, fold)?);
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
    Ok(points)
}

fn make_point(
    scene: &Scene,
    solution: HbSolution,
    options: &ContinuationOptions,
    teeth: f64,
    fold: bool,
) -> Result<BranchPoint, String> {
    let speed = solution.mesh_frequency * TAU / teeth;
    let multipliers = if options.stability {
        let mut at = scene.clone();
        at.operating.pinion_speed = speed;
        let y0 = solution.state_at(0.0);
        period_map(&at, &y0, solution.subharmonic)
            .ok()
            .map(|(_, m)| m.complex_eigenvalues().iter().copied().collect())
    } else {
        None
    };
    Ok(BranchPoint {
        solution,
        speed,
        multipliers,
        fold,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn projection_inverts_sampling_of_band_limited_signals() {
        let scene = Scene::example("spur_pair").unwrap();
        let options = HbOptions::new(5);
        let p = Problem::new(&scene, &options).unwrap();
        let u = DVector::from_fn(p.dim(), |i, _| (i as f64 + 1.0).sin());
        let back = &p.projection * (&p.gamma * &u);
        let err = (back - u).amax();
        assert!(err < 1e-9, "{err}");
    }
}
