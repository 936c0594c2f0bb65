//! The drivetrain as a hybrid system for the RK integrator ([`HybridSystem`]): the right-hand
//! side, the contact guards as state events and the knots as stops, the event maps.

use super::*;

/// The sign of a guard relative to the slot deflection.
pub(super) fn surface_sign(surface: Surface) -> f64 {
    match surface {
        Surface::Drive | Surface::SepBack => 1.0,
        Surface::SepDrive | Surface::Back => -1.0,
    }
}

impl HybridSystem for GearTrain {
    fn dim(&self) -> usize {
        2 * self.m + self.rotation.as_ref().map_or(0, |r| r.extra_dim())
    }

    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) {
        // With elements the train's torques are those of their shafts, from the state.
        // With elements or speed ports the train's torques are those of their shafts and
        // couplings, from the state.
        let given = self.torques_at(t);
        let torques = (self.rotation.as_ref()).and_then(|rot| rot.train_torques(t, y, given));
        if let Some(rot) = &self.rotation {
            rot.rigid_rhs(self, t, y, dy, torques.unwrap_or(given));
        }
        let m = self.m;
        let mut acc = self.scratch.borrow_mut();
        for i in 0..m {
            dy[i] = y[m + i];
            let mut f = match torques {
                Some((t_in, t_load)) => self.external_force(i, t_in, t_load),
                None => self.f_ext[i],
            };
            for k in 0..m {
                f -= self.k_b[i * m + k] * y[k] + self.c[i * m + k] * y[m + k];
            }
            acc[i] = f;
        }
        // The torques from the state already hold the ramps of `torques_at`.
        if self.force_ramp && torques.is_none() {
            for (a, r) in acc.iter_mut().zip(&self.f_rate) {
                *a += r * (t - self.f_anchor);
            }
            if self.cubic_torques() {
                // Separate from the ramp, so a ramp alone keeps its bits.
                let dt = t - self.f_anchor;
                let (q2, q3) = (dt * dt / 2.0, dt * dt * dt / 6.0);
                for ((a, r2), r3) in acc.iter_mut().zip(&self.f_higher[0]).zip(&self.f_higher[1]) {
                    *a += r2 * q2 + r3 * q3;
                }
            }
        }
        for n in 0..self.meshes.len() {
            if self.meshes[n].friction.is_some() {
                self.add_friction_mesh_force(n, t, y, &mut acc);
                continue;
            }
            let mesh = &self.meshes[n];
            let (force, force_back) =
                self.mesh_force_split_at(n, self.phase_and_rate(n, t, y), y, None);
            for i in 0..m {
                acc[i] -= mesh.a[i] * force;
            }
            if let Some(a_back) = &mesh.a_back {
                for i in 0..m {
                    acc[i] -= a_back[i] * force_back;
                }
            }
        }
        if m == 1 {
            dy[1] = acc[0] / self.m_hat[0];
        } else {
            for i in 0..m {
                dy[m + i] = (0..m).map(|k| self.minv[i * m + k] * acc[k]).sum();
            }
        }
    }

    fn guard_count(&self) -> usize {
        self.guards.len() + self.rotation.as_ref().map_or(0, |r| r.knot_count())
    }

    /// `∂f/∂y` of the frozen mode, `[[0, I], [−M̂⁻¹(K̂_b + Σ k_n a_n a_nᵀ), −M̂⁻¹(Ĉ + Σ c_n a_n
    /// a_nᵀ)]]` with `k_n` the stiffness of mesh n's slots in contact and `c_n` its damping
    /// while any is (the STE and gaps are functions of time only). Tooth friction is not
    /// covered (its arms move with the phase).
    fn jacobian(&self, t: f64, _y: &[f64], jac: &mut [f64]) -> bool {
        if self.rotation.is_some() || self.meshes.iter().any(|mesh| mesh.friction.is_some()) {
            return false;
        }
        // Gains of every drive row, then of the back rows (`JacobianParts::new`'s order).
        let gains = |back: bool| {
            self.meshes
                .iter()
                .filter(move |mesh| !back || mesh.a_back.is_some())
                .map(move |mesh| {
                    let p = mesh.clock.phase_at(t);
                    let (mut kn, mut damped) = (0.0, false);
                    for (j, flag) in mesh.flags.iter().enumerate() {
                        for (on_back, _) in mesh.pressed_flanks(*flag) {
                            if on_back == back {
                                damped = true;
                                let law = mesh.law(j).expect("a slot in contact is engaged");
                                kn += mesh.k(j, p, &law);
                            }
                        }
                    }
                    (kn, if damped { mesh.damping } else { 0.0 })
                })
        };
        self.jacobian_parts
            .fill(gains(false).chain(gains(true)), jac);
        true
    }

    fn guards(&self, t: f64, y: &[f64], g: &mut [f64]) {
        for (slot, &(n, j, surface)) in g.iter_mut().zip(&self.guards) {
            let delta = self
                .slot_gap_on(n, j, surface.back_flank(), t, y)
                .map_or(0.0, |v| v.0);
            let mesh = &self.meshes[n];
            let clearance = match mesh.eccentric {
                None => mesh.clearance(),
                Some(_) => mesh.clearance_at(self.phase_of(n, t, y)).0,
            };
            let back = delta + clearance;
            *slot = match surface {
                Surface::Drive => delta,
                Surface::SepDrive => -delta,
                Surface::SepBack => back,
                Surface::Back => -back,
            };
        }
        if let Some(rot) = &self.rotation {
            rot.knot_guards(self, t, y, &mut g[self.guards.len()..]);
        }
    }

    /// Slot gaps `±(a·ξ − e(p) − g_j(r)) (+ clearance)`: gradient `±a` over the positions,
    /// explicit time derivative `∓(ė + g1 f)`.
    fn guard_gradient(&self, t: f64, _y: &[f64], index: usize, grad: &mut [f64]) -> Option<f64> {
        if self.rotation.is_some() {
            // The gaps depend on the carried angle through the phase: not affine.
            return None;
        }
        let (n, j, surface) = self.guards[index];
        let sign = surface_sign(surface);
        let mesh = &self.meshes[n];
        grad.fill(0.0);
        // A slot without a law has the constant guard 0 (see `guards`).
        let Some(law) = mesh.law(j) else {
            return Some(0.0);
        };
        for (g, a) in grad.iter_mut().zip(mesh.flank(surface.back_flank())) {
            *g = sign * a;
        }
        let (p, f) = mesh.clock.phase_and_frequency(t);
        let slope = mesh.ste_at(p).1;
        if mesh.eccentric.is_some() {
            // The gaps are read at the contact phase; the back side moves with the backlash.
            let dq = mesh.contact_phase(p).1;
            let back = matches!(surface, Surface::SepBack | Surface::Back);
            let clearance_rate = if back {
                mesh.clearance_at(p).1 * f
            } else {
                0.0
            };
            return Some(sign * (clearance_rate - (slope + law.g1 * dq) * f));
        }
        Some(-sign * (slope * f + law.g1 * f))
    }

    /// Slot gaps are affine in the state; the time part `e(p) + g0 + g1 r` has the STE's
    /// curvature only (`r` runs linearly between stops): `|ë| ≤ (2π f)² Σ_h h² |(a_h, b_h)|`.
    /// On a speed ramp (`docs/runup.md`) `f` is the larger of its values at the ends, and the
    /// ramp adds `|ḟ| Σ_h 2πh |(a_h, b_h)| + |g1 ḟ|` (`ë = e'' f² + e' ḟ`, `r̈ = ḟ`).
    fn affine_guard(&self, index: usize, t0: f64, t1: f64, w: &mut [f64]) -> Option<f64> {
        if self.rotation.is_some() {
            return None;
        }
        let (n, j, _) = self.guards[index];
        self.guard_gradient(t0, &[], index, w)?;
        let mesh = &self.meshes[n];
        let f = mesh.clock.frequency_at(t0).max(mesh.clock.frequency_at(t1));
        let omega = TAU * f;
        let curvature: f64 = (mesh.ste.coefficients().iter().enumerate())
            .map(|(i, &(a, b))| ((i + 1) as f64 * omega).powi(2) * a.hypot(b))
            .sum::<f64>()
            + mesh.errors.curvature_bound() * f.powi(2);
        let curvature = curvature
            + mesh.eccentric.as_ref().map_or(0.0, |ec| {
                // e(q(p)) and g(r(q)) on a moving contact phase, the moving backlash:
                // |d²/dp²| ≤ |e''|((1 + |δq'|)² − 1) + |e'||δq''| + |g1||δq''| + |Δj''|.
                let (dq2, _, dj2) = ec.geometry.curvature_bounds();
                let dq1 = ec.geometry.phase_slope_bound();
                let g1 = mesh.law(j).map_or(0.0, |l| l.g1.abs());
                let slope: f64 = (mesh.ste.coefficients().iter().enumerate())
                    .map(|(i, &(a, b))| TAU * (i + 1) as f64 * a.hypot(b))
                    .sum();
                curvature * ((1.0 + dq1).powi(2) - 1.0) + ((slope + g1) * dq2 + dj2) * f.powi(2)
            });
        let rate = mesh.clock.rate();
        if rate == 0.0 {
            return Some(curvature);
        }
        let g1 = mesh.law(j).map_or(0.0, |l| l.g1);
        let slope: f64 = (mesh.ste.coefficients().iter().enumerate())
            .map(|(i, &(a, b))| TAU * (i + 1) as f64 * a.hypot(b))
            .sum::<f64>()
            + mesh.errors.slope_bound();
        let slope = slope
            + mesh.eccentric.as_ref().map_or(0.0, |ec| {
                let dq1 = ec.geometry.phase_slope_bound();
                (slope + g1.abs()) * dq1 + ec.geometry.backlash_slope_bound()
            });
        Some(curvature + rate.abs() * (slope + g1.abs()))
    }

    fn next_stop(&self) -> f64 {
        if self.rotation.is_some() {
            // Stiffness knots are state events on the pinion angle.
            return f64::INFINITY;
        }
        self.meshes
            .iter()
            .map(MeshRt::next_stop)
            .fold(f64::INFINITY, f64::min)
    }

    /// Switches every mesh whose interval ends at `t`, each past any interval that ends at `t`
    /// too: an interval narrower than the time resolution (trapezoidal ramps that touch) lasts
    /// no time. At most one cycle of intervals per mesh, as for the single pair.
    fn on_stop(&mut self, t: f64, y: &mut [f64]) {
        self.stop_meshes(t, Some(y));
    }

    fn on_event(&mut self, t: f64, y: &mut [f64], index: usize) {
        if index >= self.guards.len() {
            self.knot_event(t, y, index - self.guards.len());
            return;
        }
        self.switch_slot(t, None, y, index);
    }
}
