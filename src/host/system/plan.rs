//! What the master runs: the system, the algorithm and coupling, the order, the recorded
//! columns and the watches (divergence, interrupt).

use super::check::System;
use crate::host::description::VarType;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Algorithm {
    Jacobi,
    GaussSeidel,
}

/// How a connection's value reaches its consumer over a step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Coupling {
    Hold,
    Extrapolate,
    Interpolate,
}

/// One CSV column: an output port of the links (`port`) or another variable.
#[derive(Debug, Clone)]
pub struct Column {
    pub element: usize,
    pub vr: u32,
    pub var_type: VarType,
    pub name: String,
    pub port: Option<usize>,
}

/// Everything decided before the FMUs are loaded.
pub struct Plan<'a> {
    pub system: System,
    pub algorithm: Algorithm,
    pub order: Vec<usize>,
    /// Per link: whether its consumer steps before its producer (Gauss–Seidel).
    pub cut: Vec<bool>,
    pub coupling: Vec<Coupling>,
    /// Distinct producer ports `(element, vr, type)`; `port_of[link]` indexes them.
    pub ports: Vec<(usize, u32, VarType)>,
    pub port_of: Vec<usize>,
    /// Ports whose first derivative is read after each step (for [`Coupling::Extrapolate`]).
    pub needs_derivative: Vec<bool>,
    /// Per link: its consumer is given the cubic Hermite interpolant of the producer's values
    /// and derivatives at both ends of the step (input derivatives of orders 1 to 3) instead of
    /// the chord (an interpolated connection of the error-controlled master).
    pub hermite: Vec<bool>,
    /// Per link: the degree of the polynomial an extrapolated connection gives its consumer,
    /// 1 (the line) to 3: the consumer's highest input derivative order, capped at 3, under
    /// the error-controlled master ([`super::extrapolation`]); 1 with fixed steps.
    pub extrapolation_order: Vec<u8>,
    /// Per link: the producer ports of its consumer that its input feeds directly
    /// ([`super::graph::feedthrough`]).
    pub feedthrough: Vec<Vec<usize>>,
    /// In fmpy's order: Reals, then Integers, then Booleans.
    pub columns: Vec<Column>,
    pub start_time: f64,
    pub stop_time: f64,
    pub h: f64,
    /// Every FMU has `canHandleVariableCommunicationStepSize="true"`.
    pub can_vary: bool,
    /// Threads for the `fmi2DoStep` calls of a Jacobi step ([`super::parallel`]; 1: serial).
    pub threads: usize,
    /// Whether `--threads` asked for them: otherwise they are used only where a measured
    /// handoff to a thread costs less than the work it moves ([`super::parallel::Pool::assign`]).
    pub threads_asked: bool,
    /// The ports watched for divergence, with their units ([`super::divergence`]), and the
    /// growth factor that stops the run (0: off).
    pub watched: Vec<(usize, String)>,
    pub divergence_factor: f64,
    /// `--tolerance`: the error-controlled master ([`super::controlled`]); `None`: fixed steps.
    pub control: Option<ErrorControl>,
    pub interrupt: Option<&'a std::sync::atomic::AtomicBool>,
}

/// The settings of the error-controlled master ([`super::controlled`]).
#[derive(Debug, Clone)]
pub struct ErrorControl {
    /// Relative tolerance of each communication step's coupling-error estimate.
    pub tolerance: f64,
    /// Bounds of the communication step, s.
    pub h_min: f64,
    pub h_max: f64,
    /// Carry each step's impulse deficit into the next step (`controlled::impulse_deficits`;
    /// off with `--no-impulse-correction`).
    pub impulse_correction: bool,
    /// Per element: the value reference of its announced next switch time (the FMU's vendor
    /// annotation `<SwitchTimes>`), where a step ends (`controlled`, "Steps that end at a
    /// switch"); all `None` with `--no-switch-steps`.
    pub switch_times: Vec<Option<u32>>,
}

/// One attempted communication step.
#[derive(Debug, Clone, Copy)]
pub struct StepRecord {
    pub time: f64,
    pub step: f64,
    /// The error estimate relative to the tolerance (∞: an FMU refused the step).
    pub error: f64,
    pub accepted: bool,
}
