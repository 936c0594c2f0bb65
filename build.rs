// Compiles the C shim that gives the FMI 2.0 host a variadic fmi2CallbackLogger
// (see src/host/logger_shim.c for why it must be C).
fn main() {
    println!("cargo:rerun-if-changed=src/host/logger_shim.c");
    cc::Build::new()
        .file("src/host/logger_shim.c")
        .warnings(true)
        .compile("geardyn_host_logger_shim");
}
