//! Harmonic balance of any drivetrain ([`crate::model::Drivetrain`]): Galerkin projection with alternating
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
//! orders `J` are the combination tones `|Σ_n a_n Q_n|` of the mesh frequencies (and of the
//! revolution frequencies of gears with errors) divided by `K` (`Q_n` cycles per response
//! period) of total order `Σ_n |a_n| ≤ H` ([`Basis::TotalOrder`]; Krack & Gross §2.5): for one
//! mesh frequency (the single pair, the idler train) the harmonics `1…H` of `f_m/K`; for the
//! countershaft (`f_2/f_1 = 19/72`, `Q = (72, 19)`) the tones `a f_1 + b f_2` with
//! `|a| + |b| ≤ H` — at `H = 20` 421 orders instead of the 1441 multiples of `1/T` up to
//! `20 f_1` ([`Basis::Full`], kept as the reference the truncation is measured against:
//! docs/harmonic-balance.md). Large systems (more than 512 unknowns) are solved by
//! Newton–Krylov with matrix-free products on the torus quadrature of a two-frequency train
//! (krylov.rs), elsewhere by the chord method with a Jacobian kept from earlier points
//! (continuation.rs).
//!
//! **Condensation.** The mesh forces depend on the state only through the mesh deflections
//! `S_n = a_n·ξ` ([`crate::model::Drivetrain::mesh_law`]); the linear part, with each mesh's mean stiffness
//! and damping moved into it, is diagonal in the harmonics. Per order `j` the coordinates are
//! therefore `X_j = Z_j⁻¹ (F̂_j − Σ v_{n,k} G_{n,k,j})` with the dynamic stiffness
//! `Z_j = K̄ − (2πjf)² M + i 2πjf C̄` (`f = 1/T`), and the harmonic-balance equations reduce
//! exactly (no approximation) to the Fourier coefficients `s` of the mesh deflections:
//! `r(s) = s − Aᵀ Z⁻¹ F̂ + Aᵀ Z⁻¹ V g(s) = 0` (condensation onto the nonlinear coordinates with
//! the receptances `Aᵀ Z_j⁻¹ V`, exact in harmonic balance because the linear part couples no
//! two harmonics). The Newton system is `n_mesh (2|J| − 1)` square instead of
//! `m (2|J| − 1)`: 16× smaller for the 8-DOF idler, whose two meshes carry all nonlinearity.
//! The coefficients of every coordinate are recovered from the converged `s`. A mesh whose
//! back flanks act along their own line of action (`docs/train.md`, "Back flanks") adds its
//! back deflection `S̃_n = ã_n·ξ` as a further condensed coordinate and its back force along
//! `ã_n` as a further output ([`crate::model::Drivetrain::mesh_back_row`]): the same
//! equations with one more block each.
//!
//! **Galerkin projection.** `g = P[F(θ, S, Ṡ)] − k̄ s − c̄ Ṡ` is integrated by composite
//! 3-point Gauss rules on cells split at every stiffness/gap breakpoint of every mesh
//! ([`crate::model::Drivetrain::mesh_breakpoints`]), so the jumps of a rectangular stiffness fall between
//! nodes; plain AFT (uniform samples, FFT) would alias them with an O(1/N) error no number of
//! harmonics removes. The contact law is evaluated exactly at the nodes (no tanh smoothing);
//! a cell in which a tooth pair's contact changes is split at the switching instants (roots of
//! [`crate::model::Drivetrain::contact_gaps`] on the trigonometric polynomial) and each part integrated by
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
//! shooting monodromy (with saltation at contact changes,
//! [`crate::analysis::shooting::PeriodMap`]) started from the HB state at `t = 0` (not Hill's
//! method: no truncated Hill matrix, no sorting of its eigenvalues; its least cost per point
//! is measured against this in docs/harmonic-balance.md, "Stability: the monodromy from the HB
//! state, not Hill's method", `benches/hb_stability.rs`). Their error is that of the
//! trajectory from the HB state, which lies off the periodic orbit by the truncation error;
//! where a contact switch is sensitive to that offset it reaches a few times the offset, so a
//! radius within [`SHOOTING_CHECK_MARGIN`] of 1 is checked by Newton shooting from the HB state
//! ([`ShootingCheck`]). The period maps of a branch are independent and run on all cores.

mod blocked_lu;
mod continuation;
mod evaluate;
mod gmres;
mod krylov;
mod problem;
mod scan;
mod statistics;

pub use continuation::{
    continuation, continuation_reporting, BranchPoint, ContinuationOptions, ShootingCheck,
    ORBIT_ERROR_WARNING, PERIODICITY_DEFECT_LIMIT, RADIUS_SENSITIVITY, SHOOTING_CHECK_DISTANCE,
    SHOOTING_CHECK_MARGIN,
};

use std::f64::consts::TAU;

use crate::analysis::mesh_response::MeshResponse;
use crate::model::SceneSource;
use crate::with_drivetrain;
use problem::Problem;

/// Settings of the harmonic balance.
#[derive(Debug, Clone)]
pub struct HbOptions {
    /// H: the total order of the retained combination tones of the mesh frequencies (divided
    /// by the subharmonic order), [`Basis`]; for one mesh frequency the harmonics `1…H` of
    /// `f_m/K`.
    pub harmonics: usize,
    /// Subharmonic order K: the HB period in response periods.
    pub subharmonic: u32,
    /// Quadrature nodes per HB period (about); default `max(16·(2j_max + 1), 256)`, `j_max`
    /// the highest retained order.
    pub samples: Option<usize>,
    /// Newton stops when the update is below `tolerance` × the displacement scale.
    pub tolerance: f64,
    pub max_iterations: usize,
    /// Which orders are retained (default [`Basis::TotalOrder`]).
    pub basis: Basis,
}

/// The retained orders of the harmonic balance for the base orders (the mesh frequencies, and
/// the revolution frequencies where gear errors act, in multiples of the HB frequency `1/T`).
/// With one base (a single pair, the idler train) both are the harmonics `1…H` of it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Basis {
    /// The combination tones `Σ a_n b_n` of total order `Σ |a_n| ≤ H`
    /// (docs/harmonic-balance.md "Retained orders").
    #[default]
    TotalOrder,
    /// Every multiple of `1/T` up to `H` times the highest base: the reference the total-order
    /// truncation is measured against (it grows like the response period: 1441 orders on the
    /// countershaft at H = 20).
    Full,
}

impl HbOptions {
    pub fn new(harmonics: usize) -> Self {
        HbOptions {
            harmonics,
            subharmonic: 1,
            samples: None,
            tolerance: 1e-12,
            max_iterations: 50,
            basis: Basis::TotalOrder,
        }
    }

    fn validate(&self) -> Result<(), String> {
        if self.harmonics == 0 {
            return Err("harmonics = 0: at least one harmonic is needed".into());
        }
        if self.subharmonic == 0 {
            return Err("subharmonic = 0: the response period is at least one mesh period".into());
        }
        // Before the orders are enumerated (issue 34: 1e12 harmonics ran without end): H
        // harmonics of the fastest mesh alone are 2H + 1 unknowns.
        if self.harmonics > problem::MAX_UNKNOWNS / 2 {
            return Err(format!(
                "harmonics = {}: at least {} unknowns, more than the {} a dense Newton system \
                 takes (lower harmonics)",
                self.harmonics,
                self.harmonics as u128 * 2 + 1,
                problem::MAX_UNKNOWNS
            ));
        }
        if self.subharmonic as u64 > problem::MAX_PERIOD_MESH_CYCLES {
            return Err(format!(
                "subharmonic = {}: more than {} mesh periods per orbit (lower subharmonic)",
                self.subharmonic,
                problem::MAX_PERIOD_MESH_CYCLES
            ));
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
    pub meshes: Vec<MeshResponse>,
    /// DTE row of each mesh over the coordinates ([`crate::model::Drivetrain::mesh_dte_row`]).
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
    let mut scene = scene.to_scene();
    scene.profiles.require_constant("harmonic balance")?;
    scene.set_input_speed(speed);
    let settings = scene.solver.clone();
    with_drivetrain!(scene.simulation()?, sim => {
        let mut problem = Problem::new(sim.model().clone(), settings, options)?;
        let f = problem.f;
        let s = match guess {
            Some(g) => problem.condense(g)?,
            None => problem.seed(sim)?,
        };
        let (_, e, iterations) = problem.newton(s, f, options)?;
        Ok(problem.solution(f, &e, iterations))
    })
}

#[cfg(test)]
mod tests {
    use super::problem::{combination_orders, factor, retained_orders};
    use super::*;
    use crate::scene::PairScene;

    #[test]
    fn projection_inverts_sampling_of_band_limited_signals() {
        let scene = PairScene::example("spur_pair").unwrap();
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
        // 72a + 19b with |a| + |b| ≤ 2.
        assert_eq!(
            combination_orders(&[72, 19], 2),
            vec![0, 19, 38, 53, 72, 91, 144]
        );
        // h² + h + 1 orders for two incommensurate bases.
        assert_eq!(combination_orders(&[72, 19], 20).len(), 421);
        assert_eq!(retained_orders(Basis::Full, &[72, 19], 2).len(), 145);
    }
}
