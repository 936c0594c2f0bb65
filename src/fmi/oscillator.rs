//! A test model for the FMI layer: a linear damped oscillator `m x'' + c x' + k x = F`
//! driven by an input force, integrated with classical RK4 on `n = max(n_min, ceil(h/h_max))`
//! equal substeps per communication step (so every step lands exactly on `t + h`).
//!
//! Not a gear model. It exists so the whole C ABI can be exercised end-to-end by fmpy and
//! libcosimpy before (and independently of) the gear model, and it covers every base type
//! and causality the layer supports. Selected by `test_model = "oscillator"` in the scene
//! file (see [`crate::fmu_entry`]).

use serde::Deserialize;

use super::model::{
    CoSimModel, DefaultExperiment, Initial, ModelInfo, StepFailure, VarKind, Variable,
};
use super::model::{Causality as C, Variability as V};

pub const VR_M: u32 = 0;
pub const VR_K: u32 = 1;
pub const VR_C: u32 = 2;
pub const VR_X0: u32 = 3;
pub const VR_V0: u32 = 4;
pub const VR_H_MAX: u32 = 5;
pub const VR_N_MIN: u32 = 6;
pub const VR_HOLD: u32 = 7;
pub const VR_F: u32 = 10;
pub const VR_X: u32 = 20;
pub const VR_V: u32 = 21;
pub const VR_A: u32 = 22;
pub const VR_SUBSTEPS: u32 = 23;
pub const VR_MOVING: u32 = 24;

/// The scene file of the test model.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OscillatorScene {
    pub test_model: String,
    pub name: String,
    #[serde(default)]
    pub description: String,
    pub parameters: Params,
    pub experiment: Experiment,
}

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Params {
    pub m: f64,
    pub k: f64,
    pub c: f64,
    #[serde(default)]
    pub x0: f64,
    #[serde(default)]
    pub v0: f64,
    pub h_max: f64,
    #[serde(default = "one")]
    pub n_min: i32,
}

fn one() -> i32 {
    1
}

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Experiment {
    #[serde(default)]
    pub start_time: f64,
    pub stop_time: f64,
    pub step_size: f64,
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Values {
    p: Params,
    hold: bool,
    f: f64,
    x: f64,
    v: f64,
    t: f64,
    substeps: i32,
    initialized: bool,
}

pub struct Oscillator {
    vars: Vec<Variable>,
    start: Values,
    s: Values,
}

fn check_param(name: &str, value: f64, ok: bool, rule: &str) -> Result<(), String> {
    if ok && value.is_finite() {
        Ok(())
    } else {
        Err(format!("parameter '{name}' = {value} must be {rule}"))
    }
}

fn validate(p: &Params) -> Result<(), String> {
    check_param("m", p.m, p.m > 0.0, "> 0 kg")?;
    check_param("k", p.k, p.k >= 0.0, ">= 0 N/m")?;
    check_param("c", p.c, p.c >= 0.0, ">= 0 N.s/m")?;
    check_param("x0", p.x0, true, "finite")?;
    check_param("v0", p.v0, true, "finite")?;
    check_param("h_max", p.h_max, p.h_max > 0.0, "> 0 s")?;
    check_param("n_min", f64::from(p.n_min), p.n_min >= 1, ">= 1")?;
    Ok(())
}

impl Oscillator {
    /// Parses and validates the scene; errors name the field and value.
    pub fn from_toml(text: &str, guid: String) -> Result<(Oscillator, ModelInfo), String> {
        let scene: OscillatorScene = toml::from_str(text).map_err(|e| e.to_string())?;
        if scene.test_model != "oscillator" {
            return Err(format!(
                "test_model = '{}' is unknown (known: 'oscillator')",
                scene.test_model
            ));
        }
        validate(&scene.parameters)?;
        let e = scene.experiment;
        if !(e.start_time.is_finite()
            && e.stop_time.is_finite()
            && e.stop_time > e.start_time
            && e.step_size > 0.0
            && e.step_size.is_finite())
        {
            return Err(format!(
                "experiment start_time = {}, stop_time = {}, step_size = {} must be finite with stop_time > start_time and step_size > 0",
                e.start_time, e.stop_time, e.step_size
            ));
        }
        let info = ModelInfo {
            model_name: scene.name.clone(),
            description: if scene.description.is_empty() {
                "Linear damped oscillator driven by an input force (geardyn FMI test model)".into()
            } else {
                scene.description.clone()
            },
            default_experiment: DefaultExperiment {
                start_time: e.start_time,
                stop_time: e.stop_time,
                step_size: e.step_size,
                tolerance: None,
            },
            guid,
        };
        Ok((Oscillator::new(scene.parameters), info))
    }

    pub fn new(p: Params) -> Oscillator {
        let start = Values {
            p,
            hold: false,
            f: 0.0,
            x: p.x0,
            v: p.v0,
            t: 0.0,
            substeps: 0,
            initialized: false,
        };
        Oscillator {
            vars: variables(&p),
            start,
            s: start,
        }
    }

    fn accel(p: &Params, f: f64, x: f64, v: f64) -> f64 {
        (f - p.c * v - p.k * x) / p.m
    }
}

fn variables(p: &Params) -> Vec<Variable> {
    let par = |name, vr, var, start, unit, desc| {
        Variable::real(name, vr, C::Parameter, var, Some(Initial::Exact), Some(start), unit, desc)
    };
    let out = |name, vr, unit, desc| {
        Variable::real(name, vr, C::Output, V::Continuous, Some(Initial::Calculated), None, unit, desc)
    };
    let mut m = par("m", VR_M, V::Fixed, p.m, Some("kg"), "Mass");
    m.min = Some(0.0);
    let mut a = out("a", VR_A, Some("m/s2"), "Acceleration (direct feedthrough of F)");
    a.depends_on = vec![VR_F];
    vec![
        m,
        par("k", VR_K, V::Fixed, p.k, Some("N/m"), "Spring stiffness"),
        par("c", VR_C, V::Tunable, p.c, Some("N.s/m"), "Viscous damping (tunable between steps)"),
        par("x0", VR_X0, V::Fixed, p.x0, Some("m"), "Initial displacement"),
        par("v0", VR_V0, V::Fixed, p.v0, Some("m/s"), "Initial velocity"),
        par("h_max", VR_H_MAX, V::Fixed, p.h_max, Some("s"), "Largest internal RK4 substep"),
        Variable {
            kind: VarKind::Integer,
            ..par("n_min", VR_N_MIN, V::Tunable, f64::from(p.n_min), None, "Minimum number of RK4 substeps per communication step")
        },
        Variable {
            kind: VarKind::Boolean,
            ..par("hold", VR_HOLD, V::Tunable, 0.0, None, "Freeze the state (steps only advance time)")
        },
        Variable::real("F", VR_F, C::Input, V::Continuous, None, Some(0.0), Some("N"), "External force, held constant over a communication step"),
        out("x", VR_X, Some("m"), "Displacement"),
        out("v", VR_V, Some("m/s"), "Velocity"),
        a,
        Variable {
            kind: VarKind::Integer,
            variability: V::Discrete,
            ..out("substeps", VR_SUBSTEPS, None, "RK4 substeps taken in the last communication step")
        },
        Variable {
            kind: VarKind::Boolean,
            variability: V::Discrete,
            ..out("moving_right", VR_MOVING, None, "True while the velocity is positive")
        },
    ]
}

impl CoSimModel for Oscillator {
    fn variables(&self) -> &[Variable] {
        &self.vars
    }

    fn get_real(&self, vr: u32) -> Result<f64, String> {
        let s = &self.s;
        Ok(match vr {
            VR_M => s.p.m,
            VR_K => s.p.k,
            VR_C => s.p.c,
            VR_X0 => s.p.x0,
            VR_V0 => s.p.v0,
            VR_H_MAX => s.p.h_max,
            VR_F => s.f,
            // Before initialization is finished the state follows the (settable) initial
            // conditions, so outputs are consistent in initialization mode.
            VR_X => s.x,
            VR_V => s.v,
            VR_A => Self::accel(&s.p, s.f, s.x, s.v),
            _ => return Err(format!("no Real variable with value reference {vr}")),
        })
    }

    fn set_real(&mut self, vr: u32, value: f64) -> Result<(), String> {
        let mut p = self.s.p;
        match vr {
            VR_M => p.m = value,
            VR_K => p.k = value,
            VR_C => p.c = value,
            VR_X0 => p.x0 = value,
            VR_V0 => p.v0 = value,
            VR_H_MAX => p.h_max = value,
            VR_F => {
                self.s.f = value;
                return Ok(());
            }
            _ => return Err(format!("no settable Real variable with value reference {vr}")),
        }
        validate(&p)?;
        self.s.p = p;
        if !self.s.initialized {
            self.s.x = p.x0;
            self.s.v = p.v0;
        }
        Ok(())
    }

    fn get_integer(&self, vr: u32) -> Result<i32, String> {
        match vr {
            VR_N_MIN => Ok(self.s.p.n_min),
            VR_SUBSTEPS => Ok(self.s.substeps),
            _ => Err(format!("no Integer variable with value reference {vr}")),
        }
    }

    fn set_integer(&mut self, vr: u32, value: i32) -> Result<(), String> {
        match vr {
            VR_N_MIN => {
                let mut p = self.s.p;
                p.n_min = value;
                validate(&p)?;
                self.s.p = p;
                Ok(())
            }
            _ => Err(format!("no settable Integer variable with value reference {vr}")),
        }
    }

    fn get_boolean(&self, vr: u32) -> Result<bool, String> {
        match vr {
            VR_HOLD => Ok(self.s.hold),
            VR_MOVING => Ok(self.s.v > 0.0),
            _ => Err(format!("no Boolean variable with value reference {vr}")),
        }
    }

    fn set_boolean(&mut self, vr: u32, value: bool) -> Result<(), String> {
        match vr {
            VR_HOLD => {
                self.s.hold = value;
                Ok(())
            }
            _ => Err(format!("no settable Boolean variable with value reference {vr}")),
        }
    }

    fn setup_experiment(&mut self, start: f64, _stop: Option<f64>, _tol: Option<f64>) -> Result<(), String> {
        self.s.t = start;
        Ok(())
    }

    fn exit_initialization(&mut self) -> Result<(), String> {
        validate(&self.s.p)?;
        self.s.initialized = true;
        Ok(())
    }

    fn do_step(&mut self, t: f64, h: f64) -> Result<(), StepFailure> {
        let s = self.s;
        let p = s.p;
        let n = (h / p.h_max).ceil().max(f64::from(p.n_min));
        if n > 1e8 {
            return Err(StepFailure::Error(format!(
                "h = {h:e} s needs {n:e} substeps of at most h_max = {:e} s (limit 1e8)",
                p.h_max
            )));
        }
        let n = n as u32;
        let (mut x, mut v) = (s.x, s.v);
        if !s.hold {
            let dt = h / f64::from(n);
            let f = |x: f64, v: f64| (v, Self::accel(&p, s.f, x, v));
            for _ in 0..n {
                let (k1x, k1v) = f(x, v);
                let (k2x, k2v) = f(x + 0.5 * dt * k1x, v + 0.5 * dt * k1v);
                let (k3x, k3v) = f(x + 0.5 * dt * k2x, v + 0.5 * dt * k2v);
                let (k4x, k4v) = f(x + dt * k3x, v + dt * k3v);
                x += dt / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
                v += dt / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
            }
        }
        if !(x.is_finite() && v.is_finite()) {
            // Keep the last valid state so that values at `reached` are consistent.
            return Err(StepFailure::Discard {
                reason: format!("state became non-finite (x = {x}, v = {v}) with F = {}", s.f),
                reached: t,
                terminate: true,
            });
        }
        self.s.x = x;
        self.s.v = v;
        self.s.t = t + h;
        self.s.substeps = n as i32;
        Ok(())
    }

    fn reset(&mut self) -> Result<(), String> {
        self.s = self.start;
        Ok(())
    }

    fn save_state(&self) -> Vec<u8> {
        let s = &self.s;
        let mut out = Vec::with_capacity(13 * 8);
        for x in [s.p.m, s.p.k, s.p.c, s.p.x0, s.p.v0, s.p.h_max, s.f, s.x, s.v, s.t] {
            out.extend_from_slice(&x.to_le_bytes());
        }
        for i in [s.p.n_min, s.substeps, i32::from(s.hold), i32::from(s.initialized)] {
            out.extend_from_slice(&i.to_le_bytes());
        }
        out
    }

    fn load_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        if bytes.len() != 10 * 8 + 4 * 4 {
            return Err(format!("oscillator state must be 96 bytes, got {}", bytes.len()));
        }
        let f = |i: usize| f64::from_le_bytes(bytes[8 * i..8 * i + 8].try_into().unwrap_or([0; 8]));
        let n = |i: usize| {
            let o = 80 + 4 * i;
            i32::from_le_bytes(bytes[o..o + 4].try_into().unwrap_or([0; 4]))
        };
        let p = Params {
            m: f(0),
            k: f(1),
            c: f(2),
            x0: f(3),
            v0: f(4),
            h_max: f(5),
            n_min: n(0),
        };
        validate(&p)?;
        self.s = Values {
            p,
            f: f(6),
            x: f(7),
            v: f(8),
            t: f(9),
            substeps: n(1),
            hold: n(2) != 0,
            initialized: n(3) != 0,
        };
        Ok(())
    }
}
