//! `geardyn run | info | validate` end to end on FMUs made here: a C stub FMU
//! (tests/fixtures/stub_fmu.c, compiled with the system C compiler) for the loop, failure
//! reporting and partial results, and broken archives/descriptions for the error paths.
//! Every bad input must give exit code 1, a message naming the problem, no panic, and leave no
//! temporary folder behind.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_geardyn");

fn stub_md(can_vary: bool) -> String {
    format!(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="stub" guid="{{stub-fmu}}" description="runner test stub">
  <CoSimulation modelIdentifier="stub" canHandleVariableCommunicationStepSize="{can_vary}"/>
  <LogCategories><Category name="logStatusError"/><Category name="logStatusDiscard"/></LogCategories>
  <DefaultExperiment startTime="0" stopTime="1" stepSize="0.1"/>
  <ModelVariables>
    <ScalarVariable name="k" valueReference="0" causality="parameter" variability="fixed" description="gain"><Real start="2"/></ScalarVariable>
    <ScalarVariable name="fail_at" valueReference="1" causality="parameter" variability="fixed"><Real start="1e300"/></ScalarVariable>
    <ScalarVariable name="error_at" valueReference="2" causality="parameter" variability="fixed"><Real start="1e300"/></ScalarVariable>
    <ScalarVariable name="u" valueReference="3" causality="input"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="y" valueReference="4" causality="output"><Real/></ScalarVariable>
    <ScalarVariable name="t" valueReference="5" causality="output"><Real/></ScalarVariable>
    <ScalarVariable name="quit_at" valueReference="6" causality="parameter" variability="fixed"><Real start="1e300"/></ScalarVariable>
    <ScalarVariable name="misbehave_at" valueReference="7" causality="parameter" variability="fixed"><Real start="1e300"/></ScalarVariable>
    <ScalarVariable name="misbehave" valueReference="8" causality="parameter" variability="fixed"><Real start="0"/></ScalarVariable>
  </ModelVariables>
  <ModelStructure>
    <Outputs><Unknown index="5"/><Unknown index="6"/></Outputs>
    <InitialUnknowns><Unknown index="5"/><Unknown index="6"/></InitialUnknowns>
  </ModelStructure>
</fmiModelDescription>
"#
    )
}

/// A scratch folder per test (under target/, removed at the start of the test).
fn scratch(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("host_cli")
        .join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Compile the stub library once per variant.
fn stub_so(omit_symbol: bool) -> PathBuf {
    static FULL: OnceLock<PathBuf> = OnceLock::new();
    static OMIT: OnceLock<PathBuf> = OnceLock::new();
    let cell = if omit_symbol { &OMIT } else { &FULL };
    cell.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("host_cli_so");
        std::fs::create_dir_all(&dir).unwrap();
        let out = dir.join(if omit_symbol {
            "stub_omit.so"
        } else {
            "stub.so"
        });
        let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/stub_fmu.c");
        let mut cmd = Command::new(std::env::var("CC").unwrap_or_else(|_| "cc".into()));
        cmd.args(["-shared", "-fPIC", "-O1", "-o"])
            .arg(&out)
            .arg(&src);
        if omit_symbol {
            cmd.arg("-DOMIT_SYMBOL");
        }
        let st = cmd
            .status()
            .expect("a C compiler (cc) is needed for the stub FMU");
        assert!(st.success(), "compiling {} failed", src.display());
        out
    })
    .clone()
}

/// Write an FMU zip with the given entries (name, bytes).
fn zip_fmu(path: &Path, entries: &[(&str, Vec<u8>)]) {
    let f = std::fs::File::create(path).unwrap();
    let mut z = zip::ZipWriter::new(f);
    let opts = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated);
    for (name, bytes) in entries {
        z.start_file(*name, opts).unwrap();
        z.write_all(bytes).unwrap();
    }
    z.finish().unwrap();
}

fn stub_fmu(dir: &Path, name: &str, md: &str, so: Option<PathBuf>) -> PathBuf {
    let p = dir.join(name);
    let mut entries = vec![("modelDescription.xml", md.as_bytes().to_vec())];
    if let Some(so) = so {
        entries.push(("binaries/linux64/stub.so", std::fs::read(so).unwrap()));
    }
    zip_fmu(&p, &entries);
    p
}

/// Run geardyn with TMPDIR pointing at `tmp`, so leftovers can be detected.
fn geardyn(tmp: &Path, args: &[&dyn AsRef<std::ffi::OsStr>]) -> Output {
    let t = tmp.join("tmp");
    std::fs::create_dir_all(&t).unwrap();
    let out = Command::new(BIN)
        .args(args.iter().map(|a| a.as_ref()))
        .env("TMPDIR", &t)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "geardyn panicked: {stderr}");
    let left: Vec<_> = std::fs::read_dir(&t).unwrap().collect();
    assert!(left.is_empty(), "temporary files left behind: {left:?}");
    out
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn read_rows(p: &Path) -> (String, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(p).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().to_string();
    let rows = lines
        .map(|l| l.split(',').map(|c| c.parse().unwrap()).collect())
        .collect();
    (header, rows)
}

#[test]
fn runs_the_stub_on_the_default_grid_with_start_values_and_inputs() {
    let d = scratch("runs");
    let fmu = stub_fmu(&d, "stub.fmu", &stub_md(true), Some(stub_so(false)));
    let out = d.join("out.csv");
    let o = geardyn(
        &d,
        &[
            &"run", &fmu, &"--out", &out, &"--start", &"u=1.5", &"--start", &"k=3",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let (header, rows) = read_rows(&out);
    assert_eq!(header, r#""time","y","t""#);
    assert_eq!(rows.len(), 11);
    for (n, r) in rows.iter().enumerate() {
        // Grid points are start + n*h, not accumulated sums (fmpy's grid).
        assert_eq!(r[0], n as f64 * 0.1);
        assert_eq!(r[2], r[0]);
        assert!((r[1] - 4.5 * r[0]).abs() < 1e-12, "{r:?}");
    }
    // An input CSV: u = 1 before t = 0.5, 3 after (a jump), k = 2.
    let csv = d.join("in.csv");
    std::fs::write(&csv, "\"time\",\"u\"\n0,1\n0.5,1\n0.5,3\n1,3\n").unwrap();
    let o = geardyn(
        &d,
        &[
            &"run",
            &fmu,
            &"--out",
            &out,
            &"--input",
            &csv,
            &"--outputs",
            &"y",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let (header, rows) = read_rows(&out);
    assert_eq!(header, r#""time","y""#);
    let last = rows.last().unwrap();
    assert_eq!(last[0], 1.0);
    assert!(
        (last[1] - (2.0 * 0.5 + 6.0 * 0.5)).abs() < 1e-12,
        "{last:?}"
    );
}

#[test]
fn discard_is_reported_with_time_and_reason_and_rows_are_kept() {
    let d = scratch("discard");
    let fmu = stub_fmu(&d, "stub.fmu", &stub_md(true), Some(stub_so(false)));
    let out = d.join("out.csv");
    let o = geardyn(
        &d,
        &[&"run", &fmu, &"--out", &out, &"--start", &"fail_at=0.35"],
    );
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(
        e.contains("t = 0.30000000000000004") && e.contains("fmi2Discard"),
        "{e}"
    );
    // The FMU's reason at the default log level, once, in the one error line (issue 32).
    assert_eq!(e.lines().count(), 1, "{e}");
    assert!(e.contains("the FMU refused the step"), "{e}");
    assert!(e.contains("state diverged after 50% of the step"), "{e}");
    assert!(e.contains("last successful time 0.35"), "{e}");
    assert!(e.contains("4 rows up to t = 0.30000000000000004"), "{e}");
    assert_eq!(read_rows(&out).1.len(), 4);
}

/// An FMU that ends the simulation itself (fmi2Discard with fmi2Terminated = true, FMI 2.0.5
/// §4.2.3) ends the run normally, as in fmpy and the Reference-FMUs' master (issue 39): exit 0,
/// a row at its last successful time, one note with its reason.
#[test]
fn discard_with_terminated_is_a_normal_end_with_a_row_at_the_last_successful_time() {
    let d = scratch("terminated");
    let fmu = stub_fmu(&d, "stub.fmu", &stub_md(true), Some(stub_so(false)));
    let out = d.join("out.csv");
    let o = geardyn(
        &d,
        &[
            &"run",
            &fmu,
            &"--out",
            &out,
            &"--start",
            &"quit_at=0.25",
            &"--start",
            &"u=1",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let e = stderr(&o);
    assert_eq!(e.lines().count(), 1, "{e}");
    assert!(
        e.starts_with("note: the FMU ended the simulation itself at t = 0.22500000000000003, before the stop time 1 (fmi2Terminated after fmi2DoStep returned fmi2Discard: end of the load cycle reached)"),
        "{e}"
    );
    let rows = read_rows(&out).1;
    // Rows at 0, 0.1, 0.2, then the last successful time 0.2 + 0.1/4.
    assert_eq!(rows.len(), 4);
    let last = rows.last().unwrap();
    assert!(
        (last[0] - 0.225).abs() < 1e-15 && last[2] == last[0],
        "{last:?}"
    );
}

#[test]
fn error_is_reported_with_time_and_reason_and_rows_are_kept() {
    let d = scratch("error");
    let fmu = stub_fmu(&d, "stub.fmu", &stub_md(true), Some(stub_so(false)));
    let out = d.join("out.csv");
    let o = geardyn(
        &d,
        &[&"run", &fmu, &"--out", &out, &"--start", &"error_at=0.55"],
    );
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(
        e.contains("step from t = 0.5 with h = 0.10000000000000009"),
        "{e}"
    );
    assert!(
        e.contains("fmi2DoStep returned fmi2Error: solver failure: matrix is singular at t=0.5"),
        "{e}"
    );
    assert_eq!(read_rows(&out).1.len(), 6);
}

#[test]
fn last_step_is_shortened_only_with_variable_step_capability() {
    let d = scratch("stop");
    let out = d.join("out.csv");
    let fmu = stub_fmu(&d, "vary.fmu", &stub_md(true), Some(stub_so(false)));
    let o = geardyn(&d, &[&"run", &fmu, &"--out", &out, &"--stop-time", &"0.95"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let rows = read_rows(&out).1;
    assert_eq!((rows.len(), rows.last().unwrap()[0]), (11, 0.95));
    let fmu = stub_fmu(&d, "fixed.fmu", &stub_md(false), Some(stub_so(false)));
    let o = geardyn(&d, &[&"run", &fmu, &"--out", &out, &"--stop-time", &"0.95"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("cannot shorten a step"),
        "{}",
        stderr(&o)
    );
    let rows = read_rows(&out).1;
    assert_eq!((rows.len(), rows.last().unwrap()[0]), (10, 0.9));
    // --max-rows is a bound, not a target: exactly as many rows as the grid has are allowed.
    let o = geardyn(&d, &[&"run", &fmu, &"--out", &out, &"--max-rows", &"11"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(read_rows(&out).1.len(), 11);
}

#[test]
fn logging_and_trace() {
    let d = scratch("trace");
    let fmu = stub_fmu(&d, "stub.fmu", &stub_md(true), Some(stub_so(false)));
    let out = d.join("out.csv");
    let o = geardyn(
        &d,
        &[
            &"run",
            &fmu,
            &"--out",
            &out,
            &"--fmi-trace",
            &"--stop-time",
            &"0.2",
            &"--log-level",
            &"all",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    for call in [
        "fmi2Instantiate(",
        "fmi2SetupExperiment(",
        "fmi2EnterInitializationMode()",
        "fmi2DoStep(currentCommunicationPoint=0.1, communicationStepSize=0.1",
        "fmi2Terminate() -> fmi2OK",
        "fmi2FreeInstance",
    ] {
        assert!(e.contains(call), "missing {call} in {e}");
    }
    // A wrong GUID: the FMU's logged reason is in the error (routed through the C shim).
    let md = stub_md(true).replace("{stub-fmu}", "{other}");
    let fmu = stub_fmu(&d, "guid.fmu", &md, Some(stub_so(false)));
    let o = geardyn(&d, &[&"run", &fmu]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("fmi2Instantiate returned NULL: wrong GUID \"{other}\""),
        "{}",
        stderr(&o)
    );
}

#[test]
fn info_and_validate() {
    let d = scratch("info");
    let fmu = stub_fmu(&d, "stub.fmu", &stub_md(true), Some(stub_so(false)));
    let o = geardyn(&d, &[&"info", &fmu]);
    assert!(o.status.success());
    let s = String::from_utf8_lossy(&o.stdout);
    assert!(
        s.contains("Model name       stub")
            && s.contains("canHandleVariableCommunicationStepSize  yes"),
        "{s}"
    );
    assert!(
        s.lines()
            .any(|l| l.starts_with("k ") && l.contains("parameter") && l.contains("gain")),
        "{s}"
    );
    let o = geardyn(&d, &[&"validate", &fmu]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stdout));
    assert!(String::from_utf8_lossy(&o.stdout).contains("No problems found."));
    let bad = stub_fmu(
        &d,
        "bad.fmu",
        &stub_md(true).replace(
            "<InitialUnknowns><Unknown index=\"5\"/>",
            "<InitialUnknowns>",
        ),
        Some(stub_so(true)),
    );
    let o = geardyn(&d, &[&"validate", &bad]);
    assert_eq!(o.status.code(), Some(1));
    let s = String::from_utf8_lossy(&o.stdout);
    assert!(
        s.contains("<InitialUnknowns>: missing \"y\"") && s.contains("fmi2GetStringStatus"),
        "{s}"
    );
    assert!(stderr(&o).contains("2 problems found"), "{}", stderr(&o));
}

/// Every bad input of issue 4, acceptance item 4: exit code 1 and a message naming it.
#[test]
fn bad_inputs_give_clear_errors() {
    let d = scratch("bad");
    let good_md = stub_md(true);
    let so = Some(stub_so(false));
    let not_zip = d.join("text.fmu");
    std::fs::write(&not_zip, "this is not a zip file").unwrap();
    let no_md = d.join("nomd.fmu");
    zip_fmu(&no_md, &[("binaries/linux64/stub.so", b"x".to_vec())]);
    let malformed = stub_fmu(
        &d,
        "malformed.fmu",
        &good_md.replace("<Real start=\"2\"/>", "<Real start=\"2\">"),
        so.clone(),
    );
    let truncated = stub_fmu(
        &d,
        "truncated.fmu",
        &good_md[..good_md.len() / 2],
        so.clone(),
    );
    let fmi1 = stub_fmu(
        &d,
        "fmi1.fmu",
        &good_md.replace("fmiVersion=\"2.0\"", "fmiVersion=\"1.0\""),
        so.clone(),
    );
    let fmi3 = stub_fmu(
        &d,
        "fmi3.fmu",
        &good_md.replace("fmiVersion=\"2.0\"", "fmiVersion=\"3.0\""),
        so.clone(),
    );
    let me = stub_fmu(
        &d,
        "me.fmu",
        &good_md.replace("<CoSimulation", "<ModelExchange"),
        so.clone(),
    );
    let nobin = stub_fmu(&d, "nobin.fmu", &good_md, None);
    let missing_sym = stub_fmu(&d, "sym.fmu", &good_md, Some(stub_so(true)));
    let good = stub_fmu(&d, "good.fmu", &good_md, so.clone());
    let bad_csv = d.join("bad.csv");
    std::fs::write(&bad_csv, "time,u\n0,1\n0.5,one\n").unwrap();
    let bad_csv2 = d.join("bad2.csv");
    std::fs::write(&bad_csv2, "u,time\n0,1\n").unwrap();
    let missing = d.join("missing.fmu");
    let md_bytes = good_md.as_bytes().to_vec();
    let absolute = d.join("absolute.fmu");
    zip_fmu(
        &absolute,
        &[
            ("modelDescription.xml", md_bytes.clone()),
            ("/tmp/geardyn-absolute-entry.txt", b"x".to_vec()),
        ],
    );
    let drive = d.join("drive.fmu");
    zip_fmu(
        &drive,
        &[
            ("modelDescription.xml", md_bytes.clone()),
            ("C:/evil.dll", b"x".to_vec()),
        ],
    );

    let cases: Vec<(Vec<&dyn AsRef<std::ffi::OsStr>>, &str)> = vec![
        (vec![&"run", &missing], "missing.fmu: no such file"),
        (
            vec![&"run", &not_zip],
            "not an FMU: not a valid ZIP archive",
        ),
        (vec![&"run", &no_md], "no modelDescription.xml"),
        (vec![&"run", &malformed], "malformed XML at line"),
        (vec![&"run", &truncated], "XML"),
        (vec![&"run", &fmi1], "fmiVersion=\"1.0\" is FMI 1.0"),
        (vec![&"run", &fmi3], "fmiVersion=\"3.0\" is FMI 3.0"),
        (vec![&"run", &me], "Model Exchange only"),
        (
            vec![&"run", &nobin],
            "no linux64 binary: binaries/linux64/stub.so does not exist",
        ),
        (
            vec![&"run", &missing_sym],
            "does not export the FMI 2.0 function fmi2GetStringStatus",
        ),
        (
            vec![&"run", &good, &"--start", &"nope=1"],
            "the FMU has no variable named \"nope\"",
        ),
        (
            vec![&"run", &good, &"--start", &"y=1"],
            "\"y\" is not a parameter or input",
        ),
        (
            vec![&"run", &good, &"--start", &"k=abc"],
            "\"abc\" is not a real number",
        ),
        (vec![&"run", &good, &"--start", &"k"], "expected NAME=VALUE"),
        (
            vec![&"run", &good, &"--input", &bad_csv],
            "line 3, column \"u\": \"one\" is not a number",
        ),
        (
            vec![&"run", &good, &"--input", &bad_csv2],
            "the first column must be \"time\"",
        ),
        (
            vec![&"run", &good, &"--input", &missing],
            "cannot read input file",
        ),
        (
            vec![&"run", &good, &"--outputs", &"y,zz"],
            "--outputs: the FMU has no variable named \"zz\"",
        ),
        (
            vec![&"run", &good, &"--output-interval", &"0"],
            "--output-interval 0: must be a finite number > 0",
        ),
        (
            vec![&"run", &good, &"--stop-time", &"-1"],
            "stop time -1 must be finite and after the start time 0",
        ),
        (
            vec![&"run", &good, &"--log-level", &"loud"],
            "--log-level \"loud\"",
        ),
        (
            vec![&"run", &good, &"--out", &"/nonexistent-dir/o.csv"],
            "/nonexistent-dir/o.csv: cannot create",
        ),
        (
            vec![&"run", &absolute],
            "ZIP entry \"/tmp/geardyn-absolute-entry.txt\" has an absolute path (it starts at the root)",
        ),
        (
            vec![&"validate", &absolute],
            "ZIP entry \"/tmp/geardyn-absolute-entry.txt\" has an absolute path",
        ),
        (
            vec![&"validate", &drive],
            "ZIP entry \"C:/evil.dll\" has an absolute path (a drive letter)",
        ),
        (
            vec![&"run", &good, &"--output-interval", &"1e-300"],
            "output interval 1e-300 s is below the resolution of the time at 1.0 s (2.220446049250313e-16 s)",
        ),
        (
            vec![&"run", &good, &"--output-interval", &"1e-7"],
            "output interval 1e-7 s from t = 0.0 to 1.0 s gives 10000001 output rows, more than the maximum of 10000000 (--max-rows raises it)",
        ),
        (
            vec![&"run", &good, &"--max-rows", &"10"],
            "output interval 0.1 s from t = 0.0 to 1.0 s gives 11 output rows, more than the maximum of 10",
        ),
        (vec![&"info", &truncated], "XML"),
        (vec![&"validate", &not_zip], "not a valid ZIP archive"),
    ];
    for (args, needle) in cases {
        let o = geardyn(&d, &args);
        let e = stderr(&o);
        assert_eq!(
            o.status.code(),
            Some(1),
            "args {:?}: {e}",
            args.iter().map(|a| a.as_ref()).collect::<Vec<_>>()
        );
        assert!(e.starts_with("error: ") || e.contains("\nerror: "), "{e}");
        assert!(e.contains(needle), "expected {needle:?} in: {e}");
    }
}

/// Start `geardyn run` in the background with TMPDIR at `<d>/tmp`, and wait until the FMU is
/// unpacked and its step loop has had `settle` to get going.
fn spawn_run(
    d: &Path,
    args: &[&dyn AsRef<std::ffi::OsStr>],
    settle: Duration,
) -> (std::process::Child, PathBuf) {
    let t = d.join("tmp");
    std::fs::create_dir_all(&t).unwrap();
    let child = Command::new(BIN)
        .arg("run")
        .args(args.iter().map(|a| a.as_ref()))
        .env("TMPDIR", &t)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    while std::fs::read_dir(&t).unwrap().next().is_none() && t0.elapsed().as_secs() < 30 {
        std::thread::sleep(Duration::from_millis(10));
    }
    std::thread::sleep(settle);
    (child, t)
}

/// Wait for a run, killing it and failing if it takes longer than `limit` (a run that ignores
/// signals must fail this test, not hang it).
fn finish_within(mut child: std::process::Child, limit: Duration) -> Output {
    let t0 = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if t0.elapsed() > limit {
            let _ = child.kill();
            let o = child.wait_with_output().unwrap();
            panic!("still running after {limit:?}: {}", stderr(&o));
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    child.wait_with_output().unwrap()
}

fn send(child: &std::process::Child, signal: &str) {
    let st = Command::new("kill")
        .args([signal, &child.id().to_string()])
        .status()
        .unwrap();
    assert!(st.success());
}

fn assert_empty(tmp: &Path) {
    let left: Vec<_> = std::fs::read_dir(tmp).unwrap().collect();
    assert!(left.is_empty(), "temporary files left behind: {left:?}");
}

/// Ctrl-C (SIGINT) stops the loop at the next step: FMU terminated and freed, rows written,
/// temporary folder removed, exit code 1 with the time reached.
#[test]
fn interrupt_stops_cleanly() {
    let d = scratch("interrupt");
    let fmu = stub_fmu(&d, "stub.fmu", &stub_md(true), Some(stub_so(false)));
    let out = d.join("out.csv");
    let (child, t) = spawn_run(
        &d,
        &[
            &fmu,
            &"--out",
            &out,
            &"--stop-time",
            &"1e12",
            &"--output-interval",
            &"0.1",
            &"--max-rows",
            &"100000000000000",
        ],
        Duration::from_millis(200),
    );
    send(&child, "-INT");
    let o = finish_within(child, Duration::from_secs(10));
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(
        e.contains("note: SIGINT received: stopping the run at its next step"),
        "{e}"
    );
    assert!(e.contains("error: interrupted at t = "), "{e}");
    assert!(!e.contains("killed"), "{e}");
    let rows = read_rows(&out).1;
    assert!(rows.len() > 1, "{}", rows.len());
    for (n, r) in rows.iter().enumerate() {
        assert_eq!(r[0], n as f64 * 0.1);
    }
    assert_empty(&t);
}

/// An FMU that aborts, crashes or exits inside fmi2DoStep (issue 17): exit code 1, a message
/// naming the signal or exit status, the FMI call and the time, the rows computed before it
/// in the CSV (whole blocks already written plus the pending rows from shared memory, each
/// row once), and no temporary folder.
#[test]
fn an_fmu_that_aborts_crashes_or_exits_is_reported_and_its_rows_are_kept() {
    let d = scratch("crash");
    let fmu = stub_fmu(&d, "stub.fmu", &stub_md(true), Some(stub_so(false)));
    for (how, what) in [
        (
            "1",
            "the FMU's process was killed by signal 6 (SIGABRT: Aborted)",
        ),
        (
            "2",
            "the FMU's process was killed by signal 11 (SIGSEGV: Segmentation fault)",
        ),
        ("3", "the FMU ended its process with exit status 0"),
    ] {
        // 3500 rows before the failure: some blocks written, the rest pending.
        let out = d.join(format!("out{how}.csv"));
        let o = geardyn(
            &d,
            &[
                &"run",
                &fmu,
                &"--out",
                &out,
                &"--output-interval",
                &"1e-4",
                &"--start",
                &"misbehave_at=0.35",
                &"--start",
                &format!("misbehave={how}"),
                &"--start",
                &"u=1",
            ],
        );
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{e}");
        let last = 3499.0 * 1e-4;
        assert!(e.contains(what), "{e}");
        assert!(
            e.contains(&format!("during fmi2DoStep at t = {last}")),
            "{e}"
        );
        assert!(
            e.contains(&format!("(3500 rows up to t = {last} were written to")),
            "{e}"
        );
        let rows = read_rows(&out).1;
        assert_eq!(rows.len(), 3500);
        for (n, r) in rows.iter().enumerate() {
            assert_eq!(r[0], n as f64 * 1e-4);
            assert!((r[1] - 2.0 * r[0]).abs() < 1e-12, "{r:?}");
        }
    }
    // To stdout: the rows computed before the crash follow the header there too.
    let o = geardyn(
        &d,
        &[
            &"run",
            &fmu,
            &"--start",
            &"misbehave_at=0.35",
            &"--start",
            &"misbehave=2",
        ],
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert_eq!(text.lines().count(), 1 + 4, "{text}");
    assert!(
        text.ends_with("0.30000000000000004,0.0,0.30000000000000004\n"),
        "{text}"
    );
}

/// SIGTERM to a run whose FMU blocks forever inside fmi2DoStep: asked politely first, killed
/// after the grace time, within a second or two in all; message, rows kept, folder removed.
#[test]
fn sigterm_ends_a_run_blocked_in_the_fmu() {
    let d = scratch("blocked");
    let fmu = stub_fmu(&d, "stub.fmu", &stub_md(true), Some(stub_so(false)));
    let out = d.join("out.csv");
    let (child, t) = spawn_run(
        &d,
        &[
            &fmu,
            &"--out",
            &out,
            &"--start",
            &"misbehave_at=0.35",
            &"--start",
            &"misbehave=4",
        ],
        Duration::from_millis(300),
    );
    let sent = Instant::now();
    send(&child, "-TERM");
    let o = finish_within(child, Duration::from_secs(10));
    let took = sent.elapsed();
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(took < Duration::from_secs(2), "{took:?}: {e}");
    assert!(
        took >= Duration::from_millis(800),
        "not asked politely first: {took:?}: {e}"
    );
    assert!(
        e.contains("SIGTERM received, and the FMU did not return within 0.9 s: its process was killed during fmi2DoStep at t = 0.30000000000000004"),
        "{e}"
    );
    assert!(
        e.contains("(4 rows up to t = 0.30000000000000004 were written to"),
        "{e}"
    );
    assert_eq!(read_rows(&out).1.len(), 4);
    assert_empty(&t);

    // A second signal does not wait for the grace time.
    let (child, t) = spawn_run(
        &d,
        &[
            &fmu,
            &"--out",
            &out,
            &"--start",
            &"misbehave_at=0.35",
            &"--start",
            &"misbehave=4",
        ],
        Duration::from_millis(300),
    );
    send(&child, "-INT");
    std::thread::sleep(Duration::from_millis(100));
    send(&child, "-INT");
    let o = finish_within(child, Duration::from_secs(10));
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(
        e.contains("a second SIGINT received: the FMU's process was killed during fmi2DoStep at t = 0.30000000000000004"),
        "{e}"
    );
    assert_eq!(read_rows(&out).1.len(), 4);
    assert_empty(&t);
}

/// The exit status is documented in `--help`, and behaviour agrees (the discard tests above:
/// 0 when the FMU ends the simulation with fmi2Terminated, 1 for a refused step).
#[test]
fn help_documents_the_exit_status() {
    let o = Command::new(BIN).args(["run", "--help"]).output().unwrap();
    let h = String::from_utf8_lossy(&o.stdout);
    assert!(h.contains("Exit status:"), "{h}");
    assert!(
        h.contains("0  the run reached the stop time, or an FMU ended the simulation itself"),
        "{h}"
    );
    assert!(
        h.contains("1  anything else: a bad argument or FMU, a refused step (fmi2Discard without\n     fmi2Terminated"),
        "{h}"
    );
    assert!(
        h.contains("--max-rows <MAX_ROWS>") && h.contains("[default: 10000000]"),
        "{h}"
    );
}
