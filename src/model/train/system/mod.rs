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

use super::assembly::{generalized_eigen, Assembly, DofKind, Reduction};
use super::friction::FrictionTable;
use super::mesh::{CycleTable, Interval, SlotLaw};
use super::statics::{equilibrium, loaded_ste, Ste};
use crate::mesh::errors::{GearInMesh, MeshErrors};
use crate::mesh::{MeshStiffness, PhaseSeries};
use crate::model::PhaseClock;
use crate::scene::train::{MeshForceModel, PairModel, TrainScene};
use crate::scene::{ContactLaw, InitialDte};
use crate::solve::exact::PiecewiseLti;
use crate::solve::HybridSystem;
use jacobian::JacobianParts;

mod friction;
mod frozen;
mod harmonic;
mod jacobian;
pub(crate) mod rotating;
mod snapshot;
pub use frozen::FrozenStatics;
pub use rotating::Neighbour;
pub use snapshot::{MeshRunState, TrainRunState};

/// Contact flag of one tooth-pair slot.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SlotContact {
    /// The slot's pair is not engaged (outside its window).
    Inactive = 3,
    Drive = 1,
    Separated = 0,
    Back = 2,
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
    dte: Vec<f64>,
    clock: PhaseClock,
    cycles_per_rev: f64,
    stiffness: Stiffness,
    /// `s = frac(p + offset)`: the lumped source's phase shift, 0 for pair tables.
    offset: f64,
    ste: PhaseSeries,
    /// Runout and pitch errors of the mesh's gears (`docs/errors.md`).
    errors: MeshErrors,
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

impl MeshRt {
    fn clearance(&self) -> f64 {
        match self.contact {
            ContactLaw::Backlash { clearance } => clearance,
            _ => 0.0,
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

    /// `r = s − interval start` at phase `p`.
    fn local(&self, p: f64) -> f64 {
        let start = self.current().map_or(0.0, |iv| iv.start);
        (p + self.offset - self.cycle) - start
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
            } => mean + series.value(p + phase),
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
        self.ste_in_cycle(p, (p + self.offset).floor())
    }

    fn ste_in_cycle(&self, p: f64, cycle: f64) -> (f64, f64) {
        let (e, slope) = self.ste.value_and_slope(p);
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
                self.clock.time_of(end - self.offset)
            }
            None if steps => self.clock.time_of(self.cycle + 1.0 - self.offset),
            _ => f64::INFINITY,
        }
    }
}

/// One guard: mesh, slot and which surface.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Surface {
    /// In drive contact: `δ >= 0`.
    Drive,
    /// Separated, watching the drive side: `−δ >= 0`.
    SepDrive,
    /// Separated, watching the back side: `δ + 2b >= 0`.
    SepBack,
    /// In back contact: `−(δ + 2b) >= 0`.
    Back,
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
    pub fn new(scene: &TrainScene) -> Result<GearTrain, String> {
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
        let mut k_mean = k_b.clone();
        let a_vecs: Vec<DVector<f64>> = asm.mesh.iter().map(|d| q.transpose() * d).collect();
        for (a, &k) in a_vecs.iter().zip(&asm.mean_stiffness) {
            k_mean += k * a * a.transpose();
        }
        let zeta = scene.modal_damping_ratio;
        if zeta > 0.0 {
            // Modal damping on the mean-stiffness modes: C = M̂ Φ diag(2ζω) Φᵀ M̂ with Φ
            // mass-normalised (Liu 2007 eq. 2.14, ζ = εμ/2); rigid modes are already removed.
            let (w2, phi) = generalized_eigen(&k_mean, &mass);
            let diag = DMatrix::from_diagonal(&DVector::from_iterator(
                m,
                w2.iter().map(|&w| 2.0 * zeta * w.max(0.0).sqrt()),
            ));
            c += &mass * &phi * diag * phi.transpose() * &mass;
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
            meshes.push(MeshRt {
                a: a_vecs[n].as_slice().to_vec(),
                dte: (q.transpose() * &asm.dte[n]).as_slice().to_vec(),
                clock: PhaseClock::new(0.0, p0, 0.0),
                cycles_per_rev: sm.cycles_per_input_rev,
                stiffness,
                offset,
                ste,
                errors,
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
            f_in: f_in.as_slice().to_vec(),
            f_out: f_out.as_slice().to_vec(),
            f_ext: vec![0.0; m],
            f_rate: vec![0.0; m],
            force_ramp: false,
            f_anchor: 0.0,
            torque_rates: [0.0; 2],
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
        train.jacobian_parts = JacobianParts::new(
            m,
            &minv,
            &train.k_b,
            &train.c,
            train.meshes.iter().map(|mesh| mesh.a.as_slice()),
        );
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
        for i in 0..self.m {
            self.f_rate[i] = self.f_in[i] * torque_rate + self.f_out[i] * load_rate;
        }
        if let Some([(d_in, j_in), (d_out, j_out)]) = self.pair_form {
            self.f_rate[0] =
                self.m_hat[0] * (d_in * torque_rate / j_in + d_out * -load_rate / j_out);
        }
    }

    /// First-order rates `[input, load]` (N·m/s) of the torques from `t` on: the right-hand
    /// side reads `T + T'·(τ − t)`, elastic and rigid part alike (FMI 2.0.x §4.2.1
    /// `fmi2SetRealInputDerivatives`, used by the drivetrain FMU with torque ports). Rates
    /// `[0, 0]` restore held torques. Not with torque profiles, which own the force ramp.
    pub fn set_torque_rates(&mut self, t: f64, rates: [f64; 2]) -> Result<(), String> {
        if self.profiles.is_some() {
            return Err("torque rates cannot be combined with [profile] run-ups".into());
        }
        if let Some(r) = rates.iter().find(|r| !r.is_finite()) {
            return Err(format!("torque rate {r} is not finite"));
        }
        self.torque_rates = rates;
        self.set_force_rate(rates[0], rates[1]);
        self.force_ramp = rates != [0.0; 2];
        self.f_anchor = t;
        Ok(())
    }

    /// The rates of [`GearTrain::set_torque_rates`] and the time they start from.
    pub fn torque_rates(&self) -> ([f64; 2], f64) {
        (self.torque_rates, self.f_anchor)
    }

    /// Input and load torque at `t` (the held torques plus their rates, if any).
    pub(crate) fn torques_at(&self, t: f64) -> (f64, f64) {
        let (t_in, t_load) = (self.inputs.input_torque, self.inputs.load_torque);
        if self.torque_rates == [0.0; 2] {
            return (t_in, t_load);
        }
        let dt = t - self.f_anchor;
        (
            t_in + self.torque_rates[0] * dt,
            t_load + self.torque_rates[1] * dt,
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

    fn build_names(&mut self, scene: &TrainScene) -> Vec<String> {
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
        let mut dy = vec![0.0; y.len()];
        self.rhs(t, y, &mut dy);
        rot.port_torque_rate(name, t, y, &dy)
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
    pub fn initial_state(&mut self, scene: &TrainScene) -> Result<Vec<f64>, String> {
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
                    let xi = k
                        .lu()
                        .solve(&rhs)
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

    /// Whether mesh n has lost contact on every pair.
    fn totally_lost(&self, n: usize) -> bool {
        !self.meshes[n]
            .flags
            .iter()
            .any(|f| matches!(f, SlotContact::Drive | SlotContact::Back))
    }

    /// Books a possible change of mesh n's total contact loss at `t`.
    fn book_loss(&mut self, n: usize, t: f64) {
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
    fn slot_gap(&self, n: usize, j: usize, t: f64, y: &[f64]) -> Option<(f64, f64, SlotLaw)> {
        let mesh = &self.meshes[n];
        let law = mesh.law(j)?;
        let (p, f) = self.phase_and_rate(n, t, y);
        let (e, slope) = mesh.ste_at(p);
        let (s, sd) = self.deflection(n, y);
        let r = mesh.local(p);
        Some((s - e - law.g(r), sd - slope * f - law.g1 * f, law))
    }

    fn classify(&self, n: usize, j: usize, t: f64, y: &[f64]) -> SlotContact {
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
            ContactLaw::Backlash { clearance } => {
                let back = delta + clearance;
                if delta > 0.0 || (delta == 0.0 && rate > 0.0) {
                    SlotContact::Drive
                } else if back < 0.0 || (back == 0.0 && rate < 0.0) {
                    SlotContact::Back
                } else {
                    SlotContact::Separated
                }
            }
        }
    }

    fn refresh_guards(&mut self) {
        self.guards.clear();
        for (n, mesh) in self.meshes.iter().enumerate() {
            if mesh.contact == ContactLaw::Linear {
                continue;
            }
            let backlash = matches!(mesh.contact, ContactLaw::Backlash { .. });
            for (j, flag) in mesh.flags.iter().enumerate() {
                match flag {
                    SlotContact::Inactive => {}
                    SlotContact::Drive => self.guards.push((n, j, Surface::Drive)),
                    SlotContact::Separated => {
                        self.guards.push((n, j, Surface::SepDrive));
                        if backlash {
                            self.guards.push((n, j, Surface::SepBack));
                        }
                    }
                    SlotContact::Back => self.guards.push((n, j, Surface::Back)),
                }
            }
        }
    }

    fn deflection(&self, n: usize, y: &[f64]) -> (f64, f64) {
        let a = &self.meshes[n].a;
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
    fn mesh_force(&self, n: usize, t: f64, y: &[f64], slots: Option<&mut [f64]>) -> f64 {
        self.mesh_force_at(n, self.phase_and_rate(n, t, y), y, slots)
    }

    /// Mesh phase (cycles) and its rate (1/s) of mesh n at `(t, y)`: from the mesh clock in
    /// the nominal-speed form, from the carried pinion angle with ports (`docs/ports.md`).
    fn phase_and_rate(&self, n: usize, t: f64, y: &[f64]) -> (f64, f64) {
        match &self.rotation {
            None => self.meshes[n].clock.phase_and_frequency(t),
            Some(rot) => rot.mesh_phase(n, t, y),
        }
    }

    /// Mesh phase of mesh n at `(t, y)` (see [`GearTrain::phase_and_rate`]).
    fn phase_of(&self, n: usize, t: f64, y: &[f64]) -> f64 {
        match &self.rotation {
            None => self.meshes[n].clock.phase_at(t),
            Some(rot) => rot.mesh_phase(n, t, y).0,
        }
    }

    /// Force of mesh n in the current mode at mesh phase `p` with phase rate `f` (cycles/s):
    /// the one force routine of both the nominal-speed form and the carried rotation.
    fn mesh_force_at(
        &self,
        n: usize,
        (p, f): (f64, f64),
        y: &[f64],
        mut slots: Option<&mut [f64]>,
    ) -> f64 {
        let mesh = &self.meshes[n];
        let (e, e_slope) = mesh.ste_at(p);
        let (s, sd) = self.deflection(n, y);
        let r = mesh.local(p);
        let clearance = mesh.clearance();
        let mut force = 0.0;
        let mut touching = false;
        for (j, flag) in mesh.flags.iter().enumerate() {
            let offset = match flag {
                SlotContact::Inactive | SlotContact::Separated => {
                    if let Some(out) = slots.as_deref_mut() {
                        out[j] = 0.0;
                    }
                    continue;
                }
                SlotContact::Drive => 0.0,
                SlotContact::Back => clearance,
            };
            let law = mesh.law(j).expect("a slot in contact is engaged");
            let delta = s - e - law.g(r);
            let fj = mesh.k(j, p, &law) * (delta + offset);
            if let Some(out) = slots.as_deref_mut() {
                out[j] = fj;
            }
            force += fj;
            touching = true;
        }
        if touching && mesh.damping != 0.0 {
            // The damper acts on Ṡ − ė, never on the rate of a gap: Models 2 and 3 put the
            // loaded STE / NLTE into the gap and damp the velocities only (eqs. 2.10, 2.11:
            // `C U̇`), like Model-1's tooth pairs.
            force += mesh.damping * (sd - e_slope * f);
        }
        force
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
            in_contact: mesh
                .flags
                .iter()
                .filter(|f| matches!(f, SlotContact::Drive | SlotContact::Back))
                .count(),
            any_back: mesh.flags.contains(&SlotContact::Back),
            phase: crate::mesh::cycle_fraction(p),
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
            .fold(0.0, f64::max);
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
            fastest_rate: if !(damping_rate <= self.max_frequency()) {
                (
                    damping_rate,
                    "the damping on the masses: mesh damping, bearing damping, modal damping ratio",
                )
            } else {
                (
                    self.max_frequency(),
                    "the mesh and bearing stiffnesses on the masses (or the STE harmonics)",
                )
            },
        }
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
            let state = if st.in_contact == 0 {
                0.0
            } else if st.any_back && !self.meshes[n].flags.contains(&SlotContact::Drive) {
                -1.0
            } else {
                1.0
            };
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

    fn on_mesh_stop(&mut self, n: usize, t: f64, y: &[f64]) {
        let mesh = &mut self.meshes[n];
        let steps = mesh.errors.has_steps();
        let Stiffness::Table(table) = &mesh.stiffness else {
            // A smooth stiffness stops only at the pitch-error steps.
            mesh.cycle += 1.0;
            self.reclassify_engaged(n, t, y);
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
                (true, SlotContact::Inactive) => self.classify(n, j, t, y),
                (true, f) => f,
            };
        }
        if wrapped && steps {
            self.reclassify_engaged(n, t, y);
        }
    }

    /// After a pitch-error step of the STE every engaged slot's gap jumped: its contact is
    /// decided afresh from the state.
    fn reclassify_engaged(&mut self, n: usize, t: f64, y: &[f64]) {
        for j in 0..self.meshes[n].flags.len() {
            if self.meshes[n].flags[j] != SlotContact::Inactive {
                self.meshes[n].flags[j] = self.classify(n, j, t, y);
            }
        }
    }
}

/// The errors of mesh `n`'s two gears as the mesh sees them (`docs/errors.md`): the line of
/// action `β_n = centre_angle + σ_a·pressure_angle` of the assembly, and per gear the teeth
/// between this mesh and the gear's first mesh, `k = round(σ_g z (α_n − α_1)/2π)` with `α` the
/// direction from the gear's centre to its mate (teeth numbered against the rotation, so the
/// tooth at a mesh further along the rotation sense has a lower number).
fn mesh_errors(scene: &TrainScene, n: usize, p0: f64, offset: f64) -> MeshErrors {
    let sm = &scene.meshes[n];
    let beta = sm.centre_angle + scene.rotation[sm.pinion] * sm.pressure_angle;
    let towards_mate = |g: usize, m: &crate::scene::train::TrainMesh| {
        if m.pinion == g {
            m.centre_angle
        } else {
            m.centre_angle + std::f64::consts::PI
        }
    };
    let gear = |g: usize, side: f64| {
        let first = scene
            .meshes
            .iter()
            .find(|m| m.pinion == g || m.gear == g)
            .expect("the gear takes part in mesh n");
        let z = scene.gears[g].teeth;
        let turn =
            scene.rotation[g] * f64::from(z) * (towards_mate(g, sm) - towards_mate(g, first)) / TAU;
        GearInMesh {
            errors: &scene.gears[g].errors,
            teeth: z,
            side,
            sense: scene.rotation[g],
            line_of_action: beta,
            tooth_offset: turn.round() as i64,
        }
    };
    MeshErrors::new(&[gear(sm.pinion, 1.0), gear(sm.gear, -1.0)], p0, offset)
}

/// The nominal motion per rad/s of input speed in the physical coordinates (`u_b = ρ_b θ_b`,
/// translations 0): rolling without slip on the base circles, `d_n·v = 0` for every mesh (so
/// the nominal motion deflects no mesh even where tabulated radii and tooth counts differ in
/// the last digits), and coaxial gears on an elastic shaft turning together. Parts the input
/// does not drive stand still.
fn nominal_rotation(scene: &TrainScene, asm: &Assembly) -> DVector<f64> {
    let bodies = asm.body_radius.len();
    let mut omega: Vec<Option<f64>> = vec![None; bodies];
    omega[asm.body_of[scene.input_gear]] = Some(1.0);
    let mut changed = true;
    while changed {
        changed = false;
        for (n, m) in scene.meshes.iter().enumerate() {
            let (a, b) = (asm.body_of[m.pinion], asm.body_of[m.gear]);
            // d_n·v = 0 on the two rotations: c_a ρ_a ω_a + c_b ρ_b ω_b = 0.
            let ca = asm.mesh[n][asm.body_dof[a]] * asm.body_radius[a];
            let cb = asm.mesh[n][asm.body_dof[b]] * asm.body_radius[b];
            match (omega[a], omega[b]) {
                (Some(wa), None) => {
                    omega[b] = Some(-ca * wa / cb);
                    changed = true;
                }
                (None, Some(wb)) => {
                    omega[a] = Some(-cb * wb / ca);
                    changed = true;
                }
                _ => {}
            }
        }
        for s in &scene.shafts {
            let (a, b) = (asm.body_of[s.gears[0]], asm.body_of[s.gears[1]]);
            match (omega[a], omega[b]) {
                (Some(w), None) => {
                    omega[b] = Some(w);
                    changed = true;
                }
                (None, Some(w)) => {
                    omega[a] = Some(w);
                    changed = true;
                }
                _ => {}
            }
        }
    }
    let mut v = DVector::zeros(asm.dim());
    for (body, w) in omega.iter().enumerate() {
        v[asm.body_dof[body]] = asm.body_radius[body] * w.unwrap_or(0.0);
    }
    v
}

/// The closed form of a free single pair: one mesh, two rotating bodies (the input and the
/// output), nothing else. Returns `(d_θ, J)` per body, `d_θ = ±r_b` the mesh vector in
/// rotation angle and `J` the body inertia.
fn pair_closed_form(
    scene: &TrainScene,
    asm: &Assembly,
    m: usize,
    rigid: usize,
) -> Option<[(f64, f64); 2]> {
    let single = m == 1
        && rigid == 1
        && asm.dim() == 2
        && scene.meshes.len() == 1
        && asm.k_base.iter().all(|&v| v == 0.0)
        && asm
            .dofs
            .iter()
            .all(|d| matches!(d, DofKind::Rotation { .. }));
    if !single {
        return None;
    }
    let mesh = &scene.meshes[0];
    let body = |g: usize| -> (f64, f64) {
        let b = asm.body_of[g];
        let j: f64 = (0..scene.gears.len())
            .filter(|&k| asm.body_of[k] == b)
            .map(|k| scene.gears[k].inertia)
            .sum();
        let r = scene.gears[g].base_radius;
        let d = if g == mesh.pinion { r } else { -r };
        (d, j)
    };
    let (i, o) = (scene.input_gear, scene.output_gear);
    let on_mesh = |g: usize| g == mesh.pinion || g == mesh.gear;
    (on_mesh(i) && on_mesh(o) && asm.body_of[i] != asm.body_of[o]).then(|| [body(i), body(o)])
}

/// Model-3 table: one slot with the total engaged stiffness and the NLTE as gap (eq. 2.11).
fn nlte_table(pairs: &CycleTable) -> CycleTable {
    let nlte = loaded_ste(pairs, 0.0);
    single_slot_table(pairs, &nlte, |iv, r| {
        let k0: f64 = iv.laws.iter().flatten().map(|l| l.k(r)).sum();
        let k1: f64 = iv.laws.iter().flatten().map(|l| l.k1).sum();
        (k0, k1)
    })
}

/// Model-2 table: one slot with the mean stiffness and the loaded STE minus its mean as gap
/// (eq. 2.10), at the static mesh force `force`.
fn loaded_ste_table(pairs: &CycleTable, force: f64, k_mean: f64) -> CycleTable {
    let ste = loaded_ste(pairs, force);
    let mean = ste.mean();
    let shifted = Ste {
        pieces: ste
            .pieces
            .iter()
            .map(|p| super::statics::LinPiece {
                v0: p.v0 - mean,
                ..*p
            })
            .collect(),
    };
    single_slot_table(pairs, &shifted, |_, _| (k_mean, 0.0))
}

fn single_slot_table(
    pairs: &CycleTable,
    gap: &Ste,
    k: impl Fn(&Interval, f64) -> (f64, f64),
) -> CycleTable {
    let intervals = gap
        .pieces
        .iter()
        .filter(|p| p.end > p.start)
        .map(|p| {
            let iv = &pairs.intervals[pairs.interval_at(0.5 * (p.start + p.end))];
            let (k0, k1) = k(iv, p.start - iv.start);
            Interval {
                start: p.start,
                end: p.end,
                laws: vec![Some(SlotLaw {
                    k0,
                    k1,
                    g0: p.v0,
                    g1: p.slope,
                })],
            }
        })
        .collect();
    CycleTable {
        slots: 1,
        shift_on_wrap: false,
        intervals,
    }
}

/// The sign of a guard relative to the slot deflection.
fn surface_sign(surface: Surface) -> f64 {
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
        }
        for n in 0..self.meshes.len() {
            if self.meshes[n].friction.is_some() {
                self.add_friction_mesh_force(n, t, y, &mut acc);
                continue;
            }
            let force = self.mesh_force(n, t, y, None);
            let a = &self.meshes[n].a;
            for i in 0..m {
                acc[i] -= a[i] * force;
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
        let gains = self.meshes.iter().map(|mesh| {
            let p = mesh.clock.phase_at(t);
            let mut kn = 0.0;
            let mut touching = false;
            for (j, flag) in mesh.flags.iter().enumerate() {
                if matches!(flag, SlotContact::Drive | SlotContact::Back) {
                    let law = mesh.law(j).expect("a slot in contact is engaged");
                    kn += mesh.k(j, p, &law);
                    touching = true;
                }
            }
            (kn, if touching { mesh.damping } else { 0.0 })
        });
        self.jacobian_parts.fill(gains, jac);
        true
    }

    fn guards(&self, t: f64, y: &[f64], g: &mut [f64]) {
        for (slot, &(n, j, surface)) in g.iter_mut().zip(&self.guards) {
            let delta = self.slot_gap(n, j, t, y).map_or(0.0, |v| v.0);
            let back = delta + self.meshes[n].clearance();
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
        for (g, a) in grad.iter_mut().zip(&mesh.a) {
            *g = sign * a;
        }
        let (p, f) = mesh.clock.phase_and_frequency(t);
        let slope = mesh.ste_at(p).1;
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
        let rate = mesh.clock.rate();
        if rate == 0.0 {
            return Some(curvature);
        }
        let g1 = mesh.law(j).map_or(0.0, |l| l.g1);
        let slope: f64 = (mesh.ste.coefficients().iter().enumerate())
            .map(|(i, &(a, b))| TAU * (i + 1) as f64 * a.hypot(b))
            .sum::<f64>()
            + mesh.errors.slope_bound();
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

    fn on_event(&mut self, t: f64, y: &mut [f64], index: usize) {
        if index >= self.guards.len() {
            self.knot_event(t, y, index - self.guards.len());
            return;
        }
        self.switch_slot(t, None, y, index);
    }
}

impl GearTrain {
    /// The contact switch of guard `index` at an event at `t`: snaps `ξ` onto the crossed
    /// surface and switches the slot. With the lifted event state `z`, a one-DOF train reads
    /// its STE from the propagated harmonic states (as the single pair does).
    fn switch_slot(&mut self, t: f64, z: Option<&[f64]>, y: &mut [f64], index: usize) {
        let (n, j, surface) = self.guards[index];
        let clearance = self.meshes[n].clearance();
        let (level, next) = match surface {
            Surface::Drive => (0.0, SlotContact::Separated),
            Surface::SepDrive => (0.0, SlotContact::Drive),
            Surface::SepBack => (-clearance, SlotContact::Back),
            Surface::Back => (-clearance, SlotContact::Separated),
        };
        // Snap onto the surface δ = level (numerics-notes §2.1): the smallest mass-weighted
        // change of ξ that puts S_n − e_n − g_j at `level`.
        if let Some((delta, _, _)) = self.slot_gap(n, j, t, y) {
            let m = self.m;
            let a = &self.meshes[n].a;
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
    fn harmonic_base(&self) -> Vec<usize> {
        let mut base = Vec::with_capacity(self.meshes.len());
        let mut k = self.dim();
        for mesh in &self.meshes {
            base.push(k);
            k += 2 * mesh.ste.harmonics() + usize::from(self.phase_ramp(mesh));
        }
        base
    }

    /// [`GearTrain::harmonic_base`] of mesh n alone (no allocation: called at every event).
    fn forcing_base(&self, n: usize) -> usize {
        self.dim()
            + (self.meshes[..n].iter())
                .map(|k| 2 * k.ste.harmonics() + usize::from(self.phase_ramp(k)))
                .sum::<usize>()
    }

    /// Whether mesh's forcing block ends with a phase ramp `r = s − interval start`: for
    /// affine gaps in the nominal form, and always with the carried rotation, where `r` is
    /// affine in the state and carries the knot guards (`rotating::lti`).
    fn phase_ramp(&self, mesh: &MeshRt) -> bool {
        mesh.ramp || self.rotation.is_some()
    }

    /// Lifted entry of `t − f_anchor` (the time along a torque ramp of the carried rotation:
    /// the FMU's input derivatives), if the lifted state has it; the constant is after it.
    fn ramp_time_index(&self) -> Option<usize> {
        (self.rotation.is_some() && self.force_ramp).then(|| self.lti_dim() - 2)
    }

    /// Row of the slot deflection `δ_j = S − e − g_j` over the augmented state.
    fn delta_row(&self, n: usize, j: usize, base: usize, w: &mut [f64]) {
        let mesh = &self.meshes[n];
        w[..self.m].copy_from_slice(&mesh.a);
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

    fn lti_dim(&self) -> usize {
        self.dim()
            + self
                .meshes
                .iter()
                .map(|m| 2 * m.ste.harmonics() + usize::from(self.phase_ramp(m)))
                .sum::<usize>()
            + usize::from(self.rotation.is_some() && self.force_ramp)
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
            z[u] = t - self.f_anchor;
        }
        let last = z.len() - 1;
        z[last] = 1.0;
    }

    fn lti_matrix(&self, a: &mut DMatrix<f64>) {
        a.fill(0.0);
        let nz = a.nrows();
        let last = nz - 1;
        let m = self.m;
        // Generalised force rows over z (before M̂⁻¹): f_ext − K_b ξ − C ξ' − Σ a_n F_n.
        let mut force = DMatrix::<f64>::zeros(m, nz);
        let torque_rows =
            (self.rotation.as_ref()).map(|rot| rot.torque_rows(self, nz, self.ramp_time_index()));
        for i in 0..m {
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
        for (n, mesh) in self.meshes.iter().enumerate() {
            let base = bases[n];
            let omega = TAU * mesh.clock.mesh_frequency();
            let f = mesh.clock.mesh_frequency();
            row.fill(0.0);
            let mut touching = false;
            for (j, flag) in mesh.flags.iter().enumerate() {
                let offset = match flag {
                    SlotContact::Inactive | SlotContact::Separated => continue,
                    SlotContact::Drive => 0.0,
                    SlotContact::Back => mesh.clearance(),
                };
                let law = mesh.law(j).expect("engaged");
                w.fill(0.0);
                self.delta_row(n, j, base, &mut w);
                w[last] += offset;
                for (r, v) in row.iter_mut().zip(&w) {
                    *r += law.k0 * v;
                }
                touching = true;
            }
            if touching && mesh.damping != 0.0 {
                let c = mesh.damping;
                for i in 0..m {
                    row[m + i] += c * mesh.a[i];
                }
                for (i, &(ah, bh)) in mesh.ste.coefficients().iter().enumerate() {
                    let h = (i + 1) as f64;
                    // ė = Σ hω(−a_h sin + b_h cos).
                    row[base + 2 * i] -= c * h * omega * bh;
                    row[base + 2 * i + 1] += c * h * omega * ah;
                }
            }
            for i in 0..m {
                for col in 0..nz {
                    force[(i, col)] -= mesh.a[i] * row[col];
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
            }
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
        let base = self.harmonic_base()[n];
        self.delta_row(n, j, base, w);
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
            for f in &mesh.flags {
                key.push(*f as u64, 4);
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
