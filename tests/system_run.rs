//! `geardyn run` on SSP systems (issue 18, point 4): the master against closed forms, the
//! single-FMU runner, and every refusal.
//!
//! The FMUs: `tests/fixtures/linear_fmu.c` (compiled here), an exact integrator x' = k·u with
//! input and output derivatives, so that each coupling has a closed-form result; and the
//! shipped `spur_pair` FMU, built here with `geardyn fmu build`, for the comparison with
//! single-FMU runs. Oracles: closed forms (chains of integrators, the harmonic oscillator
//! cos t / −sin t) and `geardyn run` of the FMU alone, never the master itself.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

const BIN: &str = env!("CARGO_BIN_EXE_geardyn");

fn scratch(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("system_run")
        .join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn linear_so() -> PathBuf {
    static SO: OnceLock<PathBuf> = OnceLock::new();
    SO.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("system_run_so");
        std::fs::create_dir_all(&dir).unwrap();
        let out = dir.join("linear.so");
        let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/linear_fmu.c");
        let st = Command::new(std::env::var("CC").unwrap_or_else(|_| "cc".into()))
            .args(["-shared", "-fPIC", "-O1", "-o"])
            .arg(&out)
            .arg(&src)
            .status()
            .expect("a C compiler (cc) is needed for the linear test FMU");
        assert!(st.success());
        out
    })
    .clone()
}

/// Capabilities and units of a linear FMU.
#[derive(Clone, Copy)]
struct Caps {
    interpolate: bool,
    order: u32,
    u_unit: &'static str,
    x_unit: &'static str,
    /// canGetAndSetFMUstate (the fixture copies its model).
    state: bool,
}

const CAPS: Caps = Caps {
    interpolate: true,
    order: 1,
    state: true,
    u_unit: "m",
    x_unit: "m",
};

fn linear_md(c: Caps) -> String {
    format!(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="linear" guid="{{linear-fmu}}">
  <CoSimulation modelIdentifier="linear" canHandleVariableCommunicationStepSize="true" canInterpolateInputs="{}" maxOutputDerivativeOrder="{}" canGetAndSetFMUstate="{}"/>
  <UnitDefinitions>
    <Unit name="m"><BaseUnit m="1"/></Unit>
    <Unit name="mm"><BaseUnit m="1" factor="0.001"/></Unit>
    <Unit name="m/s"><BaseUnit m="1" s="-1"/></Unit>
    <Unit name="N.m"><BaseUnit kg="1" m="2" s="-2"/></Unit>
    <Unit name="J"><BaseUnit kg="1" m="2" s="-2"/></Unit>
  </UnitDefinitions>
  <ModelVariables>
    <ScalarVariable name="k" valueReference="0" causality="parameter" variability="fixed"><Real start="1"/></ScalarVariable>
    <ScalarVariable name="u" valueReference="1" causality="input"><Real start="0" unit="{}"/></ScalarVariable>
    <ScalarVariable name="x" valueReference="2" causality="output"><Real unit="{}"/></ScalarVariable>
    <ScalarVariable name="x0" valueReference="3" causality="parameter" variability="fixed"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="y" valueReference="4" causality="output"><Real unit="{}"/></ScalarVariable>
    <ScalarVariable name="refuse_at" valueReference="5" causality="parameter" variability="fixed"><Real start="1e300"/></ScalarVariable>
    <ScalarVariable name="refuse_how" valueReference="6" causality="parameter" variability="fixed"><Real start="2"/></ScalarVariable>
    <ScalarVariable name="n" valueReference="7" causality="input"><Integer start="0"/></ScalarVariable>
    <ScalarVariable name="abort_at" valueReference="8" causality="parameter" variability="fixed"><Real start="1e300"/></ScalarVariable>
  </ModelVariables>
  <ModelStructure>
    <Outputs><Unknown index="3" dependencies=""/><Unknown index="5" dependencies="2"/></Outputs>
    <InitialUnknowns><Unknown index="3"/><Unknown index="5"/></InitialUnknowns>
  </ModelStructure>
</fmiModelDescription>
"#,
        c.interpolate, c.order, c.state, c.u_unit, c.x_unit, c.x_unit
    )
}

fn write_zip(path: &Path, entries: &[(&str, Vec<u8>)]) {
    use std::io::Write;
    let mut z = zip::ZipWriter::new(std::fs::File::create(path).unwrap());
    let opts = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated);
    for (name, bytes) in entries {
        z.start_file(*name, opts).unwrap();
        z.write_all(bytes).unwrap();
    }
    z.finish().unwrap();
}

fn linear_fmu(path: &Path, c: Caps) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    write_zip(
        path,
        &[
            ("modelDescription.xml", linear_md(c).into_bytes()),
            (
                "binaries/linux64/linear.so",
                std::fs::read(linear_so()).unwrap(),
            ),
        ],
    );
}

/// A component: name, source, connectors (name, kind, type element), parameters (name, value).
struct Comp<'a> {
    name: &'a str,
    source: &'a str,
    connectors: Vec<(&'a str, &'a str, String)>,
    params: Vec<(&'a str, String)>,
}

fn real(unit: Option<&str>) -> String {
    match unit {
        Some(u) => format!("<ssc:Real unit=\"{u}\"/>"),
        None => "<ssc:Real/>".into(),
    }
}

/// A linear element with connectors u (input), x and y (outputs), n (Integer input).
fn lin<'a>(name: &'a str, params: &[(&'a str, f64)]) -> Comp<'a> {
    Comp {
        name,
        source: "resources/linear.fmu",
        connectors: vec![
            ("u", "input", real(None)),
            ("x", "output", real(None)),
            ("y", "output", real(None)),
            ("n", "input", "<ssc:Integer/>".into()),
        ],
        params: params.iter().map(|(n, v)| (*n, format!("{v:?}"))).collect(),
    }
}

/// A connection: start element, connector, end element, connector, optional (factor, offset).
type Conn<'a> = (&'a str, &'a str, &'a str, &'a str, Option<(f64, f64)>);
/// A coupling case: algorithm, extrapolation, B.x/(k c h²) as a function of the step count.
type Case = (&'static str, &'static str, fn(f64) -> f64);

/// SystemStructure.ssd text. `connections`: (start element, connector, end element,
/// connector, optional (factor, offset)).
fn ssd(comps: &[Comp], connections: &[Conn], stop: f64, units: &str) -> String {
    let mut s = String::from(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<ssd:SystemStructureDescription xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" version="1.0" name="test">
  <ssd:System name="root">
    <ssd:Elements>
"#,
    );
    for c in comps {
        s += &format!(
            "      <ssd:Component name=\"{}\" type=\"application/x-fmu-sharedlibrary\" source=\"{}\">\n        <ssd:Connectors>\n",
            c.name, c.source
        );
        for (n, k, t) in &c.connectors {
            s += &format!(
                "          <ssd:Connector name=\"{n}\" kind=\"{k}\">{t}</ssd:Connector>\n"
            );
        }
        s += "        </ssd:Connectors>\n";
        if !c.params.is_empty() {
            s += "        <ssd:ParameterBindings><ssd:ParameterBinding><ssd:ParameterValues>\n          <ssv:ParameterSet version=\"1.0\" name=\"p\"><ssv:Parameters>\n";
            for (n, v) in &c.params {
                s += &format!("            <ssv:Parameter name=\"{n}\"><ssv:Real value=\"{v}\"/></ssv:Parameter>\n");
            }
            s += "          </ssv:Parameters></ssv:ParameterSet>\n        </ssd:ParameterValues></ssd:ParameterBinding></ssd:ParameterBindings>\n";
        }
        s += "      </ssd:Component>\n";
    }
    s += "    </ssd:Elements>\n    <ssd:Connections>\n";
    for (a, ac, b, bc, t) in connections {
        match t {
            None => s += &format!("      <ssd:Connection startElement=\"{a}\" startConnector=\"{ac}\" endElement=\"{b}\" endConnector=\"{bc}\"/>\n"),
            Some((f, o)) => s += &format!("      <ssd:Connection startElement=\"{a}\" startConnector=\"{ac}\" endElement=\"{b}\" endConnector=\"{bc}\"><ssc:LinearTransformation factor=\"{f:?}\" offset=\"{o:?}\"/></ssd:Connection>\n"),
        }
    }
    s += "    </ssd:Connections>\n  </ssd:System>\n";
    s += units;
    s += &format!("  <ssd:DefaultExperiment startTime=\"0\" stopTime=\"{stop:?}\"/>\n</ssd:SystemStructureDescription>\n");
    s
}

/// A system folder with the SSD and the linear FMU (capabilities `c`).
fn system(name: &str, text: &str, c: Caps) -> PathBuf {
    let d = scratch(name);
    let sys = d.join("sys");
    linear_fmu(&sys.join("resources/linear.fmu"), c);
    std::fs::write(sys.join("SystemStructure.ssd"), text).unwrap();
    sys
}

fn geardyn(args: &[&dyn AsRef<std::ffi::OsStr>]) -> Output {
    let mut cmd = Command::new(BIN);
    for a in args {
        cmd.arg(a);
    }
    cmd.output().unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn read_rows(p: &Path) -> (String, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(p).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().to_string();
    let rows = lines
        .map(|l| l.split(',').map(|c| c.parse::<f64>().unwrap()).collect())
        .collect();
    (header, rows)
}

/// Run a system to `out`, asserting success; the rows.
fn run_ok(sys: &Path, out: &Path, extra: &[&str]) -> (String, Vec<Vec<f64>>, String) {
    let mut args: Vec<&dyn AsRef<std::ffi::OsStr>> = vec![&"run", &sys, &"--out", &out];
    for e in extra {
        args.push(e);
    }
    let o = geardyn(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let (h, r) = read_rows(out);
    (h, r, stderr(&o))
}

/// A → B chain: A integrates a constant c (bound as A.u's start value), B integrates A.x.
/// A.x = c t exactly; B.x over the grid t_n = n h has a closed form for each coupling:
/// Jacobi hold k c h² n(n−1)/2, Gauss–Seidel hold k c h² n(n+1)/2 (B sees A.x at the end of
/// the step), and the exact k c t²/2 for extrapolation and interpolation (A.x is linear).
#[test]
fn chain_matches_the_closed_form_of_each_coupling() {
    let (c, kb, h) = (2.0, 0.5, 0.1);
    let text = ssd(
        &[lin("A", &[("u", c)]), lin("B", &[("k", kb)])],
        &[("A", "x", "B", "u", None)],
        1.0,
        "",
    );
    let sys = system("chain", &text, CAPS);
    let out = sys.parent().unwrap().join("o.csv");
    let cases: [Case; 4] = [
        ("jacobi", "none", |n| n * (n - 1.0) / 2.0),
        ("gauss-seidel", "none", |n| n * (n + 1.0) / 2.0),
        ("jacobi", "linear", |n| n * n / 2.0),
        ("gauss-seidel", "linear", |n| n * n / 2.0),
    ];
    for (alg, ex, form) in cases {
        let (header, rows, err) = run_ok(
            &sys,
            &out,
            &[
                "--output-interval",
                "0.1",
                "--algorithm",
                alg,
                "--extrapolation",
                ex,
                "--outputs",
                "B.x",
            ],
        );
        assert_eq!(header, "\"time\",\"A.x\",\"B.x\"");
        assert!(!err.contains("zero-order hold"), "{err}");
        assert_eq!(rows.len(), 11);
        for (i, r) in rows.iter().enumerate() {
            let n = i as f64;
            assert!(
                (r[1] - c * n * h).abs() <= 1e-14,
                "{alg}/{ex} A.x row {i}: {}",
                r[1]
            );
            let want = kb * c * h * h * form(n);
            assert!(
                (r[2] - want).abs() <= 1e-13,
                "{alg}/{ex} B.x row {i}: {} vs {want}",
                r[2]
            );
        }
    }
    // Without the capabilities, linear falls back to the hold, and says so per connection.
    let sys = system(
        "chain_nocaps",
        &text,
        Caps {
            interpolate: false,
            order: 0,
            ..CAPS
        },
    );
    let (_, rows, err) = run_ok(
        &sys,
        &out,
        &[
            "--output-interval",
            "0.1",
            "--algorithm",
            "jacobi",
            "--outputs",
            "B.x",
        ],
    );
    assert!(
        err.contains("connection A.x → B.u (line")
            && err.contains("zero-order hold: A declares maxOutputDerivativeOrder=\"0\" and B does not declare canInterpolateInputs=\"true\""),
        "{err}"
    );
    let n = 10.0;
    assert!((rows[10][2] - kb * c * h * h * n * (n - 1.0) / 2.0).abs() <= 1e-13);
}

/// The harmonic oscillator as two coupled integrators: A.x' = B.x, B.x' = −A.x, A.x(0) = 1,
/// so A.x = cos t and B.x = −sin t. The error at t = 2 falls with the communication step at
/// order 1 with the hold and order 2 with extrapolation/interpolation (the cycle is cut in
/// Gauss–Seidel: one connection is extrapolated, the other interpolated).
#[test]
fn coupled_oscillator_converges_at_the_order_of_the_coupling() {
    let text = ssd(
        &[lin("A", &[("x0", 1.0)]), lin("B", &[("k", -1.0)])],
        &[("A", "x", "B", "u", None), ("B", "x", "A", "u", None)],
        2.0,
        "",
    );
    let sys = system("oscillator", &text, CAPS);
    let out = sys.parent().unwrap().join("o.csv");
    let steps = [0.04, 0.02, 0.01, 0.005];
    let mut table = String::new();
    for (alg, ex, order) in [
        ("jacobi", "none", 1.0),
        ("gauss-seidel", "none", 1.0),
        ("jacobi", "linear", 2.0),
        ("gauss-seidel", "linear", 2.0),
    ] {
        let mut errs = Vec::new();
        for h in steps {
            let hs = format!("{h}");
            let (header, rows, _) = run_ok(
                &sys,
                &out,
                &[
                    "--output-interval",
                    &hs,
                    "--algorithm",
                    alg,
                    "--extrapolation",
                    ex,
                ],
            );
            assert_eq!(header, "\"time\",\"A.x\",\"B.x\"");
            let e = rows
                .iter()
                .map(|r| (r[1] - r[0].cos()).abs().max((r[2] + r[0].sin()).abs()))
                .fold(0.0, f64::max);
            errs.push(e);
        }
        let orders: Vec<f64> = errs.windows(2).map(|w| (w[0] / w[1]).log2()).collect();
        let es: Vec<String> = errs.iter().map(|e| format!("{e:.3e}")).collect();
        let os: Vec<String> = orders.iter().map(|o| format!("{o:.3}")).collect();
        table += &format!(
            "{alg:>12} {ex:>6}: max error {} | observed orders {}\n",
            es.join(" "),
            os.join(" ")
        );
        for o in &orders {
            assert!(
                (o - order).abs() < 0.15,
                "{alg}/{ex}: orders {orders:?}, errors {errs:?}"
            );
        }
    }
    eprintln!("{table}");
}

#[test]
fn a_refused_step_keeps_the_rows_before_and_names_element_time_and_status() {
    for (how, status) in [(2.0, "fmi2Discard"), (3.0, "fmi2Error")] {
        let text = ssd(
            &[
                lin("A", &[("u", 1.0)]),
                lin("B", &[("refuse_at", 0.35), ("refuse_how", how)]),
            ],
            &[("A", "x", "B", "u", None)],
            1.0,
            "",
        );
        let sys = system("refused", &text, CAPS);
        let out = sys.parent().unwrap().join("o.csv");
        let o = geardyn(&[&"run", &sys, &"--out", &out, &"--output-interval", &"0.1"]);
        assert_eq!(o.status.code(), Some(1));
        let e = stderr(&o);
        assert!(
            e.contains("element \"B\" refused the step from t = 0.30000000000000004 with h = 0.09999999999999998")
                && e.contains(status)
                && e.contains("refuse_at=0.35")
                && e.contains("4 rows up to t = 0.30000000000000004 were written"),
            "{e}"
        );
        let (_, rows) = read_rows(&out);
        assert_eq!(rows.len(), 4);
    }
}

/// An element that ends the simulation itself (fmi2Discard with fmi2Terminated = true) ends
/// the run normally (issue 39): exit 0, the rows up to the last communication point, one note
/// naming the element, its last successful time and its reason; every instance terminated.
#[test]
fn an_element_that_ends_the_simulation_is_a_normal_end() {
    let text = ssd(
        &[
            lin("A", &[("u", 1.0)]),
            lin("B", &[("refuse_at", 0.35), ("refuse_how", 4.0)]),
        ],
        &[("A", "x", "B", "u", None)],
        1.0,
        "",
    );
    let sys = system("ended", &text, CAPS);
    let out = sys.parent().unwrap().join("o.csv");
    for alg in ["jacobi", "gauss-seidel"] {
        let o = geardyn(&[
            &"run",
            &sys,
            &"--out",
            &out,
            &"--output-interval",
            &"0.1",
            &"--algorithm",
            &alg,
            &"--fmi-trace",
        ]);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(0), "{e}");
        let notes: Vec<&str> = e.lines().filter(|l| !l.starts_with("[FMI]")).collect();
        assert_eq!(
            notes,
            ["note: element \"B\" ended the simulation itself at t = 0.30000000000000004 in the step from t = 0.30000000000000004 (fmi2Terminated after fmi2DoStep returned fmi2Discard: end of the test drive (refuse_at=0.35)); the rows end at t = 0.30000000000000004"],
            "{alg}: {e}"
        );
        assert_eq!(
            e.matches("fmi2Terminate() -> fmi2OK").count(),
            2,
            "{alg}: {e}"
        );
        let (_, rows) = read_rows(&out);
        assert_eq!(rows.len(), 4, "{alg}");
        assert_eq!(rows[3][0], 0.30000000000000004);
    }
}

/// The system runs under the crash supervision of single runs: an FMU that aborts ends the
/// run with a message naming the signal, the call and the time; the rows before are kept.
#[test]
fn a_crashing_fmu_is_reported_and_the_rows_before_are_kept() {
    let text = ssd(
        &[lin("A", &[("u", 1.0)]), lin("B", &[("abort_at", 0.35)])],
        &[("A", "x", "B", "u", None)],
        1.0,
        "",
    );
    let sys = system("crash", &text, CAPS);
    let out = sys.parent().unwrap().join("o.csv");
    let o = geardyn(&[&"run", &sys, &"--out", &out, &"--output-interval", &"0.1"]);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(
        e.contains("SIGABRT")
            && e.contains("during fmi2DoStep at t = 0.30000000000000004")
            && e.contains("4 rows up to t = 0.30000000000000004 were written"),
        "{e}"
    );
    assert_eq!(read_rows(&out).1.len(), 4);
}

/// An FMU that cannot be instantiated (here: its binary refuses the GUID) ends the run before
/// any row, naming the element and the FMU's reason; no CSV is left.
#[test]
fn a_failing_instantiation_names_the_element_and_leaves_no_csv() {
    let text = ssd(
        &[lin("A", &[]), lin("B", &[])],
        &[("A", "x", "B", "u", None)],
        1.0,
        "",
    );
    let d = scratch("guid");
    let sys = d.join("sys");
    std::fs::create_dir_all(sys.join("resources")).unwrap();
    write_zip(
        &sys.join("resources/linear.fmu"),
        &[
            (
                "modelDescription.xml",
                linear_md(CAPS)
                    .replace("{linear-fmu}", "{other}")
                    .into_bytes(),
            ),
            (
                "binaries/linux64/linear.so",
                std::fs::read(linear_so()).unwrap(),
            ),
        ],
    );
    std::fs::write(sys.join("SystemStructure.ssd"), text).unwrap();
    let out = d.join("o.csv");
    let o = geardyn(&[&"run", &sys, &"--out", &out]);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(
        e.contains("element \"A\": fmi2Instantiate returned NULL") && e.contains("wrong GUID"),
        "{e}"
    );
    assert!(!out.exists());
}

/// Every bad system gives exit 1, a message naming the item, and no CSV.
#[test]
fn bad_systems_are_refused_naming_the_item() {
    let two = |conns: &[Conn]| ssd(&[lin("A", &[]), lin("B", &[])], conns, 1.0, "");
    let mut unit_comp_a = lin("A", &[]);
    unit_comp_a.connectors[1].2 = real(Some("J"));
    let mut unit_comp_b = lin("B", &[]);
    unit_comp_b.connectors[0].2 = real(Some("N.m"));
    let units = "  <ssd:Units>\n    <ssc:Unit name=\"J\"><ssc:BaseUnit kg=\"1\" m=\"2\" s=\"-2\"/></ssc:Unit>\n    <ssc:Unit name=\"N.m\"><ssc:BaseUnit kg=\"1\" m=\"2\" s=\"-2\"/></ssc:Unit>\n    <ssc:Unit name=\"m/s\"><ssc:BaseUnit m=\"1\" s=\"-1\"/></ssc:Unit>\n  </ssd:Units>\n";
    let mut kind_comp = lin("A", &[]);
    kind_comp.connectors[1].1 = "input";
    let mut missing = lin("B", &[]);
    missing.source = "resources/missing.fmu";
    let mut conn_unit = lin("A", &[]);
    conn_unit.connectors[1].2 = real(Some("m/s"));
    let cases: Vec<(&str, String, Caps, Vec<&str>)> = vec![
        ("unknown element", two(&[("A", "x", "C", "u", None)]), CAPS,
            vec!["connection A.x → C.u (line", "unknown end element \"C\"", "\"A\", \"B\""]),
        ("unknown connector", two(&[("A", "z", "B", "u", None)]), CAPS,
            vec!["connection A.z → B.u", "element \"A\" has no connector \"z\"", "\"u\", \"x\", \"y\", \"n\""]),
        ("input as start", two(&[("A", "u", "B", "u", None)]), CAPS,
            vec!["connection A.u → B.u", "the start A.u is an input connector", "starts at an output"]),
        ("output as end", two(&[("A", "x", "B", "y", None)]), CAPS,
            vec!["connection A.x → B.y", "the end B.y is an output connector"]),
        ("kind vs causality", ssd(&[kind_comp, lin("B", &[])], &[], 1.0, ""), CAPS,
            vec!["connector A.x has kind=\"input\"", "causality=\"output\""]),
        ("type mismatch", two(&[("A", "x", "B", "n", None)]), CAPS,
            vec!["connection A.x → B.n", "type mismatch: A.x is Real, B.n is Integer"]),
        ("unit mismatch", two(&[("A", "x", "B", "u", None)]), Caps { u_unit: "m/s", ..CAPS },
            vec!["connection A.x → B.u", "unit mismatch: A.x is in \"m\" (m), B.u in \"m/s\" (m·s-1)"]),
        ("connector unit vs FMU unit", ssd(&[conn_unit, lin("B", &[])], &[], 1.0, units), CAPS,
            vec!["connector A.x has unit=\"m/s\" (m·s-1), but the FMU declares \"x\" with unit=\"m\" (m)"]),
        ("input connected twice", two(&[("A", "x", "B", "u", None), ("A", "y", "B", "u", None)]), CAPS,
            vec!["connection A.y → B.u", "the input B.u is already connected by connection A.x → B.u"]),
        ("algebraic loop", two(&[("A", "y", "B", "u", None), ("B", "y", "A", "u", None)]), CAPS,
            vec!["algebraic loop between direct-feedthrough ports: A.y → B.u → B.y → A.u → A.y"]),
        ("missing FMU", ssd(&[lin("A", &[]), missing], &[], 1.0, ""), CAPS,
            vec!["component \"B\": its FMU source=\"resources/missing.fmu\" is not in the folder"]),
        ("unknown parameter", ssd(&[lin("A", &[("nope", 1.0)]), lin("B", &[])], &[], 1.0, ""), CAPS,
            vec!["parameter of element \"A\"", "no variable named \"nope\""]),
        ("parameter unit", ssd(&[lin("A", &[("u", 1.0)]), lin("B", &[])], &[], 1.0, units)
            .replace("<ssv:Real value=\"1.0\"/>", "<ssv:Real value=\"1.0\" unit=\"m/s\"/>"), CAPS,
            vec!["parameter \"u\" of element \"A\" is given in unit=\"m/s\", but the FMU declares unit=\"m\""]),
        ("output as parameter", ssd(&[lin("A", &[("x", 1.0)]), lin("B", &[])], &[], 1.0, ""), CAPS,
            vec!["parameter of element \"A\"", "\"x\" is not a parameter or input"]),
    ];
    for (what, text, caps, needles) in cases {
        let sys = system("bad", &text, caps);
        let out = sys.parent().unwrap().join("o.csv");
        let o = geardyn(&[&"run", &sys, &"--out", &out]);
        assert_eq!(o.status.code(), Some(1), "{what}");
        let e = stderr(&o);
        for n in needles {
            assert!(e.contains(n), "{what}: expected {n:?} in {e}");
        }
        assert!(!out.exists(), "{what}: a CSV was left");
    }
    // Compatible units pass (J and N.m have the same base units); the negative control of
    // the loop (A.x does not depend on A.u) runs.
    let ok = ssd(
        &[unit_comp_a, unit_comp_b],
        &[("A", "x", "B", "u", None)],
        1.0,
        units,
    );
    let sys = system(
        "units_ok",
        &ok,
        Caps {
            u_unit: "N.m",
            x_unit: "J",
            ..CAPS
        },
    );
    run_ok(&sys, &sys.parent().unwrap().join("o.csv"), &[]);
    let sys = system(
        "no_loop",
        &two(&[("A", "x", "B", "u", None), ("B", "y", "A", "u", None)]),
        CAPS,
    );
    run_ok(&sys, &sys.parent().unwrap().join("o.csv"), &[]);
    // Options that belong to systems are refused for a single FMU and vice versa.
    let o = geardyn(&[
        &"run",
        &sys.join("resources/linear.fmu"),
        &"--algorithm",
        &"jacobi",
    ]);
    assert!(
        stderr(&o).contains(
            "--algorithm, --extrapolation, --threads and --divergence-factor are for systems"
        ),
        "{}",
        stderr(&o)
    );
    let o = geardyn(&[&"run", &sys, &"--algorithm", &"euler"]);
    assert!(stderr(&o).contains("--algorithm \"euler\": expected jacobi or gauss-seidel"));
    for (args, needle) in [
        (
            ["--outputs", "C.x"],
            "--outputs \"C.x\": the system has no element \"C\"",
        ),
        (
            ["--outputs", "A.q"],
            "--outputs \"A.q\": the FMU of \"A\" has no variable \"q\"",
        ),
        (
            ["--outputs", "x"],
            "--outputs \"x\": name a variable of a system as Element.variable",
        ),
        (
            ["--start", "A.q=1"],
            "--start A.q=1: the FMU has no variable named \"q\"",
        ),
        (
            ["--start", "k=1"],
            "--start k: name a variable as Element.variable",
        ),
        (
            ["--extrapolation", "cubic"],
            "--extrapolation \"cubic\": expected none or linear",
        ),
    ] {
        let out = sys.parent().unwrap().join("x.csv");
        let o = geardyn(&[&"run", &sys, &"--out", &out, &args[0], &args[1]]);
        assert_eq!(o.status.code(), Some(1));
        assert!(stderr(&o).contains(needle), "{needle}: {}", stderr(&o));
        assert!(!out.exists());
    }
}

/// Unit conversion through the base units (mm → m) and a LinearTransformation are applied;
/// an `.ssp` archive of the same folder gives the same bytes; `--start Element.var=value`
/// overrides a binding.
#[test]
fn conversions_archives_and_start_values() {
    let text = ssd(
        &[lin("A", &[("u", 1.0)]), lin("B", &[]), lin("C", &[])],
        &[
            ("A", "x", "B", "u", None),
            ("A", "x", "C", "u", Some((3.0, 0.5))),
        ],
        1.0,
        "",
    );
    let d = scratch("conversions");
    let sys = d.join("sys");
    // B's u is in mm: A.x in m arrives multiplied by 1000.
    linear_fmu(&sys.join("resources/linear.fmu"), CAPS);
    linear_fmu(
        &sys.join("resources/linear_mm.fmu"),
        Caps {
            u_unit: "mm",
            ..CAPS
        },
    );
    let text = text.replacen(
        "name=\"B\" type=\"application/x-fmu-sharedlibrary\" source=\"resources/linear.fmu\"",
        "name=\"B\" type=\"application/x-fmu-sharedlibrary\" source=\"resources/linear_mm.fmu\"",
        1,
    );
    std::fs::write(sys.join("SystemStructure.ssd"), &text).unwrap();
    let out = d.join("o.csv");
    let args = [
        "--output-interval",
        "0.25",
        "--algorithm",
        "jacobi",
        "--extrapolation",
        "none",
        "--outputs",
        "B.x,C.x,B.u,C.u",
        "--start",
        "A.k=2",
    ];
    let (header, rows, _) = run_ok(&sys, &out, &args);
    assert_eq!(header, "\"time\",\"A.x\",\"B.x\",\"C.x\",\"B.u\",\"C.u\"");
    for r in &rows {
        let ax = 2.0 * r[0];
        assert!((r[1] - ax).abs() < 1e-15);
        if r[0] > 0.0 {
            // Inputs at t are the outputs at t − h (Jacobi, set before the last step).
            let prev = 2.0 * (r[0] - 0.25);
            assert!((r[4] - 1000.0 * prev).abs() < 1e-9, "{r:?}");
            assert!((r[5] - (3.0 * prev + 0.5)).abs() < 1e-12, "{r:?}");
        }
    }
    // The same system as an .ssp archive.
    let ssp = d.join("sys.ssp");
    let mut entries = vec![("SystemStructure.ssd", text.into_bytes())];
    for f in ["linear.fmu", "linear_mm.fmu"] {
        entries.push((
            if f == "linear.fmu" {
                "resources/linear.fmu"
            } else {
                "resources/linear_mm.fmu"
            },
            std::fs::read(sys.join("resources").join(f)).unwrap(),
        ));
    }
    write_zip(&ssp, &entries);
    let out2 = d.join("o2.csv");
    run_ok(&ssp, &out2, &args);
    assert_eq!(std::fs::read(&out).unwrap(), std::fs::read(&out2).unwrap());
    // The .ssd file itself, named on the command line.
    let out3 = d.join("o3.csv");
    run_ok(&sys.join("SystemStructure.ssd"), &out3, &args);
    assert_eq!(std::fs::read(&out).unwrap(), std::fs::read(&out3).unwrap());
    // An archive without one of the FMUs names it.
    write_zip(&ssp, &entries[..2]);
    let o = geardyn(&[&"run", &ssp, &"--out", &out2]);
    let e = stderr(&o);
    assert!(
        e.contains(
            "component \"B\": its FMU source=\"resources/linear_mm.fmu\" is not in the archive"
        ),
        "{e}"
    );
}

/// The shipped spur_pair FMU, built here.
fn spur_pair() -> PathBuf {
    static FMU: OnceLock<PathBuf> = OnceLock::new();
    FMU.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("system_run_fmus");
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("fmu/spur_pair");
        let o = geardyn(&[&"fmu", &"build", &scene, &"--out", &dir]);
        assert!(o.status.success(), "{}", stderr(&o));
        dir.join("spur_pair.fmu")
    })
    .clone()
}

/// Independent check (a): a system of spur_pair instances without connections, with start
/// values from parameter bindings, gives byte for byte the rows of `geardyn run` of the FMU
/// alone with the same start values; two instances of one FMU in one process stay independent.
#[test]
fn unconnected_instances_equal_single_fmu_runs_byte_for_byte() {
    let d = scratch("spur_single");
    let sys = d.join("sys");
    std::fs::create_dir_all(sys.join("resources")).unwrap();
    std::fs::copy(spur_pair(), sys.join("resources/spur_pair.fmu")).unwrap();
    let comp = |name: &'static str, torque: f64| Comp {
        name,
        source: "resources/spur_pair.fmu",
        connectors: vec![],
        params: vec![("operating.input_torque", format!("{torque:?}"))],
    };
    let text = ssd(&[comp("g1", 130.0), comp("g2", 70.0)], &[], 0.005, "");
    std::fs::write(sys.join("SystemStructure.ssd"), text).unwrap();
    let out = d.join("sys.csv");
    let (header, _, _) = run_ok(
        &sys,
        &out,
        &[
            "--output-interval",
            "1e-5",
            "--outputs",
            "g1.mesh.dte,g1.mesh.force,g2.mesh.dte,g2.mesh.force",
        ],
    );
    assert_eq!(
        header,
        "\"time\",\"g1.mesh.dte\",\"g1.mesh.force\",\"g2.mesh.dte\",\"g2.mesh.force\""
    );
    let system_text = std::fs::read_to_string(&out).unwrap();
    for (k, torque) in [(0, "130"), (1, "70")] {
        let single = d.join(format!("single{k}.csv"));
        let o = geardyn(&[
            &"run",
            &sys.join("resources/spur_pair.fmu"),
            &"--out",
            &single,
            &"--start",
            &format!("operating.input_torque={torque}"),
            &"--stop-time",
            &"0.005",
            &"--output-interval",
            &"1e-5",
            &"--outputs",
            &"mesh.dte,mesh.force",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let single_text = std::fs::read_to_string(&single).unwrap();
        let a: Vec<String> = system_text
            .lines()
            .skip(1)
            .map(|l| {
                let c: Vec<&str> = l.split(',').collect();
                format!("{},{},{}", c[0], c[1 + 2 * k], c[2 + 2 * k])
            })
            .collect();
        let b: Vec<&str> = single_text.lines().skip(1).collect();
        assert_eq!(a.len(), 501);
        assert_eq!(a, b, "instance g{}", k + 1);
    }
}

/// Issue 32, "a master that says why": a step our own FMU refuses (a pinion speed whose next
/// step spans more mesh periods than a step may take) is reported at the default log level
/// with the FMU's logged reason, once, in the one error line: for the FMU alone and in a
/// system. (Before, the reason showed only with `--log-level all`.)
#[test]
fn a_refused_step_names_the_fmus_reason_at_the_default_log_level() {
    let d = scratch("spur_reason");
    let sys = d.join("sys");
    std::fs::create_dir_all(sys.join("resources")).unwrap();
    std::fs::copy(spur_pair(), sys.join("resources/spur_pair.fmu")).unwrap();
    let why = "operating.pinion_speed = 1e11 rad/s";
    let o = geardyn(&[
        &"run",
        &sys.join("resources/spur_pair.fmu"),
        &"--out",
        &d.join("single.csv"),
        &"--start",
        &"operating.pinion_speed=1e11",
        &"--output-interval",
        &"2e-4",
        &"--stop-time",
        &"4e-4",
    ]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert_eq!(e.lines().count(), 1, "{e}");
    assert!(
        e.starts_with("error: the FMU refused the step from t = 0 with h = 0.0002: fmi2DoStep returned fmi2Discard: ")
            && e.matches(why).count() == 1
            && e.contains("more than the 1.048576e6 one step may take")
            && !e.contains("terminate")
            && !e.contains("logged no reason"),
        "{e}"
    );
    let comp = Comp {
        name: "g1",
        source: "resources/spur_pair.fmu",
        connectors: vec![],
        params: vec![("operating.pinion_speed", "1e11".into())],
    };
    std::fs::write(sys.join("SystemStructure.ssd"), ssd(&[comp], &[], 4e-4, "")).unwrap();
    let o = geardyn(&[
        &"run",
        &sys,
        &"--out",
        &d.join("sys.csv"),
        &"--output-interval",
        &"2e-4",
    ]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert_eq!(e.lines().count(), 1, "{e}");
    assert!(
        e.starts_with("error: element \"g1\" refused the step from t = 0 with h = 0.0002 (fmi2Discard): fmi2DoStep returned fmi2Discard: ")
            && e.matches(why).count() == 1
            && e.contains("; last successful time 0"),
        "{e}"
    );
}

/// Issue 32, divergence: the oscillator A.x' = k B.x, B.x' = −k A.x (k = 100, h = 0.01) under
/// Jacobi with a hold is explicit Euler, whose amplitude grows by √(1 + (kh)²) = √2 per step:
/// 2^(t/2h). The growth factor 1000 between t/2 and t is reached at t/(4h) = log2(1000), i.e.
/// t = 0.399 s, give or take the factor up to √2 of the sampled components' phase (from
/// t = 0.379 s); the run must stop there (plus the persistence of 1/64 of the run), naming an
/// element and its signal, and keep the rows. Controls that grow
/// like powers of time (t, t²/2, t³/6 in a chain of integrators) or stay bounded
/// (Gauss–Seidel, symplectic at kh = 1) run to the end.
#[test]
fn a_diverging_system_stops_early_naming_the_element_and_the_signal() {
    let caps = Caps {
        u_unit: "m/s",
        x_unit: "m/s",
        ..CAPS
    };
    let text = ssd(
        &[
            lin("A", &[("x0", 1.0), ("k", 100.0)]),
            lin("B", &[("k", -100.0)]),
        ],
        &[("A", "x", "B", "u", None), ("B", "x", "A", "u", None)],
        10.0,
        "",
    );
    let sys = system("diverging", &text, caps);
    let out = sys.parent().unwrap().join("o.csv");
    let run = |extra: &[&str]| {
        let mut args: Vec<&dyn AsRef<std::ffi::OsStr>> =
            vec![&"run", &sys, &"--out", &out, &"--output-interval", &"0.01"];
        for e in extra {
            args.push(e);
        }
        geardyn(&args)
    };
    let o = run(&["--algorithm", "jacobi", "--extrapolation", "none"]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(
        e.starts_with("error: the system diverges: element \"")
            && (e.contains("\"A\" output \"x\"") || e.contains("\"B\" output \"x\""))
            && e.contains("more than 1000 times the largest m/s signal up to t = "),
        "{e}"
    );
    let rows = read_rows(&out).1;
    let t_stop = rows.last().unwrap()[0];
    assert!((0.379..0.45).contains(&t_stop), "stopped at {t_stop}: {e}");
    // The rows are explicit Euler's: amplitude 2^(n/2) after n steps.
    let n = rows.len() - 1;
    let amplitude = rows[n][1].hypot(rows[n][2]);
    assert!((amplitude / 2f64.powf(n as f64 / 2.0) - 1.0).abs() < 1e-9);
    // Off: the run goes on (to t = 3 here, amplitude 2^150, still finite).
    let o = run(&[
        "--algorithm",
        "jacobi",
        "--extrapolation",
        "none",
        "--divergence-factor",
        "0",
        "--stop-time",
        "3",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    // Bounded: Gauss–Seidel with a hold is symplectic Euler, stable at kh = 1.
    let o = run(&["--algorithm", "gauss-seidel", "--extrapolation", "none"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(read_rows(&out).1.len(), 1001);

    // Powers of time: A.x = t, B.x = t²/2, C.x = t³/6, D.x = t⁴/24 over 10 s (factors 2 to
    // 16 per doubling of the time; D.x is recorded, not watched) are no divergence.
    let text = ssd(
        &[
            lin("A", &[("u", 1.0)]),
            lin("B", &[]),
            lin("C", &[]),
            lin("D", &[]),
        ],
        &[
            ("A", "x", "B", "u", None),
            ("B", "x", "C", "u", None),
            ("C", "x", "D", "u", None),
        ],
        10.0,
        "",
    );
    let sys = system("powers", &text, caps);
    let (_, rows, _) = run_ok(
        &sys,
        &out,
        &["--output-interval", "0.001", "--outputs", "D.x"],
    );
    let last = rows.last().unwrap();
    assert_eq!(last[0], 10.0);
    assert!((last[4] - 1e4 / 24.0).abs() < 1e-6 * 1e4, "{last:?}");
}

/// Issue 32, parallel Jacobi: the elements' steps on 2 or 3 threads give the bytes of the
/// serial run (after the first steps, which are serial to measure the elements' costs), and a
/// refused or final step is reported as the serial run reports it.
#[test]
fn parallel_jacobi_is_bit_identical_to_serial() {
    let chain = |b: &[(&'static str, f64)]| {
        ssd(
            &[
                lin("A", &[("u", 1.0), ("x0", 0.5)]),
                lin("B", b),
                lin("C", &[("k", -2.0)]),
            ],
            &[
                ("A", "x", "B", "u", None),
                ("B", "x", "C", "u", None),
                ("C", "y", "A", "u", None),
            ],
            1.0,
            "",
        )
    };
    let run = |sys: &Path, out: &Path, threads: &str| {
        geardyn(&[
            &"run",
            &sys,
            &"--out",
            &out,
            &"--output-interval",
            &"0.001",
            &"--algorithm",
            &"jacobi",
            &"--threads",
            &threads,
        ])
    };
    let sys = system("parallel", &chain(&[("k", 3.0)]), CAPS);
    let d = sys.parent().unwrap();
    let mut texts = Vec::new();
    for threads in ["1", "2", "3"] {
        let out = d.join(format!("o{threads}.csv"));
        let o = run(&sys, &out, threads);
        assert!(o.status.success(), "{}", stderr(&o));
        texts.push(std::fs::read_to_string(&out).unwrap());
    }
    assert_eq!(texts[0].lines().count(), 1002);
    assert!(texts[0] == texts[1] && texts[0] == texts[2]);
    // A refused step and a final step after the serial warm-up, on threads as serially.
    for (how, code) in [(2.0, 1), (4.0, 0)] {
        let sys = system(
            "parallel_end",
            &chain(&[("k", 3.0), ("refuse_at", 0.5), ("refuse_how", how)]),
            CAPS,
        );
        let d = sys.parent().unwrap();
        let ends: Vec<(Option<i32>, String, String)> = ["1", "2"]
            .iter()
            .map(|threads| {
                let out = d.join(format!("o{threads}.csv"));
                let o = run(&sys, &out, threads);
                (
                    o.status.code(),
                    stderr(&o).replace(&format!("o{threads}.csv"), "o.csv"),
                    std::fs::read_to_string(&out).unwrap(),
                )
            })
            .collect();
        assert_eq!(ends[0].0, Some(code), "{}", ends[0].1);
        assert_eq!(ends[0], ends[1]);
        assert!(ends[0].1.contains("element \"B\""), "{}", ends[0].1);
    }
    // Gauss–Seidel steps one element after another.
    let o = geardyn(&[
        &"run",
        &sys,
        &"--algorithm",
        &"gauss-seidel",
        &"--threads",
        &"2",
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("--threads 2: only Jacobi steps the elements in parallel"),
        "{}",
        stderr(&o)
    );
}

/// The error-controlled master (`--tolerance`) on the coupled oscillator x_A' = x_B,
/// x_B' = −x_A (closed form cos, −sin): the error falls with the tolerance, the rows stay on
/// the output grid, steps are undone and redone (the fixture's state is a copy of its model),
/// and the step sequence in `<out>.steps.csv` adds up to the run.
#[test]
fn the_error_controlled_master_follows_its_tolerance_on_the_grid() {
    let text = ssd(
        &[lin("A", &[("x0", 1.0)]), lin("B", &[("k", -1.0)])],
        &[("A", "x", "B", "u", None), ("B", "x", "A", "u", None)],
        2.0,
        "",
    );
    // Speeds (a unit with a time dimension): each defect against the signal's magnitude.
    let caps = Caps {
        u_unit: "m/s",
        x_unit: "m/s",
        ..CAPS
    };
    let sys = system("controlled", &text, caps);
    let out = sys.parent().unwrap().join("o.csv");
    let o = geardyn(&[
        &"run",
        &sys,
        &"--out",
        &out,
        &"--tolerance",
        &"1e-3",
        &"--threads",
        &"2",
        &"--algorithm",
        &"jacobi",
    ]);
    assert!(
        !o.status.success() && stderr(&o).contains("--threads 2"),
        "{}",
        stderr(&o)
    );
    let mut errs = Vec::new();
    for tol in ["1e-2", "1e-3", "1e-4", "1e-5"] {
        for alg in ["jacobi", "gauss-seidel"] {
            let (_, rows, err) = run_ok(
                &sys,
                &out,
                &[
                    "--output-interval",
                    "0.1",
                    "--tolerance",
                    tol,
                    "--algorithm",
                    alg,
                ],
            );
            assert_eq!(rows.len(), 21, "{err}");
            for (k, r) in rows.iter().enumerate() {
                assert_eq!(r[0], 0.1 * k as f64, "row {k} off the grid");
            }
            let e = rows
                .iter()
                .map(|r| (r[1] - r[0].cos()).abs().max((r[2] + r[0].sin()).abs()))
                .fold(0.0, f64::max);
            let steps_path = sys.parent().unwrap().join("o.csv.steps.csv");
            let steps = std::fs::read_to_string(&steps_path).unwrap();
            let mut lines = steps.lines();
            assert_eq!(
                lines.next(),
                Some("\"time\",\"step\",\"error\",\"accepted\"")
            );
            let (mut t, mut undone) = (0.0_f64, 0);
            for l in lines {
                let f: Vec<&str> = l.split(',').collect();
                let (t0, h, e): (f64, f64, f64) = (
                    f[0].parse().unwrap(),
                    f[1].parse().unwrap(),
                    f[2].parse().unwrap(),
                );
                assert_eq!(
                    t0, t,
                    "each attempt starts where the last accepted step ended"
                );
                if f[3] == "True" {
                    assert!(e <= 1.0, "{l}");
                    t = t0 + h;
                } else {
                    assert!(e > 1.0, "{l}");
                    undone += 1;
                }
            }
            assert!((t - 2.0).abs() < 1e-12, "the accepted steps end at {t}");
            assert!(err.contains("steps accepted"), "{err}");
            if tol == "1e-4" {
                assert!(
                    undone > 0,
                    "the first step (0.1) is too long at 1e-4: {steps}"
                );
            }
            errs.push((tol, alg, e));
        }
    }
    eprintln!("{errs:?}");
    // The error follows the tolerance: each tenfold tighter tolerance cuts the error by at
    // least 3 (the local defect is second order: the error falls like tol^(1/2)…tol).
    for w in errs.chunks(2).collect::<Vec<_>>().windows(2) {
        for (a, b) in w[0].iter().zip(w[1]) {
            assert!(b.2 < a.2 / 3.0, "{errs:?}");
        }
    }
    assert!(errs.iter().all(|x| x.2 < 0.05), "{errs:?}");
}

/// An FMU that cannot get and set its state: `--tolerance` runs fixed steps and says so;
/// the bounds of the step need `--tolerance`.
#[test]
fn the_error_controlled_master_falls_back_to_fixed_steps_without_fmu_state() {
    let text = ssd(
        &[lin("A", &[("x0", 1.0)]), lin("B", &[("k", -1.0)])],
        &[("A", "x", "B", "u", None), ("B", "x", "A", "u", None)],
        1.0,
        "",
    );
    let sys = system(
        "controlled_fallback",
        &text,
        Caps {
            state: false,
            ..CAPS
        },
    );
    let out = sys.parent().unwrap().join("o.csv");
    let (_, fixed, _) = run_ok(&sys, &out, &["--output-interval", "0.1"]);
    let (_, rows, err) = run_ok(
        &sys,
        &out,
        &["--output-interval", "0.1", "--tolerance", "1e-3"],
    );
    assert!(
        err.contains("without error control") && err.contains("canGetAndSetFMUstate"),
        "{err}"
    );
    assert_eq!(rows, fixed);
    for (args, what) in [
        (vec!["--min-step", "1e-3"], "--min-step"),
        (vec!["--tolerance", "0"], "--tolerance 0"),
        (
            vec![
                "--tolerance",
                "1e-3",
                "--min-step",
                "1",
                "--max-step",
                "0.1",
            ],
            "--min-step 1",
        ),
    ] {
        let mut a: Vec<&dyn AsRef<std::ffi::OsStr>> = vec![&"run", &sys, &"--out", &out];
        for x in &args {
            a.push(x);
        }
        let o = geardyn(&a);
        assert!(!o.status.success(), "{args:?}");
        assert!(stderr(&o).contains(what), "{args:?}: {}", stderr(&o));
    }
}
