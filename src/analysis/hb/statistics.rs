//! Each mesh's response on a converged harmonic-balance orbit ([`MeshResponse`]), from the
//! harmonic series itself rather than from samples (issue 31): the DTE's mean, RMS (Parseval)
//! and harmonics from its coefficients; its extremes and the peak mesh force from the series
//! evaluated on a fine grid and refined to the maximum ([`brent_maximum`]); the separation
//! phase from the contact law along the series, refined by bisection; the force RMS and the
//! contact-loss fraction by the Galerkin quadrature, whose cells are split at the switching
//! instants (so both are exact for the series up to the rule's accuracy on smooth pieces).

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
        let mut phi = vec![0.0; self.len];
        let mut dte_at = |theta: f64| {
            self.basis(theta, &mut phi);
            dte.iter().zip(phi.iter()).map(|(c, p)| c * p).sum::<f64>()
        };
        let max_order = *self.orders.last().expect("order 0 at least");
        let points = (SCAN_PER_ORDER * max_order.max(1)).max(64);
        let hi = series_maximum(&mut dte_at, points, 1.0);
        let lo = -series_maximum(&mut |t| -dte_at(t), points, 1.0);
        let mut phi = vec![0.0; self.len];
        let mut law = |theta: f64| {
            self.basis(theta, &mut phi);
            let (x, dx) = self.deflection(s, n, &phi);
            self.model.mesh_law(n, theta / f, x, f * dx)
        };
        let peak = series_maximum(&mut |t| law(t).force[0].abs(), points, 1.0);
        let separation = self.separation(&mut |t| law(t).in_contact == 0, points, n, f);
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
    /// true (scanned on `points` cells, then bisected to [`REFINE_TOL`]); NaN without loss.
    fn separation(
        &self,
        lost: &mut dyn FnMut(f64) -> bool,
        points: usize,
        n: usize,
        f: f64,
    ) -> f64 {
        let h = 1.0 / points as f64;
        let mut before = lost(0.0);
        // A stretch lost from θ = 0 on separated before the period's start: its separation is
        // the last loss onset of the period (the orbit is periodic).
        let mut onset = None;
        for i in 1..=points {
            let now = lost(i as f64 * h);
            if now && !before {
                let (mut a, mut b) = ((i - 1) as f64 * h, i as f64 * h);
                while b - a > REFINE_TOL {
                    let m = 0.5 * (a + b);
                    if lost(m) {
                        b = m;
                    } else {
                        a = m;
                    }
                }
                onset = Some(b);
                break;
            }
            before = now;
        }
        onset.map_or(f64::NAN, |theta| {
            self.model.mesh_phase(n, theta / f).rem_euclid(1.0)
        })
    }
}

/// The largest value of a periodic series `g(θ)`, `θ ∈ [0, period)`: scanned at `points`
/// points, the best refined between its neighbours.
fn series_maximum(g: &mut dyn FnMut(f64) -> f64, points: usize, period: f64) -> f64 {
    let h = period / points as f64;
    let (mut best, mut at) = (f64::NEG_INFINITY, 0);
    for i in 0..points {
        let v = g(i as f64 * h);
        if v > best {
            best = v;
            at = i;
        }
    }
    let centre = at as f64 * h;
    let (_, v) = brent_maximum(g, centre - h, centre + h, REFINE_TOL * period);
    v.max(best)
}
