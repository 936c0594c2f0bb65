//! `geardyn fmu`: build an FMU from a scene, print a scene's model description, and keep the
//! checked-in model descriptions of the shipped FMUs equal to the generator's.

use std::path::{Path, PathBuf};

use crate::fmi::{description, package};

/// `geardyn fmu build`: writes `<out>/<modelIdentifier>.fmu` from a scene (its file or a folder
/// holding one) with the cdylib `cdylib` (default: `libgeardyn.so` next to this executable),
/// and prints its path. A bad scene is reported and no FMU is written.
pub fn build(scene: &Path, out: &Path, cdylib: Option<&Path>) -> Result<PathBuf, String> {
    let lib = match cdylib {
        Some(p) => p.to_path_buf(),
        None => package::find_cdylib()?,
    };
    let fmu = package::build_fmu(scene, out, &lib)?;
    println!("{}", fmu.display());
    Ok(fmu)
}

/// `geardyn fmu description`: prints the modelDescription.xml of a scene.
pub fn description(scene: &Path) -> Result<(), String> {
    let (scene, _) = package::resolve_scene(scene)?;
    let (xml, _) = description::for_scene(&scene)?;
    print!("{xml}");
    Ok(())
}

/// `geardyn fmu descriptions`: checks that `dir/<name>.xml` matches the generator for every
/// scene folder in `scenes`; with `write`, regenerates them. The problems are the error.
pub fn descriptions(scenes: &Path, dir: &Path, write: bool) -> Result<(), String> {
    let problems = description::check_checked_in(scenes, dir, write)?;
    if problems.is_empty() {
        let what = if write { "refreshed" } else { "up to date" };
        println!("{}: {what}", dir.display());
        Ok(())
    } else {
        Err(problems.join("\n"))
    }
}
