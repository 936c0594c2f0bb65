//! Unpacking an FMU (a ZIP file, FMI 2.0.5 §2.3 "FMU Distribution") into a temporary folder.
//!
//! Every entry is checked, but `documentation/` and `sources/` are not written: no host
//! command reads them (they are for people and for compiling), and each extra file and folder
//! costs its creation and removal on every run.
//!
//! The folder is a [`tempfile::TempDir`] owned by [`Unpacked`]: it is removed when the value is
//! dropped, which also happens on every early `return Err(..)` and on unwinding, so no error
//! path leaves files behind.

use std::fs;
use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};

/// An FMU extracted to disk without its documentation and sources (or an already extracted
/// FMU folder, which is used in place).
pub struct Unpacked {
    /// Keeps the temporary folder alive; `None` when the FMU was given as a folder.
    _temp: Option<tempfile::TempDir>,
    root: PathBuf,
    /// Departures from the ZIP rules of FMI 2.0.5 §2.3 that still allowed extraction (for
    /// `geardyn validate`).
    pub zip_problems: Vec<String>,
}

impl Unpacked {
    /// The folder holding `modelDescription.xml`, `binaries/`, `resources/`.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// `resources/` inside the extracted FMU (it may not exist; hosts pass its URI anyway).
    pub fn resources(&self) -> PathBuf {
        self.root.join("resources")
    }

    /// Read `modelDescription.xml` as UTF-8 text.
    pub fn model_description_text(&self) -> Result<String, String> {
        let p = self.root.join("modelDescription.xml");
        let bytes = fs::read(&p).map_err(|e| format!("{}: cannot read: {e}", p.display()))?;
        String::from_utf8(bytes).map_err(|e| {
            format!(
                "{}: not UTF-8 text (byte {} is invalid); FMI 2.0.5 §2.2 requires UTF-8",
                p.display(),
                e.utf8_error().valid_up_to()
            )
        })
    }
}

/// Unpack `fmu` (a `.fmu` ZIP file, or a folder that already holds `modelDescription.xml`).
///
/// Errors name the file and the reason: missing file, not a ZIP archive, an entry that would
/// escape the target folder (`../`, an absolute path: `/x`, `//server/x`, `C:/x`), a symbolic link (FMI 2.0.5 §2.3: "Links
/// must not be used"), a backslash in an entry name (§2.3 requires `/`), no
/// `modelDescription.xml` at the top level, or an I/O error while extracting.
pub fn unpack(fmu: &Path) -> Result<Unpacked, String> {
    unpack_limited(fmu, MAX_UNPACKED_BYTES)
}

/// Refuse to write more than this many bytes when unpacking: a crafted archive ("zip bomb")
/// must not fill the disk. Far above any real FMU.
pub const MAX_UNPACKED_BYTES: u64 = 8 << 30;

/// Top-level folders that are checked but not written (see the module documentation).
const NOT_EXTRACTED: [&str; 2] = ["documentation", "sources"];

/// The copy buffer of the extraction: a shared library is megabytes, and a chunk this large
/// costs one read and one write system call per 256 KiB (`io::copy` uses 8 KiB).
const COPY_CHUNK: usize = 256 << 10;

/// Copy `from` to the end into `to` through `chunk`; the bytes copied.
fn copy_through(from: &mut impl Read, to: &mut impl Write, chunk: &mut [u8]) -> io::Result<u64> {
    let mut n = 0;
    loop {
        match from.read(chunk) {
            Ok(0) => return Ok(n),
            Ok(k) => {
                to.write_all(&chunk[..k])?;
                n += k as u64;
            }
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
}

/// How an entry name is absolute, if it is: a leading `/` (also `//server/share`, UNC style)
/// or a drive letter (`C:`, `C:/`). The ZIP reader's `enclosed_name` strips such prefixes and
/// extracts the entry as if it were relative, which hides a malformed or hostile archive.
fn absolute_kind(name: &str) -> Option<&'static str> {
    let b = name.as_bytes();
    if name.starts_with("//") || name.starts_with("\\\\") {
        Some("a UNC network path")
    } else if name.starts_with('/') || name.starts_with('\\') {
        Some("it starts at the root")
    } else if b.len() >= 2 && b[0].is_ascii_alphabetic() && b[1] == b':' {
        Some("a drive letter")
    } else {
        None
    }
}

/// Entry names that occur more than once in an archive: which copy a reader takes is up to
/// the reader (the zip crate took the last `modelDescription.xml`, issue 34), so such an
/// archive is refused, naming the entry and its positions. Names are compared as paths
/// (`a/b` and `a//b` are one file once unpacked); directory entries may repeat harmlessly.
pub fn refuse_duplicates<R: io::Read + io::Seek>(
    zip: &mut zip::ZipArchive<R>,
    archive: &Path,
) -> Result<(), String> {
    if zip.has_duplicate_names() {
        // The reader's index keeps one copy per name, so it cannot say which name repeats.
        return Err(format!(
            "{}: the ZIP archive lists an entry name more than once (a reader would take one \
             copy and silently drop the other); refusing an archive whose content is ambiguous",
            archive.display()
        ));
    }
    let mut seen: std::collections::HashMap<PathBuf, usize> = std::collections::HashMap::new();
    for i in 0..zip.len() {
        let Ok(entry) = zip.by_index_raw(i) else {
            continue; // reported with its reason when it is read
        };
        if entry.is_dir() {
            continue;
        }
        let Some(rel) = entry.enclosed_name() else {
            continue; // refused as unsafe when it is read
        };
        let rel: PathBuf = rel.components().collect();
        if let Some(first) = seen.insert(rel.clone(), i) {
            return Err(format!(
                "{}: ZIP entry \"{}\" occurs twice (entries #{first} and #{i}); refusing an \
                 archive whose content is ambiguous",
                archive.display(),
                rel.display()
            ));
        }
    }
    Ok(())
}

/// Binaries extracted before in this process that other FMUs may share (they announce
/// `<SharedBinary/>`): each file with its ZIP entry's CRC-32 and size.
#[derive(Default)]
pub struct SharedBinaries(Vec<(u32, u64, PathBuf)>);

/// [`unpack`], except the entry `binary` (`binaries/linux64/<id>.so`): where a binary in
/// `shared` has the same CRC-32 and size, this FMU's is a hard link to that file, not
/// inflated and written again; otherwise it is extracted and added to `shared`. `true` when
/// linked. A link is the same file, so `dlopen` gives the library already loaded from it
/// (glibc knows a loaded object by its device and inode): one copy of the code serves both
/// FMUs, which frees the processor's caches of a second copy of the same hot paths
/// (docs/cosimulation.md, "One binary for the system's FMUs"). The CRC-32 and size of the ZIP
/// directory stand for the bytes: only FMUs whose model description announces the sharing
/// come here, and an entry that matched them by accident (odds 2⁻³² at equal size) would run
/// the announcing library, not bytes of its own.
pub fn unpack_sharing(
    fmu: &Path,
    binary: &str,
    shared: &mut SharedBinaries,
) -> Result<(Unpacked, bool), String> {
    unpack_with(fmu, MAX_UNPACKED_BYTES, Some((Path::new(binary), shared)))
}

/// `modelDescription.xml` of the FMU archive `fmu`, read without unpacking it; `None` where
/// it cannot be read that way (not a ZIP file, no such entry, not UTF-8): [`unpack`] then
/// says why.
pub fn model_description_in(fmu: &Path) -> Option<String> {
    let file = fs::File::open(fmu).ok()?;
    let mut zip = zip::ZipArchive::new(io::BufReader::new(file)).ok()?;
    let mut entry = zip.by_name("modelDescription.xml").ok()?;
    let mut text = String::new();
    entry.read_to_string(&mut text).ok()?;
    Some(text)
}

/// [`unpack`] with an explicit limit on the bytes extracted.
pub fn unpack_limited(fmu: &Path, max_bytes: u64) -> Result<Unpacked, String> {
    unpack_with(fmu, max_bytes, None).map(|(u, _)| u)
}

fn unpack_with(
    fmu: &Path,
    max_bytes: u64,
    mut share: Option<(&Path, &mut SharedBinaries)>,
) -> Result<(Unpacked, bool), String> {
    let meta = fs::metadata(fmu).map_err(|e| match e.kind() {
        io::ErrorKind::NotFound => format!("{}: no such file", fmu.display()),
        _ => format!("{}: cannot access: {e}", fmu.display()),
    })?;
    if meta.is_dir() {
        if !fmu.join("modelDescription.xml").is_file() {
            return Err(format!(
                "{}: folder has no modelDescription.xml (not an extracted FMU)",
                fmu.display()
            ));
        }
        // Absolute, because the resource location passed to the FMU is a file:// URI.
        let root = fs::canonicalize(fmu)
            .map_err(|e| format!("{}: cannot resolve the path: {e}", fmu.display()))?;
        return Ok((
            Unpacked {
                _temp: None,
                root,
                zip_problems: Vec::new(),
            },
            false,
        ));
    }
    let file = fs::File::open(fmu).map_err(|e| format!("{}: cannot open: {e}", fmu.display()))?;
    let mut zip = zip::ZipArchive::new(io::BufReader::new(file)).map_err(|e| {
        format!(
            "{}: not an FMU: not a valid ZIP archive ({e})",
            fmu.display()
        )
    })?;
    refuse_duplicates(&mut zip, fmu)?;
    let temp = tempfile::Builder::new()
        .prefix("geardyn-fmu-")
        .tempdir()
        .map_err(|e| format!("cannot create a temporary folder: {e}"))?;
    let mut has_md = false;
    let mut written: u64 = 0;
    let mut zip_problems = Vec::new();
    let mut chunk = vec![0; COPY_CHUNK];
    let mut linked = false;
    for i in 0..zip.len() {
        let mut entry = zip
            .by_index(i)
            .map_err(|e| format!("{}: ZIP entry #{i}: {e}", fmu.display()))?;
        let raw_name = entry.name().map(|n| n.into_owned()).unwrap_or_default();
        if let Some(kind) = absolute_kind(&raw_name) {
            return Err(format!(
                "{}: ZIP entry \"{raw_name}\" has an absolute path ({kind}); FMI 2.0.5 §2.3 entries are relative to the archive's root",
                fmu.display()
            ));
        }
        if raw_name.contains('\\') {
            return Err(format!(
                "{}: ZIP entry \"{raw_name}\" uses a backslash; FMI 2.0.5 §2.3 requires '/' as separator",
                fmu.display()
            ));
        }
        if entry.encrypted() {
            return Err(format!(
                "{}: ZIP entry \"{raw_name}\" is encrypted; FMI 2.0.5 §2.3 forbids encryption",
                fmu.display()
            ));
        }
        // §2.3: "compression method ... must be either 8 (deflate), or 0 (store)".
        let method = entry.compression();
        if !matches!(
            method,
            zip::CompressionMethod::Stored | zip::CompressionMethod::Deflated
        ) {
            zip_problems.push(format!(
                "ZIP entry \"{raw_name}\" uses compression method {method:?}; FMI 2.0.5 §2.3 allows only deflate (8) and store (0)"
            ));
        }
        if entry.is_symlink() {
            return Err(format!(
                "{}: ZIP entry \"{raw_name}\" is a symbolic link; FMI 2.0.5 §2.3 forbids links",
                fmu.display()
            ));
        }
        let Some(rel) = entry.enclosed_name() else {
            return Err(format!(
                "{}: ZIP entry \"{raw_name}\" has an unsafe path (absolute or outside the archive)",
                fmu.display()
            ));
        };
        if rel == Path::new("modelDescription.xml") {
            has_md = true;
        }
        if NOT_EXTRACTED.iter().any(|folder| rel.starts_with(folder)) {
            continue;
        }
        let out = temp.path().join(&rel);
        if entry.is_dir() {
            fs::create_dir_all(&out)
                .map_err(|e| format!("{}: cannot create {}: {e}", fmu.display(), out.display()))?;
            continue;
        }
        if let Some(parent) = out.parent() {
            fs::create_dir_all(parent).map_err(|e| {
                format!("{}: cannot create {}: {e}", fmu.display(), parent.display())
            })?;
        }
        // The shared binary: linked where an identical one was extracted before (a failed
        // link, say across file systems, extracts it after all), else recorded once written.
        let mut record = None;
        if let Some((binary, shared)) = &share {
            if rel == *binary {
                let key = (entry.crc32(), entry.size());
                let earlier = shared.0.iter().find(|(c, s, _)| (*c, *s) == key);
                if earlier.is_some_and(|(_, _, file)| fs::hard_link(file, &out).is_ok()) {
                    linked = true;
                    continue;
                }
                record = Some(key);
            }
        }
        let mut f = fs::File::create(&out)
            .map_err(|e| format!("{}: cannot create {}: {e}", fmu.display(), out.display()))?;
        // Count actual bytes (the sizes in the ZIP headers can lie), stop one past the limit.
        let budget = max_bytes - written;
        let n =
            copy_through(&mut (&mut entry).take(budget + 1), &mut f, &mut chunk).map_err(|e| {
                format!(
                    "{}: cannot extract ZIP entry \"{raw_name}\": {e}",
                    fmu.display()
                )
            })?;
        if n > budget {
            return Err(format!(
                "{}: the archive expands to more than {max_bytes} bytes (at ZIP entry \"{raw_name}\"); refusing to unpack it",
                fmu.display()
            ));
        }
        written += n;
        if let (Some((crc, size)), Some((_, shared))) = (record, share.as_mut()) {
            shared.0.push((crc, size, out.clone()));
        }
        // Keep the executable bit of shared libraries (dlopen does not need it, but tools
        // that exec helper binaries from resources/ do).
        #[cfg(unix)]
        if let Some(mode) = entry.unix_mode() {
            use std::os::unix::fs::PermissionsExt;
            let _ = fs::set_permissions(&out, fs::Permissions::from_mode(mode & 0o755 | 0o600));
        }
    }
    if !has_md {
        return Err(format!(
            "{}: not an FMU: the ZIP archive has no modelDescription.xml at its top level",
            fmu.display()
        ));
    }
    let root = temp.path().to_path_buf();
    Ok((
        Unpacked {
            _temp: Some(temp),
            root,
            zip_problems,
        },
        linked,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    #[test]
    fn absolute_entry_names_are_recognised() {
        assert_eq!(absolute_kind("/etc/passwd"), Some("it starts at the root"));
        assert_eq!(
            absolute_kind("//server/share/x"),
            Some("a UNC network path")
        );
        assert_eq!(
            absolute_kind("\\\\server\\share"),
            Some("a UNC network path")
        );
        assert_eq!(absolute_kind("C:/x.dll"), Some("a drive letter"));
        assert_eq!(absolute_kind("c:x"), Some("a drive letter"));
        for relative in [
            "modelDescription.xml",
            "binaries/linux64/a.so",
            "resources/a:b",
            "1:x",
        ] {
            assert_eq!(absolute_kind(relative), None, "{relative}");
        }
    }

    #[test]
    fn expansion_limit_and_cleanup() {
        let dir = tempfile::tempdir().unwrap();
        let fmu = dir.path().join("big.fmu");
        let mut z = zip::ZipWriter::new(fs::File::create(&fmu).unwrap());
        let opts = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Deflated);
        z.start_file("modelDescription.xml", opts).unwrap();
        z.write_all(b"<x/>").unwrap();
        z.start_file("resources/zeros.bin", opts).unwrap();
        z.write_all(&vec![0u8; 100_000]).unwrap();
        z.start_file("documentation/index.html", opts).unwrap();
        z.write_all(b"<html/>").unwrap();
        z.start_file("sources/model.c", opts).unwrap();
        z.write_all(b"int x;").unwrap();
        z.finish().unwrap();
        let e = unpack_limited(&fmu, 50_000).err().unwrap();
        assert!(
            e.contains("expands to more than 50000 bytes") && e.contains("zeros.bin"),
            "{e}"
        );
        let u = unpack_limited(&fmu, 200_000).unwrap();
        let root = u.root().to_path_buf();
        assert!(root.join("resources/zeros.bin").is_file());
        // Checked, but not needed by any command: not written.
        assert!(!root.join("documentation").exists() && !root.join("sources").exists());
        drop(u);
        assert!(!root.exists(), "temporary folder not removed");
    }
}
