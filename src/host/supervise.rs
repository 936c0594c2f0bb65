//! `geardyn run` survives the FMU (issue 17): the FMU runs in a forked child process, and the
//! parent owns the temporary folder, the output file and the exit status.
//!
//! An FMU is foreign code in our process: it can `abort()`, crash, call `exit`, or block
//! forever, and then no destructor of ours runs (the folder stays, the rows still in memory are
//! lost, nobody says what happened). So the parent unpacks and plans the run, writes the CSV
//! header, forks, and waits. The child loads the FMU and runs the loop. While it does, it keeps
//! an [`Activity`] record (the FMI call in progress and the communication time) in memory
//! shared with the parent, next to the CSV rows not yet written ([`super::csv::CsvWriter`]):
//! plain memory stores, no system call or message per step, so the run keeps its speed. When
//! the child ends without having reported its end, the parent names the signal or exit status,
//! the call and the time, writes the pending rows, and removes the folder.
//!
//! Signals: the parent blocks SIGINT, SIGTERM, SIGHUP ([`INTERRUPTS`]) and SIGCHLD from
//! before it creates the temporary folder, and waits for them with `sigtimedwait` (no handler,
//! no race between a signal and the wait). The child ignores the interrupts (a Ctrl-C reaches
//! the whole process group): the parent decides. The first signal asks the child to stop at its next step boundary (it then terminates and frees
//! the FMU and writes its rows, as after any failure); if it has not ended after
//! [`STOP_GRACE`], or on a second signal, the parent kills it.

use super::library::FmiFunction;
use super::shared::SharedMemory;
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// How long a child asked to stop may take to reach its next step boundary before it is
/// killed: short enough that a run blocked inside the FMU ends within a second of Ctrl-C.
pub const STOP_GRACE: Duration = Duration::from_millis(900);

/// What the process running the FMU is doing: written by it, read by the parent after it died.
/// Only atomics, so the parent may also write the stop request while the child runs.
#[repr(C)]
pub struct Activity {
    /// An [`FmiFunction`] index, or one of the `HOST_*` phases.
    doing: AtomicU32,
    /// The communication time of the runner (`f64` bits; NaN before the first).
    time: AtomicU64,
    /// Set by the parent on the first SIGINT/SIGTERM; polled by the step loop.
    stop: AtomicBool,
    /// 0 while the child runs; `1 + exit code` once it has reported its own end.
    reported_exit: AtomicU32,
}

/// Before the FMU's library was loaded.
const HOST_PREPARING: u32 = 1000;
/// While loading a `--preload` library.
const HOST_PRELOADING: u32 = 1001;
/// While loading the FMU's library (its initialisers run then).
const HOST_LOADING: u32 = 1002;
/// In the runner, between two FMI calls.
const HOST_BETWEEN_CALLS: u32 = 1003;
/// After the run, while the process was ending (exit handlers, library destructors).
const HOST_EXITING: u32 = 1004;

/// A step of the child outside the FMI calls, for [`Activity::phase`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HostPhase {
    Preloading,
    LoadingLibrary,
}

impl Default for Activity {
    fn default() -> Self {
        Activity {
            doing: AtomicU32::new(HOST_PREPARING),
            time: AtomicU64::new(f64::NAN.to_bits()),
            stop: AtomicBool::new(false),
            reported_exit: AtomicU32::new(0),
        }
    }
}

impl Activity {
    /// An FMI call starts (plain stores: this is on the hot path).
    #[inline]
    pub fn enter(&self, function: FmiFunction) {
        self.doing.store(function.index(), Ordering::Relaxed);
    }

    /// The FMI call returned.
    #[inline]
    pub fn leave(&self) {
        self.doing.store(HOST_BETWEEN_CALLS, Ordering::Relaxed);
    }

    pub fn phase(&self, phase: HostPhase) {
        let code = match phase {
            HostPhase::Preloading => HOST_PRELOADING,
            HostPhase::LoadingLibrary => HOST_LOADING,
        };
        self.doing.store(code, Ordering::Relaxed);
    }

    /// The runner's communication time.
    #[inline]
    pub fn at(&self, time: f64) {
        self.time.store(time.to_bits(), Ordering::Relaxed);
    }

    /// Set when the run is asked to stop at its next step boundary.
    pub fn stop_request(&self) -> &AtomicBool {
        &self.stop
    }

    /// "during fmi2DoStep at t = 0.3", for the parent's message.
    pub fn describe(&self) -> String {
        let time = f64::from_bits(self.time.load(Ordering::Relaxed));
        let at = if time.is_nan() {
            String::new()
        } else {
            format!(" at t = {time}")
        };
        match self.doing.load(Ordering::Relaxed) {
            HOST_PREPARING => "before the FMU's library was loaded".into(),
            HOST_PRELOADING => "while loading a --preload library".into(),
            HOST_LOADING => "while loading the FMU's library (in its initialisers)".into(),
            HOST_BETWEEN_CALLS => format!("between FMI calls{at}"),
            HOST_EXITING => "after the run, while its process was ending".into(),
            code => match FmiFunction::from_index(code) {
                Some(f) => format!("during {}{at}", f.name()),
                None => format!("in an unknown phase {code}{at}"),
            },
        }
    }
}

/// How the child ended, as seen by the parent.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ChildEnd {
    /// It reported its end itself (its message printed, its rows written) with this exit code.
    Reported(u8),
    /// It died or exited without reporting; the message says how and where. Its pending rows
    /// are still to be written.
    Abnormal(String),
}

/// An [`Activity`] in memory shared with a forked child.
pub struct SharedActivity {
    memory: SharedMemory,
}

impl SharedActivity {
    pub fn new() -> Result<SharedActivity, String> {
        let memory = SharedMemory::new(std::mem::size_of::<Activity>())
            .map_err(|e| format!("cannot map shared memory for the FMU's process: {e}"))?;
        // SAFETY: the mapping is page-aligned and large enough for one Activity.
        unsafe {
            memory
                .as_ptr()
                .cast::<Activity>()
                .write(Activity::default())
        };
        Ok(SharedActivity { memory })
    }

    pub fn get(&self) -> &Activity {
        // SAFETY: written in `new`; Activity holds only atomics, so shared access is sound.
        unsafe { &*self.memory.as_ptr().cast::<Activity>() }
    }
}

/// The signals that ask a run to stop: Ctrl-C, `kill`, a closed terminal.
const INTERRUPTS: [libc::c_int; 3] = [libc::SIGINT, libc::SIGTERM, libc::SIGHUP];

/// Blocks [`INTERRUPTS`] and SIGCHLD from its creation, so that the parent owns the
/// temporary folder from the moment it exists: a signal during unpacking waits until the
/// parent looks ([`Supervisor::pending_interrupt`]) instead of killing it with the folder
/// left behind. Dropping it discards the signals still pending and restores the mask.
pub struct Supervisor {
    waited: libc::sigset_t,
    old_mask: libc::sigset_t,
}

impl Supervisor {
    /// Block the signals. Call it before anything that must be cleaned up.
    pub fn new() -> Result<Supervisor, String> {
        // SAFETY: sigset_t is plain data, initialised by sigemptyset; then the mask of this
        // thread is changed.
        unsafe {
            let mut waited: libc::sigset_t = std::mem::zeroed();
            libc::sigemptyset(&mut waited);
            for s in INTERRUPTS.into_iter().chain([libc::SIGCHLD]) {
                libc::sigaddset(&mut waited, s);
            }
            let mut old_mask: libc::sigset_t = std::mem::zeroed();
            if libc::pthread_sigmask(libc::SIG_BLOCK, &waited, &mut old_mask) != 0 {
                return Err("cannot block SIGINT/SIGTERM/SIGCHLD to supervise the FMU".into());
            }
            Ok(Supervisor { waited, old_mask })
        }
    }

    /// An interrupt that came since [`Supervisor::new`], taken off the pending signals.
    pub fn pending_interrupt(&self) -> Option<String> {
        let zero = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        loop {
            // SAFETY: takes a pending signal of the blocked set, without waiting.
            let sig = unsafe { libc::sigtimedwait(&self.waited, std::ptr::null_mut(), &zero) };
            if sig <= 0 {
                return None;
            }
            if INTERRUPTS.contains(&sig) {
                return Some(signal_name(sig));
            }
        }
    }

    /// Run `body` in a forked child and wait for it; returns in the parent only.
    ///
    /// The child runs `body` (its exit code), records it in `activity`, and exits: it never
    /// returns into the caller, so no destructor of the parent's values (the temporary folder)
    /// runs in it. The caller must not have other threads (fork copies only the calling one).
    pub fn run(&self, activity: &Activity, body: impl FnOnce() -> u8) -> Result<ChildEnd, String> {
        // Flush what was printed, or both processes would print it again.
        use std::io::Write as _;
        let _ = std::io::stdout().flush();
        // SAFETY: fork in a single-threaded process.
        let parent = unsafe { libc::getpid() };
        let pid = unsafe { libc::fork() };
        if pid < 0 {
            let e = std::io::Error::last_os_error();
            return Err(format!(
                "cannot start the process that runs the FMU (fork): {e}"
            ));
        }
        if pid == 0 {
            child(activity, parent, &self.old_mask, body);
        }
        self.wait_for(pid, activity)
    }

    /// Wait for the child, relaying interrupts as described in the module documentation.
    fn wait_for(&self, pid: libc::pid_t, activity: &Activity) -> Result<ChildEnd, String> {
        let mut asked: Option<(libc::c_int, Instant)> = None;
        let mut killed: Option<Kill> = None;
        let mut status: libc::c_int = 0;
        loop {
            // SAFETY: waits for our own child; blocking once it has been killed.
            let r = unsafe {
                libc::waitpid(
                    pid,
                    &mut status,
                    if killed.is_some() { 0 } else { libc::WNOHANG },
                )
            };
            if r == pid {
                break;
            }
            if r < 0 {
                let e = std::io::Error::last_os_error();
                if e.kind() != std::io::ErrorKind::Interrupted {
                    return Err(format!("waiting for the process that runs the FMU: {e}"));
                }
                continue;
            }
            let signal = match asked {
                // SAFETY: waits for a signal of the blocked set.
                None => unsafe { libc::sigwaitinfo(&self.waited, std::ptr::null_mut()) },
                Some((first, since)) => {
                    let left = STOP_GRACE.saturating_sub(since.elapsed());
                    if left.is_zero() {
                        killed = Some(Kill::Grace(first));
                        // SAFETY: kills our own child.
                        unsafe { libc::kill(pid, libc::SIGKILL) };
                        continue;
                    }
                    let timeout = libc::timespec {
                        tv_sec: left.as_secs() as libc::time_t,
                        tv_nsec: left.subsec_nanos() as libc::c_long,
                    };
                    // SAFETY: as above, with a timeout.
                    unsafe { libc::sigtimedwait(&self.waited, std::ptr::null_mut(), &timeout) }
                }
            };
            if !INTERRUPTS.contains(&signal) {
                // SIGCHLD, a timeout (EAGAIN) or EINTR: look at the child again.
                continue;
            }
            if asked.is_none() {
                activity.stop.store(true, Ordering::SeqCst);
                eprintln!(
                    "note: {} received: stopping the run at its next step (a second signal, or {} s without reaching it, kills the FMU)",
                    signal_name(signal),
                    STOP_GRACE.as_secs_f64()
                );
                asked = Some((signal, Instant::now()));
            } else {
                killed = Some(Kill::Second(signal));
                // SAFETY: kills our own child.
                unsafe { libc::kill(pid, libc::SIGKILL) };
            }
        }
        Ok(ending(status, killed, activity))
    }
}

impl Drop for Supervisor {
    fn drop(&mut self) {
        // Signals that came after the child's end are answered by the cleanup already done;
        // unblocked, they would kill the process with their default action.
        while self.pending_interrupt().is_some() {}
        // SAFETY: restores the mask saved in `new`.
        unsafe { libc::pthread_sigmask(libc::SIG_SETMASK, &self.old_mask, std::ptr::null_mut()) };
    }
}

/// The child's side: never returns.
fn child(
    activity: &Activity,
    parent: libc::pid_t,
    old_mask: &libc::sigset_t,
    body: impl FnOnce() -> u8,
) -> ! {
    // SAFETY: signal dispositions and mask of this (single-threaded) process.
    unsafe {
        for s in INTERRUPTS {
            libc::signal(s, libc::SIG_IGN);
        }
        libc::pthread_sigmask(libc::SIG_SETMASK, old_mask, std::ptr::null_mut());
        // Die with the parent (killed with SIGKILL, say) instead of running on unsupervised.
        libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGKILL);
        if libc::getppid() != parent {
            libc::_exit(1);
        }
    }
    let (code, record) = match std::panic::catch_unwind(std::panic::AssertUnwindSafe(body)) {
        Ok(code) => (code, 1 + u32::from(code)),
        Err(_) => (PANIC_EXIT_CODE, PANICKED),
    };
    activity.reported_exit.store(record, Ordering::SeqCst);
    activity.doing.store(HOST_EXITING, Ordering::SeqCst);
    use std::io::Write as _;
    let _ = std::io::stdout().flush();
    std::process::exit(i32::from(code))
}

/// Rust's exit code after a panic (the panic message is already printed).
const PANIC_EXIT_CODE: u8 = 101;
/// `Activity::reported_exit` after a panic of geardyn's own code in the child.
const PANICKED: u32 = u32::MAX;

/// Why the parent killed the child: the grace time after this first interrupt ran out, or a
/// second interrupt came.
enum Kill {
    Grace(libc::c_int),
    Second(libc::c_int),
}

/// How the child ended, from its wait status.
fn ending(status: libc::c_int, killed: Option<Kill>, activity: &Activity) -> ChildEnd {
    let reported = activity.reported_exit.load(Ordering::SeqCst);
    let doing = activity.describe();
    let what = if libc::WIFEXITED(status) {
        let code = libc::WEXITSTATUS(status);
        if reported == PANICKED {
            return ChildEnd::Abnormal(format!(
                "geardyn panicked in the process running the FMU {doing} (a bug of geardyn; the panic message is above)"
            ));
        }
        if reported != 0 && reported - 1 == code as u32 {
            return ChildEnd::Reported(code as u8);
        }
        format!(
            "the FMU ended its process with exit status {code} {doing}, before the run was over"
        )
    } else if libc::WIFSIGNALED(status) {
        let sig = libc::WTERMSIG(status);
        match killed {
            Some(Kill::Grace(first)) if sig == libc::SIGKILL => format!(
                "{} received, and the FMU did not return within {} s: its process was killed {doing}",
                signal_name(first),
                STOP_GRACE.as_secs_f64()
            ),
            Some(Kill::Second(second)) if sig == libc::SIGKILL => format!(
                "a second {} received: the FMU's process was killed {doing}",
                signal_name(second)
            ),
            _ => format!(
                "the FMU's process was killed by signal {sig} ({}: {}) {doing}",
                signal_name(sig),
                signal_description(sig)
            ),
        }
    } else {
        format!("the FMU's process ended with wait status {status:#x} {doing}")
    };
    ChildEnd::Abnormal(what)
}

/// `SIGSEGV` for 11, and so on (the signals a crashing or killed process dies of).
fn signal_name(sig: libc::c_int) -> String {
    let name = match sig {
        libc::SIGHUP => "SIGHUP",
        libc::SIGINT => "SIGINT",
        libc::SIGQUIT => "SIGQUIT",
        libc::SIGILL => "SIGILL",
        libc::SIGTRAP => "SIGTRAP",
        libc::SIGABRT => "SIGABRT",
        libc::SIGBUS => "SIGBUS",
        libc::SIGFPE => "SIGFPE",
        libc::SIGKILL => "SIGKILL",
        libc::SIGUSR1 => "SIGUSR1",
        libc::SIGSEGV => "SIGSEGV",
        libc::SIGUSR2 => "SIGUSR2",
        libc::SIGPIPE => "SIGPIPE",
        libc::SIGALRM => "SIGALRM",
        libc::SIGTERM => "SIGTERM",
        libc::SIGXCPU => "SIGXCPU",
        libc::SIGXFSZ => "SIGXFSZ",
        libc::SIGSYS => "SIGSYS",
        _ => return format!("signal {sig}"),
    };
    name.to_string()
}

/// The C library's description ("Segmentation fault", "Aborted").
fn signal_description(sig: libc::c_int) -> String {
    // SAFETY: strsignal returns a NUL-terminated string (or NULL), read at once.
    let p = unsafe { libc::strsignal(sig) };
    if p.is_null() {
        return "unknown signal".into();
    }
    unsafe { std::ffi::CStr::from_ptr(p) }
        .to_string_lossy()
        .into_owned()
}
