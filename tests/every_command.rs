//! Every shipped scene through every command keeps its results (issue 30, acceptance 1): the
//! `geardyn` binary runs each scene of `fmu/`, `examples/` and `tests/scenes/` through
//! `simulate` (alone and with `--spectrum`), `spectrum`, `modes`, `periodic`, `sweep`, `hb`, `floquet`
//! and `band` on short settings (plus `waterfall` and `stiffness` where they apply), and the
//! exit status, stdout, stderr and every output file of each run hash to the value recorded in
//! `tests/fixtures/every_command.tsv`. A refusal is a result too: its message is pinned the
//! same way.
//!
//! The table was written by the code before the scene-layer refactor of issue 30 (commit
//! e658379); regenerate it (`GEARDYN_BLESS_COMMANDS=1 cargo test --release --test
//! every_command`) only for a change that is meant to move results, and say why in its
//! commit. The outputs of the last run stay in `target/tmp/every_command/` for a diff against
//! a run of the old binary.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// Each scene with the input speed (rad/s) its sweeps, HB branches and bands are centred on.
const SCENES: [(&str, f64); 31] = [
    ("fmu/bugaru_pair", 493.647),
    ("fmu/countershaft_gearset", 246.4),
    ("fmu/countershaft_stage", 246.4),
    ("fmu/emotor", 300.0),
    ("fmu/geometry_pair", 304.0),
    ("fmu/geometry_stage", 304.0),
    ("fmu/helical_pair_friction", 104.72),
    ("fmu/idler_gearset", 330.69),
    ("fmu/idler_stage", 330.69),
    ("fmu/planetary_stage", 1047.2),
    ("fmu/shaft_in", 300.0),
    ("fmu/shaft_out", 300.0),
    ("fmu/spur_pair", 471.24),
    ("fmu/spur_stage", 471.24),
    ("fmu/spur_stage_speed", 471.24),
    ("fmu/vehicle_load", 300.0),
    ("examples/chain_16.toml", 251.33),
    ("examples/drivetrain_monolithic.toml", 314.16),
    ("examples/friction_pair.toml", 248.02),
    ("examples/runup_spur.toml", 400.0),
    ("examples/user_pair.toml", 314.16),
    ("examples/liu2007/ch2_idler.toml", 330.69),
    ("examples/liu2007/ch3_idler.toml", 295.02),
    ("examples/liu2007/ch3_idler_report.toml", 295.02),
    ("examples/liu2007/ch4_countershaft.toml", 580.0),
    ("tests/scenes/backlash_rattle.toml", 430.0),
    ("tests/scenes/contact_loss.toml", 480.0),
    ("tests/scenes/smooth_fourier.toml", 350.0),
    ("tests/scenes/table.toml", 500.0),
    ("tests/scenes/table_contact_loss.toml", 460.0),
    ("tests/scenes/trapezoidal.toml", 430.0),
];

/// One run: a label, the arguments (`{out}` stands for the run's output folder) and the
/// output files it writes there.
struct Run {
    scene: String,
    label: &'static str,
    args: Vec<String>,
    files: Vec<&'static str>,
}

fn runs() -> Vec<Run> {
    let mut runs = Vec::new();
    for (scene, speed) in SCENES {
        // The 16-mesh chain spans many combination tones: a narrower, lower-order HB branch
        // keeps the whole test short.
        let (half_width, harmonics) = if scene.contains("chain_16") {
            (0.005, 3)
        } else {
            (0.02, 5)
        };
        let (lo, hi) = (speed * (1.0 - half_width), speed * (1.0 + half_width));
        let mut add = |label: &'static str, args: &[&str], files: Vec<&'static str>| {
            // `floquet-json` is `floquet --json`, `simulate-spectrum` a `simulate`: the command
            // is the label's first word.
            let command = label.split('-').next().unwrap();
            let mut all = vec![command.to_string(), scene.to_string()];
            all.extend(args.iter().map(|a| a.to_string()));
            runs.push(Run {
                scene: scene.to_string(),
                label,
                args: all,
                files,
            });
        };
        add(
            "simulate",
            &[
                "--out",
                "{out}/sim.csv",
                "--stop-time",
                "0.005",
                "--output-interval",
                "1e-4",
            ],
            vec!["sim.csv"],
        );
        // The spectrum of a run is refused for scenes whose rotation is carried (ports,
        // elements): a run of its own, so that their time series above are still compared.
        add(
            "simulate-spectrum",
            &[
                "--out",
                "{out}/sim.csv",
                "--stop-time",
                "0.005",
                "--output-interval",
                "1e-4",
                "--spectrum",
                "{out}/sim_spectrum.csv",
                "--quiet",
            ],
            vec!["sim_spectrum.csv"],
        );
        add(
            "spectrum",
            &["--out", "{out}/spectrum.csv", "--samples", "16"],
            vec!["spectrum.csv"],
        );
        add("modes", &[], vec![]);
        add("periodic", &["--warmup", "5"], vec![]);
        let sweep = format!("{lo:.6}:{hi:.6}:3");
        add(
            "sweep",
            &[
                "--out",
                "{out}/sweep.csv",
                "--poincare",
                "{out}/poincare.csv",
                "--speed",
                &sweep,
                "--max-periods",
                "200",
            ],
            vec!["sweep.csv", "poincare.csv"],
        );
        let interval = format!("{lo:.6}:{hi:.6}");
        let harmonics = harmonics.to_string();
        add(
            "hb",
            &[
                "--out",
                "{out}/hb.csv",
                "--speed",
                &interval,
                "--harmonics",
                &harmonics,
            ],
            vec!["hb.csv"],
        );
        add("floquet", &[], vec![]);
        add("floquet-json", &["--json"], vec![]);
        add("band", &["--speed", &interval, "--points", "8"], vec![]);
    }
    runs.push(Run {
        scene: "examples/runup_spur.toml".into(),
        label: "waterfall",
        args: [
            "waterfall",
            "examples/runup_spur.toml",
            "--out",
            "{out}/waterfall.csv",
        ]
        .map(String::from)
        .to_vec(),
        files: vec!["waterfall.csv"],
    });
    runs.push(Run {
        scene: "fmu/geometry_pair/gears.toml".into(),
        label: "stiffness",
        args: [
            "stiffness",
            "fmu/geometry_pair/gears.toml",
            "--torque",
            "100",
            "--out",
            "{out}/stiffness.csv",
        ]
        .map(String::from)
        .to_vec(),
        files: vec!["stiffness.csv"],
    });
    runs
}

/// FNV-1a, 64 bits: enough to tell two outputs apart, and the same on every platform.
struct Fnv(u64);

impl Fnv {
    fn new() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
    fn add(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(0x0100_0000_01b3);
        }
        // A separator so that the split between two parts counts.
        self.0 ^= 0xff;
        self.0 = self.0.wrapping_mul(0x0100_0000_01b3);
    }
}

/// Runs one case in `folder` and returns its table line.
fn run_case(run: &Run, folder: &Path) -> String {
    std::fs::create_dir_all(folder).unwrap();
    let out = folder.to_str().unwrap();
    let args: Vec<String> = run.args.iter().map(|a| a.replace("{out}", out)).collect();
    let output = Command::new(env!("CARGO_BIN_EXE_geardyn"))
        .args(&args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    // The run's own folder and the checkout's place are not results.
    let clean = |bytes: &[u8]| {
        String::from_utf8_lossy(bytes)
            .replace(out, "{out}")
            .replace(env!("CARGO_MANIFEST_DIR"), "{crate}")
    };
    let (stdout, stderr) = (clean(&output.stdout), clean(&output.stderr));
    std::fs::write(folder.join("stdout.txt"), &stdout).unwrap();
    std::fs::write(folder.join("stderr.txt"), &stderr).unwrap();
    let mut hash = Fnv::new();
    let code = output.status.code().unwrap_or(-1);
    hash.add(code.to_string().as_bytes());
    hash.add(stdout.as_bytes());
    hash.add(stderr.as_bytes());
    for file in &run.files {
        // A refused run writes nothing: the absence is hashed as an empty marker.
        match std::fs::read(folder.join(file)) {
            Ok(bytes) => hash.add(&bytes),
            Err(_) => hash.add(b"<absent>"),
        }
    }
    format!("{}\t{}\t{}\t{:016x}", run.scene, run.label, code, hash.0)
}

#[test]
fn every_scene_through_every_command_keeps_its_results() {
    let runs = runs();
    let root = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("every_command");
    let _ = std::fs::remove_dir_all(&root);
    let lines = Mutex::new(vec![String::new(); runs.len()]);
    let next = AtomicUsize::new(0);
    std::thread::scope(|s| {
        for _ in 0..2 {
            s.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(run) = runs.get(i) else { break };
                let folder = root.join(format!("{i:03}-{}", run.label));
                let line = run_case(run, &folder);
                lines.lock().unwrap()[i] = line;
            });
        }
    });
    let now = lines.into_inner().unwrap().join("\n") + "\n";
    let table = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/every_command.tsv");
    if std::env::var_os("GEARDYN_BLESS_COMMANDS").is_some() {
        std::fs::write(&table, &now).unwrap();
        println!("wrote {}", table.display());
        return;
    }
    let expected = std::fs::read_to_string(&table).unwrap();
    let (now_lines, expected_lines): (Vec<&str>, Vec<&str>) =
        (now.lines().collect(), expected.lines().collect());
    assert_eq!(
        now_lines.len(),
        expected_lines.len(),
        "the table has {} runs, this run {}",
        expected_lines.len(),
        now_lines.len()
    );
    let changed: Vec<String> = now_lines
        .iter()
        .zip(&expected_lines)
        .enumerate()
        .filter(|(_, (a, b))| a != b)
        .map(|(i, (a, b))| format!("run {i:03}: expected {b}\n          now      {a}"))
        .collect();
    let ok = now_lines.iter().filter(|l| l.contains("\t0\t")).count();
    println!(
        "{} runs ({ok} succeeded, {} refused), {} changed",
        now_lines.len(),
        now_lines.len() - ok,
        changed.len()
    );
    assert!(
        changed.is_empty(),
        "results moved (outputs in {}):\n{}",
        root.display(),
        changed.join("\n")
    );
}
