//! An FMU instance driven through the exported C ABI in-process, as a host calls it (the
//! same code as in the cdylib), with the host's logger shim capturing the FMU's messages:
//! shared by `tests/fmi_progress.rs` and `tests/fmi_fuzz.rs`.

#![allow(dead_code)]

use std::ffi::{c_char, c_void, CString};
use std::path::PathBuf;
use std::ptr::null_mut;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use geardyn::fmi::abi::*;
use geardyn::fmi::logger::Status;
use geardyn::host::library::{CallbackFunctions, Status as HostStatus};
use geardyn::host::logger::{geardyn_host_logger, Logger};

pub const OK: Status = Status::Ok;
pub const DISCARD: Status = Status::Discard;
pub const ERR: Status = Status::Error;

/// `fmu/<name>`: the shipped scene folder (the FMU's resources).
pub fn scene_dir(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("fmu")
        .join(name)
}

pub fn guid(name: &str) -> CString {
    let bytes = std::fs::read(scene_dir(name).join("scene.toml")).unwrap();
    CString::new(geardyn::fmi::blob::guid(&bytes)).unwrap()
}

/// One instance with logging on; its messages of status Warning and worse are kept.
pub struct Fmu {
    pub c: *mut c_void,
    pub name: &'static str,
    log: Logger,
}

/// The host's logger shim with a sink that keeps the messages (of status Warning and worse)
/// and prints none, and the callbacks that pass it to an FMU.
pub fn quiet_logger() -> (Logger, CallbackFunctions) {
    let log = Logger::new(HostStatus::Invalid(i32::MAX));
    let cb = CallbackFunctions {
        logger: Some(geardyn_host_logger),
        allocate_memory: None,
        free_memory: None,
        step_finished: None,
        component_environment: log.component_environment(),
    };
    (log, cb)
}

impl Fmu {
    pub fn new(name: &'static str) -> Fmu {
        let (log, cb) = quiet_logger();
        let inst = CString::new(name).unwrap();
        let uri = CString::new(format!("file://{}", scene_dir(name).display())).unwrap();
        let g = guid(name);
        // The host's fmi2CallbackFunctions and the FMU's are the same C struct.
        let cb = &cb as *const CallbackFunctions as *const geardyn::fmi::logger::CallbackFunctions;
        let c = unsafe { fmi2Instantiate(inst.as_ptr(), 1, g.as_ptr(), uri.as_ptr(), cb, 0, 1) };
        assert!(!c.is_null(), "instantiate {name}");
        Fmu { c, name, log }
    }

    /// The messages logged since the last call, one per line.
    pub fn messages(&self) -> String {
        self.log
            .take_records()
            .into_iter()
            .map(|r| r.message)
            .collect::<Vec<_>>()
            .join("\n")
    }

    pub fn setup(&self, stop: Option<f64>) -> Status {
        unsafe {
            fmi2SetupExperiment(
                self.c,
                0,
                0.0,
                0.0,
                stop.is_some() as i32,
                stop.unwrap_or(0.0),
            )
        }
    }

    pub fn enter(&self) -> Status {
        unsafe { fmi2EnterInitializationMode(self.c) }
    }

    pub fn exit(&self) -> Status {
        unsafe { fmi2ExitInitializationMode(self.c) }
    }

    /// Set up without a stop time and initialized.
    pub fn ready(name: &'static str) -> Fmu {
        let f = Fmu::new(name);
        assert_eq!(f.setup(None), OK);
        assert_eq!(f.enter(), OK);
        assert_eq!(f.exit(), OK);
        f
    }

    pub fn set(&self, vr: u32, x: f64) -> Status {
        unsafe { fmi2SetReal(self.c, &vr, 1, &x) }
    }

    pub fn set_bool(&self, vr: u32, x: bool) -> Status {
        let b = i32::from(x);
        unsafe { fmi2SetBoolean(self.c, &vr, 1, &b) }
    }

    pub fn step(&self, t: f64, h: f64) -> Status {
        unsafe { fmi2DoStep(self.c, t, h, 1) }
    }

    pub fn get(&self, vrs: &[u32]) -> (Status, Vec<f64>) {
        let mut v = vec![f64::NAN; vrs.len()];
        let s = unsafe { fmi2GetReal(self.c, vrs.as_ptr(), vrs.len(), v.as_mut_ptr()) };
        (s, v)
    }

    pub fn last_successful_time(&self) -> f64 {
        let mut t = f64::NAN;
        assert_eq!(unsafe { fmi2GetRealStatus(self.c, 2, &mut t) }, OK);
        t
    }

    pub fn state_bytes(&self) -> Vec<u8> {
        let mut st: *mut c_void = null_mut();
        assert_eq!(unsafe { fmi2GetFMUstate(self.c, &mut st) }, OK);
        let mut n = 0usize;
        assert_eq!(
            unsafe { fmi2SerializedFMUstateSize(self.c, st, &mut n) },
            OK
        );
        let mut buf = vec![0u8; n];
        let s = unsafe { fmi2SerializeFMUstate(self.c, st, buf.as_mut_ptr() as *mut c_char, n) };
        assert_eq!(s, OK);
        assert_eq!(unsafe { fmi2FreeFMUstate(self.c, &mut st) }, OK);
        buf
    }

    /// DeSerialize + SetFMUstate; the first status that is not OK, else OK.
    pub fn load_bytes(&self, buf: &[u8]) -> Status {
        let mut st: *mut c_void = null_mut();
        let s = unsafe {
            fmi2DeSerializeFMUstate(self.c, buf.as_ptr() as *const c_char, buf.len(), &mut st)
        };
        if s != OK {
            return s;
        }
        let s = unsafe { fmi2SetFMUstate(self.c, st) };
        unsafe { fmi2FreeFMUstate(self.c, &mut st) };
        s
    }
}

impl Drop for Fmu {
    fn drop(&mut self) {
        unsafe { fmi2FreeInstance(self.c) };
    }
}

/// Runs `f` on its own thread and returns its result, or fails the test naming `what` when
/// it takes longer than `limit` (a hang must fail the test, not stall the suite).
pub fn within<T: Send + 'static>(
    limit: Duration,
    what: &str,
    f: impl FnOnce() -> T + Send + 'static,
) -> T {
    let (tx, rx) = mpsc::channel();
    let start = Instant::now();
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    match rx.recv_timeout(limit) {
        Ok(x) => x,
        Err(mpsc::RecvTimeoutError::Timeout) => {
            panic!("{what}: no answer within {limit:?} (a hang)")
        }
        Err(mpsc::RecvTimeoutError::Disconnected) => {
            panic!("{what}: failed after {:?}", start.elapsed())
        }
    }
}

/// The seeded generator of the fuzzers: the one in `tests/common/rng.rs`.
#[path = "../common/rng.rs"]
mod rng;
pub use rng::SplitMix64 as SplitMix;
