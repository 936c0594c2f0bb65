//! Benchmark: the cost of one `fmi2DoStep` spanning one mesh period against the native
//! integrator (`Simulation::advance_to`) over the same interval, on the shipped scenes
//! (`fmu/*/scene.toml`) with their own propagator and with RK forced.
//!
//! The FMU side is called through the exported C functions of this crate (the same code as
//! the cdylib) with the FMI call sequence of a host, so the ratio is the overhead of the FMI
//! layer: state checks, argument checks, panic guard and the adapter.
//!
//! Run: `cargo run --release --example bench_dostep` (or `bash scripts/bench-dostep.sh`).

use std::ffi::CString;
use std::path::{Path, PathBuf};
use std::ptr::null_mut;
use std::time::Instant;

use geardyn::fmi::abi::*;
use geardyn::fmi::logger::{CallbackFunctions, Status};
use geardyn::scene::PairScene;
use geardyn::simulation::Simulation;

const PERIODS: usize = 2000;

fn native(scene: &PairScene, period: f64) -> f64 {
    let mut sim = Simulation::new(scene).unwrap();
    let start = Instant::now();
    for k in 1..=PERIODS {
        sim.advance_to(k as f64 * period).unwrap();
    }
    start.elapsed().as_secs_f64() / PERIODS as f64
}

fn fmu(dir: &Path, text: &str, period: f64) -> f64 {
    let cb = CallbackFunctions {
        logger: None,
        allocate_memory: None,
        free_memory: None,
        step_finished: None,
        component_environment: null_mut(),
    };
    let name = CString::new("bench").unwrap();
    let guid = CString::new(geardyn::fmi::blob::guid(text.as_bytes())).unwrap();
    let uri = CString::new(format!("file://{}", dir.display())).unwrap();
    unsafe {
        let c = fmi2Instantiate(name.as_ptr(), 1, guid.as_ptr(), uri.as_ptr(), &cb, 0, 0);
        assert!(!c.is_null());
        assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0), Status::Ok);
        assert_eq!(fmi2EnterInitializationMode(c), Status::Ok);
        assert_eq!(fmi2ExitInitializationMode(c), Status::Ok);
        let vr = 40u32;
        let mut dte = 0.0;
        let start = Instant::now();
        for k in 0..PERIODS {
            let t = k as f64 * period;
            let h = (k + 1) as f64 * period - t;
            assert_eq!(fmi2DoStep(c, t, h, 1), Status::Ok);
            fmi2GetReal(c, &vr, 1, &mut dte);
        }
        let per_step = start.elapsed().as_secs_f64() / PERIODS as f64;
        fmi2FreeInstance(c);
        per_step
    }
}

fn main() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(root.join("fmu"))
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.join("scene.toml").is_file())
        .collect();
    dirs.sort();
    println!("one fmi2DoStep of one mesh period vs native advance_to over the same interval ({PERIODS} periods, best of 5)");
    for dir in dirs {
        let text = std::fs::read_to_string(dir.join("scene.toml")).unwrap();
        for (label, text) in [
            ("scene method", text.clone()),
            (
                "rk forced",
                text.replace("method = \"auto\"", "method = \"rk\""),
            ),
        ] {
            let tmp = std::env::temp_dir().join(format!("geardyn-bench-{}", std::process::id()));
            std::fs::create_dir_all(&tmp).unwrap();
            std::fs::write(tmp.join("scene.toml"), &text).unwrap();
            let scene = PairScene::from_toml_str(&text, "bench").unwrap();
            let sim = Simulation::new(&scene).unwrap();
            let period = sim.model().mesh_period();
            let method = sim.method_name();
            let n = (0..5)
                .map(|_| native(&scene, period))
                .fold(f64::INFINITY, f64::min);
            let f = (0..5)
                .map(|_| fmu(&tmp, &text, period))
                .fold(f64::INFINITY, f64::min);
            println!(
                "  {:<12} {label:<13} ({method:<6}) native {:8.2} µs  fmi2DoStep {:8.2} µs  ratio {:.3}",
                dir.file_name().unwrap().to_string_lossy(),
                n * 1e6,
                f * 1e6,
                f / n
            );
            let _ = std::fs::remove_dir_all(&tmp);
        }
    }
}
