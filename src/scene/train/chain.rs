//! The benchmark chains of issue 20: a row of `M + 1` equal spur gears joined by `M` lumped
//! meshes (rectangular stiffness), so that every mesh runs at the same mesh frequency (2000 Hz
//! by default) with staggered mesh phases.
//!
//! With compliant bearings every gear has three DOFs (`x, y, u`): the centre lines zigzag, so
//! every line of action has components along both bearing axes and no translation is omitted;
//! the model has `3(M + 1)` DOFs (6, 15, 27, 51, 99 for 1, 4, 8, 16, 32 meshes). With rigid
//! bearings only the `M + 1` rotations remain. The first and the last gear are coupled to
//! ground torsionally (as the idler of Liu 2007 Table 2.1), which removes the rigid-body mode.
//!
//! The chain is built as scene text and read through the ordinary scene validation, so a chain
//! is a scene like any other ([`ChainSpec::toml`] gives the text; `examples/chain_16.toml` is
//! one). [`ChainContact::ContactLoss`] uses light modal damping and a mesh frequency at which
//! the steady state loses contact on every mesh in every mesh period (checked by
//! `tests/chains.rs`, which counts the contact events); [`ChainContact::Linear`] is the same
//! chain with the linear contact law, whose segments are the `2M` stiffness switches per
//! period.
//!
//! [`ChainSpec::free`] gives the free chain of issue 37 instead ([`ChainLayout::Free`]):
//! 38/55-tooth gears alternating with Liu (2007) Table 2.1 data and no ground coupling, so
//! the train turns freely and its rigid-body mode is removed by the reduction to elastic
//! coordinates (`docs/chains.md`, "Free chains").

use crate::scene::Scene;
use crate::scene::SceneError;

/// Bearings of the gears of a chain.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ChainBearings {
    /// Torsional model: one rotation per gear.
    Rigid,
    /// Compliant bearings: `x, y, u` per gear.
    Compliant,
}

/// Contact law of every mesh of a chain.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ChainContact {
    /// Linear contact (the mesh force may pull): no contact loss, no events.
    Linear,
    /// Contact loss without back-side contact, tuned so that contact is lost every period.
    ContactLoss,
    /// The contact-loss law with nothing that separates the teeth: the free chain
    /// ([`ChainLayout::Free`]) without its STE, so that no loaded mesh separates (issue 37's
    /// "contact-loss law while contact holds"). The grounded chain has no such variant: it
    /// is tuned to lose contact.
    ContactHolds,
}

/// Which chain: the benchmark chain of issue 20 or the free chain of issue 37.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ChainLayout {
    /// Equal 50-tooth gears, the end gears coupled torsionally to ground (issue 20).
    Grounded,
    /// A chain as a user writes it (issue 37): 38- and 55-tooth gears alternating with the
    /// data of Liu (2007) Table 2.1 (pinion and idler: base radii, inertias, masses, bearing
    /// stiffness 1.27e8 N/m, mesh stiffness 2.9831e8 N/m, ε = 0.35, contact ratio 1.504),
    /// no ground coupling, so the train turns freely; [`ChainContact::ContactLoss`] adds a
    /// 15 µm first STE harmonic on every mesh, with which contact is lost.
    Free,
}

/// A benchmark chain (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChainSpec {
    /// Number of meshes `M >= 1` (`M + 1` gears).
    pub meshes: usize,
    pub bearings: ChainBearings,
    pub contact: ChainContact,
    /// Mesh frequency, Hz (every mesh: the gears of a chain mesh at one tooth frequency).
    pub mesh_frequency: f64,
    pub layout: ChainLayout,
}

impl ChainSpec {
    /// A chain of `meshes` meshes at 2000 Hz.
    pub fn new(meshes: usize, bearings: ChainBearings, contact: ChainContact) -> Self {
        ChainSpec {
            meshes,
            bearings,
            contact,
            mesh_frequency: 2000.0,
            layout: ChainLayout::Grounded,
        }
    }

    /// The free chain of `meshes` meshes at 2000 Hz ([`ChainLayout::Free`]).
    pub fn free(meshes: usize, bearings: ChainBearings, contact: ChainContact) -> Self {
        ChainSpec {
            layout: ChainLayout::Free,
            ..ChainSpec::new(meshes, bearings, contact)
        }
    }

    /// Number of DOFs of the chain's model: `3(M + 1)` compliant, `M + 1` rigid.
    pub fn dof(&self) -> usize {
        match self.bearings {
            ChainBearings::Rigid => self.meshes + 1,
            ChainBearings::Compliant => 3 * (self.meshes + 1),
        }
    }

    /// A short name, e.g. `chain_16_compliant_contact_loss` (`free_chain_…` for the free
    /// layout).
    pub fn name(&self) -> String {
        format!(
            "{}chain_{}_{}_{}",
            match self.layout {
                ChainLayout::Grounded => "",
                ChainLayout::Free => "free_",
            },
            self.meshes,
            match self.bearings {
                ChainBearings::Rigid => "rigid",
                ChainBearings::Compliant => "compliant",
            },
            match self.contact {
                ChainContact::Linear => "linear",
                ChainContact::ContactLoss => "contact_loss",
                ChainContact::ContactHolds => "contact_holds",
            }
        )
    }

    /// The chain as scene text (`docs/train.md` format).
    pub fn toml(&self) -> Result<String, SceneError> {
        if self.meshes == 0 {
            return Err(SceneError(
                "chain.meshes = 0: a chain needs at least one mesh".into(),
            ));
        }
        if !(self.mesh_frequency.is_finite() && self.mesh_frequency > 0.0) {
            return Err(SceneError(format!(
                "chain.mesh_frequency = {}: must be finite and > 0 (Hz)",
                self.mesh_frequency
            )));
        }
        if self.layout == ChainLayout::Free {
            return Ok(self.free_toml());
        }
        use std::fmt::Write;
        let m = self.meshes;
        let teeth = 50u32;
        // Heavier gears with compliant bearings: the contact-loss resonance of the chain then
        // lies at 2000 Hz mesh frequency for both bearing models (checked by counting events).
        let scale = match self.bearings {
            ChainBearings::Rigid => INERTIA_SCALE_RIGID,
            ChainBearings::Compliant => INERTIA_SCALE_COMPLIANT,
        };
        let inertia = INERTIA * scale;
        let mass = MASS * scale;
        let (contact, modal_zeta) = match self.contact {
            ChainContact::Linear => ("linear", 0.02),
            ChainContact::ContactLoss => ("contact_loss", CONTACT_LOSS_MODAL_DAMPING),
            ChainContact::ContactHolds => {
                return Err(SceneError(
                    "chain.contact = contact_holds: only on the free chain (ChainSpec::free); \
                     the grounded chain is tuned to lose contact"
                        .into(),
                ))
            }
        };
        let mut s = String::new();
        let _ = writeln!(s, "name = \"{}\"", self.name());
        let _ = writeln!(
            s,
            "description = \"benchmark chain of issue 20: {} equal spur gears, {} lumped \
             rectangular meshes at {} Hz, staggered phases\"\n",
            m + 1,
            m,
            self.mesh_frequency
        );
        let _ = writeln!(
            s,
            "[model]\nbearings = \"{}\"\ninput_rotation = \"ccw\"\nmodal_damping_ratio = {modal_zeta}\n",
            match self.bearings {
                ChainBearings::Rigid => "rigid",
                ChainBearings::Compliant => "compliant",
            }
        );
        for i in 0..=m {
            let _ = writeln!(
                s,
                "[[gear]]\nname = \"g{i}\"\nteeth = {teeth}\nbase_radius = {BASE_RADIUS}\n\
                 inertia = {inertia:?}\nmass = {mass:?}\nbearing_stiffness = [{BEARING}, {BEARING}]"
            );
            if i == 0 || i == m {
                let _ = writeln!(s, "ground_stiffness = {GROUND}");
            }
            s.push('\n');
        }
        let stiffness = (MESH_MEAN, MESH_RATIO, CONTACT_RATIO);
        for n in 0..m {
            write_mesh(&mut s, n, contact, 20.0, stiffness, None);
        }
        self.write_operating(&mut s, teeth);
        Ok(s)
    }
}

impl ChainSpec {
    /// The text of a [`ChainLayout::Free`] chain (after the checks of [`ChainSpec::toml`]).
    fn free_toml(&self) -> String {
        use std::fmt::Write;
        let m = self.meshes;
        let (contact, ste) = match self.contact {
            ChainContact::Linear => ("linear", None),
            ChainContact::ContactLoss => ("contact_loss", Some(FREE_STE)),
            ChainContact::ContactHolds => ("contact_loss", None),
        };
        let mut s = String::new();
        let _ = writeln!(s, "name = \"{}\"", self.name());
        let _ = writeln!(
            s,
            "description = \"free chain of issue 37: {} spur gears of 38 and 55 teeth \
             alternating (Liu 2007 Table 2.1), {} lumped rectangular meshes at {} Hz, staggered \
             phases, no ground coupling\"\n",
            m + 1,
            m,
            self.mesh_frequency
        );
        let _ = writeln!(
            s,
            "[model]\nbearings = \"{}\"\ninput_rotation = \"ccw\"\nmodal_damping_ratio = 0.02\n",
            match self.bearings {
                ChainBearings::Rigid => "rigid",
                ChainBearings::Compliant => "compliant",
            }
        );
        for i in 0..=m {
            let (teeth, radius, inertia, mass) = FREE_GEARS[i % 2];
            let _ = writeln!(
                s,
                "[[gear]]\nname = \"g{i}\"\nteeth = {teeth}\nbase_radius = {radius}\n\
                 inertia = {inertia}\nmass = {mass}\nbearing_stiffness = [{FREE_BEARING}, \
                 {FREE_BEARING}]\n"
            );
        }
        // Liu 2007 Table 2.1's mesh.
        let stiffness = (2.9831e8, 0.35, 1.504);
        for n in 0..m {
            write_mesh(&mut s, n, contact, 21.22, stiffness, ste);
        }
        self.write_operating(&mut s, FREE_GEARS[0].0);
        s
    }

    /// The `[operating]` and `[solver]` tables: the input gear (of `input_teeth`) turning at
    /// the chain's mesh frequency, 100 mesh periods sampled 4 times per period.
    fn write_operating(&self, s: &mut String, input_teeth: u32) {
        use std::fmt::Write;
        let input_speed = std::f64::consts::TAU * self.mesh_frequency / f64::from(input_teeth);
        let _ = writeln!(
            s,
            "[operating]\ninput_speed = {input_speed:?}\ninput_torque = {TORQUE}\n\n\
             [solver]\nmethod = \"auto\"\nstop_time = {:?}\noutput_interval = {:?}",
            100.0 / self.mesh_frequency,
            0.25 / self.mesh_frequency
        );
    }
}

/// The `[[mesh]]` table of mesh `n` of a chain (between gears `g{n}` and `g{n+1}`): lumped,
/// on zigzag centre lines (±30°, so every line of action is oblique to both axes), phases
/// staggered ([`stagger`]), rectangular stiffness `(mean, peak-to-peak ratio, contact
/// ratio)` and an optional first STE harmonic (m).
fn write_mesh(
    s: &mut String,
    n: usize,
    contact: &str,
    pressure_angle: f64,
    (mean, ratio, contact_ratio): (f64, f64, f64),
    ste: Option<f64>,
) {
    use std::fmt::Write;
    let centre = std::f64::consts::FRAC_PI_6 * if n.is_multiple_of(2) { 1.0 } else { -1.0 };
    let _ = writeln!(
        s,
        "[[mesh]]\nname = \"mesh{}\"\npinion = \"g{n}\"\ngear = \"g{}\"\ncontact = \"{contact}\"\n\
         model = \"lumped\"\npressure_angle = {pressure_angle:?}\ncentre_angle = {centre:?}",
        n + 1,
        n + 1
    );
    if n == 0 {
        let _ = writeln!(s, "initial_phase = 0.0");
    } else {
        let _ = writeln!(s, "phase = {}", stagger(n));
    }
    let _ = writeln!(
        s,
        "stiffness = {{ kind = \"rectangular\", mean = {mean:?}, \
         peak_to_peak_ratio = {ratio:?}, contact_ratio = {contact_ratio:?} }}"
    );
    if let Some(e) = ste {
        let _ = writeln!(s, "ste = {{ cos = [{e:e}] }}");
    }
    s.push('\n');
}

/// Teeth, base radius (m), inertia (kg·m²) and mass (kg) of the free chain's gears, even and
/// odd: Liu (2007) Table 2.1's pinion and idler (38 and 55 teeth, Table 3.1).
const FREE_GEARS: [(u32, f64, f64, f64); 2] = [
    (38, 0.04535, 0.002621, 2.2325),
    (55, 0.06564, 0.01091, 4.438),
];
/// Bearing stiffness of the free chain, both axes, N/m (Table 2.1's pinion).
const FREE_BEARING: f64 = 1.27e8;
/// First STE harmonic of every mesh of the free chain with contact loss, m.
const FREE_STE: f64 = 15e-6;

/// Mesh phase of mesh `n` relative to the first, mesh cycles: the fractional parts of
/// `n·(√5 − 1)/2` (golden-ratio staggering, never two meshes in phase).
pub fn stagger(n: usize) -> f64 {
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let x = (n as f64 * g).fract();
    // Round to 1e-6 cycles so the scene text is short and exact.
    (x * 1e6).round() / 1e6
}

const BASE_RADIUS: f64 = 0.06;
const INERTIA: f64 = 0.01;
const MASS: f64 = 4.4;
const BEARING: f64 = 1.5e8;
const GROUND: f64 = 5000.0;
const MESH_MEAN: f64 = 3.0e8;
const MESH_RATIO: f64 = 0.35;
const CONTACT_RATIO: f64 = 1.5;
const TORQUE: f64 = 100.0;
const CONTACT_LOSS_MODAL_DAMPING: f64 = 0.02;
const INERTIA_SCALE_RIGID: f64 = 1.5625;
const INERTIA_SCALE_COMPLIANT: f64 = 2.25;

impl Scene {
    /// A benchmark chain (see [`ChainSpec`]).
    pub fn chain(spec: ChainSpec) -> Result<Scene, SceneError> {
        let text = spec.toml()?;
        Scene::from_toml_str(&text, &format!("chain '{}'", spec.name()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dof_counts_of_the_issue_table() {
        for (m, dof) in [(1, 6), (4, 15), (8, 27), (16, 51), (32, 99)] {
            let spec = ChainSpec::new(m, ChainBearings::Compliant, ChainContact::Linear);
            assert_eq!(spec.dof(), dof);
            let scene = Scene::chain(spec).unwrap();
            let sim = crate::model::train::TrainSimulation::new(&scene).unwrap();
            assert_eq!(sim.state().len(), 2 * dof, "{m} meshes");
            assert_eq!(scene.meshes.len(), m);
            for n in 0..m {
                let f = scene.mesh_frequency(n, scene.operating.input_speed);
                assert!((f - 2000.0).abs() < 1e-9, "mesh {n}: {f} Hz");
            }
        }
        let rigid = ChainSpec::new(8, ChainBearings::Rigid, ChainContact::ContactLoss);
        let sim = crate::model::train::TrainSimulation::new(&Scene::chain(rigid).unwrap());
        assert_eq!(sim.unwrap().state().len(), 2 * 9);
    }

    #[test]
    fn zero_meshes_refused() {
        let e = ChainSpec::new(0, ChainBearings::Rigid, ChainContact::Linear)
            .toml()
            .unwrap_err();
        assert!(e.0.contains("chain.meshes = 0"), "{}", e.0);
    }
}
