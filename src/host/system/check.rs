//! The system checked against its FMUs: every connection and connector resolved to FMU
//! variables, with a message naming the item for each way it can be wrong (issue 18, point
//! 4): unknown element or connector, a source without FMU, connector kind against the
//! variable's causality, type mismatch, unit mismatch through the base units (and a connector
//! unit that disagrees with the FMU's), an input connected twice, bad parameter values.
//! Algebraic loops are found by [`super::graph`] on the result.

use super::ssd::{Component, Connection, Kind, ParamValue, Ssd, SsdType};
use super::units::BaseUnit;
use crate::host::description::{Causality, ModelDescription, ScalarVariable, VarType};
use crate::host::start::{self, StartValue};

/// One FMU variable of one element.
#[derive(Debug, Clone, PartialEq)]
pub struct Port {
    pub element: usize,
    pub vr: u32,
    /// Real, Integer (also Enumeration) or Boolean.
    pub var_type: VarType,
    /// 1-based index in the FMU's `<ModelVariables>` (ModelStructure refers to it).
    pub index: usize,
    /// `Element.variable`.
    pub name: String,
}

/// A checked connection: end = scale · start + offset (unit conversion and
/// `ssc:LinearTransformation` folded into one affine map; `identity` when it is none, so
/// that values pass bit for bit).
#[derive(Debug, Clone, PartialEq)]
pub struct Link {
    pub from: Port,
    pub to: Port,
    pub scale: f64,
    pub offset: f64,
    pub identity: bool,
    /// `connection A.y → B.u (line 40)`.
    pub label: String,
}

#[derive(Debug, Clone)]
pub struct Element {
    pub name: String,
    /// Index of the element's FMU among the distinct sources.
    pub fmu: usize,
    pub start_values: Vec<StartValue>,
}

#[derive(Debug, Clone)]
pub struct System {
    pub elements: Vec<Element>,
    pub links: Vec<Link>,
}

/// The resolved unit of a variable or connector: its name and, when defined, its base units.
fn lookup(name: &str, ssd: &Ssd, md: &ModelDescription) -> Option<BaseUnit> {
    if let Some(u) = ssd.units.iter().find(|u| u.name == name) {
        return Some(u.base);
    }
    md.unit_definitions
        .iter()
        .find(|u| u.name == name)
        .and_then(|u| BaseUnit::from_attrs(&u.base_unit).ok())
}

fn base_type(t: VarType) -> VarType {
    if t == VarType::Enumeration {
        VarType::Integer
    } else {
        t
    }
}

fn ssd_type_matches(t: &SsdType, v: VarType) -> bool {
    matches!(
        (t, v),
        (SsdType::Real { .. }, VarType::Real)
            | (SsdType::Integer, VarType::Integer)
            | (SsdType::Boolean, VarType::Boolean)
            | (SsdType::String, VarType::String)
            | (SsdType::Enumeration, VarType::Enumeration)
    )
}

fn kind_matches(k: Kind, c: Causality) -> bool {
    matches!(
        (k, c),
        (Kind::Input, Causality::Input)
            | (Kind::Output, Causality::Output)
            | (Kind::Parameter, Causality::Parameter)
            | (Kind::CalculatedParameter, Causality::CalculatedParameter)
    )
}

/// The unit a connector carries: its own `unit=` (which must agree with the FMU's), else the
/// FMU variable's. `(name, base units if defined)`.
fn connector_unit(
    ssd: &Ssd,
    comp: &Component,
    md: &ModelDescription,
    v: &ScalarVariable,
) -> Result<Option<(String, Option<BaseUnit>)>, String> {
    let fmu_unit = md.unit_of(v).map(str::to_string);
    let declared = comp.connector(&v.name).and_then(|c| match &c.ty {
        Some(SsdType::Real { unit: Some(u) }) => Some((u.clone(), c.line)),
        _ => None,
    });
    match (declared, fmu_unit) {
        (None, None) => Ok(None),
        (None, Some(f)) => {
            let b = lookup(&f, ssd, md);
            Ok(Some((f, b)))
        }
        (Some((d, line)), fmu) => {
            let db = lookup(&d, ssd, md).ok_or_else(|| {
                format!(
                    "SystemStructure.ssd line {line}: connector {}.{} has unit=\"{d}\", which is defined neither in <ssd:Units> nor in the FMU's UnitDefinitions",
                    comp.name, v.name
                )
            })?;
            if let Some(f) = fmu {
                if f != d {
                    let fb = lookup(&f, ssd, md);
                    if !fb.is_some_and(|fb| fb.equivalent(&db)) {
                        return Err(format!(
                            "SystemStructure.ssd line {line}: connector {}.{} has unit=\"{d}\" ({}), but the FMU declares \"{}\" with unit=\"{f}\"{}",
                            comp.name,
                            v.name,
                            describe(&db),
                            v.name,
                            fb.map(|b| format!(" ({})", describe(&b))).unwrap_or_default()
                        ));
                    }
                }
            }
            Ok(Some((d, Some(db))))
        }
    }
}

fn describe(b: &BaseUnit) -> String {
    let mut s = b.dimension();
    if b.factor != 1.0 {
        s.push_str(&format!(", factor {}", b.factor));
    }
    if b.offset != 0.0 {
        s.push_str(&format!(", offset {}", b.offset));
    }
    s
}

fn text(v: &ParamValue) -> String {
    match v {
        ParamValue::Real(x) => format!("{x:?}"),
        ParamValue::Integer(i) => i.to_string(),
        ParamValue::Boolean(b) => b.to_string(),
        ParamValue::String(s) => s.clone(),
    }
}

/// Check `ssd` against the model descriptions (`mds[fmu_of[i]]` belongs to component i) and
/// the `--start Element.variable=value` pairs; the checked system.
pub fn check(
    ssd: &Ssd,
    mds: &[ModelDescription],
    fmu_of: &[usize],
    cli_starts: &[(String, String)],
) -> Result<System, String> {
    let mut elements = Vec::new();
    for (i, comp) in ssd.components.iter().enumerate() {
        let md = &mds[fmu_of[i]];
        for c in &comp.connectors {
            let v = md.variable(&c.name).ok_or_else(|| {
                format!(
                    "SystemStructure.ssd line {}: connector {}.{}: the FMU {} has no variable \"{}\"",
                    c.line, comp.name, c.name, comp.source, c.name
                )
            })?;
            if !kind_matches(c.kind, v.causality) {
                return Err(format!(
                    "SystemStructure.ssd line {}: connector {}.{} has kind=\"{}\", but the FMU's variable \"{}\" has causality=\"{}\"",
                    c.line, comp.name, c.name, c.kind.as_str(), c.name, v.causality
                ));
            }
            if let Some(t) = &c.ty {
                if !ssd_type_matches(t, v.var_type) {
                    return Err(format!(
                        "SystemStructure.ssd line {}: connector {}.{} is declared {}, but the FMU's variable \"{}\" is {}",
                        c.line, comp.name, c.name, t.name(), c.name, v.var_type
                    ));
                }
            }
            connector_unit(ssd, comp, md, v)?;
        }
        let mut starts: Vec<StartValue> = Vec::new();
        let mut add = |s: Vec<StartValue>| {
            for s in s {
                starts.retain(|x| x.name != s.name);
                starts.push(s);
            }
        };
        for p in &comp.parameters {
            let pair = (p.name.clone(), text(&p.value));
            let s = start::resolve(md, std::slice::from_ref(&pair)).map_err(|e| {
                format!(
                    "{}: parameter of element \"{}\": {}",
                    p.origin,
                    comp.name,
                    e.trim_start_matches("--start ")
                )
            })?;
            if let (Some(pu), Some(v)) = (&p.unit, md.variable(&p.name)) {
                if let Some(fu) = md.unit_of(v) {
                    let same = pu == fu
                        || matches!((lookup(pu, ssd, md), lookup(fu, ssd, md)), (Some(a), Some(b)) if a.equivalent(&b));
                    if !same {
                        return Err(format!(
                            "{}: parameter \"{}\" of element \"{}\" is given in unit=\"{pu}\", but the FMU declares unit=\"{fu}\" (give the value in the FMU's unit)",
                            p.origin, p.name, comp.name
                        ));
                    }
                }
            }
            add(s);
        }
        let prefix = format!("{}.", comp.name);
        for (n, v) in cli_starts {
            if let Some(var) = n.strip_prefix(&prefix) {
                let s = start::resolve(md, &[(var.to_string(), v.clone())]).map_err(|e| {
                    e.replacen(&format!("--start {var}="), &format!("--start {n}="), 1)
                })?;
                add(s);
            }
        }
        starts.sort_by_key(|s| md.variable(&s.name).map(|v| v.index));
        elements.push(Element {
            name: comp.name.clone(),
            fmu: fmu_of[i],
            start_values: starts,
        });
    }
    for (n, _) in cli_starts {
        let known = n
            .split_once('.')
            .is_some_and(|(e, _)| ssd.component(e).is_some());
        if !known {
            return Err(format!(
                "--start {n}: name a variable as Element.variable, with one of the elements {}",
                names(ssd)
            ));
        }
    }
    let mut links: Vec<Link> = Vec::new();
    for c in &ssd.connections {
        let link = resolve(ssd, mds, fmu_of, c)?;
        if let Some(other) = links.iter().find(|l| l.to == link.to) {
            return Err(format!(
                "{}: the input {} is already connected by {}; an input takes one connection",
                link.label, link.to.name, other.label
            ));
        }
        links.push(link);
    }
    Ok(System { elements, links })
}

fn names(ssd: &Ssd) -> String {
    ssd.components
        .iter()
        .map(|c| format!("\"{}\"", c.name))
        .collect::<Vec<_>>()
        .join(", ")
}

/// One connection end: the component, its connector and the FMU variable.
fn end<'a>(
    ssd: &'a Ssd,
    mds: &'a [ModelDescription],
    fmu_of: &[usize],
    c: &Connection,
    element: &str,
    connector: &str,
    which: &str,
) -> Result<
    (
        usize,
        &'a Component,
        &'a ModelDescription,
        &'a ScalarVariable,
        Kind,
    ),
    String,
> {
    let label = c.label();
    let i = ssd
        .components
        .iter()
        .position(|x| x.name == element)
        .ok_or_else(|| {
            format!(
                "{label}: unknown {which} element \"{element}\" (the system has {})",
                names(ssd)
            )
        })?;
    let comp = &ssd.components[i];
    let conn = comp.connector(connector).ok_or_else(|| {
        let have: Vec<String> = comp
            .connectors
            .iter()
            .map(|k| format!("\"{}\"", k.name))
            .collect();
        format!(
            "{label}: element \"{element}\" has no connector \"{connector}\" (its <ssd:Connectors> declare {})",
            if have.is_empty() {
                "none".to_string()
            } else {
                have.join(", ")
            }
        )
    })?;
    let md = &mds[fmu_of[i]];
    // Checked with the connectors above.
    let v = md.variable(connector).ok_or_else(|| {
        format!("{label}: the FMU of \"{element}\" has no variable \"{connector}\"")
    })?;
    Ok((i, comp, md, v, conn.kind))
}

fn resolve(
    ssd: &Ssd,
    mds: &[ModelDescription],
    fmu_of: &[usize],
    c: &Connection,
) -> Result<Link, String> {
    let label = c.label();
    let (ei, ecomp, emd, ev, ekind) = end(
        ssd,
        mds,
        fmu_of,
        c,
        &c.start_element,
        &c.start_connector,
        "start",
    )?;
    let (ti, tcomp, tmd, tv, tkind) =
        end(ssd, mds, fmu_of, c, &c.end_element, &c.end_connector, "end")?;
    if ekind != Kind::Output {
        return Err(format!(
            "{label}: the start {}.{} is an {} connector (causality \"{}\"); a connection starts at an output",
            c.start_element,
            c.start_connector,
            ekind.as_str(),
            ev.causality
        ));
    }
    if tkind != Kind::Input {
        return Err(format!(
            "{label}: the end {}.{} is an {} connector (causality \"{}\"); a connection ends at an input",
            c.end_element,
            c.end_connector,
            tkind.as_str(),
            tv.causality
        ));
    }
    let (st, tt) = (base_type(ev.var_type), base_type(tv.var_type));
    if st != tt || st == VarType::String {
        return Err(format!(
            "{label}: type mismatch: {}.{} is {}, {}.{} is {}{}",
            c.start_element,
            c.start_connector,
            ev.var_type,
            c.end_element,
            c.end_connector,
            tv.var_type,
            if st == VarType::String && st == tt {
                " (String connections are not supported)"
            } else {
                ""
            }
        ));
    }
    let (mut scale, mut offset, mut identity) = (1.0, 0.0, true);
    if let Some((f, o)) = c.transformation {
        if st != VarType::Real {
            return Err(format!(
                "{label}: ssc:LinearTransformation needs Real connectors, not {}",
                ev.var_type
            ));
        }
        (scale, offset, identity) = (f, o, f == 1.0 && o == 0.0);
    } else if st == VarType::Real {
        let su = connector_unit(ssd, ecomp, emd, ev)?;
        let tu = connector_unit(ssd, tcomp, tmd, tv)?;
        if let (Some((sn, sb)), Some((tn, tb))) = (su, tu) {
            if sn != tn {
                match (sb, tb) {
                    (Some(sb), Some(tb)) if sb.compatible(&tb) => {
                        (scale, offset) = sb.conversion_to(&tb);
                        identity = scale == 1.0 && offset == 0.0;
                    }
                    (Some(sb), Some(tb)) => {
                        return Err(format!(
                            "{label}: unit mismatch: {}.{} is in \"{sn}\" ({}), {}.{} in \"{tn}\" ({}); the base units differ",
                            c.start_element,
                            c.start_connector,
                            describe(&sb),
                            c.end_element,
                            c.end_connector,
                            describe(&tb)
                        ))
                    }
                    _ => {
                        return Err(format!(
                            "{label}: units \"{sn}\" and \"{tn}\" differ and cannot be compared: define both in <ssd:Units> (ssc:Unit with ssc:BaseUnit)"
                        ))
                    }
                }
            }
        }
    }
    let port = |element: usize, v: &ScalarVariable, e: &str| Port {
        element,
        vr: v.value_reference,
        var_type: base_type(v.var_type),
        index: v.index,
        name: format!("{e}.{}", v.name),
    };
    Ok(Link {
        from: port(ei, ev, &c.start_element),
        to: port(ti, tv, &c.end_element),
        scale,
        offset,
        identity,
        label,
    })
}
