//! The drivetrain as a piecewise-LTI system for the exact propagator ([`PiecewiseLti`]):
//! the lifted state (STE harmonics, phase ramps, a constant), the segment matrices, the guard
//! rows and the mode keys.

use super::*;

impl GearTrain {
    /// The contact switch of guard `index` at an event at `t`: snaps `ξ` onto the crossed
    /// surface and switches the slot. With the lifted event state `z`, a one-DOF train reads
    /// its STE from the propagated harmonic states (as the single pair does).
    pub(super) fn switch_slot(&mut self, t: f64, z: Option<&[f64]>, y: &mut [f64], index: usize) {
        let (n, j, surface) = self.guards[index];
        let clearance = self.meshes[n].clearance();
        let level = if surface.back_flank() {
            -clearance
        } else {
            0.0
        };
        let next = surface.next(self.meshes[n].flags[j]);
        // Snap onto the surface δ = level (numerics-notes §2.1): the smallest mass-weighted
        // change of ξ that puts S_n − e_n − g_j at `level`.
        if let Some((delta, _, _)) = self.slot_gap_on(n, j, surface.back_flank(), t, y) {
            let m = self.m;
            let a = self.meshes[n].flank(surface.back_flank());
            if m == 1 {
                // S = a·ξ must equal e + g + level; formed like the single pair (`x = e + surface`).
                let mesh = &self.meshes[n];
                let p = self.phase_of(n, t, y);
                let g = mesh.law(j).map_or(0.0, |l| l.g(mesh.local(p)));
                let e = match z {
                    Some(z) => mesh.ste.value_from_harmonics(&z[self.forcing_base(n)..]),
                    None => mesh.ste_at(p).0,
                };
                y[0] = (e + g + level) / a[0];
            } else {
                let w: Vec<f64> = (0..m)
                    .map(|i| (0..m).map(|k| self.minv[i * m + k] * a[k]).sum())
                    .collect();
                let aw: f64 = (0..m).map(|i| a[i] * w[i]).sum();
                let step = (level - delta) / aw;
                for i in 0..m {
                    y[i] += w[i] * step;
                }
            }
        }
        self.meshes[n].flags[j] = next;
        self.book_loss(n, t);
        if let Some(log) = &mut self.event_log {
            log.push((t, n, j, next));
        }
        self.refresh_guards();
    }

    /// First lifted entry of every mesh's forcing block (its STE harmonics, then its phase
    /// ramp if it has one), after the state `y`.
    pub(super) fn harmonic_base(&self) -> Vec<usize> {
        let mut base = Vec::with_capacity(self.meshes.len());
        let mut k = self.dim();
        for mesh in &self.meshes {
            base.push(k);
            k += 2 * mesh.ste.harmonics() + usize::from(self.phase_ramp(mesh));
        }
        base
    }

    /// [`GearTrain::harmonic_base`] of mesh n alone (no allocation: called at every event).
    pub(super) fn forcing_base(&self, n: usize) -> usize {
        self.dim()
            + (self.meshes[..n].iter())
                .map(|k| 2 * k.ste.harmonics() + usize::from(self.phase_ramp(k)))
                .sum::<usize>()
    }

    /// Whether mesh's forcing block ends with a phase ramp `r = s − interval start`: for
    /// affine gaps in the nominal form, and always with the carried rotation, where `r` is
    /// affine in the state and carries the knot guards (`rotating::lti`).
    pub(super) fn phase_ramp(&self, mesh: &MeshRt) -> bool {
        mesh.ramp || self.rotation.is_some()
    }

    /// Lifted entry of `τ = t − f_anchor` (the time along a torque ramp of the carried
    /// rotation: the FMU's input derivatives), if the lifted state has it; the rest of the
    /// chain ([`GearTrain::forcing_chain`]) and the constant are after it.
    pub(super) fn ramp_time_index(&self) -> Option<usize> {
        let chain = self.forcing_chain();
        (chain > 0).then(|| self.lti_dim() - 1 - chain)
    }

    /// Length of the nilpotent chain `τ, τ²/2, τ³/6` (`τ' = 1`, `(τ²/2)' = τ`, `(τ³/6)' =
    /// τ²/2`) the lifted state carries for the torque forcing of the carried rotation: 0 for
    /// held torques, 1 for a ramp, 3 for a cubic ([`GearTrain::set_torque_derivatives`]). With
    /// it the cubic forcing is an exact row of the propagator `exp(A h)` (Moler & Van Loan
    /// 2003, §10: a polynomial input as an augmented nilpotent block).
    pub(super) fn forcing_chain(&self) -> usize {
        match (
            self.rotation.is_some() && self.force_ramp,
            self.cubic_torques(),
        ) {
            (false, _) => 0,
            (true, false) => 1,
            (true, true) => 3,
        }
    }

    /// Row of mesh n's force over the augmented state in the current mode (its forcing block
    /// from `base`; `w` is scratch of the same length): the engaged slots' `k₀(δ_j + offset)`
    /// and the damper on `Ṡ − ė`.
    pub(super) fn mesh_force_row(&self, n: usize, base: usize, w: &mut [f64], row: &mut [f64]) {
        match self.meshes[n].a_back {
            None => self.mesh_force_rows(n, base, w, row, None),
            Some(_) => {
                let mut back = vec![0.0; row.len()];
                self.mesh_force_rows(n, base, w, row, Some(&mut back));
                for (r, b) in row.iter_mut().zip(&back) {
                    *r += b;
                }
            }
        }
    }

    /// [`GearTrain::mesh_force_row`] split as [`GearTrain::mesh_force_split_at`]: the force
    /// along the drive row into `row`, along the back row into `back` (given when the mesh has
    /// its own back row).
    pub(super) fn mesh_force_rows(
        &self,
        n: usize,
        base: usize,
        w: &mut [f64],
        row: &mut [f64],
        mut back: Option<&mut [f64]>,
    ) {
        let mesh = &self.meshes[n];
        let m = self.m;
        let last = row.len() - 1;
        let omega = TAU * mesh.clock.mesh_frequency();
        row.fill(0.0);
        if let Some(b) = back.as_deref_mut() {
            b.fill(0.0);
        }
        // Whether the drive row's, the back row's flanks touch (`MeshRt::pressed_flanks`).
        let mut touching = [false; 2];
        for (j, flag) in mesh.flags.iter().enumerate() {
            for (on_back, back_flank) in mesh.pressed_flanks(*flag) {
                let law = mesh.law(j).expect("engaged");
                w.fill(0.0);
                self.delta_row_on(n, j, on_back, base, w);
                if back_flank {
                    w[last] += mesh.clearance();
                }
                let target = match back.as_deref_mut() {
                    Some(b) if on_back => b,
                    _ => &mut *row,
                };
                for (r, v) in target.iter_mut().zip(w.iter()) {
                    *r += law.k0 * v;
                }
                touching[usize::from(on_back)] = true;
            }
        }
        if mesh.damping != 0.0 {
            let c = mesh.damping;
            // The damper along each row whose flanks touch (both when wedged).
            for on_back in [false, true] {
                if !touching[usize::from(on_back)] {
                    continue;
                }
                let row = match back.as_deref_mut() {
                    Some(b) if on_back => b,
                    _ => &mut *row,
                };
                let a = mesh.flank(on_back);
                for i in 0..m {
                    row[m + i] += c * a[i];
                }
                for (i, &(ah, bh)) in mesh.ste.coefficients().iter().enumerate() {
                    let h = (i + 1) as f64;
                    // ė = Σ hω(−a_h sin + b_h cos).
                    row[base + 2 * i] -= c * h * omega * bh;
                    row[base + 2 * i + 1] += c * h * omega * ah;
                }
            }
        }
    }

    /// Output `column` ([`GearTrain::outputs`]) of the current mode as a row `w` over the
    /// augmented state, where it is linear in it (issue 31: the closed-form spectrum,
    /// `crate::analysis::spectrum::orbit_lines`): per mesh the DTE, its rate, the deflection,
    /// the mesh force ([`GearTrain::mesh_force_row`], the force the propagator integrates),
    /// the contact state and pairs in contact (constants of the mode), and the scene's
    /// translations. `false` for the phase, the stiffness, the loss fraction and per-pair or
    /// friction forces, and for a mesh with runout or pitch errors or the carried rotation
    /// (their terms are not in the rows); the caller integrates those otherwise.
    pub fn lifted_output_row(&self, column: usize, w: &mut [f64]) -> bool {
        if self.rotation.is_some() || w.len() != self.lti_dim() {
            return false;
        }
        w.fill(0.0);
        let m = self.m;
        let last = w.len() - 1;
        let bases = self.harmonic_base();
        let mut first = 0;
        for (n, mesh) in self.meshes.iter().enumerate() {
            let width = 9 + self.pair_outputs[n] + usize::from(mesh.friction.is_some());
            if column >= first + width {
                first += width;
                continue;
            }
            if mesh.eccentric.is_some() || !mesh.errors.is_empty() {
                return false;
            }
            let in_contact = mesh.flags.iter().filter(|f| f.touches()).count();
            match column - first {
                0 => (0..m).for_each(|i| w[i] = mesh.dte[i]),
                1 => (0..m).for_each(|i| w[m + i] = mesh.dte[i]),
                2 => (0..m).for_each(|i| w[i] = mesh.a[i]),
                3 => {
                    let mut scratch = vec![0.0; w.len()];
                    self.mesh_force_row(n, bases[n], &mut scratch, w);
                }
                4 => w[last] = super::contact::contact_state(&mesh.flags),
                5 => w[last] = in_contact as f64,
                _ => return false,
            }
            return true;
        }
        match self.scene_translations.get(column - first) {
            Some((i, _)) => {
                let row = self.q.row(*i);
                for k in 0..m {
                    w[k] = row[k];
                }
                true
            }
            None => false,
        }
    }

    /// Row of the slot deflection `δ_j = S − e − g_j` over the augmented state, on the drive
    /// flanks' row or on the back flanks' (`back`).
    pub(super) fn delta_row_on(&self, n: usize, j: usize, back: bool, base: usize, w: &mut [f64]) {
        let mesh = &self.meshes[n];
        w[..self.m].copy_from_slice(mesh.flank(back));
        for (i, &(ah, bh)) in mesh.ste.coefficients().iter().enumerate() {
            w[base + 2 * i] -= ah;
            w[base + 2 * i + 1] -= bh;
        }
        if let Some(l) = mesh.law(j) {
            let last = w.len() - 1;
            w[last] -= l.g0;
            if self.phase_ramp(mesh) {
                w[base + 2 * mesh.ste.harmonics()] -= l.g1;
            }
        }
    }
}

impl GearTrain {
    /// The rows of a free train's segment matrix besides its mesh forces (already in
    /// `a`): `ξ' = ξ'`, and `M̂⁻¹(F̂ − K̂_b ξ − Ĉ ξ')` from the products formed through the
    /// physical mass ([`JacobianParts::through_physical_mass`]), `per_in`, `per_load` being
    /// `M̂⁻¹F̂` per N·m. Formed through `M̂⁻¹`, whose condition grows with the train's length,
    /// these rows moved every segment's equilibrium (issue 37: 1.7e-9 of the static deflection
    /// on a free 16-mesh chain, 1.5e-6 on 64 meshes); the right-hand side of the RK path
    /// subtracts the forces first and is not affected.
    fn free_train_rows(
        &self,
        per_in: &[f64],
        per_load: &[f64],
        torque_rows: Option<&[Vec<f64>; 2]>,
        mut rows: AccelerationRows,
    ) {
        let m = self.m;
        let nz = rows.columns;
        let last = nz - 1;
        let (k_b, c) = (self.jacobian_parts.minv_k(), self.jacobian_parts.minv_c());
        // Column by column (contiguous in the column-major `A`); every entry takes the same
        // operations in the same order as row by row: the torques, then `M̂⁻¹K̂_b`, `M̂⁻¹Ĉ`.
        match torque_rows {
            Some([t_in, t_load]) => {
                for col in 0..nz {
                    for (i, x) in rows.column(col).iter_mut().enumerate() {
                        *x += per_in[i] * t_in[col] + per_load[i] * t_load[col];
                    }
                }
            }
            None => {
                for (i, x) in rows.column(last).iter_mut().enumerate() {
                    *x += per_in[i] * self.inputs.input_torque
                        + per_load[i] * self.inputs.load_torque;
                }
            }
        }
        for k in 0..m {
            for (x, &v) in rows.column(k).iter_mut().zip(k_b[k..].iter().step_by(m)) {
                *x -= v;
            }
        }
        for k in 0..m {
            for (x, &v) in rows.column(m + k).iter_mut().zip(c[k..].iter().step_by(m)) {
                *x -= v;
            }
        }
    }

    /// `−M̂⁻¹a_n F_n` (and `−M̂⁻¹ã_n F̃_n` of back flanks) of every mesh of a free train, from
    /// the Jacobian parts, subtracted from its acceleration rows.
    fn subtract_free_mesh_terms(&self, mut rows: AccelerationRows) {
        let nz = rows.columns;
        let mut w = vec![0.0; nz];
        let mut row = vec![0.0; nz];
        let mut back = vec![0.0; nz];
        let mut backs_before = 0;
        for (n, (mesh, base)) in self.meshes.iter().zip(self.harmonic_base()).enumerate() {
            let split = mesh.a_back.is_some().then_some(&mut back[..]);
            self.mesh_force_rows(n, base, &mut w, &mut row, split);
            // The back flanks' rows follow the drive rows in the Jacobian parts, in mesh order
            // (`GearTrain::new`).
            let back_part = mesh.a_back.as_ref().map(|_| {
                backs_before += 1;
                self.meshes.len() + backs_before - 1
            });
            let parts = std::iter::once((n, &row)).chain(back_part.map(|b| (b, &back)));
            // Column by column: the acceleration rows of a column are contiguous (`A` is
            // column-major; a new contact combination of a long chain builds a mode every
            // few segments), and every entry takes the same subtraction as row by row.
            // A column where the force row is zero (most of them: a mesh's row reaches
            // only its own gears' coordinates, a few harmonics and the constant) is
            // skipped: `x − g·0` is `x`, as the entries here are never `−0` (they start
            // at `+0` and `x − y` is `−0` only for `x = −0`), unless `g` is not finite.
            for (part, force_row) in parts {
                let g = self.jacobian_parts.minv_a(part);
                let skip_zeros = g.iter().all(|gi| gi.is_finite());
                for (col, &f) in force_row.iter().enumerate() {
                    if f == 0.0 && skip_zeros {
                        continue;
                    }
                    for (x, &gi) in rows.column(col).iter_mut().zip(g) {
                        *x -= gi * f;
                    }
                }
            }
        }
    }
}

/// The acceleration rows `m..2m` of a free train's segment matrix in a column-major store:
/// `A` itself (columns of `n_z` entries, the rows from `m`) or a band of its own (columns of
/// `m` entries, [`PiecewiseLti::lti_band_rows`]).
struct AccelerationRows<'a> {
    data: &'a mut [f64],
    stride: usize,
    offset: usize,
    m: usize,
    columns: usize,
}

impl<'a> AccelerationRows<'a> {
    /// Rows `m..2m` of `A` itself.
    fn of_matrix(a: &'a mut DMatrix<f64>, m: usize) -> Self {
        let columns = a.ncols();
        AccelerationRows {
            data: a.as_mut_slice(),
            stride: columns,
            offset: m,
            m,
            columns,
        }
    }

    /// A band of `m` rows and `columns` columns of its own.
    fn band(data: &'a mut [f64], m: usize, columns: usize) -> Self {
        AccelerationRows {
            data,
            stride: m,
            offset: 0,
            m,
            columns,
        }
    }

    fn column(&mut self, col: usize) -> &mut [f64] {
        let start = col * self.stride + self.offset;
        &mut self.data[start..start + self.m]
    }
}

impl PiecewiseLti for GearTrain {
    /// The STE at the event from the propagated harmonic states (one-DOF trains, as the
    /// single pair).
    fn on_event_lifted(&mut self, t: f64, z: &[f64], y: &mut [f64], index: usize) {
        if index >= self.guards.len() {
            self.knot_event(t, y, index - self.guards.len());
            return;
        }
        self.switch_slot(t, Some(z), y, index);
    }

    /// Harmonic states and the constant are continuous; a stiffness ramp restarts at every
    /// piece (the carried rotation always has one per mesh).
    fn forcing_carries_over(&self) -> bool {
        self.meshes.iter().all(|mesh| !self.phase_ramp(mesh))
    }

    /// With a linear contact law on every mesh a stop only moves a mesh to its next stiffness
    /// piece (its slots are classified in contact whatever the state) and books nothing that
    /// depends on `y`.
    fn stops_independent_of_state(&self) -> bool {
        self.meshes
            .iter()
            .all(|mesh| mesh.contact == ContactLaw::Linear)
    }

    /// A stop reads the state only to classify the tooth pairs that enter on a mesh with
    /// the contact-loss law (`contact.rs`, `on_mesh_stop`): in contact where the gap `δ > 0`,
    /// which is the entering pair's drive guard, a guard of the next mode. Backlash (back
    /// flanks, wedging), tooth friction, pitch-error steps (which classify every engaged
    /// pair again) and the carried rotation (knots as events) are left to the segment-wise
    /// path.
    fn stops_assume_contact(&self) -> bool {
        self.rotation.is_none()
            && self.meshes.iter().all(|mesh| {
                matches!(mesh.contact, ContactLaw::Linear | ContactLaw::ContactLoss)
                    && mesh.friction.is_none()
                    && !mesh.errors.has_steps()
            })
    }

    fn on_stop_assuming_contact(&mut self, t: f64) {
        self.stop_meshes(t, None);
    }

    /// Per mesh its cycle, interval and slot flags, then the contact-loss bookkeeping.
    fn save_stops(&self, out: &mut Vec<u64>) {
        out.clear();
        for mesh in &self.meshes {
            out.extend([mesh.cycle.to_bits(), mesh.interval as u64]);
            out.extend(mesh.flags.iter().map(|f| u64::from(f.code())));
        }
        for &(total, since) in &self.loss {
            out.extend([total.to_bits(), since.map_or(u64::MAX, f64::to_bits)]);
        }
    }

    fn restore_stops(&mut self, saved: &[u64]) {
        let mut words = saved.iter().copied();
        let mut next = || words.next().expect("saved by save_stops");
        for mesh in &mut self.meshes {
            mesh.cycle = f64::from_bits(next());
            mesh.interval = next() as usize;
            for flag in &mut mesh.flags {
                *flag = SlotContact::from_code(next() as u8).expect("a saved flag");
            }
        }
        for loss in &mut self.loss {
            let total = f64::from_bits(next());
            let since = match next() {
                u64::MAX => None,
                bits => Some(f64::from_bits(bits)),
            };
            *loss = (total, since);
        }
        self.refresh_guards();
    }

    fn lti_dim(&self) -> usize {
        self.dim()
            + self
                .meshes
                .iter()
                .map(|m| 2 * m.ste.harmonics() + usize::from(self.phase_ramp(m)))
                .sum::<usize>()
            + self.forcing_chain()
            + 1
    }

    /// `z = [y, per mesh (cos 2πhp, sin 2πhp)_h and the ramp r = s − start, 1]`; with the
    /// carried rotation on a torque ramp `t − f_anchor` before the constant.
    fn lift(&self, t: f64, y: &[f64], z: &mut [f64]) {
        z[..y.len()].copy_from_slice(y);
        for ((n, mesh), base) in self.meshes.iter().enumerate().zip(self.harmonic_base()) {
            let p = self.phase_of(n, t, y);
            let pf = crate::mesh::cycle_fraction(p);
            for h in 1..=mesh.ste.harmonics() {
                let (s, c) = (TAU * h as f64 * pf).sin_cos();
                z[base + 2 * (h - 1)] = c;
                z[base + 2 * (h - 1) + 1] = s;
            }
            if self.phase_ramp(mesh) {
                z[base + 2 * mesh.ste.harmonics()] = mesh.local(p);
            }
        }
        if let Some(u) = self.ramp_time_index() {
            let tau = t - self.f_anchor;
            z[u] = tau;
            if self.forcing_chain() == 3 {
                z[u + 1] = tau * tau / 2.0;
                z[u + 2] = tau * tau * tau / 6.0;
            }
        }
        let last = z.len() - 1;
        z[last] = 1.0;
    }

    fn lti_matrix(&self, a: &mut DMatrix<f64>) {
        // By the slice (one `memset`): the matrix's own `fill` goes entry by entry through its
        // strided iterator, which was three quarters of this function on a 16-mesh chain.
        a.as_mut_slice().fill(0.0);
        let nz = a.nrows();
        let last = nz - 1;
        let m = self.m;
        let torque_rows =
            (self.rotation.as_ref()).map(|rot| rot.torque_rows(self, nz, self.ramp_time_index()));
        // A free train takes every product with M̂⁻¹ from its Jacobian parts
        // (`free_train_rows`, issue 37), so it needs no force rows.
        let solved = self.jacobian_parts.torque_columns();
        // Generalised force rows over z (before M̂⁻¹): f_ext − K_b ξ − C ξ' − Σ a_n F_n.
        let mut force = DMatrix::<f64>::zeros(if solved.is_some() { 0 } else { m }, nz);
        for i in 0..force.nrows() {
            match &torque_rows {
                // The port or shaft torques over z, through the same map as `external_force`.
                Some([t_in, t_load]) => {
                    let (per_in, per_load) = (
                        self.external_force(i, 1.0, 0.0),
                        self.external_force(i, 0.0, 1.0),
                    );
                    for col in 0..nz {
                        force[(i, col)] = per_in * t_in[col] + per_load * t_load[col];
                    }
                }
                None => force[(i, last)] = self.f_ext[i],
            }
            for k in 0..m {
                force[(i, k)] -= self.k_b[i * m + k];
                force[(i, m + k)] -= self.c[i * m + k];
            }
        }
        let bases = self.harmonic_base();
        let mut w = vec![0.0; nz];
        let mut row = vec![0.0; nz];
        let mut back = vec![0.0; nz];
        if solved.is_some() {
            // −M̂⁻¹a_n F_n (and −M̂⁻¹ã_n F̃_n) straight into the acceleration rows.
            self.subtract_free_mesh_terms(AccelerationRows::of_matrix(a, m));
        }
        for (n, mesh) in self.meshes.iter().enumerate() {
            let base = bases[n];
            let omega = TAU * mesh.clock.mesh_frequency();
            let f = mesh.clock.mesh_frequency();
            if solved.is_none() {
                let split = mesh.a_back.is_some().then_some(&mut back[..]);
                self.mesh_force_rows(n, base, &mut w, &mut row, split);
                for i in 0..m {
                    for col in 0..nz {
                        force[(i, col)] -= mesh.a[i] * row[col];
                    }
                }
                if let Some(a_back) = &mesh.a_back {
                    for i in 0..m {
                        for col in 0..nz {
                            force[(i, col)] -= a_back[i] * back[col];
                        }
                    }
                }
            }
            for (i, _) in mesh.ste.coefficients().iter().enumerate() {
                let h = (i + 1) as f64;
                let (ci, si) = (base + 2 * i, base + 2 * i + 1);
                a[(ci, si)] = -h * omega;
                a[(si, ci)] = h * omega;
            }
            if mesh.ramp && self.rotation.is_none() {
                a[(base + 2 * mesh.ste.harmonics(), last)] = f;
            }
        }
        if let (Some(rot), Some(rows)) = (&self.rotation, &torque_rows) {
            let ramps: Vec<usize> = (self.meshes.iter().zip(&bases))
                .map(|(mesh, &base)| base + 2 * mesh.ste.harmonics())
                .collect();
            rot.lti_rows(self, rows, &ramps, a);
            if let Some(u) = self.ramp_time_index() {
                a[(u, last)] = 1.0;
                if self.forcing_chain() == 3 {
                    a[(u + 1, u)] = 1.0;
                    a[(u + 2, u + 1)] = 1.0;
                }
            }
        }
        if let Some([per_in, per_load]) = solved {
            for i in 0..m {
                a[(i, m + i)] = 1.0;
            }
            let rows = AccelerationRows::of_matrix(a, m);
            self.free_train_rows(per_in, per_load, torque_rows.as_ref(), rows);
            return;
        }
        for i in 0..m {
            a[(i, m + i)] = 1.0;
            for col in 0..nz {
                a[(m + i, col)] = if m == 1 {
                    force[(0, col)] / self.m_hat[0]
                } else {
                    (0..m).map(|k| self.minv[i * m + k] * force[(k, col)]).sum()
                };
            }
        }
    }

    /// A free train without the carried rotation: its modes differ only in the mesh terms of
    /// its acceleration rows `m..2m` (the velocities' identity, the harmonics' rotations and
    /// the phase ramps are the same in every mode).
    fn lti_band(&self) -> Option<std::ops::Range<usize>> {
        (self.jacobian_parts.torque_columns().is_some() && self.rotation.is_none())
            .then_some(self.m..2 * self.m)
    }

    fn lti_band_rows(&self, rows: &mut [f64]) {
        let Some([per_in, per_load]) = self.jacobian_parts.torque_columns() else {
            return;
        };
        let (m, nz) = (self.m, self.lti_dim());
        self.subtract_free_mesh_terms(AccelerationRows::band(rows, m, nz));
        self.free_train_rows(per_in, per_load, None, AccelerationRows::band(rows, m, nz));
    }

    fn guard_row(&self, index: usize, w: &mut [f64]) {
        w.fill(0.0);
        if index >= self.guards.len() {
            let rot = self
                .rotation
                .as_ref()
                .expect("knot guards need the rotation");
            let n = rot.knot_mesh(index - self.guards.len());
            let ramp = self.forcing_base(n) + 2 * self.meshes[n].ste.harmonics();
            rot.knot_guard_row(&self.meshes[n], index - self.guards.len(), ramp, w);
            return;
        }
        let (n, j, surface) = self.guards[index];
        let base = self.forcing_base(n);
        self.delta_row_on(n, j, surface.back_flank(), base, w);
        let last = w.len() - 1;
        let clearance = self.meshes[n].clearance();
        let (sign, offset) = match surface {
            Surface::Drive => (1.0, 0.0),
            Surface::SepDrive => (-1.0, 0.0),
            Surface::SepBack => (1.0, clearance),
            Surface::Back => (-1.0, clearance),
        };
        w[last] += offset;
        for v in w.iter_mut() {
            *v *= sign;
        }
    }

    fn mode_key(&self, key: &mut crate::solve::exact::ModeKey) {
        for mesh in &self.meshes {
            let intervals = mesh.table().map_or(1, |t| t.intervals.len()) as u64;
            key.push(mesh.interval as u64, intervals);
            // A fifth flag only where a slot can wedge: the other meshes' keys stay as they were.
            let radix = if mesh.can_wedge() { 5 } else { 4 };
            for f in &mesh.flags {
                key.push(*f as u64, radix);
            }
        }
    }

    fn max_frequency(&self) -> f64 {
        // ‖M̂⁻¹ K_max‖_∞ bounds the largest ω² of any mode.
        let m = self.m;
        let mut k = DMatrix::from_row_slice(m, m, &self.k_b);
        for mesh in &self.meshes {
            let kmax = match &mesh.stiffness {
                Stiffness::Table(t) => t.max_total_stiffness(),
                Stiffness::Smooth { mean, series, .. } => mean + series.amplitude_bound(),
            };
            let a = DVector::from_column_slice(&mesh.a);
            k += kmax * &a * a.transpose();
            if let Some(a_back) = &mesh.a_back {
                // The back flanks take the stiffness along their own row.
                let b = DVector::from_column_slice(a_back);
                k += kmax * &b * b.transpose();
            }
            if let Some(fr) = &mesh.friction {
                // The friction stiffness (w0 b0 + w1 b1) aᵀ at its largest weights.
                let t = DVector::from_iterator(
                    m,
                    fr.b0
                        .iter()
                        .zip(&fr.b1)
                        .map(|(b0, b1)| b0.abs() * fr.bound.0 + b1.abs() * fr.bound.1),
                );
                k += t * a.abs().transpose();
            }
        }
        let minv = DMatrix::from_row_slice(m, m, &self.minv);
        let prod = minv * k;
        let bound = (0..m)
            .map(|i| (0..m).map(|j| prod[(i, j)].abs()).sum::<f64>())
            .fold(0.0, f64::max);
        let harmonic = self
            .meshes
            .iter()
            .map(|mesh| TAU * mesh.clock.mesh_frequency() * mesh.ste.harmonics() as f64)
            .fold(0.0, f64::max);
        match &self.rotation {
            // The element shafts on their bodies add their own modes (Gershgorin).
            Some(rot) => (bound + rot.shaft_frequency_bound(self).powi(2))
                .sqrt()
                .max(harmonic),
            None => bound.sqrt().max(harmonic),
        }
    }
}
