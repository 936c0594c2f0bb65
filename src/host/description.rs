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
//! Layout: [`scan`] (streaming pass: well-formedness, version, line numbers), [`raw`] (serde
//! tree), [`convert`] (typed conversion and located errors); the types live here.
//!
//! It never panics on any input (it is fuzzed by `tests/host_description_fuzz.rs`).

mod convert;
mod raw;
mod scan;

pub use crate::fmi::attributes::{Causality, Initial, Variability};

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

crate::fmi_str_enum!(VarType { "Real" => Real, "Integer" => Integer, "Boolean" => Boolean,
    "String" => String, "Enumeration" => Enumeration });

/// `<CoSimulation>` capabilities (FMI 2.0.5 §4.3.1). Booleans default to `false`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CoSimulation {
    pub model_identifier: String,
    pub needs_execution_tool: bool,
    pub can_handle_variable_communication_step_size: bool,
    pub can_interpolate_inputs: bool,
    pub max_output_derivative_order: u32,
    /// The highest order of `fmi2SetRealInputDerivatives` the FMU takes: geardyn's vendor
    /// annotation `<InputDerivatives maxOrder>` (FMI 2.0 declares none); else 1 with
    /// `canInterpolateInputs`, 0 without.
    pub max_input_derivative_order: u32,
    /// The value reference of the Real variable that holds the time of the FMU's next known
    /// switch of its equations (geardyn's vendor annotation `<SwitchTimes variable>`): the
    /// error-controlled master ends a step there (`host::system::controlled`).
    pub switch_time: Option<u32>,
    /// The FMU's binary keeps no state outside its instances, so one loaded copy may serve
    /// every FMU of a system whose binary is byte-identical (geardyn's vendor annotation
    /// `<SharedBinary/>`; `host::library::FmuLibrary::load_identical`).
    pub shares_binary: bool,
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

/// Parse `modelDescription.xml` text. `file` names the source in messages.
///
/// Rejects, with a message naming the file: malformed XML, a root other than
/// `fmiModelDescription`, an `fmiVersion` other than `2.0` (FMI 1.0 and 3.0 use the same
/// root element name, so the version attribute is read first, before the tree is interpreted
/// as FMI 2.0), missing required attributes (`modelName`, `guid`, `name`, `valueReference`),
/// unknown enumeration literals, unparsable numbers, and a `<ScalarVariable>` without exactly
/// one type element.
pub fn parse(xml: &str, file: &str) -> Result<ModelDescription, String> {
    // A UTF-8 byte-order mark is legal before the XML declaration (some Windows tools write
    // one); neither quick-xml pass expects it.
    let xml = xml.strip_prefix('\u{feff}').unwrap_or(xml);
    let scan = scan::scan(xml).map_err(|e| format!("{file}: {e}"))?;
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
    let raw: raw::RawRoot = quick_xml::de::from_str(xml)
        .map_err(|e| format!("{file}: not a valid FMI 2.0 modelDescription: {e}"))?;
    convert::convert(raw, &scan.variable_lines).map_err(|e| format!("{file}: {e}"))
}
