//! The carried rotation as a piecewise-LTI system (`docs/ports.md`, "What stays
//! piecewise-LTI"; issue 18 point 1).
//!
//! Between two events the stiffness piece and the contact state of every mesh are frozen.
//! With constant port torques (or torques that ramp linearly over an FMU step), linear
//! element shafts, inertias and loads, and no STE harmonics, every term of the right-hand side
//! is then affine in `[y, t]`: the body angles are `θ_b = w_b Ω_ref t + (Q ξ + R η)_b/ρ_b`,
//! and in a shaft between two bodies of equal nominal ratio the `w Ω_ref t` parts cancel. The
//! only place the angle itself enters is the mesh phase `p_n = p_n0 + z_n θ_b/2π`: its local
//! ramp `r_n = s_n − interval start` (the nominal form's affine-gap ramp) is lifted as a
//! state of its own with rate `z_n θ'_b/2π`, linear in the speeds. It carries the affine gaps
//! `g0 + g1 r_n`, and the stiffness knots become the guards `r_n ≥ 0` (crossed backwards by a
//! reversing shaft) and `(end − start) − r_n ≥ 0`: constant rows per mode, certified by the
//! same crossing search as the contact guards. An STE `e(p)` would need `cos 2πh p_n`, which
//! is not linear in the state: such a scene is refused.

use std::f64::consts::TAU;

use nalgebra::DMatrix;

use super::super::{GearTrain, MeshRt};
use super::Carried;

impl Carried {
    /// Why the carried system is not piecewise-LTI apart from its meshes (the elements), or
    /// `None`.
    pub(crate) fn not_lti_reason(&self) -> Option<String> {
        // The coupling torque k(φ − θ_g) + c(ω − ω_g) is affine in the state, but the
        // neighbour's angle integrates its speed ramp (`φ_c + ω_c s + ω' s²/2`), a term in s²
        // the lifted state does not carry; its rows are not built.
        if let Some(p) = self.ports.iter().find(|p| p.coupling.is_some()) {
            return Some(format!(
                "port '{}' has speed causality: its compliant coupling to the neighbour's motion \
                 is not a row of the exact propagator (docs/ports.md, \"What stays \
                 piecewise-LTI\")",
                p.name
            ));
        }
        self.attached.as_ref().and_then(|a| a.not_lti_reason())
    }

    /// The train's input and load torque as rows over the lifted state (`nz` entries, the
    /// constant last, `t − f_anchor` at `ramp_time` on a torque ramp): the shaft torques with
    /// elements, else the port torques and their rates.
    pub(crate) fn torque_rows(
        &self,
        train: &GearTrain,
        nz: usize,
        ramp_time: Option<usize>,
    ) -> [Vec<f64>; 2] {
        if let Some(a) = &self.attached {
            return a.train_torque_rows(self, nz);
        }
        let held = train.inputs;
        let mut rows = [vec![0.0; nz], vec![0.0; nz]];
        rows[0][nz - 1] = held.input_torque;
        rows[1][nz - 1] = held.load_torque;
        if let Some(u) = ramp_time {
            // The derivatives of orders 1–3 on the chain `τ, τ²/2, τ³/6` (only as long as
            // the chain is: a ramp has `τ` alone).
            let chain = train.forcing_chain();
            for (row, d) in rows.iter_mut().zip(train.torque_derivatives()) {
                row[u..u + chain].copy_from_slice(&d[..chain]);
            }
        }
        rows
    }

    /// Rows of `a` beyond the elastic ones: `η' = η'`, `η'' = Rᵀ F_T` under the torque rows,
    /// the element states, and the phase ramp of every mesh (`ramps[n]` its lifted entry),
    /// `r_n' = z_n θ'_b / 2π`.
    pub(crate) fn lti_rows(
        &self,
        train: &GearTrain,
        torques: &[Vec<f64>; 2],
        ramps: &[usize],
        a: &mut DMatrix<f64>,
    ) {
        let (m, r) = (self.m, self.r);
        let nz = a.ncols();
        for k in 0..r {
            a[(2 * m + k, 2 * m + r + k)] = 1.0;
            for col in 0..nz {
                a[(2 * m + r + k, col)] =
                    train.rigid_in[k] * torques[0][col] + train.rigid_out[k] * torques[1][col];
            }
        }
        for (n, &ramp) in ramps.iter().enumerate() {
            let scale = self.mesh_teeth[n] / TAU;
            let mut row = vec![0.0; nz];
            self.add_body_rows(self.mesh_body[n], 0.0, scale, &mut row);
            if let Some((carrier, zc)) = self.mesh_carrier[n] {
                self.add_body_rows(carrier, 0.0, zc / TAU, &mut row);
            }
            for (col, v) in row.into_iter().enumerate() {
                a[(ramp, col)] = v;
            }
        }
        if let Some(attached) = &self.attached {
            attached.lti_rows(self, a);
        }
    }

    /// Adds `k θ_b + c θ'_b` of body b to `row` without the `w_b Ω_ref t` part of the angle
    /// (it cancels in a shaft, and the phase ramp is lifted from the actual phase): the angle
    /// over ξ and η, the speed over ξ' and η' and its nominal part `w_b Ω_ref` on the constant
    /// (the last entry).
    pub(super) fn add_body_rows(&self, b: usize, k: f64, c: f64, row: &mut [f64]) {
        let (m, r) = (self.m, self.r);
        let body = &self.bodies[b];
        for i in 0..m {
            row[i] += k * body.xi[i];
            row[m + i] += c * body.xi[i];
        }
        for q in 0..r {
            row[2 * m + q] += k * body.eta[q];
            row[2 * m + r + q] += c * body.eta[q];
        }
        let last = row.len() - 1;
        row[last] += c * body.ratio * self.omega;
    }

    /// The mesh of knot guard `k` (two per mesh with knots, [`Carried::knot_guards`]).
    pub(crate) fn knot_mesh(&self, k: usize) -> usize {
        self.knot_meshes[k / 2]
    }

    /// Knot guard `k` over the lifted state: `(end − start) − r_n` (even `k`, the end of the
    /// current interval ahead) or `r_n` (its start behind), `ramp` the entry of `r_n`. The
    /// same guards as [`Carried::knot_guards`] with `r_n = p_n + offset − cycle − start`.
    pub(in crate::model::train::system) fn knot_guard_row(
        &self,
        mesh: &MeshRt,
        k: usize,
        ramp: usize,
        w: &mut [f64],
    ) {
        let (start, end) = mesh.current().map_or((0.0, 1.0), |iv| (iv.start, iv.end));
        let last = w.len() - 1;
        if k.is_multiple_of(2) {
            w[ramp] = -1.0;
            w[last] = end - start;
        } else {
            w[ramp] = 1.0;
        }
    }

    /// A bound of the angular frequency the element shafts add (rad/s): Gershgorin on their
    /// stiffness over the inertias of the bodies they join, `max_b 2 Σ k_s / J_b`.
    pub(crate) fn shaft_frequency_bound(&self, train: &GearTrain) -> f64 {
        self.attached.as_ref().map_or(0.0, |a| {
            a.shaft_frequency_bound(&|b| body_inertia(train, b))
        })
    }

    /// Bounds of the angular frequency and decay rate the speed ports' couplings add (rad/s):
    /// a coupling `k, c` to a neighbour of given motion adds `k/J_b` and `c/J_b` to the row of
    /// its body `b` (Gershgorin, as [`Carried::shaft_frequency_bound`]).
    pub(crate) fn port_coupling_bounds(&self, train: &GearTrain) -> (f64, f64) {
        self.ports
            .iter()
            .filter_map(|p| {
                p.coupling
                    .as_ref()
                    .map(|c| (body_inertia(train, p.body), c))
            })
            .fold((0.0, 0.0), |(w, d), (j, c)| {
                (w.max((c.stiffness / j).sqrt()), d.max(c.damping / j))
            })
    }

    /// A bound of the decay rate the element shafts' dampers add (rad/s),
    /// `max_b 2 Σ c_s / J_b`.
    pub(crate) fn shaft_damping_bound(&self, train: &GearTrain) -> f64 {
        self.attached
            .as_ref()
            .map_or(0.0, |a| a.shaft_damping_bound(&|b| body_inertia(train, b)))
    }
}

/// The inertia of carried body `b`: its rotation DOF is `u_b = ρ_b θ_b`, so its mass entry is
/// `J_b / ρ_b²`.
fn body_inertia(train: &GearTrain, b: usize) -> f64 {
    let asm = &train.asm;
    asm.mass[(asm.body_dof[b], asm.body_dof[b])] * asm.body_radius[b].powi(2)
}
