//! `SystemStructure.ssd` and `.ssv` files (Modelica Association, *System Structure and
//! Parameterization* SSP 1.0, 2019): the parts a fixed-step master needs.
//!
//! Read: `ssd:SystemStructureDescription` (name) → one `ssd:System` with `ssd:Elements`
//! (`ssd:Component source=` of type `application/x-fmu-sharedlibrary`, its `ssd:Connectors`
//! with `kind=` and a type element `ssc:Real unit=` / `ssc:Integer` / `ssc:Boolean` /
//! `ssc:String` / `ssc:Enumeration`, and `ssd:ParameterBindings`), `ssd:Connections`
//! (`startElement`/`startConnector`/`endElement`/`endConnector`, optional
//! `ssc:LinearTransformation factor= offset=`), `ssd:Units` (`ssc:Unit` with `ssc:BaseUnit`),
//! `ssd:DefaultExperiment startTime= stopTime=`.
//!
//! Refused with a message naming the item (instead of being ignored): nested systems,
//! connections to the system's own connectors, signal dictionaries, parameter mappings,
//! other connection transformations, components that are not FMUs. This module checks the
//! file on its own; [`super::check`] checks it against the FMUs.

use super::units::BaseUnit;
use super::xml::Node;

/// `kind` of an `ssd:Connector` (SSP 1.0 §5.3.3).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    Input,
    Output,
    Parameter,
    CalculatedParameter,
    Inout,
}

impl Kind {
    fn parse(s: &str) -> Option<Kind> {
        Some(match s {
            "input" => Kind::Input,
            "output" => Kind::Output,
            "parameter" => Kind::Parameter,
            "calculatedParameter" => Kind::CalculatedParameter,
            "inout" => Kind::Inout,
            _ => return None,
        })
    }

    pub fn as_str(self) -> &'static str {
        match self {
            Kind::Input => "input",
            Kind::Output => "output",
            Kind::Parameter => "parameter",
            Kind::CalculatedParameter => "calculatedParameter",
            Kind::Inout => "inout",
        }
    }
}

/// The type element of a connector or parameter (`ssc:Real`, …), with the unit of a Real.
#[derive(Debug, Clone, PartialEq)]
pub enum SsdType {
    Real { unit: Option<String> },
    Integer,
    Boolean,
    String,
    Enumeration,
}

impl SsdType {
    pub fn name(&self) -> &'static str {
        match self {
            SsdType::Real { .. } => "Real",
            SsdType::Integer => "Integer",
            SsdType::Boolean => "Boolean",
            SsdType::String => "String",
            SsdType::Enumeration => "Enumeration",
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct Connector {
    pub name: String,
    pub kind: Kind,
    /// `None` when the connector gives no type element (the FMU variable's type applies).
    pub ty: Option<SsdType>,
    pub line: usize,
}

/// One value of a parameter set (`ssv:Parameter`).
#[derive(Debug, Clone, PartialEq)]
pub enum ParamValue {
    Real(f64),
    Integer(i64),
    Boolean(bool),
    String(String),
}

#[derive(Debug, Clone, PartialEq)]
pub struct Parameter {
    pub name: String,
    pub value: ParamValue,
    /// `unit=` of an `ssv:Real` (checked against the FMU variable's unit).
    pub unit: Option<String>,
    /// Where it was given, for messages: `file.ssv line 12` or `SystemStructure.ssd line 40`.
    pub origin: String,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Component {
    pub name: String,
    /// `source` as written (a path relative to the SSP's root, e.g. `resources/a.fmu`).
    pub source: String,
    pub connectors: Vec<Connector>,
    /// Parameter values of all bindings, in document order (later ones override).
    pub parameters: Vec<Parameter>,
    pub line: usize,
}

impl Component {
    pub fn connector(&self, name: &str) -> Option<&Connector> {
        self.connectors.iter().find(|c| c.name == name)
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct Connection {
    pub start_element: String,
    pub start_connector: String,
    pub end_element: String,
    pub end_connector: String,
    /// `ssc:LinearTransformation`: end = factor · start + offset.
    pub transformation: Option<(f64, f64)>,
    pub line: usize,
}

impl Connection {
    /// `A.y → B.u (line 40)`, the name used in messages.
    pub fn label(&self) -> String {
        format!(
            "connection {}.{} → {}.{} (line {})",
            self.start_element,
            self.start_connector,
            self.end_element,
            self.end_connector,
            self.line
        )
    }
}

/// A unit of `ssd:Units`.
#[derive(Debug, Clone, PartialEq)]
pub struct SsdUnit {
    pub name: String,
    pub base: BaseUnit,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Ssd {
    pub name: String,
    pub system_name: String,
    pub components: Vec<Component>,
    pub connections: Vec<Connection>,
    pub units: Vec<SsdUnit>,
    pub start_time: Option<f64>,
    pub stop_time: Option<f64>,
}

impl Ssd {
    pub fn component(&self, name: &str) -> Option<&Component> {
        self.components.iter().find(|c| c.name == name)
    }
}

/// Reads the files a parameter binding refers to (`.ssv` beside the `.ssd` or in the archive).
pub trait Resources {
    /// The text of `source` (relative to the SSP's root), or a message why not.
    fn read(&self, source: &str) -> Result<String, String>;
}

const FILE: &str = "SystemStructure.ssd";

fn at(line: usize) -> String {
    format!("{FILE} line {line}")
}

fn required<'a>(n: &'a Node, attr: &str, what: &str) -> Result<&'a str, String> {
    n.attr(attr).ok_or_else(|| {
        format!(
            "{}: <{}>{what} has no {attr} attribute (required, SSP 1.0)",
            at(n.line),
            n.name
        )
    })
}

fn number(n: &Node, attr: &str, origin: &str) -> Result<Option<f64>, String> {
    match n.attr(attr) {
        None => Ok(None),
        Some(t) => match t.trim().parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(Some(v)),
            _ => Err(format!(
                "{origin}: <{}> {attr}=\"{t}\" is not a finite number",
                n.name
            )),
        },
    }
}

/// Parse `SystemStructure.ssd` text; `.ssv` files of parameter bindings are read through
/// `resources`.
pub fn parse(text: &str, resources: &dyn Resources) -> Result<Ssd, String> {
    let root = super::xml::parse(text, FILE)?;
    if root.name != "SystemStructureDescription" {
        return Err(format!(
            "{}: the root element is <{}>, expected <ssd:SystemStructureDescription>",
            at(root.line),
            root.name
        ));
    }
    match root.attr("version") {
        Some(v) if v.starts_with("1.") => {}
        Some(v) => {
            return Err(format!(
                "{}: version=\"{v}\": geardyn reads SSP 1.0 system structures (version=\"1.0\")",
                at(root.line)
            ))
        }
        None => {
            return Err(format!(
                "{}: <ssd:SystemStructureDescription> has no version attribute (required, SSP 1.0: \"1.0\")",
                at(root.line)
            ))
        }
    }
    let name = root.attr("name").unwrap_or("").to_string();
    let system = root.first("System").ok_or_else(|| {
        format!(
            "{}: <ssd:SystemStructureDescription> has no <ssd:System>",
            at(root.line)
        )
    })?;
    let mut units = Vec::new();
    if let Some(us) = root.first("Units") {
        for u in us.all("Unit") {
            let uname = required(u, "name", "")?;
            let origin = at(u.line);
            let base = match u.first("BaseUnit") {
                Some(b) => BaseUnit::from_attrs(&b.attrs)
                    .map_err(|e| format!("{origin}: unit \"{uname}\": {e}"))?,
                None => {
                    return Err(format!(
                        "{origin}: unit \"{uname}\" has no <ssc:BaseUnit> (required, SSP 1.0)"
                    ))
                }
            };
            if units.iter().any(|x: &SsdUnit| x.name == uname) {
                return Err(format!("{origin}: unit \"{uname}\" is defined twice"));
            }
            units.push(SsdUnit {
                name: uname.to_string(),
                base,
            });
        }
    }
    let (mut start_time, mut stop_time) = (None, None);
    if let Some(de) = root.first("DefaultExperiment") {
        start_time = number(de, "startTime", &at(de.line))?;
        stop_time = number(de, "stopTime", &at(de.line))?;
    }
    for unsupported in ["SignalDictionaries", "ParameterBindings"] {
        if let Some(n) = system.first(unsupported) {
            return Err(format!(
                "{}: <ssd:{unsupported}> on the system is not supported by geardyn's master (bind parameters on each component)",
                at(n.line)
            ));
        }
    }
    if let Some(c) = system.first("Connectors") {
        if c.first("Connector").is_some() {
            return Err(format!(
                "{}: the system declares its own <ssd:Connectors>; geardyn runs a closed system (connect component to component)",
                at(c.line)
            ));
        }
    }
    let mut components: Vec<Component> = Vec::new();
    if let Some(els) = system.first("Elements") {
        for e in &els.children {
            match e.name.as_str() {
                "Component" => {}
                "System" => {
                    return Err(format!(
                        "{}: nested <ssd:System name=\"{}\">: geardyn runs flat systems only (components directly in the one system)",
                        at(e.line),
                        e.attr("name").unwrap_or("")
                    ))
                }
                other => {
                    return Err(format!(
                        "{}: <ssd:{other}> in <ssd:Elements> is not supported (only <ssd:Component> FMUs)",
                        at(e.line)
                    ))
                }
            }
            let c = component(e, resources)?;
            if components.iter().any(|x| x.name == c.name) {
                return Err(format!(
                    "{}: two elements are named \"{}\"",
                    at(e.line),
                    c.name
                ));
            }
            components.push(c);
        }
    }
    if components.is_empty() {
        return Err(format!(
            "{}: the system \"{}\" has no <ssd:Component>",
            at(system.line),
            system.attr("name").unwrap_or("")
        ));
    }
    let mut connections = Vec::new();
    if let Some(cs) = system.first("Connections") {
        for c in cs.all("Connection") {
            connections.push(connection(c)?);
        }
    }
    Ok(Ssd {
        name,
        system_name: system.attr("name").unwrap_or("").to_string(),
        components,
        connections,
        units,
        start_time,
        stop_time,
    })
}

fn type_of(n: &Node, origin: &str) -> Result<Option<SsdType>, String> {
    for c in &n.children {
        let t = match c.name.as_str() {
            "Real" => SsdType::Real {
                unit: c.attr("unit").map(str::to_string),
            },
            "Integer" => SsdType::Integer,
            "Boolean" => SsdType::Boolean,
            "String" => SsdType::String,
            "Enumeration" => SsdType::Enumeration,
            "Binary" => return Err(format!("{origin}: ssc:Binary connectors are not supported")),
            _ => continue,
        };
        return Ok(Some(t));
    }
    Ok(None)
}

fn component(e: &Node, resources: &dyn Resources) -> Result<Component, String> {
    let name = required(e, "name", "")?.to_string();
    let origin = at(e.line);
    let source = e.attr("source").ok_or_else(|| {
        format!("{origin}: component \"{name}\" has no source attribute (the FMU, e.g. resources/{name}.fmu)")
    })?;
    if let Some(t) = e.attr("type") {
        if t != "application/x-fmu-sharedlibrary" {
            return Err(format!(
                "{origin}: component \"{name}\" has type=\"{t}\"; geardyn runs FMUs (application/x-fmu-sharedlibrary)"
            ));
        }
    }
    let mut connectors: Vec<Connector> = Vec::new();
    if let Some(cs) = e.first("Connectors") {
        for c in cs.all("Connector") {
            let cname = required(c, "name", &format!(" of component \"{name}\""))?;
            let kind_text = required(c, "kind", &format!(" \"{cname}\" of component \"{name}\""))?;
            let kind = Kind::parse(kind_text).ok_or_else(|| {
                format!(
                    "{}: connector \"{name}.{cname}\": kind=\"{kind_text}\" is not one of input, output, parameter, calculatedParameter, inout",
                    at(c.line)
                )
            })?;
            if connectors.iter().any(|x| x.name == cname) {
                return Err(format!(
                    "{}: component \"{name}\" declares connector \"{cname}\" twice",
                    at(c.line)
                ));
            }
            connectors.push(Connector {
                name: cname.to_string(),
                kind,
                ty: type_of(c, &at(c.line))?,
                line: c.line,
            });
        }
    }
    let mut parameters = Vec::new();
    if let Some(bs) = e.first("ParameterBindings") {
        for b in bs.all("ParameterBinding") {
            parameters.extend(binding(b, &name, resources)?);
        }
    }
    Ok(Component {
        name,
        source: source.to_string(),
        connectors,
        parameters,
        line: e.line,
    })
}

fn connection(c: &Node) -> Result<Connection, String> {
    let origin = at(c.line);
    let get = |a: &str| -> Result<String, String> {
        c.attr(a).map(str::to_string).ok_or_else(|| {
            if a.ends_with("Element") {
                format!("{origin}: <ssd:Connection> has no {a}: connections to the system's own connectors are not supported (name the element)")
            } else {
                format!("{origin}: <ssd:Connection> has no {a} attribute (required, SSP 1.0)")
            }
        })
    };
    let mut transformation = None;
    for t in &c.children {
        match t.name.as_str() {
            "LinearTransformation" => {
                let f = number(t, "factor", &origin)?.unwrap_or(1.0);
                let o = number(t, "offset", &origin)?.unwrap_or(0.0);
                transformation = Some((f, o));
            }
            "BooleanMappingTransformation"
            | "IntegerMappingTransformation"
            | "EnumerationMappingTransformation" => {
                return Err(format!(
                    "{}: <ssc:{}> is not supported (only ssc:LinearTransformation)",
                    at(t.line),
                    t.name
                ))
            }
            _ => {}
        }
    }
    Ok(Connection {
        start_element: get("startElement")?,
        start_connector: get("startConnector")?,
        end_element: get("endElement")?,
        end_connector: get("endConnector")?,
        transformation,
        line: c.line,
    })
}

/// One `ssd:ParameterBinding`: inline `ssd:ParameterValues` or a `source=` `.ssv` file. With
/// `prefix=`, the prefix is prepended to every parameter name of the source (SSP 1.0
/// ParameterBinding: it places the source's names inside the element, e.g. `prefix="mesh."`
/// binds `damping` to the FMU variable `mesh.damping`).
fn binding(b: &Node, component: &str, resources: &dyn Resources) -> Result<Vec<Parameter>, String> {
    let origin = at(b.line);
    if b.first("ParameterMapping").is_some() {
        return Err(format!(
            "{origin}: <ssd:ParameterMapping> (component \"{component}\") is not supported; name the FMU's variables in the parameter set"
        ));
    }
    if let Some(t) = b.attr("type") {
        if t != "application/x-ssp-parameter-set" {
            return Err(format!(
                "{origin}: parameter binding of \"{component}\" has type=\"{t}\"; only application/x-ssp-parameter-set (.ssv) is supported"
            ));
        }
    }
    let (set, file) = match (b.attr("source"), b.first("ParameterValues")) {
        (Some(src), None) => {
            let text = resources
                .read(src)
                .map_err(|e| format!("{origin}: parameter binding of \"{component}\": {e}"))?;
            (super::xml::parse(&text, src)?, src.to_string())
        }
        (None, Some(values)) => {
            let set = values.first("ParameterSet").ok_or_else(|| {
                format!("{}: <ssd:ParameterValues> of \"{component}\" holds no <ssv:ParameterSet>", at(values.line))
            })?;
            (set.clone(), FILE.to_string())
        }
        (Some(_), Some(_)) => {
            return Err(format!(
                "{origin}: parameter binding of \"{component}\" has both source= and inline <ssd:ParameterValues>; give one"
            ))
        }
        (None, None) => {
            return Err(format!(
                "{origin}: parameter binding of \"{component}\" has neither source= nor inline <ssd:ParameterValues>"
            ))
        }
    };
    if set.name != "ParameterSet" {
        return Err(format!(
            "{file} line {}: the root element is <{}>, expected <ssv:ParameterSet>",
            set.line, set.name
        ));
    }
    let prefix = b.attr("prefix").unwrap_or("");
    let mut out = Vec::new();
    let Some(params) = set.first("Parameters") else {
        return Ok(out);
    };
    for p in params.all("Parameter") {
        let here = format!("{file} line {}", p.line);
        let pname = p
            .attr("name")
            .ok_or_else(|| format!("{here}: <ssv:Parameter> has no name attribute"))?;
        let name = format!("{prefix}{pname}");
        let bad = |what: &str, v: &str| {
            format!("{here}: parameter \"{pname}\": value=\"{v}\" is not {what}")
        };
        let value = p
            .children
            .iter()
            .find_map(|t| {
                let v = t.attr("value");
                Some(match (t.name.as_str(), v) {
                    // 1e999 parses as inf: refused like any non-finite value (issue 34).
                    ("Real", Some(v)) => v
                        .trim()
                        .parse::<f64>()
                        .ok()
                        .filter(|x| x.is_finite())
                        .map(ParamValue::Real)
                        .ok_or_else(|| bad("a finite real number", v)),
                    ("Integer" | "Enumeration", Some(v)) => v
                        .trim()
                        .parse::<i64>()
                        .map(ParamValue::Integer)
                        .map_err(|_| bad("an integer", v)),
                    ("Boolean", Some(v)) => match v.trim() {
                        "true" | "1" => Ok(ParamValue::Boolean(true)),
                        "false" | "0" => Ok(ParamValue::Boolean(false)),
                        _ => Err(bad("a boolean (true or false)", v)),
                    },
                    ("String", Some(v)) => Ok(ParamValue::String(v.to_string())),
                    ("Real" | "Integer" | "Enumeration" | "Boolean" | "String", None) => {
                        Err(format!("{here}: parameter \"{pname}\": <ssv:{}> has no value attribute", t.name))
                    }
                    _ => return None,
                })
            })
            .ok_or_else(|| format!("{here}: parameter \"{pname}\" has no value element (ssv:Real, ssv:Integer, ssv:Boolean, ssv:String)"))??;
        let unit = p
            .first("Real")
            .and_then(|r| r.attr("unit"))
            .map(str::to_string);
        out.push(Parameter {
            name,
            value,
            unit,
            origin: here,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    struct NoFiles;
    impl Resources for NoFiles {
        fn read(&self, source: &str) -> Result<String, String> {
            if source == "p.ssv" {
                Ok(
                    r#"<ssv:ParameterSet xmlns:ssv="x" version="1.0" name="p"><ssv:Parameters>
<ssv:Parameter name="k"><ssv:Real value="3"/></ssv:Parameter>
</ssv:Parameters></ssv:ParameterSet>"#
                        .into(),
                )
            } else {
                Err(format!("{source}: no such file"))
            }
        }
    }

    const OK: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<ssd:SystemStructureDescription xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" version="1.0" name="s">
  <ssd:System name="root">
    <ssd:Elements>
      <ssd:Component name="A" source="resources/a.fmu">
        <ssd:Connectors>
          <ssd:Connector name="y" kind="output"><ssc:Real unit="N.m"/></ssd:Connector>
        </ssd:Connectors>
        <ssd:ParameterBindings>
          <ssd:ParameterBinding source="p.ssv" prefix="mesh."/>
          <ssd:ParameterBinding><ssd:ParameterValues><ssv:ParameterSet version="1.0" name="i"><ssv:Parameters>
            <ssv:Parameter name="u"><ssv:Real value="2.5"/></ssv:Parameter>
            <ssv:Parameter name="on"><ssv:Boolean value="true"/></ssv:Parameter>
          </ssv:Parameters></ssv:ParameterSet></ssd:ParameterValues></ssd:ParameterBinding>
        </ssd:ParameterBindings>
      </ssd:Component>
      <ssd:Component name="B" source="resources/a.fmu">
        <ssd:Connectors><ssd:Connector name="u" kind="input"><ssc:Real/></ssd:Connector></ssd:Connectors>
      </ssd:Component>
    </ssd:Elements>
    <ssd:Connections>
      <ssd:Connection startElement="A" startConnector="y" endElement="B" endConnector="u">
        <ssc:LinearTransformation factor="2" offset="0.5"/>
      </ssd:Connection>
    </ssd:Connections>
  </ssd:System>
  <ssd:Units><ssc:Unit name="N.m"><ssc:BaseUnit kg="1" m="2" s="-2"/></ssc:Unit></ssd:Units>
  <ssd:DefaultExperiment startTime="0" stopTime="0.5"/>
</ssd:SystemStructureDescription>
"#;

    #[test]
    fn reads_components_bindings_connections_units() {
        let s = parse(OK, &NoFiles).unwrap();
        assert_eq!(s.components.len(), 2);
        let a = &s.components[0];
        assert_eq!(a.connectors[0].kind, Kind::Output);
        assert_eq!(
            a.connectors[0].ty,
            Some(SsdType::Real {
                unit: Some("N.m".into())
            })
        );
        let names: Vec<_> = a.parameters.iter().map(|p| p.name.as_str()).collect();
        assert_eq!(names, ["mesh.k", "u", "on"]);
        assert_eq!(a.parameters[0].value, ParamValue::Real(3.0));
        assert!(a.parameters[0].origin.starts_with("p.ssv line 2"));
        assert_eq!(s.connections[0].transformation, Some((2.0, 0.5)));
        assert_eq!(s.connections[0].line, 22);
        assert_eq!(s.units[0].name, "N.m");
        assert_eq!((s.start_time, s.stop_time), (Some(0.0), Some(0.5)));
    }

    /// Truncated and mutated files give a result or a message, never a panic.
    #[test]
    fn never_panics_on_damaged_files() {
        for end in (0..OK.len()).filter(|&i| OK.is_char_boundary(i)) {
            let _ = parse(&OK[..end], &NoFiles);
        }
        let bytes = OK.as_bytes();
        let mut seed: u64 = 0x9e37_79b9_7f4a_7c15;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        for _ in 0..5000 {
            let mut m = bytes.to_vec();
            for _ in 0..1 + next() % 4 {
                let at = (next() % m.len() as u64) as usize;
                m[at] = b"<>\"=/ a0-.:"[(next() % 11) as usize];
            }
            if let Ok(text) = std::str::from_utf8(&m) {
                let _ = parse(text, &NoFiles);
            }
        }
    }

    #[test]
    fn refusals_name_the_item() {
        let e = parse(&OK.replace("p.ssv", "q.ssv"), &NoFiles).unwrap_err();
        assert!(
            e.contains("line 10") && e.contains("\"A\"") && e.contains("q.ssv: no such file"),
            "{e}"
        );
        let e = parse(&OK.replace("kind=\"input\"", "kind=\"in\""), &NoFiles).unwrap_err();
        assert!(e.contains("\"B.u\"") && e.contains("kind=\"in\""), "{e}");
        let e = parse(&OK.replace("startElement=\"A\" ", ""), &NoFiles).unwrap_err();
        assert!(e.contains("line 22") && e.contains("startElement"), "{e}");
        let e = parse(&OK.replace("name=\"B\"", "name=\"A\""), &NoFiles).unwrap_err();
        assert!(e.contains("two elements are named \"A\""), "{e}");
        let e = parse(&OK.replace("factor=\"2\"", "factor=\"x\""), &NoFiles).unwrap_err();
        assert!(e.contains("factor=\"x\""), "{e}");
        let e = parse(
            &OK.replace("version=\"1.0\" name=\"s\"", "version=\"2.0\" name=\"s\""),
            &NoFiles,
        )
        .unwrap_err();
        assert!(e.contains("version=\"2.0\""), "{e}");
        let e = parse(
            &OK.replace("<ssv:Real value=\"2.5\"/>", "<ssv:Real value=\"a\"/>"),
            &NoFiles,
        )
        .unwrap_err();
        assert!(e.contains("\"u\"") && e.contains("value=\"a\""), "{e}");
    }
}
