//! The work budget (issue 34 items 1 and 6, `docs/fmu.md` "Work budget"): every FMI call ends
//! within its budget or is refused naming the likely cause, every run of `geardyn simulate`
//! too; the rebuild after `fmi2SetReal` applies the scene checks of `simulate` (the mass
//! spread that kept nalgebra's SVD from converging); shipped FMUs and scenes stay far within
//! their budgets.

#[path = "common/cpu.rs"]
mod cpu;

use std::path::Path;
use std::process::Command;
use std::time::Duration;

use cpu::thread_cpu;
use geardyn::fmi::model::{CoSimModel, StepFailure};
use geardyn::scene::PairScene;
use geardyn::simulation::budget::{DEFAULT_CALL_BUDGET, DEFAULT_RUN_BUDGET};
use geardyn::simulation::Simulation;

fn fmu_dir(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fmu").join(name)
}

fn model(name: &str) -> Box<dyn CoSimModel> {
    geardyn::fmu::entry::load_scene(&fmu_dir(name).join("scene.toml"))
        .unwrap()
        .model
}

fn vr(m: &dyn CoSimModel, name: &str) -> u32 {
    m.variables()
        .iter()
        .find(|v| v.name == name)
        .unwrap_or_else(|| panic!("no variable {name}"))
        .value_reference
}

/// The calls of issue 34 that took seconds (8.6 s, 55.6 s, 2.4 s of CPU): each now ends
/// within the call budget with fmi2Discard, at a valid state, naming the budget and a likely
/// cause, in well under a second of CPU.
#[test]
fn the_slow_calls_end_within_the_budget_naming_a_cause() {
    for (scene, name, value, h) in [
        ("idler_gearset", "operating.input_speed", 1e9, 1.72e-4),
        ("spur_pair", "operating.load_torque", 1e300, 23.56),
        ("spur_stage", "input.torque", 1e7, 1e-2),
        ("spur_stage", "input.torque", 1e9, 1e-3),
        ("spur_stage", "input.torque", 1e11, 1e-3),
    ] {
        let mut m = model(scene);
        let cpu = thread_cpu();
        m.set_real(vr(&*m, name), value).unwrap();
        m.lifecycle_mut().initialized = true;
        let result = m.do_step(0.0, h);
        let took = thread_cpu() - cpu;
        let case = format!("{scene} {name} = {value:e}, step {h:e}");
        match result {
            Err(StepFailure::Discard {
                reason,
                reached,
                terminate,
            }) => {
                assert!(
                    reason.contains(&format!("work budget of {DEFAULT_CALL_BUDGET:e} units"))
                        && reason.contains("likely cause"),
                    "{case}: {reason}"
                );
                assert!(
                    reached >= 0.0 && reached < h && !terminate,
                    "{case}: {reached}"
                );
            }
            other => panic!("{case}: {other:?}"),
        }
        assert!(took < Duration::from_secs(1), "{case}: {took:?} of CPU");
        // A raised budget lets the same call go further (the budget is what stopped it).
        let mut m = model(scene);
        m.set_real(vr(&*m, "solver.work_budget"), 4.0 * DEFAULT_CALL_BUDGET)
            .unwrap();
        m.set_real(vr(&*m, name), value).unwrap();
        m.lifecycle_mut().initialized = true;
        let further = match m.do_step(0.0, h) {
            Err(StepFailure::Discard { reached, .. }) => reached,
            Ok(()) => h,
            Err(e) => panic!("{case}: {e:?}"),
        };
        assert!(further > 0.0, "{case}");
    }
}

/// A budget is a finite number >= 1; anything else is refused where it is set.
#[test]
fn the_budget_parameter_is_checked() {
    let mut m = model("spur_pair");
    let k = vr(&*m, "solver.work_budget");
    assert_eq!(m.get_real(k).unwrap(), DEFAULT_CALL_BUDGET);
    for bad in [0.0, 0.5, -1.0, f64::NAN, f64::INFINITY] {
        let e = m.set_real(k, bad).unwrap_err();
        assert!(e.contains("solver.work_budget"), "{bad}: {e}");
    }
    m.set_real(k, 1e9).unwrap();
    assert_eq!(m.get_real(k).unwrap(), 1e9);
}

/// Issue 34 item 1: `pinion.inertia` of 1e-160 … 1e-156 hung `fmi2SetReal` in nalgebra's SVD
/// (2.54e-157 for more than 360 s). The rebuild now applies the mass-spread check `simulate`
/// makes, naming the values; neighbouring values are refused the same way.
#[test]
fn a_tiny_inertia_is_refused_like_simulate_refuses_it() {
    for x in [1e-160, 2.54e-157, 1e-158, 1e-156, 1e-140, 1e-200] {
        let mut m = model("idler_gearset");
        let k = vr(&*m, "pinion.inertia");
        let e = m.set_real(k, x).unwrap_err();
        assert!(
            e.contains("'pinion.inertia'") && e.contains("a ratio above 1e10"),
            "{x:e}: {e}"
        );
        // Nothing changed.
        assert_eq!(m.get_real(k).unwrap(), 0.002621);
    }
}

/// The shipped FMUs' whole default experiments fit in one call with a quarter of the default
/// budget (the budget's documented margin).
#[test]
fn shipped_fmus_run_their_experiment_in_one_call_within_a_quarter_budget() {
    let mut checked = 0;
    for dir in std::fs::read_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join("fmu")).unwrap() {
        let name = dir.unwrap().file_name().to_string_lossy().into_owned();
        let loaded = geardyn::fmu::entry::load_scene(&fmu_dir(&name).join("scene.toml")).unwrap();
        let mut m = loaded.model;
        let Some(k) = m
            .variables()
            .iter()
            .find(|v| v.name == "solver.work_budget")
            .map(|v| v.value_reference)
        else {
            continue; // an element FMU: no gear driver
        };
        m.set_real(k, DEFAULT_CALL_BUDGET / 4.0).unwrap();
        m.lifecycle_mut().initialized = true;
        let stop = loaded.info.default_experiment.stop_time;
        m.do_step(0.0, stop)
            .unwrap_or_else(|e| panic!("{name}: {e:?}"));
        checked += 1;
    }
    assert!(checked >= 11, "{checked}");
}

/// The exact loop's metered and unmetered forms (item 6: a run without a budget pays nothing
/// for the meter) compute the same run: a bounded and an unbounded simulation agree bit for
/// bit in state and counters, sampled on a grid and in one advance, on the shipped pair (it
/// separates every mesh period: crossing searches, recurring decisions, events) and in linear
/// contact (the composite products of guard-free sequences).
#[test]
fn a_bounded_run_equals_the_unbounded_one_bit_for_bit() {
    let spur = std::fs::read_to_string(fmu_dir("spur_pair").join("scene.toml")).unwrap();
    let linear = spur
        .replace("contact = \"backlash\"", "contact = \"linear\"")
        .replace("backlash = 1.0e-4", "");
    assert_ne!(spur, linear);
    for (name, text) in [("spur_pair", &spur), ("linear contact", &linear)] {
        let scene = PairScene::from_toml_str(text, name).unwrap();
        let run = |budget: Option<f64>, grid: bool| {
            let mut sim = Simulation::new(&scene).unwrap();
            assert_eq!(sim.method_name(), "exact", "{name}");
            if let Some(limit) = budget {
                sim.set_work_budget(limit).unwrap();
            }
            assert_eq!(sim.work_limit(), budget);
            if grid {
                for k in 1..=500 {
                    sim.advance_to(k as f64 * 1e-4).unwrap();
                }
            } else {
                sim.advance_to(0.05).unwrap();
            }
            let s = sim.stats();
            let counters = [
                s.steps,
                s.events,
                s.stops,
                s.guard_evals,
                s.recurring_segments,
            ];
            (sim.state().map(f64::to_bits), counters)
        };
        for grid in [true, false] {
            let (unbounded, bounded) = (run(None, grid), run(Some(1e12), grid));
            assert!(
                unbounded.1[1] > 0 || name == "linear contact",
                "{name}: no events"
            );
            assert_eq!(unbounded, bounded, "{name}, on a grid: {grid}");
        }
    }
}

/// `geardyn simulate` stops a run over its budget with the message naming the likely cause:
/// `geometry_stage` at 1e6 rad/s (contact chatter; the default run budget) and
/// `spur_stage_speed` with a port stiffness of 9e15 N·m/rad (stiffness; a budget set in the
/// scene), where before they ground on for seconds without a word.
#[test]
fn simulate_stops_at_its_budget_naming_the_cause() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("work_budget");
    std::fs::create_dir_all(&dir).unwrap();
    let edit = |scene: &str, from: &str, to: &str| {
        let text = std::fs::read_to_string(fmu_dir(scene).join("scene.toml")).unwrap();
        assert!(text.contains(from), "{scene}: {from}");
        let path = dir.join(format!("{scene}.toml"));
        std::fs::write(&path, text.replacen(from, to, 1)).unwrap();
        path
    };
    for (path, budget, cause) in [
        (
            edit(
                "geometry_stage",
                "pinion_speed = 304.0",
                "pinion_speed = 1.0e6",
            ),
            DEFAULT_RUN_BUDGET,
            "contact chatter",
        ),
        (
            edit(
                "spur_stage_speed",
                "stiffness = 2.0e4",
                "stiffness = 9.0e15",
            ),
            2e8,
            "stiffness: the fastest mode",
        ),
    ] {
        if budget != DEFAULT_RUN_BUDGET {
            let text = std::fs::read_to_string(&path).unwrap();
            let text = text.replacen(
                "[solver]",
                &format!("[solver]\nwork_budget = {budget:e}"),
                1,
            );
            std::fs::write(&path, text).unwrap();
        }
        let out = Command::new(env!("CARGO_BIN_EXE_geardyn"))
            .args(["simulate", "--quiet", "--stop-time", "2e-3", "--out"])
            .arg(dir.join("out.csv"))
            .arg(&path)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{}: {stderr}", path.display());
        assert!(
            stderr.contains(&format!("work budget of {budget:e} units"))
                && stderr.contains(&format!("likely cause: {cause}"))
                && stderr.contains("raise solver.work_budget in the scene")
                // --quiet: no statistics, so none of the work is theirs.
                && !stderr.contains("statistics"),
            "{}: {stderr}",
            path.display()
        );
        if cause.starts_with("stiffness") {
            // The rate quoted is the port coupling's, sqrt(k / J_pinion) (the mesh and
            // bearings alone bound it near 1e5 rad/s, far below the step the run takes).
            let rate: f64 = stderr
                .split("the fastest mode (")
                .nth(1)
                .and_then(|r| r.split(' ').next())
                .and_then(|r| r.parse().ok())
                .unwrap_or_else(|| panic!("no rate in: {stderr}"));
            let expected = (9.0e15f64 / 0.002621).sqrt();
            assert!(
                (rate / expected - 1.0).abs() < 1e-3
                    && stderr.contains("set by the speed ports' coupling stiffness"),
                "rate {rate:e}, expected {expected:e}: {stderr}"
            );
        }
    }
}

/// Issue 34 item 8: `--start u=1e999` was read as infinity; it is refused, naming the value.
#[test]
fn a_non_finite_start_literal_is_refused() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("work_budget_start");
    std::fs::create_dir_all(&dir).unwrap();
    let bin = env!("CARGO_BIN_EXE_geardyn");
    let built = Command::new(bin)
        .args(["fmu", "build"])
        .arg(fmu_dir("spur_pair"))
        .arg("--out")
        .arg(&dir)
        .output()
        .unwrap();
    assert!(built.status.success(), "{built:?}");
    for literal in ["1e999", "-1e999", "inf", "nan"] {
        let out = Command::new(bin)
            .arg("run")
            .arg(dir.join("spur_pair.fmu"))
            .arg("--start")
            .arg(format!("operating.input_torque={literal}"))
            .args(["--stop-time", "1e-4", "--out"])
            .arg(dir.join("out.csv"))
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{literal}: {stderr}");
        assert!(
            stderr.contains(&format!("\"{literal}\" is not a finite real number")),
            "{literal}: {stderr}"
        );
    }
}

/// Issue 34 item 2 for the analyses: `periodic`, `spectrum`, `hb`, `sweep` and `waterfall`
/// run under the run budget (here `[solver] work_budget = 1e3`, far below one mesh period's
/// work, also of a sweep's recording, which since issue 31 takes each segment once) and stop
/// with its message naming a likely cause; a sweep marks each point it could not finish with
/// that reason and goes on.
#[test]
fn analyses_stop_at_their_run_budget_naming_the_cause() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("work_budget_analyses");
    std::fs::create_dir_all(&dir).unwrap();
    let with_budget = |from: &Path, name: &str| {
        let text = std::fs::read_to_string(from).unwrap();
        assert!(text.contains("\n[solver]\n"), "{}", from.display());
        let path = dir.join(name);
        std::fs::write(
            &path,
            text.replacen("\n[solver]\n", "\n[solver]\nwork_budget = 1e3\n", 1),
        )
        .unwrap();
        path
    };
    let pair_scene = fmu_dir("spur_pair").join("scene.toml");
    let runup_scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/runup_spur.toml");
    let pair = with_budget(&pair_scene, "pair.toml");
    let runup = with_budget(&runup_scene, "runup.toml");
    let out = dir.join("out");
    // The budget from the scene's [solver] table, then from `--work-budget` on the shipped
    // scene: the same stop.
    let cases: [(&[&str], &Path, &Path, i32); 5] = [
        (&["periodic"], &pair, &pair_scene, 1),
        (&["spectrum", "--out"], &pair, &pair_scene, 1),
        (
            &["hb", "--speed", "300:400", "--out"],
            &pair,
            &pair_scene,
            1,
        ),
        (
            &["sweep", "--speed", "300:400:3", "--out"],
            &pair,
            &pair_scene,
            0,
        ),
        (&["waterfall", "--out"], &runup, &runup_scene, 1),
    ];
    for via_flag in [false, true] {
        for (args, budgeted, shipped, code) in cases {
            let mut cmd = Command::new(env!("CARGO_BIN_EXE_geardyn"));
            cmd.args(args);
            if args.last() == Some(&"--out") {
                let ext = if args[0] == "waterfall" { "png" } else { "csv" };
                cmd.arg(out.with_extension(ext));
            }
            let run = if via_flag {
                cmd.args(["--work-budget", "1e3"]).arg(shipped)
            } else {
                cmd.arg(budgeted)
            }
            .output()
            .unwrap();
            let stderr = String::from_utf8_lossy(&run.stderr);
            let stdout = String::from_utf8_lossy(&run.stdout);
            let said = format!("{stderr}{stdout}");
            assert_eq!(run.status.code(), Some(code), "{args:?}: {said}");
            assert!(
                said.contains("the work budget of 1e3 units was spent")
                    && said.contains("likely cause: "),
                "{args:?} (flag: {via_flag}): {said}"
            );
            if args[0] == "sweep" {
                assert_eq!(said.matches("failed (row of NaN)").count(), 6, "{said}");
            }
        }
    }
    // A budget the scene would refuse is refused on the command line too, naming the flag.
    for bad in ["0", "-1", "inf", "NaN"] {
        let run = Command::new(env!("CARGO_BIN_EXE_geardyn"))
            .args(["periodic", "--work-budget", bad])
            .arg(&pair_scene)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(1), "{bad}: {stderr}");
        assert!(
            stderr.contains("--work-budget = ") && stderr.contains("must be a finite number >= 1"),
            "{bad}: {stderr}"
        );
    }
}

/// The statistics of a `simulate` run (issue 31: from the exact segments, or from the RK
/// steps' dense output) are charged to the run's work budget: a run with its summary spends
/// more work than the same run with `--quiet`, and a budget between the two stops the run with
/// the summary (naming the budget) while the run without it completes. On the shipped pair
/// (exact) and on it with `solver.method = "rk"`; the rows of both runs are the same.
#[test]
fn the_statistics_are_charged_to_the_run_budget() {
    use geardyn::commands::simulate::{simulate_in_memory, SimulateOptions, SummarySource};
    let path = fmu_dir("spur_pair").join("scene.toml");
    for method in ["exact", "rk"] {
        let scene = geardyn::scene::Scene::from_path(&path).unwrap();
        let options = |no_summary: bool, budget: Option<f64>| {
            let mut o = SimulateOptions {
                stop_time: Some(0.02),
                method: Some(method.to_owned()),
                no_summary,
                ..Default::default()
            };
            o.limits.work_budget = budget;
            o
        };
        let (quiet, quiet_rows) = simulate_in_memory(scene.clone(), &options(true, None)).unwrap();
        let (full, full_rows) = simulate_in_memory(scene.clone(), &options(false, None)).unwrap();
        let source = if method == "exact" {
            SummarySource::Segments
        } else {
            SummarySource::DenseOutput
        };
        assert_eq!(
            (quiet.source, full.source),
            (SummarySource::Samples, source)
        );
        assert_eq!(
            quiet_rows, full_rows,
            "{method}: the summary changed the rows"
        );
        println!(
            "{method}: work {:.4e} units with the summary, {:.4e} without ({:.2}x)",
            full.work,
            quiet.work,
            full.work / quiet.work
        );
        assert!(
            full.work > 1.2 * quiet.work,
            "{method}: {} vs {}",
            full.work,
            quiet.work
        );
        let between = 0.5 * (quiet.work + full.work);
        simulate_in_memory(scene.clone(), &options(true, Some(between))).unwrap();
        let e = simulate_in_memory(scene, &options(false, Some(between)))
            .err()
            .unwrap_or_else(|| panic!("{method}: a summary beyond the budget ran to its end"));
        assert!(
            e.contains(&format!("work budget of {between:e} units")),
            "{method}: {e}"
        );
        // The message names what spent the budget: the statistics' share of the work, and
        // the statistics as the likely cause where they spent most of it. Over the whole
        // run their share is `1 − quiet/full`; the run stops halfway between, at about the
        // same share (the work grows evenly over a steady run).
        let share = 1.0 - quiet.work / full.work;
        println!("{method}: the statistics' share of the work {share:.2}: {e}");
        let named = e.contains("likely cause: the statistics: their observer");
        assert!(
            named || e.contains("% of the work by the statistics' observer"),
            "{method}: {e}"
        );
        if share >= 0.6 {
            assert!(named, "{method}: share {share:.2}: {e}");
        } else if share <= 0.4 {
            assert!(!named, "{method}: share {share:.2}: {e}");
        }
    }
}
