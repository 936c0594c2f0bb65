//! `modelDescription.xml` parser (FMI 2.0.5 §2.2 "FMI Description Schema", §4.3 for
//! `<CoSimulation>`).
//!
//! Two stages, so that every error can name the element, attribute and value:
//! 1. quick-xml + serde into *raw* structs whose attributes are all `Option<String>` (the XML
//!    layer only has to get the tree shape right, it never rejects a value);
//! 2. conversion into the typed [`ModelDescription`] with located messages such as
//!    `ScalarVariable "x" (#3): valueReference="abc" is not an unsigned 32-bit integer`.
//!
//! Semantic rules that a validator reports (start values required/forbidden, legal
//! causality/variability/initial combinations, ModelStructure, units) live in
//! [`super::check`]; this module only rejects what cannot be represented at all.
//! It never panics on any input (it is fuzzed by `tests/host_description_fuzz.rs`).

use serde::Deserialize;
use std::collections::HashMap;

/// `causality` (FMI 2.0.5 §2.2.7, default `local`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Causality {
    Parameter,
    CalculatedParameter,
    Input,
    Output,
    Local,
    Independent,
}

/// `variability` (FMI 2.0.5 §2.2.7, default `continuous`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Variability {
    Constant,
    Fixed,
    Tunable,
    Discrete,
    Continuous,
}

/// `initial` (FMI 2.0.5 §2.2.7). `None` in [`ScalarVariable::initial`] means "not given".
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Initial {
    Exact,
    Approx,
    Calculated,
}

/// The base type of a scalar variable: the one child element of `<ScalarVariable>`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum VarType {
    Real,
    Integer,
    Boolean,
    String,
    Enumeration,
}

/// A typed start value.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    Real(f64),
    Integer(i32),
    Boolean(bool),
    String(String),
}

impl std::fmt::Display for Value {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Value::Real(v) => write!(f, "{}", super::csv::format_real(*v)),
            Value::Integer(v) => write!(f, "{v}"),
            Value::Boolean(v) => write!(f, "{v}"),
            Value::String(s) => write!(f, "{s:?}"),
        }
    }
}

macro_rules! str_enum {
    ($ty:ident { $($text:literal => $var:ident),* $(,)? }) => {
        impl $ty {
            /// The spelling used in modelDescription.xml.
            pub fn as_str(self) -> &'static str {
                match self { $($ty::$var => $text),* }
            }
            /// Parse the XML spelling.
            pub fn parse(s: &str) -> Option<Self> {
                match s { $($text => Some($ty::$var),)* _ => None }
            }
        }
        impl std::fmt::Display for $ty {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.as_str())
            }
        }
    };
}
str_enum!(Causality { "parameter" => Parameter, "calculatedParameter" => CalculatedParameter,
    "input" => Input, "output" => Output, "local" => Local, "independent" => Independent });
str_enum!(Variability { "constant" => Constant, "fixed" => Fixed, "tunable" => Tunable,
    "discrete" => Discrete, "continuous" => Continuous });
str_enum!(Initial { "exact" => Exact, "approx" => Approx, "calculated" => Calculated });
str_enum!(VarType { "Real" => Real, "Integer" => Integer, "Boolean" => Boolean,
    "String" => String, "Enumeration" => Enumeration });

/// `<CoSimulation>` capabilities (FMI 2.0.5 §4.3.1). Booleans default to `false`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CoSimulation {
    pub model_identifier: String,
    pub needs_execution_tool: bool,
    pub can_handle_variable_communication_step_size: bool,
    pub can_interpolate_inputs: bool,
    pub max_output_derivative_order: u32,
    pub can_run_asynchronuously: bool,
    pub can_be_instantiated_only_once_per_process: bool,
    pub can_not_use_memory_management_functions: bool,
    pub can_get_and_set_fmu_state: bool,
    pub can_serialize_fmu_state: bool,
    pub provides_directional_derivative: bool,
}

/// `<DefaultExperiment>` (FMI 2.0.5 §2.2.5). For CS, `stepSize` is the preferred
/// communication step size.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DefaultExperiment {
    pub start_time: Option<f64>,
    pub stop_time: Option<f64>,
    pub tolerance: Option<f64>,
    pub step_size: Option<f64>,
}

/// `<Unit>` with its `<BaseUnit>` exponents and `<DisplayUnit>`s (FMI 2.0.5 §2.2.2).
#[derive(Debug, Clone, PartialEq)]
pub struct Unit {
    pub name: String,
    /// `(exponent name, value)` pairs given on `<BaseUnit>` plus factor/offset.
    pub base_unit: Vec<(String, String)>,
    pub display_units: Vec<DisplayUnit>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct DisplayUnit {
    pub name: String,
    pub factor: f64,
    pub offset: f64,
}

/// `<SimpleType>` (FMI 2.0.5 §2.2.3).
#[derive(Debug, Clone, PartialEq)]
pub struct SimpleType {
    pub name: String,
    pub description: Option<String>,
    pub var_type: VarType,
    pub unit: Option<String>,
    pub display_unit: Option<String>,
    pub min: Option<f64>,
    pub max: Option<f64>,
    /// Enumeration items `(name, value)`.
    pub items: Vec<(String, i32)>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct LogCategory {
    pub name: String,
    pub description: Option<String>,
}

/// One `<ScalarVariable>` (FMI 2.0.5 §2.2.7).
#[derive(Debug, Clone, PartialEq)]
pub struct ScalarVariable {
    pub name: String,
    pub value_reference: u32,
    pub description: Option<String>,
    pub causality: Causality,
    pub variability: Variability,
    /// As written in the XML; see [`ScalarVariable::effective_initial`] for the default.
    pub initial: Option<Initial>,
    pub var_type: VarType,
    pub declared_type: Option<String>,
    pub start: Option<Value>,
    pub unit: Option<String>,
    pub display_unit: Option<String>,
    pub min: Option<f64>,
    pub max: Option<f64>,
    pub nominal: Option<f64>,
    /// `derivative`: 1-based index of the state this variable is the derivative of.
    pub derivative: Option<u32>,
    /// 1-based position in `<ModelVariables>` (how ModelStructure refers to it).
    pub index: usize,
    /// Line of the `<ScalarVariable>` start tag, for messages.
    pub line: usize,
}

impl ScalarVariable {
    /// `initial`, with the default of FMI 2.0.5 §2.2.7 (table after "initial") when absent:
    /// parameter → exact; calculatedParameter → calculated; constant (output/local) → exact;
    /// other outputs/locals → calculated; input and independent → none.
    pub fn effective_initial(&self) -> Option<Initial> {
        if self.initial.is_some() {
            return self.initial;
        }
        match (self.causality, self.variability) {
            (Causality::Input | Causality::Independent, _) => None,
            (Causality::Parameter, _) => Some(Initial::Exact),
            (Causality::CalculatedParameter, _) => Some(Initial::Calculated),
            (_, Variability::Constant) => Some(Initial::Exact),
            _ => Some(Initial::Calculated),
        }
    }

    /// Short location used in messages: `variable "x" (#3, line 12)`.
    pub fn loc(&self) -> String {
        format!(
            "variable \"{}\" (#{}, line {})",
            self.name, self.index, self.line
        )
    }
}

/// `<Unknown index= dependencies= dependenciesKind=>` in `<ModelStructure>` (FMI 2.0.5 §2.2.8).
#[derive(Debug, Clone, PartialEq)]
pub struct Unknown {
    pub index: usize,
    /// `None` = attribute absent (depends on all knowns); `Some([])` = no dependencies.
    pub dependencies: Option<Vec<usize>>,
    pub dependencies_kind: Option<Vec<String>>,
}

#[derive(Debug, Clone, Default, PartialEq)]
pub struct ModelStructure {
    pub outputs: Vec<Unknown>,
    /// `None` when `<Derivatives>` is absent.
    pub derivatives: Option<Vec<Unknown>>,
    pub initial_unknowns: Vec<Unknown>,
}

/// The parsed `modelDescription.xml` of an FMI 2.0 FMU.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelDescription {
    pub fmi_version: String,
    pub model_name: String,
    pub guid: String,
    pub description: Option<String>,
    pub author: Option<String>,
    pub version: Option<String>,
    pub generation_tool: Option<String>,
    pub generation_date_and_time: Option<String>,
    pub variable_naming_convention: Option<String>,
    pub co_simulation: Option<CoSimulation>,
    /// `modelIdentifier` of `<ModelExchange>`, if declared (we cannot run it, but `info` shows it).
    pub model_exchange: Option<String>,
    pub unit_definitions: Vec<Unit>,
    pub type_definitions: Vec<SimpleType>,
    pub log_categories: Vec<LogCategory>,
    pub default_experiment: Option<DefaultExperiment>,
    pub variables: Vec<ScalarVariable>,
    pub model_structure: ModelStructure,
}

impl ModelDescription {
    /// Look a variable up by name.
    pub fn variable(&self, name: &str) -> Option<&ScalarVariable> {
        self.variables.iter().find(|v| v.name == name)
    }

    /// The declared type a variable refers to, if any.
    pub fn simple_type(&self, name: &str) -> Option<&SimpleType> {
        self.type_definitions.iter().find(|t| t.name == name)
    }

    /// The unit of a variable, inherited from its `declaredType` when not given on the variable
    /// (FMI 2.0.5 §2.2.3: attributes of the variable override those of the type).
    pub fn unit_of<'a>(&'a self, v: &'a ScalarVariable) -> Option<&'a str> {
        v.unit.as_deref().or_else(|| {
            v.declared_type
                .as_deref()
                .and_then(|t| self.simple_type(t))
                .and_then(|t| t.unit.as_deref())
        })
    }
}

// ---------------------------------------------------------------------------------------------
// Raw serde layer: every attribute is an optional string.

#[derive(Deserialize, Default)]
struct RawRoot {
    #[serde(rename = "@fmiVersion")]
    fmi_version: Option<String>,
    #[serde(rename = "@modelName")]
    model_name: Option<String>,
    #[serde(rename = "@guid")]
    guid: Option<String>,
    #[serde(rename = "@description")]
    description: Option<String>,
    #[serde(rename = "@author")]
    author: Option<String>,
    #[serde(rename = "@version")]
    version: Option<String>,
    #[serde(rename = "@generationTool")]
    generation_tool: Option<String>,
    #[serde(rename = "@generationDateAndTime")]
    generation_date_and_time: Option<String>,
    #[serde(rename = "@variableNamingConvention")]
    variable_naming_convention: Option<String>,
    #[serde(rename = "ModelExchange")]
    model_exchange: Option<RawAttrs>,
    #[serde(rename = "CoSimulation")]
    co_simulation: Option<RawAttrs>,
    #[serde(rename = "UnitDefinitions")]
    unit_definitions: Option<RawUnitDefinitions>,
    #[serde(rename = "TypeDefinitions")]
    type_definitions: Option<RawTypeDefinitions>,
    #[serde(rename = "LogCategories")]
    log_categories: Option<RawLogCategories>,
    #[serde(rename = "DefaultExperiment")]
    default_experiment: Option<RawAttrs>,
    #[serde(rename = "ModelVariables")]
    model_variables: Option<RawModelVariables>,
    #[serde(rename = "ModelStructure")]
    model_structure: Option<RawModelStructure>,
}

/// Any element whose attributes we read generically (names kept for messages).
#[derive(Deserialize, Default)]
struct RawAttrs {
    #[serde(flatten)]
    attrs: HashMap<String, AttrValue>,
}

/// `#[serde(flatten)]` hands child elements to the map too; only `@attr` keys with string
/// values are kept, anything else (child elements of vendor content) is accepted and dropped.
#[derive(Deserialize)]
#[serde(untagged)]
enum AttrValue {
    Text(String),
    Other(serde::de::IgnoredAny),
}

impl RawAttrs {
    fn get(&self, name: &str) -> Option<&str> {
        match self.attrs.get(&format!("@{name}")) {
            Some(AttrValue::Text(s)) => Some(s.as_str()),
            _ => None,
        }
    }
}

#[derive(Deserialize, Default)]
struct RawUnitDefinitions {
    #[serde(rename = "Unit", default)]
    units: Vec<RawUnit>,
}

#[derive(Deserialize)]
struct RawUnit {
    #[serde(rename = "@name")]
    name: Option<String>,
    #[serde(rename = "BaseUnit")]
    base_unit: Option<RawAttrs>,
    #[serde(rename = "DisplayUnit", default)]
    display_units: Vec<RawAttrs>,
}

#[derive(Deserialize, Default)]
struct RawTypeDefinitions {
    #[serde(rename = "SimpleType", default)]
    types: Vec<RawSimpleType>,
}

#[derive(Deserialize)]
struct RawSimpleType {
    #[serde(rename = "@name")]
    name: Option<String>,
    #[serde(rename = "@description")]
    description: Option<String>,
    #[serde(rename = "Real")]
    real: Option<RawTyped>,
    #[serde(rename = "Integer")]
    integer: Option<RawTyped>,
    #[serde(rename = "Boolean")]
    boolean: Option<RawTyped>,
    #[serde(rename = "String")]
    string: Option<RawTyped>,
    #[serde(rename = "Enumeration")]
    enumeration: Option<RawTyped>,
}

#[derive(Deserialize, Default)]
struct RawTyped {
    #[serde(flatten)]
    attrs: RawAttrs,
    /// `<Item name= value=>` children of an enumeration type.
    #[serde(rename = "Item", default)]
    items: Vec<RawAttrs>,
}

#[derive(Deserialize, Default)]
struct RawLogCategories {
    #[serde(rename = "Category", default)]
    categories: Vec<RawAttrs>,
}

#[derive(Deserialize, Default)]
struct RawModelVariables {
    #[serde(rename = "ScalarVariable", default)]
    variables: Vec<RawScalarVariable>,
}

#[derive(Deserialize)]
struct RawScalarVariable {
    #[serde(rename = "@name")]
    name: Option<String>,
    #[serde(rename = "@valueReference")]
    value_reference: Option<String>,
    #[serde(rename = "@description")]
    description: Option<String>,
    #[serde(rename = "@causality")]
    causality: Option<String>,
    #[serde(rename = "@variability")]
    variability: Option<String>,
    #[serde(rename = "@initial")]
    initial: Option<String>,
    #[serde(rename = "Real")]
    real: Option<RawAttrs>,
    #[serde(rename = "Integer")]
    integer: Option<RawAttrs>,
    #[serde(rename = "Boolean")]
    boolean: Option<RawAttrs>,
    #[serde(rename = "String")]
    string: Option<RawAttrs>,
    #[serde(rename = "Enumeration")]
    enumeration: Option<RawAttrs>,
}

#[derive(Deserialize, Default)]
struct RawModelStructure {
    #[serde(rename = "Outputs")]
    outputs: Option<RawUnknowns>,
    #[serde(rename = "Derivatives")]
    derivatives: Option<RawUnknowns>,
    #[serde(rename = "InitialUnknowns")]
    initial_unknowns: Option<RawUnknowns>,
}

#[derive(Deserialize, Default)]
struct RawUnknowns {
    #[serde(rename = "Unknown", default)]
    unknowns: Vec<RawAttrs>,
}

// ---------------------------------------------------------------------------------------------

/// Parse `modelDescription.xml` text. `file` names the source in messages.
///
/// Rejects, with a message naming the file: malformed XML, a root other than
/// `fmiModelDescription`, an `fmiVersion` other than `2.0` (FMI 1.0 and 3.0 use the same
/// root element name, so the version attribute is read first, before the tree is interpreted
/// as FMI 2.0), missing required attributes (`modelName`, `guid`, `name`, `valueReference`),
/// unknown enumeration literals, unparsable numbers, and a `<ScalarVariable>` without exactly
/// one type element.
pub fn parse(xml: &str, file: &str) -> Result<ModelDescription, String> {
    let scan = scan(xml).map_err(|e| format!("{file}: {e}"))?;
    match scan.version.as_deref() {
        Some("2.0") => {}
        Some(v) if v.starts_with("1.") => {
            return Err(format!(
                "{file}: fmiVersion=\"{v}\" is FMI 1.0; geardyn's host runs FMI 2.0 FMUs only"
            ))
        }
        Some(v) if v.starts_with("3.") => {
            return Err(format!(
                "{file}: fmiVersion=\"{v}\" is FMI 3.0; geardyn's host runs FMI 2.0 FMUs only"
            ))
        }
        Some(v) => {
            return Err(format!(
                "{file}: fmiModelDescription has fmiVersion=\"{v}\"; expected \"2.0\""
            ))
        }
        None => {
            return Err(format!(
            "{file}: fmiModelDescription has no fmiVersion attribute (required, FMI 2.0.5 §2.2.1)"
        ))
        }
    }
    let raw: RawRoot = quick_xml::de::from_str(xml)
        .map_err(|e| format!("{file}: not a valid FMI 2.0 modelDescription: {e}"))?;
    convert(raw, &scan.variable_lines).map_err(|e| format!("{file}: {e}"))
}

/// 1-based line and column of a byte offset, for messages.
fn line_col(xml: &str, pos: u64) -> (usize, usize) {
    let pos = (pos as usize).min(xml.len());
    let before = &xml.as_bytes()[..pos];
    let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
    let col = pos
        - before
            .iter()
            .rposition(|&b| b == b'\n')
            .map_or(0, |p| p + 1)
        + 1;
    (line, col)
}

/// What the streaming pass learns before the serde pass: the root's `fmiVersion` and the line
/// of every `<ScalarVariable>` start tag (serde does not report positions).
struct Scan {
    version: Option<String>,
    variable_lines: Vec<usize>,
}

/// Read the whole document with the streaming reader: checks it is well-formed XML (quick-xml's
/// serde layer tolerates some truncation at the end; a validator must not), reads the root and
/// its `fmiVersion`, and records the line of each `<ScalarVariable>`.
fn scan(xml: &str) -> Result<Scan, String> {
    use quick_xml::events::Event;
    let mut reader = quick_xml::Reader::from_str(xml);
    reader.config_mut().check_end_names = true;
    let mut version = None;
    let mut variable_lines = Vec::new();
    let mut depth: i64 = 0;
    let mut seen_root = false;
    loop {
        let pos = reader.buffer_position();
        let ev = reader.read_event().map_err(|e| {
            let (l, c) = line_col(xml, reader.error_position());
            format!("malformed XML at line {l}, column {c}: {e}")
        })?;
        match ev {
            Event::Start(ref e) | Event::Empty(ref e) => {
                let name = e.name();
                let name: &str = name.as_ref();
                let (line, _) = line_col(xml, pos);
                if name == "ScalarVariable" {
                    variable_lines.push(line);
                }
                for a in e.attributes() {
                    a.map_err(|err| {
                        format!("malformed attribute on <{name}> at line {line}: {err}")
                    })?;
                }
                if !seen_root {
                    seen_root = true;
                    if name != "fmiModelDescription" {
                        return Err(format!(
                            "root element is <{name}> (line {line}), expected <fmiModelDescription>"
                        ));
                    }
                    for a in e.attributes().flatten() {
                        let key: &str = a.key.as_ref();
                        if key == "fmiVersion" {
                            let v = a
                                .normalized_value(quick_xml::XmlVersion::Implicit1_0)
                                .map_err(|e| format!("malformed fmiVersion value: {e}"))?;
                            version = Some(v.into_owned());
                        }
                    }
                } else if depth == 0 {
                    return Err(format!(
                        "more than one root element (<{name}> at line {line})"
                    ));
                }
                if matches!(ev, Event::Start(_)) {
                    depth += 1;
                }
            }
            Event::End(_) => depth -= 1,
            Event::Eof => break,
            _ => {}
        }
    }
    if !seen_root {
        return Err("no XML element found (empty or not XML)".into());
    }
    if depth != 0 {
        let (l, _) = line_col(xml, xml.len() as u64);
        return Err(format!(
            "truncated XML: {depth} element(s) not closed at the end of the file (line {l})"
        ));
    }
    Ok(Scan {
        version,
        variable_lines,
    })
}

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

fn convert(raw: RawRoot, lines: &[usize]) -> Result<ModelDescription, String> {
    let model_name = raw
        .model_name
        .ok_or("fmiModelDescription: required attribute modelName is missing")?;
    let guid = raw
        .guid
        .ok_or("fmiModelDescription: required attribute guid is missing")?;

    let co_simulation = raw
        .co_simulation
        .map(|a| -> Result<CoSimulation, String> {
            let c = "<CoSimulation>";
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
                can_interpolate_inputs: opt_bool(&a, "canInterpolateInputs", c)?,
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
