//! Rows of the kernels' variable tables (FMI 2.0.x §2.2.7) and lookups in a table.
//! Physics-free.

use crate::fmi::model::{Causality, Initial, VarKind, Variability, Variable};

/// A tunable-before-initialization Real parameter (`fixed`, `initial = exact`).
pub fn param(name: &str, vr: u32, start: f64, unit: Option<&str>, desc: &str) -> Variable {
    Variable::real(
        name,
        vr,
        Causality::Parameter,
        Variability::Fixed,
        Some(Initial::Exact),
        Some(start),
        unit,
        desc,
    )
}

/// A Real parameter the model computes from the others (`fixed`, `initial = calculated`).
pub fn calculated(name: &str, vr: u32, unit: &str, desc: &str) -> Variable {
    Variable::real(
        name,
        vr,
        Causality::CalculatedParameter,
        Variability::Fixed,
        Some(Initial::Calculated),
        None,
        Some(unit),
        desc,
    )
}

/// How a kernel declares the three inputs every kernel has, in
/// [`crate::fmu::Kernel::INPUTS`] order: the driving speed (named by the kernel; never
/// negative), `operating.input_torque` and `operating.load_torque` (their scene keys).
pub struct InputRows {
    pub vrs: [u32; 3],
    pub speed: &'static str,
    pub descriptions: [&'static str; 3],
}

/// The rows of the inputs, with their start values.
pub fn inputs(rows: &InputRows, start: [f64; 3]) -> [Variable; 3] {
    let (vr, desc) = (rows.vrs, rows.descriptions);
    let mut speed = input(rows.speed, vr[0], start[0], "rad/s", desc[0]);
    speed.min = Some(0.0);
    [
        speed,
        input("operating.input_torque", vr[1], start[1], "N.m", desc[1]),
        input("operating.load_torque", vr[2], start[2], "N.m", desc[2]),
    ]
}

/// A continuous Real input with a start value.
pub fn input(name: &str, vr: u32, start: f64, unit: &str, desc: &str) -> Variable {
    Variable::real(
        name,
        vr,
        Causality::Input,
        Variability::Continuous,
        None,
        Some(start),
        Some(unit),
        desc,
    )
}

/// An output (`initial = calculated`): a continuous Real, or a discrete Integer (contact
/// states, counts).
pub fn output(name: &str, vr: u32, unit: Option<&str>, desc: &str, integer: bool) -> Variable {
    let mut o = Variable::real(
        name,
        vr,
        Causality::Output,
        Variability::Continuous,
        Some(Initial::Calculated),
        None,
        unit,
        desc,
    );
    if integer {
        o.kind = VarKind::Integer;
        o.variability = Variability::Discrete;
    }
    o
}

/// Name of the variable with value reference `vr` (`?` when there is none).
pub fn name_of(vars: &[Variable], vr: u32) -> &str {
    vars.iter()
        .find(|v| v.value_reference == vr)
        .map_or("?", |v| v.name.as_str())
}

/// The Real parameters and inputs: what an FMU state must carry besides the run-time state
/// to rebuild an instance (their values set before initialization define its equations and
/// initial operating point).
pub fn settable_reals(vars: &[Variable]) -> impl Iterator<Item = &Variable> {
    vars.iter().filter(|v| {
        v.kind == VarKind::Real && matches!(v.causality, Causality::Parameter | Causality::Input)
    })
}
