//! `Scene.describe(path)` and `geardyn.describe(path)`: what the scene format says about a
//! parameter (`geardyn::scene::schema`), with a scene's own value where one is given.

use pyo3::prelude::*;

/// One parameter of the scene format: its value in this scene (or its default), unit, bounds,
/// choices and description.
#[pyclass(module = "geardyn._geardyn", name = "Parameter", get_all, frozen)]
pub struct PyParameter {
    /// The path as asked.
    path: String,
    /// The scene's value; the default where the scene leaves the key out (None where the
    /// format has no fixed default, or without a scene).
    value: Py<PyAny>,
    /// The value the format takes when the key is left out (None where there is no fixed one).
    default: Py<PyAny>,
    /// Whether the scene leaves the key out (``value`` is then the default).
    is_default: bool,
    /// `number`, `integer`, `string`, `boolean`, `array` or `table`.
    kind: String,
    /// The unit (pint and UDUNITS spelling), ``"1"`` for ratios; None for names and switches.
    unit: Option<String>,
    /// The range as text (``"> 0"``, ``">= 0 and <= 1"``; ``""`` where none is declared).
    bounds: String,
    /// ``(value, inclusive)`` of the lower end, or None.
    minimum: Option<(f64, bool)>,
    /// ``(value, inclusive)`` of the upper end, or None.
    maximum: Option<(f64, bool)>,
    /// The allowed strings of a choice (empty otherwise).
    choices: Vec<String>,
    /// The field's description (its doc comment in the scene format).
    description: String,
    /// The key must be given in its table.
    required: bool,
}

#[pymethods]
impl PyParameter {
    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let value = self.value.bind(py).repr()?;
        let mut out = format!("Parameter({}: {value}", self.path);
        if let Some(u) = &self.unit {
            out.push_str(&format!(" [{u}]"));
        }
        if !self.bounds.is_empty() {
            out.push_str(&format!(", {}", self.bounds));
        }
        if !self.choices.is_empty() {
            out.push_str(&format!(", one of {}", self.choices.join(", ")));
        }
        if self.is_default {
            out.push_str(", default");
        }
        out.push(')');
        Ok(out)
    }
}

/// Builds the Python object from the crate's answer.
pub fn parameter(
    py: Python<'_>,
    p: geardyn::scene::schema::Parameter,
    to_python: impl Fn(Python<'_>, &toml::Value) -> PyResult<Py<PyAny>>,
) -> PyResult<PyParameter> {
    let default = match p.default_value() {
        Some(v) => to_python(py, &v)?,
        None => py.None(),
    };
    let is_default = p.value.is_none();
    let value = match &p.value {
        Some(v) => to_python(py, v)?,
        None => default.clone_ref(py),
    };
    let end = |b: Option<geardyn::scene::schema::Bound>| b.map(|b| (b.value, b.inclusive));
    Ok(PyParameter {
        path: p.path,
        value,
        default,
        is_default,
        kind: p.kind.to_owned(),
        unit: p.unit.map(str::to_owned),
        bounds: if p.bounds.is_open() {
            String::new()
        } else {
            p.bounds.to_string()
        },
        minimum: end(p.bounds.min),
        maximum: end(p.bounds.max),
        choices: p.choices,
        description: p.description,
        required: p.required,
    })
}
