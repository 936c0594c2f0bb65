//! The gear pair as an FMI co-simulation model: adapts [`Simulation`] to
//! [`CoSimModel`]. The FMI layer (`src/fmi/`) knows no gear physics; this module is the only
//! place where the two meet.
//!
//! Time: the scene's `t = 0` is the experiment's `startTime` (FMI 2.0.x §2.1.6,
//! `fmi2SetupExperiment`), so the model integrates in local time `τ = t − startTime`, which
//! for the usual `startTime = 0` is the host's time bit for bit.
//!
//! Inputs (`pinion_speed`, `input_torque`, `load_torque`) are held constant over a
//! communication step (`canInterpolateInputs = false`); a change re-anchors the mesh-phase
//! clock at the current time ([`Simulation::set_inputs`]), so the phase stays continuous.
//! Before initialization is finished the inputs are part of the initial operating point: the
//! static initial DTE is computed from them.
//!
//! Parameters are `fixed` (FMI 2.0.x §2.2.7): they change the equations, so they may be set
//! before `fmi2ExitInitializationMode` only; every accepted change rebuilds the simulation so
//! outputs read in initialization mode are consistent.

use crate::fmi::model::{
    Causality as C, CoSimModel, DefaultExperiment, Initial, ModelInfo, StepFailure, VarKind,
    Variability as V, Variable,
};
use crate::fmu_state::ModelSnapshot;
use crate::model::Inputs;
use crate::scene::{ContactLaw, InitialDte, Scene};
use crate::simulation::Simulation;

// Value references: stable per meaning, grouped by causality (gaps leave room to grow).
pub const VR_PINION_INERTIA: u32 = 0;
pub const VR_GEAR_INERTIA: u32 = 1;
pub const VR_PINION_BASE_RADIUS: u32 = 2;
pub const VR_GEAR_BASE_RADIUS: u32 = 3;
pub const VR_DAMPING: u32 = 4;
pub const VR_BACKLASH: u32 = 5;
pub const VR_INITIAL_PHASE: u32 = 6;
pub const VR_INITIAL_DTE_RATE: u32 = 7;
pub const VR_INITIAL_DTE: u32 = 8;
pub const VR_INITIAL_STATIC: u32 = 9;
pub const VR_EQUIVALENT_MASS: u32 = 20;
pub const VR_MEAN_STIFFNESS: u32 = 21;
pub const VR_PINION_SPEED: u32 = 30;
pub const VR_INPUT_TORQUE: u32 = 31;
pub const VR_LOAD_TORQUE: u32 = 32;
/// Outputs in [`crate::model::OUTPUT_NAMES`] order: `VR_OUTPUT0 + i`.
pub const VR_OUTPUT0: u32 = 40;
pub const VR_CONTACT_STATE: u32 = VR_OUTPUT0 + 3;

/// (name, unit, description) of the outputs, in `OUTPUT_NAMES` order (`docs/model.md`).
const OUTPUTS: [(&str, Option<&str>, &str); 7] = [
    (
        "dte",
        Some("m"),
        "Dynamic transmission error x = r_b1*theta1 + r_b2*theta2 along the line of action",
    ),
    ("dte_rate", Some("m/s"), "Rate of the dynamic transmission error"),
    (
        "mesh_force",
        Some("N"),
        "Dynamic mesh force k(p)*delta + c_m*delta' in the current contact state (0 when separated)",
    ),
    (
        "contact_state",
        None,
        "Contact state: 1 drive side, 0 separated, -1 back side",
    ),
    ("mesh_phase", Some("cycle"), "Mesh phase frac(p), in mesh cycles"),
    ("mesh_stiffness", Some("N/m"), "Mesh stiffness k(p) of the current segment"),
    (
        "static_deflection",
        Some("m"),
        "Mean static deflection F_ext / mean stiffness under the current inputs",
    ),
];

/// The model part of `documentation/index.html`, condensed from `docs/model.md` (the
/// specification); the variable table is added by the packager.
const DOCUMENTATION: &str = r#"<h2>Model</h2>
<p>A single-mesh torsional gear pair in the coordinate of the dynamic transmission error (DTE)
<code>x = r_b1&middot;&theta;1 + r_b2&middot;&theta;2</code> (m, along the line of action; positive
when the drive flanks are pressed together). Eliminating the rigid-body mode gives</p>
<pre>m_e x'' + F(x, x', p) = F_ext
m_e   = 1 / (r_b1^2/I1 + r_b2^2/I2)
F_ext = m_e (r_b1 T1/I1 + r_b2 T2/I2)        (T1 = input_torque, T2 = load_torque)</pre>
<p>Mesh stiffness <code>k(p)</code> and static transmission error <code>e(p)</code> are functions of
the mesh phase <code>p</code> (mesh cycles), which advances with the nominal pinion speed input
&Omega;: <code>dp/dt = z1 &Omega; / (2&pi;)</code>. Mesh deflection <code>&delta; = x &minus; e(p)</code>.</p>
<table border="1">
<tr><th>contact law</th><th>drive side (1)</th><th>separated (0)</th><th>back side (&minus;1)</th></tr>
<tr><td>linear</td><td>F = k&delta; + c_m&delta;' always</td><td>&ndash;</td><td>&ndash;</td></tr>
<tr><td>contact_loss</td><td>&delta; &gt; 0: F = k&delta; + c_m&delta;'</td><td>&delta; &le; 0: F = 0</td><td>&ndash;</td></tr>
<tr><td>backlash (clearance 2b)</td><td>&delta; &gt; 0: F = k&delta; + c_m&delta;'</td><td>&minus;2b &le; &delta; &le; 0: F = 0</td><td>&delta; &lt; &minus;2b: F = k(&delta; + 2b) + c_m&delta;'</td></tr>
</table>
<p>Contact changes are located as state events; stiffness switches are landed on exactly.
Scenes with piecewise-constant stiffness are propagated exactly (matrix exponential per linear
segment), others with an adaptive Runge&ndash;Kutta pair (DOP853/DP5) with dense output.</p>
<h2>Co-simulation behaviour</h2>
<ul>
<li><code>fmi2DoStep</code> integrates exactly to <code>tc + h</code> for any positive <code>h</code>; the
inputs are held constant over the step.</li>
<li>The scene's <code>t = 0</code> is the experiment's start time.</li>
<li>Parameters are fixed: they can be set before <code>fmi2ExitInitializationMode</code> only.</li>
<li>FMU state get/set and serialization are supported; directional derivatives, input
interpolation and asynchronous stepping are not.</li>
</ul>
"#;

/// The gear pair behind an FMU instance.
pub struct GearModel {
    vars: Vec<Variable>,
    /// The scene as loaded (restored by `fmi2Reset`).
    base: Scene,
    /// The scene with the parameter and start-input values set so far.
    scene: Scene,
    /// `initial.static_dte` and `initial.dte`, kept apart from `scene.initial_dte` so that a
    /// value set for `initial.dte` survives while the static choice is on.
    static_dte: bool,
    initial_dte: f64,
    sim: Simulation,
    start_time: f64,
    initialized: bool,
}

fn param(name: &str, vr: u32, start: f64, unit: Option<&str>, desc: &str) -> Variable {
    Variable::real(
        name,
        vr,
        C::Parameter,
        V::Fixed,
        Some(Initial::Exact),
        Some(start),
        unit,
        desc,
    )
}

fn calculated(name: &str, vr: u32, unit: &str, desc: &str) -> Variable {
    Variable::real(
        name,
        vr,
        C::CalculatedParameter,
        V::Fixed,
        Some(Initial::Calculated),
        None,
        Some(unit),
        desc,
    )
}

fn input(name: &str, vr: u32, start: f64, unit: &str, desc: &str) -> Variable {
    Variable::real(
        name,
        vr,
        C::Input,
        V::Continuous,
        None,
        Some(start),
        Some(unit),
        desc,
    )
}

/// The variable table of a scene (start values from the scene).
fn variables(scene: &Scene) -> Vec<Variable> {
    let static_x0 = match scene.initial_dte {
        InitialDte::Value(x) => x,
        // The start value of `initial.dte` is informational while `initial.static_dte` is
        // true; show the value the scene's operating point gives.
        InitialDte::Static => Simulation::new(scene).map_or(0.0, |s| s.state()[0]),
    };
    let mut v = vec![
        param(
            "pinion.inertia",
            VR_PINION_INERTIA,
            scene.pinion.inertia,
            Some("kg.m2"),
            "Polar mass moment of inertia of the pinion",
        ),
        param(
            "gear.inertia",
            VR_GEAR_INERTIA,
            scene.gear.inertia,
            Some("kg.m2"),
            "Polar mass moment of inertia of the gear",
        ),
        param(
            "pinion.base_radius",
            VR_PINION_BASE_RADIUS,
            scene.pinion.base_radius,
            Some("m"),
            "Base-circle radius of the pinion",
        ),
        param(
            "gear.base_radius",
            VR_GEAR_BASE_RADIUS,
            scene.gear.base_radius,
            Some("m"),
            "Base-circle radius of the gear",
        ),
        param(
            "mesh.damping",
            VR_DAMPING,
            scene.mesh.damping,
            Some("N.s/m"),
            "Viscous mesh damping c_m (a damping_ratio in the scene is resolved with the scene's inertias and not recomputed when they change)",
        ),
    ];
    if let ContactLaw::Backlash { clearance } = scene.mesh.contact {
        v.push(param(
            "mesh.backlash",
            VR_BACKLASH,
            clearance,
            Some("m"),
            "Total backlash (clearance 2b) along the line of action",
        ));
    }
    v.extend([
        param(
            "mesh.initial_phase",
            VR_INITIAL_PHASE,
            scene.mesh.initial_phase,
            Some("cycle"),
            "Mesh phase p0 at the start time, in mesh cycles",
        ),
        param(
            "initial.dte_rate",
            VR_INITIAL_DTE_RATE,
            scene.initial_dte_rate,
            Some("m/s"),
            "Initial rate of the dynamic transmission error",
        ),
        param(
            "initial.dte",
            VR_INITIAL_DTE,
            static_x0,
            Some("m"),
            "Initial dynamic transmission error (used when initial.static_dte is false)",
        ),
        Variable {
            kind: VarKind::Boolean,
            unit: None,
            ..param(
                "initial.static_dte",
                VR_INITIAL_STATIC,
                f64::from(u8::from(scene.initial_dte == InitialDte::Static)),
                None,
                "true: the initial DTE is the mean static deflection under the inputs at initialization plus the STE at p0; false: initial.dte",
            )
        },
        calculated(
            "mesh.equivalent_mass",
            VR_EQUIVALENT_MASS,
            "kg",
            "Equivalent mass on the line of action 1/(r_b1^2/I1 + r_b2^2/I2)",
        ),
        calculated(
            "mesh.mean_stiffness",
            VR_MEAN_STIFFNESS,
            "N/m",
            "Mean mesh stiffness over one mesh period",
        ),
    ]);
    let mut speed = input(
        "pinion_speed",
        VR_PINION_SPEED,
        scene.operating.pinion_speed,
        "rad/s",
        "Nominal pinion speed; the mesh phase advances with it (z1*speed/2pi mesh cycles per second)",
    );
    speed.min = Some(0.0);
    v.push(speed);
    v.push(input(
        "input_torque",
        VR_INPUT_TORQUE,
        scene.operating.input_torque,
        "N.m",
        "Torque driving the pinion",
    ));
    v.push(input(
        "load_torque",
        VR_LOAD_TORQUE,
        scene.operating.load_torque,
        "N.m",
        "Load torque magnitude on the gear (positive resists the gear's rotation)",
    ));
    for (i, (name, unit, desc)) in OUTPUTS.iter().enumerate() {
        let vr = VR_OUTPUT0 + i as u32;
        let mut o = Variable::real(
            name,
            vr,
            C::Output,
            V::Continuous,
            Some(Initial::Calculated),
            None,
            *unit,
            desc,
        );
        // Direct feedthrough (ModelStructure/Outputs, FMI 2.0.x §2.2.8): the STE rate in the
        // damping term scales with the speed; the static deflection is F_ext / k̄.
        o.depends_on = match *name {
            "mesh_force" => vec![VR_PINION_SPEED],
            "static_deflection" => vec![VR_INPUT_TORQUE, VR_LOAD_TORQUE],
            _ => Vec::new(),
        };
        if vr == VR_CONTACT_STATE {
            o.kind = VarKind::Integer;
            o.variability = V::Discrete;
        }
        v.push(o);
    }
    v
}

/// `field = value` must be finite and > 0 (or >= 0): the messages name the FMU variable.
fn check(name: &str, value: f64, ok: bool, rule: &str) -> Result<(), String> {
    if value.is_finite() && ok {
        Ok(())
    } else {
        Err(format!("parameter '{name}' = {value}: must be {rule}"))
    }
}

impl GearModel {
    /// Builds the model of a validated scene and its description data.
    pub fn new(scene: Scene, guid: String) -> Result<(GearModel, ModelInfo), String> {
        let sim = Simulation::new(&scene)?;
        let info = ModelInfo {
            model_name: scene.name.clone(),
            description: if scene.description.is_empty() {
                "Single-mesh gear pair: dynamic transmission error, mesh force and contact loss (geardyn)".into()
            } else {
                scene.description.clone()
            },
            default_experiment: DefaultExperiment {
                start_time: 0.0,
                stop_time: scene.solver.stop_time,
                step_size: scene.solver.output_interval,
                tolerance: None,
            },
            guid,
            documentation: DOCUMENTATION.to_string(),
        };
        let vars = variables(&scene);
        let initial_dte = vars
            .iter()
            .find(|v| v.value_reference == VR_INITIAL_DTE)
            .and_then(|v| v.start)
            .unwrap_or(0.0);
        let model = GearModel {
            vars,
            static_dte: scene.initial_dte == InitialDte::Static,
            initial_dte,
            base: scene.clone(),
            scene,
            sim,
            start_time: 0.0,
            initialized: false,
        };
        Ok((model, info))
    }

    fn name_of(&self, vr: u32) -> &str {
        self.vars
            .iter()
            .find(|v| v.value_reference == vr)
            .map_or("?", |v| v.name.as_str())
    }

    /// Applies a parameter or start-input value to the scene (validated, nothing clamped)
    /// and rebuilds the simulation; on failure nothing changes.
    fn set_before_init(&mut self, vr: u32, x: f64) -> Result<(), String> {
        let name = self.name_of(vr).to_string();
        let mut scene = self.scene.clone();
        let (mut static_dte, mut initial_dte) = (self.static_dte, self.initial_dte);
        let positive =
            |unit: &str| check(&name, x, x > 0.0, &format!("a finite number > 0 {unit}"));
        match vr {
            VR_PINION_INERTIA => {
                positive("kg.m2")?;
                scene.pinion.inertia = x;
            }
            VR_GEAR_INERTIA => {
                positive("kg.m2")?;
                scene.gear.inertia = x;
            }
            VR_PINION_BASE_RADIUS => {
                positive("m")?;
                scene.pinion.base_radius = x;
            }
            VR_GEAR_BASE_RADIUS => {
                positive("m")?;
                scene.gear.base_radius = x;
            }
            VR_DAMPING => {
                check(&name, x, x >= 0.0, "a finite number >= 0 N.s/m")?;
                scene.mesh.damping = x;
            }
            VR_BACKLASH => {
                positive("m")?;
                scene.mesh.contact = ContactLaw::Backlash { clearance: x };
            }
            VR_INITIAL_PHASE => {
                check(&name, x, true, "finite")?;
                scene.mesh.initial_phase = x;
            }
            VR_INITIAL_DTE_RATE => {
                check(&name, x, true, "finite")?;
                scene.initial_dte_rate = x;
            }
            VR_INITIAL_DTE => {
                check(&name, x, true, "finite")?;
                initial_dte = x;
            }
            VR_INITIAL_STATIC => static_dte = x != 0.0,
            VR_PINION_SPEED => {
                check(&name, x, x >= 0.0, "a finite number >= 0 rad/s")?;
                scene.operating.pinion_speed = x;
            }
            VR_INPUT_TORQUE => scene.operating.input_torque = x,
            VR_LOAD_TORQUE => scene.operating.load_torque = x,
            _ => return Err(format!("no settable variable with value reference {vr}")),
        }
        scene.initial_dte = if static_dte {
            InitialDte::Static
        } else {
            InitialDte::Value(initial_dte)
        };
        let sim = Simulation::new(&scene)
            .map_err(|e| format!("'{name}' = {x}: the model cannot be built: {e}"))?;
        self.scene = scene;
        (self.static_dte, self.initial_dte) = (static_dte, initial_dte);
        self.sim = sim;
        Ok(())
    }

    /// Parameters and start inputs by value reference: what, besides the run-time state,
    /// distinguishes this instance from a freshly instantiated one.
    fn snapshot(&self) -> ModelSnapshot {
        let op = &self.scene.operating;
        let params = self
            .vars
            .iter()
            .filter(|v| v.kind == VarKind::Real && matches!(v.causality, C::Parameter | C::Input))
            .map(|v| {
                let x = match v.value_reference {
                    VR_PINION_SPEED => op.pinion_speed,
                    VR_INPUT_TORQUE => op.input_torque,
                    VR_LOAD_TORQUE => op.load_torque,
                    vr => self.get_real(vr).unwrap_or(f64::NAN),
                };
                (v.value_reference, x)
            })
            .collect();
        ModelSnapshot {
            params,
            static_dte: self.static_dte,
            initial_dte: self.initial_dte,
            start_time: self.start_time,
            initialized: self.initialized,
            sim: self.sim.snapshot(),
        }
    }

    /// Rebuilds the instance from a snapshot: the parameters go through the same checks as
    /// `fmi2SetReal`, then the run-time state is restored. On failure nothing changes.
    fn restore(&mut self, snap: &ModelSnapshot) -> Result<(), String> {
        let mut m = GearModel {
            vars: self.vars.clone(),
            base: self.base.clone(),
            scene: self.base.clone(),
            static_dte: snap.static_dte,
            initial_dte: snap.initial_dte,
            sim: Simulation::new(&self.base)?,
            start_time: snap.start_time,
            initialized: false,
        };
        for &(vr, x) in &snap.params {
            if !self.vars.iter().any(|v| v.value_reference == vr) {
                return Err(format!("the state sets unknown value reference {vr}"));
            }
            m.set_before_init(vr, x)?;
        }
        if !snap.start_time.is_finite() {
            return Err(format!("start time {} is not finite", snap.start_time));
        }
        m.sim.restore(&snap.sim)?;
        m.initialized = snap.initialized;
        *self = m;
        Ok(())
    }

    /// The inputs with one of them replaced.
    fn inputs_with(&self, vr: u32, x: f64) -> Inputs {
        let mut u = self.sim.model().inputs();
        match vr {
            VR_PINION_SPEED => u.pinion_speed = x,
            VR_INPUT_TORQUE => u.input_torque = x,
            _ => u.load_torque = x,
        }
        u
    }
}

impl CoSimModel for GearModel {
    fn variables(&self) -> &[Variable] {
        &self.vars
    }

    fn get_real(&self, vr: u32) -> Result<f64, String> {
        let s = &self.scene;
        let pair = self.sim.model();
        let inputs = pair.inputs();
        Ok(match vr {
            VR_PINION_INERTIA => s.pinion.inertia,
            VR_GEAR_INERTIA => s.gear.inertia,
            VR_PINION_BASE_RADIUS => s.pinion.base_radius,
            VR_GEAR_BASE_RADIUS => s.gear.base_radius,
            VR_DAMPING => s.mesh.damping,
            VR_BACKLASH => match s.mesh.contact {
                ContactLaw::Backlash { clearance } => clearance,
                _ => return Err(format!("no Real variable with value reference {vr}")),
            },
            VR_INITIAL_PHASE => s.mesh.initial_phase,
            VR_INITIAL_DTE_RATE => s.initial_dte_rate,
            VR_INITIAL_DTE => self.initial_dte,
            VR_EQUIVALENT_MASS => pair.equivalent_mass(),
            VR_MEAN_STIFFNESS => pair.mean_stiffness(),
            VR_PINION_SPEED => inputs.pinion_speed,
            VR_INPUT_TORQUE => inputs.input_torque,
            VR_LOAD_TORQUE => inputs.load_torque,
            vr if (VR_OUTPUT0..VR_OUTPUT0 + 7).contains(&vr) && vr != VR_CONTACT_STATE => {
                self.sim.outputs()[(vr - VR_OUTPUT0) as usize]
            }
            _ => return Err(format!("no Real variable with value reference {vr}")),
        })
    }

    fn set_real(&mut self, vr: u32, value: f64) -> Result<(), String> {
        let is_input = matches!(vr, VR_PINION_SPEED | VR_INPUT_TORQUE | VR_LOAD_TORQUE);
        if self.initialized {
            if !is_input {
                // The layer's causality/variability check comes first; this is a safety net.
                return Err(format!(
                    "'{}' is fixed after initialization",
                    self.name_of(vr)
                ));
            }
            let u = self.inputs_with(vr, value);
            self.sim.set_inputs(u);
            Ok(())
        } else {
            self.set_before_init(vr, value)
        }
    }

    fn get_integer(&self, vr: u32) -> Result<i32, String> {
        match vr {
            VR_CONTACT_STATE => Ok(self.sim.model().contact_state() as i32),
            _ => Err(format!("no Integer variable with value reference {vr}")),
        }
    }

    fn get_boolean(&self, vr: u32) -> Result<bool, String> {
        match vr {
            VR_INITIAL_STATIC => Ok(self.static_dte),
            _ => Err(format!("no Boolean variable with value reference {vr}")),
        }
    }

    fn set_boolean(&mut self, vr: u32, value: bool) -> Result<(), String> {
        match vr {
            VR_INITIAL_STATIC if !self.initialized => {
                self.set_before_init(vr, f64::from(u8::from(value)))
            }
            _ => Err(format!(
                "no settable Boolean variable with value reference {vr}"
            )),
        }
    }

    fn setup_experiment(
        &mut self,
        start_time: f64,
        _stop_time: Option<f64>,
        _tolerance: Option<f64>,
    ) -> Result<(), String> {
        // The tolerance of the RK path is a scene setting; a host tolerance is ignored, as
        // FMI 2.0.x §4.2.1 allows for co-simulation.
        self.start_time = start_time;
        Ok(())
    }

    fn exit_initialization(&mut self) -> Result<(), String> {
        self.initialized = true;
        Ok(())
    }

    /// Integrates the native propagator to exactly `t + h` (in local time); it never
    /// evaluates the model beyond that point.
    fn do_step(&mut self, t: f64, h: f64) -> Result<(), StepFailure> {
        let target = ((t + h) - self.start_time).max(self.sim.t());
        match self.sim.advance_to(target) {
            Ok(()) => Ok(()),
            Err(e) => Err(StepFailure::Discard {
                reason: format!("the integrator stopped: {e}"),
                // The propagators hold the last good state when they fail.
                reached: self.start_time + self.sim.t(),
                terminate: true,
            }),
        }
    }

    fn reset(&mut self) -> Result<(), String> {
        let base = self.base.clone();
        self.sim = Simulation::new(&base)?;
        self.static_dte = base.initial_dte == InitialDte::Static;
        self.initial_dte = self
            .vars
            .iter()
            .find(|v| v.value_reference == VR_INITIAL_DTE)
            .and_then(|v| v.start)
            .unwrap_or(0.0);
        self.scene = base;
        self.start_time = 0.0;
        self.initialized = false;
        Ok(())
    }

    fn save_state(&self) -> Vec<u8> {
        crate::fmu_state::encode(&self.snapshot())
    }

    fn load_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        self.restore(&crate::fmu_state::decode(bytes)?)
    }
}
