//! The raw serde layer of the modelDescription parser: the tree shape of FMI 2.0.5 §2.2 with
//! every attribute as an optional string, so the XML layer never rejects a value and the
//! typed conversion ([`super::convert`]) can name element, attribute and value in its errors.

use serde::Deserialize;
use std::collections::HashMap;

// Raw serde layer: every attribute is an optional string.

#[derive(Deserialize, Default)]
pub(super) struct RawRoot {
    #[serde(rename = "@fmiVersion")]
    pub(super) fmi_version: Option<String>,
    #[serde(rename = "@modelName")]
    pub(super) model_name: Option<String>,
    #[serde(rename = "@guid")]
    pub(super) guid: Option<String>,
    #[serde(rename = "@description")]
    pub(super) description: Option<String>,
    #[serde(rename = "@author")]
    pub(super) author: Option<String>,
    #[serde(rename = "@version")]
    pub(super) version: Option<String>,
    #[serde(rename = "@generationTool")]
    pub(super) generation_tool: Option<String>,
    #[serde(rename = "@generationDateAndTime")]
    pub(super) generation_date_and_time: Option<String>,
    #[serde(rename = "@variableNamingConvention")]
    pub(super) variable_naming_convention: Option<String>,
    #[serde(rename = "ModelExchange")]
    pub(super) model_exchange: Option<RawAttrs>,
    #[serde(rename = "CoSimulation")]
    pub(super) co_simulation: Option<RawAttrs>,
    #[serde(rename = "UnitDefinitions")]
    pub(super) unit_definitions: Option<RawUnitDefinitions>,
    #[serde(rename = "TypeDefinitions")]
    pub(super) type_definitions: Option<RawTypeDefinitions>,
    #[serde(rename = "LogCategories")]
    pub(super) log_categories: Option<RawLogCategories>,
    #[serde(rename = "DefaultExperiment")]
    pub(super) default_experiment: Option<RawAttrs>,
    #[serde(rename = "VendorAnnotations")]
    pub(super) vendor_annotations: Option<RawVendorAnnotations>,
    #[serde(rename = "ModelVariables")]
    pub(super) model_variables: Option<RawModelVariables>,
    #[serde(rename = "ModelStructure")]
    pub(super) model_structure: Option<RawModelStructure>,
}

/// `<VendorAnnotations>` (FMI 2.0.5 §2.2.6): only geardyn's `<InputDerivatives maxOrder>` and
/// `<SwitchTimes variable>` (tool `geardyn.switch_times`) and `<SharedBinary/>` (tool
/// `geardyn.shared_binary`) are read; any other tool's content is accepted and dropped.
#[derive(Deserialize, Default)]
pub(super) struct RawVendorAnnotations {
    #[serde(rename = "Tool", default)]
    pub(super) tools: Vec<RawTool>,
}

#[derive(Deserialize, Default)]
pub(super) struct RawTool {
    #[serde(rename = "@name", default)]
    pub(super) name: String,
    #[serde(rename = "InputDerivatives")]
    pub(super) input_derivatives: Option<RawAttrs>,
    #[serde(rename = "SwitchTimes")]
    pub(super) switch_times: Option<RawAttrs>,
    #[serde(rename = "SharedBinary")]
    pub(super) shared_binary: Option<RawAttrs>,
}

/// Any element whose attributes we read generically (names kept for messages).
#[derive(Deserialize, Default)]
pub(super) struct RawAttrs {
    #[serde(flatten)]
    pub(super) attrs: HashMap<String, AttrValue>,
}

/// `#[serde(flatten)]` hands child elements to the map too; only `@attr` keys with string
/// values are kept, anything else (child elements of vendor content) is accepted and dropped.
#[derive(Deserialize)]
#[serde(untagged)]
pub(super) enum AttrValue {
    Text(String),
    Other(serde::de::IgnoredAny),
}

impl RawAttrs {
    pub(super) fn get(&self, name: &str) -> Option<&str> {
        match self.attrs.get(&format!("@{name}")) {
            Some(AttrValue::Text(s)) => Some(s.as_str()),
            _ => None,
        }
    }
}

#[derive(Deserialize, Default)]
pub(super) struct RawUnitDefinitions {
    #[serde(rename = "Unit", default)]
    pub(super) units: Vec<RawUnit>,
}

#[derive(Deserialize)]
pub(super) struct RawUnit {
    #[serde(rename = "@name")]
    pub(super) name: Option<String>,
    #[serde(rename = "BaseUnit")]
    pub(super) base_unit: Option<RawAttrs>,
    #[serde(rename = "DisplayUnit", default)]
    pub(super) display_units: Vec<RawAttrs>,
}

#[derive(Deserialize, Default)]
pub(super) struct RawTypeDefinitions {
    #[serde(rename = "SimpleType", default)]
    pub(super) types: Vec<RawSimpleType>,
}

#[derive(Deserialize)]
pub(super) struct RawSimpleType {
    #[serde(rename = "@name")]
    pub(super) name: Option<String>,
    #[serde(rename = "@description")]
    pub(super) description: Option<String>,
    #[serde(rename = "Real")]
    pub(super) real: Option<RawTyped>,
    #[serde(rename = "Integer")]
    pub(super) integer: Option<RawTyped>,
    #[serde(rename = "Boolean")]
    pub(super) boolean: Option<RawTyped>,
    #[serde(rename = "String")]
    pub(super) string: Option<RawTyped>,
    #[serde(rename = "Enumeration")]
    pub(super) enumeration: Option<RawTyped>,
}

#[derive(Deserialize, Default)]
pub(super) struct RawTyped {
    #[serde(flatten)]
    pub(super) attrs: RawAttrs,
    /// `<Item name= value=>` children of an enumeration type.
    #[serde(rename = "Item", default)]
    pub(super) items: Vec<RawAttrs>,
}

#[derive(Deserialize, Default)]
pub(super) struct RawLogCategories {
    #[serde(rename = "Category", default)]
    pub(super) categories: Vec<RawAttrs>,
}

#[derive(Deserialize, Default)]
pub(super) struct RawModelVariables {
    #[serde(rename = "ScalarVariable", default)]
    pub(super) variables: Vec<RawScalarVariable>,
}

#[derive(Deserialize)]
pub(super) struct RawScalarVariable {
    #[serde(rename = "@name")]
    pub(super) name: Option<String>,
    #[serde(rename = "@valueReference")]
    pub(super) value_reference: Option<String>,
    #[serde(rename = "@description")]
    pub(super) description: Option<String>,
    #[serde(rename = "@causality")]
    pub(super) causality: Option<String>,
    #[serde(rename = "@variability")]
    pub(super) variability: Option<String>,
    #[serde(rename = "@initial")]
    pub(super) initial: Option<String>,
    #[serde(rename = "Real")]
    pub(super) real: Option<RawAttrs>,
    #[serde(rename = "Integer")]
    pub(super) integer: Option<RawAttrs>,
    #[serde(rename = "Boolean")]
    pub(super) boolean: Option<RawAttrs>,
    #[serde(rename = "String")]
    pub(super) string: Option<RawAttrs>,
    #[serde(rename = "Enumeration")]
    pub(super) enumeration: Option<RawAttrs>,
}

#[derive(Deserialize, Default)]
pub(super) struct RawModelStructure {
    #[serde(rename = "Outputs")]
    pub(super) outputs: Option<RawUnknowns>,
    #[serde(rename = "Derivatives")]
    pub(super) derivatives: Option<RawUnknowns>,
    #[serde(rename = "InitialUnknowns")]
    pub(super) initial_unknowns: Option<RawUnknowns>,
}

#[derive(Deserialize, Default)]
pub(super) struct RawUnknowns {
    #[serde(rename = "Unknown", default)]
    pub(super) unknowns: Vec<RawAttrs>,
}
