//! `modelDescription.xml` writer (FMI 2.0.x §2.2 common schema, §4.3 CS schema), generated
//! with quick-xml from the same variable table the C ABI uses.
//!
//! The output is deterministic (no generation date): the checked-in copies under
//! `modelDescription/` must be byte-identical to what this writer produces.

use std::io::Cursor;
use std::path::Path;

use quick_xml::events::{BytesDecl, BytesEnd, BytesStart, Event};
use quick_xml::Writer;

use super::logger::Category;
use super::model::{
    model_identifier, Capabilities, Causality, Initial, ModelInfo, VarKind, Variable,
};

/// SI base-unit exponents of a unit (`<BaseUnit>`, FMI 2.0.x §2.2.2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BaseUnit {
    pub kg: i8,
    pub m: i8,
    pub s: i8,
    pub rad: i8,
    /// `value in SI = factor · value in this unit` (1 for coherent SI units).
    pub factor: f64,
}

/// Units the generator knows. A variable with another unit fails packaging with a message,
/// rather than producing a description that fmpy rejects ("unit not defined").
pub fn base_unit(unit: &str) -> Option<BaseUnit> {
    let u = |kg, m, s, rad| BaseUnit {
        kg,
        m,
        s,
        rad,
        factor: 1.0,
    };
    Some(match unit {
        // Dimensionless (a fraction, a ratio): every base-unit exponent 0, as in src/units.rs.
        "1" => u(0, 0, 0, 0),
        // A mesh cycle (one tooth passage) is 2π rad of mesh phase.
        "cycle" => BaseUnit {
            factor: std::f64::consts::TAU,
            ..u(0, 0, 0, 1)
        },
        "m" => u(0, 1, 0, 0),
        "m/s" => u(0, 1, -1, 0),
        "m/s2" => u(0, 1, -2, 0),
        "s" => u(0, 0, 1, 0),
        "Hz" | "1/s" => u(0, 0, -1, 0),
        "kg" => u(1, 0, 0, 0),
        "kg.m2" => u(1, 2, 0, 0),
        "N" => u(1, 1, -2, 0),
        "N/m" => u(1, 0, -2, 0),
        "N.s/m" => u(1, 0, -1, 0),
        "N.m" => u(1, 2, -2, 0),
        "N.m/rad" => u(1, 2, -2, -1),
        "N.m.s/rad" => u(1, 2, -1, -1),
        "N.m.s2/rad2" => u(1, 2, 0, -2),
        "J" => u(1, 2, -2, 0),
        "W" => u(1, 2, -3, 0),
        "Pa" => u(1, -1, -2, 0),
        "rad" => u(0, 0, 0, 1),
        "rad/s" => u(0, 0, -1, 1),
        "rad/s2" => u(0, 0, -2, 1),
        _ => return None,
    })
}

/// `f64` in the shortest form that round-trips (`1.0`, `1e-5`, `2.5e8`), valid `xs:double`.
fn real(x: f64) -> String {
    format!("{x:?}")
}

type W = Writer<Cursor<Vec<u8>>>;

fn io(e: std::io::Error) -> String {
    format!("XML writer: {e}")
}

fn empty(w: &mut W, name: &str, attrs: &[(&str, String)]) -> Result<(), String> {
    let mut el = BytesStart::new(name);
    for (k, v) in attrs {
        el.push_attribute((*k, v.as_str()));
    }
    w.write_event(Event::Empty(el)).map_err(io)
}

fn start(w: &mut W, name: &str, attrs: &[(&str, String)]) -> Result<(), String> {
    let mut el = BytesStart::new(name);
    for (k, v) in attrs {
        el.push_attribute((*k, v.as_str()));
    }
    w.write_event(Event::Start(el)).map_err(io)
}

fn end(w: &mut W, name: &str) -> Result<(), String> {
    w.write_event(Event::End(BytesEnd::new(name))).map_err(io)
}

/// The vendor-annotation tool that carries `<SwitchTimes variable>` (docs/fmu.md "Switch
/// times"): one of its own beside `geardyn`'s `<InputDerivatives>`.
pub const SWITCH_TIMES_TOOL: &str = "geardyn.switch_times";

/// The vendor-annotation tool that carries `<SharedBinary/>` (docs/fmu.md "One binary for
/// several FMUs"): every geardyn FMU's binary is the same library, which keeps no state
/// outside its instances, so a host may load one copy of it for all the FMUs of a system
/// whose binaries are byte-identical (FMI 2.0 gives each FMU its own).
pub const SHARED_BINARY_TOOL: &str = "geardyn.shared_binary";

/// Writes the complete `modelDescription.xml`.
pub fn model_description(
    info: &ModelInfo,
    vars: &[Variable],
    caps: Capabilities,
) -> Result<String, String> {
    super::model::validate_variables(vars)?;
    if caps.max_output_derivative_order > 1 {
        return Err(format!(
            "maxOutputDerivativeOrder = {}: the FMI layer provides first-order output derivatives only",
            caps.max_output_derivative_order
        ));
    }
    let mut units: Vec<&str> = Vec::new();
    for v in vars {
        if let Some(u) = v.unit.as_deref() {
            if base_unit(u).is_none() {
                return Err(format!(
                    "variable '{}': unit '{u}' has no BaseUnit definition (add it to fmi::description::base_unit)",
                    v.name
                ));
            }
            if !units.contains(&u) {
                units.push(u);
            }
        }
    }
    units.sort_unstable();
    let id = model_identifier(&info.model_name);
    let yes = || "true".to_string();
    let no = || "false".to_string();

    let mut w = Writer::new_with_indent(Cursor::new(Vec::new()), b' ', 2);
    w.write_event(Event::Decl(BytesDecl::new("1.0", Some("UTF-8"), None)))
        .map_err(io)?;
    start(
        &mut w,
        "fmiModelDescription",
        &[
            ("fmiVersion", "2.0".into()),
            ("modelName", info.model_name.clone()),
            ("guid", info.guid.clone()),
            ("description", info.description.clone()),
            ("version", env!("CARGO_PKG_VERSION").into()),
            (
                "generationTool",
                format!("geardyn {}", env!("CARGO_PKG_VERSION")),
            ),
            ("variableNamingConvention", "structured".into()),
            ("numberOfEventIndicators", "0".into()),
        ],
    )?;
    // §4.3.1: capability flags. Async and directional derivatives are not provided (their
    // functions return fmi2Error); input interpolation and output derivatives are the
    // model's (`CoSimModel::capabilities`).
    empty(
        &mut w,
        "CoSimulation",
        &[
            ("modelIdentifier", id),
            ("needsExecutionTool", no()),
            ("canHandleVariableCommunicationStepSize", yes()),
            (
                "canInterpolateInputs",
                caps.can_interpolate_inputs.to_string(),
            ),
            (
                "maxOutputDerivativeOrder",
                caps.max_output_derivative_order.to_string(),
            ),
            ("canRunAsynchronuously", no()),
            ("canBeInstantiatedOnlyOncePerProcess", no()),
            ("canNotUseMemoryManagementFunctions", yes()),
            ("canGetAndSetFMUstate", yes()),
            ("canSerializeFMUstate", yes()),
            ("providesDirectionalDerivative", no()),
        ],
    )?;
    // §2.2.2: a present list must not be empty, so leave the element out without units.
    if !units.is_empty() {
        start(&mut w, "UnitDefinitions", &[])?;
        for u in &units {
            let Some(b) = base_unit(u) else {
                return Err(format!("unit '{u}' has no BaseUnit definition"));
            };
            start(&mut w, "Unit", &[("name", (*u).to_string())])?;
            let mut attrs = Vec::new();
            for (k, e) in [("kg", b.kg), ("m", b.m), ("s", b.s), ("rad", b.rad)] {
                if e != 0 {
                    attrs.push((k, e.to_string()));
                }
            }
            if b.factor != 1.0 {
                attrs.push(("factor", real(b.factor)));
            }
            empty(&mut w, "BaseUnit", &attrs)?;
            end(&mut w, "Unit")?;
        }
        end(&mut w, "UnitDefinitions")?;
    }
    start(&mut w, "LogCategories", &[])?;
    for c in Category::ALL {
        empty(
            &mut w,
            "Category",
            &[
                ("name", c.name().into()),
                ("description", c.description().into()),
            ],
        )?;
    }
    end(&mut w, "LogCategories")?;
    let d = info.default_experiment;
    let mut de = vec![
        ("startTime", real(d.start_time)),
        ("stopTime", real(d.stop_time)),
    ];
    if let Some(t) = d.tolerance {
        de.push(("tolerance", real(t)));
    }
    de.push(("stepSize", real(d.step_size)));
    empty(&mut w, "DefaultExperiment", &de)?;
    // §2.2.6: FMI 2.0 declares no highest order of fmi2SetRealInputDerivatives; a model that
    // takes more than order 1 says so here, so that a master can give it polynomial inputs.
    // A model that announces the times of its switches names the variable that holds them,
    // under a tool of its own (the schema allows one element per `Tool`, and a tool's name
    // once). Every geardyn FMU announces that its binary may be shared ([`SHARED_BINARY_TOOL`]).
    let higher_inputs = caps.can_interpolate_inputs && caps.max_input_derivative_order > 1;
    let switch_time = caps
        .switch_time
        .and_then(|vr| vars.iter().find(|v| v.value_reference == vr));
    start(&mut w, "VendorAnnotations", &[])?;
    if higher_inputs {
        start(&mut w, "Tool", &[("name", "geardyn".into())])?;
        empty(
            &mut w,
            "InputDerivatives",
            &[("maxOrder", caps.max_input_derivative_order.to_string())],
        )?;
        end(&mut w, "Tool")?;
    }
    if let Some(v) = switch_time {
        start(&mut w, "Tool", &[("name", SWITCH_TIMES_TOOL.into())])?;
        empty(&mut w, "SwitchTimes", &[("variable", v.name.clone())])?;
        end(&mut w, "Tool")?;
    }
    start(&mut w, "Tool", &[("name", SHARED_BINARY_TOOL.into())])?;
    empty(&mut w, "SharedBinary", &[])?;
    end(&mut w, "Tool")?;
    end(&mut w, "VendorAnnotations")?;

    start(&mut w, "ModelVariables", &[])?;
    for (i, v) in vars.iter().enumerate() {
        w.write_event(Event::Comment(quick_xml::events::BytesText::new(&format!(
            " index {} ",
            i + 1
        ))))
        .map_err(io)?;
        let mut attrs = vec![
            ("name", v.name.clone()),
            ("valueReference", v.value_reference.to_string()),
            ("description", v.description.clone()),
            ("causality", v.causality.as_str().into()),
            ("variability", v.variability.as_str().into()),
        ];
        if let Some(init) = v.initial {
            attrs.push(("initial", init.as_str().into()));
        }
        start(&mut w, "ScalarVariable", &attrs)?;
        let mut ta = Vec::new();
        if let Some(s) = v.start {
            ta.push((
                "start",
                match v.kind {
                    VarKind::Real => real(s),
                    VarKind::Integer => (s as i64).to_string(),
                    VarKind::Boolean => (s != 0.0).to_string(),
                },
            ));
        }
        if let Some(u) = &v.unit {
            ta.push(("unit", u.clone()));
        }
        if let Some(m) = v.min {
            ta.push(("min", real(m)));
        }
        if let Some(m) = v.max {
            ta.push(("max", real(m)));
        }
        empty(&mut w, v.kind.as_str(), &ta)?;
        end(&mut w, "ScalarVariable")?;
    }
    end(&mut w, "ModelVariables")?;

    // §2.2.8: Outputs lists every output; InitialUnknowns lists outputs with
    // initial = approx|calculated and all calculated parameters, sorted by index.
    let index_of = |vr: u32| {
        vars.iter()
            .position(|v| v.value_reference == vr)
            .map(|i| i + 1)
    };
    start(&mut w, "ModelStructure", &[])?;
    let outputs: Vec<(usize, &Variable)> = vars
        .iter()
        .enumerate()
        .filter(|(_, v)| v.causality == Causality::Output)
        .map(|(i, v)| (i + 1, v))
        .collect();
    if !outputs.is_empty() {
        start(&mut w, "Outputs", &[])?;
        for (i, v) in &outputs {
            let mut deps: Vec<usize> = v.depends_on.iter().filter_map(|d| index_of(*d)).collect();
            deps.sort_unstable();
            let deps: Vec<String> = deps.iter().map(usize::to_string).collect();
            empty(
                &mut w,
                "Unknown",
                &[("index", i.to_string()), ("dependencies", deps.join(" "))],
            )?;
        }
        end(&mut w, "Outputs")?;
    }
    let initial: Vec<usize> = vars
        .iter()
        .enumerate()
        .filter(|(_, v)| {
            (v.causality == Causality::Output
                && matches!(v.initial, Some(Initial::Approx | Initial::Calculated)))
                || v.causality == Causality::CalculatedParameter
        })
        .map(|(i, _)| i + 1)
        .collect();
    if !initial.is_empty() {
        start(&mut w, "InitialUnknowns", &[])?;
        for i in initial {
            empty(&mut w, "Unknown", &[("index", i.to_string())])?;
        }
        end(&mut w, "InitialUnknowns")?;
    }
    end(&mut w, "ModelStructure")?;
    end(&mut w, "fmiModelDescription")?;
    let mut s = String::from_utf8(w.into_inner().into_inner()).map_err(|e| e.to_string())?;
    s.push('\n');
    Ok(s)
}

/// Generates the description of a scene through the crate's factory.
pub fn for_scene(scene_path: &Path) -> Result<(String, ModelInfo), String> {
    let loaded = crate::fmu::entry::load_scene(scene_path)?;
    let xml = model_description(
        &loaded.info,
        loaded.model.variables(),
        loaded.model.capabilities(),
    )?;
    Ok((xml, loaded.info))
}

/// Compares (or with `write`, refreshes) the checked-in descriptions: every
/// `<scenes_root>/<name>/scene.toml` must have `<md_dir>/<modelIdentifier>.xml` identical to
/// the generator's output, and no stray XML may remain. Returns the problems found.
pub fn check_checked_in(
    scenes_root: &Path,
    md_dir: &Path,
    write: bool,
) -> Result<Vec<String>, String> {
    let mut problems = Vec::new();
    let mut expected = Vec::new();
    let mut dirs: Vec<_> = match std::fs::read_dir(scenes_root) {
        Ok(rd) => rd.filter_map(Result::ok).map(|e| e.path()).collect(),
        Err(_) => Vec::new(), // no shipped FMUs yet
    };
    dirs.sort();
    for dir in dirs {
        let scene = dir.join(crate::fmu::entry::SCENE_FILE);
        if !scene.is_file() {
            continue;
        }
        let (xml, info) = for_scene(&scene)?;
        let file = format!("{}.xml", model_identifier(&info.model_name));
        let path = md_dir.join(&file);
        expected.push(file);
        let current = std::fs::read_to_string(&path).ok();
        if current.as_deref() != Some(xml.as_str()) {
            if write {
                std::fs::create_dir_all(md_dir).map_err(|e| e.to_string())?;
                std::fs::write(&path, &xml).map_err(|e| format!("{}: {e}", path.display()))?;
            } else {
                problems.push(format!(
                    "{} is {} (generated from {}); regenerate with `geardyn fmu descriptions --write`",
                    path.display(),
                    if current.is_some() { "out of date" } else { "missing" },
                    scene.display()
                ));
            }
        }
    }
    if let Ok(rd) = std::fs::read_dir(md_dir) {
        for e in rd.filter_map(Result::ok) {
            let name = e.file_name().to_string_lossy().into_owned();
            if name.ends_with(".xml") && !expected.contains(&name) {
                problems.push(format!(
                    "{} has no scene under {}",
                    e.path().display(),
                    scenes_root.display()
                ));
            }
        }
    }
    Ok(problems)
}
