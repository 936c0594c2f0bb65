//! Issue 34, acceptance 1 (the CLI side): each failing case of the second reliability round is a
//! regression test here. Each runs the `geardyn` binary as a user does and gets a clear message
//! (exit status 1, the option or field and its value named, nothing left behind) or a correct
//! result checked against an independent closed form; no case may panic (status 101) or abort.

use std::io::Read as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

const BIN: &str = env!("CARGO_BIN_EXE_geardyn");

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn geardyn(args: &[&str]) -> Output {
    let out = Command::new(BIN).args(args).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "geardyn panicked: {stderr}");
    out
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Asserts exit status 1 with every piece of `expected` in the message; the message.
fn refused(args: &[&str], expected: &[&str]) -> String {
    let o = geardyn(args);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{args:?}: {e}");
    for x in expected {
        assert!(e.contains(x), "{args:?}: message {e:?} lacks {x:?}");
    }
    e
}

/// A shipped file with `from` (which must occur once after `after`) replaced by `to`, written
/// to a fresh folder as `scene.toml`.
fn edited(file: &str, after: &str, from: &str, to: &str) -> (tempfile::TempDir, PathBuf) {
    let text = std::fs::read_to_string(root().join(file)).unwrap();
    let start = text.find(after).expect("anchor") + after.len();
    let at = start + text[start..].find(from).expect("field after the anchor");
    let text = format!("{}{to}{}", &text[..at], &text[at + from.len()..]);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, text).unwrap();
    (dir, path)
}

/// Nothing but the scene in `dir`: no output, no `.partial`.
fn nothing_left(dir: &Path) {
    let left: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n != "scene.toml")
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}

/// `drivetrain_monolithic` with `damping = 1e15` on the second shaft panicked in the motor's
/// full-load curve (a NaN speed indexed it). The shaft damper is now part of the fastest rate
/// the run limits see, so the run is refused before it starts, naming it.
#[test]
fn shaft_damping_of_1e15_is_refused_naming_the_damping() {
    let (dir, scene) = edited(
        "examples/drivetrain_monolithic.toml",
        "name = \"shaft2\"",
        "damping = 2.0",
        "damping = 1e15",
    );
    let out = dir.path().join("out.csv");
    refused(
        &[
            "simulate",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        &[
            "periods of the fastest mode",
            "shaft damping",
            "--max-periods",
        ],
    );
    nothing_left(dir.path());
}

/// `friction_pair` with the gear's `bearing_stiffness = [1.4732e8, 8.0]` panicked ("mass
/// matrix is positive definite") in the aliasing check. A nearly free bearing axis is a valid
/// layout: the run succeeds, and the gear's y translation is a mode of its own at the closed
/// form of a mass on a spring, f = √(k/m)/2π (the mesh acts along x).
#[test]
fn a_nearly_free_bearing_axis_simulates_and_has_its_closed_form_mode() {
    let (dir, scene) = edited(
        "examples/friction_pair.toml",
        "name = \"gear\"",
        "bearing_stiffness = [1.4732e8, 1.4732e8]",
        "bearing_stiffness = [1.4732e8, 8.0]",
    );
    let out = dir.path().join("out.csv");
    let o = geardyn(&[
        "simulate",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(
        text.lines().count() > 1000,
        "rows: {}",
        text.lines().count()
    );
    assert!(!text.contains("NaN"));

    let any = geardyn::scene::Scene::from_path(&scene).unwrap();
    let result = geardyn::commands::modes::modes(&any, false, &mut Vec::new()).unwrap();
    let expected = (8.0f64 / 4.4380).sqrt() / std::f64::consts::TAU;
    let nearest = result
        .modes
        .iter()
        .filter(|m| !m.rigid)
        .map(|m| m.frequency)
        .min_by(|a, b| (a - expected).abs().total_cmp(&(b - expected).abs()))
        .unwrap();
    assert!(
        (nearest - expected).abs() <= 1e-6 * expected,
        "mode {nearest} Hz, closed form {expected} Hz"
    );
}

/// A closed pipe (`geardyn … | head`) ended with a panic (`println!` on EPIPE) or an error
/// message. Now: no error message, status 141 (128 + SIGPIPE) as for any filter, and no output
/// file or `.partial` left.
#[test]
fn a_closed_pipe_ends_quietly_with_status_141() {
    let chain = root().join("examples/chain_16.toml");
    let chain = chain.to_str().unwrap();
    let fmus = tempfile::tempdir().unwrap();
    let scene = root().join("fmu/spur_pair");
    let dir = fmus.path().to_str().unwrap();
    let o = geardyn(&["fmu", "build", scene.to_str().unwrap(), "--out", dir]);
    assert!(o.status.success(), "{}", stderr(&o));
    let fmu = fmus.path().join("spur_pair.fmu");
    for args in [
        vec!["simulate", chain, "--out", "/dev/stdout", "--quiet"],
        vec!["modes", chain],
        vec!["fmu", "description", chain],
        // The host runner writes its rows to stdout from the process that runs the FMU.
        vec!["run", fmu.to_str().unwrap()],
    ] {
        // The reader is gone before the child starts (`| head -c 0`), so the outcome does
        // not depend on how fast the child writes or whether its output fits in the pipe's
        // buffer (dropping the reader after the spawn raced with a fast `modes`).
        let (reader, writer) = std::io::pipe().unwrap();
        drop(reader);
        let mut child = Command::new(BIN)
            .args(&args)
            .stdout(Stdio::from(writer))
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let mut err = String::new();
        child
            .stderr
            .take()
            .unwrap()
            .read_to_string(&mut err)
            .unwrap();
        let status = child.wait().unwrap();
        assert_eq!(status.code(), Some(141), "{args:?}: {err}");
        // (The aliasing warning of chain_16's output interval comes before.)
        assert!(
            !err.contains("error") && !err.contains("Broken pipe"),
            "{args:?}: stderr {err:?}"
        );
    }
}

/// An output that is a stream (a FIFO here, `/dev/stdout` in use) is written in place: the
/// rename of the atomic write replaced `/dev/stdout` by a regular file before.
#[test]
fn an_output_fifo_stays_a_fifo_and_gets_the_rows() {
    use std::os::unix::fs::FileTypeExt;
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("rows.csv");
    let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
    // SAFETY: creating a FIFO at a path we own.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read_to_string(fifo).unwrap())
    };
    let o = geardyn(&[
        "simulate",
        "--example",
        "spur_pair",
        "--out",
        fifo.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = reader.join().unwrap();
    assert!(text.starts_with("time,"), "{}", &text[..text.len().min(80)]);
    assert_eq!(text.lines().count(), 2002);
    assert!(std::fs::metadata(&fifo).unwrap().file_type().is_fifo());
    let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert_eq!(left.len(), 1, "{left:?}");
}

/// Counts are checked before anything is allocated or run: `sweep` with 1e11 points aborted
/// on an 800 GB allocation; the others aborted or ran without end in the same way.
#[test]
fn counts_beyond_the_limits_are_refused_naming_the_option() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out.csv");
    let out = out.to_str().unwrap();
    let plot = tmp.path().join("p.svg");
    let plot = plot.to_str().unwrap();
    let gears = root().join("fmu/geometry_pair/gears.toml");
    let gears = gears.to_str().unwrap();
    let cases: &[(&[&str], &[&str])] = &[
        (
            &[
                "sweep",
                "--example",
                "spur_pair",
                "--speed",
                "300:400:100000000000",
                "--out",
                out,
            ],
            &[
                "--speed '300:400:100000000000'",
                "points = 100000000000",
                "100000",
            ],
        ),
        (
            &[
                "sweep",
                "--example",
                "spur_pair",
                "--speed",
                "300:400:3",
                "--max-periods",
                "4000000000",
                "--out",
                out,
            ],
            &["--max-periods = 4000000000"],
        ),
        (
            &[
                "hb",
                "--example",
                "spur_pair",
                "--speed",
                "300:400",
                "--harmonics",
                "1000000000000",
                "--out",
                out,
            ],
            &["harmonics = 1000000000000"],
        ),
        (
            &[
                "hb",
                "--example",
                "spur_pair",
                "--speed",
                "300:400",
                "--subharmonic",
                "4000000000",
                "--out",
                out,
            ],
            &["subharmonic = 4000000000"],
        ),
        (
            &[
                "hb",
                "--example",
                "spur_pair",
                "--speed",
                "300:400",
                "--sweep-points",
                "100000000000",
                "--out",
                out,
                "--plot",
                plot,
            ],
            &["--sweep-points = 100000000000"],
        ),
        (
            &[
                "band",
                "--example",
                "helical_pair_friction",
                "--speed",
                "1000:2000",
                "--points",
                "100000000000",
            ],
            &["points = 100000000000"],
        ),
        (
            &[
                "spectrum",
                "--example",
                "spur_pair",
                "--samples",
                "4000000000",
                "--out",
                out,
            ],
            &["--samples = 4000000000"],
        ),
        (
            &[
                "spectrum",
                "--example",
                "spur_pair",
                "--periods",
                "4000000000",
                "--out",
                out,
            ],
            &["--periods = 4000000000"],
        ),
        (
            &[
                "waterfall",
                "--example",
                "runup_spur",
                "--overlap",
                "0.9999999999",
                "--out",
                out,
            ],
            &["overlap = 0.9999999999", "lower the overlap"],
        ),
        (
            &[
                "periodic",
                "--example",
                "spur_pair",
                "--periods",
                "1000000000",
            ],
            &["periods = 1000000000", "mesh periods"],
        ),
        (
            &[
                "stiffness",
                gears,
                "--torque",
                "100",
                "--out",
                out,
                "--harmonics",
                "1000000000000",
            ],
            &["--harmonics = 1000000000000"],
        ),
    ];
    for (args, expected) in cases {
        refused(args, expected);
        assert!(!Path::new(out).exists(), "{args:?} left its output");
    }
}

/// A run beyond its work budget stops with a message naming the budget, how to raise it and
/// the likely cause, and leaves nothing behind; raising the budget runs it.
#[test]
fn a_run_beyond_its_work_budget_names_the_likely_cause() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.csv");
    let out = out.to_str().unwrap();
    let e = refused(
        &[
            "simulate",
            "--example",
            "spur_pair",
            "--out",
            out,
            "--work-budget",
            "1e4",
        ],
        &[
            "work budget of 1e4",
            "--work-budget",
            "likely cause: speed",
            "operating.pinion_speed",
        ],
    );
    assert!(e.contains("solver.work_budget"), "{e}");
    let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert!(left.is_empty(), "{left:?}");
    let o = geardyn(&[
        "simulate",
        "--example",
        "spur_pair",
        "--out",
        out,
        "--work-budget",
        "1e9",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// A stiff scene the model's frequency bound does not flag (a chattering contact from a torque
/// of 5e13 N.m on a motor curve of 7.5e13 N.m): stopped by the budget, the events named.
#[test]
fn a_chattering_contact_is_stopped_by_the_budget_naming_the_events() {
    let (dir, scene) = edited(
        "examples/drivetrain_monolithic.toml",
        "[operating]",
        "input_torque = 50.213317520077155",
        "input_torque = 50213317520077.16",
    );
    let text = std::fs::read_to_string(&scene).unwrap().replace(
        "torque = [150.0, 150.0, 120.0, 100.0, 75.0, 60.0]",
        "torque = [150.0, 150.0, 120.0, 100.0, 75000000000000.0, 60.0]",
    );
    std::fs::write(&scene, text).unwrap();
    let out = dir.path().join("out.csv");
    refused(
        &[
            "simulate",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--work-budget",
            "1e8",
            "--stop-time",
            "1e-3",
        ],
        &["work budget of 1e8", "likely cause: contact chatter"],
    );
    nothing_left(dir.path());
}

/// Issue 34 item 2: `--progress` shows the progress of a long run or analysis on a pipe too,
/// through the one progress display of every command. stderr is a pipe here: without the
/// flag it holds no progress (scripted runs stay byte-identical, `tests/every_command.rs`);
/// with it, plain `progress: …` lines (every 2 s, and one at the end: these runs are short,
/// so the end's line is the one every command must show), with what the command last
/// reported, and no carriage return or escape.
#[test]
fn progress_shows_on_a_pipe_only_when_asked_for() {
    let dir = tempfile::tempdir().unwrap();
    let out = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    let (csv, png) = (out("out.csv"), out("out.png"));
    let runup = root().join("examples/runup_spur.toml");
    let runup = runup.to_str().unwrap();
    let cases: Vec<(Vec<&str>, &[&str])> = vec![
        (
            vec![
                "simulate",
                "--example",
                "spur_pair",
                "--stop-time",
                "0.02",
                "--out",
                &csv,
            ],
            &["progress: t = 2.000000e-2 s of 0.02 s (100.0 %), "],
        ),
        (
            vec![
                "sweep",
                "--example",
                "spur_pair",
                "--speed",
                "300:400:5",
                "--direction",
                "both",
                "--out",
                &csv,
            ],
            &["progress: sweep 10/10 points, "],
        ),
        (
            vec!["periodic", "--example", "spur_pair"],
            &["progress: shooting: Newton iteration ", "scaled residual "],
        ),
        (
            vec![
                "hb",
                "--example",
                "spur_pair",
                "--speed",
                "300:320",
                "--harmonics",
                "8",
                "--out",
                &csv,
            ],
            &["progress: hb: Floquet multipliers of "],
        ),
        (
            vec!["spectrum", "--example", "spur_pair", "--out", &csv],
            &["progress: spectrum: integrating the orbit's lines"],
        ),
        (
            vec!["waterfall", runup, "--out", &png],
            &["progress: waterfall: run-up at t = "],
        ),
    ];
    for (args, expected) in cases {
        let quiet = geardyn(&args);
        let e = stderr(&quiet);
        assert_eq!(quiet.status.code(), Some(0), "{args:?}: {e}");
        assert!(!e.contains("progress"), "{args:?} without --progress: {e}");
        let shown = geardyn(&[&args[..], &["--progress"]].concat());
        let e = stderr(&shown);
        assert_eq!(shown.status.code(), Some(0), "{args:?}: {e}");
        for x in expected {
            assert!(e.contains(x), "{args:?} --progress: {e:?} lacks {x:?}");
        }
        assert!(
            !e.contains('\r') && !e.contains('\x1b'),
            "a pipe gets plain lines: {e:?}"
        );
        // The stdout of a command is the same with and without the flag.
        assert_eq!(quiet.stdout, shown.stdout, "{args:?}");
    }
}
