//! `geardyn validate` loads the FMU's library in a supervised child process, like `geardyn
//! run` (issue 34 item 4): a library whose initialiser crashes, exits or blocks is reported
//! with exit code 1 and a message naming what happened, and the unpacked folder is removed.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_geardyn");

const MD: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="ctor" guid="{ctor}" description="constructor stub">
  <CoSimulation modelIdentifier="ctor"/>
  <ModelVariables>
    <ScalarVariable name="y" valueReference="0" causality="output"><Real/></ScalarVariable>
  </ModelVariables>
  <ModelStructure><Outputs><Unknown index="1"/></Outputs></ModelStructure>
</fmiModelDescription>
"#;

/// The stub FMU (tests/fixtures/ctor_fmu.c compiled with the system C compiler) in `dir`.
fn ctor_fmu(dir: &Path) -> PathBuf {
    let so = dir.join("ctor.so");
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/ctor_fmu.c");
    let st = Command::new(std::env::var("CC").unwrap_or_else(|_| "cc".into()))
        .args(["-shared", "-fPIC", "-O1", "-o"])
        .arg(&so)
        .arg(&src)
        .status()
        .expect("a C compiler (cc) is needed for the stub FMU");
    assert!(st.success());
    let fmu = dir.join("ctor.fmu");
    let mut z = zip::ZipWriter::new(std::fs::File::create(&fmu).unwrap());
    let opts = zip::write::SimpleFileOptions::default();
    for (name, bytes) in [
        ("modelDescription.xml", MD.as_bytes().to_vec()),
        ("binaries/linux64/ctor.so", std::fs::read(&so).unwrap()),
    ] {
        z.start_file(name, opts).unwrap();
        z.write_all(&bytes).unwrap();
    }
    z.finish().unwrap();
    fmu
}

/// Runs `geardyn validate` with the stub's behaviour `how`, TMPDIR in `tmp`; after `term`
/// sends SIGTERM. Returns (exit code, stdout + stderr, seconds).
fn validate(
    fmu: &Path,
    tmp: &Path,
    how: Option<&str>,
    term: Option<Duration>,
) -> (i32, String, f64) {
    std::fs::create_dir_all(tmp).unwrap();
    let mut cmd = Command::new(BIN);
    cmd.args(["validate"])
        .arg(fmu)
        .env("TMPDIR", tmp)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    if let Some(h) = how {
        cmd.env("GEARDYN_CTOR_STUB", h);
    }
    let start = Instant::now();
    let child = cmd.spawn().unwrap();
    if let Some(after) = term {
        std::thread::sleep(after);
        // SAFETY: signals our own child.
        unsafe { libc::kill(child.id() as i32, libc::SIGTERM) };
    }
    let out = child.wait_with_output().unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(!text.contains("panicked"), "{text}");
    let left: Vec<_> = std::fs::read_dir(tmp).unwrap().collect();
    assert!(
        left.is_empty(),
        "{how:?}: temporary files left behind: {left:?}"
    );
    (
        out.status.code().unwrap_or(-1),
        text,
        start.elapsed().as_secs_f64(),
    )
}

#[test]
fn a_misbehaving_initialiser_is_reported_and_cleaned_up() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("validate_supervised");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let fmu = ctor_fmu(&dir);
    let tmp = dir.join("tmp");
    // Loads, but has none of the FMI functions: a problem, named.
    let (code, text, _) = validate(&fmu, &tmp, None, None);
    assert_eq!(code, 1, "{text}");
    assert!(text.contains("fmi2"), "{text}");
    for (how, expect) in [
        ("segv", "killed by signal 11 (SIGSEGV"),
        ("exit", "exit status 3"),
    ] {
        let (code, text, _) = validate(&fmu, &tmp, Some(how), None);
        assert_eq!(code, 1, "{how}: {text}");
        assert!(
            text.contains(expect) && text.contains("while loading the FMU's library"),
            "{how}: {text}"
        );
    }
    // A blocking initialiser: SIGTERM ends it within the grace time, with a message.
    let (code, text, secs) = validate(&fmu, &tmp, Some("block"), Some(Duration::from_millis(500)));
    assert_eq!(code, 1, "block: {text}");
    assert!(
        text.contains("SIGTERM") && text.contains("while loading the FMU's library"),
        "block: {text}"
    );
    assert!(secs < 5.0, "block: ended after {secs:.1} s");
}
