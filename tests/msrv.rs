//! The minimum Rust version the project states (`rust-version` in Cargo.toml, the README's
//! "Needs a Rust toolchain (X+)") is the largest `rust-version` among the locked dependencies:
//! a claim lower than that cannot build (issue 19: the README said 1.82 while nalgebra 0.35,
//! wide and safe_arch need 1.89).

use std::process::Command;

/// `1.89` or `1.88.0` as comparable numbers (missing parts are 0).
fn version(text: &str) -> (u32, u32, u32) {
    let mut parts = text.split('.').map(|p| p.parse::<u32>().unwrap_or(0));
    (
        parts.next().unwrap_or(0),
        parts.next().unwrap_or(0),
        parts.next().unwrap_or(0),
    )
}

/// Every `"rust_version":"X"` of `cargo metadata`'s JSON, with the package name before it.
fn dependency_versions(json: &str) -> Vec<(String, (u32, u32, u32))> {
    let mut found = Vec::new();
    for package in json.split("{\"name\":\"").skip(1) {
        let name = package.split('"').next().unwrap_or("").to_string();
        if let Some(rest) = package.split("\"rust_version\":\"").nth(1) {
            if let Some(v) = rest.split('"').next() {
                found.push((name, version(v)));
            }
        }
    }
    found
}

#[test]
fn stated_minimum_rust_version_is_what_the_locked_dependencies_need() {
    let root = env!("CARGO_MANIFEST_DIR");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    // Only the host's dependencies: a clean checkout has fetched those (building), not the
    // wasm-only ones some crates declare (plotters → web-sys), which `--offline` cannot get.
    let rustc = Command::new("rustc")
        .arg("-vV")
        .output()
        .expect("rustc -vV");
    let host = String::from_utf8_lossy(&rustc.stdout)
        .lines()
        .find_map(|l| l.strip_prefix("host: ").map(str::to_owned))
        .expect("rustc -vV names the host");
    let out = Command::new(cargo)
        .args(["metadata", "--format-version", "1", "--locked", "--offline"])
        .args(["--filter-platform", &host])
        .current_dir(root)
        .output()
        .expect("cargo metadata runs");
    assert!(
        out.status.success(),
        "cargo metadata: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json = String::from_utf8(out.stdout).expect("utf-8");
    // The project's own packages state the claim under test; only dependencies decide it.
    let deps: Vec<_> = dependency_versions(&json)
        .into_iter()
        .filter(|(name, _)| !name.starts_with("geardyn"))
        .collect();
    assert!(deps.len() > 10, "rust_version fields found: {deps:?}");
    let (needing, needed) = deps
        .iter()
        .max_by_key(|(_, v)| *v)
        .cloned()
        .expect("some dependency states a rust-version");

    let manifest = std::fs::read_to_string(format!("{root}/Cargo.toml")).unwrap();
    let stated = manifest
        .lines()
        .find_map(|l| l.strip_prefix("rust-version = \""))
        .and_then(|l| l.strip_suffix('"'))
        .expect("Cargo.toml states rust-version");
    assert_eq!(
        version(stated),
        needed,
        "Cargo.toml rust-version {stated}: the locked {needing} needs {needed:?}"
    );
    let readme = std::fs::read_to_string(format!("{root}/README.md")).unwrap();
    assert!(
        readme.contains(&format!("Rust toolchain ({stated}+)")),
        "README does not state 'Rust toolchain ({stated}+)'"
    );
}
