//! Checks of the values an FMU instance is given: parameter values, whose messages name the
//! FMU variable and the value, and the values of a snapshot to be restored. Physics-free.

use crate::fmi::model::Variable;

/// `name = value` must be finite and satisfy `ok` (`rule` says what is expected).
pub fn check(name: &str, value: f64, ok: bool, rule: &str) -> Result<(), String> {
    if value.is_finite() && ok {
        Ok(())
    } else {
        Err(format!("parameter '{name}' = {value}: must be {rule}"))
    }
}

/// Checks the values a snapshot sets, by value reference, with the layer's check of every
/// `fmi2SetReal` ([`Variable::check_value`]): a value reference the table does not have (a
/// state of another model), a non-finite value or one outside `[min, max]` is refused. The
/// model's own checks follow when the values are applied, as for a set (issue 17: a restored
/// state holds nothing `fmi2SetReal` would refuse).
pub fn check_restored(vars: &[Variable], values: &[(u32, f64)]) -> Result<(), String> {
    for &(vr, x) in values {
        let var = vars
            .iter()
            .find(|v| v.value_reference == vr)
            .ok_or_else(|| format!("the state sets unknown value reference {vr}"))?;
        var.check_value(x)
            .map_err(|e| format!("the state holds {e}"))?;
    }
    Ok(())
}

/// The values of a snapshot checked before anything is rebuilt: the parameters and start
/// inputs as `fmi2SetReal` before initialization takes them, the current inputs as it takes
/// them at a communication point (both [`check_restored`]), and a finite start time.
pub fn check_snapshot_values(
    vars: &[Variable],
    params: &[(u32, f64)],
    inputs: &[(u32, f64)],
    start_time: f64,
) -> Result<(), String> {
    check_restored(vars, params)?;
    check_restored(vars, inputs)?;
    if !start_time.is_finite() {
        return Err(format!("start time {start_time} is not finite"));
    }
    Ok(())
}

/// The same values bit for bit, by value reference in the same order: a state's parameters
/// against an instance's own (a restore that need not rebuild the model).
pub fn same_values(a: &[(u32, f64)], b: &[(u32, f64)]) -> bool {
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(x, y)| x.0 == y.0 && x.1.to_bits() == y.1.to_bits())
}
