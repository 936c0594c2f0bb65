//! Semantic validation of a parsed [`ModelDescription`], reported like a validator would
//! (a list of problems, each naming the variable/element, the attribute and the value).
//!
//! Coverage follows `fmpy validate` (the strictest of the checkers compared in
//! `reference/fmi2-cosimulation-notes.md` §2.3) plus checks it lacks (value references,
//! min/max, declared types, DefaultExperiment, CoSimulation capabilities).

use super::description::{
    Causality, Initial, ModelDescription, ScalarVariable, Value, VarType, Variability,
};
use std::collections::{BTreeSet, HashMap, HashSet};

/// All problems found, in document order. Empty means "no problems found".
pub fn check(md: &ModelDescription) -> Vec<String> {
    let mut p = Vec::new();
    check_header(md, &mut p);
    check_variables(md, &mut p);
    check_units_and_types(md, &mut p);
    check_model_structure(md, &mut p);
    p
}

/// `modelIdentifier` is "Short class name according to C syntax" (FMI 2.0.5 §4.3.1) and names
/// the shared library; a non-identifier can never be loaded portably.
fn is_c_identifier(s: &str) -> bool {
    let mut chars = s.chars();
    matches!(chars.next(), Some(c) if c == '_' || c.is_ascii_alphabetic())
        && chars.all(|c| c == '_' || c.is_ascii_alphanumeric())
}

fn check_header(md: &ModelDescription, p: &mut Vec<String>) {
    if md.model_name.is_empty() {
        p.push("fmiModelDescription: modelName is empty".into());
    }
    if md.guid.is_empty() {
        p.push("fmiModelDescription: guid is empty".into());
    }
    if let Some(c) = &md.variable_naming_convention {
        if c != "flat" && c != "structured" {
            p.push(format!(
                "fmiModelDescription: variableNamingConvention=\"{c}\" is not one of flat, structured"
            ));
        }
    }
    match &md.co_simulation {
        None => p.push(if let Some(me) = &md.model_exchange {
            format!("the FMU declares only <ModelExchange modelIdentifier=\"{me}\"> and no <CoSimulation>; it cannot be co-simulated")
        } else {
            "neither <CoSimulation> nor <ModelExchange> is declared".into()
        }),
        Some(cs) => {
            if !is_c_identifier(&cs.model_identifier) {
                p.push(format!(
                    "<CoSimulation>: modelIdentifier=\"{}\" is not a C identifier (FMI 2.0.5 §4.3.1)",
                    cs.model_identifier
                ));
            }
            if cs.can_serialize_fmu_state && !cs.can_get_and_set_fmu_state {
                p.push("<CoSimulation>: canSerializeFMUstate=\"true\" requires canGetAndSetFMUstate=\"true\"".into());
            }
        }
    }
    if let Some(de) = &md.default_experiment {
        for (name, v) in [
            ("startTime", de.start_time),
            ("stopTime", de.stop_time),
            ("tolerance", de.tolerance),
            ("stepSize", de.step_size),
        ] {
            if let Some(v) = v {
                if !v.is_finite() {
                    p.push(format!("<DefaultExperiment>: {name}=\"{v}\" is not finite"));
                }
            }
        }
        if let (Some(a), Some(b)) = (de.start_time, de.stop_time) {
            if b < a {
                p.push(format!(
                    "<DefaultExperiment>: stopTime=\"{b}\" is before startTime=\"{a}\""
                ));
            }
        }
        for (name, v) in [("tolerance", de.tolerance), ("stepSize", de.step_size)] {
            if let Some(v) = v {
                if v <= 0.0 {
                    p.push(format!("<DefaultExperiment>: {name}=\"{v}\" must be > 0"));
                }
            }
        }
    }
    let mut cats = HashSet::new();
    for c in &md.log_categories {
        if !cats.insert(c.name.as_str()) {
            p.push(format!(
                "<LogCategories>: category name \"{}\" is not unique",
                c.name
            ));
        }
    }
}

/// Legal (causality, variability, initial) combinations of FMI 2.0.5 §2.2.7 (the table after
/// the definition of `initial`); `initial` here is the effective one (defaults applied).
fn legal(c: Causality, v: Variability, i: Option<Initial>) -> bool {
    use Causality as C;
    use Initial as I;
    use Variability as V;
    matches!(
        (c, v, i),
        (C::Parameter, V::Fixed | V::Tunable, Some(I::Exact))
            | (
                C::CalculatedParameter,
                V::Fixed | V::Tunable,
                Some(I::Calculated | I::Approx)
            )
            | (C::Input, V::Discrete | V::Continuous, None)
            | (C::Output, V::Constant, Some(I::Exact))
            | (C::Output, V::Discrete | V::Continuous, Some(_))
            | (C::Local, V::Constant, Some(I::Exact))
            | (
                C::Local,
                V::Fixed | V::Tunable,
                Some(I::Calculated | I::Approx)
            )
            | (C::Local, V::Discrete | V::Continuous, Some(_))
            | (C::Independent, V::Continuous, None)
    )
}

fn check_variables(md: &ModelDescription, p: &mut Vec<String>) {
    let mut names: HashMap<&str, &ScalarVariable> = HashMap::new();
    let mut independents = 0;
    // Alias sets: same base type (Enumeration shares Integer's VR space) and same VR.
    let mut aliases: HashMap<(VarType, u32), Vec<&ScalarVariable>> = HashMap::new();
    for v in &md.variables {
        if v.name.is_empty() {
            p.push(format!("{}: name is empty", v.loc()));
        }
        if let Some(first) = names.get(v.name.as_str()) {
            p.push(format!(
                "{}: the name is not unique (also {})",
                v.loc(),
                first.loc()
            ));
        } else {
            names.insert(&v.name, v);
        }
        if v.name.chars().any(|c| c == '\r' || c == '\n' || c == '\t') {
            p.push(format!(
                "{}: name contains a line break or tab character",
                v.loc()
            ));
        }
        if v.var_type != VarType::Real && v.variability == Variability::Continuous {
            p.push(format!(
                "{}: type {} must have variability != \"continuous\" (only Real may be continuous)",
                v.loc(),
                v.var_type
            ));
        }
        // Given explicitly, `initial` is not allowed for input/independent (spec table).
        if v.initial.is_some() && matches!(v.causality, Causality::Input | Causality::Independent) {
            p.push(format!(
                "{}: causality=\"{}\" must not have an initial attribute (initial=\"{}\")",
                v.loc(),
                v.causality,
                v.initial.map(|i| i.as_str()).unwrap_or("")
            ));
        } else if !legal(v.causality, v.variability, v.effective_initial()) {
            p.push(format!(
                "{}: the combination causality=\"{}\", variability=\"{}\", initial=\"{}\" is not allowed (FMI 2.0.5 §2.2.7)",
                v.loc(),
                v.causality,
                v.variability,
                v.effective_initial().map(|i| i.as_str()).unwrap_or("(none)")
            ));
        }
        let init = v.effective_initial();
        let needs_start = matches!(init, Some(Initial::Exact | Initial::Approx))
            || v.causality == Causality::Input;
        if needs_start && v.start.is_none() {
            p.push(format!(
                "{}: has no start value (required for causality=\"{}\", initial=\"{}\")",
                v.loc(),
                v.causality,
                init.map(|i| i.as_str()).unwrap_or("(none)")
            ));
        }
        if let Some(s) = &v.start {
            if init == Some(Initial::Calculated) {
                p.push(format!(
                    "{}: has initial=\"calculated\" but provides start=\"{s}\"",
                    v.loc()
                ));
            }
            if v.causality == Causality::Independent {
                p.push(format!(
                    "{}: has causality=\"independent\" but provides start=\"{s}\"",
                    v.loc()
                ));
            }
            let numeric = match s {
                Value::Real(x) => Some(*x),
                Value::Integer(i) => Some(f64::from(*i)),
                _ => None,
            };
            if let Some(x) = numeric {
                if let Some(min) = v.min {
                    if x < min {
                        p.push(format!("{}: start=\"{s}\" is below min=\"{min}\"", v.loc()));
                    }
                }
                if let Some(max) = v.max {
                    if x > max {
                        p.push(format!("{}: start=\"{s}\" is above max=\"{max}\"", v.loc()));
                    }
                }
            }
        }
        if let (Some(min), Some(max)) = (v.min, v.max) {
            if min > max {
                p.push(format!(
                    "{}: min=\"{min}\" is greater than max=\"{max}\"",
                    v.loc()
                ));
            }
        }
        if v.causality == Causality::Independent {
            independents += 1;
            if v.var_type != VarType::Real {
                p.push(format!(
                    "{}: the independent variable must be of type Real",
                    v.loc()
                ));
            }
        }
        if let Some(d) = v.derivative {
            match md.variables.get((d as usize).wrapping_sub(1)) {
                None => p.push(format!(
                    "{}: derivative=\"{d}\" is not a variable index (1..={})",
                    v.loc(),
                    md.variables.len()
                )),
                Some(s) if s.var_type != VarType::Real => p.push(format!(
                    "{}: derivative=\"{d}\" refers to {} of type {}, expected Real",
                    v.loc(),
                    s.loc(),
                    s.var_type
                )),
                _ => {}
            }
            if v.var_type != VarType::Real {
                p.push(format!(
                    "{}: only Real variables may have a derivative attribute",
                    v.loc()
                ));
            }
        }
        let base = if v.var_type == VarType::Enumeration {
            VarType::Integer
        } else {
            v.var_type
        };
        aliases
            .entry((base, v.value_reference))
            .or_default()
            .push(v);
    }
    if independents > 1 {
        p.push(format!(
            "{independents} variables have causality=\"independent\"; at most one is allowed"
        ));
    }
    // FMI 2.0.5 §2.2.7: aliases share one value reference; at most one of a set of
    // non-constant aliases may carry a start value, and a set must not mix constants with
    // non-constants, or two inputs (two writers for one storage location).
    let mut sets: Vec<_> = aliases.into_iter().filter(|(_, vs)| vs.len() > 1).collect();
    sets.sort_by_key(|((t, vr), _)| (*t, *vr));
    for ((t, vr), vs) in sets {
        let list = || {
            vs.iter()
                .map(|v| format!("\"{}\"", v.name))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let constants = vs
            .iter()
            .filter(|v| v.variability == Variability::Constant)
            .count();
        if constants > 0 && constants < vs.len() {
            p.push(format!(
                "valueReference=\"{vr}\" ({t}) is shared by {} but only some of them are constant",
                list()
            ));
        }
        let starts = vs
            .iter()
            .filter(|v| v.start.is_some() && v.variability != Variability::Constant)
            .count();
        if starts > 1 {
            p.push(format!(
                "valueReference=\"{vr}\" ({t}) is shared by {}, and {starts} of them have a start value (at most one may)",
                list()
            ));
        }
        let inputs = vs
            .iter()
            .filter(|v| v.causality == Causality::Input)
            .count();
        if inputs > 1 {
            p.push(format!(
                "valueReference=\"{vr}\" ({t}) is shared by {} of which {inputs} are inputs",
                list()
            ));
        }
    }
}

fn check_units_and_types(md: &ModelDescription, p: &mut Vec<String>) {
    let mut units: HashMap<&str, Vec<&str>> = HashMap::new();
    for u in &md.unit_definitions {
        if units
            .insert(
                &u.name,
                u.display_units.iter().map(|d| d.name.as_str()).collect(),
            )
            .is_some()
        {
            p.push(format!(
                "<UnitDefinitions>: unit name \"{}\" is not unique",
                u.name
            ));
        }
    }
    let mut types = HashSet::new();
    for t in &md.type_definitions {
        if !types.insert(t.name.as_str()) {
            p.push(format!(
                "<TypeDefinitions>: type name \"{}\" is not unique",
                t.name
            ));
        }
        if let Some(u) = &t.unit {
            if !units.contains_key(u.as_str()) {
                p.push(format!(
                    "<SimpleType name=\"{}\">: unit=\"{u}\" is not defined in <UnitDefinitions>",
                    t.name
                ));
            }
        }
        if t.var_type == VarType::Enumeration && t.items.is_empty() {
            p.push(format!(
                "<SimpleType name=\"{}\">: an Enumeration needs at least one <Item>",
                t.name
            ));
        }
    }
    for v in &md.variables {
        match &v.declared_type {
            Some(dt) => match md.simple_type(dt) {
                None => p.push(format!(
                    "{}: declaredType=\"{dt}\" is not defined in <TypeDefinitions>",
                    v.loc()
                )),
                Some(t) if t.var_type != v.var_type => p.push(format!(
                    "{}: declaredType=\"{dt}\" is a {} type but the variable is {}",
                    v.loc(),
                    t.var_type,
                    v.var_type
                )),
                _ => {}
            },
            None if v.var_type == VarType::Enumeration => p.push(format!(
                "{}: an Enumeration variable requires declaredType",
                v.loc()
            )),
            None => {}
        }
        let unit = md.unit_of(v);
        if let Some(u) = unit {
            if !units.contains_key(u) {
                p.push(format!(
                    "{}: unit=\"{u}\" is not defined in <UnitDefinitions>",
                    v.loc()
                ));
            }
        }
        if let Some(du) = &v.display_unit {
            let ok = unit
                .and_then(|u| units.get(u))
                .is_some_and(|ds| ds.contains(&du.as_str()));
            if !ok {
                p.push(format!(
                    "{}: displayUnit=\"{du}\" is not a <DisplayUnit> of unit \"{}\"",
                    v.loc(),
                    unit.unwrap_or("(none)")
                ));
            }
        }
    }
}

fn check_model_structure(md: &ModelDescription, p: &mut Vec<String>) {
    let n = md.variables.len();
    let var = |i: usize| md.variables.get(i.wrapping_sub(1));
    let ms = &md.model_structure;
    let mut lists: Vec<(&str, &Vec<super::description::Unknown>)> = vec![
        ("Outputs", &ms.outputs),
        ("InitialUnknowns", &ms.initial_unknowns),
    ];
    if let Some(d) = &ms.derivatives {
        lists.push(("Derivatives", d));
    }
    let mut valid = true;
    for (what, list) in &lists {
        let mut seen = HashSet::new();
        for (k, u) in list.iter().enumerate() {
            let ctx = format!("<ModelStructure>/<{what}>/<Unknown> #{}", k + 1);
            if var(u.index).is_none() {
                p.push(format!(
                    "{ctx}: index=\"{}\" is not a variable index (1..={n})",
                    u.index
                ));
                valid = false;
            } else if !seen.insert(u.index) {
                p.push(format!("{ctx}: index=\"{}\" is listed twice", u.index));
            }
            if let Some(deps) = &u.dependencies {
                for d in deps {
                    if var(*d).is_none() {
                        p.push(format!(
                            "{ctx}: dependencies contains \"{d}\", which is not a variable index (1..={n})"
                        ));
                    }
                }
            }
            match (&u.dependencies, &u.dependencies_kind) {
                (None, Some(_)) => p.push(format!(
                    "{ctx}: dependenciesKind is given without dependencies"
                )),
                (Some(d), Some(k)) if d.len() != k.len() => p.push(format!(
                    "{ctx}: dependencies has {} entries but dependenciesKind has {}",
                    d.len(),
                    k.len()
                )),
                _ => {}
            }
            if let Some(kinds) = &u.dependencies_kind {
                for kind in kinds {
                    if !matches!(
                        kind.as_str(),
                        "dependent" | "constant" | "fixed" | "tunable" | "discrete"
                    ) {
                        p.push(format!(
                            "{ctx}: dependenciesKind contains \"{kind}\" (expected dependent, constant, fixed, tunable or discrete)"
                        ));
                    }
                }
            }
        }
    }
    // FMI 2.0.5 §2.2.8: "<Outputs>: ... every variable with causality="output" must be listed".
    let expected: BTreeSet<usize> = md
        .variables
        .iter()
        .filter(|v| v.causality == Causality::Output)
        .map(|v| v.index)
        .collect();
    let listed: BTreeSet<usize> = ms.outputs.iter().map(|u| u.index).collect();
    for i in expected.difference(&listed) {
        p.push(format!(
            "<ModelStructure>/<Outputs>: output {} is not listed",
            md.variables[i - 1].loc()
        ));
    }
    for i in listed.difference(&expected) {
        if let Some(v) = var(*i) {
            p.push(format!(
                "<ModelStructure>/<Outputs>: lists {} whose causality is \"{}\", not output",
                v.loc(),
                v.causality
            ));
        }
    }
    if let Some(ders) = &ms.derivatives {
        for u in ders {
            if let Some(v) = var(u.index) {
                if v.derivative.is_none() {
                    p.push(format!(
                        "<ModelStructure>/<Derivatives>: lists {} which has no derivative attribute",
                        v.loc()
                    ));
                }
            }
        }
    }
    if !valid {
        return; // the InitialUnknowns set cannot be computed from broken indices
    }
    // FMI 2.0.5 §2.2.8 InitialUnknowns: exactly (a) outputs with initial approx|calculated,
    // (b) all calculated parameters, (c) states and derivatives with approx|calculated
    // (only when <Derivatives> is present).
    let mut want: BTreeSet<usize> = BTreeSet::new();
    for v in &md.variables {
        let ac = matches!(
            v.effective_initial(),
            Some(Initial::Approx | Initial::Calculated)
        );
        if (v.causality == Causality::Output && ac) || v.causality == Causality::CalculatedParameter
        {
            want.insert(v.index);
        }
    }
    if let Some(ders) = &ms.derivatives {
        for u in ders {
            let Some(der) = var(u.index) else { continue };
            let mut pair = vec![der];
            if let Some(state) = der.derivative.and_then(|s| var(s as usize)) {
                pair.push(state);
            }
            for v in pair {
                if matches!(
                    v.effective_initial(),
                    Some(Initial::Approx | Initial::Calculated)
                ) {
                    want.insert(v.index);
                }
            }
        }
    }
    let have: BTreeSet<usize> = ms.initial_unknowns.iter().map(|u| u.index).collect();
    let names = |s: &BTreeSet<usize>| {
        s.iter()
            .filter_map(|i| var(*i))
            .map(|v| format!("\"{}\"", v.name))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let missing: BTreeSet<usize> = want.difference(&have).copied().collect();
    let extra: BTreeSet<usize> = have.difference(&want).copied().collect();
    if !missing.is_empty() {
        p.push(format!(
            "<ModelStructure>/<InitialUnknowns>: missing {}",
            names(&missing)
        ));
    }
    if !extra.is_empty() {
        p.push(format!(
            "<ModelStructure>/<InitialUnknowns>: must not list {}",
            names(&extra)
        ));
    }
    let idx: Vec<usize> = ms.initial_unknowns.iter().map(|u| u.index).collect();
    if idx.windows(2).any(|w| w[0] > w[1]) {
        p.push("<ModelStructure>/<InitialUnknowns>: entries are not sorted by index".into());
    }
}
