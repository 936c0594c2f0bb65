//! The drivetrain as a hybrid system in elastic coordinates: `y = [ξ, ξ']`,
//!
//! `M̂ ξ'' + Ĉ ξ' + K̂_b ξ + Σ_n a_n F_n = F̂`,  `a_n = Qᵀ d_n`,  `S_n = a_nᵀ ξ`
//!
//! (Liu 2007 eq. 2.6 projected on the elastic coordinates of [`super::assembly`]). Mesh n has
//! the force of its cycle table ([`super::mesh`]): per slot j in contact
//! `F_nj = k_j(s)(S_n − e_n(p) − g_j(s) + o_j)`, `o_j = 2b` on the back side, else 0
//! (eq. 2.2 with the back-side sign corrected, notes §1.3 [R], erratum §8 item 2), plus the
//! mesh damping `c_n(Ṡ_n − ė_n)` while any slot is in contact. The mesh phase of mesh n is
//! `p_n(t) = φ_n + (f_n/f_1)·p_1(0) + f_n t` with `f_n` its mesh frequency: mesh n leads mesh 1
//! by `φ_n` cycles, `k_n(t) = k̃_n(t + φ_n T_n)` (Ch. 4 Fig. 4.2; eq. 2.1 writes the opposite
//! sign), turned from time into phase by one [`PhaseClock`] per mesh.
//!
//! Contact changes of every slot are state events (guards linear in the state), stiffness and
//! gap knots are stops; the discrete mode is frozen in between (numerics-notes §2.1). When all
//! stiffnesses are piecewise constant the segments are LTI in an augmented state (harmonics of
//! the STE, one phase ramp per mesh for affine gaps, a constant), so the exact propagator
//! applies.

use std::cell::RefCell;
use std::f64::consts::TAU;

use nalgebra::{DMatrix, DVector};

use super::assembly::{try_generalized_eigen, Assembly, DofKind, FreeStatics, Reduction};
use super::friction::FrictionTable;
use super::mesh::{CycleTable, Interval, SlotLaw};
use super::statics::{equilibrium, loaded_ste, Ste};
use crate::mesh::eccentricity::Eccentricity;
use crate::mesh::errors::{GearInMesh, MeshErrors};
use crate::mesh::{MeshStiffness, PhaseSeries};
use crate::model::PhaseClock;
use crate::scene::train::{MeshForceModel, PairModel};
use crate::scene::Scene;
use crate::scene::{ContactLaw, InitialDte};
use crate::solve::exact::PiecewiseLti;
use crate::solve::HybridSystem;
use jacobian::JacobianParts;

mod contact;
mod friction;
mod frozen;
mod harmonic;
mod hybrid;
mod jacobian;
mod lti;
pub(crate) mod rotating;
mod setup;
mod snapshot;
pub use frozen::FrozenStatics;
pub use rotating::Neighbour;
use setup::{
    entry_knot, loaded_ste_table, mesh_eccentricity, mesh_errors, nlte_table, nominal_rotation,
    pair_closed_form,
};
pub use snapshot::{MeshRunState, TrainRunState};

/// Contact flag of one tooth-pair slot.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SlotContact {
    /// The slot's pair is not engaged (outside its window).
    Inactive = 3,
    Drive = 1,
    Separated = 0,
    Back = 2,
    /// Both flanks pressed at once (tooth wedging): the drive flanks on the drive row and the
    /// back flanks on their own row, each with its spring (`docs/train.md`, "Back flanks").
    /// Only on a mesh with backlash whose back flanks have their own row
    /// ([`MeshRt::can_wedge`]): on one row `δ > 0` and `δ < −2b` exclude each other.
    Wedged = 4,
}

impl SlotContact {
    /// Whether the slot's drive flanks carry load (drive contact or wedged).
    pub fn touches_drive(self) -> bool {
        matches!(self, SlotContact::Drive | SlotContact::Wedged)
    }

    /// Whether the slot's back flanks carry load (back contact or wedged).
    pub fn touches_back(self) -> bool {
        matches!(self, SlotContact::Back | SlotContact::Wedged)
    }

    /// Whether any flank of the slot carries load.
    pub fn touches(self) -> bool {
        self.touches_drive() || self.touches_back()
    }
}

/// Operating inputs, held constant between communication points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrainInputs {
    /// Nominal speed of the input gear, rad/s (>= 0).
    pub input_speed: f64,
    /// N·m.
    pub input_torque: f64,
    /// Load torque magnitude on the output gear, N·m.
    pub load_torque: f64,
}

#[derive(Debug, Clone)]
enum Stiffness {
    Table(CycleTable),
    /// A smooth (Fourier) stiffness: `mean + series(p + phase)`.
    Smooth {
        mean: f64,
        series: PhaseSeries,
        phase: f64,
    },
}

#[derive(Debug, Clone)]
struct MeshRt {
    a: Vec<f64>,
    /// `Qᵀ d̃_n`, the back flanks' deflection row (`flanks::back_line_of_action`), when it
    /// differs from `a` (a mesh with backlash whose translations see the back line).
    a_back: Option<Vec<f64>>,
    dte: Vec<f64>,
    clock: PhaseClock,
    cycles_per_rev: f64,
    stiffness: Stiffness,
    /// `s = frac(p + offset)`: the lumped source's phase shift, 0 for pair tables.
    offset: f64,
    ste: PhaseSeries,
    /// Runout and pitch errors of the mesh's gears (`docs/errors.md`).
    errors: MeshErrors,
    /// The runout's moving centres: mesh position, start of contact and backlash
    /// (`docs/errors.md`); `None` without runout.
    eccentric: Option<EccentricMesh>,
    contact: ContactLaw,
    damping: f64,
    k_mean: f64,
    /// Model-2 meshes rebuild their table when the load changes.
    model2: Option<CycleTable>,
    /// A phase-ramp state in the augmented LTI state (affine gaps).
    ramp: bool,
    /// Tooth friction (Model-1 meshes with `[mesh.friction]`).
    friction: Option<FrictionTable>,
    cycle: f64,
    interval: usize,
    flags: Vec<SlotContact>,
}

/// A mesh whose gears have runout: the involute geometry it moves, and the interval of a
/// two-level (rectangular) table whose start is the start of contact of a tooth pair.
#[derive(Debug, Clone)]
struct EccentricMesh {
    geometry: Eccentricity,
    /// `(i, s_i)`: interval `i` starts where a pair enters, at `s_i + entry(p)`.
    entry: Option<(usize, f64)>,
}

impl MeshRt {
    /// The deflection row of the drive flanks, or of the back flanks (`back`).
    fn flank(&self, back: bool) -> &[f64] {
        match (&self.a_back, back) {
            (Some(a_back), true) => a_back,
            _ => &self.a,
        }
    }

    /// Whether a slot of this mesh can have both flanks pressed at once
    /// ([`SlotContact::Wedged`]): backlash, and the back flanks on their own row.
    fn can_wedge(&self) -> bool {
        self.a_back.is_some() && matches!(self.contact, ContactLaw::Backlash { .. })
    }

    /// The flanks slot flag `flag` presses, as `(on the back row, back flank)`: the back
    /// flank's spring acts on `δ̃ + 2b` (`δ + 2b` without a back row), the drive flank's on
    /// `δ`. A wedged slot presses both, each on its own row.
    fn pressed_flanks(&self, flag: SlotContact) -> impl Iterator<Item = (bool, bool)> {
        let back_row = self.a_back.is_some();
        let (drive, back) = (flag.touches_drive(), flag.touches_back());
        (drive.then_some((false, false)).into_iter()).chain(back.then_some((back_row, true)))
    }

    /// The nominal total backlash (without runout).
    fn clearance(&self) -> f64 {
        match self.contact {
            ContactLaw::Backlash { clearance } => clearance,
            _ => 0.0,
        }
    }

    /// The total backlash at mesh phase `p` (the runout moves the centre distance) and its
    /// slope per cycle.
    fn clearance_at(&self, p: f64) -> (f64, f64) {
        match (&self.eccentric, self.contact) {
            (Some(ec), ContactLaw::Backlash { clearance }) => {
                let m = ec.geometry.at(p);
                (clearance + m.backlash, m.backlash_slope)
            }
            _ => (self.clearance(), 0.0),
        }
    }

    /// The contact phase `q(p) = p + δq(p)` where the stiffness, the gaps and the mesh STE
    /// are read, and `dq/dp`.
    fn contact_phase(&self, p: f64) -> (f64, f64) {
        match &self.eccentric {
            None => (p, 1.0),
            Some(ec) => {
                let m = ec.geometry.at(p);
                (p + m.phase, 1.0 + m.phase_slope)
            }
        }
    }

    /// Stiffness cycle, table interval and cycle fraction `s` at nominal phase `p` (the
    /// moved start of contact included).
    fn locate_free(&self, p: f64) -> (f64, usize, f64) {
        let u = self.contact_phase(p).0 + self.offset;
        let cycle = u.floor();
        let s = u - cycle;
        let mut interval = self.table().map_or(0, |tb| tb.interval_at(s));
        if let Some(EccentricMesh {
            geometry,
            entry: Some((i, start)),
        }) = &self.eccentric
        {
            if interval + 1 == *i || interval == *i {
                let knot = start + geometry.at(p).entry;
                interval = if s < knot { i - 1 } else { *i };
            }
        }
        (cycle, interval, s)
    }

    /// The nominal phase at which the shifted contact phase `q + offset` reaches `u_end`, the
    /// end of the current interval (the moved start of contact for the interval before it).
    fn phase_of_interval_end(&self, u_end: f64) -> f64 {
        match &self.eccentric {
            None => u_end - self.offset,
            Some(ec) => {
                let moving = ec.entry.is_some_and(|(i, _)| self.interval + 1 == i);
                let weight = if moving { 1.0 } else { 0.0 };
                ec.geometry.solve_phase(u_end - self.offset, weight)
            }
        }
    }

    fn table(&self) -> Option<&CycleTable> {
        match &self.stiffness {
            Stiffness::Table(t) => Some(t),
            Stiffness::Smooth { .. } => None,
        }
    }

    fn slots(&self) -> usize {
        self.table().map_or(1, |t| t.slots)
    }

    fn current(&self) -> Option<&Interval> {
        self.table().map(|t| &t.intervals[self.interval])
    }

    /// `r = s − interval start` at phase `p` (read at the contact phase).
    fn local(&self, p: f64) -> f64 {
        let start = self.current().map_or(0.0, |iv| iv.start);
        let q = match &self.eccentric {
            None => p,
            Some(_) => self.contact_phase(p).0,
        };
        (q + self.offset - self.cycle) - start
    }

    fn law(&self, j: usize) -> Option<SlotLaw> {
        match &self.stiffness {
            Stiffness::Table(t) => t.intervals[self.interval].laws[j],
            Stiffness::Smooth { .. } => Some(SlotLaw {
                k0: 0.0,
                k1: 0.0,
                g0: 0.0,
                g1: 0.0,
            }),
        }
    }

    /// Stiffness of slot j at phase p (frozen interval).
    fn k(&self, j: usize, p: f64, law: &SlotLaw) -> f64 {
        match &self.stiffness {
            Stiffness::Smooth {
                mean,
                series,
                phase,
            } => match &self.eccentric {
                None => mean + series.value(p + phase),
                Some(_) => mean + series.value(self.contact_phase(p).0 + phase),
            },
            Stiffness::Table(_) => {
                let _ = j;
                law.k(self.local(p))
            }
        }
    }

    /// The STE `e` (mesh series and gear errors) and `de/dp` at phase `p` in the frozen
    /// stiffness cycle.
    fn ste_at(&self, p: f64) -> (f64, f64) {
        self.ste_in_cycle(p, self.cycle)
    }

    /// The same in the stiffness cycle that contains `p` (no frozen mode: statics, harmonic
    /// balance).
    fn ste_free(&self, p: f64) -> (f64, f64) {
        match &self.eccentric {
            None => self.ste_in_cycle(p, (p + self.offset).floor()),
            Some(_) => self.ste_in_cycle(p, self.locate_free(p).0),
        }
    }

    fn ste_in_cycle(&self, p: f64, cycle: f64) -> (f64, f64) {
        let (e, slope) = match &self.eccentric {
            None => self.ste.value_and_slope(p),
            Some(_) => {
                // The tooth STE follows the contact position; the runout term below the
                // nominal rotation.
                let (q, dq) = self.contact_phase(p);
                let (e, slope) = self.ste.value_and_slope(q);
                (e, slope * dq)
            }
        };
        if self.errors.is_empty() {
            return (e, slope);
        }
        let (de, dslope) = self.errors.value_and_slope(p, cycle);
        (e + de, slope + dslope)
    }

    fn locate(&mut self, t: f64) {
        self.locate_phase(self.clock.phase_at(t));
    }

    fn locate_phase(&mut self, p: f64) {
        if self.eccentric.is_some() {
            (self.cycle, self.interval, _) = self.locate_free(p);
            return;
        }
        let u = p + self.offset;
        self.cycle = u.floor();
        let s = u - self.cycle;
        self.interval = self.table().map_or(0, |tb| tb.interval_at(s));
    }

    fn next_stop(&self) -> f64 {
        // Pitch errors step at every stiffness-cycle boundary.
        let steps = self.errors.has_steps();
        match self.table() {
            Some(t) if t.has_stops() || steps => {
                let end = self.cycle + t.intervals[self.interval].end;
                self.clock.time_of(self.phase_of_interval_end(end))
            }
            None if steps => self
                .clock
                .time_of(self.phase_of_interval_end(self.cycle + 1.0)),
            _ => f64::INFINITY,
        }
    }
}

/// One guard: mesh, slot and which surface. The names say the flag that watches them first;
/// a mesh that can wedge ([`MeshRt::can_wedge`]) also watches the other flank in contact
/// (`Drive` with `SepBack`, `Back` with `SepDrive`) and a wedged slot both flanks' ends
/// (`Drive` and `Back`): [`Surface::next`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Surface {
    /// The drive flanks touch: `δ >= 0`.
    Drive,
    /// The drive flanks are apart: `−δ >= 0`.
    SepDrive,
    /// The back flanks are apart: `δ̃ + 2b >= 0`.
    SepBack,
    /// The back flanks touch: `−(δ̃ + 2b) >= 0`.
    Back,
}

impl Surface {
    /// Whether the guard watches the back flanks (their deflection row, `MeshRt::flank`).
    fn back_flank(self) -> bool {
        matches!(self, Surface::SepBack | Surface::Back)
    }

    /// The slot's flag after this guard of a slot with flag `flag` crossed zero: the flank it
    /// watches closes or opens, the other flank keeps its state.
    fn next(self, flag: SlotContact) -> SlotContact {
        let (drive, back) = (flag.touches_drive(), flag.touches_back());
        let (drive, back) = match self {
            Surface::Drive => (false, back),
            Surface::SepDrive => (true, back),
            Surface::SepBack => (drive, true),
            Surface::Back => (drive, false),
        };
        match (drive, back) {
            (true, true) => SlotContact::Wedged,
            (true, false) => SlotContact::Drive,
            (false, true) => SlotContact::Back,
            (false, false) => SlotContact::Separated,
        }
    }
}

/// Evaluated quantities of one mesh.
#[derive(Debug, Clone, Copy, Default)]
pub struct MeshState {
    pub deflection: f64,
    pub deflection_rate: f64,
    pub dte: f64,
    pub dte_rate: f64,
    pub force: f64,
    /// Sum of the engaged slots' stiffness.
    pub stiffness: f64,
    pub in_contact: usize,
    pub any_back: bool,
    pub phase: f64,
}

/// The drivetrain model.
#[derive(Debug, Clone)]
pub struct GearTrain {
    m: usize,
    m_hat: Vec<f64>,
    minv: Vec<f64>,
    k_b: Vec<f64>,
    c: Vec<f64>,
    /// `M̂⁻¹K̂_b`, `M̂⁻¹Ĉ`, `M̂⁻¹a_n` for the frozen mode's Jacobian.
    jacobian_parts: JacobianParts,
    /// A free train's static solution through the physical coordinates (issue 37).
    free_statics: Option<Box<FreeStatics>>,
    f_in: Vec<f64>,
    f_out: Vec<f64>,
    f_ext: Vec<f64>,
    /// `dF̂/dt` on a torque-profile piece (`force_ramp`), from `f_anchor`, N/s.
    f_rate: Vec<f64>,
    force_ramp: bool,
    f_anchor: f64,
    /// First-order rates of the input and load torques from `f_anchor`, N·m/s: the FMU's
    /// input derivatives over one communication step (`docs/ports.md`); 0 otherwise.
    torque_rates: [f64; 2],
    /// Second and third derivatives `[[T'', T'''] of the input, of the load]` from
    /// `f_anchor` (N·m/s², N·m/s³): the FMU's input derivatives of orders 2 and 3 (a cubic
    /// Hermite input, `docs/cosimulation.md`); all 0 for a ramp or held torques.
    torque_higher: [[f64; 2]; 2],
    /// `d²F̂/dt²`, `d³F̂/dt³` of [`GearTrain::torque_higher`], formed as `f_rate` is.
    f_higher: [Vec<f64>; 2],
    /// `Qᵀ M v`: the elastic force per rad/s² of nominal input acceleration is its negative.
    inertial: Vec<f64>,
    /// The scene's speed and torque profiles (a run-up), followed by the driver.
    profiles: Option<std::sync::Arc<crate::scene::Profiles>>,
    /// Rigid-body acceleration per N·m of input / load torque.
    rigid_in: Vec<f64>,
    rigid_out: Vec<f64>,
    meshes: Vec<MeshRt>,
    q: DMatrix<f64>,
    asm: Assembly,
    scene_translations: Vec<(usize, String)>,
    inputs: TrainInputs,
    guards: Vec<(usize, usize, Surface)>,
    scratch: RefCell<Vec<f64>>,
    names: Vec<String>,
    /// Mesh names (column prefixes) in scene order.
    mesh_names: Vec<String>,
    /// Per gear: name, teeth and nominal speed over the input speed (shaft orders).
    gears: Vec<(String, u32, f64)>,
    pair_outputs: Vec<usize>,
    event_log: Option<Vec<(f64, usize, usize, SlotContact)>>,
    /// Free single pair: `(d_θ, J)` of the input and output bodies for the closed form.
    pair_form: Option<[(f64, f64); 2]>,
    /// Per mesh: time with total contact loss so far, and since when it is lost now.
    loss: Vec<(f64, Option<f64>)>,
    /// Start of the contact-loss bookkeeping (last (re)start).
    loss_start: f64,
    /// The carried rigid-body rotation of a scene with ports (`docs/ports.md`); `None`: the
    /// nominal-speed form, where the mesh clocks follow the input speed.
    rotation: Option<Box<rotating::Carried>>,
}

fn row_major(a: &DMatrix<f64>) -> Vec<f64> {
    let (r, c) = a.shape();
    (0..r)
        .flat_map(|i| (0..c).map(move |j| (i, j)))
        .map(|(i, j)| a[(i, j)])
        .collect()
}

impl GearTrain {
    /// Assembles the model at `t = 0` with the scene's inputs.
    pub fn new(scene: &Scene) -> Result<GearTrain, String> {
        if let Some(why) = super::frame::gyroscopic_refusal(scene) {
            return Err(why);
        }
        if let Some(why) = super::planetary::refusal(scene) {
            return Err(why);
        }
        let asm = Assembly::new(scene);
        let red = Reduction::new(&asm)?;
        let q = red.q.clone();
        let m = red.elastic_dim();
        if m == 0 {
            return Err("the train has no elastic coordinate".into());
        }
        let mass = q.transpose() * &asm.mass * &q;
        let k_b = q.transpose() * &asm.k_base * &q;
        let mut c = q.transpose() * &asm.c_base * &q;
        if let Some(frame) = &asm.frame {
            // The rotating carrier frame's skew velocity term (Lin & Parker 1999 eq. 1).
            c += q.transpose() * &frame.gyroscopic * &q;
        }
        let mut k_mean = k_b.clone();
        let a_vecs: Vec<DVector<f64>> = asm.mesh.iter().map(|d| q.transpose() * d).collect();
        for (a, &k) in a_vecs.iter().zip(&asm.mean_stiffness) {
            k_mean += k * a * a.transpose();
        }
        let zeta = scene.modal_damping_ratio;
        // `M̂⁻¹Ĉ_modal = Φ diag(2ζω) ΦᵀM̂`, for the products of a free train.
        let mut minv_modal = None;
        if zeta > 0.0 {
            // Modal damping on the mean-stiffness modes: C = M̂ Φ diag(2ζω) Φᵀ M̂ with Φ
            // mass-normalised (Liu 2007 eq. 2.14, ζ = εμ/2); rigid modes are already removed.
            let (w2, phi) = try_generalized_eigen(&k_mean, &mass)?;
            let diag = DMatrix::from_diagonal(&DVector::from_iterator(
                m,
                w2.iter().map(|&w| 2.0 * zeta * w.max(0.0).sqrt()),
            ));
            c += &mass * &phi * &diag * phi.transpose() * &mass;
            if red.rigid_dim() > 0 {
                minv_modal = Some(&phi * diag * (phi.transpose() * &mass));
            }
        }
        let minv = mass
            .clone()
            .try_inverse()
            .ok_or("the reduced mass matrix is singular")?;
        let f_in = q.transpose() * &asm.input_load;
        let f_out = q.transpose() * &asm.output_load;
        let (rigid_in, rigid_out) = if red.rigid_dim() > 0 {
            (
                (red.r.transpose() * &asm.input_load).as_slice().to_vec(),
                (red.r.transpose() * &asm.output_load).as_slice().to_vec(),
            )
        } else {
            (Vec::new(), Vec::new())
        };
        // Inertial forcing of a nominal angular acceleration α of the input gear
        // (`docs/runup.md`): the nominal motion q_nom'' = v α (every body turning at its
        // speed ratio, no translation) leaves `−Qᵀ M v α` on the elastic coordinates. In a
        // free train v is a rigid-body mode and RᵀMQ = 0 makes the term vanish (up to
        // rounding; as for the single pair); ground couplings, which act on the vibration,
        // make it nonzero.
        let v = nominal_rotation(scene, &asm);
        let inertial = (q.transpose() * &asm.mass * v).as_slice().to_vec();

        let mut meshes = Vec::new();
        let ratio1 = scene.meshes[0].cycles_per_input_rev;
        for (n, sm) in scene.meshes.iter().enumerate() {
            let p0 = if ratio1 > 0.0 {
                sm.phase + sm.cycles_per_input_rev / ratio1 * scene.meshes[0].initial_phase
            } else {
                sm.phase
            };
            let (stiffness, offset, ste, model2) = match &sm.force {
                MeshForceModel::Lumped { stiffness, ste } => {
                    let st = match stiffness {
                        MeshStiffness::Piecewise { phase, pieces } => {
                            (Stiffness::Table(CycleTable::lumped(pieces)), *phase)
                        }
                        MeshStiffness::Fourier {
                            phase,
                            mean,
                            series,
                        } => (
                            Stiffness::Smooth {
                                mean: *mean,
                                series: series.clone(),
                                phase: *phase,
                            },
                            0.0,
                        ),
                    };
                    (st.0, st.1, ste.clone(), None)
                }
                MeshForceModel::Pairs {
                    model,
                    pair,
                    relief,
                } => {
                    let pairs = match &sm.friction {
                        // Eq. (4.42): k(1 ± β) per pair, split at the pitch point.
                        Some(fr) => CycleTable::pairs(&fr.pair_stiffness(pair), relief),
                        None => CycleTable::pairs(pair, relief),
                    };
                    let table = match model {
                        PairModel::PerPair => pairs.clone(),
                        PairModel::Nlte => nlte_table(&pairs),
                        PairModel::LoadedSte => pairs.clone(),
                    };
                    let model2 = (*model == PairModel::LoadedSte).then_some(pairs);
                    (Stiffness::Table(table), 0.0, PhaseSeries::default(), model2)
                }
            };
            let slots = match &stiffness {
                Stiffness::Table(t) if model2.is_none() => t.slots,
                _ => 1,
            };
            let ramp = match &stiffness {
                Stiffness::Table(t) => t
                    .intervals
                    .iter()
                    .any(|iv| iv.laws.iter().flatten().any(|l| l.g1 != 0.0)),
                _ => false,
            } || model2.is_some();
            let friction = match (&sm.friction, &stiffness, &sm.force, &asm.friction[n]) {
                (
                    Some(fr),
                    Stiffness::Table(table),
                    MeshForceModel::Pairs { pair, .. },
                    Some(vectors),
                ) => {
                    let bent = fr.pair_stiffness(pair);
                    Some(FrictionTable::new(
                        table,
                        pair.contact_ratio,
                        |xi| match &sm.helical {
                            // Friction distributed along the contact line (He & Singh 2007).
                            Some(h) => h.weights(fr.coefficient, xi),
                            None => fr.weights(&bent, xi),
                        },
                        (q.transpose() * &vectors.base).as_slice().to_vec(),
                        (q.transpose() * &vectors.per_arm).as_slice().to_vec(),
                    ))
                }
                _ => None,
            };
            let errors = mesh_errors(scene, n, p0, offset);
            let eccentric = match mesh_eccentricity(scene, n, p0)? {
                None => None,
                Some(geometry) => Some(EccentricMesh {
                    entry: entry_knot(&stiffness, &geometry, &scene.meshes[n].name)?,
                    geometry,
                }),
            };
            let back = (q.transpose() * &asm.mesh_back[n]).as_slice().to_vec();
            meshes.push(MeshRt {
                a_back: (back != a_vecs[n].as_slice()).then_some(back),
                a: a_vecs[n].as_slice().to_vec(),
                dte: (q.transpose() * &asm.dte[n]).as_slice().to_vec(),
                clock: PhaseClock::new(0.0, p0, 0.0),
                cycles_per_rev: sm.cycles_per_input_rev,
                stiffness,
                offset,
                ste,
                errors,
                eccentric,
                contact: sm.contact,
                damping: sm.damping,
                k_mean: asm.mean_stiffness[n],
                model2,
                ramp,
                friction,
                cycle: 0.0,
                interval: 0,
                flags: vec![SlotContact::Drive; slots],
            });
        }

        let scene_translations = asm
            .dofs
            .iter()
            .enumerate()
            .filter(|(_, d)| !matches!(d, DofKind::Rotation { .. }))
            .map(|(i, _)| (i, asm.labels[i].clone()))
            .collect();
        let mut train = GearTrain {
            m,
            m_hat: row_major(&mass),
            minv: row_major(&minv),
            k_b: row_major(&k_b),
            c: row_major(&c),
            jacobian_parts: JacobianParts::default(),
            free_statics: None,
            f_in: f_in.as_slice().to_vec(),
            f_out: f_out.as_slice().to_vec(),
            f_ext: vec![0.0; m],
            f_rate: vec![0.0; m],
            force_ramp: false,
            f_anchor: 0.0,
            torque_rates: [0.0; 2],
            torque_higher: [[0.0; 2]; 2],
            f_higher: [vec![0.0; m], vec![0.0; m]],
            inertial,
            profiles: scene
                .profiles
                .any()
                .then(|| std::sync::Arc::new(scene.profiles.clone())),
            rigid_in,
            rigid_out,
            meshes,
            q,
            asm,
            scene_translations,
            inputs: TrainInputs {
                input_speed: scene.operating.input_speed,
                input_torque: scene.operating.input_torque,
                load_torque: scene.operating.load_torque,
            },
            guards: Vec::new(),
            scratch: RefCell::new(vec![0.0; m]),
            names: Vec::new(),
            mesh_names: scene.meshes.iter().map(|m| m.name.clone()).collect(),
            gears: (scene.gears.iter().zip(&scene.speed_ratio))
                .map(|(g, &r)| (g.name.clone(), g.teeth, r))
                .collect(),
            pair_outputs: Vec::new(),
            event_log: None,
            pair_form: None,
            loss: Vec::new(),
            loss_start: 0.0,
            rotation: None,
        };
        train.pair_form = pair_closed_form(scene, &train.asm, m, red.rigid_dim());
        if let Some([(d_in, j_in), (d_out, j_out)]) = train.pair_form {
            // One mesh between two free bodies: M̂ = 1/(d_θ,inᵀ²/J_in + d_θ,out²/J_out), the
            // equivalent mass of docs/model.md, formed in the same order as the single pair.
            let m_e = 1.0 / (d_in.powi(2) / j_in + d_out.powi(2) / j_out);
            train.m_hat = vec![m_e];
            train.minv = vec![1.0 / m_e];
        }
        // The single mass as the right-hand side divides by it.
        let minv = if m == 1 {
            vec![1.0 / train.m_hat[0]]
        } else {
            train.minv.clone()
        };
        // The meshes' rows `a_n`, then the back flanks' own rows `ã_n` of the meshes that have
        // them (issue 33), in mesh order: `lti_matrix` and the Jacobian's gains index them so.
        let backs: Vec<usize> = (train.meshes.iter().enumerate())
            .filter(|(_, mesh)| mesh.a_back.is_some())
            .map(|(n, _)| n)
            .collect();
        train.jacobian_parts = if red.rigid_dim() > 0 && m > 1 {
            // A free train: the products through the physical mass (issue 37).
            let g = red.inverse_mass_rows(&train.asm)?;
            train.free_statics = FreeStatics::new(&train.asm, &red).map(Box::new);
            let physical: Vec<&DVector<f64>> = (train.asm.mesh.iter())
                .chain(backs.iter().map(|&n| &train.asm.mesh_back[n]))
                .collect();
            let reduced: Vec<&[f64]> = (train.meshes.iter().map(|mesh| mesh.a.as_slice()))
                .chain(
                    backs
                        .iter()
                        .filter_map(|&n| train.meshes[n].a_back.as_deref()),
                )
                .collect();
            JacobianParts::through_physical_mass(
                &g, &train.asm, &train.q, minv_modal, &physical, &reduced,
            )
        } else {
            JacobianParts::new(
                m,
                &minv,
                &train.k_b,
                &train.c,
                (train.meshes.iter().map(|mesh| mesh.a.as_slice())).chain(
                    backs
                        .iter()
                        .filter_map(|&n| train.meshes[n].a_back.as_deref()),
                ),
            )
        };
        train.names = train.build_names(scene);
        train.apply_inputs(0.0, train.inputs)?;
        if let Some(pr) = &train.profiles {
            if pr.torque_varies() {
                if let Some(n) = train.meshes.iter().position(|m| m.model2.is_some()) {
                    return Err(format!(
                        "mesh[{n}] model = \"loaded_ste\" builds its excitation from the static \
                         load, which operating.torque_profile changes continuously: use another \
                         mesh model or a constant torque"
                    ));
                }
            }
        }
        if let Some(p) = train.profiles.as_ref().and_then(|p| p.speed.as_ref()) {
            // The largest speed of the profile within the propagators' range, before the run.
            let peak = p.max_value();
            for (n, mesh) in train.meshes.iter().enumerate() {
                let rate = mesh.cycles_per_rev * peak;
                if !(rate <= crate::model::MAX_RATE) {
                    return Err(format!(
                        "operating.speed_profile reaches {peak:?} rad/s, which gives mesh {n} a \
                         mesh rate of {rate:e} 1/s, beyond {:e} 1/s (the propagators square it)",
                        crate::model::MAX_RATE
                    ));
                }
            }
        }
        train.apply_profiles(0.0)?;
        for mesh in &mut train.meshes {
            mesh.locate(0.0);
        }
        if scene.carries_rotation() {
            let carried = rotating::Carried::new(scene, &train, &red)?;
            train.names.extend(carried.names());
            train.rotation = Some(Box::new(carried));
        }
        Ok(train)
    }

    /// Takes the profile pieces that start at `t` (`docs/runup.md`): every mesh clock runs on
    /// the speed piece (phase quadratic in time), the external force on the torque piece, and
    /// a grounded train carries the inertial force `−Qᵀ M v Ω̇` of the nominal acceleration.
    pub fn apply_profiles(&mut self, t: f64) -> Result<(), String> {
        let Some(pr) = self.profiles.clone() else {
            return Ok(());
        };
        let mut inputs = self.inputs;
        let piece = pr.piece_at(t, inputs.input_speed, inputs.input_torque);
        let ((speed, speed_rate), (torque, torque_rate)) = (piece.speed, piece.torque);
        inputs.input_speed = speed;
        inputs.input_torque = torque;
        let load_rate = piece.load.map_or(0.0, |(load, rate)| {
            inputs.load_torque = load;
            rate
        });
        self.apply_inputs(t, inputs)?;
        for mesh in &mut self.meshes {
            let f = mesh.cycles_per_rev * speed / TAU;
            mesh.clock
                .reanchor_ramp(t, f, mesh.cycles_per_rev * speed_rate / TAU);
        }
        if speed_rate != 0.0 {
            for (f, g) in self.f_ext.iter_mut().zip(&self.inertial) {
                *f -= g * speed_rate;
            }
        }
        self.set_force_rate(torque_rate, load_rate);
        self.force_ramp = torque_rate != 0.0;
        self.f_anchor = t;
        Ok(())
    }

    /// `dF̂/dt` of torque rates, formed as `f_ext` is from the torques.
    fn set_force_rate(&mut self, torque_rate: f64, load_rate: f64) {
        let mut f_rate = std::mem::take(&mut self.f_rate);
        self.force_of_rates(torque_rate, load_rate, &mut f_rate);
        self.f_rate = f_rate;
    }

    /// The generalised force of torque derivatives `[input, load]` of one order into `out`
    /// (the map of `f_ext` from the torques, linear in them).
    fn force_of_rates(&self, torque_rate: f64, load_rate: f64, out: &mut [f64]) {
        for ((o, f_in), f_out) in out.iter_mut().zip(&self.f_in).zip(&self.f_out) {
            *o = f_in * torque_rate + f_out * load_rate;
        }
        if let Some([(d_in, j_in), (d_out, j_out)]) = self.pair_form {
            out[0] = self.m_hat[0] * (d_in * torque_rate / j_in + d_out * -load_rate / j_out);
        }
    }

    /// First-order rates `[input, load]` (N·m/s) of the torques from `t` on: the right-hand
    /// side reads `T + T'·(τ − t)`, elastic and rigid part alike (FMI 2.0.x §4.2.1
    /// `fmi2SetRealInputDerivatives`, used by the drivetrain FMU with torque ports). Rates
    /// `[0, 0]` restore held torques. Not with torque profiles, which own the force ramp.
    pub fn set_torque_rates(&mut self, t: f64, rates: [f64; 2]) -> Result<(), String> {
        self.set_torque_derivatives(t, [[rates[0], 0.0, 0.0], [rates[1], 0.0, 0.0]])
    }

    /// Derivatives of orders 1–3 `[[T', T'', T'''] of the input, of the load]` of the torques
    /// from `t` on: the right-hand side reads the cubic `T + T'τ + T''τ²/2 + T'''τ³/6`,
    /// `τ = t' − t` (FMI 2.0.x §4.2.1, `fmi2SetRealInputDerivatives` of orders 1–3). The exact
    /// propagator carries `τ, τ²/2, τ³/6` as a nilpotent chain in the lifted state
    /// ([`GearTrain::forcing_chain`]). All 0 restore held torques; without orders 2 and 3 this
    /// is [`GearTrain::set_torque_rates`] bit for bit. Not with torque profiles.
    pub fn set_torque_derivatives(&mut self, t: f64, d: [[f64; 3]; 2]) -> Result<(), String> {
        if self.profiles.is_some() {
            return Err("torque rates cannot be combined with [profile] run-ups".into());
        }
        for (which, row) in ["input", "load"].iter().zip(&d) {
            for (order, x) in row.iter().enumerate() {
                if !x.is_finite() {
                    return Err(format!(
                        "{which} torque derivative of order {} = {x} is not finite",
                        order + 1
                    ));
                }
            }
        }
        let rates = [d[0][0], d[1][0]];
        self.torque_rates = rates;
        self.torque_higher = [[d[0][1], d[0][2]], [d[1][1], d[1][2]]];
        self.set_force_rate(rates[0], rates[1]);
        let mut f_higher = std::mem::take(&mut self.f_higher);
        for (k, out) in f_higher.iter_mut().enumerate() {
            self.force_of_rates(d[0][k + 1], d[1][k + 1], out);
        }
        self.f_higher = f_higher;
        self.force_ramp = rates != [0.0; 2] || self.cubic_torques();
        self.f_anchor = t;
        Ok(())
    }

    /// Whether the torques have derivatives of order 2 or 3
    /// ([`GearTrain::set_torque_derivatives`]).
    pub(crate) fn cubic_torques(&self) -> bool {
        self.torque_higher != [[0.0; 2]; 2]
    }

    /// The rates of [`GearTrain::set_torque_rates`] and the time they start from.
    pub fn torque_rates(&self) -> ([f64; 2], f64) {
        (self.torque_rates, self.f_anchor)
    }

    /// The derivatives of orders 1–3 of [`GearTrain::set_torque_derivatives`] (input, load).
    pub fn torque_derivatives(&self) -> [[f64; 3]; 2] {
        let (r, h) = (self.torque_rates, self.torque_higher);
        [[r[0], h[0][0], h[0][1]], [r[1], h[1][0], h[1][1]]]
    }

    /// Input and load torque at `t` (the held torques plus their rates, if any).
    pub(crate) fn torques_at(&self, t: f64) -> (f64, f64) {
        let (t_in, t_load) = (self.inputs.input_torque, self.inputs.load_torque);
        if self.torque_rates == [0.0; 2] && !self.cubic_torques() {
            return (t_in, t_load);
        }
        let dt = t - self.f_anchor;
        if !self.cubic_torques() {
            return (
                t_in + self.torque_rates[0] * dt,
                t_load + self.torque_rates[1] * dt,
            );
        }
        let [[r_in, s_in, u_in], [r_load, s_load, u_load]] = self.torque_derivatives();
        (
            t_in + dt * (r_in + dt * (s_in / 2.0 + dt * u_in / 6.0)),
            t_load + dt * (r_load + dt * (s_load / 2.0 + dt * u_load / 6.0)),
        )
    }

    /// The scene's profiles, if any.
    pub fn profiles(&self) -> Option<&crate::scene::Profiles> {
        self.profiles.as_deref()
    }

    /// Why this run-up is not piecewise LTI ([`crate::scene::Profiles::not_lti_reason`]).
    pub fn runup_not_lti(&self) -> Option<String> {
        let ste = self.meshes.iter().any(|m| m.ste.harmonics() > 0);
        let ramp = self.meshes.iter().any(|m| m.ramp);
        self.profiles.as_ref()?.not_lti_reason(ste, ramp)
    }

    fn build_names(&mut self, scene: &Scene) -> Vec<String> {
        let mut names = Vec::new();
        for (n, m) in scene.meshes.iter().enumerate() {
            for q in [
                "dte",
                "dte_rate",
                "deflection",
                "force",
                "contact_state",
                "pairs_in_contact",
                "phase",
                "stiffness",
                "contact_loss_fraction",
            ] {
                names.push(format!("{}.{q}", m.name));
            }
            let per_pair = matches!(
                m.force,
                MeshForceModel::Pairs {
                    model: PairModel::PerPair,
                    ..
                }
            );
            let slots = if per_pair { self.meshes[n].slots() } else { 0 };
            for j in 0..slots {
                names.push(format!("{}.pair{j}.force", m.name));
            }
            if self.meshes[n].friction.is_some() {
                names.push(format!("{}.friction_force", m.name));
            }
            self.pair_outputs.push(slots);
        }
        for (_, label) in &self.scene_translations {
            names.push(label.clone());
        }
        names
    }

    /// Output names in [`GearTrain::outputs`] order.
    pub fn output_names(&self) -> &[String] {
        &self.names
    }

    pub fn mesh_count(&self) -> usize {
        self.meshes.len()
    }

    /// Each gear's name, teeth and rotation frequency at the current input speed, Hz.
    pub fn gear_rotations(&self) -> Vec<(String, u32, f64)> {
        let f_in = self.inputs.input_speed / std::f64::consts::TAU;
        self.gears
            .iter()
            .map(|(name, z, r)| (name.clone(), *z, (r * f_in).abs()))
            .collect()
    }

    /// Name of mesh n (the owner of its output columns, `<mesh>.dte`).
    pub fn mesh_name(&self, n: usize) -> &str {
        &self.mesh_names[n]
    }

    /// Whether every mesh force is linear in the state: linear contact law (no contact loss,
    /// no backlash) on every mesh.
    pub fn is_linear_law(&self) -> bool {
        self.meshes
            .iter()
            .all(|m| matches!(m.contact, ContactLaw::Linear))
    }

    /// Static mesh forces under the current torques, N: reacted through the meshes alone as in
    /// Liu 2007 eq. (2.8) (`F = T_1/r_1` for the first mesh), or with the ground couplings when
    /// the meshes alone cannot balance the torques.
    pub fn static_forces(&self) -> Vec<f64> {
        let (t_in, t_load) = (self.inputs.input_torque, self.inputs.load_torque);
        equilibrium(&self.asm, t_in, t_load, false)
            .or_else(|_| equilibrium(&self.asm, t_in, t_load, true))
            .map(|st| st.mesh_force)
            .unwrap_or_else(|_| vec![f64::NAN; self.meshes.len()])
    }

    /// The largest |ξ| of the mean-stiffness static solution `K̄ ξ = F̂`, or the largest
    /// clearance when that is larger (unloaded trains), at least 1e-9 m: the displacement
    /// scale of periodicity residuals.
    pub fn static_coordinate_scale(&self) -> f64 {
        let m = self.m;
        let mut k = DMatrix::from_row_slice(m, m, &self.k_b);
        for mesh in &self.meshes {
            let a = DVector::from_column_slice(&mesh.a);
            k += mesh.k_mean * &a * a.transpose();
        }
        let rhs = DVector::from_column_slice(&self.f_ext);
        let xi = k.lu().solve(&rhs).map_or(0.0, |x| x.amax());
        let clearance = self
            .meshes
            .iter()
            .map(|mesh| mesh.clearance())
            .fold(0.0, f64::max);
        xi.max(clearance).max(1e-9)
    }

    /// Number of elastic coordinates `m` (the state has `2m` entries).
    pub fn elastic_dim(&self) -> usize {
        self.m
    }

    pub fn assembly(&self) -> &Assembly {
        &self.asm
    }

    /// `Q` of the split `q = Q ξ + R η`.
    pub fn reduction_matrix(&self) -> &DMatrix<f64> {
        &self.q
    }

    /// The reduced mass matrix `M̂ = QᵀMQ` (row-major, `m × m`).
    pub fn reduced_mass(&self) -> DMatrix<f64> {
        DMatrix::from_row_slice(self.m, self.m, &self.m_hat)
    }

    /// Mesh deflection row `a_n` over ξ.
    pub fn mesh_row(&self, n: usize) -> &[f64] {
        &self.meshes[n].a
    }

    pub fn inputs(&self) -> TrainInputs {
        self.inputs
    }

    /// Whether the rigid-body rotation is carried (a scene with `[[port]]`, `docs/ports.md`).
    pub fn carries_rotation(&self) -> bool {
        self.rotation.is_some()
    }

    /// The neighbour's motion at the speed port on `end` (`None`: no speed port there).
    pub fn neighbour(&self, end: crate::scene::train::PortEnd) -> Option<Neighbour> {
        self.rotation.as_ref()?.neighbour(end)
    }

    /// Sets the neighbour's motion at the speed port on `end`; an error if there is none.
    pub fn set_neighbour(
        &mut self,
        end: crate::scene::train::PortEnd,
        motion: Neighbour,
    ) -> Result<(), String> {
        let values = [
            motion.angle,
            motion.speed,
            motion.angle_rate,
            motion.speed_rate,
        ];
        if let Some(x) = values.iter().find(|x| !x.is_finite()) {
            return Err(format!("neighbour motion {x} is not finite"));
        }
        let set = (self.rotation.as_mut()).is_some_and(|r| r.set_neighbour(end, motion));
        if set {
            Ok(())
        } else {
            Err(format!("no speed port on the {end:?} gear"))
        }
    }

    /// `d/dt` of a speed port's `<port>.torque` output at `(t, y)`; `None` for other names.
    pub fn port_torque_rate(&self, name: &str, t: f64, y: &[f64]) -> Option<f64> {
        let rot = self.rotation.as_ref()?;
        // The name first: the state derivative below is not needed for any other output (a
        // host reads every output's derivative at every communication step).
        if !rot.is_port_torque(name) {
            return None;
        }
        let mut dy = vec![0.0; y.len()];
        self.rhs(t, y, &mut dy);
        rot.port_torque_rate(name, t, y, &dy)
    }

    /// A speed port's `<port>.torque` output at `(t, y)` on its own, without the other
    /// outputs (the same value as in [`Self::outputs`]); `None` if `name` is not one.
    pub fn port_torque(&self, name: &str, t: f64, y: &[f64]) -> Option<f64> {
        self.rotation.as_ref()?.port_torque(name, t, y)
    }

    /// Whether `name` is a speed port's `<port>.torque` output ([`Self::port_torque_rate`]).
    pub fn is_port_torque(&self, name: &str) -> bool {
        self.rotation
            .as_ref()
            .is_some_and(|rot| rot.is_port_torque(name))
    }

    /// The state derivative at `(t, y)` (the right-hand side), for
    /// [`Self::port_torque_rate_with`].
    pub fn state_derivative(&self, t: f64, y: &[f64]) -> Vec<f64> {
        let mut dy = vec![0.0; y.len()];
        self.rhs(t, y, &mut dy);
        dy
    }

    /// [`Self::port_torque_rate`] with the state derivative `dy` at `(t, y)` given, so that
    /// several ports' rates share one evaluation of it.
    pub fn port_torque_rate_with(&self, name: &str, t: f64, y: &[f64], dy: &[f64]) -> Option<f64> {
        self.rotation.as_ref()?.port_torque_rate(name, t, y, dy)
    }

    /// Whether a torque port sits on the output gear: its port torque is `−load_torque`.
    pub fn has_output_port(&self) -> bool {
        self.rotation.as_ref().is_some_and(|r| r.output_port())
    }

    /// Rigid-body accelerations `η''` (M-normalised rigid coordinates) of unbalanced torques;
    /// empty for a grounded train. They do not enter the elastic motion.
    pub fn rigid_body_acceleration(&self) -> Vec<f64> {
        self.rigid_in
            .iter()
            .zip(&self.rigid_out)
            .map(|(a, b)| a * self.inputs.input_torque + b * self.inputs.load_torque)
            .collect()
    }

    /// Sets new inputs at `t`: phases stay continuous, frequencies change from `t` on.
    pub fn set_inputs(&mut self, t: f64, inputs: TrainInputs) -> Result<(), String> {
        self.apply_inputs(t, inputs)
    }

    fn apply_inputs(&mut self, t: f64, inputs: TrainInputs) -> Result<(), String> {
        if let Some(frame) = &self.asm.frame {
            if inputs.input_speed != frame.input_speed {
                return Err(format!(
                    "operating.input_speed = {} rad/s: the gyroscopic terms of the carrier \
                     frame (gyroscopic = true) were assembled at {} rad/s and are not \
                     reassembled when the speed changes (sweeps, continuation in speed, a \
                     speed input); run one scene per speed (docs/planetary.md, \
                     \"Gyroscopic terms\")",
                    inputs.input_speed, frame.input_speed
                ));
            }
        }
        // Before anything changes: every mesh frequency within the range the propagators
        // can square (an input_speed of 1e308 rad/s made it infinite and the outputs NaN).
        for (n, mesh) in self.meshes.iter().enumerate() {
            let rate = mesh.cycles_per_rev * inputs.input_speed;
            if !(rate <= crate::model::MAX_RATE) {
                return Err(format!(
                    "operating.input_speed = {:?} rad/s gives mesh {n} a mesh rate of {rate:e} 1/s, \
                     beyond {:e} 1/s (the propagators square it)",
                    inputs.input_speed,
                    crate::model::MAX_RATE
                ));
            }
        }
        let torque_changed = inputs.input_torque != self.inputs.input_torque
            || inputs.load_torque != self.inputs.load_torque
            || t == 0.0;
        self.inputs = inputs;
        for mesh in &mut self.meshes {
            let f = mesh.cycles_per_rev * inputs.input_speed / TAU;
            mesh.clock.reanchor(t, f);
        }
        for i in 0..self.m {
            self.f_ext[i] = self.external_force(i, inputs.input_torque, inputs.load_torque);
        }
        if torque_changed && self.meshes.iter().any(|m| m.model2.is_some()) {
            // Model-2 excitation: the loaded STE at the static mesh force (mean removed),
            // eq. (2.10); it depends on the load, so it is rebuilt when the torques change.
            let st = equilibrium(&self.asm, inputs.input_torque, inputs.load_torque, false)
                .or_else(|_| equilibrium(&self.asm, inputs.input_torque, inputs.load_torque, true))
                .map_err(|e| format!("Model-2 (loaded_ste) needs a static load: {e}"))?;
            for (n, mesh) in self.meshes.iter_mut().enumerate() {
                if let Some(pairs) = &mesh.model2 {
                    let table = loaded_ste_table(pairs, st.mesh_force[n], mesh.k_mean);
                    mesh.stiffness = Stiffness::Table(table);
                    mesh.flags.resize(1, SlotContact::Drive);
                    mesh.locate(t);
                }
            }
        }
        Ok(())
    }

    /// Elastic coordinate i of the external force `F̂` under the input and load torques.
    fn external_force(&self, i: usize, t_in: f64, t_load: f64) -> f64 {
        match self.pair_form {
            // F̂ = m_e (d_in T_in/J_in + d_out T_out/J_out), T_out = −T_load (docs/model.md).
            Some([(d_in, j_in), (d_out, j_out)]) if i == 0 => {
                self.m_hat[0] * (d_in * t_in / j_in + d_out * -t_load / j_out)
            }
            _ => self.f_in[i] * t_in + self.f_out[i] * t_load,
        }
    }

    /// Whether every segment is LTI in the augmented state (exact propagator).
    pub fn is_piecewise_lti(&self) -> bool {
        self.not_lti_reason().is_none()
    }

    /// Why a segment is not LTI in the augmented state (the first mesh that makes it so), or
    /// `None`. There is no limit on the number of meshes or contact states: the mode key has
    /// any length ([`crate::solve::exact::ModeKey`]).
    pub fn not_lti_reason(&self) -> Option<String> {
        if let Some(rot) = &self.rotation {
            if let Some(reason) = rot.not_lti_reason() {
                return Some(reason);
            }
        }
        for (m, name) in self.meshes.iter().zip(&self.mesh_names) {
            if self.rotation.is_some() && m.ste.harmonics() > 0 {
                return Some(format!(
                    "mesh '{name}' has an STE e(p) ([mesh.ste] harmonics), and with [[port]] or \
                     elements the rotation is carried: the phase p follows the pinion angle, a \
                     state, and cos 2πhp is not linear in the state (docs/ports.md, \"What stays \
                     piecewise-LTI\")"
                ));
            }
            // Friction arms move with the phase: the friction moment is not piecewise constant.
            if m.friction.is_some() {
                return Some(format!(
                    "mesh '{name}' has Coulomb tooth friction, whose moment arm moves with the \
                     mesh phase within a segment"
                ));
            }
            // Runout adds harmonics of the shaft frequencies and pitch errors steps at the
            // tooth boundaries; the augmented state carries neither (`docs/errors.md`).
            if !m.errors.is_empty() {
                return Some(format!(
                    "gear runout and pitch errors on mesh '{name}' add shaft-order harmonics \
                     and tooth steps to the STE, which the exact propagator's augmented state \
                     does not carry"
                ));
            }
            match &m.stiffness {
                Stiffness::Table(t) if t.stiffness_piecewise_constant() => {}
                Stiffness::Table(_) => {
                    return Some(format!(
                        "mesh '{name}' has a stiffness that varies within its pieces (sloped \
                         pieces, e.g. trapezoidal, a load share or a tabulated pair), not a \
                         piecewise-constant one"
                    ))
                }
                Stiffness::Smooth { .. } => {
                    return Some(format!(
                        "mesh '{name}' has a smooth (Fourier or geometry) stiffness, not a \
                         piecewise-constant one"
                    ))
                }
            }
        }
        None
    }

    /// The scene's initial state `[ξ0, ξ0']`; also sets the contact flags to match it.
    pub fn initial_state(&mut self, scene: &Scene) -> Result<Vec<f64>, String> {
        let m = self.m;
        let mut y = vec![0.0; 2 * m];
        match scene.initial_dte {
            InitialDte::Value(x) => {
                if m != 1 {
                    return Err(format!(
                        "initial.dte = {x}: a number is only allowed for a train with one elastic \
                         coordinate (this one has {m}); use \"static\""
                    ));
                }
                y[0] = x / self.meshes[0].a[0];
            }
            InitialDte::Static => {
                // K̄ ξ = F̂ + Σ k̄_n a_n e_n(p0): mean stiffness, excitation at the start phase.
                let mut k = DMatrix::from_row_slice(m, m, &self.k_b);
                let mut rhs = DVector::from_column_slice(&self.f_ext);
                let nominal = equilibrium(
                    &self.asm,
                    self.inputs.input_torque,
                    self.inputs.load_torque,
                    false,
                )
                .ok();
                let mut e0s = Vec::with_capacity(self.meshes.len());
                for (n, mesh) in self.meshes.iter().enumerate() {
                    let a = DVector::from_column_slice(&mesh.a);
                    k += mesh.k_mean * &a * a.transpose();
                    let p0 = mesh.clock.phase_at(0.0);
                    let mut e0 = mesh.ste_free(p0).0;
                    if let Some(tb) = mesh.table() {
                        let s0 = crate::mesh::cycle_fraction(p0 + mesh.offset);
                        if tb.slots > 1 {
                            let f = nominal.as_ref().map_or(0.0, |st| st.mesh_force[n]);
                            e0 += loaded_ste(tb, f).value(s0) - f / mesh.k_mean;
                        } else {
                            let iv = &tb.intervals[tb.interval_at(s0)];
                            e0 += iv.laws[0].map_or(0.0, |l| l.g(s0 - iv.start));
                        }
                    }
                    rhs += mesh.k_mean * e0 * a;
                    e0s.push(e0);
                }
                if m == 1 && self.meshes.len() == 1 {
                    // One coordinate: ξ0 = F̂/K̄ + e0·(k̄a/K̄), which for the single pair is
                    // `F_ext/k̄ + e(p0)` of docs/model.md, formed in the same order.
                    let mesh = &self.meshes[0];
                    let kk = k[(0, 0)];
                    let e0 = e0s[0];
                    y[0] = self.f_ext[0] / kk + e0 * (mesh.k_mean * mesh.a[0] / kk);
                } else {
                    let xi = match &self.free_statics {
                        Some(statics) => {
                            let mut f = self
                                .asm
                                .load(self.inputs.input_torque, self.inputs.load_torque);
                            for (d, (mesh, e0)) in
                                self.asm.mesh.iter().zip(self.meshes.iter().zip(&e0s))
                            {
                                f += mesh.k_mean * e0 * d;
                            }
                            statics.solve(&f)
                        }
                        None => k.lu().solve(&rhs),
                    }
                    .ok_or("the mean stiffness matrix is singular")?;
                    y[..m].copy_from_slice(xi.as_slice());
                }
            }
        }
        if scene.initial_dte_rate != 0.0 {
            if m != 1 {
                return Err(format!(
                    "initial.dte_rate = {}: only allowed for a train with one elastic coordinate",
                    scene.initial_dte_rate
                ));
            }
            y[1] = scene.initial_dte_rate / self.meshes[0].a[0];
        }
        if let Some(rot) = &mut self.rotation {
            let start: Vec<_> = (scene.ports.iter())
                .map(|p| {
                    let c = p.coupling.as_ref();
                    (p.torque, c.and_then(|c| c.speed), c.and_then(|c| c.angle))
                })
                .collect();
            y = rot.initial_state(&y, &start);
        }
        self.resynchronise(0.0, &y);
        Ok(y)
    }

    /// Re-derives the discrete mode (intervals, contact flags) from a state at `t`.
    pub fn resynchronise(&mut self, t: f64, y: &[f64]) {
        for n in 0..self.meshes.len() {
            match &self.rotation {
                None => self.meshes[n].locate(t),
                Some(rot) => {
                    let p = rot.mesh_phase(n, t, y).0;
                    self.meshes[n].locate_phase(p);
                }
            }
            let slots = self.meshes[n].slots();
            for j in 0..slots {
                self.meshes[n].flags[j] = self.classify(n, j, t, y);
            }
        }
        self.loss_start = t;
        self.loss = (0..self.meshes.len())
            .map(|n| (0.0, self.totally_lost(n).then_some(t)))
            .collect();
        self.refresh_guards();
    }
}
