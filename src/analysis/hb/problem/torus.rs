//! The Galerkin sums of a two-frequency train on the torus (issue 38): multi-dimensional
//! alternating frequency/time evaluation (Krack & Gross 2019 §2.5; Schilder, Vogt, Schreiber
//! & Osinga 2006 for the torus view of quasi-periodic HB).
//!
//! On the countershaft the retained orders are the tones `c·Q = a f_1 + b f_2` (`Q = (72, 19)`)
//! of total order `|a| + |b| ≤ H`. Along the orbit the HB phase `θ` sits on the torus at
//! `(ϑ_1, ϑ_2) = (72θ, 19θ) mod 1`, and each mesh's law depends on its own angle only (its
//! stiffness on its mesh phase, its force on its own deflection). So mesh `n` is integrated on a
//! grid of its own angle (the composite Gauss rule of [`super`], split at the mesh's
//! stiffness breakpoints, over one mesh cycle: `16(2H + 1)` nodes) times a uniform grid of the
//! other angle (a power of two above `4H`, exact for the trigonometric polynomials of degree
//! `≤ 2H` the projections and the Jacobian's Toeplitz sums need there), with one FFT per own
//! node. The torus projection of a tone differs from the projection along the line
//! `(72θ, 19θ)` only by the torus harmonics `c + k(19, −72)`, `k ≠ 0`, of total order ≥ 51,
//! which the line quadrature folds onto the retained ones.
//!
//! Cost per residual: ~2·10⁵ law evaluations and 2·656 FFTs of 128 points at H = 20, instead
//! of 46 000 nodes each with a basis row, a deflection and a projection over 841 coefficients
//! (and ~5 800 Toeplitz sums for a Jacobian).
//!
//! Contact changes inside a smooth piece (contact loss) are not split here: where the law's
//! contact pattern changes between two nodes of one own-angle piece on any line of the grid,
//! [`Torus::accumulate`] declines, and the problem keeps the split one-dimensional quadrature
//! from then on.

use std::f64::consts::TAU;
use std::sync::Arc;

use nalgebra::DVector;
use rustfft::num_complex::Complex64;
use rustfft::{Fft, FftPlanner};

use super::{Accumulator, Problem, Want, GAUSS3, PROBE};
use crate::model::{Drivetrain, MeshLaw};

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
        let points = (2 * top as usize + 1).next_power_of_two().max(8);
        let own_samples = (16 * (2 * h as usize + 1)).max(256);
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
                };
                for (k, w) in breaks.windows(2).enumerate() {
                    let (lo, hi) = (w[0], w[1]);
                    let count = ((own_samples as f64 / 3.0) * (hi - lo)).ceil().max(1.0) as usize;
                    let step = (hi - lo) / count as f64;
                    grid.nodes.push(lo + PROBE * step);
                    grid.weights.push(0.0);
                    for c in 0..count {
                        let mid = lo + (c as f64 + 0.5) * step;
                        for (x, wt) in GAUSS3 {
                            grid.nodes.push(mid + 0.5 * step * x);
                            grid.weights.push(0.5 * step * wt);
                        }
                    }
                    grid.nodes.push(hi - PROBE * step);
                    grid.weights.push(0.0);
                    grid.piece.resize(grid.nodes.len(), k);
                }
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
        })
    }

    /// Index of component `b` on the uniform grid's FFT.
    #[inline]
    fn slot(&self, b: i64) -> usize {
        b.rem_euclid(self.points as i64) as usize
    }

    /// Adds every mesh's torus sums to `acc` (the same sums as the one-dimensional pass, over
    /// the torus): false, with `acc` partly filled, where a contact pattern changes inside a
    /// smooth piece on some grid line (the caller then integrates along the line).
    pub(in crate::analysis::hb) fn accumulate<M: Drivetrain>(
        &self,
        problem: &Problem<M>,
        s: &DVector<f64>,
        want: Want,
        acc: &mut Accumulator,
    ) -> bool {
        let f = problem.f;
        let len = problem.len;
        let nm = problem.meshes.len();
        let np = self.points;
        let span = (2 * self.top + 1) as usize;
        for (n, grid) in self.grids.iter().enumerate() {
            let mesh = &problem.meshes[n];
            let (u, v) = (grid.base, 1 - grid.base);
            let rows = grid.nodes.len();
            // e^{2πiaφ} of every own node for a ∈ [−top, top].
            let mut table = vec![Complex64::new(0.0, 0.0); rows * span];
            for (i, &phi) in grid.nodes.iter().enumerate() {
                let (sn, cs) = (TAU * phi).sin_cos();
                let z = Complex64::new(cs, sn);
                let row = &mut table[i * span..(i + 1) * span];
                let mid = self.top as usize;
                row[mid] = Complex64::new(1.0, 0.0);
                for a in 1..=mid {
                    row[mid + a] = row[mid + a - 1] * z;
                    row[mid - a] = row[mid + a].conj();
                }
            }
            let e = |i: usize, a: i64| table[i * span + (a + self.top) as usize];
            // S and dS/dθ on the grid: per own node the partial sums over the own component,
            // then the inverse FFT over the other angle.
            let coefficients = &s.as_slice()[n * len..(n + 1) * len];
            let mut x = vec![Complex64::new(0.0, 0.0); rows * np];
            let mut dx = vec![Complex64::new(0.0, 0.0); rows * np];
            for i in 0..rows {
                let (xr, dr) = (&mut x[i * np..(i + 1) * np], &mut dx[i * np..(i + 1) * np]);
                xr[0] += Complex64::new(coefficients[0], 0.0);
                for (qi, &j) in problem.orders.iter().enumerate().skip(1) {
                    let c = self.tones[qi];
                    let hat = Complex64::new(coefficients[2 * qi - 1], -coefficients[2 * qi]);
                    let term = hat * e(i, c[u]);
                    let k = self.slot(c[v]);
                    xr[k] += term;
                    dr[k] += term * Complex64::new(0.0, TAU * j as f64);
                }
            }
            self.inverse.process(&mut x);
            self.inverse.process(&mut dx);
            // The law at every grid point; the contact pattern constant along each piece.
            let outs = mesh.outputs;
            let total = rows * np;
            let mut laws = vec![MeshLaw::default(); total];
            let to_time = 1.0 / (mesh.cycles * f);
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
                            return false
                        }
                        _ => previous = Some((grid.piece[i], law.pattern)),
                    }
                    laws[i * np + k] = law;
                }
            }
            if want.samples {
                for i in 0..rows {
                    let w = grid.weights[i] / np as f64;
                    if w == 0.0 {
                        continue;
                    }
                    for k in 0..np {
                        let law = &laws[i * np + k];
                        for m in 0..nm {
                            acc.sample_w.push(if m == n { w } else { 0.0 });
                            acc.sample_force.push(if m == n {
                                problem.total_force(n, law)
                            } else {
                                0.0
                            });
                            acc.sample_lost.push(m == n && law.in_contact == 0);
                        }
                    }
                }
            }
            // Σ w y e^{−2πi c·ϑ} of a signal y over the tones `tones`, into (cos, sin) sums.
            let mut buf = vec![Complex64::new(0.0, 0.0); total];
            let mut project = |signal: &dyn Fn(&MeshLaw) -> f64,
                               tones: &[[i64; 2]],
                               out: &mut [f64],
                               paired: bool| {
                let mut any = false;
                for i in 0..rows {
                    let w = grid.weights[i] / np as f64;
                    for k in 0..np {
                        let y = w * signal(&laws[i * np + k]);
                        any |= y != 0.0;
                        buf[i * np + k] = Complex64::new(y, 0.0);
                    }
                }
                if !any {
                    return;
                }
                self.forward.process(&mut buf);
                for (t, c) in tones.iter().enumerate() {
                    let slot = self.slot(c[v]);
                    let mut sum = Complex64::new(0.0, 0.0);
                    for i in 0..rows {
                        sum += buf[i * np + slot] * e(i, c[u]).conj();
                    }
                    // cos sum = Re, sin sum = −Im.
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
            };
            for o in 0..outs {
                let out = mesh.first + o;
                project(
                    &|l: &MeshLaw| l.force[o],
                    &self.tones,
                    &mut acc.gal[out],
                    false,
                );
                if want.frequency {
                    project(
                        &|l: &MeshLaw| l.viscous[o],
                        &self.tones,
                        &mut acc.visc[out],
                        false,
                    );
                }
                if want.jacobian {
                    project(
                        &|l: &MeshLaw| l.stiffness[o],
                        &self.sum_tones,
                        &mut acc.kap_s[out],
                        true,
                    );
                    project(
                        &|l: &MeshLaw| l.damping[o],
                        &self.sum_tones,
                        &mut acc.kap_v[out],
                        true,
                    );
                }
            }
        }
        true
    }
}
