//! Parallel Jacobi (issue 32, item 4): in a Jacobi macro step every element steps from the
//! same inputs, so the `fmi2DoStep` calls of different instances are independent and may run
//! on threads. The results are bit-identical to the serial run: each instance sees exactly the
//! calls of the serial run, in the same order (inputs set before the step, outputs read after
//! it, both on the master's thread); only calls to *different* instances overlap in time.
//!
//! FMI 2.0.5 §2.1.1 leaves thread safety across the functions of *one* instance to the
//! caller; an FMU declaring `canBeInstantiatedOnlyOncePerProcess="true"` may keep global
//! state, so a system with such an FMU is stepped serially.
//!
//! The workers live for the whole run (a thread per step would cost ~26 µs, more than a step
//! of the shipped drivetrain); each macro step costs one channel round trip per worker
//! (~3 µs measured on 2026-11-29, ~60 µs on the same kind of virtual machine on 2026-12-01:
//! a wake-up across its processors costs what the machine makes it cost). The elements are
//! assigned to the threads after [`MEASURED`] serial steps, longest measured `fmi2DoStep`
//! time first, each to the least loaded thread (the master's own thread is one of them).
//! Unless `--threads` asked for the threads, the assignment is kept only if the step it gives
//! (the most loaded thread's work plus a measured round trip) is shorter than the serial
//! step; otherwise every element stays on the master's thread, so that the default never
//! makes a run slower than the serial one.

use super::step::{do_step, StepEnd};
use crate::host::instance::Instance;
use std::sync::mpsc::{channel, Receiver, Sender};
use std::time::{Duration, Instant};

/// Serial steps whose `fmi2DoStep` times decide the assignment.
pub const MEASURED: u64 = 32;

/// An instance handed to a worker for one `fmi2DoStep`.
struct Ptr<'a>(*mut Instance<'a>);

// SAFETY: an FMI instance may be called from any thread as long as its calls do not overlap
// (FMI 2.0.5 §2.1.1); the master hands each instance to exactly one thread per step and
// waits for it to come back before it calls the instance again. The instance's logger sink
// is a Mutex and atomics; its activity record is atomics.
unsafe impl Send for Ptr<'_> {}

/// One step's work for a worker: (element, instance) pairs and the step.
struct Job<'a> {
    items: Vec<(usize, Ptr<'a>)>,
    time: f64,
    step: f64,
}

type Done = Vec<(usize, Result<(), StepEnd>)>;

/// The workers of one run; dropping it ends them (their channels close).
pub(super) struct Pool<'a> {
    jobs: Vec<Sender<Job<'a>>>,
    done: Receiver<Done>,
    /// Per element: the thread that steps it (0 = the master's).
    thread_of: Vec<usize>,
    /// Per element: measured `fmi2DoStep` time over the first [`MEASURED`] steps.
    measured: Vec<Duration>,
    /// `--threads` asked for the threads: they are used whatever the measurements say.
    asked: bool,
}

impl<'a> Pool<'a> {
    /// Start `threads − 1` workers in `scope` for the elements named `names`.
    pub(super) fn start<'scope>(
        scope: &'scope std::thread::Scope<'scope, '_>,
        threads: usize,
        asked: bool,
        names: &'scope [String],
    ) -> Pool<'a>
    where
        'a: 'scope,
    {
        let (done_tx, done) = channel::<Done>();
        let mut jobs = Vec::new();
        for _ in 1..threads {
            let (tx, rx) = channel::<Job<'a>>();
            let done_tx = done_tx.clone();
            scope.spawn(move || {
                while let Ok(job) = rx.recv() {
                    let mut out = Vec::with_capacity(job.items.len());
                    for (e, p) in job.items {
                        // SAFETY: see `Ptr`: this thread is the only user of the instance
                        // until it is sent back below.
                        let inst = unsafe { &mut *p.0 };
                        out.push((e, do_step(inst, &names[e], job.time, job.step)));
                    }
                    if done_tx.send(out).is_err() {
                        break;
                    }
                }
            });
            jobs.push(tx);
        }
        Pool {
            jobs,
            done,
            thread_of: vec![0; names.len()],
            measured: vec![Duration::ZERO; names.len()],
            asked,
        }
    }

    /// Record a serial step's `fmi2DoStep` time of element `e`.
    pub(super) fn measure(&mut self, e: usize, took: Duration) {
        self.measured[e] += took;
    }

    /// The time of one round trip to every worker with no work: the median of a few.
    fn round_trip(&self) -> Duration {
        let mut took: Vec<Duration> = (0..9)
            .map(|_| {
                let start = Instant::now();
                let sent = (self.jobs.iter())
                    .filter(|tx| {
                        let empty = Job {
                            items: Vec::new(),
                            time: 0.0,
                            step: 0.0,
                        };
                        tx.send(empty).is_ok()
                    })
                    .count();
                for _ in 0..sent {
                    let _ = self.done.recv();
                }
                start.elapsed()
            })
            .collect();
        took.sort();
        took[took.len() / 2]
    }

    /// Assign the elements to the threads from the measured times (longest first, each to
    /// the least loaded thread); unless `--threads` asked for them, back to the master's
    /// thread alone when that step would not be shorter than the serial one (module doc).
    pub(super) fn assign(&mut self) {
        let threads = self.jobs.len() + 1;
        let mut order: Vec<usize> = (0..self.measured.len()).collect();
        order.sort_by(|&a, &b| self.measured[b].cmp(&self.measured[a]).then(a.cmp(&b)));
        let mut load = vec![Duration::ZERO; threads];
        for e in order {
            let t = (0..threads).min_by_key(|&t| (load[t], t)).unwrap_or(0);
            load[t] += self.measured[e];
            self.thread_of[e] = t;
        }
        if self.asked {
            return;
        }
        // Over the measured steps: the serial work against the busiest thread's plus a
        // round trip per step.
        let serial: Duration = self.measured.iter().sum();
        let busiest = load.iter().copied().max().unwrap_or_default();
        let parallel = busiest + self.round_trip() * MEASURED as u32;
        if parallel >= serial {
            self.thread_of.fill(0);
        }
    }

    /// `fmi2DoStep` of every element from `time` by `step`, the elements of each worker on
    /// its thread and the others here; the results per element.
    pub(super) fn step(
        &self,
        insts: &mut [Instance<'a>],
        names: &[String],
        time: f64,
        step: f64,
    ) -> Vec<Option<Result<(), StepEnd>>> {
        let n = insts.len();
        let base = insts.as_mut_ptr();
        let mut results: Vec<Option<Result<(), StepEnd>>> = (0..n).map(|_| None).collect();
        let mut sent = 0;
        for (w, tx) in self.jobs.iter().enumerate() {
            let items: Vec<(usize, Ptr<'a>)> = (0..n)
                .filter(|&e| self.thread_of[e] == w + 1)
                // SAFETY: e < n; the pointers of different elements do not overlap, and the
                // slice is not used through `insts` until every worker has answered.
                .map(|e| (e, Ptr(unsafe { base.add(e) })))
                .collect();
            if items.is_empty() {
                continue;
            }
            if tx.send(Job { items, time, step }).is_ok() {
                sent += 1;
            }
        }
        for e in (0..n).filter(|&e| self.thread_of[e] == 0) {
            // SAFETY: as above; element e is stepped by this thread only.
            let inst = unsafe { &mut *base.add(e) };
            results[e] = Some(do_step(inst, &names[e], time, step));
        }
        for _ in 0..sent {
            if let Ok(done) = self.done.recv() {
                for (e, r) in done {
                    results[e] = Some(r);
                }
            }
        }
        results
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The default keeps the threads only where they shorten the step: elements whose
    /// measured steps took a nanosecond stay on the master's thread (any handoff costs more),
    /// elements of a second each go to both threads; `--threads` keeps them on threads
    /// whatever the measurements say.
    #[test]
    fn threads_are_kept_only_where_they_pay_unless_asked_for() {
        let names: Vec<String> = (0..3).map(|e| format!("e{e}")).collect();
        std::thread::scope(|s| {
            let assigned = |asked: bool, each: Duration| {
                let mut pool = Pool::start(s, 2, asked, &names);
                for e in 0..names.len() {
                    pool.measure(e, each);
                }
                pool.assign();
                pool.thread_of.clone()
            };
            let tiny = Duration::from_nanos(1);
            assert_eq!(assigned(false, tiny), vec![0, 0, 0]);
            assert_eq!(assigned(false, Duration::from_secs(1)), vec![0, 1, 0]);
            assert_eq!(assigned(true, tiny), vec![0, 1, 0]);
        });
    }
}
