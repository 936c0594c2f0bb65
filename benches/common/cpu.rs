//! CPU clocks for the benchmarks (included by each with `#[path]`, like `stats.rs`): unlike
//! wall time, they do not count the other processes of a shared machine.
#![allow(dead_code)] // each bench uses the clock it needs

fn clock(id: libc::clockid_t) -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: writes the clock `id` into `ts`.
    unsafe { libc::clock_gettime(id, &mut ts) };
    ts.tv_sec as f64 + 1e-9 * ts.tv_nsec as f64
}

/// CPU time of the calling thread, s.
pub fn thread_cpu() -> f64 {
    clock(libc::CLOCK_THREAD_CPUTIME_ID)
}

/// CPU time of the process (every thread), s: for work that runs on all cores, such as the
/// period maps of HB's stability step.
pub fn process_cpu() -> f64 {
    clock(libc::CLOCK_PROCESS_CPUTIME_ID)
}
