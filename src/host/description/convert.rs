//! Typed conversion of the raw tree into [`ModelDescription`] (FMI 2.0.5 §2.2, §4.3.1), with
//! located messages such as `ScalarVariable "x" (#3, line 12): valueReference="abc" is not an
//! unsigned 32-bit integer`.

use super::raw::*;
use super::*;

fn parse_f64(s: &str, what: &dyn Fn() -> String) -> Result<f64, String> {
    // xs:double allows INF, -INF and NaN; Rust spells them inf/NaN, so map them explicitly.
    let t = s.trim();
    match t {
        "INF" | "+INF" => return Ok(f64::INFINITY),
        "-INF" => return Ok(f64::NEG_INFINITY),
        "NaN" => return Ok(f64::NAN),
        _ => {}
    }
    if t.is_empty()
        || t.chars()
            .any(|c| c.is_ascii_alphabetic() && c != 'e' && c != 'E')
    {
        return Err(format!("{}=\"{s}\" is not a real number", what()));
    }
    t.parse::<f64>()
        .map_err(|_| format!("{}=\"{s}\" is not a real number", what()))
}

fn parse_bool(s: &str, what: &dyn Fn() -> String) -> Result<bool, String> {
    // xs:boolean: true, false, 1, 0.
    match s.trim() {
        "true" | "1" => Ok(true),
        "false" | "0" => Ok(false),
        _ => Err(format!(
            "{}=\"{s}\" is not a boolean (true|false|1|0)",
            what()
        )),
    }
}

fn parse_i32(s: &str, what: &dyn Fn() -> String) -> Result<i32, String> {
    s.trim()
        .parse::<i32>()
        .map_err(|_| format!("{}=\"{s}\" is not a 32-bit integer", what()))
}

fn parse_u32(s: &str, what: &dyn Fn() -> String) -> Result<u32, String> {
    s.trim()
        .parse::<u32>()
        .map_err(|_| format!("{}=\"{s}\" is not an unsigned 32-bit integer", what()))
}

fn opt_f64(a: &RawAttrs, name: &str, ctx: &str) -> Result<Option<f64>, String> {
    a.get(name)
        .map(|s| parse_f64(s, &|| format!("{ctx}: {name}")))
        .transpose()
}

fn opt_bool(a: &RawAttrs, name: &str, ctx: &str) -> Result<bool, String> {
    Ok(a.get(name)
        .map(|s| parse_bool(s, &|| format!("{ctx}: {name}")))
        .transpose()?
        .unwrap_or(false))
}

pub(super) fn convert(raw: RawRoot, lines: &[usize]) -> Result<ModelDescription, String> {
    let model_name = raw
        .model_name
        .ok_or("fmiModelDescription: required attribute modelName is missing")?;
    let guid = raw
        .guid
        .ok_or("fmiModelDescription: required attribute guid is missing")?;

    let input_order = (raw.vendor_annotations.iter())
        .flat_map(|v| &v.tools)
        .filter(|t| t.name == "geardyn")
        .find_map(|t| t.input_derivatives.as_ref())
        .and_then(|a| a.get("maxOrder"))
        .map(|s| parse_u32(s, &|| "<InputDerivatives>: maxOrder".to_string()))
        .transpose()?;
    let switch_time_name = (raw.vendor_annotations.iter())
        .flat_map(|v| &v.tools)
        .filter(|t| t.name == crate::fmi::description::SWITCH_TIMES_TOOL)
        .find_map(|t| t.switch_times.as_ref())
        .map(|a| {
            a.get("variable")
                .map(str::to_string)
                .ok_or("<SwitchTimes>: required attribute variable is missing")
        })
        .transpose()?;
    let shares_binary = (raw.vendor_annotations.iter())
        .flat_map(|v| &v.tools)
        .filter(|t| t.name == crate::fmi::description::SHARED_BINARY_TOOL)
        .any(|t| t.shared_binary.is_some());
    let mut co_simulation = raw
        .co_simulation
        .map(|a| -> Result<CoSimulation, String> {
            let c = "<CoSimulation>";
            let can_interpolate_inputs = opt_bool(&a, "canInterpolateInputs", c)?;
            Ok(CoSimulation {
                model_identifier: a
                    .get("modelIdentifier")
                    .ok_or("<CoSimulation>: required attribute modelIdentifier is missing")?
                    .to_string(),
                needs_execution_tool: opt_bool(&a, "needsExecutionTool", c)?,
                can_handle_variable_communication_step_size: opt_bool(
                    &a,
                    "canHandleVariableCommunicationStepSize",
                    c,
                )?,
                can_interpolate_inputs,
                max_input_derivative_order: match (can_interpolate_inputs, input_order) {
                    (false, _) => 0,
                    (true, order) => order.unwrap_or(1).max(1),
                },
                // Resolved below, once the variables are read.
                switch_time: None,
                shares_binary,
                max_output_derivative_order: a
                    .get("maxOutputDerivativeOrder")
                    .map(|s| parse_u32(s, &|| format!("{c}: maxOutputDerivativeOrder")))
                    .transpose()?
                    .unwrap_or(0),
                can_run_asynchronuously: opt_bool(&a, "canRunAsynchronuously", c)?,
                can_be_instantiated_only_once_per_process: opt_bool(
                    &a,
                    "canBeInstantiatedOnlyOncePerProcess",
                    c,
                )?,
                can_not_use_memory_management_functions: opt_bool(
                    &a,
                    "canNotUseMemoryManagementFunctions",
                    c,
                )?,
                can_get_and_set_fmu_state: opt_bool(&a, "canGetAndSetFMUstate", c)?,
                can_serialize_fmu_state: opt_bool(&a, "canSerializeFMUstate", c)?,
                provides_directional_derivative: opt_bool(&a, "providesDirectionalDerivative", c)?,
            })
        })
        .transpose()?;
    let model_exchange = raw
        .model_exchange
        .map(|a| {
            a.get("modelIdentifier")
                .map(str::to_string)
                .ok_or("<ModelExchange>: required attribute modelIdentifier is missing")
        })
        .transpose()?;

    let mut unit_definitions = Vec::new();
    for (i, u) in raw
        .unit_definitions
        .unwrap_or_default()
        .units
        .into_iter()
        .enumerate()
    {
        let name = u
            .name
            .ok_or_else(|| format!("<Unit> #{}: required attribute name is missing", i + 1))?;
        let ctx = format!("<Unit name=\"{name}\">");
        let mut base_unit: Vec<(String, String)> = u
            .base_unit
            .map(|b| {
                b.attrs
                    .iter()
                    .filter_map(|(k, v)| match v {
                        AttrValue::Text(t) => {
                            k.strip_prefix('@').map(|k| (k.to_string(), t.clone()))
                        }
                        AttrValue::Other(_) => None,
                    })
                    .collect()
            })
            .unwrap_or_default();
        base_unit.sort();
        for (k, v) in &base_unit {
            if matches!(k.as_str(), "factor" | "offset") {
                parse_f64(v, &|| format!("{ctx}/<BaseUnit>: {k}"))?;
            } else {
                parse_i32(v, &|| format!("{ctx}/<BaseUnit>: {k}"))?;
            }
        }
        let mut display_units = Vec::new();
        for d in &u.display_units {
            let dname = d.get("name").ok_or_else(|| {
                format!("{ctx}/<DisplayUnit>: required attribute name is missing")
            })?;
            let dctx = format!("{ctx}/<DisplayUnit name=\"{dname}\">");
            display_units.push(DisplayUnit {
                name: dname.to_string(),
                factor: opt_f64(d, "factor", &dctx)?.unwrap_or(1.0),
                offset: opt_f64(d, "offset", &dctx)?.unwrap_or(0.0),
            });
        }
        unit_definitions.push(Unit {
            name,
            base_unit,
            display_units,
        });
    }

    let mut type_definitions = Vec::new();
    for (i, t) in raw
        .type_definitions
        .unwrap_or_default()
        .types
        .into_iter()
        .enumerate()
    {
        let name = t.name.ok_or_else(|| {
            format!(
                "<SimpleType> #{}: required attribute name is missing",
                i + 1
            )
        })?;
        let ctx = format!("<SimpleType name=\"{name}\">");
        let present: Vec<(VarType, RawTyped)> = [
            (VarType::Real, t.real),
            (VarType::Integer, t.integer),
            (VarType::Boolean, t.boolean),
            (VarType::String, t.string),
            (VarType::Enumeration, t.enumeration),
        ]
        .into_iter()
        .filter_map(|(k, v)| v.map(|v| (k, v)))
        .collect();
        if present.len() != 1 {
            return Err(format!(
                "{ctx}: must have exactly one of Real, Integer, Boolean, String, Enumeration (found {})",
                present.len()
            ));
        }
        let (var_type, typed) = present.into_iter().next().expect("len checked == 1");
        let a = &typed.attrs;
        let mut items = Vec::new();
        for (j, it) in typed.items.iter().enumerate() {
            let iname = it.get("name").ok_or_else(|| {
                format!(
                    "{ctx}/<Item> #{}: required attribute name is missing",
                    j + 1
                )
            })?;
            let value = it.get("value").ok_or_else(|| {
                format!("{ctx}/<Item name=\"{iname}\">: required attribute value is missing")
            })?;
            let value = parse_i32(value, &|| format!("{ctx}/<Item name=\"{iname}\">: value"))?;
            items.push((iname.to_string(), value));
        }
        type_definitions.push(SimpleType {
            name: name.clone(),
            description: t.description,
            var_type,
            unit: a.get("unit").map(str::to_string),
            display_unit: a.get("displayUnit").map(str::to_string),
            min: if var_type == VarType::Real {
                opt_f64(a, "min", &ctx)?
            } else {
                a.get("min")
                    .map(|s| parse_i32(s, &|| format!("{ctx}: min")).map(f64::from))
                    .transpose()?
            },
            max: if var_type == VarType::Real {
                opt_f64(a, "max", &ctx)?
            } else {
                a.get("max")
                    .map(|s| parse_i32(s, &|| format!("{ctx}: max")).map(f64::from))
                    .transpose()?
            },
            items,
        });
    }

    let log_categories = raw
        .log_categories
        .unwrap_or_default()
        .categories
        .iter()
        .enumerate()
        .map(|(i, c)| {
            Ok(LogCategory {
                name: c
                    .get("name")
                    .ok_or_else(|| {
                        format!(
                            "<LogCategories>/<Category> #{}: required attribute name is missing",
                            i + 1
                        )
                    })?
                    .to_string(),
                description: c.get("description").map(str::to_string),
            })
        })
        .collect::<Result<Vec<_>, String>>()?;

    let default_experiment = raw
        .default_experiment
        .map(|a| -> Result<DefaultExperiment, String> {
            let c = "<DefaultExperiment>";
            Ok(DefaultExperiment {
                start_time: opt_f64(&a, "startTime", c)?,
                stop_time: opt_f64(&a, "stopTime", c)?,
                tolerance: opt_f64(&a, "tolerance", c)?,
                step_size: opt_f64(&a, "stepSize", c)?,
            })
        })
        .transpose()?;

    let raw_vars = raw
        .model_variables
        .ok_or("required element <ModelVariables> is missing")?
        .variables;
    let mut variables = Vec::with_capacity(raw_vars.len());
    for (i, rv) in raw_vars.into_iter().enumerate() {
        variables.push(convert_variable(
            rv,
            i + 1,
            lines.get(i).copied().unwrap_or(0),
        )?);
    }

    if let (Some(name), Some(cs)) = (&switch_time_name, co_simulation.as_mut()) {
        let v = variables
            .iter()
            .find(|v| &v.name == name && v.var_type == VarType::Real)
            .ok_or_else(|| {
                format!("<SwitchTimes>: variable '{name}' is not a Real variable of the model")
            })?;
        cs.switch_time = Some(v.value_reference);
    }

    let ms = raw
        .model_structure
        .ok_or("required element <ModelStructure> is missing")?;
    let unknowns = |u: Option<RawUnknowns>, what: &str| -> Result<Vec<Unknown>, String> {
        let mut out = Vec::new();
        for (i, a) in u.unwrap_or_default().unknowns.iter().enumerate() {
            let ctx = format!("<ModelStructure>/<{what}>/<Unknown> #{}", i + 1);
            let index = a
                .get("index")
                .ok_or_else(|| format!("{ctx}: required attribute index is missing"))?;
            let index = parse_u32(index, &|| format!("{ctx}: index"))? as usize;
            let dependencies = a
                .get("dependencies")
                .map(|s| {
                    s.split_whitespace()
                        .map(|d| {
                            parse_u32(d, &|| format!("{ctx}: dependencies")).map(|x| x as usize)
                        })
                        .collect::<Result<Vec<_>, _>>()
                })
                .transpose()?;
            let dependencies_kind = a
                .get("dependenciesKind")
                .map(|s| s.split_whitespace().map(str::to_string).collect());
            out.push(Unknown {
                index,
                dependencies,
                dependencies_kind,
            });
        }
        Ok(out)
    };
    let has_derivatives = ms.derivatives.is_some();
    let model_structure = ModelStructure {
        outputs: unknowns(ms.outputs, "Outputs")?,
        derivatives: if has_derivatives {
            Some(unknowns(ms.derivatives, "Derivatives")?)
        } else {
            None
        },
        initial_unknowns: unknowns(ms.initial_unknowns, "InitialUnknowns")?,
    };

    Ok(ModelDescription {
        fmi_version: raw.fmi_version.unwrap_or_default(),
        model_name,
        guid,
        description: raw.description,
        author: raw.author,
        version: raw.version,
        generation_tool: raw.generation_tool,
        generation_date_and_time: raw.generation_date_and_time,
        variable_naming_convention: raw.variable_naming_convention,
        co_simulation,
        model_exchange,
        unit_definitions,
        type_definitions,
        log_categories,
        default_experiment,
        variables,
        model_structure,
    })
}

fn convert_variable(
    rv: RawScalarVariable,
    index: usize,
    line: usize,
) -> Result<ScalarVariable, String> {
    let name = rv.name.ok_or_else(|| {
        format!("<ScalarVariable> #{index} (line {line}): required attribute name is missing")
    })?;
    let ctx = format!("ScalarVariable \"{name}\" (#{index}, line {line})");
    let value_reference = rv
        .value_reference
        .as_deref()
        .ok_or_else(|| format!("{ctx}: required attribute valueReference is missing"))?;
    let value_reference = parse_u32(value_reference, &|| format!("{ctx}: valueReference"))?;
    let causality = match rv.causality.as_deref() {
        None => Causality::Local,
        Some(s) => Causality::parse(s).ok_or_else(|| {
            format!("{ctx}: causality=\"{s}\" is not one of parameter, calculatedParameter, input, output, local, independent")
        })?,
    };
    let variability = match rv.variability.as_deref() {
        None => Variability::Continuous,
        Some(s) => Variability::parse(s).ok_or_else(|| {
            format!("{ctx}: variability=\"{s}\" is not one of constant, fixed, tunable, discrete, continuous")
        })?,
    };
    let initial = rv
        .initial
        .as_deref()
        .map(|s| {
            Initial::parse(s).ok_or_else(|| {
                format!("{ctx}: initial=\"{s}\" is not one of exact, approx, calculated")
            })
        })
        .transpose()?;
    let present: Vec<(VarType, RawAttrs)> = [
        (VarType::Real, rv.real),
        (VarType::Integer, rv.integer),
        (VarType::Boolean, rv.boolean),
        (VarType::String, rv.string),
        (VarType::Enumeration, rv.enumeration),
    ]
    .into_iter()
    .filter_map(|(k, v)| v.map(|v| (k, v)))
    .collect();
    if present.len() != 1 {
        return Err(format!(
            "{ctx}: must have exactly one type element (Real, Integer, Boolean, String or Enumeration), found {}",
            present.len()
        ));
    }
    let (var_type, a) = present.into_iter().next().expect("len checked == 1");
    let tctx = format!("{ctx}/<{var_type}>");
    let start = match a.get("start") {
        None => None,
        Some(s) => Some(match var_type {
            VarType::Real => Value::Real(parse_f64(s, &|| format!("{tctx}: start"))?),
            VarType::Integer | VarType::Enumeration => {
                Value::Integer(parse_i32(s, &|| format!("{tctx}: start"))?)
            }
            VarType::Boolean => Value::Boolean(parse_bool(s, &|| format!("{tctx}: start"))?),
            VarType::String => Value::String(s.to_string()),
        }),
    };
    let num = |n: &str| -> Result<Option<f64>, String> {
        match var_type {
            VarType::Real => opt_f64(&a, n, &tctx),
            VarType::Integer | VarType::Enumeration => a
                .get(n)
                .map(|s| parse_i32(s, &|| format!("{tctx}: {n}")).map(f64::from))
                .transpose(),
            _ => Ok(None),
        }
    };
    Ok(ScalarVariable {
        name,
        value_reference,
        description: rv.description,
        causality,
        variability,
        initial,
        var_type,
        declared_type: a.get("declaredType").map(str::to_string),
        start,
        unit: a.get("unit").map(str::to_string),
        display_unit: a.get("displayUnit").map(str::to_string),
        min: num("min")?,
        max: num("max")?,
        nominal: if var_type == VarType::Real {
            opt_f64(&a, "nominal", &tctx)?
        } else {
            None
        },
        derivative: a
            .get("derivative")
            .map(|s| parse_u32(s, &|| format!("{tctx}: derivative")))
            .transpose()?,
        index,
        line,
    })
}
