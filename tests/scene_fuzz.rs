//! Scene-mutation fuzzer (issue 17, acceptance 3): every shipped scene (`fmu/*/scene.toml`:
//! single pairs, geometry, helical, Bugaru, drivetrains) is mutated at random, deterministically
//! from a seed, and run through the path of `geardyn simulate` (scene file → load → validate →
//! limits → streamed CSV, [`geardyn::commands::simulate::simulate`]). Each mutation must end in a result
//! or a message: no panic (caught), no hang (a watchdog bounds every mutation), and after an
//! error neither the output nor its `.partial` sibling may exist.
//!
//! Runs are kept short without hiding the mutation: the stop time is capped (1 ms) only when
//! the mutation did not touch `solver.stop_time` or `solver.output_interval`; a mutated stop
//! time or interval runs as mutated and must be refused by the run limits or finish within
//! them. The limits are the library's [`RunLimits`], set low here as `--max-rows` and
//! `--max-periods` would set them.
//!
//! Issue 34 extended it to every shipped scene: the FMU scenes (element scenes through the
//! element FMU's model: load, initialise, three steps, every variable read), the examples
//! (`examples/**/*.toml`, the Python study spec excepted) and the test scenes
//! (`tests/scenes`); and to the work budget ([`RunLimits::work_budget`]): a run that succeeds
//! must have stayed within it, so one beyond it ends with a message.
//!
//! `scene_mutations` (1e4) runs in the normal test run; `scene_mutations_long` (1e5) is
//! `#[ignore]`d and run by `bash scripts/stress.sh`.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use geardyn::commands::simulate::{simulate, SimulateOptions};
use geardyn::scene::Scene;
use geardyn::simulation::RunLimits;
use toml::Value;

#[path = "common/rng.rs"]
mod rng;
use rng::SplitMix64 as Rng;

/// A step into a TOML document: a key of a table or an index of an array.
#[derive(Clone, Debug, PartialEq)]
enum Step {
    Key(String),
    Index(usize),
}

/// Every value's path in the document (tables and arrays included, the root excluded).
fn paths(v: &Value, prefix: &mut Vec<Step>, out: &mut Vec<Vec<Step>>) {
    match v {
        Value::Table(t) => {
            for (k, child) in t {
                prefix.push(Step::Key(k.clone()));
                out.push(prefix.clone());
                paths(child, prefix, out);
                prefix.pop();
            }
        }
        Value::Array(a) => {
            for (i, child) in a.iter().enumerate() {
                prefix.push(Step::Index(i));
                out.push(prefix.clone());
                paths(child, prefix, out);
                prefix.pop();
            }
        }
        _ => {}
    }
}

fn get_mut<'a>(v: &'a mut Value, path: &[Step]) -> Option<&'a mut Value> {
    let mut cur = v;
    for s in path {
        cur = match (s, cur) {
            (Step::Key(k), Value::Table(t)) => t.get_mut(k)?,
            (Step::Index(i), Value::Array(a)) => a.get_mut(*i)?,
            _ => return None,
        };
    }
    Some(cur)
}

/// Strings a scene uses as kinds, laws, methods and names: swapping one for another changes
/// what a table means without touching its keys.
const WORDS: &[&str] = &[
    "",
    "constant",
    "rectangular",
    "trapezoidal",
    "fourier",
    "table",
    "geometry",
    "helical",
    "linear",
    "contact_loss",
    "backlash",
    "auto",
    "rk",
    "exact",
    "dp5",
    "dop853",
    "pairs",
    "lumped",
    "per_pair",
    "compliant",
    "rigid",
    "static",
    "always",
    "in_contact",
    "cw",
    "ccw",
    "pinion",
    "gear",
    "idler",
    "nan",
    "inf",
    "-1e300",
    "é\u{0}",
];

/// Extreme numbers: zero, signs, the edges of the double range, NaN, infinities, huge integers.
fn extreme_number(rng: &mut Rng, x: f64) -> Value {
    match rng.below(22) {
        0 => Value::Float(0.0),
        1 => Value::Float(-x),
        2 => Value::Float(f64::NAN),
        3 => Value::Float(f64::INFINITY),
        4 => Value::Float(f64::NEG_INFINITY),
        5 => Value::Float(1e300),
        6 => Value::Float(-1e300),
        7 => Value::Float(1e-300),
        8 => Value::Float(f64::MAX),
        9 => Value::Float(f64::MIN_POSITIVE / 4.0),
        10 => Value::Integer(i64::MAX),
        11 => Value::Integer(i64::MIN),
        12 => Value::Integer(0),
        13 => Value::Integer(-1),
        14 => Value::Float(x * 1e6),
        15 => Value::Float(x * 1e-6),
        16 => Value::Float(x * 1e12),
        17 => Value::Float(x * 1e-12),
        18 => Value::Float(9.007_199_254_740_993e15),
        19 => Value::String(format!("{x}")),
        20 => Value::Float(x * (1.0 + 1e-15)),
        _ => Value::Float(1.0 - x),
    }
}

/// Mutates the value at `path` (or the table holding it); returns a description.
fn mutate_at(doc: &mut Value, path: &[Step], rng: &mut Rng) -> String {
    let (parent_path, last) = path.split_at(path.len() - 1);
    let op = rng.below(10);
    // Structural mutations of the parent: drop or duplicate the entry, add an unknown key.
    if op == 0 {
        if let Some(parent) = get_mut(doc, parent_path) {
            match (parent, &last[0]) {
                (Value::Table(t), Step::Key(k)) => {
                    t.remove(k);
                    return format!("drop {path:?}");
                }
                // (An earlier mutation may have shortened the array.)
                (Value::Array(a), Step::Index(i)) if *i < a.len() => {
                    if rng.below(2) == 0 {
                        a.remove(*i);
                        return format!("drop {path:?}");
                    }
                    let copy = a[*i].clone();
                    a.insert(*i, copy);
                    return format!("duplicate {path:?}");
                }
                _ => {}
            }
        }
    }
    if op == 1 {
        if let Some(Value::Table(t)) = get_mut(doc, parent_path) {
            t.insert("unexpected_key".into(), Value::Float(1.0));
            return format!("unknown key beside {path:?}");
        }
    }
    let Some(v) = get_mut(doc, path) else {
        return "no-op".into();
    };
    let new = match v {
        Value::Float(x) => extreme_number(rng, *x),
        Value::Integer(i) => extreme_number(rng, *i as f64),
        Value::String(_) => match rng.below(4) {
            0 => Value::Float(rng.next() as f64),
            _ => Value::String(rng.pick(WORDS).to_string()),
        },
        Value::Boolean(b) => match rng.below(2) {
            0 => Value::Boolean(!*b),
            _ => Value::String("yes".into()),
        },
        Value::Array(a) => match rng.below(6) {
            0 => Value::Array(Vec::new()),
            // A huge list of numbers (of tables: a few hundred, which the TOML writer can
            // still format quickly): allocation sizes must be checked before allocating.
            1 => {
                let item = a.first().cloned().unwrap_or(Value::Float(1e-9));
                let n = if item.is_table() {
                    300
                } else {
                    [300, 5_000, 100_000][rng.below(3)]
                };
                Value::Array(vec![item; n])
            }
            2 => {
                let mut b = a.clone();
                b.extend(a.iter().cloned());
                Value::Array(b)
            }
            3 => Value::Float(1.0),
            4 => {
                let mut b = a.clone();
                b.truncate(1);
                Value::Array(b)
            }
            _ => {
                let mut b = a.clone();
                b.reverse();
                Value::Array(b)
            }
        },
        Value::Table(_) => match rng.below(3) {
            0 => Value::Table(Default::default()),
            1 => Value::Float(0.0),
            _ => Value::String("table".into()),
        },
        Value::Datetime(_) => Value::Float(0.0),
    };
    *v = new;
    format!("set {path:?}")
}

/// Whether a path is the stop time or the output interval (or a table holding them).
fn touches_run_length(path: &[Step]) -> bool {
    matches!(path.first(), Some(Step::Key(k)) if k == "solver")
        && (path.len() == 1
            || matches!(&path[1], Step::Key(k) if k == "stop_time" || k == "output_interval"))
}

/// One mutated scene text: 1 to 3 mutations; the stop time is capped unless a mutation
/// touched the run length.
fn mutated_scene(base: &Value, rng: &mut Rng) -> (String, String) {
    let mut doc = base.clone();
    let mut all = Vec::new();
    paths(&doc, &mut Vec::new(), &mut all);
    let count = 1 + rng.below(3);
    let mut touched = false;
    let mut what = Vec::new();
    for _ in 0..count {
        let path = rng.pick(&all).clone();
        touched |= touches_run_length(&path);
        what.push(mutate_at(&mut doc, &path, rng));
    }
    if !touched {
        if let Value::Table(t) = &mut doc {
            let solver = t
                .entry("solver")
                .or_insert_with(|| Value::Table(Default::default()));
            if let Value::Table(s) = solver {
                s.insert("stop_time".into(), Value::Float(1e-3));
                s.insert("output_interval".into(), Value::Float(2e-5));
            }
        }
    }
    let mut text = toml::to_string(&doc).unwrap_or_default();
    // Key duplication is a text-level mutation (a TOML table cannot hold it).
    if rng.below(40) == 0 {
        if let Some(line) = text.lines().find(|l| l.contains(" = ")).map(str::to_owned) {
            text = format!("{line}\n{text}");
            what.push(format!("duplicate key line {line:?}"));
        }
    }
    (text, what.join("; "))
}

/// Every `.toml` file below `dir` (recursively), sorted.
fn toml_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let mut paths: Vec<PathBuf> = entries.filter_map(|e| Some(e.ok()?.path())).collect();
    paths.sort();
    for p in paths {
        if p.is_dir() {
            toml_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "toml") {
            out.push(p);
        }
    }
}

/// How a shipped file is run: through `geardyn simulate`, or (an `[element]` scene, an
/// FMU-only model: docs/elements.md) through the element FMU's model.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Simulate,
    Element,
}

/// A Python study spec (`geardyn-study`, docs/python.md: a `scene` path and `parameter`
/// grid), not a scene: its mutations are in the Python fuzzer (tests/python).
fn is_study(doc: &toml::Table) -> bool {
    doc.get("scene").is_some_and(Value::is_str) && doc.contains_key("parameter")
}

/// Every shipped scene, parsed: the FMU scenes (`fmu/*/scene.toml`, element scenes
/// included), the examples (`examples/**/*.toml`) and the test scenes (`tests/scenes`).
fn shipped() -> Vec<(String, Kind, Value)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files: Vec<PathBuf> = Vec::new();
    toml_files(&root.join("fmu"), &mut files);
    files.retain(|p| p.file_name().is_some_and(|n| n == "scene.toml"));
    toml_files(&root.join("examples"), &mut files);
    toml_files(&root.join("tests/scenes"), &mut files);
    let mut scenes = Vec::new();
    for p in files {
        let text = std::fs::read_to_string(&p).expect("shipped scene");
        let name = p.strip_prefix(root).unwrap_or(&p).display().to_string();
        let doc: toml::Table = text
            .parse()
            .unwrap_or_else(|e| panic!("{name}: shipped file is not TOML: {e}"));
        if is_study(&doc) {
            continue;
        }
        let kind = if geardyn::fmu::element::is_element_text(&text) {
            Kind::Element
        } else {
            Kind::Simulate
        };
        scenes.push((name, kind, Value::Table(doc)));
    }
    scenes
}

#[test]
fn every_shipped_scene_is_fuzzed() {
    let scenes = shipped();
    let count = |dir: &str| scenes.iter().filter(|(n, ..)| n.starts_with(dir)).count();
    // fmu/: 15 scenes (4 of them elements); examples/: 9 scenes (and one study spec);
    // tests/scenes: 6.
    assert!(count("fmu/") >= 15, "{}", count("fmu/"));
    assert!(count("examples/") >= 9, "{}", count("examples/"));
    assert!(count("tests/scenes/") >= 6, "{}", count("tests/scenes/"));
    assert!(scenes.iter().filter(|s| s.1 == Kind::Element).count() >= 4);
}

/// Runs a mutated element scene as its FMU would be run: load (parse and validate), set up,
/// initialise, a few steps, every variable read. `Ok` when it ran, `Err` with the message of
/// the first refusal.
fn run_element(text: &str) -> Result<(), String> {
    use geardyn::fmi::model::StepFailure;
    let mut loaded = geardyn::fmu::element::load(text, "fuzz", "guid".into())?;
    let m = &mut loaded.model;
    m.setup_experiment(0.0, Some(1e-2), None)?;
    m.exit_initialization()?;
    let vrs: Vec<u32> = m.variables().iter().map(|v| v.value_reference).collect();
    let mut t = 0.0;
    for h in [1e-4, 1e-3, 5e-3] {
        m.do_step(t, h).map_err(|f| match f {
            StepFailure::Discard { reason, .. } => reason,
            other => format!("{other:?}"),
        })?;
        t += h;
        for &vr in &vrs {
            if let Ok(v) = m.get_real(vr) {
                if !v.is_finite() {
                    return Err(format!("vr {vr} = {v} after a step that returned OK"));
                }
            }
        }
    }
    Ok(())
}

#[derive(Default)]
struct Counts {
    ok: AtomicU64,
    refused: AtomicU64,
    panics: AtomicU64,
    partial: AtomicU64,
}

/// The limits of the fuzz runs: low, so that a mutation towards a long run is refused quickly
/// (the same checks as the defaults, with other numbers).
const FUZZ_LIMITS: RunLimits = RunLimits {
    max_rows: 20_000,
    max_mesh_periods: 2e4,
    max_mode_periods: 2e4,
    work_budget: Some(FUZZ_WORK_BUDGET),
};

/// The work budget of the fuzz runs ([`RunLimits::work_budget`], work units): a run that
/// succeeds must have stayed within it, one beyond it must have been stopped with a message.
/// The propagators stop at the step where the scope's budget is spent (`solve::work`), so a
/// finished run may pass it only by its last step's guard work:
/// [`FUZZ_WORK_SLACK`].
const FUZZ_WORK_BUDGET: f64 = 1e8;
const FUZZ_WORK_SLACK: f64 = 1.01;

/// Bound on one mutation's wall time: generous for a loaded machine, far below a hang.
const HANG_BOUND: Duration = Duration::from_secs(20);

fn fuzz(mutations: u64, seed: u64) {
    let scenes = Arc::new(shipped());
    let counts = Arc::new(Counts::default());
    let failures = Arc::new(Mutex::new(Vec::<String>::new()));
    let next = Arc::new(AtomicU64::new(0));
    let workers = std::thread::available_parallelism().map_or(2, |n| n.get().min(4));
    let dir = tempfile::tempdir().expect("temp dir");
    // Per worker: the start time (ms since `t0`, 0 = idle) and the scene of the mutation it
    // runs, for the watchdog.
    let t0 = Instant::now();
    let busy: Arc<Vec<AtomicU64>> = Arc::new((0..workers).map(|_| AtomicU64::new(0)).collect());
    let current: Arc<Vec<Mutex<String>>> =
        Arc::new((0..workers).map(|_| Mutex::new(String::new())).collect());
    let done = Arc::new(AtomicUsize::new(0));
    // Panics are counted, not printed 1e4 times.
    let hook = std::panic::take_hook();
    if std::env::var_os("SCENE_FUZZ_TRACE").is_none() {
        std::panic::set_hook(Box::new(|_| {}));
    }
    let handles: Vec<_> = (0..workers)
        .map(|w| {
            let (scenes, counts, failures, next, busy, current, done) = (
                scenes.clone(),
                counts.clone(),
                failures.clone(),
                next.clone(),
                busy.clone(),
                current.clone(),
                done.clone(),
            );
            let wdir: PathBuf = dir.path().join(format!("w{w}"));
            std::fs::create_dir_all(&wdir).unwrap();
            std::thread::spawn(move || {
                // Counts the worker as done however it ends, so the watchdog never waits for
                // a worker that is gone.
                struct Done(Arc<AtomicUsize>);
                impl Drop for Done {
                    fn drop(&mut self) {
                        self.0.fetch_add(1, Ordering::SeqCst);
                    }
                }
                let _done = Done(done);
                loop {
                    let mut i = next.fetch_add(1, Ordering::Relaxed);
                    if i >= mutations {
                        break;
                    }
                    // Debugging aid: SCENE_FUZZ_ONLY=i replays mutation i.
                    if let Some(only) = std::env::var("SCENE_FUZZ_ONLY")
                        .ok()
                        .and_then(|v| v.parse().ok())
                    {
                        if i > 0 {
                            break;
                        }
                        i = only;
                    }
                    let mut rng = Rng(seed ^ i.wrapping_mul(0xD6E8_FEB8_6659_FD93));
                    let (name, kind, base) = &scenes[rng.below(scenes.len())];
                    let Ok((text, what)) =
                        std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                            mutated_scene(base, &mut rng)
                        }))
                    else {
                        failures
                            .lock()
                            .unwrap()
                            .push(format!("fuzzer bug: generating mutation {i} panicked"));
                        continue;
                    };
                    *current[w].lock().unwrap() = format!("mutation {i} of {name}: {what}");
                    if std::env::var_os("SCENE_FUZZ_TRACE").is_some() {
                        eprintln!("mutation {i} of {name}: {what}");
                        std::fs::write(format!("/tmp/scene_fuzz_{i}.toml"), &text).unwrap();
                    }
                    busy[w].store(t0.elapsed().as_millis() as u64 + 1, Ordering::SeqCst);
                    let scene_path = wdir.join("scene.toml");
                    std::fs::write(&scene_path, &text).unwrap();
                    let out = wdir.join("out.csv");
                    let partial = wdir.join(".out.csv.partial");
                    let result = std::panic::catch_unwind(|| {
                        if *kind == Kind::Element {
                            return run_element(&text).map(|()| 0.0);
                        }
                        let scene = Scene::from_path(&scene_path)?;
                        let opts = SimulateOptions {
                            limits: FUZZ_LIMITS,
                            ..Default::default()
                        };
                        simulate(scene, &opts, &out).map(|r| r.work)
                    });
                    let started = busy[w].swap(0, Ordering::SeqCst);
                    if std::env::var_os("SCENE_FUZZ_SLOW").is_some() {
                        let ms = t0.elapsed().as_millis() as u64 + 1 - started;
                        if ms > 100 {
                            eprintln!("slow {ms} ms: mutation {i} of {name}: {what}");
                        }
                    }
                    let succeeded = matches!(result, Ok(Ok(_)));
                    match result {
                        Ok(Ok(work)) => {
                            counts.ok.fetch_add(1, Ordering::Relaxed);
                            if work > FUZZ_WORK_BUDGET * FUZZ_WORK_SLACK {
                                failures.lock().unwrap().push(format!(
                                    "over its work budget without a message ({work}): \
                                     mutation {i} of {name}: {what}"
                                ));
                            }
                            if *kind == Kind::Simulate && std::fs::remove_file(&out).is_err() {
                                failures
                                    .lock()
                                    .unwrap()
                                    .push(format!("no output after success: mutation {i}"));
                            }
                        }
                        Ok(Err(msg)) => {
                            counts.refused.fetch_add(1, Ordering::Relaxed);
                            if msg.trim().is_empty() {
                                failures
                                    .lock()
                                    .unwrap()
                                    .push(format!("empty message: mutation {i} of {name}: {what}"));
                            }
                        }
                        Err(_) => {
                            counts.panics.fetch_add(1, Ordering::Relaxed);
                            failures
                                .lock()
                                .unwrap()
                                .push(format!("panic: mutation {i} of {name}: {what}\n{text}"));
                        }
                    }
                    if partial.exists() || (!succeeded && out.exists()) {
                        counts.partial.fetch_add(1, Ordering::Relaxed);
                        failures
                            .lock()
                            .unwrap()
                            .push(format!("partial output: mutation {i} of {name}: {what}"));
                        let _ = std::fs::remove_file(&partial);
                        let _ = std::fs::remove_file(&out);
                    }
                }
            })
        })
        .collect();
    // Watchdog: a worker busy beyond the bound is a hang; it cannot be stopped, so it is
    // reported and the test fails without waiting for it.
    let mut hangs = Vec::new();
    while done.load(Ordering::SeqCst) + hangs.len() < workers {
        std::thread::sleep(Duration::from_millis(50));
        let now = t0.elapsed().as_millis() as u64;
        for w in 0..workers {
            let start = busy[w].load(Ordering::SeqCst);
            if start > 0 && now + 1 - start > HANG_BOUND.as_millis() as u64 && !hangs.contains(&w) {
                hangs.push(w);
                failures
                    .lock()
                    .unwrap()
                    .push(format!("hang: {}", current[w].lock().unwrap()));
            }
        }
    }
    if hangs.is_empty() {
        for h in handles {
            if h.join().is_err() {
                failures
                    .lock()
                    .unwrap()
                    .push("fuzzer bug: a worker panicked".into());
            }
        }
    }
    std::panic::set_hook(hook);
    let c = &*counts;
    let line = format!(
        "scene fuzzer (seed {seed:#x}): {mutations} mutations, {} ok, {} refused, {} panics, {} hangs, {} partial, {:.1} s",
        c.ok.load(Ordering::Relaxed),
        c.refused.load(Ordering::Relaxed),
        c.panics.load(Ordering::Relaxed),
        hangs.len(),
        c.partial.load(Ordering::Relaxed),
        t0.elapsed().as_secs_f64()
    );
    println!("{line}");
    let failures = failures.lock().unwrap();
    for f in failures.iter().take(50) {
        eprintln!("{}", f.lines().next().unwrap_or(""));
    }
    assert!(
        failures.is_empty() && hangs.is_empty(),
        "{line}\n{}",
        failures
            .iter()
            .take(10)
            .cloned()
            .collect::<Vec<_>>()
            .join("\n")
    );
    assert_eq!(
        c.ok.load(Ordering::Relaxed) + c.refused.load(Ordering::Relaxed),
        mutations,
        "{line}"
    );
    // The fuzzer must reach both outcomes, or it is not exercising the path.
    assert!(c.ok.load(Ordering::Relaxed) > mutations / 20, "{line}");
    assert!(c.refused.load(Ordering::Relaxed) > mutations / 20, "{line}");
}

#[test]
fn scene_mutations() {
    // Debugging aids: SCENE_FUZZ_N and SCENE_FUZZ_SEED (hex) replay other runs.
    let n = std::env::var("SCENE_FUZZ_N").map_or(10_000, |v| v.parse().unwrap());
    let seed = std::env::var("SCENE_FUZZ_SEED").map_or(0x05CE_7E17, |v| {
        u64::from_str_radix(v.trim_start_matches("0x"), 16).unwrap()
    });
    fuzz(n, seed);
}

#[test]
#[ignore = "long variant (1e5 mutations): bash scripts/stress.sh"]
fn scene_mutations_long() {
    fuzz(100_000, 0x10C6_5CE7);
}
