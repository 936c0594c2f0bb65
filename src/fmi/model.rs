//! The contract between the generic FMI layer and a concrete model.
//!
//! The layer in [`crate::fmi`] knows no physics. It owns the FMI state machine, the
//! causality/variability rules, logging, FMU-state envelopes and the C ABI; a model only
//! provides its variable table ([`Variable`]) and the operations of [`CoSimModel`]. The same
//! table drives the C ABI (value-reference lookup, set rules) and the generated
//! `modelDescription.xml`, so value references cannot drift between the two.

use std::collections::HashSet;

pub use super::attributes::{Causality, Initial, Variability};

/// Base type of a scalar variable (FMI 2.0.x §2.2.7, `ScalarVariable` child element).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VarKind {
    Real,
    Integer,
    Boolean,
}

impl VarKind {
    pub fn as_str(self) -> &'static str {
        match self {
            VarKind::Real => "Real",
            VarKind::Integer => "Integer",
            VarKind::Boolean => "Boolean",
        }
    }
}

/// One row of the variable table: everything the C ABI and `modelDescription.xml` need.
#[derive(Debug, Clone, PartialEq)]
pub struct Variable {
    /// Unique name (structured naming convention, e.g. `mesh.dte`).
    pub name: String,
    pub value_reference: u32,
    pub kind: VarKind,
    pub causality: Causality,
    pub variability: Variability,
    /// Must be `None` for inputs (FMI 2.0.x §2.2.7 table of legal combinations).
    pub initial: Option<Initial>,
    /// Start value; required for inputs and for `initial = exact | approx`, forbidden for
    /// `initial = calculated`. Integer/Boolean start values are stored as `f64` (0/1 for
    /// Boolean) and written as integers.
    pub start: Option<f64>,
    /// SI unit symbol (`m`, `N/m`, `rad/s`, …). Must be known to
    /// [`crate::fmi::description::base_unit`]; `None` for dimensionless quantities.
    pub unit: Option<String>,
    /// Inclusive bounds the layer checks before a set reaches the model (Real only).
    pub min: Option<f64>,
    pub max: Option<f64>,
    /// Shown by every FMI tool; required (non-empty) for every variable.
    pub description: String,
    /// For outputs: value references of the inputs this output depends on directly
    /// (`ModelStructure/Outputs/Unknown/@dependencies`). Empty = no direct feedthrough.
    pub depends_on: Vec<u32>,
}

impl Variable {
    /// A Real variable with no bounds and no dependencies; adjust fields afterwards.
    /// The arguments are the `ScalarVariable` attributes in the order of the schema.
    #[allow(clippy::too_many_arguments)]
    pub fn real(
        name: &str,
        value_reference: u32,
        causality: Causality,
        variability: Variability,
        initial: Option<Initial>,
        start: Option<f64>,
        unit: Option<&str>,
        description: &str,
    ) -> Variable {
        Variable {
            name: name.to_string(),
            value_reference,
            kind: VarKind::Real,
            causality,
            variability,
            initial,
            start,
            unit: unit.map(str::to_string),
            min: None,
            max: None,
            description: description.to_string(),
            depends_on: Vec::new(),
        }
    }
}

impl Variable {
    /// Whether `value` may be given to this variable: finite for Real, within `[min, max]`.
    /// The layer's value check of every `fmi2SetXXX`, and of values a model restores from
    /// an FMU state outside the setters (issue 17: a restored state must hold nothing a
    /// setter would refuse).
    pub fn check_value(&self, value: f64) -> Result<(), String> {
        let (name, vr) = (&self.name, self.value_reference);
        if self.kind == VarKind::Real && !value.is_finite() {
            return Err(format!("'{name}' (vr {vr}) = {value} is not finite"));
        }
        if self.min.is_some_and(|m| value < m) || self.max.is_some_and(|m| value > m) {
            return Err(format!(
                "'{name}' (vr {vr}) = {value} outside [{}, {}]",
                self.min.unwrap_or(f64::NEG_INFINITY),
                self.max.unwrap_or(f64::INFINITY)
            ));
        }
        Ok(())
    }
}

/// Why `do_step` did not complete the communication step.
#[derive(Debug, Clone, PartialEq)]
pub enum StepFailure {
    /// Only part of the step was done (`fmi2Discard`, FMI 2.0.x §4.2.2): the state is valid at
    /// `reached` (`tc <= reached < tc + h`). `terminate` is the model ending the run itself
    /// (reported through `fmi2GetBooleanStatus(fmi2Terminated)`, FMI 2.0.5 §4.2.3), e.g. a
    /// drive cycle that is over: hosts (fmpy, the Reference-FMUs' master, `geardyn run`) take
    /// it as a normal end. A failure (the integrator stopped, a non-finite state) is never a
    /// termination: it stays `false`, so the host reports it as one (issue 39).
    Discard {
        reason: String,
        reached: f64,
        terminate: bool,
    },
    /// The step failed and the state is unusable (`fmi2Error`); the master may only
    /// `fmi2Reset` or `fmi2SetFMUstate`.
    Error(String),
}

/// A co-simulation model as the FMI layer sees it. Physics-free on purpose.
///
/// The layer guarantees before each call: the instance is in a state where the call is
/// allowed (FMI 2.0.x §4.2.4), value references exist and have the right base type, a set
/// respects causality/variability/initial (§2.2.7) and `min`/`max`, Real values are finite.
/// The model still validates physics (e.g. a mass must be positive) and returns a message
/// that names the variable and the value.
pub trait CoSimModel: Send {
    /// The variable table. Must not change during the lifetime of the model.
    fn variables(&self) -> &[Variable];

    /// Current value of a Real variable. In initialization mode outputs must already be
    /// consistent with the parameters and inputs set so far (compute lazily).
    fn get_real(&self, vr: u32) -> Result<f64, String>;
    /// Several Real variables at once (`fmi2GetReal` with a vector; the layer has checked
    /// that every value reference is a Real variable). The default asks [`Self::get_real`]
    /// for each; a model whose outputs are read after every step may answer them in one
    /// pass. The first failure is the call's error.
    fn get_reals(&self, vrs: &[u32], out: &mut [f64]) -> Result<(), String> {
        for (&vr, slot) in vrs.iter().zip(out.iter_mut()) {
            *slot = self.get_real(vr)?;
        }
        Ok(())
    }
    fn set_real(&mut self, vr: u32, value: f64) -> Result<(), String>;
    /// Several Real variables at once (`fmi2SetReal` with a vector; the layer has checked
    /// every value first). The default sets them in order with [`Self::set_real`]; a model
    /// whose inputs are set at every step may apply them in one change. The first failure is
    /// the call's error.
    fn set_reals(&mut self, vrs: &[u32], values: &[f64]) -> Result<(), String> {
        for (&vr, &x) in vrs.iter().zip(values) {
            self.set_real(vr, x)?;
        }
        Ok(())
    }

    fn get_integer(&self, vr: u32) -> Result<i32, String> {
        Err(format!(
            "model has no Integer variable with value reference {vr}"
        ))
    }
    fn set_integer(&mut self, vr: u32, _value: i32) -> Result<(), String> {
        Err(format!(
            "model has no Integer variable with value reference {vr}"
        ))
    }
    fn get_boolean(&self, vr: u32) -> Result<bool, String> {
        Err(format!(
            "model has no Boolean variable with value reference {vr}"
        ))
    }
    fn set_boolean(&mut self, vr: u32, _value: bool) -> Result<(), String> {
        Err(format!(
            "model has no Boolean variable with value reference {vr}"
        ))
    }

    /// The model's start time and initialization stage.
    fn lifecycle_mut(&mut self) -> &mut Lifecycle;

    /// `fmi2SetupExperiment`: the start time becomes the model time. A host tolerance is
    /// ignored, as FMI 2.0.x §4.2.1 allows for co-simulation (a model's tolerances are its
    /// own settings).
    fn setup_experiment(
        &mut self,
        start_time: f64,
        _stop_time: Option<f64>,
        _tolerance: Option<f64>,
    ) -> Result<(), String> {
        self.lifecycle_mut().start_time = start_time;
        Ok(())
    }

    /// `fmi2ExitInitializationMode`: parameters are final; build whatever depends on them.
    fn exit_initialization(&mut self) -> Result<(), String> {
        self.lifecycle_mut().initialized = true;
        Ok(())
    }

    /// Integrate from `t` to exactly `t + h` (computed once as `t + h` in `f64`), inputs held
    /// constant over the step. `h > 0` and finite; uneven steps are normal. On success the
    /// model time is `t + h`.
    fn do_step(&mut self, t: f64, h: f64) -> Result<(), StepFailure>;

    /// `fmi2Reset`: back to the state right after instantiation (start values).
    fn reset(&mut self) -> Result<(), String>;

    /// Everything needed to continue bit-identically: continuous and discrete states, time,
    /// parameters, inputs, initialization stage. The layer wraps it in a versioned,
    /// checksummed envelope ([`crate::fmi::blob`]); the model only sees its own bytes.
    /// `&mut`: the model may drop what it learned from the run so far (caches whose content
    /// reaches the last bits of the results), so that the continuation from the captured state
    /// is the same as from the restored one.
    fn save_state(&mut self) -> Vec<u8>;
    fn load_state(&mut self, bytes: &[u8]) -> Result<(), String>;

    /// What the model offers beyond zero-order hold (FMI 2.0.x §4.3.1, `canInterpolateInputs`
    /// and `maxOutputDerivativeOrder`). Written into `modelDescription.xml`; the layer refuses
    /// the calls of a capability the model does not declare. Must not change during the
    /// lifetime of the model. Default: neither.
    fn capabilities(&self) -> Capabilities {
        Capabilities::default()
    }

    /// `fmi2SetRealInputDerivatives` of `order` (1 to
    /// [`Capabilities::max_input_derivative_order`]) for one continuous Real input (the layer
    /// has checked the order, the causality, variability and finiteness): the input's
    /// derivative of that order from the current communication point `tc` on. The model
    /// stores it and, during the next `do_step` only, uses the Taylor polynomial
    /// `u(t) = u + Σₖ u⁽ᵏ⁾·(t − tc)ᵏ/k!` (FMI 2.0.x §4.2.1); at the end of that step the
    /// input's value becomes the polynomial's end value and every derivative 0 (zero-order
    /// hold again until the master sets others). The derivatives are part of the FMU state.
    fn set_input_derivative(&mut self, vr: u32, _order: u32, _value: f64) -> Result<(), String> {
        Err(format!(
            "input value reference {vr}: inputs are held constant over a step"
        ))
    }
    /// Several input derivatives at once (`fmi2SetRealInputDerivatives` with a vector; the
    /// layer has checked every value reference, order and value first; `orders` as the call
    /// passes them, each 1 to [`Capabilities::max_input_derivative_order`]). The default sets
    /// them in order with [`Self::set_input_derivative`]; a model for which a change of its
    /// inputs' derivatives is costly may apply the call's values in one change, as the
    /// derivatives of the next step together (a master sets them all before every step).
    /// The first failure is the call's error.
    fn set_input_derivatives(
        &mut self,
        vrs: &[u32],
        orders: &[i32],
        values: &[f64],
    ) -> Result<(), String> {
        for ((&vr, &order), &x) in vrs.iter().zip(orders).zip(values) {
            self.set_input_derivative(vr, order as u32, x)?;
        }
        Ok(())
    }

    /// `fmi2GetRealOutputDerivatives` of order 1 for one Real output (the layer has checked
    /// the order and the causality): `dy/dt` at the current time, with the input rates
    /// stored by [`Self::set_input_derivative`] (0 when none were set).
    fn output_derivative(&self, vr: u32) -> Result<f64, String> {
        Err(format!(
            "output value reference {vr}: the model provides no output derivatives"
        ))
    }
    /// Several first-order output derivatives at once (the layer has checked each value
    /// reference and order). The default asks [`Self::output_derivative`] for each; a model
    /// whose derivatives share a costly evaluation (the state derivative) may make it once.
    fn output_derivatives(&self, vrs: &[u32], out: &mut [f64]) -> Result<(), String> {
        for (&vr, slot) in vrs.iter().zip(out.iter_mut()) {
            *slot = self.output_derivative(vr)?;
        }
        Ok(())
    }
}

/// A model's co-simulation capabilities beyond zero-order hold ([`CoSimModel::capabilities`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Capabilities {
    /// `canInterpolateInputs`: first-order input derivatives are used during a step.
    pub can_interpolate_inputs: bool,
    /// The highest order of `fmi2SetRealInputDerivatives` the model takes when it
    /// interpolates (FMI 2.0 declares none in `modelDescription.xml`; a higher order is
    /// refused, naming the input): 1 unless the model says more.
    pub max_input_derivative_order: u32,
    /// `maxOutputDerivativeOrder`: 0 or 1 (the layer supports first-order derivatives).
    pub max_output_derivative_order: u32,
    /// The Real variable that holds the time of the model's next known switch of its
    /// equations (a stiffness knot, where its outputs' slopes jump), announced in the vendor
    /// annotation `<SwitchTimes variable=…>`: geardyn's master ends a controlled step there
    /// (`host::system::controlled`). FMI 2.0 has no such notion (FMI 3.0's event mode).
    pub switch_time: Option<u32>,
}

/// Where a model instance stands in its life cycle: the start time of `fmi2SetupExperiment`
/// (the model time before the first step) and whether `fmi2ExitInitializationMode` has
/// made the parameters final (FMI 2.0.x §4.2.4). A fresh instance and `fmi2Reset` start from
/// the default.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Lifecycle {
    pub start_time: f64,
    pub initialized: bool,
}

/// `DefaultExperiment` element (FMI 2.0.x §2.2.5). For co-simulation `step_size` is the
/// preferred communication step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DefaultExperiment {
    pub start_time: f64,
    pub stop_time: f64,
    pub step_size: f64,
    pub tolerance: Option<f64>,
}

/// Description-level data the factory derives from the scene together with the model.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelInfo {
    /// `modelName`; the `modelIdentifier` is derived from it by [`model_identifier`].
    pub model_name: String,
    pub description: String,
    pub default_experiment: DefaultExperiment,
    /// Derived from the scene bytes and the crate version ([`crate::fmi::blob::guid`]).
    pub guid: String,
    /// HTML fragment for `documentation/index.html` (FMI 2.0.x §2.3): what the model is and
    /// its equations. The layer adds the variable table.
    pub documentation: String,
}

/// What the factory returns: a ready model plus its description data.
pub struct LoadedModel {
    pub model: Box<dyn CoSimModel>,
    pub info: ModelInfo,
}

/// `modelIdentifier` from a model name: a C identifier (FMI 2.0.x §4.3.1, "short class name
/// according to C syntax"), which is also the name of the shared library in the FMU.
pub fn model_identifier(model_name: &str) -> String {
    let mut id: String = model_name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if id.is_empty() || id.starts_with(|c: char| c.is_ascii_digit()) {
        id.insert(0, '_');
    }
    id
}

/// Checks a variable table against the legal combinations of FMI 2.0.x §2.2.7 and the
/// layer's own requirements (unique names and value references, a description everywhere).
/// Used at instantiation and before packaging, so a bad table never ships.
pub fn validate_variables(vars: &[Variable]) -> Result<(), String> {
    use Causality as C;
    use Variability as V;
    let mut names = HashSet::new();
    let mut refs = HashSet::new();
    for v in vars {
        let who = format!("variable '{}' (vr {})", v.name, v.value_reference);
        if v.name.is_empty() {
            return Err(format!(
                "variable with vr {} has an empty name",
                v.value_reference
            ));
        }
        if !names.insert(v.name.as_str()) {
            return Err(format!("{who}: duplicate name"));
        }
        // Value references are unique per base type in FMI 2.0; we make them unique overall
        // so that a log line `#r<vr>#` or a vr in an error message is unambiguous.
        if !refs.insert(v.value_reference) {
            return Err(format!("{who}: duplicate value reference"));
        }
        if v.description.trim().is_empty() {
            return Err(format!("{who}: missing description"));
        }
        if v.kind != VarKind::Real && v.variability == V::Continuous {
            return Err(format!("{who}: only Real variables may be continuous"));
        }
        if v.kind != VarKind::Real && (v.unit.is_some() || v.min.is_some() || v.max.is_some()) {
            return Err(format!(
                "{who}: unit/min/max are only supported on Real variables"
            ));
        }
        let legal = match v.causality {
            C::Parameter => {
                matches!(v.variability, V::Fixed | V::Tunable) && v.initial == Some(Initial::Exact)
            }
            C::CalculatedParameter => {
                matches!(v.variability, V::Fixed | V::Tunable)
                    && matches!(v.initial, Some(Initial::Calculated | Initial::Approx))
            }
            C::Input => matches!(v.variability, V::Discrete | V::Continuous) && v.initial.is_none(),
            C::Output => match v.variability {
                V::Constant => v.initial == Some(Initial::Exact),
                V::Discrete | V::Continuous => v.initial.is_some(),
                _ => false,
            },
            // The independent variable (time) is not part of an exported table.
            C::Independent => false,
            C::Local => match v.variability {
                V::Constant => v.initial == Some(Initial::Exact),
                V::Fixed | V::Tunable => {
                    matches!(v.initial, Some(Initial::Calculated | Initial::Approx))
                }
                V::Discrete | V::Continuous => v.initial.is_some(),
            },
        };
        if !legal {
            return Err(format!(
                "{who}: illegal combination causality={} variability={} initial={}",
                v.causality.as_str(),
                v.variability.as_str(),
                v.initial.map_or("(none)", Initial::as_str)
            ));
        }
        let needs_start =
            v.causality == C::Input || matches!(v.initial, Some(Initial::Exact | Initial::Approx));
        if needs_start && v.start.is_none() {
            return Err(format!("{who}: a start value is required"));
        }
        if !needs_start && v.start.is_some() {
            return Err(format!(
                "{who}: must not have a start value (initial=calculated)"
            ));
        }
        if let Some(s) = v.start {
            if !s.is_finite() {
                return Err(format!("{who}: start value {s} is not finite"));
            }
            if v.min.is_some_and(|m| s < m) || v.max.is_some_and(|m| s > m) {
                return Err(format!("{who}: start value {s} outside [min, max]"));
            }
            if v.kind == VarKind::Boolean && s != 0.0 && s != 1.0 {
                return Err(format!(
                    "{who}: Boolean start value must be 0 or 1, got {s}"
                ));
            }
            if v.kind == VarKind::Integer && (s.fract() != 0.0 || s.abs() > i32::MAX as f64) {
                return Err(format!(
                    "{who}: Integer start value {s} is not a 32-bit integer"
                ));
            }
        }
        if v.causality != C::Output && !v.depends_on.is_empty() {
            return Err(format!("{who}: only outputs declare dependencies"));
        }
        for d in &v.depends_on {
            let ok = vars
                .iter()
                .any(|u| u.value_reference == *d && u.causality == C::Input);
            if !ok {
                return Err(format!("{who}: dependency vr {d} is not an input"));
            }
        }
    }
    Ok(())
}

/// The input of `fmi2SetRealInputDerivatives` over a step (FMI 2.0.x §4.2.1, the Taylor
/// polynomial of [`CoSimModel::set_input_derivative`]): `u + u'·s + u''·s²/2 + u'''·s³/6` with
/// `higher = [u'', u''']`, `s = t − tc`. A ramp alone (`higher` zero) is `u + u'·s`, bit for
/// bit as before the higher orders. The models evaluate their inputs by it, and the master the
/// polynomials it gives (`host::system::extrapolation`).
pub fn input_polynomial(u: f64, du: f64, higher: [f64; 2], s: f64) -> f64 {
    if higher == [0.0; 2] {
        return u + du * s;
    }
    u + s * (du + s * (higher[0] / 2.0 + s * higher[1] / 6.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identifier_is_c_syntax() {
        assert_eq!(model_identifier("Gear Mesh-1"), "Gear_Mesh_1");
        assert_eq!(model_identifier("1stage"), "_1stage");
        assert_eq!(model_identifier(""), "_");
    }

    #[test]
    fn illegal_combinations_are_rejected() {
        let ok = Variable::real(
            "k",
            0,
            Causality::Parameter,
            Variability::Fixed,
            Some(Initial::Exact),
            Some(1.0),
            Some("N/m"),
            "stiffness",
        );
        assert!(validate_variables(std::slice::from_ref(&ok)).is_ok());
        let mut bad = ok.clone();
        bad.variability = Variability::Continuous;
        assert!(validate_variables(&[bad])
            .unwrap_err()
            .contains("illegal combination"));
        let mut bad = ok.clone();
        bad.start = None;
        assert!(validate_variables(&[bad])
            .unwrap_err()
            .contains("start value"));
        let mut dup = ok.clone();
        dup.name = "k2".into();
        assert!(validate_variables(&[ok.clone(), dup])
            .unwrap_err()
            .contains("duplicate value reference"));
        let mut bad = ok;
        bad.description.clear();
        assert!(validate_variables(&[bad])
            .unwrap_err()
            .contains("description"));
    }
}
