//! `--start NAME=VALUE`: start values checked against the model description before anything
//! is loaded, and split into the two phases in which FMI 2.0 allows setting them.
//!
//! FMI 2.0.5 §2.2.7 (table "which variables may be set when"), as fmpy 0.3.32 applies it
//! (`settable_in_instantiated`, `settable_in_initialization_mode`):
//! * after `fmi2Instantiate` (before initialization): inputs, and non-constant variables with
//!   `initial="exact"` or `"approx"`;
//! * in initialization mode: additionally tunable non-parameters.
//!
//! Anything else (outputs and locals with `initial="calculated"`, constants, calculated
//! parameters, the independent variable) cannot take a start value, and is rejected with a
//! message naming the variable and why, instead of an FMU error at run time.

use super::description::{
    Causality, Initial, ModelDescription, ScalarVariable, Value, VarType, Variability,
};

/// When a start value is set.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// Between `fmi2SetupExperiment` and `fmi2EnterInitializationMode`.
    Instantiated,
    /// Between `fmi2EnterInitializationMode` and `fmi2ExitInitializationMode`.
    Initialization,
}

/// One checked start value.
#[derive(Debug, Clone, PartialEq)]
pub struct StartValue {
    pub name: String,
    pub vr: u32,
    pub var_type: VarType,
    pub value: Value,
    pub phase: Phase,
}

fn settable_in_instantiated(v: &ScalarVariable) -> bool {
    v.causality == Causality::Input
        || (v.variability != Variability::Constant
            && matches!(
                v.effective_initial(),
                Some(Initial::Exact | Initial::Approx)
            ))
}

fn settable_in_initialization(v: &ScalarVariable) -> bool {
    v.causality == Causality::Input
        || (v.causality != Causality::Parameter && v.variability == Variability::Tunable)
        || (v.variability != Variability::Constant && v.effective_initial() == Some(Initial::Exact))
}

/// Parse one `NAME=VALUE` argument.
pub fn parse_arg(arg: &str) -> Result<(String, String), String> {
    match arg.split_once('=') {
        Some((n, v)) if !n.trim().is_empty() => Ok((n.trim().to_string(), v.trim().to_string())),
        _ => Err(format!("--start \"{arg}\": expected NAME=VALUE")),
    }
}

/// Check `name=value` pairs against `md` (in the order given; later ones override earlier).
pub fn resolve(
    md: &ModelDescription,
    pairs: &[(String, String)],
) -> Result<Vec<StartValue>, String> {
    let mut out: Vec<StartValue> = Vec::new();
    for (name, text) in pairs {
        let v = md.variable(name).ok_or_else(|| {
            format!("--start {name}={text}: the FMU has no variable named \"{name}\"")
        })?;
        let phase = if settable_in_instantiated(v) {
            Phase::Instantiated
        } else if settable_in_initialization(v) {
            Phase::Initialization
        } else {
            return Err(format!(
                "--start {name}={text}: \"{name}\" is not a parameter or input and cannot be given a start value (causality=\"{}\", variability=\"{}\", initial=\"{}\"; FMI 2.0.5 §2.2.7)",
                v.causality,
                v.variability,
                v.effective_initial().map(|i| i.as_str()).unwrap_or("(none)")
            ));
        };
        let bad = |what: &str| {
            format!(
                "--start {name}={text}: \"{text}\" is not {what} (\"{name}\" is {})",
                v.var_type
            )
        };
        let value = match v.var_type {
            // A literal beyond the double range (1e999) parses as inf: refused, not read as
            // infinity (issue 34).
            VarType::Real => Value::Real(
                text.parse::<f64>()
                    .ok()
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| bad("a finite real number"))?,
            ),
            VarType::Integer | VarType::Enumeration => {
                Value::Integer(text.parse::<i32>().map_err(|_| bad("a 32-bit integer"))?)
            }
            VarType::Boolean => Value::Boolean(match text.to_ascii_lowercase().as_str() {
                "true" | "1" => true,
                "false" | "0" => false,
                _ => return Err(bad("a boolean (true, false, 1 or 0)")),
            }),
            VarType::String => Value::String(text.clone()),
        };
        out.retain(|s| s.name != *name);
        out.push(StartValue {
            name: name.clone(),
            vr: v.value_reference,
            var_type: v.var_type,
            value,
            phase,
        });
    }
    // Apply in document order, as fmpy does.
    out.sort_by_key(|s| md.variable(&s.name).map(|v| v.index));
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::host::description::parse;

    fn md() -> ModelDescription {
        parse(
            r#"<fmiModelDescription fmiVersion="2.0" modelName="m" guid="g">
  <CoSimulation modelIdentifier="m"/>
  <ModelVariables>
    <ScalarVariable name="k" valueReference="0" causality="parameter" variability="fixed"><Real start="1"/></ScalarVariable>
    <ScalarVariable name="u" valueReference="1" causality="input"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="y" valueReference="2" causality="output"><Real/></ScalarVariable>
    <ScalarVariable name="n" valueReference="0" causality="parameter" variability="fixed"><Integer start="1"/></ScalarVariable>
    <ScalarVariable name="b" valueReference="0" causality="parameter" variability="tunable"><Boolean start="false"/></ScalarVariable>
  </ModelVariables>
  <ModelStructure><Outputs><Unknown index="3"/></Outputs></ModelStructure>
</fmiModelDescription>"#,
            "t",
        )
        .unwrap()
    }

    #[test]
    fn accepts_parameters_and_inputs() {
        let pairs: Vec<_> = ["u=2.5", "k=3", "n=4", "b=True", "k=5"]
            .iter()
            .map(|a| parse_arg(a).unwrap())
            .collect();
        let s = resolve(&md(), &pairs).unwrap();
        let names: Vec<_> = s.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(names, ["k", "u", "n", "b"]);
        assert_eq!(s[0].value, Value::Real(5.0));
        assert_eq!(s[2].value, Value::Integer(4));
        assert_eq!(s[3].value, Value::Boolean(true));
        assert!(s.iter().all(|s| s.phase == Phase::Instantiated));
    }

    #[test]
    fn rejects_unknown_output_and_bad_values() {
        let e = resolve(&md(), &[parse_arg("nope=1").unwrap()]).unwrap_err();
        assert!(e.contains("no variable named \"nope\""), "{e}");
        let e = resolve(&md(), &[parse_arg("y=1").unwrap()]).unwrap_err();
        assert!(
            e.contains("\"y\" is not a parameter or input") && e.contains("causality=\"output\""),
            "{e}"
        );
        let e = resolve(&md(), &[parse_arg("n=1.5").unwrap()]).unwrap_err();
        assert!(e.contains("\"1.5\" is not a 32-bit integer"), "{e}");
        assert!(parse_arg("novalue").unwrap_err().contains("NAME=VALUE"));
    }
}
