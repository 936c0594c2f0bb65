//! FMU packager (FMI 2.0.x §2.3 "FMU Distribution"): one generic cdylib, one scene per FMU.
//!
//! Layout: `modelDescription.xml`, `binaries/linux64/<modelIdentifier>.so` (a copy of
//! `libgeardyn.so`), `resources/scene.toml`, `documentation/index.html`. ZIP rules of §2.3:
//! deflate or store only, forward slashes, no zip64, no encryption; entries carry a fixed
//! timestamp so the same inputs give the same archive. The shared library is stored, not
//! deflated: every host unpacks it before each run, and inflating its ~2.5 MB cost about 3 %
//! of a 1e5-step `geardyn run` (scripts/bench-host.sh); stored, the FMU is ~2.5 MB instead
//! of ~1 MB. The small text files stay deflated.

use std::io::Write;
use std::path::{Path, PathBuf};

use zip::write::SimpleFileOptions;
use zip::{CompressionMethod, DateTime, ZipWriter};

use super::description;
use super::model::{model_identifier, ModelInfo, Variable};
use crate::fmu::entry::{load_scene, SCENE_FILE};

/// Resolves `scene.toml | fmu/<name>` into the scene file and an optional README.
pub fn resolve_scene(input: &Path) -> Result<(PathBuf, Option<PathBuf>), String> {
    if input.is_dir() {
        let scene = input.join(SCENE_FILE);
        if !scene.is_file() {
            return Err(format!("{} has no {SCENE_FILE}", input.display()));
        }
        let readme = input.join("README.md");
        Ok((scene, readme.is_file().then_some(readme)))
    } else if input.is_file() {
        Ok((input.to_path_buf(), None))
    } else {
        Err(format!("scene '{}' does not exist", input.display()))
    }
}

/// The cdylib the release binary carries (build.rs), for a binary installed without it.
static EMBEDDED_CDYLIB: std::sync::OnceLock<&'static [u8]> = std::sync::OnceLock::new();

/// Registers the cdylib bytes the binary carries; empty bytes (a `cargo check` build) are none.
pub fn embed_cdylib(bytes: &'static [u8]) {
    if !bytes.is_empty() {
        let _ = EMBEDDED_CDYLIB.set(bytes);
    }
}

/// The FMU binary: `libgeardyn.so` next to the running executable (`target/<profile>/`), or
/// one level up (test binaries live in `deps/`, examples in `examples/`); else the copy the
/// binary carries ([`embed_cdylib`]), written once to the user's cache folder.
pub fn find_cdylib() -> Result<PathBuf, String> {
    let exe = std::env::current_exe().map_err(|e| format!("cannot locate executable: {e}"))?;
    let mut dir = exe.parent();
    for _ in 0..2 {
        let Some(d) = dir else { break };
        let lib = d.join("libgeardyn.so");
        if lib.is_file() {
            return Ok(lib);
        }
        dir = d.parent();
    }
    if let Some(bytes) = EMBEDDED_CDYLIB.get() {
        return cached_cdylib(bytes);
    }
    Err(format!(
        "libgeardyn.so not found next to {} (build it with `cargo build --release` or pass --cdylib)",
        exe.display()
    ))
}

/// Writes the embedded cdylib to `<cache>/geardyn/libgeardyn-<version>-<hash>.so` unless that
/// file is there already. The content hash in the name keeps binaries of different builds
/// apart; the file is written under a temporary name and renamed, so a reader never sees a
/// partial one.
fn cached_cdylib(bytes: &[u8]) -> Result<PathBuf, String> {
    let home_cache = || std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache"));
    let base = std::env::var_os("XDG_CACHE_HOME")
        .map(PathBuf::from)
        .filter(|p| p.is_absolute())
        .or_else(home_cache)
        .unwrap_or_else(std::env::temp_dir);
    let dir = base.join("geardyn");
    // FNV-1a: a fingerprint of the content, not a defence against a crafted file.
    let hash = bytes.iter().fold(0xcbf2_9ce4_8422_2325_u64, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    });
    let lib = dir.join(format!(
        "libgeardyn-{}-{hash:016x}.so",
        env!("CARGO_PKG_VERSION")
    ));
    if std::fs::metadata(&lib).is_ok_and(|m| m.len() == bytes.len() as u64) {
        return Ok(lib);
    }
    let fail = |e: std::io::Error| {
        format!(
            "cannot write the FMU binary this executable carries to {}: {e} (pass --cdylib)",
            lib.display()
        )
    };
    std::fs::create_dir_all(&dir).map_err(fail)?;
    let partial = dir.join(format!(".libgeardyn-{}.partial", std::process::id()));
    std::fs::write(&partial, bytes).map_err(fail)?;
    std::fs::rename(&partial, &lib).map_err(fail)?;
    Ok(lib)
}

/// Builds `<out_dir>/<modelIdentifier>.fmu` and returns its path. The scene is loaded and
/// validated through the same factory the binary uses before anything is written; the
/// archive is written to a temporary name and renamed, so a failure leaves no FMU behind.
pub fn build_fmu(scene_input: &Path, out_dir: &Path, cdylib: &Path) -> Result<PathBuf, String> {
    let (scene, readme) = resolve_scene(scene_input)?;
    let scene_bytes =
        std::fs::read(&scene).map_err(|e| format!("cannot read {}: {e}", scene.display()))?;
    let loaded = load_scene(&scene)?;
    let xml = description::model_description(
        &loaded.info,
        loaded.model.variables(),
        loaded.model.capabilities(),
    )?;
    let lib = std::fs::read(cdylib)
        .map_err(|e| format!("cannot read shared library {}: {e}", cdylib.display()))?;
    if !lib.starts_with(b"\x7fELF") {
        return Err(format!("{} is not an ELF shared library", cdylib.display()));
    }
    let readme_text = match &readme {
        Some(p) => Some(std::fs::read_to_string(p).map_err(|e| format!("{}: {e}", p.display()))?),
        None => None,
    };
    let html = documentation(
        &loaded.info,
        loaded.model.variables(),
        readme_text.as_deref(),
    );
    let id = model_identifier(&loaded.info.model_name);

    std::fs::create_dir_all(out_dir)
        .map_err(|e| format!("cannot create {}: {e}", out_dir.display()))?;
    let target = out_dir.join(format!("{id}.fmu"));
    let tmp = out_dir.join(format!(".{id}.fmu.partial"));
    let r = write_zip(
        &tmp,
        &[
            ("modelDescription.xml", xml.as_bytes(), 0o644, DEFLATE),
            (&format!("binaries/linux64/{id}.so"), &lib, 0o755, STORE),
            (
                &format!("resources/{SCENE_FILE}"),
                &scene_bytes,
                0o644,
                DEFLATE,
            ),
            ("documentation/index.html", html.as_bytes(), 0o644, DEFLATE),
        ],
    )
    .and_then(|()| {
        std::fs::rename(&tmp, &target)
            .map_err(|e| format!("cannot write {}: {e}", target.display()))
    });
    if r.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    r.map(|()| target)
}

/// The two compression methods FMI 2.0.x §2.3 allows.
const DEFLATE: CompressionMethod = CompressionMethod::Deflated;
const STORE: CompressionMethod = CompressionMethod::Stored;

/// Entries are `(name, bytes, unix mode, compression method)`.
fn write_zip(path: &Path, entries: &[(&str, &[u8], u32, CompressionMethod)]) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Display| format!("writing {}: {e}", path.display());
    let file = std::fs::File::create(path).map_err(|e| err(&e))?;
    let mut zip = ZipWriter::new(file);
    for (name, data, mode, method) in entries {
        // No zip64 (large_file stays false): "version needed to extract" 2.0 at most.
        let opts = SimpleFileOptions::default()
            .compression_method(*method)
            .last_modified_time(DateTime::default())
            .unix_permissions(*mode);
        zip.start_file(*name, opts).map_err(|e| err(&e))?;
        zip.write_all(data).map_err(|e| err(&e))?;
    }
    let mut file = zip.finish().map_err(|e| err(&e))?;
    file.flush().map_err(|e| err(&e))?;
    Ok(())
}

fn html_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// `documentation/index.html`: the model's variables (from the same table) and the scene's
/// README, if any.
pub fn documentation(info: &ModelInfo, vars: &[Variable], readme: Option<&str>) -> String {
    let mut h = String::new();
    let name = html_escape(&info.model_name);
    h.push_str(&format!(
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>{name}</title></head><body>\n<h1>{name}</h1>\n<p>{}</p>\n",
        html_escape(&info.description)
    ));
    h.push_str(&info.documentation);
    h.push_str(&format!(
        "<p>FMI 2.0 Co-Simulation FMU generated by geardyn {}. GUID {}.</p>\n",
        env!("CARGO_PKG_VERSION"),
        html_escape(&info.guid)
    ));
    h.push_str("<h2>Variables</h2>\n<table border=\"1\">\n<tr><th>name</th><th>vr</th><th>type</th><th>causality</th><th>variability</th><th>start</th><th>unit</th><th>description</th></tr>\n");
    for v in vars {
        h.push_str(&format!(
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
            html_escape(&v.name),
            v.value_reference,
            v.kind.as_str(),
            v.causality.as_str(),
            v.variability.as_str(),
            v.start.map(|s| format!("{s:?}")).unwrap_or_default(),
            html_escape(v.unit.as_deref().unwrap_or("")),
            html_escape(&v.description)
        ));
    }
    h.push_str("</table>\n");
    if let Some(r) = readme {
        h.push_str(&format!(
            "<h2>Scene notes</h2>\n<pre>{}</pre>\n",
            html_escape(r)
        ));
    }
    h.push_str("</body></html>\n");
    h
}
