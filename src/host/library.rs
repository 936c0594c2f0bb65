//! Loading `binaries/linux64/<modelIdentifier>.so` and resolving the FMI 2.0 Co-Simulation
//! functions (FMI 2.0.5 §2.3: "all functions specified for ... Co-Simulation are present,
//! even if they are only needed for capabilities that the FMU does not support").
//!
//! All 34 symbols are resolved at load time, as fmpy and FMIL-based hosts do, so a missing
//! one is reported up front (naming every missing function) instead of at first use.

use libloading::Library;
use std::ffi::{c_char, c_int, c_void, CStr};
use std::path::{Path, PathBuf};

/// `fmi2Component`.
pub type Component = *mut c_void;
/// `fmi2FMUstate`.
pub type FmuState = *mut c_void;
type VrPtr = *const u32;

/// `fmi2Status` (fmi2FunctionTypes.h). Ordered by severity.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Status {
    Ok,
    Warning,
    Discard,
    Error,
    Fatal,
    Pending,
    /// A value outside the enum (a broken FMU); treated as worse than Fatal.
    Invalid(i32),
}

impl Status {
    pub fn from_raw(v: c_int) -> Status {
        match v {
            0 => Status::Ok,
            1 => Status::Warning,
            2 => Status::Discard,
            3 => Status::Error,
            4 => Status::Fatal,
            5 => Status::Pending,
            x => Status::Invalid(x),
        }
    }

    /// Parse a `--log-level` value.
    pub fn parse_level(s: &str) -> Option<Status> {
        Some(match s.to_ascii_lowercase().as_str() {
            "ok" | "all" | "debug" | "info" => Status::Ok,
            "warning" => Status::Warning,
            "discard" => Status::Discard,
            "error" => Status::Error,
            "fatal" => Status::Fatal,
            _ => return None,
        })
    }
}

impl std::fmt::Display for Status {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Status::Ok => f.write_str("fmi2OK"),
            Status::Warning => f.write_str("fmi2Warning"),
            Status::Discard => f.write_str("fmi2Discard"),
            Status::Error => f.write_str("fmi2Error"),
            Status::Fatal => f.write_str("fmi2Fatal"),
            Status::Pending => f.write_str("fmi2Pending"),
            Status::Invalid(x) => write!(f, "invalid status {x}"),
        }
    }
}

/// `fmi2CallbackFunctions` (FMI 2.0.5 §2.1.5). The FMU copies it in fmi2Instantiate.
#[repr(C)]
pub struct CallbackFunctions {
    pub logger: Option<
        unsafe extern "C" fn(*mut c_void, *const c_char, c_int, *const c_char, *const c_char, ...),
    >,
    pub allocate_memory: Option<unsafe extern "C" fn(usize, usize) -> *mut c_void>,
    pub free_memory: Option<unsafe extern "C" fn(*mut c_void)>,
    pub step_finished: Option<unsafe extern "C" fn(*mut c_void, c_int)>,
    pub component_environment: *mut c_void,
}

extern "C" {
    // libc, for fmi2CallbackAllocateMemory/FreeMemory (an FMU without
    // canNotUseMemoryManagementFunctions may rely on them).
    pub fn calloc(n: usize, size: usize) -> *mut c_void;
    pub fn free(p: *mut c_void);
}

macro_rules! fmi2_functions {
    ($($field:ident = $sym:literal : fn($($arg:ty),*) $(-> $ret:ty)?;)*) => {
        /// The 34 FMI 2.0 CS entry points of one loaded library.
        #[derive(Clone, Copy)]
        pub struct Functions {
            $(pub $field: unsafe extern "C" fn($($arg),*) $(-> $ret)?,)*
        }

        /// Names of all functions a CS FMU must export, in the order of fmi2Functions.h.
        pub const FUNCTION_NAMES: &[&str] = &[$($sym),*];

        impl Functions {
            /// Resolve every symbol; on failure, name all missing ones.
            ///
            /// # Safety
            /// The library must export these symbols with the FMI 2.0 signatures.
            unsafe fn resolve(lib: &Library, so: &Path) -> Result<Functions, String> {
                let mut missing: Vec<&str> = Vec::new();
                $(
                    let $field = match unsafe {
                        lib.get::<unsafe extern "C" fn($($arg),*) $(-> $ret)?>($sym)
                    } {
                        Ok(s) => Some(*s),
                        Err(_) => { missing.push($sym); None }
                    };
                )*
                match ($($field,)*) {
                    ($(Some($field),)*) => Ok(Functions { $($field,)* }),
                    _ => Err(format!(
                        "{}: the library does not export the FMI 2.0 function{} {} (all 34 Co-Simulation functions are required, FMI 2.0.5 §2.3)",
                        so.display(),
                        if missing.len() == 1 { "" } else { "s" },
                        missing.join(", ")
                    )),
                }
            }
        }
    };
}

fmi2_functions! {
    get_types_platform = "fmi2GetTypesPlatform": fn() -> *const c_char;
    get_version = "fmi2GetVersion": fn() -> *const c_char;
    set_debug_logging = "fmi2SetDebugLogging": fn(Component, c_int, usize, *const *const c_char) -> c_int;
    instantiate = "fmi2Instantiate": fn(*const c_char, c_int, *const c_char, *const c_char, *const CallbackFunctions, c_int, c_int) -> Component;
    free_instance = "fmi2FreeInstance": fn(Component);
    setup_experiment = "fmi2SetupExperiment": fn(Component, c_int, f64, f64, c_int, f64) -> c_int;
    enter_initialization_mode = "fmi2EnterInitializationMode": fn(Component) -> c_int;
    exit_initialization_mode = "fmi2ExitInitializationMode": fn(Component) -> c_int;
    terminate = "fmi2Terminate": fn(Component) -> c_int;
    reset = "fmi2Reset": fn(Component) -> c_int;
    get_real = "fmi2GetReal": fn(Component, VrPtr, usize, *mut f64) -> c_int;
    get_integer = "fmi2GetInteger": fn(Component, VrPtr, usize, *mut c_int) -> c_int;
    get_boolean = "fmi2GetBoolean": fn(Component, VrPtr, usize, *mut c_int) -> c_int;
    get_string = "fmi2GetString": fn(Component, VrPtr, usize, *mut *const c_char) -> c_int;
    set_real = "fmi2SetReal": fn(Component, VrPtr, usize, *const f64) -> c_int;
    set_integer = "fmi2SetInteger": fn(Component, VrPtr, usize, *const c_int) -> c_int;
    set_boolean = "fmi2SetBoolean": fn(Component, VrPtr, usize, *const c_int) -> c_int;
    set_string = "fmi2SetString": fn(Component, VrPtr, usize, *const *const c_char) -> c_int;
    get_fmu_state = "fmi2GetFMUstate": fn(Component, *mut FmuState) -> c_int;
    set_fmu_state = "fmi2SetFMUstate": fn(Component, FmuState) -> c_int;
    free_fmu_state = "fmi2FreeFMUstate": fn(Component, *mut FmuState) -> c_int;
    serialized_fmu_state_size = "fmi2SerializedFMUstateSize": fn(Component, FmuState, *mut usize) -> c_int;
    serialize_fmu_state = "fmi2SerializeFMUstate": fn(Component, FmuState, *mut c_char, usize) -> c_int;
    de_serialize_fmu_state = "fmi2DeSerializeFMUstate": fn(Component, *const c_char, usize, *mut FmuState) -> c_int;
    get_directional_derivative = "fmi2GetDirectionalDerivative": fn(Component, VrPtr, usize, VrPtr, usize, *const f64, *mut f64) -> c_int;
    set_real_input_derivatives = "fmi2SetRealInputDerivatives": fn(Component, VrPtr, usize, *const c_int, *const f64) -> c_int;
    get_real_output_derivatives = "fmi2GetRealOutputDerivatives": fn(Component, VrPtr, usize, *const c_int, *mut f64) -> c_int;
    do_step = "fmi2DoStep": fn(Component, f64, f64, c_int) -> c_int;
    cancel_step = "fmi2CancelStep": fn(Component) -> c_int;
    get_status = "fmi2GetStatus": fn(Component, c_int, *mut c_int) -> c_int;
    get_real_status = "fmi2GetRealStatus": fn(Component, c_int, *mut f64) -> c_int;
    get_integer_status = "fmi2GetIntegerStatus": fn(Component, c_int, *mut c_int) -> c_int;
    get_boolean_status = "fmi2GetBooleanStatus": fn(Component, c_int, *mut c_int) -> c_int;
    get_string_status = "fmi2GetStringStatus": fn(Component, c_int, *mut *const c_char) -> c_int;
}

/// One of the FMI 2.0 CS functions, as its index in [`FUNCTION_NAMES`]: a number that the
/// process running an FMU can write to shared memory before each call, and its supervising
/// parent can name after a crash ([`super::supervise::Activity`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FmiFunction(u32);

impl FmiFunction {
    /// The function called `name`; meant for constants, where an unknown name fails the build.
    pub const fn named(name: &str) -> FmiFunction {
        let mut i = 0;
        while i < FUNCTION_NAMES.len() {
            let (a, b) = (FUNCTION_NAMES[i].as_bytes(), name.as_bytes());
            if a.len() == b.len() {
                let mut k = 0;
                while k < a.len() && a[k] == b[k] {
                    k += 1;
                }
                if k == a.len() {
                    return FmiFunction(i as u32);
                }
            }
            i += 1;
        }
        panic!("not an FMI 2.0 Co-Simulation function name")
    }

    pub fn from_index(index: u32) -> Option<FmiFunction> {
        ((index as usize) < FUNCTION_NAMES.len()).then_some(FmiFunction(index))
    }

    pub fn index(self) -> u32 {
        self.0
    }

    pub fn name(self) -> &'static str {
        FUNCTION_NAMES[self.0 as usize]
    }
}

/// libloading's `Display` says only "dlopen failed"; the reason (`undefined symbol: …`,
/// `wrong ELF class`, …) is in its source.
fn describe(e: &libloading::Error) -> String {
    match std::error::Error::source(e) {
        Some(s) => format!("{e}: {s}"),
        None => e.to_string(),
    }
}

/// Load shared libraries into the global symbol namespace (`RTLD_NOW | RTLD_GLOBAL`) before
/// the FMU, for FMUs with `needsExecutionTool="true"` (FMI 2.0.5 §4.3.1) whose binary expects
/// the tool's symbols to be present in the host process: a PythonFMU, for instance, resolves
/// the CPython API from the process, so it needs `libpython3.X.so` loaded first.
///
/// The libraries are never unloaded: an embedded interpreter may have registered exit
/// handlers that live in them.
pub fn preload(paths: &[PathBuf]) -> Result<(), String> {
    use libloading::os::unix::{Library as UnixLibrary, RTLD_GLOBAL, RTLD_NOW};
    for p in paths {
        // SAFETY: loading a library runs its initialisers; the user asked for this library.
        let lib = unsafe { UnixLibrary::open(Some(p), RTLD_NOW | RTLD_GLOBAL) }
            .map_err(|e| format!("--preload {}: cannot load: {}", p.display(), describe(&e)))?;
        std::mem::forget(lib);
    }
    Ok(())
}

/// A loaded FMU library with its resolved function table. The function pointers are only
/// valid while this value (which owns the `dlopen` handle) is alive.
pub struct FmuLibrary {
    pub fns: Functions,
    pub path: PathBuf,
    _lib: Library,
}

/// The FMI 2.0 platform folder for this host (FMI 2.0.5 §2.3: win32, win64, linux32, linux64,
/// darwin64).
pub const PLATFORM: &str = "linux64";

/// Path of the shared library inside an extracted FMU.
pub fn library_path(root: &Path, model_identifier: &str) -> PathBuf {
    root.join("binaries")
        .join(PLATFORM)
        .join(format!("{model_identifier}.so"))
}

impl FmuLibrary {
    /// Load `binaries/linux64/<model_identifier>.so` from an extracted FMU and resolve all
    /// 34 functions; check that `fmi2GetVersion()` is "2.0" and `fmi2GetTypesPlatform()` is
    /// "default" (FMI 2.0.5 §2.1.4).
    pub fn load(root: &Path, model_identifier: &str) -> Result<FmuLibrary, String> {
        let path = library_path(root, model_identifier);
        if !path.is_file() {
            let bin = root.join("binaries");
            let platforms: Vec<String> = std::fs::read_dir(&bin)
                .map(|rd| {
                    let mut v: Vec<String> = rd
                        .filter_map(|e| e.ok())
                        .map(|e| e.file_name().to_string_lossy().into_owned())
                        .collect();
                    v.sort();
                    v
                })
                .unwrap_or_default();
            let have = if platforms.is_empty() {
                "the FMU has no binaries at all (a source-only FMU cannot be run)".to_string()
            } else {
                format!("the FMU has binaries for: {}", platforms.join(", "))
            };
            let linux = bin.join(PLATFORM);
            let detail = match std::fs::read_dir(&linux) {
                Ok(rd) => {
                    let files: Vec<String> = rd
                        .filter_map(|e| e.ok())
                        .map(|e| e.file_name().to_string_lossy().into_owned())
                        .collect();
                    format!("; binaries/{PLATFORM}/ holds: {}", files.join(", "))
                }
                Err(_) => String::new(),
            };
            return Err(format!(
                "no {PLATFORM} binary: binaries/{PLATFORM}/{model_identifier}.so does not exist ({have}{detail})"
            ));
        }
        // SAFETY: loading a shared library runs its initialisers; that is inherent in running
        // an FMU. RTLD_LOCAL (libloading's default) keeps its fmi2* symbols out of the global
        // namespace, so several FMUs can be loaded side by side.
        let lib = unsafe { Library::new(&path) }.map_err(|e| {
            format!(
                "binaries/{PLATFORM}/{model_identifier}.so: cannot load the library: {}",
                describe(&e)
            )
        })?;
        // SAFETY: symbols are FMI 2.0 functions with the signatures of fmi2FunctionTypes.h.
        let fns = unsafe { Functions::resolve(&lib, &path) }?;
        let cstr = |p: *const c_char| {
            if p.is_null() {
                "(null)".to_string()
            } else {
                // SAFETY: FMI 2.0 returns static NUL-terminated strings here.
                unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
            }
        };
        // SAFETY: both take no arguments and return a static string.
        let version = cstr(unsafe { (fns.get_version)() });
        if version != "2.0" {
            return Err(format!(
                "{}: fmi2GetVersion() returned \"{version}\", expected \"2.0\"",
                path.display()
            ));
        }
        let platform = cstr(unsafe { (fns.get_types_platform)() });
        if platform != "default" {
            return Err(format!(
                "{}: fmi2GetTypesPlatform() returned \"{platform}\", expected \"default\"",
                path.display()
            ));
        }
        Ok(FmuLibrary {
            fns,
            path,
            _lib: lib,
        })
    }
}
