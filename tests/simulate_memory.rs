//! Issue 17 (item 3) and issue 20 (item 5, acceptance 4): the memory of `geardyn simulate` is
//! flat in the run length. Measured as a property, not a time: the peak of live heap bytes
//! (a counting allocator wraps the system one in this test binary) and the writer's peak of
//! buffered bytes, for a run 10× longer at the same dense output grid (one row per mesh
//! period), for the single pair (1e5 against 1e6 mesh periods) and a drivetrain (2e3 against
//! 2e4). Holding the rows in memory, as `simulate` did before, costs about 60 bytes per row
//! and fails this by far.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use geardyn::commands::simulate::{simulate, SimulateOptions};
use geardyn::scene::Scene;

struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            let live = LIVE.fetch_add(layout.size(), Ordering::Relaxed) + layout.size();
            PEAK.fetch_max(live, Ordering::Relaxed);
        }
        p
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) };
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Runs `scene` for `periods` mesh periods with one output row per period; returns the peak
/// of live heap bytes above the level before the run, the writer's peak buffered bytes and
/// the rows written.
fn peak_bytes(scene: &str, periods: f64) -> (usize, usize, u64) {
    let s = Scene::example(scene).unwrap();
    let period = match s.pair() {
        Some(p) => geardyn::simulation::Simulation::new(&p)
            .unwrap()
            .model()
            .mesh_period(),
        None => geardyn::model::train::TrainSimulation::new(&s)
            .unwrap()
            .model()
            .mesh_period(0),
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.csv");
    let mut opts = SimulateOptions {
        stop_time: Some(periods * period),
        output_interval: Some(period),
        ..Default::default()
    };
    // The summary's work is charged to the run's budget (issue 31): a million mesh periods
    // with it need more than the default run budget.
    opts.limits.work_budget = Some(1e11);
    let base = LIVE.load(Ordering::Relaxed);
    PEAK.store(base, Ordering::Relaxed);
    let report = simulate(s, &opts, &out).unwrap();
    let peak = PEAK.load(Ordering::Relaxed) - base;
    (peak, report.peak_buffered_bytes, report.rows)
}

/// One test (the allocator counters are global): pair, then drivetrain.
#[test]
fn memory_is_flat_in_run_length() {
    for (scene, short) in [("spur_pair", 1e5), ("idler_gearset", 2e3)] {
        let (heap_short, buf_short, rows_short) = peak_bytes(scene, short);
        let (heap_long, buf_long, rows_long) = peak_bytes(scene, 10.0 * short);
        println!(
            "{scene}: {rows_short} rows: peak heap {heap_short} B, writer buffer {buf_short} B; \
             {rows_long} rows: peak heap {heap_long} B, writer buffer {buf_long} B"
        );
        assert!(
            rows_long >= 10 * rows_short - 10,
            "{rows_long} vs {rows_short}"
        );
        assert!(
            (heap_long as f64) <= 1.1 * heap_short as f64,
            "{scene}: peak heap {heap_long} B for {rows_long} rows vs {heap_short} B for {rows_short}"
        );
        assert!(
            buf_long <= 64 * 1024 && buf_short <= 64 * 1024,
            "{scene}: writer buffered {buf_short} / {buf_long} B"
        );
    }
}
