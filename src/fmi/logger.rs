//! The host's logger (FMI 2.0.x §2.1.5, `fmi2CallbackLogger`) with log categories.
//!
//! The logger is a C-variadic function with `printf` semantics. Calling a variadic function
//! pointer is stable Rust; every message goes through a literal `"%s"` format so that a `%`
//! in a message (a file name, a unit) is never interpreted by the host.

use std::ffi::{c_char, c_int, c_void, CString};

/// `fmi2Status` (FMI 2.0.x §2.1.3). C `int`-sized on every platform we build for.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Status {
    Ok = 0,
    Warning = 1,
    Discard = 2,
    Error = 3,
    Fatal = 4,
    Pending = 5,
}

impl Status {
    pub fn name(self) -> &'static str {
        match self {
            Status::Ok => "fmi2OK",
            Status::Warning => "fmi2Warning",
            Status::Discard => "fmi2Discard",
            Status::Error => "fmi2Error",
            Status::Fatal => "fmi2Fatal",
            Status::Pending => "fmi2Pending",
        }
    }
}

/// `fmi2CallbackLogger`: the last parameter is the `printf` format, followed by varargs.
pub type LoggerFn = unsafe extern "C" fn(
    component_environment: *mut c_void,
    instance_name: *const c_char,
    status: c_int,
    category: *const c_char,
    message: *const c_char,
    ...
);

/// `fmi2CallbackFunctions` (FMI 2.0.x §2.1.5). Copied by value in `fmi2Instantiate` because
/// the pointer passed there is only valid during that call (2.0.x clarification).
#[repr(C)]
#[derive(Clone, Copy)]
pub struct CallbackFunctions {
    pub logger: Option<LoggerFn>,
    /// Unused: the FMU declares `canNotUseMemoryManagementFunctions="true"`.
    pub allocate_memory: Option<unsafe extern "C" fn(usize, usize) -> *mut c_void>,
    pub free_memory: Option<unsafe extern "C" fn(*mut c_void)>,
    pub step_finished: Option<unsafe extern "C" fn(*mut c_void, c_int)>,
    pub component_environment: *mut c_void,
}

/// A log category as declared in `<LogCategories>` (names as in the Reference FMUs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Category {
    /// State transitions and step results.
    Events,
    StatusWarning,
    StatusError,
    StatusFatal,
    /// Call trace: every FMI call with its arguments (verbose).
    All,
}

impl Category {
    pub const ALL: [Category; 5] = [
        Category::Events,
        Category::StatusWarning,
        Category::StatusError,
        Category::StatusFatal,
        Category::All,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Category::Events => "logEvents",
            Category::StatusWarning => "logStatusWarning",
            Category::StatusError => "logStatusError",
            Category::StatusFatal => "logStatusFatal",
            Category::All => "logAll",
        }
    }

    pub fn description(self) -> &'static str {
        match self {
            Category::Events => "State transitions, initialization and step results",
            Category::StatusWarning => "Messages with status fmi2Warning or fmi2Discard",
            Category::StatusError => "Messages with status fmi2Error",
            Category::StatusFatal => "Messages with status fmi2Fatal",
            Category::All => "Trace of every FMI call with its arguments (enables all categories)",
        }
    }

    fn bit(self) -> u8 {
        1 << (self as u8)
    }

    pub fn from_name(name: &str) -> Option<Category> {
        Category::ALL.into_iter().find(|c| c.name() == name)
    }

    /// The category a message of this status belongs to.
    pub fn for_status(status: Status) -> Category {
        match status {
            Status::Ok | Status::Pending => Category::Events,
            Status::Warning | Status::Discard => Category::StatusWarning,
            Status::Error => Category::StatusError,
            Status::Fatal => Category::StatusFatal,
        }
    }
}

const ALL_BITS: u8 = 0b1_1111;

/// Per-instance logger: the copied callbacks plus the enabled categories. Not global.
pub struct Logger {
    callbacks: CallbackFunctions,
    instance_name: CString,
    enabled: u8,
}

// SAFETY: the component environment pointer is opaque to us and only handed back to the
// host's logger; instances are not shared between threads by the FMI contract (§2.1.1).
unsafe impl Send for Logger {}

impl Logger {
    /// `logging_on` (from `fmi2Instantiate`) enables every category. Otherwise only the
    /// messages of warnings, discards, errors and fatal errors are passed on: the spec says
    /// the logger "should" only be called for enabled categories, but a refused step whose
    /// reason is swallowed is worse for users (issue 32: the reason of an `fmi2Discard` must
    /// reach a host at its default log level); the host can still silence them with
    /// `fmi2SetDebugLogging(fmi2False, 0, NULL)`.
    pub fn new(callbacks: CallbackFunctions, instance_name: CString, logging_on: bool) -> Logger {
        let enabled = if logging_on {
            ALL_BITS
        } else {
            Category::StatusWarning.bit()
                | Category::StatusError.bit()
                | Category::StatusFatal.bit()
        };
        Logger {
            callbacks,
            instance_name,
            enabled,
        }
    }

    pub fn instance_name(&self) -> &str {
        self.instance_name.to_str().unwrap_or("?")
    }

    pub fn is_enabled(&self, category: Category) -> bool {
        self.enabled & category.bit() != 0
    }

    /// `fmi2SetDebugLogging` (FMI 2.0.x §2.1.5): with no categories, switch all; otherwise
    /// switch the listed ones (`logAll` switches all). Unknown names are returned so the
    /// caller can warn about them.
    pub fn set_categories(&mut self, on: bool, names: &[String]) -> Vec<String> {
        let mut unknown = Vec::new();
        let mut bits = 0u8;
        if names.is_empty() {
            bits = ALL_BITS;
        }
        for n in names {
            match Category::from_name(n) {
                Some(Category::All) => bits = ALL_BITS,
                Some(c) => bits |= c.bit(),
                None => unknown.push(n.clone()),
            }
        }
        if on {
            self.enabled |= bits;
        } else {
            self.enabled &= !bits;
        }
        unknown
    }

    /// Logs `message` with the category that belongs to `status`.
    pub fn log(&self, status: Status, message: &str) {
        self.log_in(Category::for_status(status), status, message);
    }

    /// Logs `message` if `category` is enabled.
    pub fn log_in(&self, category: Category, status: Status, message: &str) {
        if !self.is_enabled(category) {
            return;
        }
        let Some(logger) = self.callbacks.logger else {
            return;
        };
        let text = CString::new(escape_message(message)).unwrap_or_default();
        let cat = CString::new(category.name()).unwrap_or_default();
        // SAFETY: all pointers are valid NUL-terminated strings for the duration of the call;
        // the format "%s" consumes exactly the one vararg we pass.
        unsafe {
            logger(
                self.callbacks.component_environment,
                self.instance_name.as_ptr(),
                status as c_int,
                cat.as_ptr(),
                c"%s".as_ptr(),
                text.as_ptr(),
            );
        }
    }
}

/// `#` starts a variable reference (`#r12#`) in FMI log messages and must be doubled
/// (FMI 2.0.x §2.1.5); NUL cannot travel through a C string.
fn escape_message(message: &str) -> String {
    message.replace('#', "##").replace('\0', "\\0")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escaping() {
        assert_eq!(escape_message("a#b%d\0"), "a##b%d\\0");
    }

    #[test]
    fn categories_switch() {
        let cb = CallbackFunctions {
            logger: None,
            allocate_memory: None,
            free_memory: None,
            step_finished: None,
            component_environment: std::ptr::null_mut(),
        };
        let mut l = Logger::new(cb, CString::new("x").unwrap(), false);
        assert!(l.is_enabled(Category::StatusError));
        assert!(!l.is_enabled(Category::Events));
        assert!(l.set_categories(true, &["logEvents".into()]).is_empty());
        assert!(l.is_enabled(Category::Events));
        assert_eq!(
            l.set_categories(true, &["nope".into()]),
            vec!["nope".to_string()]
        );
        l.set_categories(false, &[]);
        assert!(!l.is_enabled(Category::StatusError));
        l.set_categories(true, &["logAll".into()]);
        assert!(Category::ALL.iter().all(|c| l.is_enabled(*c)));
    }
}
