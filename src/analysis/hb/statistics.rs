//! Each mesh's response on a converged harmonic-balance orbit ([`MeshResponse`]), from the
//! harmonic series itself rather than from samples (issue 31): the DTE's mean, RMS (Parseval)
//! and harmonics from its coefficients; its extremes and the peak mesh force from the series
//! evaluated on a fine grid and refined to the maximum ([`brent_maximum`] around every grid
//! maximum that may be the highest); the separation phase from the contact law along the
//! series, refined by bisection; the force RMS and the
//! contact-loss fraction by the Galerkin quadrature, whose cells are split at the switching
//! instants (so both are exact for the series up to the rule's accuracy on smooth pieces).

use std::f64::consts::TAU;

use nalgebra::DVector;

use super::problem::{Evaluation, Problem};
use crate::analysis::mesh_response::MeshResponse;
use crate::model::Drivetrain;
use crate::solve::roots::brent_maximum;

/// Grid points per period of the highest retained order on which the series are scanned
/// before the best point is refined.
const SCAN_PER_ORDER: usize = 8;

/// Abscissa tolerance of the refinement, in HB periods.
const REFINE_TOL: f64 = 1e-13;

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
        // Every quantity on one grid `θ_i = i/points`, the basis rows from the grid's roots of
        // unity (`cos, sin 2π j i/points` is entry `j i mod points` of one table: no
        // trigonometry per row); then each extreme refined from its best grid point and its
        // neighbours.
        let max_order = *self.orders.last().expect("order 0 at least");
        let points = (SCAN_PER_ORDER * max_order.max(1)).max(64);
        let h = 1.0 / points as f64;
        let roots: Vec<(f64, f64)> = (0..points)
            .map(|r| {
                let (sn, cs) = (TAU * r as f64 * h).sin_cos();
                (cs, sn)
            })
            .collect();
        let mut phi = vec![0.0; self.len];
        let law_at = |theta: f64, phi: &[f64]| {
            let (x, dx) = self.deflection(s, n, phi);
            self.model.mesh_law(n, theta / f, x, f * dx)
        };
        // The DTE's extremes about its mean (`dte[0]`, which cancels in the peak to peak): the
        // refinement then settles to a rounding unit of the oscillation, not of the mean.
        let dot = |phi: &[f64]| {
            (dte.iter().zip(phi).skip(1))
                .map(|(c, p)| c * p)
                .sum::<f64>()
        };
        let (mut dte_grid, mut force_grid, mut lost_grid) = (
            Vec::with_capacity(points),
            Vec::with_capacity(points),
            Vec::with_capacity(points),
        );
        phi[0] = 1.0;
        // Order `j_q`'s entry of row `i`, `j_q i mod points`, stepped by `j_q` per row.
        let mut entry = vec![0; self.orders.len()];
        for i in 0..points {
            for (q, &j) in self.orders.iter().enumerate().skip(1) {
                let (cs, sn) = roots[entry[q]];
                phi[2 * q - 1] = cs;
                phi[2 * q] = sn;
                let next = entry[q] + j;
                entry[q] = if next >= points { next - points } else { next };
            }
            let law = law_at(i as f64 * h, &phi);
            dte_grid.push(dot(&phi));
            force_grid.push(law.force[0].abs());
            lost_grid.push(law.in_contact == 0);
        }
        // The refinements evaluate the series with one `sin_cos` and powers of it
        // ([`Problem::basis_fast`]: each entry to a few rounding units per order), about a
        // tenth of the cost of one `sin_cos` per order.
        let mut dte_at = |theta: f64| {
            self.basis_fast(theta, &mut phi);
            dot(&phi)
        };
        let hi = series_maximum(&mut dte_at, &dte_grid, 1.0);
        let minus: Vec<f64> = dte_grid.iter().map(|d| -d).collect();
        let lo = -series_maximum(&mut |t| -dte_at(t), &minus, 1.0);
        let mut phi = vec![0.0; self.len];
        let mut law = |theta: f64| {
            self.basis_fast(theta, &mut phi);
            law_at(theta, &phi)
        };
        let peak = series_maximum(&mut |t| law(t).force[0].abs(), &force_grid, 1.0);
        let separation = self.separation(&mut |t| law(t).in_contact == 0, &lost_grid, n, f);
        let nm = self.meshes.len();
        let force = |i: usize| e.sample_force[i * nm + n];
        let w = &e.sample_w;
        let total = w.iter().fold(0.0, |a, b| a + b);
        let mean = (0..w.len()).fold(0.0, |a, i| a + w[i] * force(i)) / total;
        let var = (0..w.len()).fold(0.0, |a, i| a + w[i] * (force(i) - mean).powi(2)) / total;
        let lost = (0..w.len())
            .filter(|&i| e.sample_lost[i * nm + n])
            .fold(0.0, |a, i| a + w[i])
            / total;
        MeshResponse {
            prefix: mesh.prefix.clone(),
            mesh_frequency: mesh.cycles * f,
            dte_mean: dte[0],
            dte_rms: (dte[1..].iter().map(|c| c * c).sum::<f64>() / 2.0).sqrt(),
            dte_peak_to_peak: hi - lo,
            harmonics: [harmonic(1), harmonic(2), harmonic(3)],
            contact_loss_fraction: lost,
            separation_phase: separation,
            peak_force: peak,
            force_rms: var.sqrt(),
            dynamic_factor: peak / mesh.static_force,
            poincare: Vec::new(),
        }
    }

    /// Mesh `n`'s phase (cycles) at the first instant of the HB period at which `lost` turns
    /// true (found on the grid `lost_grid` of `θ_i = i/points`, then bisected to
    /// [`REFINE_TOL`]); NaN without loss.
    fn separation(
        &self,
        lost: &mut dyn FnMut(f64) -> bool,
        lost_grid: &[bool],
        n: usize,
        f: f64,
    ) -> f64 {
        let points = lost_grid.len();
        let h = 1.0 / points as f64;
        // A stretch lost from θ = 0 on separated before the period's start: its separation is
        // the last loss onset of the period (the orbit is periodic).
        let onset = (1..=points)
            .find(|&i| lost_grid[i % points] && !lost_grid[i - 1])
            .map(|i| {
                let (mut a, mut b) = ((i - 1) as f64 * h, i as f64 * h);
                while b - a > REFINE_TOL {
                    let m = 0.5 * (a + b);
                    if lost(m) {
                        b = m;
                    } else {
                        a = m;
                    }
                }
                b
            });
        onset.map_or(f64::NAN, |theta| {
            self.model.mesh_phase(n, theta / f).rem_euclid(1.0)
        })
    }
}

/// The largest value of a periodic series `g(θ)`, `θ ∈ [0, period)`, from its values `grid` at
/// `θ_i = i·period/grid.len()`: every local maximum of the grid within [`SCAN_MARGIN`] of the
/// grid's spread below the best, refined from its neighbours (two peaks of nearly one height
/// are both refined, whichever the grid happens to rank first).
fn series_maximum(g: &mut dyn FnMut(f64) -> f64, grid: &[f64], period: f64) -> f64 {
    let points = grid.len();
    let h = period / points as f64;
    let best = grid.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let worst = grid.iter().copied().fold(best, f64::min);
    let margin = SCAN_MARGIN * (best - worst);
    let beside = |at: usize, k: usize| grid[(at + points + k - 1) % points];
    let mut result = best;
    for (at, &value) in grid.iter().enumerate() {
        if value < best - margin || value < beside(at, 0) || value < beside(at, 2) {
            continue;
        }
        // Brent on the grid cells beside it: the law may jump or kink between grid points
        // (a contact or stiffness switch), where a parabola says nothing.
        let centre = at as f64 * h;
        let (_, v) = brent_maximum(&mut *g, centre - h, centre + h, REFINE_TOL * period);
        result = result.max(v);
    }
    result
}

/// A grid point `h = 1/(8 j_max)` from a maximum of a tone of order `≤ j_max` lies below it
/// by at most `½ (2π j_max)² (h/2)² ≈ 0.077` of the tone's amplitude: grid maxima this
/// fraction of the spread below the best may still be the highest.
const SCAN_MARGIN: f64 = 0.1;
