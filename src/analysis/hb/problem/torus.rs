//! The Galerkin sums of a two-frequency train on the torus (issue 38): multi-dimensional
//! alternating frequency/time evaluation (Krack & Gross 2019 §2.5; Schilder, Vogt, Schreiber
//! & Osinga 2006 for the torus view of quasi-periodic HB).
//!
//! On the countershaft the retained orders are the tones `c·Q = a f_1 + b f_2` (`Q = (72, 19)`)
//! of total order `|a| + |b| ≤ H`. Along the orbit the HB phase `θ` sits on the torus at
//! `(ϑ_1, ϑ_2) = (72θ, 19θ) mod 1`, and each mesh's law depends on its own angle only (its
//! stiffness on its mesh phase, its force on its own deflection). So mesh `n` is integrated on a
//! grid of its own angle (Gauss–Legendre rules on the smooth pieces of one mesh cycle, between
//! the mesh's stiffness breakpoints, exact for the tones of degree `≤ 2H` the integrands hold
//! there: [`piece_nodes`]) times a uniform grid of the other angle (a power of two above `2H`,
//! exact for the residual's integrands of degree `≤ 2H` there), with one FFT per own node. The
//! torus projection of a tone differs from the projection along the line `(72θ, 19θ)` only by
//! the torus harmonics `c + k(19, −72)`, `k ≠ 0`, of total order ≥ 51, which the line
//! quadrature folds onto the retained ones.
//!
//! Cost per residual at H = 20: ~1.3·10⁴ law evaluations per mesh (about 100 own nodes × 64)
//! and as many FFTs of 64 points as own nodes, instead of 46 000 nodes each with a basis row,
//! a deflection and a projection over 841 coefficients. With [`Want::linear`] the evaluation
//! keeps the law's slopes for the matrix-free Jacobian products of Newton–Krylov
//! ([`Torus::product`], `krylov.rs`).
//!
//! Contact loss: where the law's contact pattern changes between two nodes of one own-angle
//! piece on a line of the grid, that piece of that line leaves the grid's sums and is cut at
//! the roots of the switching functions on the line, each part taking its own Gauss–Legendre
//! rule ([`Torus::split_piece`]; the nodes then differ per line, so the series there is summed
//! directly, from its fold onto the own component, [`Torus::fold`]: `2·top + 1` terms a node).
//! The moving cuts add the line quadrature's boundary terms (the damper's force jumps where a
//! contact opens). Along the other angle the uniform rule is then no longer exact (the pieces'
//! integrals are kinked functions of it); on the countershaft at 231 rad/s (mesh 1 lost 6 %
//! of the period) the solution is within 1e-5 of the line quadrature's in DTE RMS and 1.4e-4
//! in peak force, where either differs from shooting by 1.6e-4 and 5–7e-4 (the H = 20
//! truncation; `docs/harmonic-balance.md`).
//! [`Torus::accumulate`] declines (the problem keeps the split one-dimensional quadrature from
//! then on) only where the pattern changes but no switching function changes sign between the
//! grid's nodes.

use std::collections::BTreeMap;
use std::f64::consts::TAU;
use std::sync::Arc;

use nalgebra::DVector;
use rustfft::num_complex::Complex64;
use rustfft::{Fft, FftPlanner};

use super::{Accumulator, Problem, Want, PROBE};
use crate::mesh::geometry::quadrature::GaussLegendre;
use crate::model::{Drivetrain, MAX_MESH_DIRECTIONS};
use crate::solve::roots::illinois;

/// One mesh's grid of its own angle.
#[derive(Clone)]
struct OwnGrid {
    /// The base (0 or 1) of the mesh's own angle.
    base: usize,
    /// Nodes in mesh cycles (Gauss nodes, with zero-weight probes just inside every piece's
    /// ends), their weights, and the smooth piece (between two stiffness breakpoints) of each.
    nodes: Vec<f64>,
    weights: Vec<f64>,
    piece: Vec<usize>,
    /// Each smooth piece's ends `(lo, hi)` in mesh cycles.
    bounds: Vec<(f64, f64)>,
    /// `e^{2πiaφ}` of every own node for `a ∈ [−top, top]` (row-major, `2·top + 1` a row).
    table: Vec<Complex64>,
    /// The terms of [`Torus::own_product`]: `(t', t, α + top, conj)` for every pair of
    /// retained tones of equal (`e^{+}` part, `α = c'_u − c_u`) or opposite (`e^{−}` part,
    /// conjugated, `α = c'_u + c_u`) component along the other angle.
    pairs: Vec<(u32, u32, u32, bool)>,
}

/// The torus quadrature of a two-frequency problem.
#[derive(Clone)]
pub(in crate::analysis::hb) struct Torus {
    /// Tone `(a, b)` of each retained order and of each entry of [`Problem::sums`].
    tones: Vec<[i64; 2]>,
    sum_tones: Vec<[i64; 2]>,
    /// Largest `|component|` of the sum tones (the `e^{2πiaφ}` tables span `−top…top`).
    top: i64,
    /// Uniform points of the other angle.
    points: usize,
    grids: Vec<OwnGrid>,
    forward: Arc<dyn Fft<f64>>,
    inverse: Arc<dyn Fft<f64>>,
    /// The linearisation of the last evaluation that asked for it ([`Want::linear`]): per
    /// output, `w ∂F/∂S` and `w ∂F/∂Ṡ` at every point of its mesh's grid (`w` the point's
    /// weight), for the matrix-free Jacobian products of [`Torus::product`].
    slopes: Vec<Vec<f64>>,
    rates: Vec<Vec<f64>>,
    /// Per output, where its slopes depend on the own angle only (the same at every point of
    /// each own node's line: a law linear in the deflection with a constant contact pattern
    /// per piece, as on the countershaft without contact loss): their own-angle transforms
    /// `K(α) = Σ w k e^{−2πiαφ}`, `α ∈ [−top, top]`, of `∂F/∂S` and `∂F/∂Ṡ`.
    own: Vec<Option<[Vec<Complex64>; 2]>>,
    /// `e^{2πibϑ}` of every line `ϑ = k/points` of the other angle for `b ∈ [−top, top]`.
    lines: Vec<Vec<Complex64>>,
    /// The linearisation at the nodes and cuts of the split pieces ([`Torus::split_piece`]).
    split: Vec<SplitPiece>,
}

/// A piece of one line of the grid cut at its contact switches ([`Torus::split_piece`]),
/// kept for the matrix-free products: mesh, line, nodes and cuts.
#[derive(Clone)]
struct SplitPiece {
    mesh: usize,
    line: usize,
    nodes: Vec<SplitNode>,
    cuts: Vec<Cut>,
}

/// A node of a [`SplitPiece`]: `e^{2πiaφ}` of its own angle (`|a| ≤ top`), and per output
/// `w ∂F/∂S`, `w ∂F/∂Ṡ`.
#[derive(Clone)]
struct SplitNode {
    own: Vec<Complex64>,
    slopes: [f64; MAX_MESH_DIRECTIONS],
    rates: [f64; MAX_MESH_DIRECTIONS],
}

/// A contact switch of a [`SplitPiece`] at which output `out`'s force jumps by `ΔF`: the
/// moving cut adds `coefficient · δS(ϑ*)` times the tones at `ϑ*` to the Galerkin sums
/// (`coefficient = ΔF / (∂δ/∂φ) / points`, the torus form of the line quadrature's boundary
/// term; `own` as in [`SplitNode`]).
#[derive(Clone)]
struct Cut {
    out: usize,
    own: Vec<Complex64>,
    coefficient: f64,
}

/// One line `k` of mesh `n`'s grid and one of its pieces, for [`Torus::split_piece`]: the
/// mesh's coefficients and its series on the grid ([`Torus::series`]).
struct Line<'a> {
    n: usize,
    k: usize,
    piece: usize,
    coefficients: &'a [f64],
    x: &'a [Complex64],
    dx: &'a [Complex64],
}

impl std::fmt::Debug for Torus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "Torus({} tones, {} points)",
            self.tones.len(),
            self.points
        )
    }
}

/// The tone `c` with `c·q = j`, if it is the only one of total order `≤ limit` and its order
/// is `≤ h`.
fn tone(j: i64, q: [i64; 2], h: i64, limit: i64) -> Option<[i64; 2]> {
    let mut found: Vec<[i64; 2]> = Vec::new();
    for a in -limit..=limit {
        let rest = j - a * q[0];
        if rest % q[1] == 0 {
            let b = rest / q[1];
            if a.abs() + b.abs() <= limit {
                found.push([a, b]);
            }
        }
    }
    match found.as_slice() {
        [c] if c[0].abs() + c[1].abs() <= h => Some(*c),
        _ => None,
    }
}

/// Gauss–Legendre nodes of one smooth piece of `length` mesh cycles for the own-angle
/// integrands, trigonometric polynomials of degree up to `top` on the piece (the law's slope
/// there times a tone of total order ≤ 2H): such a tone spans `ω = π·top·length` radians of
/// the rule's half-interval, and the `n`-point rule (exact to degree `2n − 1`) converges on it
/// once `2n` exceeds `ω` by a margin (the Chebyshev series of `e^{iωx}` converges from degree
/// `ω` on; Trefethen 2008, SIAM Rev. 50:67–87, §4). With the margin here the highest tone errs
/// by at most ~1e-9 of the piece (2e-11 and 1.7e-10 on the countershaft's longest pieces at
/// H = 20, measured against the closed form), tones below ~1.7H by rounding: about 100 nodes
/// a mesh cycle instead of the 656 of the composite 3-point rule, which erred by ~1e-6 there.
fn piece_nodes(top: i64, length: f64) -> usize {
    let omega = std::f64::consts::PI * top as f64 * length;
    (0.5 * omega + 2.0 * omega.cbrt() + 8.0).ceil() as usize
}

/// The `n`-point Gauss–Legendre rule on `[−1, 1]`: (node, weight), ascending.
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    GaussLegendre::new(n).points().collect()
}

/// `e^{2πi a φ}` of every node `φ` for `a ∈ [−top, top]`, row-major (`2·top + 1` a row).
fn exponentials(nodes: &[f64], top: i64) -> Vec<Complex64> {
    let span = (2 * top + 1) as usize;
    let mid = top as usize;
    let mut table = vec![Complex64::new(0.0, 0.0); nodes.len() * span];
    for (i, &phi) in nodes.iter().enumerate() {
        let (sn, cs) = (TAU * phi).sin_cos();
        let z = Complex64::new(cs, sn);
        let row = &mut table[i * span..(i + 1) * span];
        row[mid] = Complex64::new(1.0, 0.0);
        for a in 1..=mid {
            row[mid + a] = row[mid + a - 1] * z;
            row[mid - a] = row[mid + a].conj();
        }
    }
    table
}

/// `b[a] += y e^{−2πiaφ}` for the own angle whose `e^{2πiaφ}` are `own` ([`Torus::spread`]).
fn gather(b: &mut [Complex64], own: &[Complex64], y: f64) {
    if y == 0.0 {
        return;
    }
    for (b, e) in b.iter_mut().zip(own) {
        *b += y * e.conj();
    }
}

impl Torus {
    /// The torus quadrature for `problem`, when it applies: two distinct base orders (the
    /// mesh frequencies, subharmonic 1, no gear errors, no back rows, the total-order basis),
    /// each mesh at one of them, and every retained order and every Toeplitz sum one tone.
    pub(in crate::analysis::hb) fn new<M: Drivetrain>(
        problem: &Problem<M>,
        bases: &[usize],
        h: usize,
    ) -> Option<Torus> {
        let mut distinct = bases.to_vec();
        distinct.sort_unstable();
        distinct.dedup();
        if distinct.len() != 2 || bases.len() != problem.meshes.len() {
            return None;
        }
        if problem.meshes.iter().any(|m| m.back.is_some()) {
            return None;
        }
        let q = [distinct[0] as i64, distinct[1] as i64];
        let h = h as i64;
        // Two tones of total order ≤ 2h (sums of two retained ones) with one order differ by a
        // tone of the kernel `c·q = 0` of order ≤ 4h: there must be none but 0.
        tone(0, q, 0, 4 * h)?;
        let tones: Vec<[i64; 2]> = (problem.orders.iter())
            .map(|&j| tone(j as i64, q, h, h))
            .collect::<Option<_>>()?;
        let sum_tones: Vec<[i64; 2]> = (problem.sums.iter())
            .map(|&(d, qi, p, plus)| {
                let (x, y) = (tones[qi], tones[p]);
                let c = if plus {
                    [x[0] + y[0], x[1] + y[1]]
                } else {
                    [x[0] - y[0], x[1] - y[1]]
                };
                (c[0] * q[0] + c[1] * q[1] == d as i64).then_some(c)
            })
            .collect::<Option<_>>()?;
        let top = (sum_tones.iter().chain(&tones))
            .map(|c| c[0].abs().max(c[1].abs()))
            .max()
            .unwrap_or(0);
        // Along the other angle the retained tones reach order H, so the residual's integrands
        // (a law linear in the deflection times a tone) are of degree ≤ 2H there: 2H + 1
        // uniform points integrate them exactly. The Jacobian's sum tones reach 2H, but a law
        // whose slopes depend on the own angle only (no contact change along a piece) has none
        // along the other angle, so they need no more.
        let points = (2 * h as usize + 1).next_power_of_two().max(8);
        let grids = (0..problem.meshes.len())
            .map(|n| {
                let base = distinct
                    .iter()
                    .position(|&b| b == bases[n])
                    .expect("a base");
                let p0 = problem.model.mesh_phase(n, 0.0);
                let mut breaks: Vec<f64> = (problem.model.mesh_breakpoints(n).iter())
                    .map(|&b| crate::mesh::cycle_fraction(b - p0))
                    .filter(|&x| x > 0.0 && x < 1.0)
                    .chain([0.0, 1.0])
                    .collect();
                breaks.sort_by(f64::total_cmp);
                breaks.dedup_by(|x, y| (*x - *y).abs() < 1e-14);
                let mut grid = OwnGrid {
                    base,
                    nodes: Vec::new(),
                    weights: Vec::new(),
                    piece: Vec::new(),
                    bounds: Vec::new(),
                    table: Vec::new(),
                    pairs: Vec::new(),
                };
                let (u, v) = (base, 1 - base);
                let mut by_other: BTreeMap<i64, Vec<usize>> = BTreeMap::new();
                for (q, c) in tones.iter().enumerate() {
                    by_other.entry(c[v]).or_default().push(q);
                }
                for (tp, cp) in tones.iter().enumerate() {
                    for (sign, conj) in [(1, false), (-1, true)] {
                        for &q in by_other.get(&(sign * cp[v])).into_iter().flatten() {
                            let a = if conj {
                                cp[u] + tones[q][u]
                            } else {
                                cp[u] - tones[q][u]
                            };
                            grid.pairs
                                .push((tp as u32, q as u32, (a + top) as u32, conj));
                        }
                    }
                }
                for (k, w) in breaks.windows(2).enumerate() {
                    let (lo, hi) = (w[0], w[1]);
                    let half = 0.5 * (hi - lo);
                    grid.bounds.push((lo, hi));
                    grid.nodes.push(lo + PROBE * half);
                    grid.weights.push(0.0);
                    for (x, wt) in gauss_legendre(piece_nodes(top, hi - lo)) {
                        grid.nodes.push(lo + half * (1.0 + x));
                        grid.weights.push(half * wt);
                    }
                    grid.nodes.push(hi - PROBE * half);
                    grid.weights.push(0.0);
                    grid.piece.resize(grid.nodes.len(), k);
                }
                grid.table = exponentials(&grid.nodes, top);
                grid
            })
            .collect();
        let mut planner = FftPlanner::new();
        Some(Torus {
            tones,
            sum_tones,
            top,
            points,
            grids,
            forward: planner.plan_fft_forward(points),
            inverse: planner.plan_fft_inverse(points),
            slopes: vec![Vec::new(); problem.outputs()],
            rates: vec![Vec::new(); problem.outputs()],
            own: vec![None; problem.outputs()],
            lines: (0..points)
                .map(|k| exponentials(&[k as f64 / points as f64], top))
                .collect(),
            split: Vec::new(),
        })
    }

    /// `e^{2πi a φ_i}` of own node `i` (`|a| ≤ top`).
    #[inline]
    fn e(&self, grid: &OwnGrid, i: usize, a: i64) -> Complex64 {
        grid.table[i * (2 * self.top + 1) as usize + (a + self.top) as usize]
    }

    /// A series of mesh `n` (`coefficients` over the retained orders) on line `k` of the
    /// other angle, folded onto its own component: `A[a] = Σ_{c_u = a} ĉ_t e^{2πi c_v ϑ_k}`
    /// and the same `D[a]` of `2πi j_t ĉ_t` (the θ-derivative), `a ∈ [−top, top]`. A point of
    /// the line then costs `2·top + 1` terms ([`Torus::at`]), not one per tone.
    fn fold<M: Drivetrain>(
        &self,
        problem: &Problem<M>,
        n: usize,
        coefficients: &[f64],
        k: usize,
    ) -> [Vec<Complex64>; 2] {
        let (u, v) = (self.grids[n].base, 1 - self.grids[n].base);
        let top = self.top;
        let line = &self.lines[k];
        let span = (2 * top + 1) as usize;
        let mut a = vec![Complex64::new(0.0, 0.0); span];
        let mut d = vec![Complex64::new(0.0, 0.0); span];
        a[top as usize] += Complex64::new(coefficients[0], 0.0);
        for (qi, &j) in problem.orders.iter().enumerate().skip(1) {
            let c = self.tones[qi];
            let hat = Complex64::new(coefficients[2 * qi - 1], -coefficients[2 * qi]);
            let z = hat * line[(c[v] + top) as usize];
            a[(c[u] + top) as usize] += z;
            d[(c[u] + top) as usize] += z * Complex64::new(0.0, TAU * j as f64);
        }
        [a, d]
    }

    /// `(S, dS/dθ, ∂S/∂φ)` of a folded series ([`Torus::fold`]) at the own angle whose
    /// `e^{2πiaφ}` are `own`.
    fn at(&self, [a, d]: &[Vec<Complex64>; 2], own: &[Complex64]) -> [f64; 3] {
        let (mut x, mut dx, mut dx_own) = (0.0, 0.0, 0.0);
        for (i, ((a, d), e)) in a.iter().zip(d).zip(own).enumerate() {
            let z = a * e;
            x += z.re;
            dx += (d * e).re;
            // Re(2πi a z) = −2π a Im z.
            dx_own -= TAU * (i as i64 - self.top) as f64 * z.im;
        }
        [x, dx, dx_own]
    }

    /// `Σ y e^{−2πi c·ϑ}` of the points of line `k` of mesh `n` whose own-angle sums are
    /// `b[a] = Σ y e^{−2πiaφ}` (gathered by [`gather`]), for the tones `tones`, added to `out`
    /// in the layout of [`Torus::project`].
    fn spread(
        &self,
        n: usize,
        k: usize,
        b: &[Complex64],
        tones: &[[i64; 2]],
        out: &mut [f64],
        paired: bool,
    ) {
        let (u, v) = (self.grids[n].base, 1 - self.grids[n].base);
        let (top, line) = (self.top, &self.lines[k]);
        for (t, c) in tones.iter().enumerate() {
            let sum = b[(c[u] + top) as usize] * line[(c[v] + top) as usize].conj();
            deposit(out, t, paired, sum);
        }
    }

    /// A series on mesh `n`'s grid (`coefficients`: `[c_0, a_1, b_1, …]` over the retained
    /// orders) and its θ-derivative, point `(i, k)` at `i·points + k`: per own node the
    /// partial sums over the own component, then the inverse FFT over the other angle.
    fn series<M: Drivetrain>(
        &self,
        problem: &Problem<M>,
        n: usize,
        coefficients: &[f64],
    ) -> (Vec<Complex64>, Vec<Complex64>) {
        let grid = &self.grids[n];
        let (u, v) = (grid.base, 1 - grid.base);
        let (rows, np) = (grid.nodes.len(), self.points);
        let mut x = vec![Complex64::new(0.0, 0.0); rows * np];
        let mut dx = vec![Complex64::new(0.0, 0.0); rows * np];
        for i in 0..rows {
            let (xr, dr) = (&mut x[i * np..(i + 1) * np], &mut dx[i * np..(i + 1) * np]);
            xr[0] += Complex64::new(coefficients[0], 0.0);
            for (qi, &j) in problem.orders.iter().enumerate().skip(1) {
                let c = self.tones[qi];
                let hat = Complex64::new(coefficients[2 * qi - 1], -coefficients[2 * qi]);
                let term = hat * self.e(grid, i, c[u]);
                let k = self.slot(c[v]);
                xr[k] += term;
                dr[k] += term * Complex64::new(0.0, TAU * j as f64);
            }
        }
        self.inverse.process(&mut x);
        self.inverse.process(&mut dx);
        (x, dx)
    }

    /// `Σ w y e^{−2πi c·ϑ}` over mesh `n`'s grid of the weighted samples `buf` (`w y`, point
    /// `(i, k)` at `i·points + k`; overwritten by their FFT) for the tones `tones`, added to
    /// `out` as (cos, sin) sums: `[c_0, a_1, b_1, …]` over the retained orders, or (`paired`)
    /// a (cos, sin) pair for every tone.
    fn project(
        &self,
        n: usize,
        buf: &mut [Complex64],
        tones: &[[i64; 2]],
        out: &mut [f64],
        paired: bool,
    ) {
        let grid = &self.grids[n];
        let (u, v) = (grid.base, 1 - grid.base);
        let (rows, np) = (grid.nodes.len(), self.points);
        self.forward.process(buf);
        for (t, c) in tones.iter().enumerate() {
            let slot = self.slot(c[v]);
            let mut sum = Complex64::new(0.0, 0.0);
            for i in 0..rows {
                sum += buf[i * np + slot] * self.e(grid, i, c[u]).conj();
            }
            deposit(out, t, paired, sum);
        }
    }

    /// The Galerkin sums `Σ w (∂F/∂S δS + ∂F/∂Ṡ δṠ) φ` per output (`[c_0, a_1, b_1, …]`,
    /// unweighted by the projection factors) for the mesh-deflection coefficients `ds`, from
    /// the linearisation of the last evaluation that asked for it ([`Want::linear`]): the
    /// directional derivative of the Galerkin sums of the force, without a Jacobian matrix
    /// (one partial-sum pass, two inverse and one forward FFT per own node and output).
    pub(in crate::analysis::hb) fn product<M: Drivetrain>(
        &self,
        problem: &Problem<M>,
        ds: &DVector<f64>,
    ) -> Vec<Vec<f64>> {
        let len = problem.len;
        let f = problem.f;
        let mut gal = vec![vec![0.0; len]; problem.outputs()];
        for n in 0..self.grids.len() {
            let mesh = &problem.meshes[n];
            let coefficients = &ds.as_slice()[n * len..(n + 1) * len];
            let outputs = mesh.first..mesh.first + mesh.outputs;
            if outputs.clone().all(|out| self.own[out].is_some()) {
                for out in outputs {
                    let own = self.own[out].as_ref().expect("checked");
                    self.own_product(problem, n, own, coefficients, &mut gal[out]);
                }
                continue;
            }
            let (x, dx) = self.series(problem, n, coefficients);
            let mut buf = vec![Complex64::new(0.0, 0.0); x.len()];
            for out in outputs {
                let (ks, kv) = (&self.slopes[out], &self.rates[out]);
                for (p, b) in buf.iter_mut().enumerate() {
                    *b = Complex64::new(ks[p] * x[p].re + kv[p] * f * dx[p].re, 0.0);
                }
                self.project(n, &mut buf, &self.tones, &mut gal[out], false);
            }
        }
        // The split pieces' nodes and the moving cuts (contact loss).
        let span = (2 * self.top + 1) as usize;
        for piece in &self.split {
            let (n, k) = (piece.mesh, piece.line);
            let mesh = &problem.meshes[n];
            let folded = self.fold(problem, n, &ds.as_slice()[n * len..(n + 1) * len], k);
            let mut b = vec![vec![Complex64::new(0.0, 0.0); span]; mesh.outputs];
            for node in &piece.nodes {
                let [x, dx, _] = self.at(&folded, &node.own);
                for (o, b) in b.iter_mut().enumerate() {
                    gather(b, &node.own, node.slopes[o] * x + node.rates[o] * f * dx);
                }
            }
            for cut in &piece.cuts {
                let [x, _, _] = self.at(&folded, &cut.own);
                gather(&mut b[cut.out - mesh.first], &cut.own, cut.coefficient * x);
            }
            for (o, b) in b.iter().enumerate() {
                self.spread(n, k, b, &self.tones, &mut gal[mesh.first + o], false);
            }
        }
        gal
    }

    /// [`Torus::product`] of one output of mesh `n` whose slopes depend on its own angle only
    /// (`own`: their transforms `K_S`, `K_Ṡ`), in the coefficients: with
    /// `δS = Re Σ_t ĉ_t e^{2πi c_t·ϑ}` the sum over the other angle keeps the tones of equal
    /// (`e^{+}` part) and opposite (`e^{−}` part) other component, so tone `t'` sums
    /// `½ ĉ_t (K_S + 2πi j_t f K_Ṡ)(c'_u − c_u) + ½ ĉ_t* (K_S − 2πi j_t f K_Ṡ)(c'_u + c_u)`:
    /// the same sums as the grid pass, `O(|J| · 2H)` instead of a pass over the grid.
    fn own_product<M: Drivetrain>(
        &self,
        problem: &Problem<M>,
        n: usize,
        [ks, kv]: &[Vec<Complex64>; 2],
        coefficients: &[f64],
        out: &mut [f64],
    ) {
        let f = problem.f;
        let hats: Vec<Complex64> = (0..self.tones.len())
            .map(|q| {
                if q == 0 {
                    Complex64::new(coefficients[0], 0.0)
                } else {
                    Complex64::new(coefficients[2 * q - 1], -coefficients[2 * q])
                }
            })
            .collect();
        let rates: Vec<f64> = (problem.orders.iter())
            .map(|&j| TAU * j as f64 * f)
            .collect();
        let mut sums = vec![Complex64::new(0.0, 0.0); self.tones.len()];
        for &(tp, q, a, conj) in &self.grids[n].pairs {
            let (q, a) = (q as usize, a as usize);
            let rate = Complex64::new(0.0, rates[q]) * kv[a];
            sums[tp as usize] += if conj {
                hats[q].conj() * (ks[a] - rate)
            } else {
                hats[q] * (ks[a] + rate)
            };
        }
        for (tp, &sum) in sums.iter().enumerate() {
            deposit(out, tp, false, 0.5 * sum);
        }
    }

    /// The sums of a piece of `line` in which a contact switches: the piece cut at the roots
    /// of the switching functions on that line ([`Drivetrain::contact_gaps`], bracketed by the
    /// grid's own nodes) and each part integrated by its own Gauss–Legendre rule
    /// ([`piece_nodes`]), the series evaluated from its fold onto the own component
    /// ([`Torus::fold`]); with [`Want::jacobian`] the cuts' boundary terms as on the line
    /// (`evaluate.rs`, `split_cell`), with [`Want::linear`] the nodes and cuts for
    /// [`Torus::product`] (pushed to `kept`). False where the pattern changes but no
    /// switching function changes sign between the grid's nodes.
    fn split_piece<M: Drivetrain>(
        &self,
        problem: &Problem<M>,
        line: &Line,
        want: Want,
        acc: &mut Accumulator,
        kept: &mut Vec<SplitPiece>,
    ) -> bool {
        let &Line {
            n,
            k,
            piece,
            coefficients,
            x,
            dx,
        } = line;
        let grid = &self.grids[n];
        let mesh = &problem.meshes[n];
        let (f, np, top) = (problem.f, self.points, self.top);
        let nm = problem.meshes.len();
        let to_time = 1.0 / (mesh.cycles * f);
        let (lo, hi) = grid.bounds[piece];
        let folded = self.fold(problem, n, coefficients, k);
        let nodes: Vec<usize> = (0..grid.nodes.len())
            .filter(|&i| grid.piece[i] == piece)
            .collect();
        let mut buf = Vec::new();
        let grid_gaps = |i: usize, buf: &mut Vec<(f64, f64)>| -> Vec<f64> {
            let p = i * np + k;
            let t = grid.nodes[i] * to_time;
            (problem.model).contact_gaps(n, t, x[p].re, f * dx[p].re, buf);
            buf.iter().map(|g| g.0).collect()
        };
        // Switching function `q` and its derivative along the own angle at `φ` on the line
        // (the rate passed is `∂S/∂φ` in time units, so the returned rate is along the line).
        let gap = |phi: f64, q: usize, buf: &mut Vec<(f64, f64)>| -> (f64, f64) {
            let [s, _, s_own] = self.at(&folded, &exponentials(&[phi], top));
            (problem.model).contact_gaps(n, phi * to_time, s, s_own / to_time, buf);
            buf.get(q).map_or((0.0, 0.0), |g| (g.0, g.1 * to_time))
        };
        let law_at = |phi: f64| {
            let own = exponentials(&[phi], top);
            let [s, ds, _] = self.at(&folded, &own);
            (own, problem.model.mesh_law(n, phi * to_time, s, f * ds))
        };
        let mut switches: Vec<(f64, usize)> = Vec::new();
        let mut before = grid_gaps(nodes[0], &mut buf);
        for pair in nodes.windows(2) {
            let after = grid_gaps(pair[1], &mut buf);
            for (q, (a, b)) in before.iter().zip(&after).enumerate() {
                if (*a > 0.0) != (*b > 0.0) {
                    let bracket = (grid.nodes[pair[0]], grid.nodes[pair[1]]);
                    let root = illinois(|phi| gap(phi, q, &mut buf).0, bracket);
                    switches.push((root, q));
                }
            }
            before = after;
        }
        if switches.is_empty() {
            return false;
        }
        switches.sort_by(|a, b| a.0.total_cmp(&b.0));
        // Per output the own-angle sums ([`gather`]) of the force, its viscous part, ∂F/∂S
        // and ∂F/∂Ṡ, spread onto the tones at the end.
        let span = (2 * top + 1) as usize;
        let mut sums = vec![vec![Complex64::new(0.0, 0.0); span]; 4 * mesh.outputs];
        let mut piece_kept = SplitPiece {
            mesh: n,
            line: k,
            nodes: Vec::new(),
            cuts: Vec::new(),
        };
        let mut start = lo;
        for end in switches.iter().map(|c| c.0).chain([hi]) {
            let half = 0.5 * (end - start);
            if half <= 0.0 {
                continue;
            }
            for (node, wt) in gauss_legendre(piece_nodes(top, end - start)) {
                let w = half * wt / np as f64;
                let (own, law) = law_at(start + half * (1.0 + node));
                for o in 0..mesh.outputs {
                    gather(&mut sums[4 * o], &own, w * law.force[o]);
                    if want.frequency {
                        gather(&mut sums[4 * o + 1], &own, w * law.viscous[o]);
                    }
                    if want.jacobian {
                        gather(&mut sums[4 * o + 2], &own, w * law.stiffness[o]);
                        gather(&mut sums[4 * o + 3], &own, w * law.damping[o]);
                    }
                }
                if want.samples {
                    for m in 0..nm {
                        acc.sample_w.push(if m == n { w } else { 0.0 });
                        let force = problem.total_force(n, &law);
                        acc.sample_force.push(if m == n { force } else { 0.0 });
                        acc.sample_lost.push(m == n && law.in_contact == 0);
                    }
                }
                if want.linear {
                    piece_kept.nodes.push(SplitNode {
                        own,
                        slopes: law.stiffness.map(|k| w * k),
                        rates: law.damping.map(|c| w * c),
                    });
                }
            }
            start = end;
        }
        for o in 0..mesh.outputs {
            let out = mesh.first + o;
            let (tones, pairs) = (&self.tones, &self.sum_tones);
            self.spread(n, k, &sums[4 * o], tones, &mut acc.gal[out], false);
            if want.frequency {
                self.spread(n, k, &sums[4 * o + 1], tones, &mut acc.visc[out], false);
            }
            if want.jacobian {
                self.spread(n, k, &sums[4 * o + 2], pairs, &mut acc.kap_s[out], true);
                self.spread(n, k, &sums[4 * o + 3], pairs, &mut acc.kap_v[out], true);
            }
        }
        if want.jacobian || want.linear {
            // A cut moving with the state moves the force's jump: `ΔF/(∂δ/∂φ) · δS(ϑ*)`.
            let h = 1e-3 * (PROBE * (hi - lo)).max(1e-14);
            for &(phi, q) in &switches {
                let rate = gap(phi, q, &mut buf).1;
                if rate == 0.0 {
                    continue;
                }
                let ((_, left), (_, right)) = (law_at(phi - h), law_at(phi + h));
                let own = exponentials(&[phi], top);
                for o in 0..mesh.outputs {
                    // Only the jump counts: remove the continuous part's change over 2h.
                    let slope = 0.5 * (right.stiffness[o] + left.stiffness[o]) * rate;
                    let jump = right.force[o] - left.force[o] - slope * 2.0 * h;
                    if jump.abs() <= 1e-9 * (right.force[o].abs() + left.force[o].abs()) {
                        continue;
                    }
                    let coefficient = jump / rate / np as f64;
                    let out = mesh.first + o;
                    if want.jacobian {
                        // The tones at the cut: the basis row `φ(θ*)` of the line's term.
                        let mut b = vec![Complex64::new(0.0, 0.0); span];
                        gather(&mut b, &own, 1.0);
                        let mut row = vec![0.0; problem.len];
                        row[0] = 1.0;
                        self.spread(n, k, &b, &self.tones[1..], &mut row[1..], true);
                        acc.boundary.push((out, coefficient, row));
                    }
                    if want.linear {
                        piece_kept.cuts.push(Cut {
                            out,
                            own: own.clone(),
                            coefficient,
                        });
                    }
                }
            }
        }
        if want.linear {
            kept.push(piece_kept);
        }
        true
    }

    /// Index of component `b` on the uniform grid's FFT.
    #[inline]
    fn slot(&self, b: i64) -> usize {
        b.rem_euclid(self.points as i64) as usize
    }

    /// Adds every mesh's torus sums to `acc` (the same sums as the one-dimensional pass, over
    /// the torus): false, with `acc` partly filled, where a contact pattern changes inside a
    /// smooth piece on some grid line (the caller then integrates along the line). With
    /// [`Want::linear`] it keeps the slopes for [`Torus::product`].
    pub(in crate::analysis::hb) fn accumulate<M: Drivetrain>(
        &mut self,
        problem: &Problem<M>,
        s: &DVector<f64>,
        want: Want,
        acc: &mut Accumulator,
    ) -> bool {
        let f = problem.f;
        let len = problem.len;
        let nm = problem.meshes.len();
        let np = self.points;
        let mut kept = Vec::new();
        for n in 0..self.grids.len() {
            let grid = &self.grids[n];
            let mesh = &problem.meshes[n];
            let rows = grid.nodes.len();
            let pieces = grid.bounds.len();
            let coefficients = &s.as_slice()[n * len..(n + 1) * len];
            let (x, dx) = self.series(problem, n, coefficients);
            // The law at every grid point. Kept per output and signal (force, viscous force,
            // ∂F/∂S, ∂F/∂Ṡ: `values[(4o + k)·total + point]`), not as whole laws: these arrays
            // are what the sums read.
            let outs = mesh.outputs;
            let total = rows * np;
            let mut values = vec![0.0; 4 * outs * total];
            let (mut totals, mut lost) = (Vec::new(), Vec::new());
            if want.samples {
                totals.resize(total, 0.0);
                lost.resize(total, false);
            }
            let to_time = 1.0 / (mesh.cycles * f);
            // Pieces of a line in which the contact pattern changes: integrated apart.
            let mut split = vec![false; np * pieces];
            for k in 0..np {
                let mut previous: Option<(usize, u64)> = None;
                for i in 0..rows {
                    let law = problem.model.mesh_law(
                        n,
                        grid.nodes[i] * to_time,
                        x[i * np + k].re,
                        f * dx[i * np + k].re,
                    );
                    match previous {
                        Some((piece, pattern))
                            if piece == grid.piece[i] && pattern != law.pattern =>
                        {
                            split[k * pieces + piece] = true;
                        }
                        _ => previous = Some((grid.piece[i], law.pattern)),
                    }
                    let p = i * np + k;
                    for o in 0..outs {
                        let at = 4 * o * total + p;
                        values[at] = law.force[o];
                        values[at + total] = law.viscous[o];
                        values[at + 2 * total] = law.stiffness[o];
                        values[at + 3 * total] = law.damping[o];
                    }
                    if want.samples {
                        totals[p] = problem.total_force(n, &law);
                        lost[p] = law.in_contact == 0;
                    }
                }
            }
            // A split piece's grid points leave the grid's sums; its parts between the
            // switches take their own Gauss rules (`split_piece`).
            let mut dropped = vec![false; total];
            for k in 0..np {
                for p in 0..pieces {
                    if !split[k * pieces + p] {
                        continue;
                    }
                    for i in (0..rows).filter(|&i| grid.piece[i] == p) {
                        dropped[i * np + k] = true;
                        for v in 0..4 * outs {
                            values[v * total + i * np + k] = 0.0;
                        }
                    }
                    let line = Line {
                        n,
                        k,
                        piece: p,
                        coefficients,
                        x: &x,
                        dx: &dx,
                    };
                    if !self.split_piece(problem, &line, want, acc, &mut kept) {
                        return false;
                    }
                }
            }
            if want.samples {
                for i in 0..rows {
                    let w = grid.weights[i] / np as f64;
                    if w == 0.0 {
                        continue;
                    }
                    for k in 0..np {
                        let p = i * np + k;
                        if dropped[p] {
                            continue;
                        }
                        for m in 0..nm {
                            acc.sample_w.push(if m == n { w } else { 0.0 });
                            acc.sample_force.push(if m == n { totals[p] } else { 0.0 });
                            acc.sample_lost.push(m == n && lost[p]);
                        }
                    }
                }
            }
            // `w y` of signal `k` of output `o` at every grid point.
            let weighted = |o: usize, k: usize| -> Vec<f64> {
                let y = &values[(4 * o + k) * total..(4 * o + k + 1) * total];
                let mut wy = vec![0.0; total];
                for i in 0..rows {
                    let w = grid.weights[i] / np as f64;
                    for c in 0..np {
                        wy[i * np + c] = w * y[i * np + c];
                    }
                }
                wy
            };
            // Σ w y e^{−2πi c·ϑ} of the weighted samples over the tones, into (cos, sin) sums.
            let mut buf = vec![Complex64::new(0.0, 0.0); total];
            let mut project = |y: &[f64], tones: &[[i64; 2]], out: &mut [f64], paired: bool| {
                if y.iter().all(|&y| y == 0.0) {
                    return;
                }
                for (b, &y) in buf.iter_mut().zip(y) {
                    *b = Complex64::new(y, 0.0);
                }
                self.project(n, &mut buf, tones, out, paired);
            };
            for o in 0..outs {
                let out = mesh.first + o;
                project(&weighted(o, 0), &self.tones, &mut acc.gal[out], false);
                if want.frequency {
                    project(&weighted(o, 1), &self.tones, &mut acc.visc[out], false);
                }
                if want.jacobian {
                    project(&weighted(o, 2), &self.sum_tones, &mut acc.kap_s[out], true);
                    project(&weighted(o, 3), &self.sum_tones, &mut acc.kap_v[out], true);
                }
            }
            if want.linear {
                for o in 0..outs {
                    let out = mesh.first + o;
                    let (slopes, rates) = (weighted(o, 2), weighted(o, 3));
                    // Slopes the same along every own node's line: their own-angle transforms.
                    let flat = |y: &[f64]| {
                        y.chunks_exact(np)
                            .all(|line| line.iter().all(|&x| x == line[0]))
                    };
                    let whole = !split.contains(&true);
                    let own = (whole && flat(&slopes) && flat(&rates)).then(|| {
                        [&slopes, &rates].map(|y| {
                            (-self.top..=self.top)
                                .map(|a| {
                                    (0..rows).fold(Complex64::new(0.0, 0.0), |sum, i| {
                                        sum + self.e(grid, i, a).conj() * (y[i * np] * np as f64)
                                    })
                                })
                                .collect()
                        })
                    });
                    self.own[out] = own;
                    self.slopes[out] = slopes;
                    self.rates[out] = rates;
                }
            }
        }
        if want.linear {
            self.split = kept;
        }
        true
    }
}

/// Adds tone `t`'s complex sum `Σ y e^{−2πi c·ϑ}` to `out` as its (cos, sin) sums (cos = Re,
/// sin = −Im): in the layout `[c_0, a_1, b_1, …]` over the retained orders, or (`paired`) as
/// a (cos, sin) pair for every tone.
#[inline]
fn deposit(out: &mut [f64], t: usize, paired: bool, sum: Complex64) {
    if paired {
        out[2 * t] += sum.re;
        out[2 * t + 1] -= sum.im;
    } else if t == 0 {
        out[0] += sum.re;
    } else {
        out[2 * t - 1] += sum.re;
        out[2 * t] -= sum.im;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The own-angle rule integrates every tone up to its degree over pieces of a cycle
    /// (the countershaft's at H = 20, a whole cycle, a short piece) to 2e-9 of the piece
    /// against `∫ e^{2πidφ} dφ` in closed form (the whole cycle, the worst, errs by 9.7e-10
    /// at degree 40); a rule of half the nodes misses by more than 1e-9.
    #[test]
    fn piece_rules_integrate_the_tones_exactly() {
        assert_eq!(gauss_legendre(1), vec![(0.0, 2.0)]);
        let top = 40;
        for (lo, hi) in [
            (0.0, 0.6),
            (0.6, 1.0),
            (0.0, 0.7),
            (0.7, 1.0),
            (0.0, 1.0),
            (0.25, 0.3),
        ] {
            let half = 0.5 * (hi - lo);
            let rule = gauss_legendre(piece_nodes(top, hi - lo));
            for d in 0..=top {
                let w = TAU * d as f64;
                let (mut re, mut im) = (0.0, 0.0);
                for &(x, wt) in &rule {
                    let (s, c) = (w * (lo + half * (1.0 + x))).sin_cos();
                    re += half * wt * c;
                    im += half * wt * s;
                }
                let (exact_re, exact_im) = if d == 0 {
                    (hi - lo, 0.0)
                } else {
                    (
                        (w * hi).sin() - (w * lo).sin(),
                        (w * lo).cos() - (w * hi).cos(),
                    )
                };
                let (exact_re, exact_im) = if d == 0 {
                    (exact_re, exact_im)
                } else {
                    (exact_re / w, exact_im / w)
                };
                let error = (re - exact_re).hypot(im - exact_im);
                assert!(
                    error < 2e-9 * (hi - lo),
                    "[{lo}, {hi}] degree {d}: {error:e}"
                );
            }
        }
        let (lo, hi) = (0.0, 0.6);
        let half = 0.5 * (hi - lo);
        let rule = gauss_legendre(piece_nodes(top, hi - lo) / 2);
        let w = TAU * top as f64;
        let re: f64 = (rule.iter())
            .map(|&(x, wt)| half * wt * (w * (lo + half * (1.0 + x))).cos())
            .sum();
        let exact = ((w * hi).sin() - (w * lo).sin()) / w;
        assert!((re - exact).abs() > 1e-9, "{re} {exact}");
    }
}
