//! A gear FMU's model as `fmi2Instantiate` makes it, for tests that drive it directly.

use geardyn::fmi::model::{CoSimModel, LoadedModel};
use geardyn::fmu::entry::load_scene;

/// The model of the scene at `path`, initialized at `t = 0`.
pub fn initialized(path: &std::path::Path) -> LoadedModel {
    let mut loaded = load_scene(path).unwrap();
    let m = loaded.model.as_mut();
    m.setup_experiment(0.0, None, None).unwrap();
    m.exit_initialization().unwrap();
    loaded
}

/// The value reference of the variable `name`.
pub fn vr(m: &dyn CoSimModel, name: &str) -> u32 {
    (m.variables().iter())
        .find(|v| v.name == name)
        .unwrap_or_else(|| panic!("no variable {name}"))
        .value_reference
}
