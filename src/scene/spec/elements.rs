//! The element tables of a scene file (`[[motor]]`, `[[load]]`, `[[inertia]]`;
//! `docs/ports.md`, "Elements in the scene"): a body name and the element's own fields, read
//! by the element specs of `src/model/elements/`.

use std::borrow::Cow;

use schemars::{JsonSchema, Schema, SchemaGenerator};
use serde::Deserialize;
use serde_json::{json, Value};

use crate::model::elements::{InertiaSpec, LoadSpec, MotorSpec};

/// `[[motor]]`: a name (the rotor body) and the motor's fields (`docs/elements.md`).
#[derive(Debug, Clone, Deserialize)]
#[serde(try_from = "toml::Table")]
pub struct MotorBodySpec {
    pub name: String,
    pub motor: MotorSpec,
}

impl TryFrom<toml::Table> for MotorBodySpec {
    type Error = String;
    fn try_from(table: toml::Table) -> Result<Self, String> {
        let (name, rest) = split_name(table)?;
        Ok(MotorBodySpec {
            name,
            motor: rest
                .try_into()
                .map_err(|e: toml::de::Error| e.message().to_owned())?,
        })
    }
}

/// `[[load]]`: a name (the load body) and the load's fields.
#[derive(Debug, Clone, Deserialize)]
#[serde(try_from = "toml::Table")]
pub struct LoadBodySpec {
    pub name: String,
    pub load: LoadSpec,
}

impl TryFrom<toml::Table> for LoadBodySpec {
    type Error = String;
    fn try_from(table: toml::Table) -> Result<Self, String> {
        let (name, rest) = split_name(table)?;
        Ok(LoadBodySpec {
            name,
            load: rest
                .try_into()
                .map_err(|e: toml::de::Error| e.message().to_owned())?,
        })
    }
}

/// `[[inertia]]`: a toothless body (a name, `inertia`, optional `damping` to ground).
#[derive(Debug, Clone, Deserialize)]
#[serde(try_from = "toml::Table")]
pub struct InertiaBodySpec {
    pub name: String,
    pub inertia: InertiaSpec,
}

impl TryFrom<toml::Table> for InertiaBodySpec {
    type Error = String;
    fn try_from(table: toml::Table) -> Result<Self, String> {
        let (name, rest) = split_name(table)?;
        Ok(InertiaBodySpec {
            name,
            inertia: rest
                .try_into()
                .map_err(|e: toml::de::Error| e.message().to_owned())?,
        })
    }
}

/// `name` and the element's own fields. (Not `#[serde(flatten)]`: it would let unknown keys
/// through, and the element specs reject them.)
fn split_name(mut table: toml::Table) -> Result<(String, toml::Table), String> {
    match table.remove("name") {
        Some(toml::Value::String(name)) => Ok((name, table)),
        Some(v) => Err(format!("name = {v}: must be a string")),
        None => Err("missing field `name`".into()),
    }
}

/// The schema of an element table: the element's own fields and `name` beside them, as
/// `split_name` reads it.
fn named<T: JsonSchema>(generator: &mut SchemaGenerator, what: &str) -> Schema {
    let mut schema = T::json_schema(generator);
    if let Some(object) = schema.as_object_mut() {
        if let Some(Value::Object(properties)) = object.get_mut("properties") {
            properties.insert(
                "name".into(),
                json!({"type": "string", "description": format!("Name of the {what} body.")}),
            );
        }
        match object.get_mut("required") {
            Some(Value::Array(required)) => required.push("name".into()),
            _ => {
                object.insert("required".into(), json!(["name"]));
            }
        }
    }
    schema
}

macro_rules! named_schema {
    ($body:ty, $spec:ty, $what:literal) => {
        impl JsonSchema for $body {
            fn schema_name() -> Cow<'static, str> {
                stringify!($body).into()
            }
            fn json_schema(generator: &mut SchemaGenerator) -> Schema {
                named::<$spec>(generator, $what)
            }
        }
    };
}

named_schema!(MotorBodySpec, MotorSpec, "motor");
named_schema!(LoadBodySpec, LoadSpec, "load");
named_schema!(InertiaBodySpec, InertiaSpec, "inertia");
