//! `geardyn info`: what an FMU is and what it offers, from its modelDescription.xml
//! (FMI 2.0.5 §2.2.1 attributes, §4.3.1 capabilities, §2.2.7 variables).

use super::description::{ModelDescription, VarType};
use std::fmt::Write;

fn yes(b: bool) -> &'static str {
    if b {
        "yes"
    } else {
        "no"
    }
}

/// The text printed by `geardyn info`.
pub fn render(md: &ModelDescription) -> String {
    let mut s = String::new();
    let opt = |o: &Option<String>| o.clone().unwrap_or_else(|| "-".into());
    let _ = writeln!(s, "Model name       {}", md.model_name);
    let _ = writeln!(s, "FMI version      {}", md.fmi_version);
    let _ = writeln!(s, "GUID             {}", md.guid);
    let _ = writeln!(s, "Description      {}", opt(&md.description));
    let _ = writeln!(s, "Author           {}", opt(&md.author));
    let _ = writeln!(s, "Version          {}", opt(&md.version));
    let _ = writeln!(s, "Generation tool  {}", opt(&md.generation_tool));
    let _ = writeln!(s, "Generated        {}", opt(&md.generation_date_and_time));
    let mut kinds = Vec::new();
    if md.co_simulation.is_some() {
        kinds.push("Co-Simulation");
    }
    if md.model_exchange.is_some() {
        kinds.push("Model Exchange");
    }
    let _ = writeln!(
        s,
        "Interfaces       {}",
        if kinds.is_empty() {
            "none".into()
        } else {
            kinds.join(", ")
        }
    );
    if let Some(cs) = &md.co_simulation {
        let _ = writeln!(s, "\nCo-Simulation capabilities");
        let _ = writeln!(
            s,
            "  modelIdentifier                         {}",
            cs.model_identifier
        );
        for (name, v) in [
            (
                "canHandleVariableCommunicationStepSize",
                cs.can_handle_variable_communication_step_size,
            ),
            ("canInterpolateInputs", cs.can_interpolate_inputs),
            ("canGetAndSetFMUstate", cs.can_get_and_set_fmu_state),
            ("canSerializeFMUstate", cs.can_serialize_fmu_state),
            (
                "providesDirectionalDerivative",
                cs.provides_directional_derivative,
            ),
            (
                "canBeInstantiatedOnlyOncePerProcess",
                cs.can_be_instantiated_only_once_per_process,
            ),
            (
                "canNotUseMemoryManagementFunctions",
                cs.can_not_use_memory_management_functions,
            ),
            ("canRunAsynchronuously", cs.can_run_asynchronuously),
            ("needsExecutionTool", cs.needs_execution_tool),
        ] {
            let _ = writeln!(s, "  {name:<40}{}", yes(v));
        }
        let _ = writeln!(
            s,
            "  {:<40}{}",
            "maxOutputDerivativeOrder", cs.max_output_derivative_order
        );
    }
    if let Some(de) = &md.default_experiment {
        let f = |v: Option<f64>| v.map(|x| x.to_string()).unwrap_or_else(|| "-".into());
        let _ = writeln!(
            s,
            "\nDefault experiment  start {}  stop {}  tolerance {}  step size {}",
            f(de.start_time),
            f(de.stop_time),
            f(de.tolerance),
            f(de.step_size)
        );
    }
    if !md.log_categories.is_empty() {
        let cats: Vec<&str> = md.log_categories.iter().map(|c| c.name.as_str()).collect();
        let _ = writeln!(s, "Log categories      {}", cats.join(", "));
    }
    let _ = writeln!(s, "\nVariables ({})", md.variables.len());
    let rows: Vec<[String; 7]> = md
        .variables
        .iter()
        .map(|v| {
            let ty = if v.var_type == VarType::Enumeration {
                format!("Enumeration({})", v.declared_type.as_deref().unwrap_or("?"))
            } else {
                v.var_type.to_string()
            };
            [
                v.name.clone(),
                v.causality.to_string(),
                v.variability.to_string(),
                ty,
                md.unit_of(v).unwrap_or("").to_string(),
                v.start.as_ref().map(|x| x.to_string()).unwrap_or_default(),
                v.description.clone().unwrap_or_default(),
            ]
        })
        .collect();
    let head = [
        "name",
        "causality",
        "variability",
        "type",
        "unit",
        "start",
        "description",
    ];
    let mut w = head.map(|h| h.chars().count());
    for r in &rows {
        for (k, c) in r.iter().enumerate() {
            w[k] = w[k].max(c.chars().count());
        }
    }
    let line = |cells: &[String]| {
        let mut l = String::new();
        for (k, c) in cells.iter().enumerate() {
            if k + 1 == cells.len() {
                l.push_str(c);
            } else {
                let _ = write!(l, "{c:<width$}  ", width = w[k]);
            }
        }
        l.trim_end().to_string()
    };
    let _ = writeln!(s, "{}", line(&head.map(String::from)));
    for r in &rows {
        let _ = writeln!(s, "{}", line(r));
    }
    s
}
