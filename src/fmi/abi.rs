//! The 34 functions a Co-Simulation FMU exports (FMI 2.0.x §2.1 common API, §4.2 CS API),
//! without prefix as required for a binary FMU (§2.1.1, §2.3).
//!
//! Each function is thin: validate the raw pointers (NULL arrays with `nvr > 0`, NULL
//! outputs, unknown instance), run the body under `catch_unwind` so that no panic crosses
//! the C boundary (a panic becomes `fmi2Fatal` plus a log line), and dispatch to
//! [`Instance`]. No global state: everything lives behind the `fmi2Component` pointer.

use std::any::Any;
use std::ffi::{c_char, c_int, c_void, CStr, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;

use super::blob;
use super::instance::{Instance, StateBox, StatusAnswer, INSTANCE_MAGIC, STATE_MAGIC};
use super::logger::{CallbackFunctions, Logger, Status};
use super::model::validate_variables;
use super::state::Call;

type Component = *mut c_void;
type FmuStatePtr = *mut c_void;
type ValueReference = u32;

const CO_SIMULATION: c_int = 1;

/// Largest `nvr` for which a slice of 8-byte elements stays below `isize::MAX` bytes.
const MAX_N: usize = (isize::MAX as usize) / 8;

fn panic_message(p: &(dyn Any + Send)) -> String {
    if let Some(s) = p.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = p.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown panic payload".into()
    }
}

/// The instance behind `c`, or `None` for NULL or a pointer that is not a live instance of
/// ours (checked through the magic word; best effort against stale pointers).
///
/// # Safety
/// `c` must be NULL or a pointer returned by `fmi2Instantiate` (possibly freed already).
unsafe fn instance<'a>(c: Component) -> Option<&'a mut Instance> {
    if c.is_null() || !(c as usize).is_multiple_of(std::mem::align_of::<Instance>()) {
        return None;
    }
    let inst = &mut *(c as *mut Instance);
    (inst.magic == INSTANCE_MAGIC).then_some(inst)
}

/// Runs `body` for the instance `c` with panics contained.
fn guarded(c: Component, call: Call, body: impl FnOnce(&mut Instance) -> Status) -> Status {
    // SAFETY: see `instance`.
    let Some(inst) = (unsafe { instance(c) }) else {
        return Status::Error;
    };
    match catch_unwind(AssertUnwindSafe(|| body(inst))) {
        Ok(s) => s,
        Err(p) => {
            let msg = panic_message(&*p);
            // Logging itself must not unwind out of here either.
            let _ = catch_unwind(AssertUnwindSafe(|| {
                // SAFETY: the borrow from the closure has ended.
                if let Some(inst) = unsafe { instance(c) } {
                    inst.fatal(call, &msg);
                }
            }));
            Status::Fatal
        }
    }
}

/// `(ptr, n)` as a slice; `n == 0` never touches `ptr` (it may be NULL).
///
/// # Safety
/// If `n > 0` and `ptr` is non-NULL, `ptr` must point to `n` valid elements.
unsafe fn slice<'a, T>(ptr: *const T, n: usize) -> Option<&'a [T]> {
    if n == 0 {
        Some(&[])
    } else if ptr.is_null() || n > MAX_N {
        None
    } else {
        Some(std::slice::from_raw_parts(ptr, n))
    }
}

/// # Safety
/// As [`slice`], for writing.
unsafe fn slice_mut<'a, T>(ptr: *mut T, n: usize) -> Option<&'a mut [T]> {
    if n == 0 {
        Some(&mut [])
    } else if ptr.is_null() || n > MAX_N {
        None
    } else {
        Some(std::slice::from_raw_parts_mut(ptr, n))
    }
}

fn null_arg(inst: &mut Instance, call: Call, what: &str, n: usize) -> Status {
    inst.error(
        call,
        format!("{what} is NULL (or nvr = {n} is impossibly large) with nvr = {n} > 0"),
    )
}

/// Shared body of the getters/setters: pointer checks, then dispatch.
macro_rules! array_call {
    ($c:expr, $call:expr, $vr:expr, $nvr:expr, $val:expr, $slice:ident, |$inst:ident, $vrs:ident, $vals:ident| $body:expr) => {
        guarded($c, $call, |$inst| {
            // SAFETY: the host promises `nvr` elements behind non-NULL arrays (§2.1.7).
            let Some($vrs) = (unsafe { slice($vr, $nvr) }) else {
                return null_arg($inst, $call, "vr[]", $nvr);
            };
            let Some($vals) = (unsafe { $slice($val, $nvr) }) else {
                return null_arg($inst, $call, "value[]", $nvr);
            };
            $body
        })
    };
}

// ---------------------------------------------------------------------------------------
// Inquire platform and version (§2.1.4)
// ---------------------------------------------------------------------------------------

/// `fmi2GetTypesPlatform` (§2.1.4): the default types header is used.
#[no_mangle]
pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
    c"default".as_ptr()
}

/// `fmi2GetVersion` (§2.1.4).
#[no_mangle]
pub extern "C" fn fmi2GetVersion() -> *const c_char {
    c"2.0".as_ptr()
}

/// `fmi2SetDebugLogging` (§2.1.5).
///
/// # Safety
/// Pointers as in the FMI standard.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetDebugLogging(
    c: Component,
    logging_on: c_int,
    n_categories: usize,
    categories: *const *const c_char,
) -> Status {
    let call = Call::SetDebugLogging;
    guarded(c, call, |inst| {
        // SAFETY: the host promises `n_categories` strings behind a non-NULL array.
        let Some(ptrs) = (unsafe { slice(categories, n_categories) }) else {
            return null_arg(inst, call, "categories[]", n_categories);
        };
        let mut names = Vec::with_capacity(ptrs.len());
        for (i, p) in ptrs.iter().enumerate() {
            if p.is_null() {
                return inst.error(call, format!("categories[{i}] is NULL"));
            }
            // SAFETY: non-NULL, NUL-terminated per the standard.
            names.push(unsafe { CStr::from_ptr(*p) }.to_string_lossy().into_owned());
        }
        inst.set_debug_logging(logging_on != 0, &names)
    })
}

// ---------------------------------------------------------------------------------------
// Creation and destruction (§2.1.5)
// ---------------------------------------------------------------------------------------

/// `fmi2Instantiate` (§2.1.5): builds the model from `<resources>/scene.toml` through the
/// crate's single factory [`crate::fmu::entry::instantiate`] and checks the GUID. Returns
/// NULL (with a log line) on any failure.
///
/// # Safety
/// Pointers as in the FMI standard; `functions` is only read during this call.
#[no_mangle]
pub unsafe extern "C" fn fmi2Instantiate(
    instance_name: *const c_char,
    fmu_type: c_int,
    fmu_guid: *const c_char,
    fmu_resource_location: *const c_char,
    functions: *const CallbackFunctions,
    _visible: c_int,
    logging_on: c_int,
) -> Component {
    let r = catch_unwind(AssertUnwindSafe(|| {
        if functions.is_null() {
            return std::ptr::null_mut();
        }
        // Copy by value: the struct is only valid during this call (§2.1.5, 2.0.x).
        let callbacks = unsafe { *functions };
        let name = if instance_name.is_null() {
            CString::new("(null instanceName)").unwrap_or_default()
        } else {
            unsafe { CStr::from_ptr(instance_name) }.to_owned()
        };
        let logger = Logger::new(callbacks, name, logging_on != 0);
        match instantiate_inner(instance_name, fmu_type, fmu_guid, fmu_resource_location) {
            Ok((model, info)) => {
                let inst = Box::new(Instance::new(logger, model, info));
                Box::into_raw(inst) as Component
            }
            Err(e) => {
                logger.log(Status::Error, &format!("fmi2Instantiate: {e}"));
                std::ptr::null_mut()
            }
        }
    }));
    r.unwrap_or(std::ptr::null_mut())
}

type Built = (Box<dyn super::model::CoSimModel>, super::model::ModelInfo);

unsafe fn instantiate_inner(
    instance_name: *const c_char,
    fmu_type: c_int,
    fmu_guid: *const c_char,
    resource_location: *const c_char,
) -> Result<Built, String> {
    if instance_name.is_null() {
        return Err("instanceName is NULL".into());
    }
    if fmu_type != CO_SIMULATION {
        return Err(format!(
            "fmuType = {fmu_type}: this FMU only supports Co-Simulation (fmi2CoSimulation = 1)"
        ));
    }
    if fmu_guid.is_null() {
        return Err("fmuGUID is NULL".into());
    }
    if resource_location.is_null() {
        return Err("fmuResourceLocation is NULL".into());
    }
    let guid = CStr::from_ptr(fmu_guid).to_string_lossy().into_owned();
    let uri = CStr::from_ptr(resource_location)
        .to_string_lossy()
        .into_owned();
    let dir: PathBuf = super::uri::file_uri_to_path(&uri)
        .map_err(|e| format!("fmuResourceLocation '{uri}': {e}"))?;
    let loaded = crate::fmu::entry::instantiate(&dir)?;
    if loaded.info.guid != guid {
        return Err(format!(
            "fmuGUID '{guid}' does not match this binary and scene (expected '{}'): the modelDescription.xml was generated for another scene or geardyn version",
            loaded.info.guid
        ));
    }
    validate_variables(loaded.model.variables())?;
    Ok((loaded.model, loaded.info))
}

/// `fmi2FreeInstance` (§2.1.5): frees everything; NULL or an unknown pointer is a no-op.
///
/// # Safety
/// `c` must be NULL or a pointer from `fmi2Instantiate`.
#[no_mangle]
pub unsafe extern "C" fn fmi2FreeInstance(c: Component) {
    let _ = catch_unwind(AssertUnwindSafe(|| {
        if let Some(inst) = instance(c) {
            inst.magic = 0;
            drop(Box::from_raw(c as *mut Instance));
        }
    }));
}

// ---------------------------------------------------------------------------------------
// Initialization, termination, reset (§2.1.6)
// ---------------------------------------------------------------------------------------

/// `fmi2SetupExperiment` (§2.1.6).
///
/// # Safety
/// `c` as returned by `fmi2Instantiate`.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetupExperiment(
    c: Component,
    tolerance_defined: c_int,
    tolerance: f64,
    start_time: f64,
    stop_time_defined: c_int,
    stop_time: f64,
) -> Status {
    guarded(c, Call::SetupExperiment, |inst| {
        inst.trace(Call::SetupExperiment, || {
            format!("toleranceDefined={tolerance_defined}, tolerance={tolerance:?}, startTime={start_time:?}, stopTimeDefined={stop_time_defined}, stopTime={stop_time:?}")
        });
        inst.setup_experiment(
            (tolerance_defined != 0).then_some(tolerance),
            start_time,
            (stop_time_defined != 0).then_some(stop_time),
        )
    })
}

/// `fmi2EnterInitializationMode` (§2.1.6).
///
/// # Safety
/// `c` as returned by `fmi2Instantiate`.
#[no_mangle]
pub unsafe extern "C" fn fmi2EnterInitializationMode(c: Component) -> Status {
    guarded(c, Call::EnterInitializationMode, |i| {
        i.enter_initialization_mode()
    })
}

/// `fmi2ExitInitializationMode` (§2.1.6).
///
/// # Safety
/// `c` as returned by `fmi2Instantiate`.
#[no_mangle]
pub unsafe extern "C" fn fmi2ExitInitializationMode(c: Component) -> Status {
    guarded(c, Call::ExitInitializationMode, |i| {
        i.exit_initialization_mode()
    })
}

/// `fmi2Terminate` (§2.1.6).
///
/// # Safety
/// `c` as returned by `fmi2Instantiate`.
#[no_mangle]
pub unsafe extern "C" fn fmi2Terminate(c: Component) -> Status {
    guarded(c, Call::Terminate, |i| i.terminate())
}

/// `fmi2Reset` (§2.1.6).
///
/// # Safety
/// `c` as returned by `fmi2Instantiate`.
#[no_mangle]
pub unsafe extern "C" fn fmi2Reset(c: Component) -> Status {
    guarded(c, Call::Reset, |i| i.reset())
}

// ---------------------------------------------------------------------------------------
// Getting and setting variable values (§2.1.7)
// ---------------------------------------------------------------------------------------

/// `fmi2GetReal` (§2.1.7).
///
/// # Safety
/// Arrays of `nvr` elements (may be NULL when `nvr == 0`).
#[no_mangle]
pub unsafe extern "C" fn fmi2GetReal(
    c: Component,
    vr: *const ValueReference,
    nvr: usize,
    value: *mut f64,
) -> Status {
    array_call!(
        c,
        Call::GetReal,
        vr,
        nvr,
        value,
        slice_mut,
        |inst, vrs, vals| inst.get_real(vrs, vals)
    )
}

/// `fmi2GetInteger` (§2.1.7).
///
/// # Safety
/// Arrays of `nvr` elements (may be NULL when `nvr == 0`).
#[no_mangle]
pub unsafe extern "C" fn fmi2GetInteger(
    c: Component,
    vr: *const ValueReference,
    nvr: usize,
    value: *mut c_int,
) -> Status {
    array_call!(
        c,
        Call::GetInteger,
        vr,
        nvr,
        value,
        slice_mut,
        |inst, vrs, vals| inst.get_integer(vrs, vals)
    )
}

/// `fmi2GetBoolean` (§2.1.7).
///
/// # Safety
/// Arrays of `nvr` elements (may be NULL when `nvr == 0`).
#[no_mangle]
pub unsafe extern "C" fn fmi2GetBoolean(
    c: Component,
    vr: *const ValueReference,
    nvr: usize,
    value: *mut c_int,
) -> Status {
    array_call!(
        c,
        Call::GetBoolean,
        vr,
        nvr,
        value,
        slice_mut,
        |inst, vrs, vals| inst.get_boolean(vrs, vals)
    )
}

/// `fmi2GetString` (§2.1.7). The model has no String variables.
///
/// # Safety
/// Arrays of `nvr` elements (may be NULL when `nvr == 0`).
#[no_mangle]
pub unsafe extern "C" fn fmi2GetString(
    c: Component,
    vr: *const ValueReference,
    nvr: usize,
    value: *mut *const c_char,
) -> Status {
    array_call!(
        c,
        Call::GetString,
        vr,
        nvr,
        value,
        slice_mut,
        |inst, vrs, _vals| inst.no_strings(Call::GetString, vrs)
    )
}

/// `fmi2SetReal` (§2.1.7).
///
/// # Safety
/// Arrays of `nvr` elements (may be NULL when `nvr == 0`).
#[no_mangle]
pub unsafe extern "C" fn fmi2SetReal(
    c: Component,
    vr: *const ValueReference,
    nvr: usize,
    value: *const f64,
) -> Status {
    array_call!(
        c,
        Call::SetReal,
        vr,
        nvr,
        value,
        slice,
        |inst, vrs, vals| inst.set_real(vrs, vals)
    )
}

/// `fmi2SetInteger` (§2.1.7).
///
/// # Safety
/// Arrays of `nvr` elements (may be NULL when `nvr == 0`).
#[no_mangle]
pub unsafe extern "C" fn fmi2SetInteger(
    c: Component,
    vr: *const ValueReference,
    nvr: usize,
    value: *const c_int,
) -> Status {
    array_call!(
        c,
        Call::SetInteger,
        vr,
        nvr,
        value,
        slice,
        |inst, vrs, vals| inst.set_integer(vrs, vals)
    )
}

/// `fmi2SetBoolean` (§2.1.7).
///
/// # Safety
/// Arrays of `nvr` elements (may be NULL when `nvr == 0`).
#[no_mangle]
pub unsafe extern "C" fn fmi2SetBoolean(
    c: Component,
    vr: *const ValueReference,
    nvr: usize,
    value: *const c_int,
) -> Status {
    array_call!(
        c,
        Call::SetBoolean,
        vr,
        nvr,
        value,
        slice,
        |inst, vrs, vals| inst.set_boolean(vrs, vals)
    )
}

/// `fmi2SetString` (§2.1.7). The model has no String variables.
///
/// # Safety
/// Arrays of `nvr` elements (may be NULL when `nvr == 0`).
#[no_mangle]
pub unsafe extern "C" fn fmi2SetString(
    c: Component,
    vr: *const ValueReference,
    nvr: usize,
    value: *const *const c_char,
) -> Status {
    array_call!(
        c,
        Call::SetString,
        vr,
        nvr,
        value,
        slice,
        |inst, vrs, _vals| inst.no_strings(Call::SetString, vrs)
    )
}

// ---------------------------------------------------------------------------------------
// FMU state (§2.1.8)
// ---------------------------------------------------------------------------------------

/// # Safety
/// `s` NULL or a pointer we handed out.
unsafe fn state_box<'a>(s: FmuStatePtr) -> Option<&'a mut StateBox> {
    if s.is_null() || !(s as usize).is_multiple_of(std::mem::align_of::<StateBox>()) {
        return None;
    }
    let b = &mut *(s as *mut StateBox);
    (b.magic == STATE_MAGIC).then_some(b)
}

/// `fmi2GetFMUstate` (§2.1.8): a new state, or overwrite `*state` if it is non-NULL.
///
/// # Safety
/// `state` points to an `fmi2FMUstate` (NULL or ours).
#[no_mangle]
pub unsafe extern "C" fn fmi2GetFMUstate(c: Component, state: *mut FmuStatePtr) -> Status {
    let call = Call::GetFMUstate;
    guarded(c, call, |inst| {
        if state.is_null() {
            return inst.error(call, "FMUstate pointer is NULL");
        }
        let existing = unsafe { *state };
        if !existing.is_null() && unsafe { state_box(existing) }.is_none() {
            return inst.error(call, "*FMUstate is neither NULL nor a state of this FMU");
        }
        match unsafe { state_box(existing) } {
            // Overwritten in place: a master that saves a state before every step passes
            // the same object each time, so its buffer is reused.
            Some(b) => {
                if let Err(s) = inst.snapshot(&mut b.bytes) {
                    return s;
                }
                b.sealed = false;
            }
            None => {
                let mut bytes = Vec::new();
                if let Err(s) = inst.snapshot(&mut bytes) {
                    return s;
                }
                let b = Box::new(StateBox {
                    magic: STATE_MAGIC,
                    bytes,
                    sealed: false,
                });
                unsafe { *state = Box::into_raw(b) as FmuStatePtr };
            }
        }
        Status::Ok
    })
}

/// `fmi2SetFMUstate` (§2.1.8).
///
/// # Safety
/// `state` NULL or a state from `fmi2GetFMUstate`/`fmi2DeSerializeFMUstate`.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetFMUstate(c: Component, state: FmuStatePtr) -> Status {
    let call = Call::SetFMUstate;
    guarded(c, call, |inst| match unsafe { state_box(state) } {
        Some(b) => {
            let bytes = std::mem::take(&mut b.bytes);
            let s = inst.restore(&bytes);
            b.bytes = bytes;
            s
        }
        None => inst.error(call, "FMUstate is NULL or not a state of this FMU"),
    })
}

/// `fmi2FreeFMUstate` (§2.1.8): frees `*state` and sets it to NULL; `*state == NULL` is a
/// no-op.
///
/// # Safety
/// `state` points to an `fmi2FMUstate` (NULL or ours).
#[no_mangle]
pub unsafe extern "C" fn fmi2FreeFMUstate(c: Component, state: *mut FmuStatePtr) -> Status {
    let call = Call::FreeFMUstate;
    guarded(c, call, |inst| {
        if let Err(s) = inst.check(call) {
            return s;
        }
        if state.is_null() {
            return inst.error(call, "FMUstate pointer is NULL");
        }
        let s = unsafe { *state };
        if s.is_null() {
            return Status::Ok;
        }
        match unsafe { state_box(s) } {
            Some(b) => {
                b.magic = 0;
                drop(unsafe { Box::from_raw(s as *mut StateBox) });
                unsafe { *state = std::ptr::null_mut() };
                Status::Ok
            }
            None => inst.error(call, "*FMUstate is not a state of this FMU"),
        }
    })
}

/// `fmi2SerializedFMUstateSize` (§2.1.8).
///
/// # Safety
/// `size` writable; `state` ours.
#[no_mangle]
pub unsafe extern "C" fn fmi2SerializedFMUstateSize(
    c: Component,
    state: FmuStatePtr,
    size: *mut usize,
) -> Status {
    let call = Call::SerializedFMUstateSize;
    guarded(c, call, |inst| {
        if let Err(s) = inst.check(call) {
            return s;
        }
        if size.is_null() {
            return inst.error(call, "size pointer is NULL");
        }
        match unsafe { state_box(state) } {
            Some(b) => {
                unsafe { *size = b.bytes.len() };
                Status::Ok
            }
            None => inst.error(call, "FMUstate is NULL or not a state of this FMU"),
        }
    })
}

/// `fmi2SerializeFMUstate` (§2.1.8): `size` must be the value from
/// `fmi2SerializedFMUstateSize`.
///
/// # Safety
/// `serialized` has `size` writable bytes; `state` ours.
#[no_mangle]
pub unsafe extern "C" fn fmi2SerializeFMUstate(
    c: Component,
    state: FmuStatePtr,
    serialized: *mut c_char,
    size: usize,
) -> Status {
    let call = Call::SerializeFMUstate;
    guarded(c, call, |inst| {
        if let Err(s) = inst.check(call) {
            return s;
        }
        let Some(b) = (unsafe { state_box(state) }) else {
            return inst.error(call, "FMUstate is NULL or not a state of this FMU");
        };
        if size != b.bytes.len() {
            let n = b.bytes.len();
            return inst.error(
                call,
                format!("size = {size} but the state needs {n} bytes (fmi2SerializedFMUstateSize)"),
            );
        }
        let Some(out) = (unsafe { slice_mut(serialized as *mut u8, size) }) else {
            return inst.error(call, "serializedState is NULL");
        };
        if !b.sealed {
            blob::seal(&mut b.bytes);
            b.sealed = true;
        }
        out.copy_from_slice(&b.bytes);
        Status::Ok
    })
}

/// `fmi2DeSerializeFMUstate` (§2.1.8): the blob is checked (magic, version, length,
/// checksum, GUID) before a state object is created or overwritten.
///
/// # Safety
/// `serialized` has `size` readable bytes; `state` points to an `fmi2FMUstate`.
#[no_mangle]
pub unsafe extern "C" fn fmi2DeSerializeFMUstate(
    c: Component,
    serialized: *const c_char,
    size: usize,
    state: *mut FmuStatePtr,
) -> Status {
    let call = Call::DeSerializeFMUstate;
    guarded(c, call, |inst| {
        if state.is_null() {
            return inst.error(call, "FMUstate pointer is NULL");
        }
        let Some(bytes) = (unsafe { slice(serialized as *const u8, size) }) else {
            return inst.error(call, format!("serializedState is NULL with size = {size}"));
        };
        let existing = unsafe { *state };
        if !existing.is_null() && unsafe { state_box(existing) }.is_none() {
            return inst.error(call, "*FMUstate is neither NULL nor a state of this FMU");
        }
        let s = inst.check_blob(bytes);
        if s != Status::Ok {
            return s;
        }
        match unsafe { state_box(existing) } {
            Some(b) => {
                b.bytes.clear();
                b.bytes.extend_from_slice(bytes);
                b.sealed = true;
            }
            None => {
                let b = Box::new(StateBox {
                    magic: STATE_MAGIC,
                    bytes: bytes.to_vec(),
                    sealed: true,
                });
                unsafe { *state = Box::into_raw(b) as FmuStatePtr };
            }
        }
        Status::Ok
    })
}

// ---------------------------------------------------------------------------------------
// Directional derivatives (declared false), input and output derivatives (per model)
// ---------------------------------------------------------------------------------------

/// `fmi2GetDirectionalDerivative` (§2.1.9): not provided
/// (`providesDirectionalDerivative="false"`); returns `fmi2Error` with a log line.
///
/// # Safety
/// Not dereferenced.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetDirectionalDerivative(
    c: Component,
    _unknown: *const ValueReference,
    _n_unknown: usize,
    _known: *const ValueReference,
    _n_known: usize,
    _dv_known: *const f64,
    _dv_unknown: *mut f64,
) -> Status {
    let call = Call::GetDirectionalDerivative;
    guarded(c, call, |i| {
        i.unsupported(call, "providesDirectionalDerivative=\"false\"")
    })
}

/// `fmi2SetRealInputDerivatives` (§4.2.1): first-order input rates for the next step, for a
/// model with `canInterpolateInputs="true"`; otherwise `fmi2Error` with a log line.
///
/// # Safety
/// Arrays of `nvr` elements (may be NULL when `nvr == 0`).
#[no_mangle]
pub unsafe extern "C" fn fmi2SetRealInputDerivatives(
    c: Component,
    vr: *const ValueReference,
    nvr: usize,
    order: *const c_int,
    value: *const f64,
) -> Status {
    let call = Call::SetRealInputDerivatives;
    array_call!(c, call, vr, nvr, value, slice, |inst, vrs, vals| {
        // SAFETY: as for `vr[]`, `nvr` elements behind a non-NULL array (§4.2.1).
        let Some(orders) = (unsafe { slice(order, nvr) }) else {
            return null_arg(inst, call, "order[]", nvr);
        };
        inst.set_real_input_derivatives(vrs, orders, vals)
    })
}

/// `fmi2GetRealOutputDerivatives` (§4.2.1): first-order output derivatives for a model with
/// `maxOutputDerivativeOrder="1"`; otherwise `fmi2Error` with a log line.
///
/// # Safety
/// Arrays of `nvr` elements (may be NULL when `nvr == 0`).
#[no_mangle]
pub unsafe extern "C" fn fmi2GetRealOutputDerivatives(
    c: Component,
    vr: *const ValueReference,
    nvr: usize,
    order: *const c_int,
    value: *mut f64,
) -> Status {
    let call = Call::GetRealOutputDerivatives;
    array_call!(c, call, vr, nvr, value, slice_mut, |inst, vrs, vals| {
        // SAFETY: as for `vr[]`, `nvr` elements behind a non-NULL array (§4.2.1).
        let Some(orders) = (unsafe { slice(order, nvr) }) else {
            return null_arg(inst, call, "order[]", nvr);
        };
        inst.get_real_output_derivatives(vrs, orders, vals)
    })
}

// ---------------------------------------------------------------------------------------
// Computation (§4.2.2) and status (§4.2.3)
// ---------------------------------------------------------------------------------------

/// `fmi2DoStep` (§4.2.2): integrates exactly to `tc + h`; `noSetFMUStatePriorToCurrentPoint`
/// is not needed (no buffers to flush) and ignored.
///
/// # Safety
/// `c` as returned by `fmi2Instantiate`.
#[no_mangle]
pub unsafe extern "C" fn fmi2DoStep(
    c: Component,
    current_communication_point: f64,
    communication_step_size: f64,
    _no_set_fmu_state_prior_to_current_point: c_int,
) -> Status {
    guarded(c, Call::DoStep, |i| {
        i.do_step(current_communication_point, communication_step_size)
    })
}

/// `fmi2CancelStep` (§4.2.2): only meaningful for asynchronous FMUs; `fmi2Error` here.
///
/// # Safety
/// `c` as returned by `fmi2Instantiate`.
#[no_mangle]
pub unsafe extern "C" fn fmi2CancelStep(c: Component) -> Status {
    guarded(c, Call::CancelStep, |i| i.cancel_step())
}

fn status_out<T>(
    c: Component,
    call: Call,
    kind: c_int,
    out: *mut T,
    write: impl FnOnce(StatusAnswer) -> Option<T>,
) -> Status {
    guarded(c, call, |inst| {
        if out.is_null() {
            if let Err(s) = inst.check(call) {
                return s;
            }
            return inst.error(call, "value pointer is NULL");
        }
        match inst.status_query(call, kind) {
            Ok(answer) => match write(answer) {
                Some(v) => {
                    // SAFETY: non-NULL, the host provides storage for one value.
                    unsafe { *out = v };
                    Status::Ok
                }
                None => Status::Discard,
            },
            Err(s) => s,
        }
    })
}

/// `fmi2GetStatus` (§4.2.3): only `fmi2DoStepStatus` exists for it, which is asynchronous;
/// returns `fmi2Discard` (status not available).
///
/// # Safety
/// `value` writable.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetStatus(c: Component, kind: c_int, value: *mut Status) -> Status {
    status_out(c, Call::GetStatus, kind, value, |_| None)
}

/// `fmi2GetRealStatus` (§4.2.3): `fmi2LastSuccessfulTime`.
///
/// # Safety
/// `value` writable.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetRealStatus(c: Component, kind: c_int, value: *mut f64) -> Status {
    status_out(c, Call::GetRealStatus, kind, value, |a| match a {
        StatusAnswer::Real(x) => Some(x),
        StatusAnswer::Boolean(_) => None,
    })
}

/// `fmi2GetIntegerStatus` (§4.2.3): FMI 2.0 defines no Integer status; `fmi2Discard`.
///
/// # Safety
/// `value` writable.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetIntegerStatus(
    c: Component,
    kind: c_int,
    value: *mut c_int,
) -> Status {
    status_out(c, Call::GetIntegerStatus, kind, value, |_| None)
}

/// `fmi2GetBooleanStatus` (§4.2.3): `fmi2Terminated`.
///
/// # Safety
/// `value` writable.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetBooleanStatus(
    c: Component,
    kind: c_int,
    value: *mut c_int,
) -> Status {
    status_out(c, Call::GetBooleanStatus, kind, value, |a| match a {
        StatusAnswer::Boolean(b) => Some(c_int::from(b)),
        StatusAnswer::Real(_) => None,
    })
}

/// `fmi2GetStringStatus` (§4.2.3): only `fmi2PendingStatus` (asynchronous); `fmi2Discard`.
///
/// # Safety
/// `value` writable.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetStringStatus(
    c: Component,
    kind: c_int,
    value: *mut *const c_char,
) -> Status {
    status_out(c, Call::GetStringStatus, kind, value, |_| None)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fmi::model::{
        CoSimModel, DefaultExperiment, Lifecycle, ModelInfo, StepFailure, Variable,
    };

    /// A model whose step panics: the panic must stay inside the FMU.
    struct Panicky {
        lifecycle: Lifecycle,
    }

    impl CoSimModel for Panicky {
        fn variables(&self) -> &[Variable] {
            &[]
        }
        fn get_real(&self, vr: u32) -> Result<f64, String> {
            Err(format!("no {vr}"))
        }
        fn set_real(&mut self, vr: u32, _: f64) -> Result<(), String> {
            Err(format!("no {vr}"))
        }
        fn lifecycle_mut(&mut self) -> &mut Lifecycle {
            &mut self.lifecycle
        }
        fn do_step(&mut self, _: f64, _: f64) -> Result<(), StepFailure> {
            panic!("bug in the model")
        }
        fn reset(&mut self) -> Result<(), String> {
            Ok(())
        }
        fn save_state(&mut self) -> Vec<u8> {
            Vec::new()
        }
        fn load_state(&mut self, _: &[u8]) -> Result<(), String> {
            Ok(())
        }
    }

    #[test]
    fn a_panic_becomes_fatal_and_the_instance_stays_dead() {
        let cb = CallbackFunctions {
            logger: None,
            allocate_memory: None,
            free_memory: None,
            step_finished: None,
            component_environment: std::ptr::null_mut(),
        };
        let info = ModelInfo {
            model_name: "p".into(),
            description: String::new(),
            default_experiment: DefaultExperiment {
                start_time: 0.0,
                stop_time: 1.0,
                step_size: 0.1,
                tolerance: None,
            },
            guid: "{p}".into(),
            documentation: String::new(),
        };
        let logger = Logger::new(cb, CString::new("p").unwrap(), false);
        let c = Box::into_raw(Box::new(Instance::new(
            logger,
            Box::new(Panicky {
                lifecycle: Lifecycle::default(),
            }),
            info,
        ))) as Component;
        unsafe {
            assert_eq!(fmi2EnterInitializationMode(c), Status::Ok);
            assert_eq!(fmi2ExitInitializationMode(c), Status::Ok);
            assert_eq!(fmi2DoStep(c, 0.0, 0.1, 1), Status::Fatal);
            // fmi2Fatal: nothing but fmi2FreeInstance is allowed any more (FMI 2.0.x §2.1.3).
            assert_eq!(fmi2Reset(c), Status::Error);
            assert_eq!(fmi2DoStep(c, 0.0, 0.1, 1), Status::Error);
            fmi2FreeInstance(c);
        }
    }
}
