//! The one model interface under every tool: a drivetrain with one or more meshes.
//!
//! A scene is assembled into one specialised kernel that carries only the terms the scene uses
//! (DESIGN.md, "Data flow"):
//!
//! - [`GearPair`]: one mesh between two rotating bodies, in the DTE coordinate `[x, x']`
//!   (`docs/model.md`); it also carries the single-pair terms (Bugaru's cubic springs, He &
//!   Singh's sliding friction, geometry stiffness).
//! - [`GearTrain`]: any graph of gears, shafts and meshes with bearings (`docs/train.md`).
//!
//! Both implement [`Drivetrain`]; simulation, shooting, Floquet analysis, sweeps, harmonic
//! balance and the FMU adapter are written once against it and monomorphised per kernel, so the
//! single pair keeps its specialised speed without a second stack. A new kind of element
//! (a body, a coupling, a mesh-force term) goes into the assembly of [`GearTrain`]
//! (`src/model/train/assembly.rs` for bodies and couplings, `src/model/train/mesh.rs` for the
//! mesh cycle) and is reported through this trait.

use super::train::{GearTrain, SlotContact, TrainInputs, TrainSimulation};
use super::{GearPair, Inputs};
use crate::analysis::spectrum::ShaftFrequency;
use crate::scene::{PairScene, Scene};
use crate::simulation::{DrivenModel, Driver, Simulation};
use nalgebra::DMatrix;

/// The mesh quantities every analysis reports, evaluated at `(t, y)` in the current mode.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeshSample {
    /// Dynamic transmission error, m (along the line of action).
    pub dte: f64,
    /// Dynamic mesh force, N.
    pub force: f64,
    /// No tooth pair of the mesh is in contact (total contact loss).
    pub lost: bool,
    /// Mesh phase in cycles of the mesh period, in `[0, 1)`.
    pub phase: f64,
    /// Bit `j` set while the tooth pair in slot `j` ([`Drivetrain::mesh_pair_slots`]) is
    /// engaged but in contact on neither flank (partial or total contact loss); 0 for a mesh
    /// without tooth pairs.
    pub separated_pairs: u64,
}

/// Where mesh `n`'s quantities sit in the output row, for run summaries.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeshColumns {
    pub dte: usize,
    pub force: usize,
    /// The contact column and its value while the mesh is in contact, or (`lost_value`) while
    /// it has lost contact.
    pub contact: usize,
    pub contact_value: f64,
    /// `contact_value` marks rows in contact (the pair's `contact_state = 1`: drive side)
    /// rather than rows without contact (the drivetrain's `pairs_in_contact = 0`).
    pub value_means_contact: bool,
}

/// What the analyses need from a model beyond its equations ([`DrivenModel`]).
pub trait Drivetrain: DrivenModel {
    fn mesh_count(&self) -> usize;
    /// Prefix of mesh `n`'s columns in the summary tables of `sweep`, `hb` and `steady`
    /// (`""` for the single pair, whose one mesh's statistics are the row's: `dte_rms`, …;
    /// `"<mesh name>."` in a drivetrain: `mesh1.dte_rms`).
    fn mesh_prefix(&self, n: usize) -> String;
    /// Mesh frequency of mesh `n` at the current input speed, Hz.
    fn mesh_frequency(&self, n: usize) -> f64;
    /// Every gear's name, teeth and rotation frequency at the current input speed, Hz: the
    /// shaft orders that label spectral lines (`docs/spectrum.md`).
    fn shafts(&self) -> Vec<ShaftFrequency>;
    /// Rotation frequencies of the gears whose manufacturing errors excite a mesh, Hz (empty
    /// without errors): the response repeats only once per revolution of each
    /// (`docs/errors.md`).
    fn error_frequencies(&self) -> Vec<f64>;
    /// Nominal speed of the input gear, rad/s.
    fn input_speed(&self) -> f64;
    /// Input torque `T1` and load torque magnitude `T2`, N·m.
    fn torques(&self) -> (f64, f64);
    /// Sets the nominal input speed from time `t` on; every mesh phase stays continuous.
    fn set_input_speed(&mut self, t: f64, speed: f64) -> Result<(), String>;
    /// Mesh `n` at `(t, y)`.
    fn mesh_sample(&self, n: usize, t: f64, y: &[f64]) -> MeshSample;
    /// The tooth-pair slots of mesh `n` whose contact the model tracks one by one (a Model-1
    /// `pairs` mesh: slot `j` holds the pair at window position `ξ_j = s + c − 1 − j`,
    /// `docs/train.md`, the `<mesh>.pair<j>.force` outputs); 0 for a mesh without pairs.
    /// At most 64 ([`MeshSample::separated_pairs`] is a bit set).
    fn mesh_pair_slots(&self, _n: usize) -> usize {
        0
    }
    /// Mesh phase of mesh `n` at `t`, cycles (not reduced: it counts the cycles since the
    /// start, so with the response period it locates a state on an orbit).
    fn mesh_phase(&self, n: usize, t: f64) -> f64;
    /// Static mesh force of every mesh under the current torques (mean stiffness), N: the
    /// reference of the dynamic factor.
    fn static_mesh_forces(&self) -> Vec<f64>;
    /// A displacement scale of the state (the largest static deflection of a coordinate, or
    /// the clearance when unloaded), m; velocities scale with it times
    /// [`crate::solve::exact::PiecewiseLti::max_frequency`].
    fn displacement_scale(&self) -> f64;
    /// Whether every mesh force is linear in the state (no contact loss or backlash, no cubic
    /// springs): the linear Floquet analyses apply.
    fn is_linear(&self) -> bool;
    /// Names of the state's displacement coordinates (for reports).
    fn coordinate_names(&self) -> Vec<String>;
    /// Names of the output row (`geardyn simulate` columns after `time`, FMU outputs).
    fn row_names(&self) -> Vec<String>;
    /// The output row at `(t, y)`.
    fn output_row(&self, t: f64, y: &[f64], row: &mut Vec<f64>);
    /// Where mesh `n`'s DTE, force and contact sit in the output row.
    fn mesh_columns(&self, n: usize) -> MeshColumns;
    /// Output column `column` of the current mode as a row `w` over the lifted state
    /// ([`crate::solve::exact::PiecewiseLti::lift`], `w.len()` its size):
    /// `output_row(t, y)[column] = w·z(t)` throughout a segment of this mode. `false` where
    /// the column is not linear in `z` (a phase, a cumulative fraction) or the model does not
    /// give the row: the closed-form spectrum ([`crate::analysis::spectrum::orbit_lines`])
    /// integrates such a column by quadrature.
    fn lifted_output_row(&self, _column: usize, _w: &mut [f64]) -> bool {
        false
    }

    // The equations split for frequency-domain methods (harmonic balance,
    // `crate::analysis::hb`): in the model's displacement coordinates `ξ` (dimension `m`, the
    // state is `[ξ, ξ']`)
    //
    //   M ξ'' + C ξ' + K ξ + Σ_n Σ_k v_{n,k} F_{n,k}(t, S_n, Ṡ_n) = F̂(t),   S_n = a_n·ξ,
    //
    // a linear part and per mesh a few forces that depend on the state only through the mesh
    // deflection `S_n` and its rate, with the contact decided by that state at `t` (not by the
    // frozen mode of the integrators). All nonlinearity of both kernels lives in the mesh
    // forces, so a frequency-domain method can condense onto the mesh deflections.

    /// `M`, `C`, `K` of the linear part (bearings, shafts, modal damping; no mesh terms).
    fn linear_part(&self) -> LinearPart;
    /// `a_n`: mesh `n`'s deflection `S_n = a_n·ξ`, m (before STE and gaps).
    fn mesh_deflection_row(&self, n: usize) -> Vec<f64>;
    /// `d_n`: mesh `n`'s DTE `= d_n·ξ`, m (the `<mesh>.dte` output).
    fn mesh_dte_row(&self, n: usize) -> Vec<f64>;
    /// The directions `v_{n,k}` of mesh `n`'s forces: first `a_n` (the mesh force), then any
    /// other generalised force the mesh exerts (tooth friction), at most
    /// [`MAX_MESH_DIRECTIONS`].
    fn mesh_force_directions(&self, n: usize) -> Vec<Vec<f64>>;
    /// Mesh `n`'s forces at time `t` for deflection `s` and rate `s_rate`, every tooth pair's
    /// contact decided from that state and the mesh phase at `t` (the contact law as a static
    /// piecewise-linear function).
    fn mesh_law(&self, n: usize, t: f64, s: f64, s_rate: f64) -> MeshLaw;
    /// `ã_n`: the back flanks' own deflection row of mesh `n`, `S̃_n = ã_n·ξ`, where their
    /// line of action is not the drive line's (backlash, a pressure angle and translations:
    /// `docs/train.md`, "Back flanks"); `None` where the back flanks act on `S_n` itself. Such
    /// a mesh's back-side force depends on `S̃_n`, a second deflection of the mesh: its law
    /// is [`Drivetrain::mesh_law_with_back`], its force along `ã_n` the entry after those of
    /// [`Drivetrain::mesh_force_directions`].
    fn mesh_back_row(&self, _n: usize) -> Option<Vec<f64>> {
        None
    }
    /// [`Drivetrain::mesh_law`] of a mesh with a back row ([`Drivetrain::mesh_back_row`]):
    /// the back flanks' contact decided by, and their force formed from, `back = (S̃_n,
    /// dS̃_n/dt)`; that force (and its `∂/∂S̃`, `∂/∂(dS̃/dt)`, viscous part) is entry
    /// `mesh_force_directions(n).len()`, acting along `ã_n`. Both flanks can be pressed at once
    /// (tooth wedging). The damper acts along each row whose flanks touch. The other entries
    /// depend on `S_n` only.
    /// Without a back row, [`Drivetrain::mesh_law`].
    fn mesh_law_with_back(
        &self,
        n: usize,
        t: f64,
        s: f64,
        s_rate: f64,
        _back: (f64, f64),
    ) -> MeshLaw {
        self.mesh_law(n, t, s, s_rate)
    }
    /// The switching functions of mesh `n`'s contact law at `(t, s, s_rate)` with their time
    /// derivatives: per tooth pair engaged at `t`, its deflection `δ_j` (and `δ_j + 2b` with
    /// backlash). A pair's contact changes where one changes sign; none for a linear law.
    fn contact_gaps(&self, n: usize, t: f64, s: f64, s_rate: f64, out: &mut Vec<(f64, f64)>);
    /// [`Drivetrain::contact_gaps`] of a mesh with a back row: per engaged tooth pair `δ_j`
    /// (on `S_n`, entry `2j`) and `δ̃_j + 2b` (on `back = (S̃_n, dS̃_n/dt)`, entry `2j + 1`).
    /// Without a back row, [`Drivetrain::contact_gaps`].
    fn contact_gaps_with_back(
        &self,
        n: usize,
        t: f64,
        s: f64,
        s_rate: f64,
        _back: (f64, f64),
        out: &mut Vec<(f64, f64)>,
    ) {
        self.contact_gaps(n, t, s, s_rate, out)
    }
    /// Mesh phases (cycles, in `[0, 1)`) at which mesh `n`'s stiffness or gap law changes its
    /// formula, once per mesh cycle: the quadrature of a frequency-domain method is split there.
    fn mesh_breakpoints(&self, n: usize) -> Vec<f64>;
    /// The mesh phase at which the knot of mesh `n` that lies at phase `nominal` by
    /// [`Drivetrain::mesh_breakpoints`] (any cycle) really lies: a gear's runout moves the
    /// mesh's knots once per revolution (`docs/errors.md`, "Runout as a moving centre").
    /// `nominal` itself where nothing moves them.
    fn mesh_knot_phase(&self, _n: usize, nominal: f64) -> f64 {
        nominal
    }
    /// Mean stiffness and viscous damping of mesh `n`'s force (the linear part a method may
    /// move into its linear operator), N/m and N·s/m.
    fn mean_mesh_law(&self, n: usize) -> (f64, f64);
    /// The external generalised force `F̂(t)` (mean torques and any torque ripple), N.
    fn external_force(&self, t: f64, out: &mut [f64]);
}

/// Largest number of forces of one mesh ([`MeshLaw`]): the mesh force, the friction force and
/// moment of a Model-1 mesh with tooth friction ([`Drivetrain::mesh_force_directions`]), and the
/// back flanks' force along their own row ([`Drivetrain::mesh_back_row`]).
pub const MAX_MESH_DIRECTIONS: usize = 4;

/// The linear part of the equations of motion in the model's coordinates
/// ([`Drivetrain::linear_part`]).
#[derive(Debug, Clone, PartialEq)]
pub struct LinearPart {
    pub mass: DMatrix<f64>,
    pub damping: DMatrix<f64>,
    pub stiffness: DMatrix<f64>,
}

/// One mesh's forces at a state ([`Drivetrain::mesh_law`]), one entry per force direction
/// (then, with a back row, the back flanks' force: [`Drivetrain::mesh_law_with_back`]).
/// Every force is affine in the rates (viscous damping), so `viscous`, the part proportional to
/// the rates, is what changes with the speed at a fixed mesh phase.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct MeshLaw {
    /// Force along each direction, N (`force[0]`: the mesh force on the drive row; the mesh's
    /// total force is that plus the back flanks' force of a mesh with a back row).
    pub force: [f64; MAX_MESH_DIRECTIONS],
    /// `∂force/∂S` (of the back flanks' force: `∂/∂S̃`), N/m.
    pub stiffness: [f64; MAX_MESH_DIRECTIONS],
    /// `∂force/∂Ṡ` (of the back flanks' force: `∂/∂(dS̃/dt)`), N·s/m.
    pub damping: [f64; MAX_MESH_DIRECTIONS],
    /// The part of `force` proportional to the rates, N.
    pub viscous: [f64; MAX_MESH_DIRECTIONS],
    /// Tooth pairs in contact (drive or back side); 0 is total contact loss.
    pub in_contact: usize,
    /// The branch of the contact law each tooth pair engaged at `t` is on: bit `2j` set when
    /// pair `j` is in drive-side contact, bit `2j + 1` on the back side. While it stays the same
    /// the forces are one smooth formula of the state (a quadrature can split where it changes).
    pub pattern: u64,
}

impl Drivetrain for GearPair {
    fn mesh_count(&self) -> usize {
        1
    }
    fn mesh_prefix(&self, _n: usize) -> String {
        String::new()
    }
    fn mesh_frequency(&self, _n: usize) -> f64 {
        1.0 / self.mesh_period()
    }
    fn shafts(&self) -> Vec<ShaftFrequency> {
        // Each gear turns once per `teeth` mesh cycles.
        let f_m = 1.0 / self.mesh_period();
        let (zp, zg) = self.teeth();
        vec![
            ShaftFrequency {
                name: "pinion".into(),
                teeth: zp,
                frequency: f_m / zp as f64,
            },
            ShaftFrequency {
                name: "gear".into(),
                teeth: zg,
                frequency: f_m / zg as f64,
            },
        ]
    }
    fn error_frequencies(&self) -> Vec<f64> {
        // The pair kernel carries no gear errors: a pair scene with errors runs as its
        // one-mesh drivetrain (`crate::scene::kernel::choose`).
        Vec::new()
    }
    fn input_speed(&self) -> f64 {
        self.inputs().pinion_speed
    }
    fn torques(&self) -> (f64, f64) {
        let i = self.inputs();
        (i.input_torque, i.load_torque)
    }
    fn set_input_speed(&mut self, t: f64, speed: f64) -> Result<(), String> {
        let inputs = Inputs {
            pinion_speed: speed,
            ..self.inputs()
        };
        self.check_inputs(&inputs)?;
        self.set_inputs(t, inputs);
        Ok(())
    }
    fn mesh_sample(&self, _n: usize, t: f64, y: &[f64]) -> MeshSample {
        let mut out = [0.0; 7];
        self.outputs(t, y, &mut out);
        MeshSample {
            dte: out[0],
            force: out[2],
            lost: out[3] == 0.0,
            phase: out[4],
            separated_pairs: 0,
        }
    }
    fn mesh_phase(&self, _n: usize, t: f64) -> f64 {
        GearPair::mesh_phase(self, t)
    }
    fn static_mesh_forces(&self) -> Vec<f64> {
        vec![self.external_force()]
    }
    fn displacement_scale(&self) -> f64 {
        self.static_deflection()
            .abs()
            .max(self.contact_clearance())
            .max(1e-9)
    }
    fn is_linear(&self) -> bool {
        self.is_linear_law()
    }
    fn coordinate_names(&self) -> Vec<String> {
        vec!["dte".into()]
    }
    fn row_names(&self) -> Vec<String> {
        super::OUTPUT_NAMES.iter().map(|s| s.to_string()).collect()
    }
    fn output_row(&self, t: f64, y: &[f64], row: &mut Vec<f64>) {
        let mut out = [0.0; super::OUTPUT_NAMES.len()];
        self.outputs(t, y, &mut out);
        row.clear();
        row.extend_from_slice(&out);
    }
    fn lifted_output_row(&self, column: usize, w: &mut [f64]) -> bool {
        GearPair::lifted_output_row(self, column, w)
    }
    fn mesh_columns(&self, _n: usize) -> MeshColumns {
        // mesh.dte 0, mesh.force 2, mesh.contact_state 3 (1 = drive-side contact).
        MeshColumns {
            dte: 0,
            force: 2,
            contact: 3,
            contact_value: 1.0,
            value_means_contact: true,
        }
    }
    fn linear_part(&self) -> LinearPart {
        LinearPart {
            mass: DMatrix::from_element(1, 1, self.equivalent_mass()),
            damping: DMatrix::zeros(1, 1),
            stiffness: DMatrix::zeros(1, 1),
        }
    }
    fn mesh_deflection_row(&self, _n: usize) -> Vec<f64> {
        vec![1.0]
    }
    fn mesh_dte_row(&self, _n: usize) -> Vec<f64> {
        vec![1.0]
    }
    fn mesh_force_directions(&self, _n: usize) -> Vec<Vec<f64>> {
        vec![vec![1.0]]
    }
    fn mesh_law(&self, _n: usize, t: f64, s: f64, s_rate: f64) -> MeshLaw {
        let law = self.force_law(self.mesh_phase(t), 1.0 / self.mesh_period(), s, s_rate);
        MeshLaw {
            force: [law.force, 0.0, 0.0, 0.0],
            stiffness: [law.stiffness, 0.0, 0.0, 0.0],
            damping: [law.damping, 0.0, 0.0, 0.0],
            viscous: [law.viscous, 0.0, 0.0, 0.0],
            in_contact: usize::from(law.engaged),
            pattern: u64::from(law.engaged) << u32::from(law.back),
        }
    }
    fn contact_gaps(&self, _n: usize, t: f64, s: f64, s_rate: f64, out: &mut Vec<(f64, f64)>) {
        self.contact_gaps_at(self.mesh_phase(t), 1.0 / self.mesh_period(), s, s_rate, out);
    }
    fn mesh_breakpoints(&self, _n: usize) -> Vec<f64> {
        self.stiffness_breakpoints()
    }
    fn mean_mesh_law(&self, _n: usize) -> (f64, f64) {
        (self.mean_stiffness(), self.damping())
    }
    fn external_force(&self, t: f64, out: &mut [f64]) {
        out[0] = self.external_force_at_phase(GearPair::mesh_phase(self, t));
    }
}

impl Drivetrain for GearTrain {
    fn mesh_count(&self) -> usize {
        GearTrain::mesh_count(self)
    }
    fn mesh_prefix(&self, n: usize) -> String {
        format!("{}.", self.mesh_name(n))
    }
    fn mesh_frequency(&self, n: usize) -> f64 {
        1.0 / self.mesh_period(n)
    }
    fn shafts(&self) -> Vec<ShaftFrequency> {
        (self.gear_rotations().into_iter())
            .map(|(name, teeth, frequency)| ShaftFrequency {
                name,
                teeth,
                frequency,
            })
            .collect()
    }
    fn error_frequencies(&self) -> Vec<f64> {
        GearTrain::error_frequencies(self)
    }
    fn input_speed(&self) -> f64 {
        self.inputs().input_speed
    }
    fn torques(&self) -> (f64, f64) {
        let i = self.inputs();
        (i.input_torque, i.load_torque)
    }
    fn set_input_speed(&mut self, t: f64, speed: f64) -> Result<(), String> {
        let inputs = TrainInputs {
            input_speed: speed,
            ..self.inputs()
        };
        self.set_inputs(t, inputs)
    }
    fn mesh_sample(&self, n: usize, t: f64, y: &[f64]) -> MeshSample {
        let st = self.mesh_state(n, t, y);
        let flags = self.slot_flags(n);
        let separated_pairs = (flags.iter().take(self.mesh_pair_slots(n)).enumerate())
            .filter(|(_, f)| **f == SlotContact::Separated)
            .fold(0u64, |bits, (j, _)| bits | 1 << j);
        MeshSample {
            dte: st.dte,
            force: st.force,
            lost: !flags.iter().any(|f| f.touches()),
            phase: st.phase,
            separated_pairs,
        }
    }
    fn mesh_pair_slots(&self, n: usize) -> usize {
        match self.pair_slots(n) {
            slots @ 0..=64 => slots,
            _ => 0,
        }
    }
    fn mesh_phase(&self, n: usize, t: f64) -> f64 {
        GearTrain::mesh_phase(self, n, t)
    }
    fn static_mesh_forces(&self) -> Vec<f64> {
        self.static_forces()
    }
    fn displacement_scale(&self) -> f64 {
        self.static_coordinate_scale()
    }
    fn is_linear(&self) -> bool {
        self.is_linear_law()
    }
    fn coordinate_names(&self) -> Vec<String> {
        (1..=self.elastic_dim()).map(|i| format!("ξ{i}")).collect()
    }
    fn row_names(&self) -> Vec<String> {
        GearTrain::output_names(self).to_vec()
    }
    fn output_row(&self, t: f64, y: &[f64], row: &mut Vec<f64>) {
        self.outputs(t, y, row);
    }
    fn lifted_output_row(&self, column: usize, w: &mut [f64]) -> bool {
        GearTrain::lifted_output_row(self, column, w)
    }
    fn mesh_columns(&self, n: usize) -> MeshColumns {
        let names = GearTrain::output_names(self);
        let column = |q: &str| {
            let c = format!("{}.{q}", self.mesh_name(n));
            names
                .iter()
                .position(|name| *name == c)
                .expect("every mesh has its dte, force and pairs_in_contact outputs")
        };
        MeshColumns {
            dte: column("dte"),
            force: column("force"),
            contact: column("pairs_in_contact"),
            contact_value: 0.0,
            value_means_contact: false,
        }
    }
    fn linear_part(&self) -> LinearPart {
        GearTrain::linear_part(self)
    }
    fn mesh_deflection_row(&self, n: usize) -> Vec<f64> {
        self.mesh_row(n).to_vec()
    }
    fn mesh_dte_row(&self, n: usize) -> Vec<f64> {
        GearTrain::mesh_dte_row(self, n).to_vec()
    }
    fn mesh_force_directions(&self, n: usize) -> Vec<Vec<f64>> {
        GearTrain::mesh_force_directions(self, n)
    }
    fn mesh_law(&self, n: usize, t: f64, s: f64, s_rate: f64) -> MeshLaw {
        self.free_mesh_law(n, t, s, s_rate)
    }
    fn mesh_back_row(&self, n: usize) -> Option<Vec<f64>> {
        GearTrain::mesh_back_row(self, n).map(<[f64]>::to_vec)
    }
    fn mesh_law_with_back(
        &self,
        n: usize,
        t: f64,
        s: f64,
        s_rate: f64,
        back: (f64, f64),
    ) -> MeshLaw {
        self.free_mesh_law_with_back(n, t, s, s_rate, back)
    }
    fn contact_gaps(&self, n: usize, t: f64, s: f64, s_rate: f64, out: &mut Vec<(f64, f64)>) {
        self.free_contact_gaps(n, t, s, s_rate, out)
    }
    fn contact_gaps_with_back(
        &self,
        n: usize,
        t: f64,
        s: f64,
        s_rate: f64,
        back: (f64, f64),
        out: &mut Vec<(f64, f64)>,
    ) {
        self.free_contact_gaps_with_back(n, t, s, s_rate, back, out)
    }
    fn mesh_breakpoints(&self, n: usize) -> Vec<f64> {
        GearTrain::mesh_breakpoints(self, n)
    }
    fn mesh_knot_phase(&self, n: usize, nominal: f64) -> f64 {
        GearTrain::mesh_knot_phase(self, n, nominal)
    }
    fn mean_mesh_law(&self, n: usize) -> (f64, f64) {
        GearTrain::mean_mesh_law(self, n)
    }
    fn external_force(&self, _t: f64, out: &mut [f64]) {
        out.copy_from_slice(self.external_forces());
    }
}

/// A running simulation of either kernel. Generic code takes `Driver<M: Drivetrain>`; this
/// enum is the one place where the kernel is chosen ([`with_drivetrain!`]).
// One value per command, moved straight into generic code: boxing would only add a deref.
#[allow(clippy::large_enum_variant)]
pub enum AnySimulation {
    Pair(Simulation),
    Train(TrainSimulation),
}

/// Runs `$body` with `$sim` bound to the `Driver<M>` inside an [`AnySimulation`], for both
/// kernels (the body is monomorphised twice).
#[macro_export]
macro_rules! with_drivetrain {
    ($any:expr, $sim:ident => $body:expr) => {
        match $any {
            $crate::model::AnySimulation::Pair($sim) => $body,
            $crate::model::AnySimulation::Train($sim) => $body,
        }
    };
}

/// Anything that names a scene: the analyses take the resolved [`Scene`], or the single-pair
/// kernel's [`PairScene`] (lifted into the scene it is).
pub trait SceneSource {
    fn to_scene(&self) -> Scene;
}

impl SceneSource for Scene {
    fn to_scene(&self) -> Scene {
        self.clone()
    }
}

impl SceneSource for PairScene {
    fn to_scene(&self) -> Scene {
        Scene::from(self)
    }
}

impl Scene {
    /// Nominal speed of the input gear, rad/s.
    pub fn input_speed(&self) -> f64 {
        self.operating.input_speed
    }

    /// The same scene at another nominal input speed, rad/s.
    pub fn set_input_speed(&mut self, speed: f64) {
        self.operating.input_speed = speed;
    }

    /// Assembles the scene's kernel and starts it at `t = 0` from the scene's initial state,
    /// for the analyses of the nominal-speed form (steady states, Floquet, harmonic balance,
    /// sweeps, spectra, run-ups): a scene with `[[port]]` carries its rotation and is refused
    /// with the reason (`docs/ports.md`); `geardyn simulate` takes [`Scene::run`]. The
    /// run's work budget applies (the scene's `solver.work_budget`, else
    /// [`crate::simulation::budget::DEFAULT_RUN_BUDGET`]): to each run of an analysis, a
    /// sweep point starting a new scope ([`crate::simulation::Driver::new_run_scope`]).
    pub fn simulation(&self) -> Result<AnySimulation, String> {
        if let Some(p) = self.ports.first() {
            return Err(format!(
                "scene {:?} has [[port]] ({:?}, ...): its rigid-body rotation is carried and \
                 the mesh phase follows the pinion angle, so the periodic and nominal-speed \
                 analyses do not apply; run it with `geardyn simulate` or as an FMU \
                 (docs/ports.md)",
                self.name, p.name
            ));
        }
        if let Some(b) = self.elements.bodies.first() {
            return Err(format!(
                "scene {:?} has elements ({:?}, ...): its rigid-body rotation is carried and \
                 the mesh phase follows the pinion angle, so the periodic and nominal-speed \
                 analyses do not apply; run it with `geardyn simulate` (docs/ports.md)",
                self.name, b.name
            ));
        }
        let mut sim = self.run()?;
        with_drivetrain!(&mut sim, driver => {
            driver.default_work_budget(crate::simulation::budget::DEFAULT_RUN_BUDGET)
        });
        Ok(sim)
    }

    /// The scene's simulation in any form (nominal speed, or carried rotation with ports).
    pub fn run(&self) -> Result<AnySimulation, String> {
        // The kernel chosen when the scene was read (`crate::scene::kernel`).
        if let Some(why) = crate::model::train::frame::gyroscopic_refusal(self) {
            return Err(why);
        }
        if let Some(why) = crate::model::train::planetary::refusal(self) {
            return Err(why);
        }
        Ok(match self.pair() {
            Some(pair) => AnySimulation::Pair(Simulation::new(&pair)?),
            None => AnySimulation::Train(TrainSimulation::new(self)?),
        })
    }
}

/// The response period of mesh frequencies `f_n` in periods of the first mesh: the least
/// common multiple of the mesh periods, i.e. the fundamental response frequency is the
/// greatest common divisor of the mesh frequencies (Liu 2007 §4.2, notes §3.2). Each ratio
/// `f_n/f_1` is recognised as a fraction `p/q` with `q ≤ 1000` to 1e-12 relative; the result
/// is the least common multiple of the denominators. Incommensurate mesh frequencies have no
/// common period: the message says so.
pub fn response_period_in_mesh_periods(frequencies: &[f64]) -> Result<u64, String> {
    let f1 = frequencies[0];
    let mut k: u64 = 1;
    for (n, &f) in frequencies.iter().enumerate().skip(1) {
        let ratio = f / f1;
        let (_, q) = rational(ratio, 1000).ok_or_else(|| {
            format!(
                "excitation {} (meshes first, then gear revolutions with errors) frequency \
                 {f:e} Hz over mesh 1 frequency {f1:e} Hz = {ratio}: not a ratio of small \
                 integers, so the response is quasi-periodic and has no period",
                n + 1
            )
        })?;
        k = lcm(k, q);
    }
    Ok(k)
}

/// The frequencies the response is periodic in, Hz: the mesh frequencies (mesh 1 first), then
/// the rotation frequencies of gears with manufacturing errors.
pub fn response_frequencies<M: Drivetrain>(model: &M) -> Vec<f64> {
    let mut f: Vec<f64> = (0..model.mesh_count())
        .map(|n| model.mesh_frequency(n))
        .collect();
    f.extend(model.error_frequencies());
    f
}

/// The period of the drivetrain's response at its current input speed, s: the least common
/// multiple of the mesh periods and the revolution periods of gears with errors (with a
/// 25-tooth pinion and a 40-tooth gear both eccentric, the hunting period of 200 mesh cycles).
pub fn response_period<M: Drivetrain>(model: &M) -> Result<f64, String> {
    period_of(model, &response_frequencies(model))
}

/// The period of the parametric excitation, s: the least common multiple of the mesh periods
/// only. Manufacturing errors are a forcing (`docs/errors.md`): they do not enter the
/// homogeneous equations, so the monodromy and Floquet multipliers of a linear system are
/// those of this period.
pub fn parametric_period<M: Drivetrain>(model: &M) -> Result<f64, String> {
    let f: Vec<f64> = (0..model.mesh_count())
        .map(|n| model.mesh_frequency(n))
        .collect();
    period_of(model, &f)
}

fn period_of<M: Drivetrain>(model: &M, f: &[f64]) -> Result<f64, String> {
    if !(f[0] > 0.0) {
        return Err(format!(
            "input speed {} rad/s: a response period needs a positive speed",
            model.input_speed()
        ));
    }
    Ok(response_period_in_mesh_periods(f)? as f64 / f[0])
}

/// The best fraction `p/q` with `q ≤ max_den` within 1e-12 relative of `x > 0` (continued
/// fractions).
fn rational(x: f64, max_den: u64) -> Option<(u64, u64)> {
    let (mut h0, mut h1, mut k0, mut k1) = (0u64, 1u64, 1u64, 0u64);
    let mut r = x;
    for _ in 0..64 {
        let a = r.floor();
        if a > 1e15 {
            break;
        }
        let a = a as u64;
        let (h2, k2) = (a * h1 + h0, a * k1 + k0);
        if k2 > max_den {
            break;
        }
        (h0, h1, k0, k1) = (h1, h2, k1, k2);
        if ((h1 as f64 / k1 as f64) - x).abs() <= 1e-12 * x {
            return Some((h1, k1));
        }
        let frac = r - a as f64;
        if frac <= 0.0 {
            break;
        }
        r = 1.0 / frac;
    }
    None
}

fn gcd(a: u64, b: u64) -> u64 {
    if b == 0 {
        a
    } else {
        gcd(b, a % b)
    }
}

fn lcm(a: u64, b: u64) -> u64 {
    a / gcd(a, b) * b
}

/// Builds a driver for `model` from `y0` with the scene's solver settings (shooting and sweeps
/// restart from states they choose).
pub fn driver_from<M: Drivetrain>(
    model: M,
    y0: &[f64],
    settings: &crate::scene::SolverSettings,
) -> Result<Driver<M>, String> {
    Driver::with_model(model, y0, settings)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn response_period_of_commensurate_meshes() {
        assert_eq!(response_period_in_mesh_periods(&[100.0]).unwrap(), 1);
        assert_eq!(response_period_in_mesh_periods(&[100.0, 60.0]).unwrap(), 5);
        assert_eq!(response_period_in_mesh_periods(&[100.0, 50.0]).unwrap(), 2);
        assert_eq!(
            response_period_in_mesh_periods(&[100.0, 100.0 * 23.0 / 41.0]).unwrap(),
            41
        );
        assert!(response_period_in_mesh_periods(&[1.0, std::f64::consts::PI]).is_err());
    }
}
