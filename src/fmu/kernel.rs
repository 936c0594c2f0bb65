//! What a gear model adds to the one FMU adapter [`crate::fmu::Adapter`]: its scene format,
//! its variable table, how the table's value references map onto the scene, the inputs and
//! the outputs, and the byte layout of its FMU-state payload. Everything else (the life
//! cycle, the rebuild on every parameter change, the output cache, stepping, reset, the
//! snapshot and its checks) is the adapter's and the same for every kernel.

use std::cell::Ref;

use crate::fmi::model::{input_polynomial, Variable};
use crate::fmu::payload::Snapshot;
use crate::scene::SolverSettings;
use crate::simulation::{DrivenModel, Driver};

/// The model part of an FMU state of kernel `K`.
pub type KernelSnapshot<K> = Snapshot<<K as Kernel>::SimState, <K as Kernel>::Extra>;

/// One gear model as seen by the FMU adapter. Implemented by [`crate::fmu::pair::Pair`] and
/// [`crate::fmu::drivetrain::Drivetrain`]; the functions are associated (no `self`): a kernel
/// is a type, its state lives in the adapter.
pub trait Kernel: 'static {
    /// The model the shared [`Driver`] integrates.
    type Model: DrivenModel + Send;
    /// The values of the parameters and start inputs set so far: the scene, and whatever the
    /// variable table holds apart from it. Every accepted change rebuilds the simulation
    /// from it.
    type Settings: Clone + Send;
    /// What [`Self::Settings`] holds besides the values of its Real parameters, so an FMU
    /// state carries it next to the parameter list (the pair's initial-DTE choice).
    type Extra: Clone + PartialEq;
    /// The driver's snapshot of a run ([`crate::simulation::SimState`] and its drivetrain
    /// counterpart).
    type SimState;

    /// The `description` of a scene without one.
    const FALLBACK_DESCRIPTION: &'static str;
    /// The model part of `documentation/index.html` (the adapter adds its co-simulation
    /// behaviour).
    const DOCUMENTATION: &'static str;
    /// The documentation's item on the start of a run.
    const START_DOCUMENTATION: &'static str;
    /// Value references of the inputs: speed, input torque, load torque, then any the kernel
    /// adds (a drivetrain's speed ports); a scene's variable table may leave some out (the
    /// input torque of a speed port), and the adapter reads only those it has.
    const INPUTS: &'static [u32];
    /// Value reference of the first output; output `i` of [`Self::outputs`] is
    /// `OUTPUT0 + i`, and nothing above the outputs has a value reference.
    const OUTPUT0: u32;

    /// Parses and validates a scene of this kernel's format (messages name the field and
    /// value) into the settings of a fresh instance.
    fn load(text: &str, origin: &str) -> Result<Self::Settings, String>;
    /// The scene's name, description and solver settings.
    fn header(s: &Self::Settings) -> (&str, &str, &SolverSettings);
    /// The solver settings, for the adapter's own parameters (the work budget).
    fn solver_mut(s: &mut Self::Settings) -> &mut SolverSettings;
    /// A simulation of the settings, at `t = 0` in its initial state.
    fn build(s: &Self::Settings) -> Result<Driver<Self::Model>, String>;
    /// The variable table (start values from the settings). Called once per instance.
    fn variables(s: &Self::Settings, sim: &Driver<Self::Model>) -> Result<Vec<Variable>, String>;

    /// Applies one parameter or start-input value `name = x` to the settings, validated and
    /// nothing clamped (the build that follows checks the combination).
    fn apply(s: &mut Self::Settings, name: &str, vr: u32, x: f64) -> Result<(), String>;
    /// The value of a Real parameter or calculated parameter (`None`: no such variable).
    fn parameter(s: &Self::Settings, model: &Self::Model, vr: u32) -> Option<f64>;
    /// The value of a Boolean parameter (`None`: no such variable); it is set, before
    /// initialization only, through [`Self::apply`] as 0 or 1.
    fn boolean(_s: &Self::Settings, _vr: u32) -> Option<bool> {
        None
    }

    /// The inputs the settings start from, in [`Self::INPUTS`] order.
    fn start_inputs(s: &Self::Settings) -> Vec<f64>;
    /// The current inputs, in [`Self::INPUTS`] order.
    fn inputs(model: &Self::Model) -> Vec<f64>;
    /// New inputs after initialization, from the current time on; on failure nothing changes.
    fn set_inputs(sim: &mut Driver<Self::Model>, u: &[f64]) -> Result<(), String>;
    /// The outputs at the current time, in value-reference order (cleared first).
    fn outputs(sim: &Driver<Self::Model>, out: &mut Vec<f64>);
    /// Output `k` (an index into [`Kernel::outputs`]) on its own, where the kernel evaluates
    /// it without the others (the same value); `None` otherwise. A master that refreshes a
    /// compliance's efforts after its new inputs reads only those (the drivetrain's speed-port
    /// torques), and the whole vector costs a right-hand side and every mesh's quantities.
    fn output(_sim: &Driver<Self::Model>, _k: usize) -> Option<f64> {
        None
    }

    fn extra(s: &Self::Settings) -> Self::Extra;
    fn set_extra(s: &mut Self::Settings, extra: &Self::Extra);
    fn sim_state(sim: &Driver<Self::Model>) -> Self::SimState;
    /// Whether the FMU provides first-order output derivatives
    /// (`maxOutputDerivativeOrder = 1`, FMI 2.0.x §4.2.1; [`Self::output_rate`]).
    fn output_derivatives(_s: &Self::Settings) -> bool {
        false
    }
    /// `d/dt` of output `k` at the current time; `outputs` are the current outputs.
    fn output_rate(_sim: &Driver<Self::Model>, k: usize, _outputs: &[f64]) -> Result<f64, String> {
        Err(format!(
            "output {k}: the model provides no output derivatives"
        ))
    }
    /// `d/dt` of the outputs `ks` at the current time into `out` ([`Self::output_rate`] of
    /// each; a kernel whose rates share the state derivative may evaluate it once).
    /// `outputs` gives the current outputs, evaluated only when first asked for (a rate that
    /// does not need them, a speed port torque's, costs no evaluation of the others).
    fn output_rates<'a>(
        sim: &Driver<Self::Model>,
        ks: &[usize],
        outputs: &dyn Fn() -> Ref<'a, [f64]>,
        out: &mut [f64],
    ) -> Result<(), String> {
        for (&k, slot) in ks.iter().zip(out.iter_mut()) {
            *slot = Self::output_rate(sim, k, &outputs())?;
        }
        Ok(())
    }
    /// The highest order of input derivatives the inputs of [`Self::rate_inputs`] take
    /// ([`crate::fmi::model::Capabilities::max_input_derivative_order`]).
    const MAX_INPUT_DERIVATIVE_ORDER: u32 = 1;
    /// Which inputs take input derivatives over the next step, in [`Self::INPUTS`] order
    /// (`canInterpolateInputs` when any does, FMI 2.0.x §4.2.1); none by default.
    fn rate_inputs(_s: &Self::Settings) -> Vec<bool> {
        vec![false; Self::INPUTS.len()]
    }
    /// The input derivatives of orders 1–3 set for the next step, in [`Self::INPUTS`]
    /// order (0: held).
    fn input_rates(_model: &Self::Model) -> Vec<[f64; 3]> {
        vec![[0.0; 3]; Self::INPUTS.len()]
    }
    /// Sets input derivatives of orders 1–3 from the current time on: the model reads the
    /// Taylor polynomial `u + u'·s + u''·s²/2 + u'''·s³/6`, `s = t − tc`, until they change
    /// (only for the inputs of [`Self::rate_inputs`], orders up to
    /// [`Self::MAX_INPUT_DERIVATIVE_ORDER`]).
    fn set_input_rates(_sim: &mut Driver<Self::Model>, _du: &[[f64; 3]]) -> Result<(), String> {
        Err("the model takes no input derivatives".into())
    }
    /// Whether a step leaves the inputs as they are (no rate set, nothing the model moves
    /// over a step): the common case, in which a step only advances the model.
    fn inputs_held(model: &Self::Model) -> bool {
        Self::input_rates(model).iter().all(|&r| r == [0.0; 3])
    }
    /// The inputs at the end of a step of `dt` that started from inputs `u` with derivatives
    /// `du`: their Taylor polynomials ([`input_polynomial`]), unless the model moves an input otherwise
    /// over the step (a speed port's neighbour angle follows its speed).
    fn inputs_after(_sim: &Driver<Self::Model>, u: &[f64], du: &[[f64; 3]], dt: f64) -> Vec<f64> {
        u.iter()
            .zip(du)
            .map(|(&u, &du)| input_polynomial(u, du[0], [du[1], du[2]], dt))
            .collect()
    }
    /// The inputs of a run state, in [`Self::INPUTS`] order, as the variables read them
    /// (the settings say how: a drivetrain's output port reads minus the load torque).
    fn sim_inputs(s: &Self::Settings, state: &Self::SimState) -> Vec<f64>;
    /// Continues from a run state of a simulation of the same settings; on failure nothing
    /// changes.
    fn restore_sim(sim: &mut Driver<Self::Model>, state: &Self::SimState) -> Result<(), String>;

    /// The payload bytes of a snapshot (the kernel's own layout, stable across versions).
    fn encode(s: &KernelSnapshot<Self>) -> Vec<u8>;
    fn decode(bytes: &[u8]) -> Result<KernelSnapshot<Self>, String>;
}
