//! The single factory through which the FMU (`fmi2Instantiate`) and the packager
//! (`geardyn fmu build`) turn a scene file into a [`CoSimModel`]. Both go through
//! [`load_scene`], so the variable table, model name and GUID in `modelDescription.xml` are
//! by construction the ones the binary uses at run time.

use std::path::Path;

use crate::fmi::blob;
use crate::fmi::model::{CoSimModel, LoadedModel};
use crate::fmu::drivetrain::Drivetrain;
use crate::fmu::kernel::Kernel;
use crate::fmu::pair::Pair;
use crate::fmu::Adapter;
use crate::scene::is_train_text;

/// Name of the scene file inside an FMU's `resources/` folder.
pub const SCENE_FILE: &str = "scene.toml";

/// Called by `fmi2Instantiate` with the decoded `fmuResourceLocation` (FMI 2.0.x §2.1.5).
pub fn instantiate(resources_dir: &Path) -> Result<LoadedModel, String> {
    load_scene(&resources_dir.join(SCENE_FILE))
}

/// Reads, parses and validates a scene file and builds its model. The GUID is derived from
/// the exact file bytes and the crate version ([`blob::guid`]).
pub fn load_scene(scene_path: &Path) -> Result<LoadedModel, String> {
    let bytes = std::fs::read(scene_path)
        .map_err(|e| format!("cannot read scene '{}': {e}", scene_path.display()))?;
    let text = std::str::from_utf8(&bytes)
        .map_err(|e| format!("scene '{}' is not UTF-8: {e}", scene_path.display()))?;
    let origin = scene_path.display().to_string();
    let guid = blob::guid(&bytes);
    // Drivetrain scenes (`[[mesh]]`, `[[shaft]]` or `[model]`, `docs/train.md`) go to the
    // drivetrain kernel; the single-mesh format of `docs/model.md` to the pair kernel.
    // Element scenes (`[element]`, `docs/elements.md`) are their own models.
    if crate::fmu::element::is_element_text(text) {
        return crate::fmu::element::load(text, &origin, guid);
    }
    if is_train_text(text) {
        load::<Drivetrain>(text, &origin, guid)
    } else {
        load::<Pair>(text, &origin, guid)
    }
}

/// Validates the scene text (messages name the field and value) and adapts its simulation
/// to the FMI layer.
fn load<K: Kernel>(text: &str, origin: &str, guid: String) -> Result<LoadedModel, String> {
    let settings = K::load(text, origin)?;
    let (model, info) =
        Adapter::<K>::new(settings, guid).map_err(|e| format!("scene '{origin}': {e}"))?;
    Ok(LoadedModel {
        model: Box::new(model) as Box<dyn CoSimModel>,
        info,
    })
}
