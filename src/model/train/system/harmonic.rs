//! The drivetrain split for frequency-domain methods ([`crate::model::Drivetrain::mesh_law`]):
//! the linear part `M̂ ξ'' + Ĉ ξ' + K̂_b ξ` and, per mesh, the forces of its cycle table as
//! functions of the mesh deflection `S_n = a_n·ξ`, every slot's contact decided from the state
//! at the mesh phase (the table interval located from the phase, not the frozen mode).

use nalgebra::DMatrix;

use super::{GearTrain, Stiffness};
use crate::model::{LinearPart, MeshLaw};
use crate::scene::ContactLaw;

/// One engaged slot at a phase: its stiffness, gap `e + g_j` and gap rate, and the friction
/// weights `(w0, w1)` when the mesh has tooth friction.
struct FreeSlot {
    k: f64,
    gap: f64,
    gap_rate: f64,
    friction: Option<(f64, f64)>,
}

impl GearTrain {
    /// `M̂`, `Ĉ` (bearing, coupling and modal damping) and `K̂_b`.
    pub fn linear_part(&self) -> LinearPart {
        let m = self.m;
        LinearPart {
            mass: DMatrix::from_row_slice(m, m, &self.m_hat),
            damping: DMatrix::from_row_slice(m, m, &self.c),
            stiffness: DMatrix::from_row_slice(m, m, &self.k_b),
        }
    }

    /// Mesh `n`'s DTE row `d_n` over ξ.
    pub fn mesh_dte_row(&self, n: usize) -> &[f64] {
        &self.meshes[n].dte
    }

    /// The external generalised force `F̂` (constant between input changes), N.
    pub fn external_forces(&self) -> &[f64] {
        &self.f_ext
    }

    /// Mean stiffness and viscous damping of mesh `n`.
    pub fn mean_mesh_law(&self, n: usize) -> (f64, f64) {
        (self.meshes[n].k_mean, self.meshes[n].damping)
    }

    /// `a_n`, then with tooth friction the friction vectors `b0`, `b1`
    /// (`system/friction.rs`): the friction adds `+(f0 b0 + f1 b1)` to the generalised force,
    /// i.e. forces `−f0`, `−f1` along them in the sign of [`crate::model::Drivetrain`].
    pub fn mesh_force_directions(&self, n: usize) -> Vec<Vec<f64>> {
        let mesh = &self.meshes[n];
        let mut out = vec![mesh.a.clone()];
        if let Some(fr) = &mesh.friction {
            out.push(fr.b0.clone());
            out.push(fr.b1.clone());
        }
        out
    }

    /// `ã_n = Qᵀd̃_n`, mesh `n`'s back flanks' own deflection row, where it differs from `a_n`
    /// (a mesh with backlash, a pressure angle and translations: `docs/train.md`, "Back
    /// flanks"); its back-side force depends on `ã_n·ξ`, not on `S_n`.
    pub fn mesh_back_row(&self, n: usize) -> Option<&[f64]> {
        self.meshes[n].a_back.as_deref()
    }

    /// Mesh phases (cycles, `[0, 1)`) of mesh `n`'s interval knots, and with pitch errors the
    /// stiffness-cycle boundary (where a pitch error steps, `docs/errors.md`); none for a
    /// smooth stiffness without pitch errors. Nominal: without runout (see
    /// [`GearTrain::mesh_knot_phase`]).
    pub fn mesh_breakpoints(&self, n: usize) -> Vec<f64> {
        let mesh = &self.meshes[n];
        match &mesh.stiffness {
            Stiffness::Table(table) if table.has_stops() => table
                .intervals
                .iter()
                .map(|iv| crate::mesh::cycle_fraction(iv.start - mesh.offset))
                .collect(),
            _ if mesh.errors.has_steps() => vec![crate::mesh::cycle_fraction(-mesh.offset)],
            _ => Vec::new(),
        }
    }

    /// The mesh phase at which the knot of mesh `n` that lies at `nominal` without runout
    /// ([`GearTrain::mesh_breakpoints`], any cycle) lies: where the contact phase
    /// `q = p + δq(p)` reaches it, and for the interval where a tooth pair enters, where it
    /// reaches the moved start of contact (`docs/errors.md`, "Runout as a moving centre";
    /// the integrators stop there, `MeshRt::next_stop`). `nominal` itself without runout.
    pub fn mesh_knot_phase(&self, n: usize, nominal: f64) -> f64 {
        let mesh = &self.meshes[n];
        let Some(ec) = &mesh.eccentric else {
            return nominal;
        };
        // The interval the knot starts: the entry interval's start (the only knot whose
        // place also moves with the contact ratio), or any other.
        let moving = match (ec.entry, mesh.table()) {
            (Some((i, _)), Some(table)) => {
                let s = crate::mesh::cycle_fraction(nominal + mesh.offset);
                let nearest = (0..table.intervals.len())
                    .min_by(|&a, &b| {
                        let distance = |k: usize| {
                            let d = (s - table.intervals[k].start).abs();
                            d.min(1.0 - d)
                        };
                        distance(a).total_cmp(&distance(b))
                    })
                    .expect("one interval at least");
                nearest == i
            }
            _ => false,
        };
        ec.geometry
            .solve_phase(nominal, if moving { 1.0 } else { 0.0 })
    }

    /// Visits the engaged slots of mesh `n` at phase `p` (mesh frequency `f`), from the table
    /// interval that contains `p` (no allocation: called at every quadrature node).
    fn for_each_free_slot(&self, n: usize, p: f64, f: f64, mut visit: impl FnMut(FreeSlot)) {
        let mesh = &self.meshes[n];
        let (e, e_slope) = mesh.ste_free(p);
        match &mesh.stiffness {
            Stiffness::Smooth {
                mean,
                series,
                phase,
            } => visit(FreeSlot {
                k: mean + series.value(mesh.contact_phase(p).0 + phase),
                gap: e,
                gap_rate: e_slope * f,
                friction: None,
            }),
            Stiffness::Table(table) => {
                let (index, r) = match mesh.eccentric {
                    None => table.locate(p + mesh.offset),
                    Some(_) => {
                        let (_, index, s) = mesh.locate_free(p);
                        (index, s - table.intervals[index].start)
                    }
                };
                let iv = &table.intervals[index];
                let dq = mesh.contact_phase(p).1;
                for (j, law) in iv.laws.iter().enumerate() {
                    let Some(law) = law else { continue };
                    let friction = mesh
                        .friction
                        .as_ref()
                        .and_then(|fr| fr.intervals[index][j])
                        .map(|sf| sf.weights(r));
                    visit(FreeSlot {
                        k: law.k(r),
                        gap: e + law.g(r),
                        gap_rate: (e_slope + law.g1 * dq) * f,
                        friction,
                    });
                }
            }
        }
    }

    /// Mesh `n`'s forces at `(t, S, Ṡ)` with every slot's contact decided by its deflection
    /// `δ_j = S − e − g_j` (drive for `δ_j > 0`, back side for `δ_j < −2b`, the rule of
    /// `GearTrain::classify` without the tie-break, which has measure zero): `Σ_j k_j(δ_j +
    /// o_j) + c(Ṡ − ė)` while any slot touches, and the friction of the slots in drive contact.
    pub fn free_mesh_law(&self, n: usize, t: f64, s: f64, s_rate: f64) -> MeshLaw {
        let mesh = &self.meshes[n];
        let (p, f) = mesh.clock.phase_and_frequency(t);
        let mut law = MeshLaw::default();
        let clearance = mesh.clearance_at(p).0;
        let mut j = 0;
        self.for_each_free_slot(n, p, f, |slot| {
            let bit = 2 * j;
            j += 1;
            let delta = s - slot.gap;
            let (drive, offset) = match mesh.contact {
                ContactLaw::Linear => (true, 0.0),
                ContactLaw::ContactLoss if delta > 0.0 => (true, 0.0),
                ContactLaw::Backlash { .. } if delta > 0.0 => (true, 0.0),
                ContactLaw::Backlash { .. } if delta < -clearance => (false, clearance),
                _ => return,
            };
            law.force[0] += slot.k * (delta + offset);
            law.stiffness[0] += slot.k;
            law.in_contact += 1;
            law.pattern |= 1 << (bit + u32::from(!drive)).min(63);
            if let (true, Some((w0, w1))) = (drive, slot.friction) {
                law.force[1] -= w0 * delta;
                law.force[2] -= w1 * delta;
                law.stiffness[1] -= w0;
                law.stiffness[2] -= w1;
            }
        });
        if law.in_contact > 0 && mesh.damping != 0.0 {
            let (_, e_slope) = mesh.ste_free(p);
            let viscous = mesh.damping * (s_rate - e_slope * f);
            law.force[0] += viscous;
            law.viscous[0] = viscous;
            law.damping[0] = mesh.damping;
        }
        law
    }

    /// [`GearTrain::free_mesh_law`] with the back flanks on their own row (`MeshRt::a_back`):
    /// a slot's back flanks touch for `δ̃_j = S̃ − e − g_j < −2b`, whatever its drive flanks do
    /// (both: wedged, `SlotContact::Wedged`), with the force `k_j(δ̃_j + 2b)`, and the damper
    /// `c(dS̃/dt − ė)` while back flanks touch, both in entry `k_b` (after the mesh's force
    /// directions), acting along `ã_n` (`GearTrain::mesh_force_split_at`'s split). A mesh without its own back row:
    /// [`GearTrain::free_mesh_law`].
    pub fn free_mesh_law_with_back(
        &self,
        n: usize,
        t: f64,
        s: f64,
        s_rate: f64,
        back: (f64, f64),
    ) -> MeshLaw {
        match self.meshes[n].a_back {
            Some(_) => self.free_flanks_law(n, t, s, s_rate, Some(back)),
            None => self.free_mesh_law(n, t, s, s_rate),
        }
    }

    /// The law of both rows: `back` the back row's deflection and rate (`None` takes the back
    /// flanks on `S`, the operations of [`GearTrain::free_mesh_law`], which stays separate:
    /// it runs at every quadrature node of every HB evaluation).
    fn free_flanks_law(
        &self,
        n: usize,
        t: f64,
        s: f64,
        s_rate: f64,
        back: Option<(f64, f64)>,
    ) -> MeshLaw {
        let mesh = &self.meshes[n];
        let (p, f) = mesh.clock.phase_and_frequency(t);
        let mut law = MeshLaw::default();
        let clearance = mesh.clearance_at(p).0;
        // The back flanks' entry: after the mesh force and the friction's two.
        let k_back = match back {
            Some(_) => 1 + 2 * usize::from(mesh.friction.is_some()),
            None => 0,
        };
        let s_back = back.map_or(s, |b| b.0);
        // Whether the drive row's, the back row's flanks touch.
        let mut touching = [false; 2];
        let mut j = 0;
        self.for_each_free_slot(n, p, f, |slot| {
            let bit = 2 * j;
            j += 1;
            let delta = s - slot.gap;
            let delta_back = s_back - slot.gap;
            let drive = match mesh.contact {
                ContactLaw::Linear => true,
                ContactLaw::ContactLoss | ContactLaw::Backlash { .. } => delta > 0.0,
            };
            // With its own row the back flank closes whatever the drive flank does (both
            // pressed: tooth wedging, `SlotContact::Wedged`); on `S` it cannot while `δ > 0`.
            let back_flank = matches!(mesh.contact, ContactLaw::Backlash { .. })
                && delta_back < -clearance
                && (back.is_some() || !drive);
            if !(drive || back_flank) {
                return;
            }
            law.in_contact += 1;
            if drive {
                law.force[0] += slot.k * delta;
                law.stiffness[0] += slot.k;
                law.pattern |= 1 << bit.min(63);
                touching[0] = true;
                if let Some((w0, w1)) = slot.friction {
                    law.force[1] -= w0 * delta;
                    law.force[2] -= w1 * delta;
                    law.stiffness[1] -= w0;
                    law.stiffness[2] -= w1;
                }
            }
            if back_flank {
                law.force[k_back] += slot.k * (delta_back + clearance);
                law.stiffness[k_back] += slot.k;
                law.pattern |= 1 << (bit + 1).min(63);
                touching[usize::from(back.is_some())] = true;
            }
        });
        if mesh.damping != 0.0 {
            let (_, e_slope) = mesh.ste_free(p);
            // Along each row whose flanks touch: both when wedged.
            let rates = [(0, s_rate), (k_back, back.map_or(s_rate, |b| b.1))];
            for (&(k, rate), _) in rates.iter().zip(touching).filter(|(_, on)| *on) {
                let viscous = mesh.damping * (rate - e_slope * f);
                law.force[k] += viscous;
                law.viscous[k] = viscous;
                law.damping[k] = mesh.damping;
            }
        }
        law
    }

    /// The switching functions of mesh `n` at `(t, S, Ṡ)`: `δ_j` of every engaged slot (and
    /// `δ_j + 2b` with backlash), with their rates; none for the linear law.
    pub fn free_contact_gaps(
        &self,
        n: usize,
        t: f64,
        s: f64,
        s_rate: f64,
        out: &mut Vec<(f64, f64)>,
    ) {
        out.clear();
        let mesh = &self.meshes[n];
        if mesh.contact == ContactLaw::Linear {
            return;
        }
        let (p, f) = mesh.clock.phase_and_frequency(t);
        let clearance = mesh.clearance_at(p).0;
        self.for_each_free_slot(n, p, f, |slot| {
            let (delta, rate) = (s - slot.gap, s_rate - slot.gap_rate);
            out.push((delta, rate));
            if let ContactLaw::Backlash { .. } = mesh.contact {
                out.push((delta + clearance, rate));
            }
        });
    }

    /// [`GearTrain::free_contact_gaps`] with the back flanks on their own row: `δ_j` and
    /// `δ̃_j + 2b` per engaged slot, the latter from `back = (S̃, dS̃/dt)`.
    pub fn free_contact_gaps_with_back(
        &self,
        n: usize,
        t: f64,
        s: f64,
        s_rate: f64,
        back: (f64, f64),
        out: &mut Vec<(f64, f64)>,
    ) {
        match self.meshes[n].a_back {
            Some(_) => self.free_flanks_gaps(n, t, s, s_rate, Some(back), out),
            None => self.free_contact_gaps(n, t, s, s_rate, out),
        }
    }

    fn free_flanks_gaps(
        &self,
        n: usize,
        t: f64,
        s: f64,
        s_rate: f64,
        back: Option<(f64, f64)>,
        out: &mut Vec<(f64, f64)>,
    ) {
        out.clear();
        let mesh = &self.meshes[n];
        if mesh.contact == ContactLaw::Linear {
            return;
        }
        let (p, f) = mesh.clock.phase_and_frequency(t);
        let clearance = mesh.clearance_at(p).0;
        let (s_back, s_back_rate) = back.unwrap_or((s, s_rate));
        self.for_each_free_slot(n, p, f, |slot| {
            let (delta, rate) = (s - slot.gap, s_rate - slot.gap_rate);
            out.push((delta, rate));
            if let ContactLaw::Backlash { .. } = mesh.contact {
                let (delta_back, rate_back) = (s_back - slot.gap, s_back_rate - slot.gap_rate);
                out.push((delta_back + clearance, rate_back));
            }
        });
    }
}
