//! Ctrl-C during `geardyn run`: SIGINT/SIGTERM set a flag that the step loop polls, so an
//! interrupted run still terminates and frees the FMU, flushes the CSV and removes its
//! temporary folder (the default disposition kills the process without running destructors).
//! Only the CLI installs it; the library's runner just reads the flag it is given.

use std::ffi::c_int;
use std::sync::atomic::{AtomicBool, Ordering};

/// Set by SIGINT/SIGTERM; polled by the step loop.
pub static INTERRUPTED: AtomicBool = AtomicBool::new(false);

const SIGINT: c_int = 2;
const SIGTERM: c_int = 15;
/// `SIG_DFL`.
const SIG_DFL: usize = 0;

extern "C" {
    /// POSIX `signal(2)` (Linux x86-64/aarch64 ABI: the handler is a pointer-sized value).
    fn signal(signum: c_int, handler: usize) -> usize;
}

extern "C" fn on_interrupt(sig: c_int) {
    // Only async-signal-safe work: an atomic store, and the default disposition again so a
    // second Ctrl-C ends the process at once.
    INTERRUPTED.store(true, Ordering::SeqCst);
    // SAFETY: signal() is async-signal-safe.
    unsafe { signal(sig, SIG_DFL) };
}

/// Install the handler for SIGINT and SIGTERM.
pub fn catch_interrupts() {
    // SAFETY: installs a handler that only touches an atomic.
    unsafe {
        signal(SIGINT, on_interrupt as extern "C" fn(c_int) as usize);
        signal(SIGTERM, on_interrupt as extern "C" fn(c_int) as usize);
    }
}
