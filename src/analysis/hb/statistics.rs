//! Each mesh's response on a converged harmonic-balance orbit ([`MeshResponse`]), from the
//! harmonic series itself rather than from samples (issue 31): the DTE's mean, RMS (Parseval)
//! and harmonics from its coefficients; its extremes from the series evaluated on a fine grid
//! and refined by Newton on the series' analytic derivatives; the peak mesh force from the law
//! along the series on the same grid, refined to the maximum ([`brent_maximum`] around every
//! grid maximum that may be the highest: the law kinks where a contact switches); the
//! separation phase at the root of the contact gap that opens (the regula falsi of the
//! quadrature's split cells, [`Problem::root`]), or by bisection on the contact law where no
//! single gap decides it; the force RMS and the contact-loss fraction by the Galerkin
//! quadrature, whose cells are split at the switching instants (so both are exact for the
//! series up to the rule's accuracy on smooth pieces); on the torus quadrature, whose nodes
//! weigh the torus rather than the orbit, the contact-loss fraction from the lost stretches of
//! the scan grid, their ends refined like the separation.

use std::f64::consts::TAU;

use nalgebra::DVector;

use super::problem::{Evaluation, Problem};
use crate::analysis::mesh_response::MeshResponse;
use crate::model::Drivetrain;
use crate::solve::roots::brent_maximum;

/// Abscissa tolerance of the refinement, in HB periods.
const REFINE_TOL: f64 = 1e-13;

/// Newton steps of a DTE extreme before it falls back to Brent's search.
const NEWTON_STEPS: usize = 8;

/// A Newton step below this (HB periods) is the last: the point it lands on is within
/// `~(π j_max)·step²` (< 1e-13 for the orders HB retains) of the extreme, whose value is then
/// exact to rounding.
const NEWTON_LAST_STEP: f64 = 1e-8;

impl<M: Drivetrain> Problem<M> {
    /// Mesh `n`'s response at frequency `f` from the orbit's mesh-deflection coefficients `s`,
    /// its DTE coefficients `dte` and the evaluation `e` (with node samples).
    pub(super) fn mesh_response(
        &self,
        n: usize,
        f: f64,
        s: &DVector<f64>,
        dte: &[f64],
        e: &Evaluation,
    ) -> MeshResponse {
        let mesh = &self.meshes[n];
        let harmonic = |h: usize| {
            let j = h * mesh.cycles as usize;
            self.orders
                .iter()
                .position(|&o| o == j)
                .filter(|&q| q > 0)
                .map_or(0.0, |q| dte[2 * q - 1].hypot(dte[2 * q]))
        };
        // Every series on one grid `θ_i = i/points` ([`super::scan::ScanGrid`]). The DTE about
        // its mean (`dte[0]`, which cancels in the peak to peak): its refinement then settles
        // to a rounding unit of the oscillation, not of the mean.
        let points = self.scan.points();
        let h = 1.0 / points as f64;
        let coefficients = &s.as_slice()[n * self.len..(n + 1) * self.len];
        let x = self.scan.series(&self.orders, coefficients, false);
        let dx = self.scan.series(&self.orders, coefficients, true);
        let mut about_mean = dte.to_vec();
        about_mean[0] = 0.0;
        let dte_grid = self.scan.series(&self.orders, &about_mean, false);
        let (mut force_grid, mut lost_grid) =
            (Vec::with_capacity(points), Vec::with_capacity(points));
        let back = mesh.back.map(|c| self.grid_series(s, c));
        for (i, (&x, &dx)) in x.iter().zip(&dx).enumerate() {
            let t = i as f64 * h / f;
            let law = match &back {
                None => self.model.mesh_law(n, t, x, f * dx),
                Some((xb, dxb)) => {
                    self.model
                        .mesh_law_with_back(n, t, x, f * dx, (xb[i], f * dxb[i]))
                }
            };
            force_grid.push(self.total_force(n, &law).abs());
            lost_grid.push(law.in_contact == 0);
        }
        // The refinements evaluate the series with one `sin_cos` and powers of it
        // ([`Problem::basis_fast`]: each entry to a few rounding units per order), about a
        // tenth of the cost of one `sin_cos` per order.
        let mut phi = vec![0.0; self.len];
        let hi = series_maximum(&dte_grid, 1.0, &mut |centre| {
            self.dte_extreme(dte, 1.0, centre, h, &mut phi)
        });
        let lo = -series_maximum(&dte_grid, -1.0, &mut |centre| {
            self.dte_extreme(dte, -1.0, centre, h, &mut phi)
        });
        let law_at = |theta: f64, phi: &mut [f64]| {
            self.basis_fast(theta, phi);
            self.law_at(n, theta, f, phi, s)
        };
        let peak = series_maximum(&force_grid, 1.0, &mut |centre| {
            let force = |t: f64| self.total_force(n, &law_at(t, &mut phi)).abs();
            brent_maximum(force, centre - h, centre + h, REFINE_TOL).1
        });
        let separation = self.separation(s, n, f, &lost_grid, &mut phi);
        let nm = self.meshes.len();
        let force = |i: usize| e.sample_force[i * nm + n];
        // Each mesh's own weights (the torus quadrature integrates each mesh on its own grid).
        let w: Vec<f64> = (e.sample_w.iter().skip(n).step_by(nm)).copied().collect();
        let total = w.iter().fold(0.0, |a, b| a + b);
        let mean = (0..w.len()).fold(0.0, |a, i| a + w[i] * force(i)) / total;
        let var = (0..w.len()).fold(0.0, |a, i| a + w[i] * (force(i) - mean).powi(2)) / total;
        // On the torus the samples weigh the torus, not the orbit's line through it: the lost
        // stretches along the line (a kinked indicator, whose torus and line averages differ
        // by ~1e-2 of the fraction at 64 lines) from the scan grid instead.
        let lost = if self.torus.is_some() {
            self.lost_fraction(s, n, f, &lost_grid, &mut phi)
        } else {
            (0..w.len())
                .filter(|&i| e.sample_lost[i * nm + n])
                .fold(0.0, |a, i| a + w[i])
                / total
        };
        MeshResponse {
            prefix: mesh.prefix.clone(),
            mesh_frequency: mesh.cycles * f,
            dte_mean: dte[0],
            dte_rms: (dte[1..].iter().map(|c| c * c).sum::<f64>() / 2.0).sqrt(),
            dte_peak_to_peak: hi - lo,
            harmonics: [harmonic(1), harmonic(2), harmonic(3)],
            contact_loss_fraction: lost,
            pair_contact_loss_fractions: Vec::new(),
            separation_phase: separation,
            peak_force: peak,
            force_rms: var.sqrt(),
            dynamic_factor: peak / mesh.static_force,
            poincare: Vec::new(),
        }
    }

    /// Coordinate `c`'s series and its θ-derivative on the scan grid `θ_i = i/points`.
    fn grid_series(&self, s: &DVector<f64>, c: usize) -> (Vec<f64>, Vec<f64>) {
        let coefficients = &s.as_slice()[c * self.len..(c + 1) * self.len];
        (
            self.scan.series(&self.orders, coefficients, false),
            self.scan.series(&self.orders, coefficients, true),
        )
    }

    /// `sign` times the DTE series `dte` (about its mean) and its first two θ-derivatives at
    /// `θ`, from the basis row (computed into `phi`).
    fn dte_derivatives(&self, dte: &[f64], sign: f64, theta: f64, phi: &mut [f64]) -> [f64; 3] {
        self.basis_fast(theta, phi);
        let (mut d, mut d1, mut d2) = (0.0, 0.0, 0.0);
        let pairs = dte[1..].chunks_exact(2).zip(phi[1..].chunks_exact(2));
        for (&j, (ab, row)) in self.orders[1..].iter().zip(pairs) {
            let (a, b) = (sign * ab[0], sign * ab[1]);
            let (c, sn) = (row[0], row[1]);
            let w = TAU * j as f64;
            let value = a * c + b * sn;
            d += value;
            d1 += w * (b * c - a * sn);
            d2 -= w * w * value;
        }
        [d, d1, d2]
    }

    /// The largest value of `sign` times the DTE series about its mean within `h` of the grid
    /// maximum at `centre`: Newton on its derivative from the grid point (quadratic from a
    /// grid point of [`super::scan::SCAN_PER_ORDER`] per period of the highest order), or Brent's search
    /// where Newton leaves the bracket or meets no maximum.
    fn dte_extreme(&self, dte: &[f64], sign: f64, centre: f64, h: f64, phi: &mut [f64]) -> f64 {
        let mut theta = centre;
        for _ in 0..NEWTON_STEPS {
            let [_, d1, d2] = self.dte_derivatives(dte, sign, theta, phi);
            if !(d2 < 0.0) {
                break;
            }
            let step = -d1 / d2;
            let next = theta + step;
            if !((next - centre).abs() <= h) {
                break;
            }
            theta = next;
            if step.abs() <= NEWTON_LAST_STEP {
                return self.dte_derivatives(dte, sign, theta, phi)[0];
            }
        }
        let value = |t: f64| self.dte_derivatives(dte, sign, t, phi)[0];
        brent_maximum(value, centre - h, centre + h, REFINE_TOL).1
    }

    /// Mesh `n`'s phase (cycles) at the first instant of the HB period at which it loses
    /// contact on every tooth pair (found on the grid `lost_grid` of `θ_i = i/points`, then
    /// located by [`Problem::loss_switch`]); NaN without loss.
    fn separation(
        &self,
        s: &DVector<f64>,
        n: usize,
        f: f64,
        lost_grid: &[bool],
        phi: &mut [f64],
    ) -> f64 {
        let points = lost_grid.len();
        let h = 1.0 / points as f64;
        // A stretch lost from θ = 0 on separated before the period's start: its separation is
        // the last loss onset of the period (the orbit is periodic).
        let onset = (1..=points)
            .find(|&i| lost_grid[i % points] && !lost_grid[i - 1])
            .map(|i| self.loss_switch(s, n, f, ((i - 1) as f64 * h, i as f64 * h), true, phi));
        onset.map_or(f64::NAN, |theta| {
            self.model.mesh_phase(n, theta / f).rem_euclid(1.0)
        })
    }

    /// The fraction of the period in which mesh `n` has lost contact on every tooth pair,
    /// along the orbit: the stretches lost on the grid `lost_grid` of `θ_i = i/points`, their
    /// ends refined by [`Problem::loss_switch`].
    fn lost_fraction(
        &self,
        s: &DVector<f64>,
        n: usize,
        f: f64,
        lost_grid: &[bool],
        phi: &mut [f64],
    ) -> f64 {
        let points = lost_grid.len();
        let h = 1.0 / points as f64;
        // Σ (end − onset) over the stretches; one lost at θ = 0 wraps around the period.
        let mut lost = if lost_grid[0] { 1.0 } else { 0.0 };
        for i in 0..points {
            let (before, after) = (lost_grid[i], lost_grid[(i + 1) % points]);
            if before != after {
                let bracket = (i as f64 * h, (i + 1) as f64 * h);
                let theta = self.loss_switch(s, n, f, bracket, after, phi);
                lost += if after { -theta } else { theta };
            }
        }
        lost
    }

    /// The instant in `(a, b)` at which mesh `n` loses its last contact (`begins`: in contact
    /// at `a`, lost at `b`) or regains one (the converse): the root of the one contact gap that changes sign between them
    /// ([`Problem::root`]), checked by the contact law [`REFINE_TOL`] either side of it; else
    /// (several gaps change, the engaged pairs change, or the check fails) bisection on the
    /// contact law to [`REFINE_TOL`].
    fn loss_switch(
        &self,
        s: &DVector<f64>,
        n: usize,
        f: f64,
        (a, b): (f64, f64),
        begins: bool,
        phi: &mut [f64],
    ) -> f64 {
        let lost = |theta: f64, phi: &mut [f64]| {
            self.basis_fast(theta, phi);
            self.law_at(n, theta, f, phi, s).in_contact == 0
        };
        let mut buf = Vec::new();
        let gaps = |theta: f64, phi: &mut [f64], buf: &mut Vec<(f64, f64)>| {
            self.basis_fast(theta, phi);
            self.gaps_at(n, theta, f, phi, s, buf);
            buf.iter().map(|g| g.0 > 0.0).collect::<Vec<bool>>()
        };
        let (at_a, at_b) = (gaps(a, phi, &mut buf), gaps(b, phi, &mut buf));
        // `Problem::root` follows the gap at the problem's frequency (the orbit's, as the
        // results are made right after its evaluation).
        if at_a.len() == at_b.len() && self.f == f {
            let mut changed = (0..at_a.len()).filter(|&q| at_a[q] != at_b[q]);
            if let (Some(q), None) = (changed.next(), changed.next()) {
                let root = self.root(s, (n, q), (a, b), phi, &mut buf);
                let (before, after) = ((root - REFINE_TOL).max(a), (root + REFINE_TOL).min(b));
                if lost(before, phi) != begins && lost(after, phi) == begins {
                    return root;
                }
            }
        }
        let (mut a, mut b) = (a, b);
        while b - a > REFINE_TOL {
            let m = 0.5 * (a + b);
            if lost(m, phi) == begins {
                b = m;
            } else {
                a = m;
            }
        }
        b
    }
}

/// The largest value of `sign` times a periodic series `g(θ)`, `θ ∈ [0, 1)`, from its values
/// `grid` at `θ_i = i/grid.len()`: every local maximum of `sign` times the grid within
/// [`SCAN_MARGIN`] of its spread below the best, refined by `refine` from its abscissa (the
/// maximum of `sign·g` near it; two peaks of nearly one height are both refined, whichever the
/// grid happens to rank first).
fn series_maximum(grid: &[f64], sign: f64, refine: &mut dyn FnMut(f64) -> f64) -> f64 {
    let points = grid.len();
    let h = 1.0 / points as f64;
    let value = |i: usize| sign * grid[i];
    let best = (0..points).map(value).fold(f64::NEG_INFINITY, f64::max);
    let worst = (0..points).map(value).fold(best, f64::min);
    let margin = SCAN_MARGIN * (best - worst);
    let beside = |at: usize, k: usize| value((at + points + k - 1) % points);
    let mut result = best;
    for at in 0..points {
        let v = value(at);
        if v < best - margin || v < beside(at, 0) || v < beside(at, 2) {
            continue;
        }
        result = result.max(refine(at as f64 * h));
    }
    result
}

/// A grid point `h = 1/(8 j_max)` from a maximum of a tone of order `≤ j_max` lies below it
/// by at most `½ (2π j_max)² (h/2)² ≈ 0.077` of the tone's amplitude: grid maxima this
/// fraction of the spread below the best may still be the highest.
const SCAN_MARGIN: f64 = 0.1;
