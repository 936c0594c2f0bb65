//! Files the integration tests set up: a copy of a folder, the cdylib of this build.

#![allow(dead_code)]

use std::path::{Path, PathBuf};

/// Copies the folder `from` with everything in it to `to`.
pub fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let target = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &target);
        } else {
            std::fs::copy(e.path(), &target).unwrap();
        }
    }
}

/// The cdylib of this build: next to the test executable (`target/<profile>/deps`).
pub fn cdylib() -> PathBuf {
    let deps = std::env::current_exe()
        .unwrap()
        .parent()
        .unwrap()
        .to_path_buf();
    let so = deps.join("libgeardyn.so");
    assert!(so.is_file(), "{} not built", so.display());
    so
}
