//! Issue 34, failing case 7: a zip with two `modelDescription.xml` entries was read with the
//! last one, without a word. The shipped spur_pair FMU with a second copy of its description
//! (the bytes of a same-length name patched in place) is refused by `geardyn validate` and
//! `geardyn run`, naming the ambiguity; nothing is run.

use std::io::{Read, Write};
use std::path::Path;
use std::process::Command;

#[test]
fn an_fmu_with_two_model_descriptions_is_refused() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("archive_duplicates");
    std::fs::create_dir_all(&dir).unwrap();
    let bin = env!("CARGO_BIN_EXE_geardyn");
    let built = Command::new(bin)
        .args(["fmu", "build"])
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("fmu/spur_pair"))
        .arg("--out")
        .arg(&dir)
        .output()
        .unwrap();
    assert!(built.status.success(), "{built:?}");
    // Copy every entry and add the description again under a name of the same length.
    let mut src =
        zip::ZipArchive::new(std::fs::File::open(dir.join("spur_pair.fmu")).unwrap()).unwrap();
    let patched = dir.join("twice.fmu");
    {
        let mut out = zip::ZipWriter::new(std::fs::File::create(&patched).unwrap());
        let options = zip::write::SimpleFileOptions::default();
        let mut description = Vec::new();
        for i in 0..src.len() {
            let mut entry = src.by_index(i).unwrap();
            let name = entry.name().unwrap().to_string();
            let mut data = Vec::new();
            entry.read_to_end(&mut data).unwrap();
            if name == "modelDescription.xml" {
                description = data.clone();
            }
            if entry.is_dir() {
                out.add_directory(name, options).unwrap();
            } else {
                out.start_file(name, options).unwrap();
                out.write_all(&data).unwrap();
            }
        }
        assert!(!description.is_empty());
        out.start_file("modelDescriptionXxml", options).unwrap();
        out.write_all(&description).unwrap();
        out.finish().unwrap();
    }
    let bytes = std::fs::read(&patched).unwrap();
    let from = b"modelDescriptionXxml";
    let mut patched_bytes = bytes.clone();
    let mut hits = 0;
    let mut i = 0;
    while i + from.len() <= patched_bytes.len() {
        if &patched_bytes[i..i + from.len()] == from {
            patched_bytes[i..i + from.len()].copy_from_slice(b"modelDescription.xml");
            hits += 1;
        }
        i += 1;
    }
    assert_eq!(hits, 2, "the local header and the central directory");
    std::fs::write(&patched, patched_bytes).unwrap();
    for args in [vec!["validate"], vec!["run"]] {
        let out = Command::new(bin)
            .args(&args)
            .arg(&patched)
            .args(if args[0] == "run" {
                vec!["--out", "-"]
            } else {
                vec![]
            })
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?}: {stderr}");
        assert!(
            stderr.contains("more than once") || stderr.contains("duplicate"),
            "{args:?}: {stderr}"
        );
    }
}
