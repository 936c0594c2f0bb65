//! The single-mesh torsional gear pair in the DTE coordinate (`docs/model.md`).
//!
//! `m_e x'' + F(x, x', p) = F_ext` with the mesh force of the contact law, the mesh stiffness
//! `k(p)` and the static transmission error `e(p)` as functions of the mesh phase `p`.
//! Kahraman & Singh (1990, JSV 142:49–75) form with Liu (2007) conventions; the back-side
//! branch uses the corrected sign `k(δ + 2b)` (Liu 2007 eq. 2.4 erratum,
//! `models-liu-parker-2007.md` §8 item 2).
//!
//! Only the terms the scene uses are active: without contact loss there are no guards (no event
//! work); without STE the harmonic terms vanish; a constant or smooth stiffness has no stops.

mod guard_bound;
mod kernel;

use std::f64::consts::TAU;

use nalgebra::DMatrix;

use kernel::Kernel;

use super::{PhaseClock, MAX_MESH_CYCLES};

/// The largest rate (1/s) a pair may have: the propagators square their rates (the exact
/// propagator's estimate from `A²`, the `y''` of RK, the Taylor bounds of the crossing search),
/// which overflows `f64` beyond ~1.3e154 1/s; 1e150 leaves room for the sums they enter.
pub const MAX_RATE: f64 = 1e150;
use crate::mesh::{MeshStiffness, PhaseSeries};
use crate::scene::{ContactLaw, InitialDte, PairScene, SmoothTerms};
use crate::solve::exact::PiecewiseLti;
use crate::solve::HybridSystem;

/// Contact state of the mesh; the value is the `mesh.contact_state` output.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ContactState {
    Drive = 1,
    Separated = 0,
    Back = -1,
}

/// The operating inputs (FMU inputs), held constant between communication points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Inputs {
    /// Nominal pinion speed Ω, rad/s (>= 0).
    pub pinion_speed: f64,
    /// T1, N·m.
    pub input_torque: f64,
    /// T2 (magnitude, resisting the gear), N·m.
    pub load_torque: f64,
}

/// The mesh force law at one state ([`GearPair::force_law`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForceLaw {
    /// Mesh force, N.
    pub force: f64,
    /// `∂F/∂x`, N/m.
    pub stiffness: f64,
    /// `∂F/∂x'`, N·s/m.
    pub damping: f64,
    /// The part of the force proportional to the deflection rate, N.
    pub viscous: f64,
    /// The teeth are in contact (drive or back side).
    pub engaged: bool,
    /// In back-side contact.
    pub back: bool,
}

/// Output names in CSV/FMU order (`docs/model.md`, "Outputs").
pub const OUTPUT_NAMES: [&str; 7] = [
    "mesh.dte",
    "mesh.dte_rate",
    "mesh.force",
    "mesh.contact_state",
    "mesh.phase",
    "mesh.stiffness",
    "mesh.static_deflection",
];

/// The part of a [`GearPair`] that changes during a run: inputs, phase clock, stiffness
/// segment and contact state. Restoring it (instead of re-deriving the mode with
/// [`GearPair::resynchronise`]) continues a run bit-identically, also from a state sitting
/// exactly on a switching surface (FMU state get/set, FMI 2.0.x §2.1.8).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairState {
    pub inputs: Inputs,
    pub clock: PhaseClock,
    /// Stiffness cycle (integer-valued) and piece index.
    pub segment_cycle: f64,
    pub segment_piece: usize,
    pub contact: ContactState,
}

/// Position in the piecewise stiffness: `cycle` (integer-valued) and `piece` index of the
/// shifted phase `u = p + phase`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Segment {
    cycle: f64,
    piece: usize,
}

/// The gear pair as a hybrid system with state `y = [x, x']`.
#[derive(Debug, Clone)]
pub struct GearPair {
    // Parameters (fixed after assembly).
    r_b1: f64,
    r_b2: f64,
    inertia1: f64,
    inertia2: f64,
    pinion_teeth: f64,
    gear_teeth: u32,
    m_e: f64,
    k_mean: f64,
    stiffness: MeshStiffness,
    /// Whether the stiffness has pieces whose boundaries must be stops.
    has_stops: bool,
    ste: PhaseSeries,
    contact_law: ContactLaw,
    damping: f64,
    /// Damping also during separation (Kahraman–Singh form).
    damping_always: bool,
    /// Smooth terms (Bugaru 2006): cubic springs, damping variation, torque ripple.
    smooth: SmoothTerms,
    /// Force amplitude of the torque ripple, `m_e r_b1 T̃1 / I1`, N.
    ripple_force: f64,
    // Inputs and what follows from them.
    inputs: Inputs,
    f_ext: f64,
    /// `dF_ext/dt` on a torque-profile piece, N/s (0 otherwise), from `f_anchor`, s.
    f_ext_rate: f64,
    f_anchor: f64,
    /// The scene's speed and torque profiles (a run-up), followed by the driver.
    profiles: Option<std::sync::Arc<crate::scene::Profiles>>,
    // Discrete mode.
    clock: PhaseClock,
    segment: Segment,
    contact: ContactState,
    /// Contact changes `(t, new state)`, recorded only when enabled (tests, analysis).
    event_log: Option<Vec<(f64, ContactState)>>,
    /// Right-hand side with only the terms this scene uses ([`kernel`]).
    kernel: Kernel,
}

impl GearPair {
    /// Assembles the pair at `t = 0` with the scene's inputs; call [`GearPair::initial_state`]
    /// for the matching initial state.
    pub fn new(scene: &PairScene) -> GearPair {
        let m_e = scene.equivalent_mass();
        let pieces = scene.mesh.stiffness.pieces();
        let has_stops = match pieces {
            Some(pieces) => pieces.len() > 1 || pieces[0].slope != 0.0,
            None => false,
        };
        let mut pair = GearPair {
            r_b1: scene.pinion.base_radius,
            r_b2: scene.gear.base_radius,
            inertia1: scene.pinion.inertia,
            inertia2: scene.gear.inertia,
            pinion_teeth: scene.pinion.teeth as f64,
            gear_teeth: scene.gear.teeth,
            m_e,
            k_mean: scene.mesh.stiffness.mean(),
            stiffness: scene.mesh.stiffness.clone(),
            has_stops,
            ste: scene.mesh.ste.clone(),
            contact_law: scene.mesh.contact,
            damping: scene.mesh.damping,
            damping_always: scene.mesh.damping_always,
            smooth: scene.mesh.smooth,
            ripple_force: 0.0,
            inputs: Inputs {
                pinion_speed: scene.operating.pinion_speed,
                input_torque: scene.operating.input_torque,
                load_torque: scene.operating.load_torque,
            },
            f_ext: 0.0,
            f_ext_rate: 0.0,
            f_anchor: 0.0,
            profiles: scene
                .profiles
                .any()
                .then(|| std::sync::Arc::new(scene.profiles.clone())),
            clock: PhaseClock::new(0.0, scene.mesh.initial_phase, 0.0),
            segment: Segment {
                cycle: 0.0,
                piece: 0,
            },
            contact: ContactState::Drive,
            event_log: None,
            kernel: Kernel::generic(),
        };
        pair.kernel = Kernel::for_pair(&pair);
        pair.apply_inputs(0.0, pair.inputs);
        pair.apply_profiles(0.0);
        pair.locate_segment(0.0);
        pair
    }

    /// Takes the profile pieces that start at `t` (`docs/runup.md`): the clock runs on the
    /// speed piece `Ω + Ω̇ (t' − t)` (phase quadratic in time), and the external force on the
    /// torque piece. The nominal angular acceleration adds no force to the DTE equation: it
    /// is a rigid-body motion, `r_b1 φ1'' = r_b2 φ2''`, which cancels in `x'' = r_b1 θ1'' +
    /// r_b2 θ2''` (`docs/runup.md`, "Inertial forcing").
    pub fn apply_profiles(&mut self, t: f64) {
        let Some(pr) = self.profiles.clone() else {
            return;
        };
        let mut inputs = self.inputs;
        let piece = pr.piece_at(t, inputs.pinion_speed, inputs.input_torque);
        let ((speed, speed_rate), (torque, torque_rate)) = (piece.speed, piece.torque);
        inputs.pinion_speed = speed;
        inputs.input_torque = torque;
        let load_rate = piece.load.map_or(0.0, |(load, rate)| {
            inputs.load_torque = load;
            rate
        });
        self.inputs = inputs;
        self.clock.reanchor_ramp(
            t,
            self.mesh_frequency_at(speed),
            self.mesh_frequency_at(speed_rate),
        );
        self.f_ext = self.external_force_for(&inputs);
        self.f_ext_rate = self.external_force_for(&Inputs {
            pinion_speed: 0.0,
            input_torque: torque_rate,
            load_torque: load_rate,
        });
        self.f_anchor = t;
    }

    /// The scene's profiles, if any.
    pub fn profiles(&self) -> Option<&crate::scene::Profiles> {
        self.profiles.as_deref()
    }

    /// The largest mesh frequency of the run, Hz: the current one, or the speed profile's
    /// largest value's.
    pub fn peak_mesh_frequency(&self) -> f64 {
        let now = self.clock.mesh_frequency().abs();
        match self.profiles.as_ref().and_then(|p| p.speed.as_ref()) {
            Some(p) => now.max(self.mesh_frequency_at(p.max_value())),
            None => now,
        }
    }

    /// Why this run-up is not piecewise LTI ([`crate::scene::Profiles::not_lti_reason`]).
    pub fn runup_not_lti(&self) -> Option<String> {
        let ste = !self.ste.is_zero();
        self.profiles.as_ref()?.not_lti_reason(ste, false)
    }

    /// The mean external force at `t`: `F_ext`, plus the torque profile's ramp, N.
    #[inline(always)]
    pub(crate) fn external_force_at(&self, t: f64) -> f64 {
        if self.f_ext_rate == 0.0 {
            self.f_ext
        } else {
            self.f_ext + self.f_ext_rate * (t - self.f_anchor)
        }
    }

    /// The scene's initial state `[x0, x0']`; also sets the contact state to match it.
    pub fn initial_state(&mut self, scene: &PairScene) -> [f64; 2] {
        let e0 = self.ste_at(0.0).0;
        let x0 = match scene.initial_dte {
            InitialDte::Static => self.static_deflection() + e0,
            InitialDte::Value(x) => x,
        };
        let y = [x0, scene.initial_dte_rate];
        self.classify_contact(0.0, &y);
        y
    }

    /// Sets new inputs at time `t` (between communication points). The mesh phase stays
    /// continuous; the nominal speed changes from `t` on.
    pub fn set_inputs(&mut self, t: f64, inputs: Inputs) {
        self.apply_inputs(t, inputs);
    }

    pub fn inputs(&self) -> Inputs {
        self.inputs
    }

    /// Mesh frequency `f_m = z1 Ω / 2π` at pinion speed `Ω` (`docs/model.md`, "Mesh phase").
    fn mesh_frequency_at(&self, pinion_speed: f64) -> f64 {
        self.pinion_teeth * pinion_speed / TAU
    }

    /// Mean external force on the DTE coordinate for torques `inputs`, N.
    fn external_force_for(&self, inputs: &Inputs) -> f64 {
        self.m_e
            * (self.r_b1 * inputs.input_torque / self.inertia1
                + self.r_b2 * inputs.load_torque / self.inertia2)
    }

    fn apply_inputs(&mut self, t: f64, inputs: Inputs) {
        self.inputs = inputs;
        let f_m = self.mesh_frequency_at(inputs.pinion_speed);
        self.clock.reanchor(t, f_m);
        self.f_ext = self.external_force_for(&inputs);
        self.ripple_force = self.m_e * self.r_b1 * self.smooth.torque_ripple / self.inertia1;
    }

    /// Places the stiffness segment from the phase at `t` (only at (re)start: during
    /// integration the segment advances through `on_stop`, never from a rounded phase).
    fn locate_segment(&mut self, t: f64) {
        let u = self.clock.phase_at(t) + self.stiffness.phase();
        let cycle = u.floor();
        let s = u - cycle;
        let piece = match self.stiffness.pieces() {
            Some(pieces) => pieces
                .partition_point(|piece| piece.start <= s)
                .saturating_sub(1),
            None => 0,
        };
        self.segment = Segment { cycle, piece };
    }

    /// Snapshot of the run-time state ([`PairState`]).
    pub fn pair_state(&self) -> PairState {
        PairState {
            inputs: self.inputs,
            clock: self.clock,
            segment_cycle: self.segment.cycle,
            segment_piece: self.segment.piece,
            contact: self.contact,
        }
    }

    /// Restores a [`PairState`] taken from a pair assembled from the same scene. Rejects a
    /// piece index or contact state this pair cannot have (a state from another scene).
    pub fn restore_pair_state(&mut self, s: &PairState) -> Result<(), String> {
        let pieces = self.stiffness.pieces().map_or(1, <[_]>::len);
        if s.segment_piece >= pieces {
            return Err(format!(
                "stiffness piece {} does not exist (the stiffness has {pieces})",
                s.segment_piece
            ));
        }
        let contact_ok = match self.contact_law {
            ContactLaw::Linear => s.contact == ContactState::Drive,
            ContactLaw::ContactLoss => s.contact != ContactState::Back,
            ContactLaw::Backlash { .. } => true,
        };
        if !contact_ok {
            return Err(format!(
                "contact state {:?} is impossible with this contact law",
                s.contact
            ));
        }
        // The cycle of a phase within the clock's limit, shifted by the stiffness' phase.
        let cycle_ok = s.segment_cycle.is_finite() && s.segment_cycle.fract() == 0.0;
        if !cycle_ok || s.segment_cycle.abs() > 2.0 * MAX_MESH_CYCLES {
            return Err(format!(
                "stiffness cycle {} is not a whole number of magnitude <= 2^33",
                s.segment_cycle
            ));
        }
        s.clock
            .check_restored(self.mesh_frequency_at(s.inputs.pinion_speed))?;
        self.apply_inputs(0.0, s.inputs);
        self.clock = s.clock;
        self.segment = Segment {
            cycle: s.segment_cycle,
            piece: s.segment_piece,
        };
        self.contact = s.contact;
        Ok(())
    }

    /// Checks that the parameters keep the model within the range of `f64` arithmetic: a
    /// finite, positive equivalent mass, finite forces, and rates (natural and mesh
    /// frequencies, `c/m_e`) up to [`MAX_RATE`]. Sign and finiteness of each parameter are
    /// checked where it is given; this is where their combination breaks down (issue 17: an
    /// inertia of 1e-300, a damping of 1e300 or a base radius of 1e300 made the first step
    /// non-finite).
    pub fn check_scales(&self) -> Result<(), String> {
        let (m_e, c) = (self.m_e, self.damping);
        let masses = || {
            format!(
                "the equivalent mass m_e = {m_e:e} kg (pinion inertia {:e} kg.m2, base radius \
                 {:e} m; gear inertia {:e} kg.m2, base radius {:e} m)",
                self.inertia1, self.r_b1, self.inertia2, self.r_b2
            )
        };
        if !(m_e.is_finite() && m_e > 0.0) {
            return Err(format!("{}: must be a finite number > 0", masses()));
        }
        let rates = [
            (
                "the fastest frequency (natural or mesh harmonic)",
                self.max_frequency(),
            ),
            ("the damping rate c/m_e", c / m_e),
        ];
        for (what, rate) in rates {
            if !(rate <= MAX_RATE) {
                return Err(format!(
                    "with {}, mean stiffness {:e} N/m and damping {c:e} N.s/m, {what} is \
                     {rate:e} 1/s, beyond {MAX_RATE:e} 1/s (the propagators square it: A², y'')",
                    masses(),
                    self.k_mean
                ));
            }
        }
        if let Some(p) = self.profiles.as_ref().and_then(|p| p.speed.as_ref()) {
            let peak = Inputs {
                pinion_speed: p.max_value(),
                ..self.inputs
            };
            self.check_inputs(&peak)
                .map_err(|e| format!("operating.speed_profile at its largest value: {e}"))?;
        }
        self.check_inputs(&self.inputs)
            .map_err(|e| format!("with {}: {e}", masses()))
    }

    /// Checks that inputs keep the pair within the range of `f64` arithmetic: the mesh
    /// harmonics' rate `2π h f_m` up to [`MAX_RATE`] and a finite mean force and static
    /// deflection. O(1): the check of every input set at a communication point (the pinion
    /// speed of 1e308 rad/s gave an infinite mesh frequency and NaN outputs).
    pub fn check_inputs(&self, inputs: &Inputs) -> Result<(), String> {
        let speed = inputs.pinion_speed;
        let harmonics = self.ste.harmonics().max(1) as f64;
        let rate = TAU * self.mesh_frequency_at(speed) * harmonics;
        if !(rate <= MAX_RATE) {
            return Err(format!(
                "operating.pinion_speed = {speed:?} rad/s gives the mesh harmonics a rate of {rate:e} 1/s, \
                 beyond {MAX_RATE:e} 1/s (the propagators square it)"
            ));
        }
        let force = self.external_force_for(inputs);
        if !(force.is_finite() && (force / self.k_mean).is_finite()) {
            return Err(format!(
                "operating.input_torque = {:?} N.m and operating.load_torque = {:?} N.m give the mean mesh force \
                 {force:e} N: not finite",
                inputs.input_torque, inputs.load_torque
            ));
        }
        Ok(())
    }

    /// Whether advancing from `t` to `t_end` stays within the limits of one advance
    /// ([`PhaseClock::check_advance`]).
    #[inline]
    pub fn check_advance(&self, t: f64, t_end: f64) -> Result<(), String> {
        self.clock
            .check_advance(t, t_end)
            .map_err(|e| self.advance_refusal(t, e))
    }

    /// [`GearPair::check_advance`]'s refusal `e` with the speed and phase that caused it.
    #[cold]
    #[inline(never)]
    fn advance_refusal(&self, t: f64, e: String) -> String {
        format!(
            "operating.pinion_speed = {:e} rad/s, mesh phase {:e} cycles at t = {t:e} s: {e}",
            self.inputs.pinion_speed,
            self.clock.phase_at(t)
        )
    }

    /// Resets the discrete mode from a state at time `t`: used at start and after a state is
    /// restored from outside (FMU `SetFMUstate`).
    pub fn resynchronise(&mut self, t: f64, y: &[f64]) {
        self.locate_segment(t);
        self.classify_contact(t, y);
    }

    /// Sets the contact state from the deflection, ties broken by the deflection rate.
    fn classify_contact(&mut self, t: f64, y: &[f64]) {
        let (delta, delta_rate) = self.deflection(t, y);
        self.contact = match self.contact_law {
            ContactLaw::Linear => ContactState::Drive,
            ContactLaw::ContactLoss => {
                if delta > 0.0 || (delta == 0.0 && delta_rate > 0.0) {
                    ContactState::Drive
                } else {
                    ContactState::Separated
                }
            }
            ContactLaw::Backlash { clearance } => {
                let back = delta + clearance;
                if delta > 0.0 || (delta == 0.0 && delta_rate > 0.0) {
                    ContactState::Drive
                } else if back < 0.0 || (back == 0.0 && delta_rate < 0.0) {
                    ContactState::Back
                } else {
                    ContactState::Separated
                }
            }
        };
    }

    /// `e(p(t))` and `de/dt`.
    fn ste_at(&self, t: f64) -> (f64, f64) {
        let (p, f) = self.clock.phase_and_frequency(t);
        let (e, slope) = self.ste.value_and_slope(p);
        (e, slope * f)
    }

    /// Mesh deflection `δ = x − e` and its rate.
    fn deflection(&self, t: f64, y: &[f64]) -> (f64, f64) {
        let (e, e_rate) = self.ste_at(t);
        (y[0] - e, y[1] - e_rate)
    }

    /// Stiffness of the frozen segment at time `t`.
    fn stiffness_at(&self, t: f64) -> f64 {
        self.stiffness_at_phase(self.clock.phase_at(t))
    }

    /// The stiffness at mesh phase `p` (unshifted) in the current piece.
    #[inline(always)]
    pub(crate) fn stiffness_at_phase(&self, p: f64) -> f64 {
        match &self.stiffness {
            MeshStiffness::Piecewise { phase, pieces } => {
                let u = p + phase;
                pieces[self.segment.piece].value(u - self.segment.cycle)
            }
            MeshStiffness::Fourier {
                phase,
                mean,
                series,
            } => mean + series.value(p + phase),
        }
    }

    /// Clearance 2b (0 unless backlash).
    fn clearance(&self) -> f64 {
        match self.contact_law {
            ContactLaw::Backlash { clearance } => clearance,
            _ => 0.0,
        }
    }

    /// Mesh force in the current contact state (Bugaru 2006 eq. 13; see [`kernel`]).
    pub fn mesh_force(&self, t: f64, y: &[f64]) -> f64 {
        (self.kernel.force)(self, t, y)
    }

    /// Switches to the kernel that evaluates every term, also those with zero coefficients:
    /// the baseline of `benches/features.rs` and the oracle of the specialised kernels
    /// (bit-identical results). The equations do not change.
    pub fn use_generic_kernel(&mut self) {
        // A run-up's kernel already evaluates every term.
        if self.kernel.name != "runup" {
            self.kernel = Kernel::generic();
        }
    }

    /// Name of the right-hand-side kernel in use (the terms it evaluates, or `generic`).
    pub fn kernel_name(&self) -> &'static str {
        self.kernel.name
    }

    /// The mesh force as a function of mesh phase and state, with the contact state taken from
    /// the deflection rather than from the frozen mode: the force, `∂F/∂x`, `∂F/∂x'`, the
    /// viscous part `c·δ̇` and whether the teeth are in contact. `f_m` is the mesh frequency that
    /// turns `de/dp` into `ė`. For frequency-domain methods (harmonic balance), which see the
    /// contact law as a static piecewise-linear function of the state.
    pub fn force_law(&self, p: f64, f_m: f64, x: f64, v: f64) -> ForceLaw {
        let (e, slope) = self.ste.value_and_slope(p);
        let delta = x - e;
        let delta_rate = v - f_m * slope;
        let k = self.stiffness.value(p);
        let (engaged, offset) = match self.contact_law {
            ContactLaw::Linear => (true, 0.0),
            ContactLaw::ContactLoss => (delta > 0.0, 0.0),
            ContactLaw::Backlash { clearance } => {
                if delta > 0.0 {
                    (true, 0.0)
                } else if delta < -clearance {
                    (true, clearance)
                } else {
                    (false, 0.0)
                }
            }
        };
        let viscous = |c: f64| ForceLaw {
            force: c * delta_rate,
            stiffness: 0.0,
            damping: c,
            viscous: c * delta_rate,
            engaged,
            back: engaged && offset != 0.0,
        };
        if engaged && !self.smooth.is_zero() {
            let s = &self.smooth;
            let c = self.damping + s.damping_variation * (TAU * p).cos();
            let d2 = delta * delta;
            ForceLaw {
                force: k * (delta + s.cubic_factor * d2 * delta)
                    + s.cubic_spring * d2 * delta
                    + c * delta_rate,
                stiffness: k * (1.0 + 3.0 * s.cubic_factor * d2) + 3.0 * s.cubic_spring * d2,
                ..viscous(c)
            }
        } else if engaged {
            ForceLaw {
                force: k * (delta + offset) + self.damping * delta_rate,
                stiffness: k,
                ..viscous(self.damping)
            }
        } else if self.damping_always {
            viscous(self.damping)
        } else {
            viscous(0.0)
        }
    }

    /// The switching functions of the contact law at mesh phase `p` and state `(x, v)` with
    /// their rates: `δ = x − e(p)` (contact loss), and `δ + 2b` (backlash); none for the linear
    /// law. The same rule as [`Self::force_law`].
    pub fn contact_gaps_at(&self, p: f64, f_m: f64, x: f64, v: f64, out: &mut Vec<(f64, f64)>) {
        out.clear();
        if self.contact_law == ContactLaw::Linear {
            return;
        }
        let (e, slope) = self.ste.value_and_slope(p);
        let (delta, rate) = (x - e, v - f_m * slope);
        out.push((delta, rate));
        if let ContactLaw::Backlash { clearance } = self.contact_law {
            out.push((delta + clearance, rate));
        }
    }

    /// Mesh phases (cycles, `[0, 1)`) where the stiffness changes its piece; none for a
    /// smooth or constant stiffness.
    pub fn stiffness_breakpoints(&self) -> Vec<f64> {
        match self.stiffness.pieces() {
            Some(pieces) if self.has_stops => pieces
                .iter()
                .map(|piece| crate::mesh::cycle_fraction(piece.start - self.stiffness.phase()))
                .collect(),
            _ => Vec::new(),
        }
    }

    /// Viscous mesh damping `c_m`, N·s/m.
    pub fn damping(&self) -> f64 {
        self.damping
    }

    /// Whether the damping also acts while the teeth are separated.
    pub fn damping_always(&self) -> bool {
        self.damping_always
    }

    /// Clearance `2b` of the contact law (0 without backlash), m.
    pub fn contact_clearance(&self) -> f64 {
        self.clearance()
    }

    /// Mean external force on the DTE coordinate `F_ext`, N.
    pub fn external_force(&self) -> f64 {
        self.f_ext
    }

    /// External force at mesh phase `p`, with the torque ripple, N.
    pub fn external_force_at_phase(&self, p: f64) -> f64 {
        self.f_ext + self.ripple_force * (TAU * p).cos()
    }

    /// Upper bound of |e(p)|, m.
    pub fn ste_amplitude_bound(&self) -> f64 {
        self.ste.amplitude_bound()
    }

    /// Starts recording contact changes (cleared on every call).
    pub fn record_events(&mut self) {
        self.event_log = Some(Vec::new());
    }

    /// The recorded contact changes `(t, new state)`.
    pub fn events(&self) -> &[(f64, ContactState)] {
        self.event_log.as_deref().unwrap_or(&[])
    }

    pub fn contact_state(&self) -> ContactState {
        self.contact
    }

    /// Mean static deflection `F_ext / k̄`, m.
    pub fn static_deflection(&self) -> f64 {
        self.f_ext / self.k_mean
    }

    /// The fastest rate of the pair around its operating point, rad/s, and the fields that set
    /// it: the natural frequency at the stiffest piece, the STE harmonics at the mesh
    /// frequency, the natural frequency with the cubic springs' tangent stiffness
    /// `3(k δ̄ + γ)δ²` at the static deflection plus the ripple's and the STE's (Bugaru 2006
    /// eq. 13: a cubic spring stiffens the mesh with the load), or `2c/m_e`, which bounds the damping rate `(c + |c̃|)/m_e` of
    /// an overdamped mesh (`|c̃| <= c`), whichever is largest. It sizes the work of a run
    /// ([`crate::simulation::RunLimits`]).
    pub fn fastest_rate(&self) -> (f64, &'static str) {
        let k_max = match self.stiffness.pieces() {
            Some(pieces) => pieces.iter().map(|p| p.k_start).fold(0.0, f64::max),
            None => self.k_mean,
        };
        let s = &self.smooth;
        let delta = self.static_deflection().abs()
            + self.ripple_force.abs() / self.k_mean
            + self.ste_amplitude_bound();
        let cubic = 3.0 * (k_max * s.cubic_factor + s.cubic_spring) * delta * delta;
        [
            (
                (k_max / self.m_e).sqrt(),
                "the mesh stiffness on the equivalent mass: mesh.stiffness, gear inertias and base radii",
            ),
            (
                TAU * self.clock.mesh_frequency() * self.ste.harmonics() as f64,
                "the highest STE harmonic: mesh.ste at operating.pinion_speed",
            ),
            (
                ((k_max + cubic) / self.m_e).sqrt(),
                "the cubic springs at the static deflection: mesh.cubic and the operating torques",
            ),
            (
                2.0 * self.damping / self.m_e,
                "the mesh damping on the equivalent mass: mesh.damping or mesh.damping_ratio",
            ),
        ]
        .into_iter()
        .fold((0.0, ""), |best, c| if !(c.0 <= best.0) { c } else { best })
    }

    pub fn equivalent_mass(&self) -> f64 {
        self.m_e
    }

    pub fn mean_stiffness(&self) -> f64 {
        self.k_mean
    }

    /// Mesh period at the current nominal speed, s (`inf` at standstill).
    /// Teeth of the pinion and the gear.
    pub fn teeth(&self) -> (u32, u32) {
        (self.pinion_teeth as u32, self.gear_teeth)
    }

    pub fn mesh_period(&self) -> f64 {
        1.0 / self.clock.mesh_frequency()
    }

    pub fn mesh_phase(&self, t: f64) -> f64 {
        self.clock.phase_at(t)
    }

    /// All outputs at `(t, y)` in [`OUTPUT_NAMES`] order.
    #[inline]
    pub fn outputs(&self, t: f64, y: &[f64], out: &mut [f64; 7]) {
        *out = [
            y[0],
            y[1],
            self.mesh_force(t, y),
            self.contact as i8 as f64,
            crate::mesh::output_phase(self.clock.phase_at(t)),
            self.stiffness_at(t),
            self.external_force_at(t) / self.k_mean,
        ];
    }

    /// Output `column` ([`OUTPUT_NAMES`]) of the current mode as a row `w` over the lifted
    /// state `z = [x, x', cos/sin 2πhp…, 1]` where it is linear in `z` (issue 31: the
    /// closed-form spectrum, `crate::analysis::spectrum::orbit_lines`): the DTE and its rate,
    /// the mesh force (the stiffness, damping and offset of the mode that `lti_matrix`
    /// puts into `x''`), and the contact state, the piece's stiffness and
    /// the static deflection, constants of the mode. `false` for the phase, and off the
    /// piecewise-LTI form.
    pub fn lifted_output_row(&self, column: usize, w: &mut [f64]) -> bool {
        if !self.is_piecewise_lti() || self.f_ext_rate != 0.0 || w.len() != self.lti_dim() {
            return false;
        }
        w.fill(0.0);
        let last = w.len() - 1;
        match column {
            0 => w[0] = 1.0,
            1 => w[1] = 1.0,
            2 => {
                // F = k(x − e + offset) + c(x' − ė), as `lti_matrix` puts it into x''.
                let (k, c, offset) = self.mode_law();
                let omega = TAU * self.clock.mesh_frequency();
                w[0] = k;
                w[1] = c;
                w[last] = k * offset;
                for (i, &(ah, bh)) in self.ste.coefficients().iter().enumerate() {
                    let h = (i + 1) as f64;
                    w[2 * (i + 1)] = -(k * ah + c * h * omega * bh);
                    w[2 * (i + 1) + 1] = -(k * bh - c * h * omega * ah);
                }
            }
            3 => w[last] = self.contact as i8 as f64,
            5 => w[last] = self.segment_stiffness(),
            6 => w[last] = self.f_ext / self.k_mean,
            _ => return false,
        }
        true
    }

    /// Stiffness, damping and back-flank offset of the mesh force in the current mode.
    fn mode_law(&self) -> (f64, f64, f64) {
        match self.contact {
            ContactState::Separated if self.damping_always => (0.0, self.damping, 0.0),
            ContactState::Separated => (0.0, 0.0, 0.0),
            ContactState::Drive => (self.segment_stiffness(), self.damping, 0.0),
            ContactState::Back => (self.segment_stiffness(), self.damping, self.clearance()),
        }
    }

    /// The constant stiffness of the current piece (piecewise-constant sources only).
    fn segment_stiffness(&self) -> f64 {
        self.stiffness
            .pieces()
            .map_or(self.k_mean, |pieces| pieces[self.segment.piece].k_start)
    }

    /// Whether the mesh force is linear in the state: linear contact law, no cubic springs.
    pub fn is_linear_law(&self) -> bool {
        self.contact_law == ContactLaw::Linear
            && self.smooth.cubic_factor == 0.0
            && self.smooth.cubic_spring == 0.0
    }

    /// Whether every segment is linear time-invariant (the exact propagator applies).
    pub fn is_piecewise_lti(&self) -> bool {
        self.stiffness.is_piecewise_constant() && self.smooth.is_zero()
    }

    /// Why a segment is not LTI (exact propagator refused), or `None`.
    pub fn not_lti_reason(&self) -> Option<String> {
        if !self.stiffness.is_piecewise_constant() {
            Some(
                "the mesh stiffness is not piecewise constant (smooth, trapezoidal or tabulated \
                 with slopes), so it varies within a segment"
                    .to_owned(),
            )
        } else if !self.smooth.is_zero() {
            Some(
                "the mesh has smooth nonlinear or time-varying terms (cubic stiffness, damping \
                 variation or torque ripple), which are not linear time-invariant"
                    .to_owned(),
            )
        } else {
            None
        }
    }
}

impl HybridSystem for GearPair {
    fn dim(&self) -> usize {
        2
    }

    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) {
        (self.kernel.rhs)(self, t, y, dy)
    }

    fn guard_count(&self) -> usize {
        match (self.contact_law, self.contact) {
            (ContactLaw::Linear, _) => 0,
            (ContactLaw::Backlash { .. }, ContactState::Separated) => 2,
            _ => 1,
        }
    }

    /// Guards of the current mode: drive `[δ]`, separated `[−δ, δ + 2b]`, back `[−(δ + 2b)]`.
    fn guards(&self, t: f64, y: &[f64], g: &mut [f64]) {
        let delta = self.deflection(t, y).0;
        let back = delta + self.clearance();
        match self.contact {
            ContactState::Drive => g[0] = delta,
            ContactState::Separated => {
                g[0] = -delta;
                if g.len() > 1 {
                    g[1] = back;
                }
            }
            ContactState::Back => g[0] = -back,
        }
    }

    fn next_stop(&self) -> f64 {
        if !self.has_stops {
            return f64::INFINITY;
        }
        let pieces = self
            .stiffness
            .pieces()
            .expect("stops only for piecewise stiffness");
        let end = self.segment.cycle + pieces[self.segment.piece].end;
        self.clock.time_of(end - self.stiffness.phase())
    }

    /// Moves to the next piece, and past any piece that ends at `t` too: a piece narrower
    /// than the time resolution at `t` (the flat zone between trapezoidal ramps that touch,
    /// `transition = 1 − f`, is zero up to rounding) lasts no time, and the stiffness is
    /// continuous across it. At most one cycle of pieces is skipped, so a cycle shorter than
    /// the time resolution still reaches the integrator's progress check.
    fn on_stop(&mut self, t: f64, _y: &mut [f64]) {
        let count = self.stiffness.pieces().map_or(1, <[_]>::len);
        for _ in 0..count {
            self.segment.piece += 1;
            if self.segment.piece == count {
                self.segment.piece = 0;
                self.segment.cycle += 1.0;
            }
            if self.next_stop() > t {
                break;
            }
        }
    }

    /// `∂f/∂y` of the frozen mode: `[[0, 1], [−∂F/∂x / m, −∂F/∂x' / m]]`.
    fn jacobian(&self, t: f64, y: &[f64], jac: &mut [f64]) -> bool {
        let (kx, cv) = match self.contact {
            ContactState::Separated if self.damping_always => (0.0, self.damping),
            ContactState::Separated => (0.0, 0.0),
            ContactState::Drive | ContactState::Back => {
                let k = self.stiffness_at(t);
                if self.smooth.is_zero() {
                    (k, self.damping)
                } else {
                    let s = &self.smooth;
                    let d2 = self.deflection(t, y).0.powi(2);
                    let p = self.clock.phase_at(t);
                    (
                        k * (1.0 + 3.0 * s.cubic_factor * d2) + 3.0 * s.cubic_spring * d2,
                        self.damping + s.damping_variation * (TAU * p).cos(),
                    )
                }
            }
        };
        jac.copy_from_slice(&[0.0, 1.0, -kx / self.m_e, -cv / self.m_e]);
        true
    }

    /// Guards are `±δ` or `±(δ + 2b)` with `δ = x − e(p(t))`: gradient `[±1, 0]`, explicit
    /// time derivative `∓ė`.
    fn guard_gradient(&self, t: f64, _y: &[f64], index: usize, grad: &mut [f64]) -> Option<f64> {
        let sign = match (self.contact, index) {
            (ContactState::Drive, _) => 1.0,
            (ContactState::Separated, 0) => -1.0,
            (ContactState::Separated, _) => 1.0,
            (ContactState::Back, _) => -1.0,
        };
        let e_rate = self.ste_at(t).1;
        grad.copy_from_slice(&[sign, 0.0]);
        Some(-sign * e_rate)
    }

    /// `g = ±(x − e(p(t))) + offset`: `w = [±1, 0]`, and `|c''| = |ë| ≤ (2π f_m)² Σ_h h² |(a_h,
    /// b_h)|` for the STE series `e(p) = Σ a_h cos 2πhp + b_h sin 2πhp` (the phase runs at the
    /// constant mesh frequency between events and stops, `docs/model.md`).
    ///
    /// On a speed ramp (`docs/runup.md`) `f_m` is the larger of its values at the ends and
    /// `ë = e''(p) f_m² + e'(p) ḟ_m` adds `|ḟ_m| Σ_h 2πh |(a_h, b_h)|`.
    fn affine_guard(&self, index: usize, t0: f64, t1: f64, w: &mut [f64]) -> Option<f64> {
        let sign = match (self.contact, index) {
            (ContactState::Drive, _) => 1.0,
            (ContactState::Separated, 0) => -1.0,
            (ContactState::Separated, _) => 1.0,
            (ContactState::Back, _) => -1.0,
        };
        w.copy_from_slice(&[sign, 0.0]);
        let omega = TAU * self.clock.frequency_at(t0).max(self.clock.frequency_at(t1));
        let curvature: f64 = (self.ste.coefficients().iter().enumerate())
            .map(|(i, &(a, b))| {
                let h = (i + 1) as f64;
                (h * omega).powi(2) * a.hypot(b)
            })
            .sum();
        let rate = self.clock.rate();
        if rate == 0.0 {
            return Some(curvature);
        }
        let slope: f64 = (self.ste.coefficients().iter().enumerate())
            .map(|(i, &(a, b))| TAU * (i + 1) as f64 * a.hypot(b))
            .sum();
        Some(curvature + rate.abs() * slope)
    }

    fn on_event(&mut self, t: f64, y: &mut [f64], index: usize) {
        self.switch_contact(t, self.ste_at(t).0, y, index);
    }
}

impl GearPair {
    /// The contact switch at an event at `t` where the STE is `e`: snaps `x` onto the
    /// surface that guard `index` crossed and changes the contact state.
    fn switch_contact(&mut self, t: f64, e: f64, y: &mut [f64], index: usize) {
        let clearance = self.clearance();
        // Snap x so that δ sits exactly on the surface that was crossed (numerics-notes §2.1,
        // lesson 4), then switch.
        let (surface, next) = match (self.contact, index) {
            (ContactState::Drive, _) => (0.0, ContactState::Separated),
            (ContactState::Separated, 0) => (0.0, ContactState::Drive),
            (ContactState::Separated, _) => (-clearance, ContactState::Back),
            (ContactState::Back, _) => (-clearance, ContactState::Separated),
        };
        y[0] = e + surface;
        self.contact = next;
        if let Some(log) = &mut self.event_log {
            log.push((t, next));
        }
    }
}

impl PiecewiseLti for GearPair {
    fn lti_dim(&self) -> usize {
        3 + 2 * self.ste.harmonics()
    }

    /// `z = [x, x', cos 2πp, sin 2πp, …, cos 2πHp, sin 2πHp, 1]`.
    fn lift(&self, t: f64, y: &[f64], z: &mut [f64]) {
        z[0] = y[0];
        z[1] = y[1];
        let p = crate::mesh::cycle_fraction(self.clock.phase_at(t));
        for h in 1..=self.ste.harmonics() {
            let (s, c) = (TAU * h as f64 * p).sin_cos();
            z[2 * h] = c;
            z[2 * h + 1] = s;
        }
        let last = z.len() - 1;
        z[last] = 1.0;
    }

    fn lti_matrix(&self, a: &mut DMatrix<f64>) {
        a.fill(0.0);
        let n = a.nrows();
        let last = n - 1;
        let (k, c, offset) = self.mode_law();
        let m = self.m_e;
        let omega = TAU * self.clock.mesh_frequency();
        a[(0, 1)] = 1.0;
        a[(1, 0)] = -k / m;
        a[(1, 1)] = -c / m;
        a[(1, last)] = (self.f_ext - k * offset) / m;
        for (i, &(ah, bh)) in self.ste.coefficients().iter().enumerate() {
            let h = (i + 1) as f64;
            let (ci, si) = (2 * (i + 1), 2 * (i + 1) + 1);
            // F contains −k·e − c·ė with e = Σ a c_h + b s_h, ė = Σ hω(−a s_h + b c_h).
            a[(1, ci)] = (k * ah + c * h * omega * bh) / m;
            a[(1, si)] = (k * bh - c * h * omega * ah) / m;
            a[(ci, si)] = -h * omega;
            a[(si, ci)] = h * omega;
        }
    }

    fn guard_row(&self, index: usize, w: &mut [f64]) {
        w.fill(0.0);
        // δ = x − e as a row over z.
        w[0] = 1.0;
        for (i, &(ah, bh)) in self.ste.coefficients().iter().enumerate() {
            w[2 * (i + 1)] = -ah;
            w[2 * (i + 1) + 1] = -bh;
        }
        let last = w.len() - 1;
        let clearance = self.clearance();
        let (sign, offset) = match (self.contact, index) {
            (ContactState::Drive, _) => (1.0, 0.0),
            (ContactState::Separated, 0) => (-1.0, 0.0),
            (ContactState::Separated, _) => (1.0, clearance),
            (ContactState::Back, _) => (-1.0, clearance),
        };
        for v in w.iter_mut() {
            *v *= sign;
        }
        w[last] = sign * offset;
    }

    fn mode_key(&self, key: &mut crate::solve::exact::ModeKey) {
        key.push(
            (self.segment.piece as u64) << 2 | (self.contact as i8 + 1) as u64,
            u64::MAX,
        );
    }

    /// Contact guards proved positive by the energy bound of [`guard_bound`].
    fn guard_excluded(&self, _index: usize, z: &[f64]) -> bool {
        guard_bound::contact_guard_lower_bound(self, z).is_some()
    }

    /// `z` beyond `y` is `cos`/`sin` of the mesh phase and the constant 1: continuous.
    fn forcing_carries_over(&self) -> bool {
        true
    }

    /// The STE at the event from the lifted state's harmonic entries (no `sin`/`cos`).
    fn on_event_lifted(&mut self, t: f64, z: &[f64], y: &mut [f64], index: usize) {
        let e = self.ste.value_from_harmonics(&z[2..]);
        self.switch_contact(t, e, y, index);
    }

    fn max_frequency(&self) -> f64 {
        let k_max = match self.stiffness.pieces() {
            Some(pieces) => pieces.iter().map(|p| p.k_start).fold(0.0, f64::max),
            None => self.k_mean,
        };
        let natural = (k_max / self.m_e).sqrt();
        natural.max(TAU * self.clock.mesh_frequency() * self.ste.harmonics() as f64)
    }
}
