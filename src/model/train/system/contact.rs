//! The contact state of every tooth-pair slot as the run goes (classification, guards,
//! contact-loss bookkeeping), the mesh forces it gives, and what a run reads of it: events,
//! mesh states, outputs and the run's time scales.

use super::*;

impl GearTrain {
    /// Whether mesh n has lost contact on every pair.
    pub(super) fn totally_lost(&self, n: usize) -> bool {
        !self.meshes[n].flags.iter().any(|f| f.touches())
    }

    /// Books a possible change of mesh n's total contact loss at `t`.
    pub(super) fn book_loss(&mut self, n: usize, t: f64) {
        let lost = self.totally_lost(n);
        let entry = &mut self.loss[n];
        match (lost, entry.1) {
            (true, None) => entry.1 = Some(t),
            (false, Some(since)) => {
                entry.0 += t - since;
                entry.1 = None;
            }
            _ => {}
        }
    }

    /// Fraction of the time since the last (re)start during which mesh n had lost contact on
    /// every tooth pair (total contact loss), at time `t`.
    pub fn contact_loss_fraction(&self, n: usize, t: f64) -> f64 {
        let span = t - self.loss_start;
        if !(span > 0.0) {
            return if self.totally_lost(n) { 1.0 } else { 0.0 };
        }
        let (total, since) = self.loss.get(n).copied().unwrap_or((0.0, None));
        (total + since.map_or(0.0, |s| t - s)) / span
    }

    /// Deflection of slot j relative to its gap, and its rate.
    pub(super) fn slot_gap(
        &self,
        n: usize,
        j: usize,
        t: f64,
        y: &[f64],
    ) -> Option<(f64, f64, SlotLaw)> {
        self.slot_gap_on(n, j, false, t, y)
    }

    /// [`GearTrain::slot_gap`] on the drive flanks' row, or on the back flanks' (`back`).
    pub(super) fn slot_gap_on(
        &self,
        n: usize,
        j: usize,
        back: bool,
        t: f64,
        y: &[f64],
    ) -> Option<(f64, f64, SlotLaw)> {
        let mesh = &self.meshes[n];
        let law = mesh.law(j)?;
        let (p, f) = self.phase_and_rate(n, t, y);
        let (e, slope) = mesh.ste_at(p);
        let (s, sd) = self.deflection_on(n, back, y);
        let r = mesh.local(p);
        let g_rate = match mesh.eccentric {
            None => law.g1 * f,
            Some(_) => law.g1 * mesh.contact_phase(p).1 * f,
        };
        Some((s - e - law.g(r), sd - slope * f - g_rate, law))
    }

    pub(super) fn classify(&self, n: usize, j: usize, t: f64, y: &[f64]) -> SlotContact {
        let Some((delta, rate, _)) = self.slot_gap(n, j, t, y) else {
            return SlotContact::Inactive;
        };
        match self.meshes[n].contact {
            ContactLaw::Linear => SlotContact::Drive,
            ContactLaw::ContactLoss => {
                if delta > 0.0 || (delta == 0.0 && rate > 0.0) {
                    SlotContact::Drive
                } else {
                    SlotContact::Separated
                }
            }
            ContactLaw::Backlash { .. } => {
                let (delta_back, rate_back) = match self.meshes[n].a_back {
                    None => (delta, rate),
                    Some(_) => self
                        .slot_gap_on(n, j, true, t, y)
                        .map_or((delta, rate), |v| (v.0, v.1)),
                };
                let back = delta_back + self.meshes[n].clearance_at(self.phase_of(n, t, y)).0;
                let drive = delta > 0.0 || (delta == 0.0 && rate > 0.0);
                let back = back < 0.0 || (back == 0.0 && rate_back < 0.0);
                match (drive, back) {
                    // On one row (no back row) `δ > 0` and `δ < −2b` exclude each other.
                    (true, true) if self.meshes[n].can_wedge() => SlotContact::Wedged,
                    (true, _) => SlotContact::Drive,
                    (false, true) => SlotContact::Back,
                    (false, false) => SlotContact::Separated,
                }
            }
        }
    }

    pub(super) fn refresh_guards(&mut self) {
        self.guards.clear();
        for (n, mesh) in self.meshes.iter().enumerate() {
            if mesh.contact == ContactLaw::Linear {
                continue;
            }
            let backlash = matches!(mesh.contact, ContactLaw::Backlash { .. });
            // With the back flanks on their own row, the flank not in contact is watched too:
            // it can close while the other is pressed (tooth wedging, `SlotContact::Wedged`).
            let wedge = mesh.can_wedge();
            for (j, flag) in mesh.flags.iter().enumerate() {
                match flag {
                    SlotContact::Inactive => {}
                    SlotContact::Drive => {
                        self.guards.push((n, j, Surface::Drive));
                        if wedge {
                            self.guards.push((n, j, Surface::SepBack));
                        }
                    }
                    SlotContact::Separated => {
                        self.guards.push((n, j, Surface::SepDrive));
                        if backlash {
                            self.guards.push((n, j, Surface::SepBack));
                        }
                    }
                    SlotContact::Back => {
                        self.guards.push((n, j, Surface::Back));
                        if wedge {
                            self.guards.push((n, j, Surface::SepDrive));
                        }
                    }
                    SlotContact::Wedged => {
                        self.guards.push((n, j, Surface::Drive));
                        self.guards.push((n, j, Surface::Back));
                    }
                }
            }
        }
    }

    pub(super) fn deflection(&self, n: usize, y: &[f64]) -> (f64, f64) {
        self.deflection_on(n, false, y)
    }

    /// The deflection along the drive flanks' row, or along the back flanks' (`back`).
    pub(super) fn deflection_on(&self, n: usize, back: bool, y: &[f64]) -> (f64, f64) {
        let a = self.meshes[n].flank(back);
        let m = self.m;
        let mut s = 0.0;
        let mut sd = 0.0;
        for i in 0..m {
            s += a[i] * y[i];
            sd += a[i] * y[m + i];
        }
        (s, sd)
    }

    /// Force of mesh n in the current mode; per-slot forces into `slots` when given.
    pub(super) fn mesh_force(&self, n: usize, t: f64, y: &[f64], slots: Option<&mut [f64]>) -> f64 {
        self.mesh_force_at(n, self.phase_and_rate(n, t, y), y, slots)
    }

    /// Mesh phase (cycles) and its rate (1/s) of mesh n at `(t, y)`: from the mesh clock in
    /// the nominal-speed form, from the carried pinion angle with ports (`docs/ports.md`).
    pub(super) fn phase_and_rate(&self, n: usize, t: f64, y: &[f64]) -> (f64, f64) {
        match &self.rotation {
            None => self.meshes[n].clock.phase_and_frequency(t),
            Some(rot) => rot.mesh_phase(n, t, y),
        }
    }

    /// Mesh phase of mesh n at `(t, y)` (see [`GearTrain::phase_and_rate`]).
    pub(super) fn phase_of(&self, n: usize, t: f64, y: &[f64]) -> f64 {
        match &self.rotation {
            None => self.meshes[n].clock.phase_at(t),
            Some(rot) => rot.mesh_phase(n, t, y).0,
        }
    }

    /// Force of mesh n in the current mode at mesh phase `p` with phase rate `f` (cycles/s):
    /// the one force routine of both the nominal-speed form and the carried rotation.
    pub(super) fn mesh_force_at(
        &self,
        n: usize,
        pf: (f64, f64),
        y: &[f64],
        slots: Option<&mut [f64]>,
    ) -> f64 {
        let (drive, back) = self.mesh_force_split_at(n, pf, y, slots);
        drive + back
    }

    /// [`GearTrain::mesh_force_at`] split by the row it acts along: `(F, F̃)`, the generalised
    /// force `−a F − ã F̃`. `F̃` holds the back flanks of a mesh with its own back row
    /// ([`MeshRt::pressed_flanks`], `docs/train.md`, "Back flanks"; a wedged slot adds to
    /// both) and the damper on that row while back flanks touch; otherwise 0, and `F` is the
    /// mesh force as formed without a back row.
    pub(super) fn mesh_force_split_at(
        &self,
        n: usize,
        (p, f): (f64, f64),
        y: &[f64],
        mut slots: Option<&mut [f64]>,
    ) -> (f64, f64) {
        let mesh = &self.meshes[n];
        let (e, e_slope) = mesh.ste_at(p);
        let (s, sd) = self.deflection(n, y);
        let (s_back, sd_back) = match mesh.a_back {
            Some(_) => self.deflection_on(n, true, y),
            None => (s, sd),
        };
        let r = mesh.local(p);
        let clearance = mesh.clearance_at(p).0;
        let mut force = 0.0;
        let mut force_back = 0.0;
        let (mut touching_drive, mut touching_back) = (false, false);
        for (j, flag) in mesh.flags.iter().enumerate() {
            let mut fj = 0.0;
            for (on_back, back_flank) in mesh.pressed_flanks(*flag) {
                let law = mesh.law(j).expect("a slot in contact is engaged");
                let offset = if back_flank { clearance } else { 0.0 };
                let delta = if on_back { s_back } else { s } - e - law.g(r);
                let force_flank = mesh.k(j, p, &law) * (delta + offset);
                fj += force_flank;
                if on_back {
                    force_back += force_flank;
                    touching_back = true;
                } else {
                    force += force_flank;
                    touching_drive = true;
                }
            }
            if let Some(out) = slots.as_deref_mut() {
                out[j] = fj;
            }
        }
        if mesh.damping != 0.0 {
            // The damper acts on Ṡ − ė, never on the rate of a gap: Models 2 and 3 put the
            // loaded STE / NLTE into the gap and damp the velocities only (eqs. 2.10, 2.11:
            // `C U̇`), like Model-1's tooth pairs. It acts along the flanks in contact, each
            // row's while its flanks touch: both when the mesh is wedged.
            if touching_drive {
                force += mesh.damping * (sd - e_slope * f);
            }
            if touching_back {
                force_back += mesh.damping * (sd_back - e_slope * f);
            }
        }
        (force, force_back)
    }

    /// Starts recording contact changes `(t, mesh, slot, new flag)`.
    pub fn record_events(&mut self) {
        self.event_log = Some(Vec::new());
    }

    pub fn events(&self) -> &[(f64, usize, usize, SlotContact)] {
        self.event_log.as_deref().unwrap_or(&[])
    }

    /// Contact flags of mesh n's slots.
    pub fn slot_flags(&self, n: usize) -> &[SlotContact] {
        &self.meshes[n].flags
    }

    /// The tooth-pair slots of mesh n with outputs of their own (`<mesh>.pair<j>.force`: a
    /// Model-1 mesh), 0 otherwise.
    pub fn pair_slots(&self, n: usize) -> usize {
        self.pair_outputs.get(n).copied().unwrap_or(0)
    }

    /// Evaluated quantities of mesh n at `(t, y)`.
    pub fn mesh_state(&self, n: usize, t: f64, y: &[f64]) -> MeshState {
        let mesh = &self.meshes[n];
        let (deflection, deflection_rate) = self.deflection(n, y);
        let m = self.m;
        let mut dte = 0.0;
        let mut dte_rate = 0.0;
        for i in 0..m {
            dte += mesh.dte[i] * y[i];
            dte_rate += mesh.dte[i] * y[m + i];
        }
        let p = self.phase_of(n, t, y);
        let stiffness = (0..mesh.slots())
            .filter_map(|j| mesh.law(j).map(|l| mesh.k(j, p, &l)))
            .sum();
        MeshState {
            deflection,
            deflection_rate,
            dte,
            dte_rate,
            force: self.mesh_force(n, t, y, None),
            stiffness,
            in_contact: mesh.flags.iter().filter(|f| f.touches()).count(),
            any_back: mesh.flags.iter().any(|f| f.touches_back()),
            phase: crate::mesh::output_phase(p),
        }
    }

    /// The time scales that decide the work of a run (checked against
    /// [`crate::simulation::RunLimits`] before it starts): the fastest mesh frequency, the
    /// largest |phase| at t = 0, and the fastest rate of any mode: the bound of
    /// [`PiecewiseLti::max_frequency`] or the damping rate `‖M̂⁻¹C‖_∞`, whichever is larger
    /// (an overdamped mode decays at about that rate, and the RK path must resolve it).
    pub fn run_scales(&self) -> crate::simulation::RunScales {
        let m = self.m;
        let damping_rate = (0..m)
            .map(|i| {
                (0..m)
                    .map(|j| {
                        (0..m)
                            .map(|l| self.minv[i * m + l] * self.c[l * m + j])
                            .sum::<f64>()
                            .abs()
                    })
                    .sum::<f64>()
            })
            .fold(0.0, f64::max)
            .max(
                self.rotation
                    .as_ref()
                    .map_or(0.0, |r| r.shaft_damping_bound(self)),
            );
        let peak_speed = self
            .profiles
            .as_ref()
            .and_then(|p| p.speed.as_ref())
            .map(|p| p.max_value());
        crate::simulation::RunScales {
            mesh_frequency: self
                .meshes
                .iter()
                .map(|mesh| match peak_speed {
                    Some(s) => (mesh.cycles_per_rev * s / TAU).abs(),
                    None => mesh.clock.mesh_frequency().abs(),
                })
                .fold(0.0, f64::max),
            mesh_frequency_slope: self.rotation.as_ref().map_or(0.0, |r| {
                r.mesh_frequency_slope(self.inputs.input_torque, self.inputs.load_torque)
            }),
            start_phase: self
                .meshes
                .iter()
                .map(|mesh| (mesh.clock.phase_at(0.0) + mesh.offset).abs())
                .fold(0.0, f64::max),
            speed: match peak_speed {
                Some(s) => ("operating.speed_profile (its largest value)", s),
                None => ("operating.input_speed", self.inputs.input_speed),
            },
            fastest_rate: self.fastest_rate(damping_rate),
        }
    }

    /// The fastest rate of any mode and what sets it: [`PiecewiseLti::max_frequency`] with
    /// the speed ports' coupling springs added (Gershgorin: `ω² ≤ bound + k/J`), or the
    /// damping rate with their dampers, whichever is larger (an overdamped mode decays at
    /// about that rate, and the RK path must resolve it). The couplings are left out of
    /// `max_frequency` itself, which also paces the exact propagator's guard samples.
    fn fastest_rate(&self, damping_rate: f64) -> (f64, &'static str) {
        let frequency = self.max_frequency();
        let (port_frequency, port_damping) = self
            .rotation
            .as_ref()
            .map_or((0.0, 0.0), |r| r.port_coupling_bounds(self));
        let with_ports = frequency.hypot(port_frequency);
        let damping = damping_rate + port_damping;
        if !(damping <= with_ports) {
            if port_damping > damping_rate {
                return (
                    damping,
                    "the speed ports' coupling damping (port damping) on the port gears' inertia",
                );
            }
            return (
                damping,
                "the damping on the masses: mesh damping, bearing damping, modal damping ratio, shaft damping",
            );
        }
        if port_frequency > frequency {
            return (
                with_ports,
                "the speed ports' coupling stiffness (port stiffness) on the port gears' inertia",
            );
        }
        (
            with_ports,
            "the mesh and bearing stiffnesses on the masses (or the STE harmonics)",
        )
    }

    /// Whether advancing from `t` to `t_end` stays within the limits of one advance for
    /// every mesh clock ([`PhaseClock::check_advance`]); the message names the mesh.
    pub fn check_advance(&self, t: f64, t_end: f64) -> Result<(), String> {
        for (n, mesh) in self.meshes.iter().enumerate() {
            mesh.clock.check_advance(t, t_end).map_err(|e| {
                format!(
                    "operating.input_speed = {:e} rad/s, mesh {n} phase {:e} cycles at t = {t:e} s: {e}",
                    self.inputs.input_speed,
                    mesh.clock.phase_at(t)
                )
            })?;
        }
        Ok(())
    }

    /// Mesh phase of mesh n at `t`, cycles (the clock's, without the stiffness source's shift).
    pub fn mesh_phase(&self, n: usize, t: f64) -> f64 {
        self.meshes[n].clock.phase_at(t)
    }

    /// Mesh period of mesh n at the current speed, s.
    /// Whether any mesh sees gear runout or pitch errors.
    pub fn has_gear_errors(&self) -> bool {
        self.meshes.iter().any(|m| !m.errors.is_empty())
    }

    /// Rotation frequencies of the gears with errors, per mesh that sees them, Hz.
    pub fn error_frequencies(&self) -> Vec<f64> {
        self.meshes
            .iter()
            .flat_map(|m| {
                let f = m.clock.mesh_frequency();
                m.errors.revolution_orders().into_iter().map(move |o| o * f)
            })
            .collect()
    }

    pub fn mesh_period(&self, n: usize) -> f64 {
        1.0 / self.meshes[n].clock.mesh_frequency()
    }

    /// All outputs at `(t, y)` in [`GearTrain::output_names`] order.
    pub fn outputs(&self, t: f64, y: &[f64], out: &mut Vec<f64>) {
        out.clear();
        for n in 0..self.meshes.len() {
            let st = self.mesh_state(n, t, y);
            let state = contact_state(&self.meshes[n].flags);
            out.extend([
                st.dte,
                st.dte_rate,
                st.deflection,
                st.force,
                state,
                st.in_contact as f64,
                st.phase,
                st.stiffness,
                self.contact_loss_fraction(n, t),
            ]);
            let slots = self.pair_outputs[n];
            if slots > 0 {
                let start = out.len();
                out.resize(start + slots, 0.0);
                self.mesh_force(n, t, y, Some(&mut out[start..]));
            }
            if self.meshes[n].friction.is_some() {
                out.push(self.friction_force(n, t, y));
            }
        }
        for (i, _) in &self.scene_translations {
            let row = self.q.row(*i);
            out.push((0..self.m).map(|k| row[k] * y[k]).sum());
        }
        if let Some(rot) = &self.rotation {
            let mut dy = vec![0.0; y.len()];
            self.rhs(t, y, &mut dy);
            rot.outputs(t, y, &dy, out);
        }
    }

    /// Switches every mesh whose interval ends at `t`, each past any interval that ends at `t`
    /// too: an interval narrower than the time resolution (trapezoidal ramps that touch) lasts
    /// no time. At most one cycle of intervals per mesh, as for the single pair. Without `y`
    /// (a walk of the stops ahead of the state, [`PiecewiseLti::on_stop_assuming_contact`])
    /// every slot that enters is taken in contact.
    pub(super) fn stop_meshes(&mut self, t: f64, y: Option<&[f64]>) {
        let due: Vec<usize> = (0..self.meshes.len())
            .filter(|&n| self.meshes[n].next_stop() <= t)
            .collect();
        for n in due {
            let count = self.meshes[n].table().map_or(1, |tb| tb.intervals.len());
            for _ in 0..count {
                self.on_mesh_stop(n, t, y);
                if self.meshes[n].next_stop() > t {
                    break;
                }
            }
            self.book_loss(n, t);
        }
        self.refresh_guards();
    }

    pub(super) fn on_mesh_stop(&mut self, n: usize, t: f64, y: Option<&[f64]>) {
        let mesh = &mut self.meshes[n];
        let steps = mesh.errors.has_steps();
        let Stiffness::Table(table) = &mesh.stiffness else {
            // A smooth stiffness stops only at the pitch-error steps.
            mesh.cycle += 1.0;
            if let Some(y) = y {
                self.reclassify_engaged(n, t, y);
            }
            return;
        };
        let count = table.intervals.len();
        let shift = table.shift_on_wrap;
        mesh.interval += 1;
        let wrapped = mesh.interval == count;
        if wrapped {
            mesh.interval = 0;
            mesh.cycle += 1.0;
        }
        let slots = mesh.flags.len();
        let old = mesh.flags.clone();
        for j in 0..slots {
            let carried = if wrapped && shift {
                old.get(j + 1).copied().unwrap_or(SlotContact::Inactive)
            } else {
                old[j]
            };
            mesh.flags[j] = carried;
        }
        for j in 0..slots {
            let engaged = self.meshes[n].law(j).is_some();
            let flag = self.meshes[n].flags[j];
            self.meshes[n].flags[j] = match (engaged, flag) {
                (false, _) => SlotContact::Inactive,
                (true, SlotContact::Inactive) => match y {
                    Some(y) => self.classify(n, j, t, y),
                    None => SlotContact::Drive,
                },
                (true, f) => f,
            };
        }
        if let (true, true, Some(y)) = (wrapped, steps, y) {
            self.reclassify_engaged(n, t, y);
        }
    }

    /// After a pitch-error step of the STE every engaged slot's gap jumped: its contact is
    /// decided afresh from the state.
    pub(super) fn reclassify_engaged(&mut self, n: usize, t: f64, y: &[f64]) {
        for j in 0..self.meshes[n].flags.len() {
            if self.meshes[n].flags[j] != SlotContact::Inactive {
                self.meshes[n].flags[j] = self.classify(n, j, t, y);
            }
        }
    }
}

/// The `<mesh>.contact_state` output of a mesh whose slots have `flags`: 0 total contact loss,
/// 1 drive flanks only, −1 back flanks only, 2 both at once (a wedged slot, or one slot on
/// each side).
pub(super) fn contact_state(flags: &[SlotContact]) -> f64 {
    let drive = flags.iter().any(|f| f.touches_drive());
    let back = flags.iter().any(|f| f.touches_back());
    match (drive, back) {
        (false, false) => 0.0,
        (true, false) => 1.0,
        (false, true) => -1.0,
        (true, true) => 2.0,
    }
}
