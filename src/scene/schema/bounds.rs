//! The bounds the scene types carry, as schemars transforms: `#[schemars(transform =
//! positive)]` on a field writes `exclusiveMinimum: 0` into its schema (into its items, for a
//! list of numbers), where validation reads it back (`validate::checks::bounded`).

use schemars::Schema;
use serde_json::{json, Value};

/// `> 0`.
pub fn positive(schema: &mut Schema) {
    set(schema, &[("exclusiveMinimum", json!(0.0))]);
}

/// `>= 0`.
pub fn non_negative(schema: &mut Schema) {
    set(schema, &[("minimum", json!(0.0))]);
}

/// `>= 0 and <= 1`.
pub fn fraction(schema: &mut Schema) {
    set(schema, &[("minimum", json!(0.0)), ("maximum", json!(1.0))]);
}

/// Writes the keys on the number schema: the node itself, or the items of a list.
fn set(schema: &mut Schema, keys: &[(&str, Value)]) {
    let Some(object) = schema.as_object_mut() else {
        return;
    };
    let target = match object.get_mut("items") {
        Some(Value::Object(items)) => items,
        _ => object,
    };
    for (k, v) in keys {
        target.insert((*k).to_owned(), v.clone());
    }
}
