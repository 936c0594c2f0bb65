//! `geardyn._geardyn`: the Python extension module (PyO3). A thin adapter over the library:
//! every solve calls the same function as the CLI (`geardyn::simulation::run`,
//! `geardyn::model::train::run_train`, `geardyn::commands::*`), so results and error messages
//! are the CLI's. The GIL is released around every solve so Python threads run in parallel.
//! The public API, its result classes and docs are in `geardyn/__init__.py`.

use std::ffi::CString;
use std::path::PathBuf;
use std::sync::Arc;

use pyo3::create_exception;
use pyo3::exceptions::{
    PyException, PyOverflowError, PyRecursionError, PyRuntimeWarning, PyTypeError, PyValueError,
};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyByteArray, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};

mod parameter;

use geardyn::commands;
use geardyn::scene::schema::path as scene_path;
use geardyn::scene::train::TRAIN_EXAMPLES;
use geardyn::scene::KernelChoice;
use geardyn::scene::Scene;
use geardyn::scene::{read_scene_file, scene_file, EXAMPLES};
use geardyn::simulation::budget::with_deadline;

create_exception!(
    _geardyn,
    GeardynError,
    PyException,
    "A geardyn error: a bad scene or option, or a failed solve. The message is the CLI's."
);

fn err(message: impl Into<String>) -> PyErr {
    GeardynError::new_err(pythonic(&message.into(), &SCENE_OPTIONS))
}

/// The CLI options that override the scene on the command line: here they are its `solver.*`
/// parameters, and `--quiet` is `statistics=False`.
const SCENE_OPTIONS: [(&str, &str); 7] = [
    ("stop-time", "solver.stop_time"),
    ("output-interval", "solver.output_interval"),
    ("method", "solver.method"),
    ("rk-method", "solver.rk_method"),
    ("rtol", "solver.rtol"),
    ("atol", "solver.atol"),
    ("quiet", "statistics=False"),
];

/// A library message in this module's terms. The commands name the CLI's options; here they
/// are a function's arguments (`--max-rows` → `max_rows=`, `--speed` → `speed`) or, for the
/// options that override the scene on the command line, its `solver.*` parameters
/// (`--stop-time` → `solver.stop_time`, docs/python.md "The module"): `renamed` lists those.
fn pythonic(message: &str, renamed: &[(&str, &str)]) -> String {
    // Arguments that take a value keep `=` (`max_rows=`) where the message says how to
    // raise a limit; a name in a value's message stays bare (`speed '400:500': …`).
    const LIMITS: [&str; 3] = ["max-rows", "max-periods", "work-budget"];
    let message = message.replace(
        "the command's --work-budget, Python's work_budget=",
        "work_budget=",
    );
    let mut out = String::with_capacity(message.len());
    let mut rest = message.as_str();
    while let Some(at) = rest.find("--") {
        let name_len = rest[at + 2..]
            .find(|c: char| !(c.is_ascii_lowercase() || c == '-'))
            .unwrap_or(rest.len() - at - 2);
        let name = rest[at + 2..at + 2 + name_len].trim_end_matches('-');
        if name.is_empty() || !name.starts_with(|c: char| c.is_ascii_lowercase()) {
            out.push_str(&rest[..at + 2]);
            rest = &rest[at + 2..];
            continue;
        }
        out.push_str(&rest[..at]);
        match renamed.iter().find(|(cli, _)| *cli == name) {
            Some((_, python)) => out.push_str(python),
            None => {
                out.push_str(&name.replace('-', "_"));
                if LIMITS.contains(&name) {
                    out.push('=');
                }
            }
        }
        rest = &rest[at + 2 + name.len()..];
    }
    out.push_str(rest);
    out
}

/// Validates scene text the way the CLI does: the one scene reader, which chooses the kernel.
fn validate(text: &str, origin: &str) -> Result<Arc<Scene>, String> {
    Scene::from_toml_str(text, origin)
        .map(Arc::new)
        .map_err(|e| e.to_string())
}

/// A scene: its TOML text, where it came from, and the validated model description. Changing
/// a parameter edits the TOML and re-validates the whole text with the scene reader, so a bad
/// value is rejected with the message the CLI gives for the same file.
#[pyclass(module = "geardyn._geardyn", name = "Scene")]
#[derive(Clone)]
struct PyScene {
    text: String,
    table: toml::Table,
    /// Names the source in messages (the file path for a file, as the CLI does).
    origin: String,
    /// The scene file, while the scene is unchanged since it was read (FMUs built from it
    /// then carry the file itself, comments and README included).
    file: Option<PathBuf>,
    scene: Arc<Scene>,
}

impl PyScene {
    fn new(text: String, origin: String, file: Option<PathBuf>) -> PyResult<PyScene> {
        let scene = validate(&text, &origin).map_err(err)?;
        let table = text
            .parse::<toml::Table>()
            .map_err(|e| err(format!("{origin}: {e}")))?;
        Ok(PyScene {
            text,
            table,
            origin,
            file,
            scene,
        })
    }

    /// The scene in either format, for the commands that take every scene.
    fn any(&self) -> Scene {
        (*self.scene).clone()
    }
}

/// Parses `mesh.stiffness.mean`, `gear[1].inertia` or `gear[0].bearing_stiffness[x]`: the
/// scene format's one path syntax ([`scene_path::parse`], which the messages and
/// `describe` use too).
fn parse_path(path: &str) -> PyResult<Vec<scene_path::Step>> {
    scene_path::parse(path).map_err(err)
}

/// The array positions after a step's key (`[x]` is position 0 of a pair).
fn positions(step: &scene_path::Step) -> impl Iterator<Item = usize> + '_ {
    step.indices.iter().map(|i| match i {
        scene_path::Index::At(n) | scene_path::Index::Named(n) => *n,
        // `parse` never writes one: it stands for a list the file leaves out.
        scene_path::Index::Implicit => 0,
    })
}

/// The value at `path` below `table`; an error names the first step that does not exist.
fn lookup<'t>(table: &'t toml::Table, path: &str) -> PyResult<&'t toml::Value> {
    let steps = parse_path(path)?;
    let missing = |what: String| err(format!("scene path '{path}': {what}"));
    let mut tab = table;
    let last = steps.len() - 1;
    for (n, step) in steps.iter().enumerate() {
        let mut v = tab
            .get(&step.key)
            .ok_or_else(|| missing(format!("no key '{}'", step.key)))?;
        for i in positions(step) {
            v = index(v, i, &step.key).map_err(missing)?;
        }
        if n == last {
            return Ok(v);
        }
        tab = v
            .as_table()
            .ok_or_else(|| missing(format!("'{}' is not a table", step.key)))?;
    }
    unreachable!("the last step returns")
}

fn index<'v>(v: &'v toml::Value, i: usize, key: &str) -> Result<&'v toml::Value, String> {
    let a = v
        .as_array()
        .ok_or_else(|| format!("'{key}' is not an array"))?;
    a.get(i)
        .ok_or_else(|| format!("index {i} out of range ('{key}' has {} elements)", a.len()))
}

/// Sets `path` in `table`. The last key may be new, and so may the tables on the way to it
/// (`solver.stop_time` on a file without `[solver]`): the scene reader then says whether the
/// format knows them. Array elements are never created: an index names an existing one. A
/// value replacing one of the file's takes its type where that loses nothing
/// ([`typed_like`]).
fn assign(table: &mut toml::Table, path: &str, value: toml::Value) -> PyResult<()> {
    let steps = parse_path(path)?;
    let missing = |what: String| err(format!("scene path '{path}': {what}"));
    let mut tab = table;
    let last = steps.len() - 1;
    for (n, step) in steps.iter().enumerate() {
        if n == last && step.indices.is_empty() {
            let value = typed_like(tab.get(&step.key), value, path)?;
            tab.insert(step.key.clone(), value);
            return Ok(());
        }
        let mut v = if step.indices.is_empty() {
            tab.entry(step.key.as_str())
                .or_insert_with(|| toml::Value::Table(toml::Table::new()))
        } else {
            tab.get_mut(&step.key)
                .ok_or_else(|| missing(format!("no key '{}'", step.key)))?
        };
        for i in positions(step) {
            let a = v
                .as_array_mut()
                .ok_or_else(|| missing(format!("'{}' is not an array", step.key)))?;
            let len = a.len();
            v = a.get_mut(i).ok_or_else(|| {
                missing(format!(
                    "index {i} out of range ('{}' has {len} elements)",
                    step.key
                ))
            })?;
        }
        if n == last {
            *v = typed_like(Some(v), value, path)?;
            return Ok(());
        }
        tab = v
            .as_table_mut()
            .ok_or_else(|| missing(format!("'{}' is not a table", step.key)))?;
    }
    unreachable!("the last step returns")
}

/// `new` in the type of the value it replaces, where that is exact: a whole float (NumPy's
/// `38.0`, a study's grid) for an integer such as `gear[0].teeth`. A fractional one is refused
/// with the path, rather than rounded. Everything else goes to the scene reader as given (an
/// integer where the format wants a float is read exactly).
fn typed_like(old: Option<&toml::Value>, new: toml::Value, path: &str) -> PyResult<toml::Value> {
    // Integers of f64 up to 2^53 are exact; teeth counts and the like are far below.
    const EXACT: f64 = 9_007_199_254_740_992.0;
    match (old, new) {
        (Some(toml::Value::Integer(_)), toml::Value::Float(f)) => {
            if f.fract() == 0.0 && f.abs() <= EXACT {
                Ok(toml::Value::Integer(f as i64))
            } else {
                Err(err(format!(
                    "scene path '{path}' = {f}: must be a whole number (the scene has an integer there)"
                )))
            }
        }
        (_, new) => Ok(new),
    }
}

/// Every leaf path below `table` (arrays of tables indexed, arrays of values as leaves).
fn leaf_paths(prefix: &str, table: &toml::Table, out: &mut Vec<String>) {
    for (k, v) in table {
        let path = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        match v {
            toml::Value::Table(t) => leaf_paths(&path, t, out),
            toml::Value::Array(a) if !a.is_empty() && a.iter().all(toml::Value::is_table) => {
                for (i, t) in a.iter().enumerate() {
                    let t = t.as_table().expect("checked");
                    leaf_paths(&format!("{path}[{i}]"), t, out);
                }
            }
            _ => out.push(path),
        }
    }
}

/// Deepest nesting of dicts and lists a scene converted from Python objects may have. Scenes
/// are a few levels deep; the bound keeps the recursion of the conversion (and of the TOML
/// writer after it) far from the end of the thread's stack (issue 34: a dict nested 15 000 deep
/// crashed the interpreter).
const MAX_DEPTH: usize = 64;

/// The conversion of one Python value to TOML: the containers open on the way down (by
/// identity, to refuse a cycle) and the path to the current value (for the messages).
#[derive(Default)]
struct Conversion {
    open: Vec<usize>,
    path: Vec<String>,
}

impl Conversion {
    /// `a.b[2]`, or `<top>` at the top.
    fn at(&self) -> String {
        if self.path.is_empty() {
            return "<top>".into();
        }
        let mut s = String::new();
        for p in &self.path {
            if !p.starts_with('[') && !s.is_empty() {
                s.push('.');
            }
            s.push_str(p);
        }
        s
    }

    /// Enters container `v` (a dict, list or tuple, or an object converted through
    /// `tolist`): refuses a cycle (`ValueError`) and a nesting beyond [`MAX_DEPTH`]
    /// (`RecursionError`), as `json.dumps` does.
    fn enter(&mut self, v: &Bound<'_, PyAny>) -> PyResult<()> {
        let id = v.as_ptr() as usize;
        if self.open.contains(&id) {
            return Err(PyValueError::new_err(format!(
                "scene value at '{}' contains itself (a circular reference): a scene is a tree",
                self.at()
            )));
        }
        if self.open.len() >= MAX_DEPTH {
            return Err(PyRecursionError::new_err(format!(
                "scene value at '{}' is nested deeper than {MAX_DEPTH} levels",
                self.at()
            )));
        }
        self.open.push(id);
        Ok(())
    }

    fn leave(&mut self) {
        self.open.pop();
    }
}

/// A Python value as TOML. `bool` is tested before `int` (it is a subclass); NumPy scalars
/// come in through `__index__`/`__float__`.
/// A value given with a unit (`"4500rpm"`, `("150", "N*m")`, a pint Quantity) for a path
/// the scene format gives a unit: the number in that unit (`geardyn._quantity`); any other
/// value as it is. A string for a path without a unit (`mesh.contact`) stays a string.
fn in_scene_units<'py>(path: &str, value: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    if geardyn::units::parameter_unit(path).is_none() && !value.hasattr("units")? {
        return Ok(value.clone());
    }
    let quantity = value.py().import("geardyn._quantity")?;
    if !quantity
        .call_method1("is_quantity", (value,))?
        .is_truthy()?
    {
        return Ok(value.clone());
    }
    quantity.call_method1("to_si", (path, value))
}

fn to_toml(v: &Bound<'_, PyAny>) -> PyResult<toml::Value> {
    to_toml_in(v, &mut Conversion::default())
}

fn to_toml_in(v: &Bound<'_, PyAny>, conv: &mut Conversion) -> PyResult<toml::Value> {
    if v.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(v.extract()?));
    }
    if v.is_instance_of::<PyInt>() {
        return v.extract().map(toml::Value::Integer).map_err(|_| {
            PyOverflowError::new_err(format!(
                "scene value at '{}' = {v}: an integer beyond the 64-bit range of TOML",
                conv.at()
            ))
        });
    }
    if v.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(v.extract()?));
    }
    if v.is_instance_of::<PyString>() {
        return Ok(toml::Value::String(v.extract()?));
    }
    if let Ok(d) = v.cast::<PyDict>() {
        conv.enter(v)?;
        let table = dict_to_table_in(d, conv);
        conv.leave();
        return Ok(toml::Value::Table(table?));
    }
    if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        conv.enter(v)?;
        let mut items = Vec::new();
        let mut result = Ok(());
        for (i, item) in v.try_iter()?.enumerate() {
            conv.path.push(format!("[{i}]"));
            let converted = item.and_then(|item| to_toml_in(&item, conv));
            conv.path.pop();
            match converted {
                Ok(x) => items.push(x),
                Err(e) => {
                    result = Err(e);
                    break;
                }
            }
        }
        conv.leave();
        return result.map(|()| toml::Value::Array(items));
    }
    if v.hasattr("tolist")? {
        // NumPy arrays and scalars (an object whose `tolist` returns itself is a cycle).
        conv.enter(v)?;
        let converted = v
            .call_method0("tolist")
            .and_then(|list| to_toml_in(&list, conv));
        conv.leave();
        return converted;
    }
    Err(PyTypeError::new_err(format!(
        "scene value at '{}': cannot put a {} into a scene (bool, int, float, str, list or dict)",
        conv.at(),
        v.get_type().name()?
    )))
}

fn dict_to_table(d: &Bound<'_, PyDict>) -> PyResult<toml::Table> {
    let mut conv = Conversion::default();
    conv.enter(d.as_any())?;
    dict_to_table_in(d, &mut conv)
}

fn dict_to_table_in(d: &Bound<'_, PyDict>, conv: &mut Conversion) -> PyResult<toml::Table> {
    let mut t = toml::Table::new();
    for (k, v) in d.iter() {
        let key: String = k.extract().map_err(|_| {
            PyTypeError::new_err(format!(
                "scene keys are strings, not {k} (in '{}')",
                conv.at()
            ))
        })?;
        conv.path.push(key.clone());
        let value = to_toml_in(&v, conv);
        conv.path.pop();
        t.insert(key, value?);
    }
    Ok(t)
}

fn to_python<'py>(py: Python<'py>, v: &toml::Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        toml::Value::String(s) => s.into_pyobject(py)?.into_any(),
        toml::Value::Integer(i) => i.into_pyobject(py)?.into_any(),
        toml::Value::Float(f) => f.into_pyobject(py)?.into_any(),
        toml::Value::Boolean(b) => PyBool::new(py, *b).to_owned().into_any(),
        toml::Value::Datetime(d) => d.to_string().into_pyobject(py)?.into_any(),
        toml::Value::Array(a) => {
            let items: PyResult<Vec<_>> = a.iter().map(|x| to_python(py, x)).collect();
            PyList::new(py, items?)?.into_any()
        }
        toml::Value::Table(t) => {
            let d = PyDict::new(py);
            for (k, x) in t {
                d.set_item(k, to_python(py, x)?)?;
            }
            d.into_any()
        }
    })
}

#[pymethods]
impl PyScene {
    /// Reads a scene file, or the `scene.toml` in a folder (such as `fmu/spur_pair`).
    #[staticmethod]
    fn from_file(path: PathBuf) -> PyResult<PyScene> {
        // The CLI's reading of a scene argument (same file, same message if it is missing).
        let file = scene_file(&path);
        let (text, origin) = read_scene_file(&file).map_err(|e| err(e.to_string()))?;
        PyScene::new(text, origin, Some(file))
    }

    /// Parses scene text; `origin` names it in messages.
    #[staticmethod]
    #[pyo3(signature = (text, origin = "<string>"))]
    fn from_toml(text: String, origin: &str) -> PyResult<PyScene> {
        PyScene::new(text, origin.to_string(), None)
    }

    /// A scene from nested dicts shaped like the TOML file.
    #[staticmethod]
    #[pyo3(signature = (data, origin = "<dict>"))]
    fn from_dict(data: &Bound<'_, PyDict>, origin: &str) -> PyResult<PyScene> {
        let table = dict_to_table(data)?;
        let text = toml::to_string(&table).map_err(|e| err(format!("{origin}: {e}")))?;
        PyScene::new(text, origin.to_string(), None)
    }

    /// A built-in example (single mesh or drivetrain), as `--example NAME` on the CLI.
    #[staticmethod]
    fn example(name: &str) -> PyResult<PyScene> {
        let origin = format!("example '{name}'");
        match TRAIN_EXAMPLES
            .iter()
            .chain(EXAMPLES)
            .find(|(n, _)| *n == name)
        {
            Some((_, text)) => PyScene::new(text.to_string(), origin, None),
            // The scene reader's message: it lists every example, pairs and drivetrains.
            None => Err(err(Scene::example(name).expect_err("not an example").0)),
        }
    }

    /// Names of the built-in examples.
    #[staticmethod]
    fn examples() -> Vec<&'static str> {
        EXAMPLES
            .iter()
            .chain(TRAIN_EXAMPLES)
            .map(|(n, _)| *n)
            .collect()
    }

    fn __getitem__<'py>(&self, py: Python<'py>, path: &str) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, lookup(&self.table, path)?)
    }

    fn __setitem__(&mut self, path: &str, value: &Bound<'_, PyAny>) -> PyResult<()> {
        let mut table = self.table.clone();
        let value = to_toml(&in_scene_units(path, value)?)?;
        let shown = value.to_string();
        assign(&mut table, path, value)?;
        // The reader's message is the CLI's, and it names the field when it checks a value;
        // a type error of the TOML reader names only a line of the generated text.
        self.replace(table).map_err(|e| {
            if e.contains(path) {
                err(e)
            } else {
                err(format!("scene path '{path}' = {shown}: {e}"))
            }
        })
    }

    fn __contains__(&self, path: &str) -> bool {
        lookup(&self.table, path).is_ok()
    }

    /// Sets several parameters at once and validates once (for values that are only valid
    /// together); on error the scene is unchanged.
    fn update(&mut self, values: &Bound<'_, PyDict>) -> PyResult<()> {
        let mut table = self.table.clone();
        for (k, v) in values.iter() {
            let path: String = k.extract()?;
            assign(&mut table, &path, to_toml(&in_scene_units(&path, &v)?)?)?;
        }
        self.replace(table).map_err(err)
    }

    /// What the scene format says about ``path`` (``"solver.atol"``, ``"gear[0].teeth"``): this
    /// scene's value or the default, the unit, the bounds validation applies, the choices and
    /// a description. A path the format does not know raises GeardynError naming the keys
    /// its table has.
    fn describe(&self, py: Python<'_>, path: &str) -> PyResult<parameter::PyParameter> {
        let p = geardyn::scene::schema::describe(path, Some(&self.table)).map_err(err)?;
        parameter::parameter(py, p, |py, v| Ok(to_python(py, v)?.unbind()))
    }

    /// Every parameter path of the scene as written (defaults not listed).
    fn paths(&self) -> Vec<String> {
        let mut out = Vec::new();
        leaf_paths("", &self.table, &mut out);
        out
    }

    /// The scene as TOML text (the file's own text until a parameter is changed).
    fn to_toml(&self) -> String {
        self.text.clone()
    }

    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &toml::Value::Table(self.table.clone()))
    }

    fn copy(&self) -> PyScene {
        self.clone()
    }

    fn __copy__(&self) -> PyScene {
        self.clone()
    }

    fn __deepcopy__(&self, _memo: &Bound<'_, PyAny>) -> PyScene {
        self.clone()
    }

    /// Pickles as text and origin (Dask ships scenes to worker processes).
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<(Bound<'py, PyAny>, SceneState)> {
        let this = slf.borrow();
        let restore = slf
            .py()
            .import("geardyn._geardyn")?
            .getattr("_restore_scene")?;
        Ok((
            restore,
            (this.text.clone(), this.origin.clone(), this.file.clone()),
        ))
    }

    #[getter]
    fn name(&self) -> String {
        self.scene.name.clone()
    }

    /// Each mesh's frequency at the scene's input speed, Hz, by mesh name (a single pair's
    /// mesh is `mesh`): the base of the spectrum's mesh orders.
    #[getter]
    fn mesh_frequencies(&self) -> Vec<(String, f64)> {
        let omega = self.scene.operating.input_speed;
        (0..self.scene.meshes.len())
            .map(|n| {
                let name = if self.scene.kernel == KernelChoice::Pair {
                    "mesh".to_string()
                } else {
                    self.scene.meshes[n].name.clone()
                };
                (name, self.scene.mesh_frequency(n, omega))
            })
            .collect()
    }

    /// True for a drivetrain scene (docs/train.md), false for a single mesh (docs/model.md).
    #[getter]
    fn is_train(&self) -> bool {
        self.scene.kernel != KernelChoice::Pair
    }

    #[getter]
    fn origin(&self) -> String {
        self.origin.clone()
    }

    /// The file the scene was read from, while it is unchanged; else None.
    #[getter]
    fn file(&self) -> Option<PathBuf> {
        self.file.clone()
    }

    fn __repr__(&self) -> String {
        format!(
            "<geardyn.Scene {} ({}) from {}>",
            self.name(),
            if self.is_train() {
                "drivetrain"
            } else {
                "single mesh"
            },
            self.origin
        )
    }
}

impl PyScene {
    /// Validates `table` and makes it the scene; on error the scene is unchanged and the
    /// reader's message is returned.
    fn replace(&mut self, table: toml::Table) -> Result<(), String> {
        let text = toml::to_string(&table).map_err(|e| format!("{}: {e}", self.origin))?;
        self.scene = validate(&text, &self.origin)?;
        self.table = table;
        self.text = text;
        self.file = None;
        Ok(())
    }
}

/// What a pickled [`PyScene`] carries: text, origin, file.
type SceneState = (String, String, Option<PathBuf>);

#[pyfunction]
fn _restore_scene(text: String, origin: String, file: Option<PathBuf>) -> PyResult<PyScene> {
    PyScene::new(text, origin, file)
}

/// A NumPy float64 array over one copy of `values`, shaped `shape`. Built through NumPy's
/// `frombuffer` on a bytearray (writable, owned by the array) rather than with the `numpy`
/// crate: that crate's `ndarray` turns on features of `num-complex` and `matrixmultiply`
/// that the library does not use, and the different feature set made cargo rebuild the
/// library each time the CLI and the module were built in turn in the shared `target/`.
fn array<'py>(
    py: Python<'py>,
    values: impl Iterator<Item = f64>,
    len: usize,
    shape: &[usize],
) -> PyResult<Bound<'py, PyAny>> {
    let mut values = values;
    let bytes = PyByteArray::new_with(py, 8 * len, |buf| {
        for chunk in buf.chunks_exact_mut(8) {
            let v = values.next().expect("len values");
            chunk.copy_from_slice(&v.to_ne_bytes());
        }
        Ok(())
    })?;
    let np = py.import("numpy")?;
    np.getattr("frombuffer")?
        .call1((bytes, np.getattr("float64")?))?
        .call_method1("reshape", (shape.to_vec(),))
}

fn vector<'py>(py: Python<'py>, values: &[f64]) -> PyResult<Bound<'py, PyAny>> {
    array(py, values.iter().copied(), values.len(), &[values.len()])
}

/// Rows of equal width as a 2-D array.
fn matrix<'py>(
    py: Python<'py>,
    rows: &[impl AsRef<[f64]>],
    width: usize,
) -> PyResult<Bound<'py, PyAny>> {
    if let Some(r) = rows.iter().find(|r| r.as_ref().len() != width) {
        return Err(err(format!(
            "ragged result table: a row of {} values, {width} columns",
            r.as_ref().len()
        )));
    }
    let values = rows.iter().flat_map(|r| r.as_ref().iter().copied());
    array(py, values, rows.len() * width, &[rows.len(), width])
}

/// A result table: column names and one row per point (the CLI's CSV).
type Table<'py> = (Vec<String>, Bound<'py, PyAny>);

fn table<'py>(
    py: Python<'py>,
    columns: &[impl AsRef<str>],
    rows: &[impl AsRef<[f64]>],
) -> PyResult<Table<'py>> {
    let names = columns.iter().map(|c| c.as_ref().to_owned()).collect();
    Ok((names, matrix(py, rows, columns.len())?))
}

/// A count argument: a Python `int` (not a `bool`) within `min..=max`. The built-in
/// conversion's `OverflowError` does not name the argument (issue 34); this one does, with
/// the value and the range.
fn count<T: TryFrom<i64>>(name: &str, v: &Bound<'_, PyAny>, min: i64, max: i64) -> PyResult<T> {
    if !v.is_instance_of::<PyInt>() || v.is_instance_of::<PyBool>() {
        return Err(PyTypeError::new_err(format!(
            "{name} = {v}: must be an int, not {}",
            v.get_type().name()?
        )));
    }
    let out_of_range = || {
        PyOverflowError::new_err(format!(
            "{name} = {v}: out of range, must be a whole number from {min} to {max}"
        ))
    };
    let n: i64 = v.extract().map_err(|_| out_of_range())?;
    if n < min || n > max {
        return Err(out_of_range());
    }
    T::try_from(n).map_err(|_| out_of_range())
}

/// An optional count (`None` keeps the default).
fn optional_count<T: TryFrom<i64>>(
    name: &str,
    v: Option<&Bound<'_, PyAny>>,
    min: i64,
    max: i64,
) -> PyResult<Option<T>> {
    match v {
        Some(v) if !v.is_none() => count(name, v, min, max).map(Some),
        _ => Ok(None),
    }
}

const U32_MAX: i64 = u32::MAX as i64;

/// `timeout=`: a wall-clock limit in seconds on the solve (a study's per-point timeout,
/// `budget::with_deadline`), checked: a finite number > 0, or `None`.
fn check_timeout(timeout: Option<f64>) -> PyResult<Option<f64>> {
    timeout
        .map(|t| geardyn::simulation::budget::check_deadline("timeout", t))
        .transpose()
        .map_err(PyValueError::new_err)
}

/// `work_budget=`: the work budget of each run of an analysis, in work units (the scene's
/// `solver.work_budget`, the CLI's `--work-budget`), checked as they are; `None` keeps the
/// scene's (else the default run budget). The error names the Python argument.
fn apply_work_budget(scene: &mut Scene, work_budget: Option<f64>) -> PyResult<()> {
    if let Some(b) = work_budget {
        scene.solver.work_budget = Some(
            geardyn::simulation::budget::check_limit("work_budget", b)
                .map_err(PyValueError::new_err)?,
        );
    }
    Ok(())
}

/// Simulates the scene over its `[solver]` experiment (`stop_time`, `output_interval`):
/// returns `(names, times, data, method, stats, statistics, source)`, `data` one row per output
/// time, `statistics` one dict per mesh (`geardyn simulate`'s summary: `name`, `prefix`,
/// `mesh_frequency`, the per-mesh columns of `sweep` and each tooth pair's contact-loss
/// fraction; `None` without `statistics`) and `source` where they come from.
///
/// The run is `geardyn simulate`'s own (`geardyn::commands::simulate::simulate_in_memory`):
/// the same rows and the same summary, bit for bit; `statistics = False` is its `--quiet`.
/// `max_rows`, `max_periods` and `work_budget` raise (or lower) the run limits as the CLI's
/// `--max-rows`, `--max-periods` and `--work-budget` do (`work_budget` in work units, the
/// scene's `solver.work_budget`); the rows held in memory are bounded too
/// (`geardyn::simulation::MAX_IN_MEMORY_VALUES`).
#[pyfunction]
#[pyo3(signature = (scene, max_rows = None, max_periods = None, work_budget = None, statistics = true,
    timeout = None))]
#[allow(clippy::type_complexity)]
fn simulate<'py>(
    py: Python<'py>,
    scene: &PyScene,
    max_rows: Option<&Bound<'py, PyAny>>,
    max_periods: Option<f64>,
    work_budget: Option<f64>,
    statistics: bool,
    timeout: Option<f64>,
) -> PyResult<(
    Vec<String>,
    Bound<'py, PyAny>,
    Bound<'py, PyAny>,
    String,
    Bound<'py, PyDict>,
    Option<Bound<'py, PyList>>,
    &'static str,
)> {
    let mut opts = commands::simulate::SimulateOptions {
        no_summary: !statistics,
        ..Default::default()
    };
    if let Some(n) = optional_count("max_rows", max_rows, 1, i64::MAX)? {
        opts.limits.max_rows = n;
    }
    if let Some(p) = max_periods {
        if p.is_nan() || p <= 0.0 {
            return Err(PyValueError::new_err(format!(
                "max_periods = {p}: must be a number > 0"
            )));
        }
        opts.limits.max_mesh_periods = p;
        opts.limits.max_mode_periods = p;
    }
    if let Some(b) = work_budget {
        let b = geardyn::simulation::budget::check_limit("work_budget", b)
            .map_err(PyValueError::new_err)?;
        opts.limits.work_budget = Some(b);
    }
    let s = scene.any();
    // The CLI's aliasing warning, under the CLI's rule: only a summary taken from the output
    // rows (a scene with speed or torque profiles) can alias; the continuous solution's cannot.
    if statistics && !commands::simulate_run::summary_from_solution(&s).map_err(err)? {
        if let Some(warning) =
            commands::spectrum::aliasing(&s, s.solver.output_interval).map_err(err)?
        {
            let message = CString::new(warning).unwrap_or_default();
            PyErr::warn(py, &py.get_type::<PyRuntimeWarning>(), &message, 1)?;
        }
    }
    let timeout = check_timeout(timeout)?;
    let (report, rows) = py
        .detach(move || with_deadline(timeout, || commands::simulate::simulate_in_memory(s, &opts)))
        .map_err(err)?;
    let width = rows.names.len();
    let data = array(
        py,
        rows.values.iter().copied(),
        rows.values.len(),
        &[rows.times.len(), width],
    )?;
    let stats = report.stats;
    let d = PyDict::new(py);
    d.set_item("steps", stats.steps)?;
    d.set_item("rejected", stats.rejected)?;
    d.set_item("rhs_evals", stats.rhs_evals)?;
    d.set_item("events", stats.events)?;
    d.set_item("stops", stats.stops)?;
    d.set_item("guard_evals", stats.guard_evals)?;
    let per_mesh = if statistics {
        let list = PyList::empty(py);
        for m in &report.meshes {
            let e = PyDict::new(py);
            e.set_item("name", &m.name)?;
            match &m.response {
                Some(r) => mesh_response(&e, r)?,
                // From the output rows: the three numbers the summary prints.
                None => {
                    e.set_item("dte_rms", m.dte_rms)?;
                    e.set_item("peak_force", m.peak_force)?;
                    e.set_item("contact_loss_fraction", m.contact_loss)?;
                }
            }
            list.append(e)?;
        }
        Some(list)
    } else {
        None
    };
    Ok((
        rows.names,
        vector(py, &rows.times)?,
        data,
        report.propagator,
        d,
        per_mesh,
        report.source.name(),
    ))
}

/// A mesh's response into `e`: `prefix`, `mesh_frequency`, the per-mesh columns of `sweep`
/// and `hb` (`MESH_COLUMNS`) by their bare names, and `pair_contact_loss_fractions` (one per
/// tooth-pair slot of a Model-1 mesh; empty otherwise).
fn mesh_response(e: &Bound<'_, PyDict>, m: &geardyn::analysis::MeshResponse) -> PyResult<()> {
    e.set_item("prefix", &m.prefix)?;
    e.set_item("mesh_frequency", m.mesh_frequency)?;
    let names = geardyn::analysis::mesh_response::mesh_columns(&[String::new()]);
    for (name, value) in names.iter().zip(m.values()) {
        e.set_item(name, value)?;
    }
    e.set_item(
        "pair_contact_loss_fractions",
        m.pair_contact_loss_fractions.clone(),
    )?;
    Ok(())
}

/// Periodic steady state by shooting at the scene's input speed, or at `speed` (`4500rpm`,
/// `471.24rad/s`, a bare number in rad/s: `geardyn periodic --speed`); returns a dict of the
/// orbit (with `report`, the text `geardyn periodic` prints, and each mesh's force).
#[pyfunction]
#[pyo3(signature = (scene, periods = None, warmup = None, speed = None, work_budget = None,
    timeout = None))]
fn periodic<'py>(
    py: Python<'py>,
    scene: &PyScene,
    periods: Option<&Bound<'py, PyAny>>,
    warmup: Option<&Bound<'py, PyAny>>,
    speed: Option<&str>,
    work_budget: Option<f64>,
    timeout: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let timeout = check_timeout(timeout)?;
    let periods: u32 = optional_count("periods", periods, 1, U32_MAX)?.unwrap_or(1);
    let warmup: u32 = optional_count("warmup", warmup, 0, U32_MAX)?.unwrap_or(20);
    let mut s = scene.any();
    apply_work_budget(&mut s, work_budget)?;
    if let Some(text) = speed {
        s.set_input_speed(geardyn::units::parse_speed("--speed", text).map_err(err)?);
    }
    let input_speed = s.input_speed();
    let (orbit, report, meshes) = py
        .detach(move || {
            with_deadline(timeout, || {
                let o = commands::steady::periodic(&s, periods, warmup)?;
                let meshes = commands::steady::periodic_responses(&s, &o)?;
                commands::steady::periodic_report(&s, &o).map(|r| (o, r, meshes))
            })
        })
        .map_err(err)?;
    let d = PyDict::new(py);
    d.set_item("speed", input_speed)?;
    d.set_item("speed_rpm", geardyn::units::rpm(input_speed))?;
    let per_mesh = PyList::empty(py);
    for m in &meshes {
        let e = PyDict::new(py);
        mesh_response(&e, m)?;
        per_mesh.append(e)?;
    }
    d.set_item("meshes", per_mesh)?;
    d.set_item("period", orbit.period)?;
    d.set_item("periods", orbit.periods)?;
    d.set_item("y0", vector(py, &orbit.y0)?)?;
    // (re, im) pairs: the Python wrapper makes them a complex array.
    let multipliers: Vec<(f64, f64)> = orbit.multipliers.iter().map(|m| (m.re, m.im)).collect();
    d.set_item("multipliers", multipliers)?;
    d.set_item("spectral_radius", orbit.spectral_radius())?;
    d.set_item("stability", format!("{:?}", orbit.stability()))?;
    d.set_item("residuals", vector(py, &orbit.residuals)?)?;
    let m = &orbit.monodromy;
    let rows: Vec<Vec<f64>> = (0..m.nrows())
        .map(|i| m.row(i).iter().copied().collect())
        .collect();
    d.set_item("monodromy", matrix(py, &rows, m.ncols())?)?;
    d.set_item("report", report)?;
    Ok(d)
}

/// Frequency-response sweep over the input-gear speed, for any scene; returns
/// `(columns, data)` as the CSV of `geardyn sweep` has them (per-mesh columns prefixed).
#[pyfunction]
#[pyo3(signature = (scene, speed, direction = "both", tolerance = 1e-7, max_periods = None, work_budget = None,
    timeout = None))]
#[allow(clippy::too_many_arguments)]
fn sweep<'py>(
    py: Python<'py>,
    scene: &PyScene,
    speed: &str,
    direction: &str,
    tolerance: f64,
    max_periods: Option<&Bound<'py, PyAny>>,
    work_budget: Option<f64>,
    timeout: Option<f64>,
) -> PyResult<Table<'py>> {
    let timeout = check_timeout(timeout)?;
    let max_periods: u32 = optional_count("max_periods", max_periods, 0, U32_MAX)?.unwrap_or(3000);
    let mut s = scene.any();
    apply_work_budget(&mut s, work_budget)?;
    let request = commands::steady::SweepRequest {
        speed,
        direction,
        tolerance,
        max_periods,
        poincare: false,
    };
    // A sweep keeps a failed point as a row of NaN and goes on; past its deadline every point
    // would fail, so the whole sweep fails with the deadline's message.
    let sweep = py
        .detach(|| {
            with_deadline(timeout, || {
                let sweep = request.run(&s, &|_, _| {})?;
                match geardyn::simulation::budget::deadline_passed(f64::NAN) {
                    Some(message) => Err(message),
                    None => Ok(sweep),
                }
            })
        })
        .map_err(err)?;
    // A point that failed (its run beyond the work budget, say) is kept as a row of NaN, as
    // in `geardyn sweep`; its reason reaches Python as a RuntimeWarning per point
    // (`warnings.simplefilter("error")` makes it an exception).
    for p in sweep.points.iter() {
        if let Some(failure) = &p.failure {
            let message = CString::new(format!(
                "sweep: speed {} rad/s failed (row of NaN): {failure}",
                p.speed
            ))
            .unwrap_or_default();
            PyErr::warn(py, &py.get_type::<PyRuntimeWarning>(), &message, 1)?;
        }
    }
    let rows: Vec<_> = sweep.points.iter().map(|p| p.row()).collect();
    let columns = sweep.columns();
    table(py, &columns, &rows)
}

/// Harmonic balance with arclength continuation over `speed = "from:to"`, for any scene;
/// returns `(columns, data)` as the CSV of `geardyn hb` has them (per-mesh columns prefixed).
#[pyfunction]
#[pyo3(signature = (scene, speed, harmonics = None, subharmonic = None, work_budget = None,
    timeout = None))]
fn hb<'py>(
    py: Python<'py>,
    scene: &PyScene,
    speed: &str,
    harmonics: Option<&Bound<'py, PyAny>>,
    subharmonic: Option<&Bound<'py, PyAny>>,
    work_budget: Option<f64>,
    timeout: Option<f64>,
) -> PyResult<Table<'py>> {
    let timeout = check_timeout(timeout)?;
    let harmonics: usize = optional_count("harmonics", harmonics, 1, i64::MAX)?.unwrap_or(20);
    let subharmonic: u32 = optional_count("subharmonic", subharmonic, 1, U32_MAX)?.unwrap_or(1);
    let mut s = scene.any();
    apply_work_budget(&mut s, work_budget)?;
    let request = commands::hb::HbRequest {
        speed,
        harmonics,
        subharmonic,
    };
    let branch = py
        .detach(|| with_deadline(timeout, || request.run(&s)))
        .map_err(err)?;
    // What `geardyn hb` prints as caveats in its summary (a branch that ends short because the
    // harmonics do not resolve the orbit, verdicts or statistics that may be wrong) reaches
    // Python as RuntimeWarnings, so a shortened table is never silent.
    for caveat in branch.caveats() {
        let message = CString::new(format!("hb: {caveat}")).unwrap_or_default();
        PyErr::warn(py, &py.get_type::<PyRuntimeWarning>(), &message, 1)?;
    }
    let columns = branch.columns();
    table(py, &columns, &branch.rows())
}

/// `geardyn spectrum`: the exact spectrum of the scene's periodic steady state, written to
/// the CSV `out` (and the plot `plot`) as the CLI writes them; returns the text it prints.
/// The Python wrapper reads the CSV back (shortest round-trip floats: the same doubles).
#[pyfunction]
#[pyo3(signature = (scene, out, signals, samples, periods, work_budget = None, plot = None))]
#[allow(clippy::too_many_arguments)]
fn spectrum(
    py: Python<'_>,
    scene: &PyScene,
    out: PathBuf,
    signals: Vec<String>,
    samples: &Bound<'_, PyAny>,
    periods: &Bound<'_, PyAny>,
    work_budget: Option<f64>,
    plot: Option<PathBuf>,
) -> PyResult<String> {
    let samples: usize = optional_count("samples", Some(samples), 1, i64::MAX)?.unwrap_or(64);
    let periods: u32 = optional_count("periods", Some(periods), 1, U32_MAX)?.unwrap_or(1);
    let mut s = scene.any();
    apply_work_budget(&mut s, work_budget)?;
    let request = commands::spectrum::SpectrumRequest {
        signals,
        samples_per_mesh_period: samples,
        periods,
    };
    let drawn = commands::spectrum::SpectrumPlot::default();
    py.detach(|| {
        commands::spectrum::spectrum_command_with(
            &s,
            &request,
            &out,
            plot.as_deref(),
            &drawn,
            geardyn::simulation::stream::ProgressDisplay::Off,
        )
    })
    .map_err(err)
}

/// `geardyn waterfall` with its defaults but for the arguments given: the order map of a
/// run-up scene to the CSV `out`, the order cuts to `order_cuts` if given (and the plots);
/// returns the text the CLI prints.
#[pyfunction]
#[pyo3(signature = (scene, out, mesh = None, signal = "dte", segment = None, overlap = 0.5,
    window = "hann", order_cuts = None, mesh_orders = None, shaft_orders = None,
    revolutions = None, order_samples = None, work_budget = None, plot = None,
    order_plot = None))]
#[allow(clippy::too_many_arguments)]
fn waterfall(
    py: Python<'_>,
    scene: &PyScene,
    out: PathBuf,
    mesh: Option<String>,
    signal: &str,
    segment: Option<&Bound<'_, PyAny>>,
    overlap: f64,
    window: &str,
    order_cuts: Option<PathBuf>,
    mesh_orders: Option<Vec<f64>>,
    shaft_orders: Option<Vec<f64>>,
    revolutions: Option<&Bound<'_, PyAny>>,
    order_samples: Option<&Bound<'_, PyAny>>,
    work_budget: Option<f64>,
    plot: Option<PathBuf>,
    order_plot: Option<PathBuf>,
) -> PyResult<String> {
    use geardyn::analysis::spectrum::Window;
    use geardyn::commands::runup::{OrderTrackRequest, WaterfallRequest};
    let segment: usize = optional_count("segment", segment, 1, i64::MAX)?.unwrap_or(1000);
    let revolutions: usize = optional_count("revolutions", revolutions, 1, i64::MAX)?.unwrap_or(8);
    let order_samples: usize =
        optional_count("order_samples", order_samples, 1, i64::MAX)?.unwrap_or(64);
    let mut s = scene.any();
    apply_work_budget(&mut s, work_budget)?;
    let request = WaterfallRequest {
        mesh: mesh.as_deref(),
        signal,
        segment,
        overlap,
        window,
        frequency_range: None,
        order_range: None,
        dynamic_range: 60.0,
        order_cuts: order_cuts.as_deref(),
        order_plot: order_plot.as_deref(),
        db: false,
        tracking: OrderTrackRequest {
            samples_per_mesh_cycle: order_samples,
            revolutions,
            overlap,
            // A bad window is refused by the waterfall, which names it (as on the CLI).
            window: Window::parse(window).unwrap_or(Window::Hann),
            mesh_orders: mesh_orders.unwrap_or_else(|| vec![1.0, 2.0, 3.0]),
            shaft_orders: shaft_orders.unwrap_or_default(),
        },
    };
    py.detach(|| {
        commands::runup::waterfall_command(
            &s,
            &request,
            &out,
            plot.as_deref(),
            geardyn::simulation::stream::ProgressDisplay::Off,
        )
    })
    .map_err(err)
}

/// `geardyn floquet --json`: the monodromy of a linear scene at its speed or `speed`, with
/// its multipliers, as the JSON text the CLI prints.
#[pyfunction]
#[pyo3(signature = (scene, speed = None, mu = None))]
fn floquet(
    py: Python<'_>,
    scene: &PyScene,
    speed: Option<String>,
    mu: Option<f64>,
) -> PyResult<String> {
    let s = commands::floquet::with_friction(scene.any(), mu).map_err(err)?;
    py.detach(|| commands::floquet::floquet(s, speed.as_deref(), true))
        .map_err(err)
}

/// `geardyn band`: the parametric instability bands of a linear scene over `speed =
/// "from:to"` with `points` scan points; the text the CLI prints.
#[pyfunction]
#[pyo3(signature = (scene, speed, points, mu = None))]
fn band(
    py: Python<'_>,
    scene: &PyScene,
    speed: &str,
    points: &Bound<'_, PyAny>,
    mu: Option<f64>,
) -> PyResult<String> {
    let points: usize = optional_count("points", Some(points), 1, i64::MAX)?.unwrap_or(400);
    let s = commands::floquet::with_friction(scene.any(), mu).map_err(err)?;
    py.detach(|| commands::floquet::band(&s, speed, points))
        .map_err(err)
}

/// Natural frequencies and mode shapes of a drivetrain's mean system; returns a dict with
/// `report`, the text `geardyn modes` prints.
#[pyfunction]
#[pyo3(signature = (scene, rigid_bearings = false))]
fn modes<'py>(
    py: Python<'py>,
    scene: &PyScene,
    rigid_bearings: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let s = scene.any();
    let (result, report) = py.detach(move || {
        let mut report = Vec::new();
        let r = commands::modes::modes(&s, rigid_bearings, &mut report);
        (r, String::from_utf8_lossy(&report).into_owned())
    });
    let result = result.map_err(err)?;
    let d = PyDict::new(py);
    let frequencies: Vec<f64> = result.modes.iter().map(|m| m.frequency).collect();
    let rigid: Vec<bool> = result.modes.iter().map(|m| m.rigid).collect();
    let shapes: Vec<Vec<f64>> = result
        .modes
        .iter()
        .map(|m| m.shape.iter().copied().collect())
        .collect();
    d.set_item("labels", result.labels.clone())?;
    d.set_item("frequencies", vector(py, &frequencies)?)?;
    d.set_item("rigid", rigid)?;
    d.set_item("shapes", matrix(py, &shapes, result.labels.len())?)?;
    d.set_item("report", report)?;
    Ok(d)
}

/// Mesh stiffness over one mesh period from a gears file at pinion torque `torque`; returns
/// `(columns, data, summary)` as `geardyn stiffness` writes and prints them.
#[pyfunction]
#[pyo3(signature = (gears, torque, etc = true, harmonics = None))]
fn stiffness<'py>(
    py: Python<'py>,
    gears: PathBuf,
    torque: f64,
    etc: bool,
    harmonics: Option<&Bound<'py, PyAny>>,
) -> PyResult<(Vec<String>, Bound<'py, PyAny>, String)> {
    let max = commands::stiffness::MAX_SUMMARY_HARMONICS as i64;
    let harmonics: usize = optional_count("harmonics", harmonics, 0, max)?.unwrap_or(4);
    let (columns, rows, summary) = py
        .detach(move || {
            commands::stiffness::stiffness(&gears, torque, etc)
                .map(|st| (st.columns(), st.rows(), st.summary(harmonics)))
        })
        .map_err(err)?;
    let data = matrix(py, &rows, columns.len())?;
    Ok((columns, data, summary))
}

/// Builds `<out>/<modelIdentifier>.fmu` from a scene file or folder with the cdylib `cdylib`
/// (`libgeardyn.so`); returns the FMU's path.
#[pyfunction]
fn build_fmu(py: Python<'_>, scene: PathBuf, out: PathBuf, cdylib: PathBuf) -> PyResult<PathBuf> {
    py.detach(move || geardyn::fmi::package::build_fmu(&scene, &out, &cdylib))
        .map_err(err)
}

/// `geardyn run` of an FMU or a system of FMUs (`commands::run::status`) into the CSV `out`,
/// with the CLI's defaults but for the arguments given. Returns the exit status: 1 after a
/// failure the run reported itself (its message went to the process's standard error, which
/// `geardyn.run` reads); a failure before the run raises `GeardynError`.
#[pyfunction]
#[pyo3(signature = (fmu, out, start_time = None, stop_time = None, output_interval = None,
    max_rows = None, start = Vec::new(), input = None, outputs = None, log_level = "warning",
    algorithm = None, extrapolation = None, threads = None, divergence_factor = None,
    tolerance = None, min_step = None, max_step = None))]
#[allow(clippy::too_many_arguments)]
fn run(
    py: Python<'_>,
    fmu: PathBuf,
    out: PathBuf,
    start_time: Option<f64>,
    stop_time: Option<f64>,
    output_interval: Option<f64>,
    max_rows: Option<&Bound<'_, PyAny>>,
    start: Vec<String>,
    input: Option<PathBuf>,
    outputs: Option<Vec<String>>,
    log_level: &str,
    algorithm: Option<String>,
    extrapolation: Option<String>,
    threads: Option<&Bound<'_, PyAny>>,
    divergence_factor: Option<f64>,
    tolerance: Option<f64>,
    min_step: Option<f64>,
    max_step: Option<f64>,
) -> PyResult<u8> {
    let args = geardyn::host::cli::RunArgs {
        fmu,
        start_time,
        stop_time,
        output_interval,
        max_rows: optional_count("max_rows", max_rows, 1, i64::MAX)?
            .unwrap_or(geardyn::host::runner::DEFAULT_MAX_ROWS),
        start,
        input,
        out: Some(out),
        outputs,
        log_level: log_level.to_string(),
        fmi_trace: false,
        preload: Vec::new(),
        algorithm,
        extrapolation,
        threads: optional_count("threads", threads, 1, i64::MAX)?,
        divergence_factor,
        tolerance,
        min_step,
        max_step,
        no_impulse_correction: false,
        no_switch_steps: false,
        no_shared_binaries: false,
        timing: false,
    };
    // `run`'s options are this function's arguments, none of them a scene parameter.
    py.detach(|| commands::run::status(&args))
        .map_err(|m| GeardynError::new_err(_pythonic(&m)))
}

/// A message of `geardyn run` in Python's terms: its options are `run`'s arguments, none of
/// them a scene parameter. `geardyn.run` applies it to the message the supervised run printed.
#[pyfunction]
fn _pythonic(message: &str) -> String {
    pythonic(message, &[])
}

/// A speed in rad/s from `4500rpm`, `471.24rad/s` or a bare number (rad/s), as `--speed`
/// reads it (`geardyn::units`).
#[pyfunction]
fn parse_speed(text: &str) -> PyResult<f64> {
    geardyn::units::parse_speed("--speed", text).map_err(err)
}

/// The unit of an output column by its name (`geardyn::units::column_unit`), or None.
#[pyfunction]
fn column_unit(name: &str) -> Option<&'static str> {
    geardyn::units::column_unit(name)
}

/// What the scene format says about a parameter path, without a scene (`Scene.describe`).
#[pyfunction]
fn describe(py: Python<'_>, path: &str) -> PyResult<parameter::PyParameter> {
    let p = geardyn::scene::schema::describe(path, None).map_err(err)?;
    parameter::parameter(py, p, |py, v| Ok(to_python(py, v)?.unbind()))
}

/// The unit of a scene parameter by its path (`geardyn::units::parameter_unit`), or None.
#[pyfunction]
fn parameter_unit(path: &str) -> Option<&'static str> {
    geardyn::units::parameter_unit(path)
}

#[pymodule]
fn _geardyn(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("GeardynError", m.py().get_type::<GeardynError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<PyScene>()?;
    m.add_function(wrap_pyfunction!(_restore_scene, m)?)?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(periodic, m)?)?;
    m.add_function(wrap_pyfunction!(sweep, m)?)?;
    m.add_function(wrap_pyfunction!(hb, m)?)?;
    m.add_function(wrap_pyfunction!(modes, m)?)?;
    m.add_function(wrap_pyfunction!(spectrum, m)?)?;
    m.add_function(wrap_pyfunction!(waterfall, m)?)?;
    m.add_function(wrap_pyfunction!(floquet, m)?)?;
    m.add_function(wrap_pyfunction!(band, m)?)?;
    m.add_function(wrap_pyfunction!(stiffness, m)?)?;
    m.add_function(wrap_pyfunction!(build_fmu, m)?)?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(_pythonic, m)?)?;
    m.add_function(wrap_pyfunction!(parse_speed, m)?)?;
    m.add_function(wrap_pyfunction!(column_unit, m)?)?;
    m.add_function(wrap_pyfunction!(parameter_unit, m)?)?;
    m.add_function(wrap_pyfunction!(describe, m)?)?;
    m.add_class::<parameter::PyParameter>()?;
    Ok(())
}
