use std::path::PathBuf;

fn main() {
    logger_shim();
    cdylib_for_the_binary();
}

// Compiles the C shim that gives the FMI 2.0 host a variadic fmi2CallbackLogger
// (see src/host/logger_shim.c for why it must be C).
fn logger_shim() {
    println!("cargo:rerun-if-changed=src/host/logger_shim.c");
    cc::Build::new()
        .file("src/host/logger_shim.c")
        .warnings(true)
        .compile("geardyn_host_logger_shim");
}

// The release `geardyn` binary carries this crate's cdylib, the FMU binary, so that a binary
// installed alone (`cargo install --path .` copies only the executable) still builds FMUs
// (src/fmi/package.rs, `find_cdylib`). The library unit writes `<profile>/deps/libgeardyn.so`
// before the binary compiles: a binary links, so cargo starts it only after its library has
// finished, all crate types included. `cargo check` and clippy write no cdylib; for them an
// empty placeholder keeps `include_bytes!` compiling (empty means "not embedded").
fn cdylib_for_the_binary() {
    println!("cargo::rustc-check-cfg=cfg(geardyn_embedded_cdylib)");
    let release = std::env::var("PROFILE").as_deref() == Ok("release");
    let linux = std::env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("linux");
    if !(release && linux) {
        return;
    }
    // OUT_DIR is <target>/[<triple>/]<profile>/build/geardyn-<hash>/out.
    let out = PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    let Some(profile_dir) = out.ancestors().nth(3) else {
        return;
    };
    let lib = profile_dir.join("deps").join("libgeardyn.so");
    if !lib.exists() {
        std::fs::create_dir_all(lib.parent().unwrap()).expect("create the deps folder");
        std::fs::write(&lib, []).expect("write the cdylib placeholder");
    }
    println!("cargo:rustc-cfg=geardyn_embedded_cdylib");
    println!("cargo:rustc-env=GEARDYN_EMBEDDED_CDYLIB={}", lib.display());
}
