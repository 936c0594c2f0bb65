//! The geardyn FMUs of the shipped example systems, built from their scenes on first use
//! (issue 39: a README command must work on a fresh clone).
//!
//! The systems under `examples/systems/` name their FMUs where `bash scripts/build-fmus.sh`
//! writes them, `<checkout>/out/fmus/<name>.fmu`, built from the shipped scene
//! `<checkout>/fmu/<name>/scene.toml`. On a fresh clone these files do not exist yet. A
//! missing source of exactly that shape, whose scene exists, is built here as
//! `geardyn fmu build fmu/<name> --out out/fmus` would build it, and the run says so. Any
//! other missing source stays an error, which names the command that builds a geardyn FMU.

use crate::fmi::package;
use std::path::{Component, Path, PathBuf};

/// The scene folder a missing FMU `X/out/fmus/NAME.fmu` is built from: `X/fmu/NAME`, when it
/// holds a `scene.toml`. `None` for any other path.
pub fn scene_of(fmu: &Path) -> Option<PathBuf> {
    let name = fmu.file_name()?.to_str()?.strip_suffix(".fmu")?;
    let fmus = fmu.parent()?;
    let out = fmus.parent()?;
    if fmus.file_name()? != "fmus" || out.file_name()? != "out" {
        return None;
    }
    let scene = out.parent()?.join("fmu").join(name);
    scene.join("scene.toml").is_file().then_some(scene)
}

/// `p` with `a/..` pairs removed, for messages (`examples/systems/x/../../../out/fmus/a.fmu`
/// reads `out/fmus/a.fmu`).
pub fn tidy(p: &Path) -> PathBuf {
    let mut parts: Vec<Component> = Vec::new();
    for c in p.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir if matches!(parts.last(), Some(Component::Normal(_))) => {
                parts.pop();
            }
            c => parts.push(c),
        }
    }
    if parts.is_empty() {
        PathBuf::from(".")
    } else {
        parts.iter().collect()
    }
}

/// Build the missing FMU `fmu` from the scene folder `scene` with the cdylib next to this
/// executable; the note saying so. The error names the command that builds it by hand.
pub fn build(fmu: &Path, scene: &Path) -> Result<String, String> {
    let (fmu_shown, scene_shown) = (tidy(fmu), tidy(scene));
    let out_dir = fmu.parent().unwrap_or(Path::new("."));
    let by_hand = || {
        format!(
            "build it with `geardyn fmu build {} --out {}` (or every shipped FMU with `bash scripts/build-fmus.sh`)",
            scene_shown.display(),
            tidy(out_dir).display()
        )
    };
    // The cdylib next to this executable (`cargo run`, target/release), else the checkout's
    // own build (a `geardyn` installed with `cargo install` has no cdylib beside it).
    let checkout_lib = out_dir
        .parent()
        .and_then(Path::parent)
        .map(|x| x.join("target/release/libgeardyn.so"))
        .filter(|p| p.is_file());
    let built = package::find_cdylib()
        .or_else(|e| checkout_lib.ok_or(e))
        .and_then(|lib| package::build_fmu(scene, out_dir, &lib));
    match built {
        Ok(p) if p.file_name() == fmu.file_name() => Ok(format!(
            "{} did not exist: built it from the shipped scene {} (first use; `bash scripts/build-fmus.sh` builds them all)",
            fmu_shown.display(),
            scene_shown.display()
        )),
        Ok(p) => Err(format!(
            "{} does not exist, and building it from {} gave {} instead (the scene's model name differs); {}",
            fmu_shown.display(),
            scene_shown.display(),
            tidy(&p).display(),
            by_hand()
        )),
        Err(e) => Err(format!(
            "{} does not exist and could not be built from {}: {e}; {}",
            fmu_shown.display(),
            scene_shown.display(),
            by_hand()
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tidy_removes_parent_pairs_only_after_names() {
        let t = |s: &str| tidy(Path::new(s)).display().to_string();
        assert_eq!(
            t("examples/systems/x/../../../out/fmus/a.fmu"),
            "out/fmus/a.fmu"
        );
        assert_eq!(t("../x/./y"), "../x/y");
        assert_eq!(t("a/.."), ".");
    }

    #[test]
    fn only_out_fmus_name_with_a_scene_is_buildable() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        assert_eq!(
            scene_of(&root.join("out/fmus/emotor.fmu")),
            Some(root.join("fmu/emotor"))
        );
        assert_eq!(scene_of(&root.join("out/fmus/no_such_scene.fmu")), None);
        assert_eq!(scene_of(&root.join("out/other/emotor.fmu")), None);
        assert_eq!(scene_of(&root.join("build/fmus/emotor.fmu")), None);
        assert_eq!(scene_of(&root.join("out/fmus/emotor.zip")), None);
    }
}
