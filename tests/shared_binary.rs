//! One loaded copy of a binary that several FMUs share (`<SharedBinary/>`, docs/fmu.md "One
//! binary for several FMUs"): `archive::unpack_sharing` links a binary whose ZIP entry has the
//! CRC-32 and size of one unpacked before, and extracts one that differs by a byte; the
//! linked file loads as the library already loaded (the same code), a copy as a second one.

use std::io::Write;
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};

#[path = "common/files.rs"]
mod files;

use files::{cdylib, copy_dir};
use geardyn::host::archive::{unpack_sharing, SharedBinaries};
use geardyn::host::library::FmuLibrary;

/// An FMU archive whose binary `binaries/linux64/m.so` is the cdylib with `extra` bytes
/// appended (an ELF file loads with bytes after its sections).
fn archive(dir: &Path, name: &str, extra: &[u8]) -> PathBuf {
    let path = dir.join(format!("{name}.fmu"));
    let mut zip = zip::ZipWriter::new(std::fs::File::create(&path).unwrap());
    let opts = zip::write::SimpleFileOptions::default();
    zip.start_file("modelDescription.xml", opts).unwrap();
    zip.write_all(b"<fmiModelDescription/>").unwrap();
    zip.start_file("binaries/linux64/m.so", opts).unwrap();
    let mut bytes = std::fs::read(cdylib()).unwrap();
    bytes.extend_from_slice(extra);
    zip.write_all(&bytes).unwrap();
    zip.finish().unwrap();
    path
}

#[test]
fn identical_binaries_are_one_file_and_one_loaded_copy() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b, c) = (
        archive(dir.path(), "a", b""),
        archive(dir.path(), "b", b""),
        archive(dir.path(), "c", b"\0"),
    );
    let mut shared = SharedBinaries::default();
    let binary = "binaries/linux64/m.so";
    let (ua, linked_a) = unpack_sharing(&a, binary, &mut shared).unwrap();
    let (ub, linked_b) = unpack_sharing(&b, binary, &mut shared).unwrap();
    let (uc, linked_c) = unpack_sharing(&c, binary, &mut shared).unwrap();
    assert_eq!((linked_a, linked_b, linked_c), (false, true, false));
    let inode = |root: &Path| std::fs::metadata(root.join(binary)).unwrap().ino();
    assert_eq!(inode(ub.root()), inode(ua.root()));
    assert_ne!(inode(uc.root()), inode(ua.root()));
    // Every entry is there in every FMU.
    for u in [&ua, &ub, &uc] {
        assert!(u.root().join("modelDescription.xml").is_file());
    }
    let load = |root: &Path| FmuLibrary::load(root, "m").unwrap();
    let (la, lb, lc) = (load(ua.root()), load(ub.root()), load(uc.root()));
    // The linked binary is the library already loaded: the same code at the same address.
    assert_eq!(lb.fns.do_step as usize, la.fns.do_step as usize);
    // A different binary is a second copy (the oracle that the address above is shared
    // because the file is).
    assert_ne!(lc.fns.do_step as usize, la.fns.do_step as usize);
}

/// The five-FMU drivetrain (`examples/systems/drivetrain`, every FMU a geardyn FMU) loads one
/// copy of the binary for all five, says so at `--log-level all`, and its rows and step
/// sequence are byte for byte those of five copies (`--no-shared-binaries`).
#[test]
fn the_drivetrain_shares_one_binary_and_gives_the_bytes_of_five() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let root = Path::new(env!("CARGO_TARGET_TMPDIR")).join("shared_binary");
    let _ = std::fs::remove_dir_all(&root);
    copy_dir(&repo.join("fmu"), &root.join("fmu"));
    copy_dir(
        &repo.join("examples/systems/drivetrain"),
        &root.join("examples/systems/drivetrain"),
    );
    let run = |out: &str, extra: &[&str]| {
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_geardyn"))
            .args(["run", "examples/systems/drivetrain", "--stop-time", "0.004"])
            .args([
                "--output-interval",
                "2.631578947368421e-05",
                "--tolerance",
                "1e-4",
            ])
            .args(["--log-level", "all", "--out", out])
            .args(extra)
            .current_dir(&root)
            .output()
            .unwrap();
        let e = String::from_utf8_lossy(&o.stderr).into_owned();
        assert!(o.status.success(), "{e}");
        let read = |p: String| std::fs::read(root.join(p)).unwrap();
        (read(out.to_string()), read(format!("{out}.steps.csv")), e)
    };
    let (rows, steps, log) = run("shared.csv", &[]);
    let (rows_apart, steps_apart, log_apart) = run("apart.csv", &["--no-shared-binaries"]);
    let note = log
        .lines()
        .find(|l| l.contains("load the identical binary"))
        .unwrap_or_else(|| panic!("no note of the shared binary:\n{log}"));
    for fmu in ["shaft_in", "spur_stage", "shaft_out", "vehicle_load"] {
        assert!(note.contains(&format!("{fmu}.fmu")), "{note}");
    }
    assert!(
        !note.contains("emotor.fmu"),
        "the first loads its own: {note}"
    );
    assert!(!log_apart.contains("load the identical binary"));
    assert!(rows == rows_apart, "the rows differ");
    assert!(steps == steps_apart, "the step sequences differ");
}
