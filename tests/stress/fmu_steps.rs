//! FMU communication step sizes (numerics notes §5, S10): the FMU (the exported FMI 2.0
//! functions, called through the C ABI as in `tests/fmi_abi.rs`) on `spur_pair` (repeated
//! contact loss) with communication steps `T_m/10`, `T_m`, `10 T_m` and with a grid that has
//! a communication point exactly at a contact-loss event time taken first from a native run.
//! Oracle: a native `Simulation` that stops only at the points of the coarsest grid (all grids
//! are built as multiples of `T_m/10`, so those instants are the same floats in every grid):
//! the output at a time must not depend on the communication grid that reached it.

use std::ffi::{c_void, CString};
use std::path::{Path, PathBuf};
use std::ptr::null_mut;

use geardyn::fmi::abi::*;
use geardyn::fmi::logger::{CallbackFunctions, Status};
use geardyn::fmu::pair::{VR_CONTACT_STATE, VR_OUTPUT0};
use geardyn::model::ContactState;
use geardyn::scene::PairScene;
use geardyn::simulation::Simulation;

/// One initialized FMU instance of the scene in `dir`, freed on drop.
struct Fmu(*mut c_void);

impl Fmu {
    fn new(dir: &Path, stop: f64) -> Fmu {
        let bytes = std::fs::read(dir.join("scene.toml")).expect("scene");
        let guid = CString::new(geardyn::fmi::blob::guid(&bytes)).unwrap();
        let name = CString::new("stress").unwrap();
        let uri = CString::new(format!("file://{}", dir.display())).unwrap();
        let cb = CallbackFunctions {
            logger: None,
            allocate_memory: None,
            free_memory: None,
            step_finished: None,
            component_environment: null_mut(),
        };
        let c =
            unsafe { fmi2Instantiate(name.as_ptr(), 1, guid.as_ptr(), uri.as_ptr(), &cb, 0, 0) };
        assert!(!c.is_null(), "instantiate");
        let f = Fmu(c);
        unsafe {
            assert_eq!(fmi2SetupExperiment(f.0, 0, 0.0, 0.0, 1, stop), Status::Ok);
            assert_eq!(fmi2EnterInitializationMode(f.0), Status::Ok);
            assert_eq!(fmi2ExitInitializationMode(f.0), Status::Ok);
        }
        f
    }

    /// DTE and contact state after stepping from `t` to `t_next`.
    fn step(&mut self, t: f64, t_next: f64) -> (f64, i32) {
        let (mut x, mut s) = (0.0, 0);
        unsafe {
            assert_eq!(
                fmi2DoStep(self.0, t, t_next - t, 1),
                Status::Ok,
                "step at {t}"
            );
            assert_eq!(fmi2GetReal(self.0, &VR_OUTPUT0, 1, &mut x), Status::Ok);
            assert_eq!(
                fmi2GetInteger(self.0, &VR_CONTACT_STATE, 1, &mut s),
                Status::Ok
            );
        }
        (x, s)
    }
}

impl Drop for Fmu {
    fn drop(&mut self) {
        unsafe { fmi2FreeInstance(self.0) };
    }
}

/// The shipped scene, or a copy with `method` replaced, in a folder the FMU can load.
fn scene_dir(method: &str) -> PathBuf {
    let shipped = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fmu/spur_pair");
    if method == "auto" {
        return shipped;
    }
    let text = std::fs::read_to_string(shipped.join("scene.toml"))
        .unwrap()
        .replace("method = \"auto\"", &format!("method = \"{method}\""));
    let dir = std::env::temp_dir().join(format!("geardyn-stress-{method}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("scene.toml"), text).unwrap();
    dir
}

fn check(method: &str, periods: f64, tol: f64) {
    let dir = scene_dir(method);
    let scene = PairScene::from_path(&dir.join("scene.toml")).expect("scene");
    let native_sim = || Simulation::new(&scene).expect("simulation");
    let (t_m, ds) = {
        let s = native_sim();
        (s.model().mesh_period(), s.model().static_deflection())
    };
    let stop = periods * t_m;
    // The first contact loss after the first 2 mesh periods, from a native run.
    let t_event = {
        let mut s = native_sim();
        s.model_mut().record_events();
        s.advance_to(stop).expect("native");
        s.model()
            .events()
            .iter()
            .find(|e| e.1 == ContactState::Separated && e.0 > 2.0 * t_m)
            .expect("a contact loss")
            .0
    };
    // Grid points as multiples of T_m/10, so that coarse points are the same floats in
    // every grid.
    let base = t_m / 10.0;
    let n = (stop / base).round() as usize;
    let regular =
        |every: usize| -> Vec<f64> { (1..=n / every).map(|i| (i * every) as f64 * base).collect() };
    let mut at_event = regular(1);
    at_event.retain(|&t| (t - t_event).abs() > 1e-9 * t_m);
    at_event.push(t_event);
    at_event.sort_by(f64::total_cmp);
    // The reference: DTE and contact state at the coarse points.
    let coarse = regular(100);
    let reference: Vec<(f64, f64)> = {
        let mut s = native_sim();
        coarse
            .iter()
            .map(|&t| {
                s.advance_to(t).expect("native");
                (s.state()[0], s.outputs()[3])
            })
            .collect()
    };
    let grids = [
        ("T_m/10", regular(1)),
        ("T_m", regular(10)),
        ("10 T_m", regular(100)),
        ("T_m/10 with a point at the event", at_event),
    ];
    for (label, grid) in grids {
        let mut fmu = Fmu::new(&dir, stop * (1.0 + 1e-12));
        let (mut t, mut worst, mut compared) = (0.0, 0.0f64, 0);
        for &t_next in &grid {
            let (x, state) = fmu.step(t, t_next);
            if let Some(k) = coarse.iter().position(|&c| c == t_next) {
                let (x_ref, state_ref) = reference[k];
                worst = worst.max((x - x_ref).abs() / ds);
                assert_eq!(
                    f64::from(state),
                    state_ref,
                    "{method}, {label}: contact state at t = {t_next:e}"
                );
                compared += 1;
            }
            t = t_next;
        }
        println!(
            "{method}, steps {label}: {} communication points, at the {compared} common points max |DTE − DTE_ref| = {worst:.2e} δ_s",
            grid.len()
        );
        assert_eq!(compared, coarse.len());
        assert!(
            worst <= tol,
            "{method}, {label}: DTE differs by {worst:e} δ_s"
        );
    }
}

#[test]
fn fmu_outputs_do_not_depend_on_the_communication_step() {
    check("auto", 100.0, 1e-9);
    check("rk", 100.0, 1e-6);
}

#[test]
#[ignore = "long: 3000 mesh periods; bash scripts/stress.sh"]
fn fmu_outputs_do_not_depend_on_the_communication_step_long() {
    check("auto", 3000.0, 1e-8);
    check("rk", 3000.0, 1e-5);
}
