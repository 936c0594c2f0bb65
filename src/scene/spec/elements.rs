//! The element tables of a scene file (`[[motor]]`, `[[load]]`, `[[inertia]]`;
//! `docs/ports.md`, "Elements in the scene"): a body name and the element's own fields, read
//! by the element specs of `src/model/elements/`.

use serde::Deserialize;

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
