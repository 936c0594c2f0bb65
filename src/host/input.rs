//! Input signals from a CSV file, applied exactly as fmpy 0.3.32 does (`fmpy.simulation.Input`),
//! so that `geardyn run --input f.csv` and `fmpy simulate --input-file f.csv` feed an FMU the
//! same values at the same communication points.
//!
//! The convention (read from fmpy 0.3.32 `simulation.py`, `Input.apply/interpolate/findEvents`,
//! and `simulateCS`):
//!
//! * The first column is the time; the table must be sorted. A column whose name is a variable
//!   with `causality="input"` **or `variability="tunable"`** drives that variable; other
//!   columns are ignored (a warning is printed), and an input without a column keeps its start
//!   value (warning, as fmpy prints).
//! * Inputs are sampled at the **start** of each communication step (`tc`) and held for the
//!   step (zero-order hold, FMI 2.0.5 §4.2.1: inputs are set before `fmi2DoStep`;
//!   `fmi2SetRealInputDerivatives` is not used). Before exiting initialization mode they are
//!   set once at the start time.
//! * **Continuous** Real inputs (variability not `discrete`/`tunable`) are interpolated
//!   linearly: with `i0` = first row with `t[i0] >= tc`, `w0 = (t1 - tc)/(t1 - t0)`,
//!   `w1 = 1 - w0`, `v = w0*v0 + w1*v1` (this exact arithmetic, so results agree to the last
//!   bit). Before the first row the first value is held; after the last row the last value.
//!   Two rows with the same time form a jump: at that time the value *after* the jump is used
//!   (except during initialization, where the value before it is used).
//! * **Discrete** inputs (Integer, Boolean, Enumeration, and Reals with variability
//!   `discrete`/`tunable`) take the value of the last row with `t <= tc` (times within
//!   `math.isclose` of `tc` count as reached). Integers and Booleans are read as numbers and
//!   truncated toward zero, as numpy's cast to C `int` does.
//! * **Input events**: the times of repeated rows and the rows where a discrete column changes.
//!   If the FMU has `canHandleVariableCommunicationStepSize`, a communication step that would
//!   pass an event is cut at it, which adds an output row at the event time.
//! * Times are compared with Python's `math.isclose` (relative tolerance 1e-9).

use super::csv::read_table;
use super::description::{Causality, ModelDescription, VarType, Variability};

/// Python's `math.isclose(a, b)` with its defaults (rel_tol = 1e-9, abs_tol = 0).
pub fn isclose(a: f64, b: f64) -> bool {
    if a == b {
        return true;
    }
    if a.is_infinite() || b.is_infinite() {
        return false;
    }
    let d = (a - b).abs();
    d <= 1e-9 * b.abs() || d <= 1e-9 * a.abs()
}

/// How a set of columns is written to the FMU.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Setter {
    Real,
    Integer,
    Boolean,
}

/// One group of variables set with one `fmi2Set*` call (fmpy groups by type).
#[derive(Debug, Clone)]
pub struct Group {
    pub setter: Setter,
    pub continuous: bool,
    pub vrs: Vec<u32>,
    /// `table[k][row]` for the k-th variable of the group.
    table: Vec<Vec<f64>>,
}

/// Values of one group at one time, ready for the setter.
#[derive(Debug, Clone, PartialEq)]
pub enum Values {
    Real(Vec<f64>),
    Int(Vec<i32>),
}

/// The input signals bound to an FMU's variables.
#[derive(Debug, Clone)]
pub struct Input {
    t: Vec<f64>,
    events: Vec<f64>,
    pub groups: Vec<Group>,
    /// Human-readable notes (ignored columns, inputs without a column), for stderr.
    pub warnings: Vec<String>,
}

impl Input {
    /// Read `path` (fmpy's CSV layout, see [`read_table`]) and bind its columns to `md`.
    pub fn from_csv(path: &std::path::Path, md: &ModelDescription) -> Result<Input, String> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("{}: cannot read input file: {e}", path.display()))?;
        let (names, columns) = read_table(&text).map_err(|e| format!("{}: {e}", path.display()))?;
        Input::bind(&names, columns, md).map_err(|e| format!("{}: {e}", path.display()))
    }

    /// Bind named columns (the first is the time) to the variables of `md`.
    pub fn bind(
        names: &[String],
        mut columns: Vec<Vec<f64>>,
        md: &ModelDescription,
    ) -> Result<Input, String> {
        if columns.is_empty() || columns[0].is_empty() || names.len() != columns.len() {
            return Err("the input table has no time column or no rows".into());
        }
        let t = columns.remove(0);
        let names = &names[1..];
        if let Some(w) = t.windows(2).position(|w| !(w[1] >= w[0])) {
            return Err(format!(
                "the time column must be non-decreasing, but row {} has time {} after {}",
                w + 3,
                t[w + 1],
                t[w]
            ));
        }
        let mut warnings = Vec::new();
        for n in names {
            match md.variable(n) {
                None => warnings.push(format!(
                    "input column \"{n}\" is not a variable of the FMU; ignored"
                )),
                Some(v)
                    if v.causality != Causality::Input
                        && v.variability != Variability::Tunable =>
                {
                    warnings.push(format!(
                        "input column \"{n}\" is a variable with causality=\"{}\" and variability=\"{}\", neither an input nor tunable; ignored",
                        v.causality, v.variability
                    ))
                }
                _ => {}
            }
        }
        let col = |name: &str| names.iter().position(|n| n == name);
        // Events (fmpy `Input.findEvents`): repeated times, and changes of discrete columns.
        let mut events: Vec<f64> = vec![f64::INFINITY];
        if t.len() >= 2 {
            for i in 0..t.len() - 1 {
                if t[i + 1] == t[i] {
                    events.push(t[i]);
                }
            }
            for v in &md.variables {
                if !matches!(v.variability, Variability::Discrete | Variability::Tunable) {
                    continue;
                }
                if let Some(k) = col(&v.name) {
                    let y = &columns[k];
                    for i in 0..y.len() - 1 {
                        if y[i + 1] != y[i] {
                            events.push(t[i + 1]);
                        }
                    }
                }
            }
        }
        events.sort_by(f64::total_cmp);
        events.dedup();

        // Groups in fmpy's order: continuous groups by type, then discrete groups by type, each
        // type in order of its first variable, variables in document order.
        let mut continuous: Vec<Group> = Vec::new();
        let mut discrete: Vec<Group> = Vec::new();
        for v in &md.variables {
            if v.causality != Causality::Input && v.variability != Variability::Tunable {
                continue;
            }
            let Some(k) = col(&v.name) else {
                if v.causality == Causality::Input {
                    warnings.push(format!("missing input for variable \"{}\"", v.name));
                }
                continue;
            };
            let setter = match v.var_type {
                VarType::Real => Setter::Real,
                VarType::Integer | VarType::Enumeration => Setter::Integer,
                VarType::Boolean => Setter::Boolean,
                VarType::String => {
                    return Err(format!(
                        "column \"{}\": String variables cannot be read from a CSV input",
                        v.name
                    ))
                }
            };
            let is_cont = v.var_type == VarType::Real
                && !matches!(v.variability, Variability::Discrete | Variability::Tunable);
            let list = if is_cont {
                &mut continuous
            } else {
                &mut discrete
            };
            let g = match list.iter().position(|g| g.setter == setter) {
                Some(i) => &mut list[i],
                None => {
                    list.push(Group {
                        setter,
                        continuous: is_cont,
                        vrs: Vec::new(),
                        table: Vec::new(),
                    });
                    list.last_mut().expect("just pushed")
                }
            };
            g.vrs.push(v.value_reference);
            g.table.push(columns[k].clone());
        }
        continuous.extend(discrete);
        Ok(Input {
            t,
            events,
            groups: continuous,
            warnings,
        })
    }

    /// fmpy `Input.nextEvent`: the first event strictly after `time` (not within isclose).
    pub fn next_event(&self, time: f64) -> f64 {
        self.events
            .iter()
            .copied()
            .find(|&e| e > time && !isclose(e, time))
            .unwrap_or(f64::INFINITY)
    }

    /// The values of group `g` at `time` (fmpy `Input.interpolate`).
    pub fn values(&self, g: &Group, time: f64, after_event: bool) -> Values {
        let row = |i: usize| -> Vec<f64> { g.table.iter().map(|c| c[i]).collect() };
        let t = &self.t;
        let v: Vec<f64> = if t.len() < 2 {
            row(0)
        } else {
            // np.searchsorted(t, time): first index with t[i] >= time.
            let i0 = t.partition_point(|&x| x < time);
            if i0 == 0 {
                row(0)
            } else if i0 == t.len() {
                row(t.len() - 1)
            } else if !g.continuous {
                let mut i = i0 - 1;
                if after_event {
                    while i + 1 < t.len() && (t[i + 1] < time || isclose(time, t[i + 1])) {
                        i += 1;
                    }
                }
                row(i)
            } else if isclose(time, t[i0]) && i0 < t.len() - 1 && isclose(t[i0], t[i0 + 1]) {
                // A jump at `time`: after it, or (during initialization) at its first row.
                let mut i = i0;
                if after_event {
                    while i < t.len() - 1 && isclose(t[i], t[i + 1]) {
                        i += 1;
                    }
                }
                row(i)
            } else {
                let (i0, i1) = (i0 - 1, i0);
                let (t0, t1) = (t[i0], t[i1]);
                let w0 = (t1 - time) / (t1 - t0);
                let w1 = 1.0 - w0;
                g.table.iter().map(|c| w0 * c[i0] + w1 * c[i1]).collect()
            }
        };
        match g.setter {
            Setter::Real => Values::Real(v),
            // numpy's float64 → C int cast truncates toward zero.
            Setter::Integer | Setter::Boolean => Values::Int(v.iter().map(|x| *x as i32).collect()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::host::description::parse;

    fn md() -> ModelDescription {
        parse(
            r#"<?xml version="1.0"?>
<fmiModelDescription fmiVersion="2.0" modelName="m" guid="g">
  <CoSimulation modelIdentifier="m"/>
  <ModelVariables>
    <ScalarVariable name="u" valueReference="0" causality="input"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="n" valueReference="1" causality="input" variability="discrete"><Integer start="0"/></ScalarVariable>
    <ScalarVariable name="y" valueReference="2" causality="output"><Real/></ScalarVariable>
  </ModelVariables>
  <ModelStructure><Outputs><Unknown index="3"/></Outputs><InitialUnknowns><Unknown index="3"/></InitialUnknowns></ModelStructure>
</fmiModelDescription>"#,
            "t",
        )
        .unwrap()
    }

    fn input() -> Input {
        let names: Vec<String> = ["time", "u", "n", "other"].map(String::from).into();
        let cols = vec![
            vec![0.0, 1.0, 1.0, 2.0],
            vec![0.0, 1.0, 5.0, 7.0],
            vec![0.0, 0.0, 2.9, -3.5],
            vec![0.0; 4],
        ];
        Input::bind(&names, cols, &md()).unwrap()
    }

    #[test]
    fn interpolation_hold_and_jump() {
        let inp = input();
        let (c, d) = (&inp.groups[0], &inp.groups[1]);
        assert!(c.continuous && !d.continuous);
        assert_eq!(inp.values(c, -1.0, true), Values::Real(vec![0.0]));
        assert_eq!(inp.values(c, 0.25, true), Values::Real(vec![0.25]));
        // At the jump t = 1: value after the jump in the loop, before it during initialization.
        assert_eq!(inp.values(c, 1.0, true), Values::Real(vec![5.0]));
        assert_eq!(inp.values(c, 1.0, false), Values::Real(vec![1.0]));
        assert_eq!(inp.values(c, 1.5, true), Values::Real(vec![6.0]));
        assert_eq!(inp.values(c, 9.0, true), Values::Real(vec![7.0]));
        // Discrete: last row with t <= time, truncated toward zero.
        assert_eq!(inp.values(d, 0.5, true), Values::Int(vec![0]));
        assert_eq!(inp.values(d, 1.0, true), Values::Int(vec![2]));
        assert_eq!(inp.values(d, 1.9, true), Values::Int(vec![2]));
        assert_eq!(inp.values(d, 2.5, true), Values::Int(vec![-3]));
    }

    #[test]
    fn events_and_warnings() {
        let inp = input();
        assert_eq!(inp.next_event(0.0), 1.0);
        assert_eq!(inp.next_event(1.0 - 1e-12), 2.0); // isclose(1.0, time): not "after"
        assert_eq!(inp.next_event(2.0), f64::INFINITY);
        assert!(inp.warnings.iter().any(|w| w.contains("\"other\"")));
    }

    #[test]
    fn unsorted_time_is_rejected() {
        let names: Vec<String> = ["time", "u"].map(String::from).into();
        let e = Input::bind(&names, vec![vec![0.0, 2.0, 1.0], vec![0.0; 3]], &md()).unwrap_err();
        assert!(e.contains("non-decreasing") && e.contains("row 4"), "{e}");
    }

    #[test]
    fn python_isclose() {
        assert!(isclose(1.0, 1.0 + 1e-10));
        assert!(!isclose(1.0, 1.0 + 1e-8));
        assert!(!isclose(0.0, 1e-300));
        assert!(isclose(f64::INFINITY, f64::INFINITY));
    }
}
