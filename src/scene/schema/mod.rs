//! The scene format as data: one JSON Schema generated from the serde types of [`super::spec`]
//! (schemars), carrying each field's doc comment, default, unit (`x-unit`) and bounds
//! (`minimum`, `exclusiveMinimum`, `maximum`, `exclusiveMaximum`). It is the one description
//! of the format: [`describe`] answers `scene.describe(path)` from it, [`crate::units::
//! parameter_unit`] reads units from it, and validation reads its scalar bounds from it
//! ([`bounds_of`], `validate::checks::bounded`), so a bound is written once, beside the field.

mod bounds;
pub mod path;

use std::fmt;
use std::sync::OnceLock;

use serde_json::Value;

pub use bounds::{fraction, non_negative, positive};
use path::Step;

/// The schema of a scene file, generated once.
pub fn scene_schema() -> &'static Value {
    static SCHEMA: OnceLock<Value> = OnceLock::new();
    SCHEMA.get_or_init(|| schemars::schema_for!(super::SceneSpec).to_value())
}

/// One end of a parameter's range.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bound {
    pub value: f64,
    /// The bound itself is allowed (`>=`, `<=`).
    pub inclusive: bool,
}

/// A parameter's range; `None` ends are open (any finite number).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Bounds {
    pub min: Option<Bound>,
    pub max: Option<Bound>,
}

impl Bounds {
    /// Whether `value` is finite and inside.
    pub fn contains(&self, value: f64) -> bool {
        value.is_finite()
            && self
                .min
                .is_none_or(|b| value > b.value || (b.inclusive && value == b.value))
            && self
                .max
                .is_none_or(|b| value < b.value || (b.inclusive && value == b.value))
    }

    /// Whether no end is set.
    pub fn is_open(&self) -> bool {
        self.min.is_none() && self.max.is_none()
    }
}

impl fmt::Display for Bounds {
    /// `> 0`, `>= 0 and <= 1`, or `any finite number`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let min = self
            .min
            .map(|b| format!("{} {}", if b.inclusive { ">=" } else { ">" }, b.value));
        let max = self
            .max
            .map(|b| format!("{} {}", if b.inclusive { "<=" } else { "<" }, b.value));
        match (min, max) {
            (Some(a), Some(b)) => write!(f, "{a} and {b}"),
            (Some(a), None) | (None, Some(a)) => f.write_str(&a),
            (None, None) => f.write_str("any finite number"),
        }
    }
}

/// What the format says about one parameter path.
#[derive(Debug, Clone, PartialEq)]
pub struct Parameter {
    /// The path as asked (`gear[0].inertia`).
    pub path: String,
    /// `number`, `integer`, `string`, `boolean`, `array` or `table`.
    pub kind: &'static str,
    /// The unit (UDUNITS and pint spelling, `N.m`), `1` for counts and ratios; None for a
    /// name, a switch or a table.
    pub unit: Option<&'static str>,
    pub bounds: Bounds,
    /// The allowed strings of a choice (`contact`: `linear`, `contact_loss`, `backlash`).
    pub choices: Vec<String>,
    /// The value the format takes when the key is left out, where it is one fixed value.
    pub default: Option<&'static Value>,
    /// The field's doc comment.
    pub description: String,
    /// The key must be given (where its table is).
    pub required: bool,
    /// The value the scene gives, where a scene was given and has the key.
    pub value: Option<toml::Value>,
}

/// The parameter at `path` (`solver.atol`, `gear[1].teeth`, `mesh[0].stiffness.mean`), read
/// from the schema. `scene`, where given, chooses between the forms of a table that has
/// several (`kind = "rectangular"` or `"fourier"` of a mesh stiffness); without it the first
/// form that has the key answers. A mesh path without an index (`mesh.damping`, as a
/// single-mesh file writes it) is the first mesh's.
pub fn describe(path: &str, scene: Option<&toml::Table>) -> Result<Parameter, String> {
    let steps = path::parse(path)?;
    let root = scene_schema();
    let mut node = root;
    let mut here: Option<&toml::Value> = None;
    let mut table = scene;
    let mut unit = None;
    let mut description = String::new();
    let mut default = None;
    let mut required = false;
    let mut bounds_node = node;
    let mut form_description = None;
    for (n, step) in steps.iter().enumerate() {
        let Step { key, indices } = step;
        let last = n + 1 == steps.len();
        // The object that holds `key`: one of the forms of the node.
        let kind_tag = table.and_then(|t| t.get("kind")).and_then(|v| v.as_str());
        let holder = forms(root, node)
            .into_iter()
            .filter(|f| property(f, key).is_some())
            .find(|f| kind_tag.is_none_or(|k| tag_of(f).is_none_or(|t| t == k)))
            .ok_or_else(|| unknown_key(root, path, step, node, n, &steps))?;
        let field = property(holder, key).expect("filtered on it");
        form_description = text(holder, "description");
        required = holder
            .get("required")
            .and_then(Value::as_array)
            .is_some_and(|r| r.iter().any(|k| k.as_str() == Some(key.as_str())));
        // The scene may write the key under its alias (`pinion_speed` for `input_speed`).
        here = table.and_then(|t| {
            holder
                .get("properties")
                .and_then(Value::as_object)
                .into_iter()
                .flatten()
                .filter(|(_, f)| std::ptr::eq(*f, field))
                .flat_map(|(name, f)| {
                    let aliases = f.get("x-aliases").and_then(Value::as_array);
                    std::iter::once(name.as_str())
                        .chain(aliases.into_iter().flatten().filter_map(Value::as_str))
                })
                .find_map(|k| t.get(k))
        });
        // Annotations of the field itself (a `$ref` field keeps its own doc comment).
        description = text(field, "description")
            .or_else(|| text(resolve(root, field), "description"))
            .unwrap_or_default()
            .to_owned();
        default = field.get("default");
        unit = text(field, "x-unit").or(unit);
        node = field;
        bounds_node = field;
        let mut indices = indices.clone();
        // `mesh.damping` in a single-mesh file: the one mesh.
        if indices.is_empty() && !last && is_array_of_tables(root, node) {
            indices.push(path::Index::Implicit);
        }
        for index in &indices {
            let items = forms(root, node)
                .into_iter()
                .find_map(|f| f.get("items"))
                .ok_or_else(|| format!("scene path '{path}': '{key}' is not a list"))?;
            here = match (here, index) {
                (Some(toml::Value::Array(a)), path::Index::At(i)) => a.get(*i),
                (Some(toml::Value::Array(a)), path::Index::Named(i)) => a.get(*i),
                (Some(toml::Value::Array(a)), path::Index::Implicit) => a.first(),
                (Some(v @ toml::Value::Table(_)), path::Index::Implicit) => Some(v),
                _ => None,
            };
            node = items;
            bounds_node = items;
            unit = text(items, "x-unit").or(unit);
            default = None;
        }
        table = here.and_then(|v| v.as_table());
    }
    let value = here.cloned();
    let leaf = forms(root, node);
    let kind = kind_of(&leaf);
    let mut choices: Vec<String> = leaf
        .iter()
        .flat_map(|f| {
            let one = f.get("const").into_iter();
            let many = f
                .get("enum")
                .and_then(Value::as_array)
                .into_iter()
                .flatten();
            one.chain(many)
        })
        .filter_map(|v| v.as_str().map(str::to_owned))
        .collect();
    // A tag (`kind`) is a choice between the forms of its table.
    if choices.len() == 1 && steps.last().is_some_and(|s| s.key == "kind") {
        choices = tags_beside(root, &steps, scene)?;
        if description.is_empty() {
            description = format!(
                "The form of the table, one of {}. This form: {}",
                choices.join(", "),
                form_description.unwrap_or("(no description)")
            );
        }
    }
    let bounds = read_bounds(root, bounds_node);
    Ok(Parameter {
        path: path.to_owned(),
        kind,
        unit: if kind == "number" || kind == "integer" || kind == "array" {
            unit
        } else {
            None
        },
        bounds,
        choices,
        default,
        description: description.trim().to_owned(),
        required,
        value,
    })
}

impl Parameter {
    /// [`Parameter::default`] as a TOML value (what a scene would write for it).
    pub fn default_value(&self) -> Option<toml::Value> {
        self.default.and_then(json_to_toml)
    }
}

fn json_to_toml(v: &Value) -> Option<toml::Value> {
    Some(match v {
        Value::Bool(b) => toml::Value::Boolean(*b),
        Value::Number(n) => match n.as_i64() {
            Some(i) => toml::Value::Integer(i),
            None => toml::Value::Float(n.as_f64()?),
        },
        Value::String(s) => toml::Value::String(s.clone()),
        Value::Array(a) => toml::Value::Array(a.iter().filter_map(json_to_toml).collect()),
        Value::Null | Value::Object(_) => return None,
    })
}

/// The bounds of a numeric parameter, for validation: `Err` where `path` is not a number of
/// the format (a validation that asks for one names a field the schema does not know).
pub fn bounds_of(path: &str) -> Result<Bounds, String> {
    let p = describe(path, None)?;
    match p.kind {
        "number" | "integer" => Ok(p.bounds),
        other => Err(format!(
            "scene path '{path}' is a {other} in the scene format, not a number"
        )),
    }
}

/// Follows `$ref`s to the schema they name.
fn resolve<'a>(root: &'a Value, node: &'a Value) -> &'a Value {
    let mut node = node;
    for _ in 0..32 {
        match node.get("$ref").and_then(Value::as_str) {
            Some(r) => match r
                .strip_prefix("#/$defs/")
                .and_then(|name| root.get("$defs").and_then(|d| d.get(name)))
            {
                Some(target) => node = target,
                None => return node,
            },
            None => return node,
        }
    }
    node
}

/// The forms a value of `node` may take: the node itself, or each alternative of a
/// `oneOf`/`anyOf` (an enum, an `Option`), `null` left out.
fn forms<'a>(root: &'a Value, node: &'a Value) -> Vec<&'a Value> {
    let node = resolve(root, node);
    let alternatives = ["oneOf", "anyOf"]
        .iter()
        .find_map(|k| node.get(*k).and_then(Value::as_array));
    match alternatives {
        Some(list) => list
            .iter()
            .flat_map(|f| forms(root, f))
            .filter(|f| f.get("type").and_then(Value::as_str) != Some("null"))
            .collect(),
        None => vec![node],
    }
}

/// The field `key` of a table form, or the field that takes `key` as an alias
/// (`operating.pinion_speed`: `x-aliases` of `input_speed`).
fn property<'a>(form: &'a Value, key: &str) -> Option<&'a Value> {
    let properties = form.get("properties")?.as_object()?;
    properties.get(key).or_else(|| {
        properties.values().find(|field| {
            field
                .get("x-aliases")
                .and_then(Value::as_array)
                .is_some_and(|a| a.iter().any(|k| k.as_str() == Some(key)))
        })
    })
}

/// The `kind` a form of a tagged table stands for.
fn tag_of(form: &Value) -> Option<&str> {
    property(form, "kind")?.get("const")?.as_str()
}

fn text<'a>(node: &'a Value, key: &str) -> Option<&'a str> {
    node.get(key).and_then(Value::as_str)
}

fn is_array_of_tables(root: &Value, node: &Value) -> bool {
    forms(root, node).iter().any(|f| {
        f.get("items").is_some_and(|items| {
            forms(root, items)
                .iter()
                .any(|i| i.get("properties").is_some())
        })
    })
}

fn kind_of(forms: &[&Value]) -> &'static str {
    let types: Vec<&str> = forms
        .iter()
        .flat_map(|f| match f.get("type") {
            Some(Value::String(t)) => vec![t.as_str()],
            Some(Value::Array(ts)) => ts.iter().filter_map(Value::as_str).collect(),
            _ => vec![],
        })
        .filter(|t| *t != "null")
        .collect();
    match types.first().copied() {
        Some("number") => "number",
        Some("integer") => "integer",
        Some("string") => "string",
        Some("boolean") => "boolean",
        Some("array") => "array",
        _ if forms
            .iter()
            .any(|f| f.get("enum").is_some() || f.get("const").is_some()) =>
        {
            "string"
        }
        // An untagged choice of number or keyword (`initial.dte`) reads as its first type;
        // a table is anything with properties.
        _ => "table",
    }
}

fn read_bounds(root: &Value, node: &Value) -> Bounds {
    let mut bounds = Bounds::default();
    for form in std::iter::once(node).chain(forms(root, node)) {
        // An exclusive bound read after the inclusive one of the same side replaces it.
        for (key, inclusive, lower) in [
            ("minimum", true, true),
            ("exclusiveMinimum", false, true),
            ("maximum", true, false),
            ("exclusiveMaximum", false, false),
        ] {
            if let Some(value) = form.get(key).and_then(Value::as_f64) {
                let side = if lower {
                    &mut bounds.min
                } else {
                    &mut bounds.max
                };
                *side = Some(Bound { value, inclusive });
            }
        }
    }
    bounds
}

/// Every `kind` of the table that holds the `kind` at the end of `steps`.
fn tags_beside(
    root: &Value,
    steps: &[Step],
    scene: Option<&toml::Table>,
) -> Result<Vec<String>, String> {
    let table_path = path::join(&steps[..steps.len() - 1]);
    let mut out = Vec::new();
    let holder = describe_node(root, &table_path, scene)?;
    for f in forms(root, holder) {
        if let Some(t) = tag_of(f) {
            out.push(t.to_owned());
        }
    }
    Ok(out)
}

/// The schema node at a table path (no annotations), for [`tags_beside`].
fn describe_node<'a>(
    root: &'a Value,
    path: &str,
    _scene: Option<&toml::Table>,
) -> Result<&'a Value, String> {
    let mut node = root;
    for step in path::parse(path)? {
        let field = forms(root, node)
            .into_iter()
            .find_map(|f| property(f, &step.key))
            .ok_or_else(|| format!("scene path '{path}': no key '{}'", step.key))?;
        node = field;
        if is_array_of_tables(root, node) {
            node = forms(root, node)
                .into_iter()
                .find_map(|f| f.get("items"))
                .unwrap_or(node);
        }
    }
    Ok(node)
}

/// "no key" with the keys the table has.
fn unknown_key(
    root: &Value,
    path: &str,
    step: &Step,
    node: &Value,
    n: usize,
    steps: &[Step],
) -> String {
    let mut keys: Vec<&str> = forms(root, node)
        .into_iter()
        .filter_map(|f| f.get("properties").and_then(Value::as_object))
        .flat_map(|p| p.keys().map(String::as_str))
        .collect();
    keys.sort_unstable();
    keys.dedup();
    let table = if n == 0 {
        "the scene".to_owned()
    } else {
        format!("'{}'", path::join(&steps[..n]))
    };
    if keys.is_empty() {
        format!(
            "scene path '{path}': {table} is not a table, it has no key '{}'",
            step.key
        )
    } else {
        format!(
            "scene path '{path}': {table} has no key '{}' (keys: {})",
            step.key,
            keys.join(", ")
        )
    }
}

#[cfg(test)]
mod tests;
