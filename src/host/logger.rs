//! Per-instance FMU logger (FMI 2.0.5 §2.1.5 `fmi2CallbackLogger`).
//!
//! The variadic entry point is C (`logger_shim.c`); it formats the message and calls
//! [`forward`] with the context stored in this instance's [`LogEnv`]. The `LogEnv` address is
//! passed as `componentEnvironment`, so messages are routed per instance without any global.

use super::library::Status;
use std::ffi::{c_char, c_int, c_void, CStr};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

extern "C" {
    /// Defined in `logger_shim.c`. Passed to the FMU as `fmi2CallbackFunctions.logger`.
    pub fn geardyn_host_logger(
        env: *mut c_void,
        instance_name: *const c_char,
        status: c_int,
        category: *const c_char,
        fmt: *const c_char,
        ...
    );
}

/// Must match `geardyn_log_env` in `logger_shim.c`.
#[repr(C)]
pub struct LogEnv {
    forward: unsafe extern "C" fn(*mut c_void, *const c_char, c_int, *const c_char, *const c_char),
    ctx: *const LogSink,
}

/// One message received from the FMU.
#[derive(Debug, Clone, PartialEq)]
pub struct LogRecord {
    pub status: Status,
    pub category: String,
    pub message: String,
}

/// Where an instance's messages go: printed to stderr when at or above `print_level`, and
/// kept (the last few at warning level or worse) to explain a failing call.
///
/// A message of status `fmi2Discard` or worse is the reason of a failing call, so it is said
/// once, in the host's one-line report of that call (issue 32, "a master that says why"):
/// below `--log-level all` it is held until the call returns, and printed on its own only
/// when the call did not fail after all (at [`Logger::clear`]) or was never reported
/// (when the logger is dropped).
pub struct LogSink {
    print_level: Status,
    records: Mutex<Vec<Kept>>,
    /// Whether `records` may be non-empty: lets [`Logger::clear`] skip the lock on the hot
    /// path (an FMU that logs nothing costs one atomic load per call).
    dirty: AtomicBool,
}

/// Only this many warning/error messages are kept per instance (the reasons for a failure are
/// the last ones; a chatty FMU must not grow memory without bound).
const KEEP: usize = 64;

/// A kept message, and whether it has been printed.
struct Kept {
    rec: LogRecord,
    printed: bool,
}

fn print(rec: &LogRecord) {
    eprintln!(
        "[{}] [{}] {}",
        rec.status,
        if rec.category.is_empty() {
            "-"
        } else {
            &rec.category
        },
        rec.message
    );
}

impl LogSink {
    fn push(&self, rec: LogRecord) {
        let wanted = rec.status >= self.print_level;
        let held = rec.status >= Status::Discard && self.print_level > Status::Ok;
        if wanted && !held {
            print(&rec);
        }
        if rec.status >= Status::Warning {
            if let Ok(mut r) = self.records.lock() {
                if r.len() == KEEP {
                    let dropped = r.remove(0);
                    self.print_held(&dropped);
                }
                r.push(Kept {
                    rec,
                    printed: !held,
                });
                self.dirty.store(true, Ordering::Release);
            }
        }
    }

    /// Print a held message that no failure report took.
    fn print_held(&self, k: &Kept) {
        if !k.printed && k.rec.status >= self.print_level {
            print(&k.rec);
        }
    }
}

impl Drop for LogSink {
    fn drop(&mut self) {
        let kept = self
            .records
            .get_mut()
            .map(std::mem::take)
            .unwrap_or_default();
        for k in &kept {
            self.print_held(k);
        }
    }
}

/// The logger of one FMU instance. Must outlive the instance (it is dropped after
/// `fmi2FreeInstance`), because the FMU keeps the `componentEnvironment` pointer.
pub struct Logger {
    env: Box<LogEnv>,
    sink: Box<LogSink>,
}

impl Logger {
    /// Messages with `status >= print_level` are printed to stderr.
    pub fn new(print_level: Status) -> Self {
        let sink = Box::new(LogSink {
            print_level,
            records: Mutex::new(Vec::new()),
            dirty: AtomicBool::new(false),
        });
        let env = Box::new(LogEnv {
            forward,
            ctx: &*sink as *const LogSink,
        });
        Logger { env, sink }
    }

    /// Whether every message is printed (`--log-level all`), debug messages included.
    pub fn prints_all(&self) -> bool {
        self.sink.print_level == Status::Ok
    }

    /// The value to pass as `componentEnvironment`.
    pub fn component_environment(&self) -> *mut c_void {
        &*self.env as *const LogEnv as *mut c_void
    }

    /// Forget the kept messages: called after every call that did not fail, so the reasons
    /// reported for a failure are the ones logged during that call. Inlined: on the hot path
    /// it is one load of the flag.
    #[inline]
    pub fn clear(&self) {
        // A plain load first: after almost every call nothing was logged, and a load is
        // cheaper than the read-modify-write of a swap (this runs after every FMI call).
        if self.sink.dirty.load(Ordering::Acquire) {
            self.clear_records();
        }
    }

    /// After a call that did not fail: the held messages are printed now.
    #[cold]
    fn clear_records(&self) {
        if self.sink.dirty.swap(false, Ordering::AcqRel) {
            if let Ok(mut r) = self.sink.records.lock() {
                for k in r.drain(..) {
                    self.sink.print_held(&k);
                }
            }
        }
    }

    /// Remove and return the kept warning/error messages: the caller reports them.
    pub fn take_records(&self) -> Vec<LogRecord> {
        self.sink
            .records
            .lock()
            .map(|mut r| {
                self.sink.dirty.store(false, Ordering::Release);
                r.drain(..).map(|k| k.rec).collect()
            })
            .unwrap_or_default()
    }

    /// The kept messages with status ≥ `min`, joined for an error report ("" if none).
    pub fn reasons(&self, min: Status) -> String {
        let recs = self.take_records();
        recs.iter()
            .filter(|r| r.status >= min)
            .map(|r| r.message.as_str())
            .collect::<Vec<_>>()
            .join("; ")
    }
}

fn text(p: *const c_char) -> String {
    if p.is_null() {
        String::new()
    } else {
        // SAFETY: the FMU passes NUL-terminated strings (FMI 2.0.5 §2.1.5); the shim passes
        // its own NUL-terminated buffer.
        unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
    }
}

/// Called by the C shim with the formatted message. Never unwinds into C.
unsafe extern "C" fn forward(
    ctx: *mut c_void,
    _instance_name: *const c_char,
    status: c_int,
    category: *const c_char,
    message: *const c_char,
) {
    let _ = std::panic::catch_unwind(|| {
        let rec = LogRecord {
            status: Status::from_raw(status),
            category: text(category),
            message: text(message),
        };
        let sink = ctx as *const LogSink;
        if sink.is_null() {
            eprintln!("[{}] {}", rec.status, rec.message);
        } else {
            // SAFETY: ctx is the LogSink boxed in the Logger that owns this LogEnv and
            // outlives the instance.
            unsafe { &*sink }.push(rec);
        }
    });
}
