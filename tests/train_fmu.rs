//! The drivetrain FMU (`src/fmu/drivetrain`) and the snapshot/restore of `TrainSimulation` it
//! rests on, on the shipped `idler_gearset` and `countershaft_gearset` scenes.
//!
//! Oracles: the uninterrupted native run (`TrainSimulation`) for values and for continuation
//! after a restore (bit equality), the native run of an edited scene for parameters, and
//! the single-mesh adapter's own encoder for the foreign payload.

use std::ffi::{c_char, c_void, CString};
use std::path::PathBuf;
use std::ptr::null_mut;

use geardyn::fmi::abi::*;
use geardyn::fmi::blob::{self, LayerSnapshot};
use geardyn::fmi::logger::{CallbackFunctions, Status};
use geardyn::fmi::model::VarKind;
use geardyn::fmi::state::FmuState;
use geardyn::fmu::drivetrain::{VR_GEAR_INERTIA0, VR_INPUT_SPEED, VR_INPUT_TORQUE, VR_OUTPUT0};
use geardyn::model::train::{SlotContact, TrainInputs, TrainSimulation};
use geardyn::scene::MethodChoice;
use geardyn::scene::Scene;

const OK: Status = Status::Ok;
const ERR: Status = Status::Error;

fn dir(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("fmu")
        .join(name)
}

fn scene(name: &str) -> Scene {
    Scene::from_path(&dir(name)).unwrap()
}

/// Outputs and state after each of `n` steps of `h` from the simulation's time.
fn run(sim: &mut TrainSimulation, n: usize, h: f64) -> Vec<Vec<f64>> {
    let t0 = sim.t();
    let mut rows = Vec::new();
    let mut out = Vec::new();
    for k in 1..=n {
        sim.advance_to(t0 + k as f64 * h).unwrap();
        sim.outputs(&mut out);
        out.extend_from_slice(sim.state());
        rows.push(out.clone());
    }
    rows
}

/// A run with an input change on the way (re-anchored clocks), then snapshot, 5 steps,
/// restore into the same and into a fresh simulation, the same 5 steps: bit-identical.
fn check_rollback(mut s: Scene, label: &str) {
    s.solver.stop_time = 1.0;
    let mut sim = TrainSimulation::new(&s).unwrap();
    let h = 3.7e-5;
    run(&mut sim, 40, h);
    let u = sim.model().inputs();
    sim.set_inputs(TrainInputs {
        input_speed: u.input_speed * 1.1,
        input_torque: u.input_torque * 0.9,
        ..u
    })
    .unwrap();
    run(&mut sim, 37, h);
    let snap = sim.snapshot();
    let first = run(&mut sim, 5, h);
    assert_ne!(first[0], first[4], "{label}: the run moves");
    sim.restore(&snap).unwrap();
    assert_eq!(run(&mut sim, 5, h), first, "{label}: same simulation");
    let mut fresh = TrainSimulation::new(&s).unwrap();
    // Without the restore a fresh simulation is elsewhere (the check can fail).
    assert_ne!(run(&mut fresh, 5, h), first, "{label}");
    let mut fresh = TrainSimulation::new(&s).unwrap();
    fresh.restore(&snap).unwrap();
    assert_eq!(
        fresh.snapshot(),
        snap,
        "{label}: snapshot of the restored run"
    );
    assert_eq!(run(&mut fresh, 5, h), first, "{label}: fresh simulation");
}

#[test]
fn snapshot_restore_continues_bit_identically() {
    for name in ["idler_gearset", "countershaft_gearset"] {
        let s = scene(name);
        check_rollback(s.clone(), &format!("{name} exact"));
        let mut rk = s;
        rk.solver.method = MethodChoice::Rk;
        check_rollback(rk, &format!("{name} rk"));
    }
}

#[test]
fn snapshot_carries_contact_loss_bookkeeping() {
    // A light load with the speed near a resonance loses contact: the loss fraction and
    // the slot flags then live in the snapshot too.
    let mut s = scene("idler_gearset");
    s.solver.stop_time = 1.0;
    s.operating.input_torque *= 0.05;
    s.operating.load_torque *= 0.05;
    let mut sim = TrainSimulation::new(&s).unwrap();
    let rows = run(&mut sim, 400, 1e-5);
    let names = sim.output_names().to_vec();
    let loss = names
        .iter()
        .position(|n| n == "mesh1.contact_loss_fraction")
        .unwrap();
    let snap = sim.snapshot();
    assert!(
        rows.last().unwrap()[loss] > 0.0,
        "the scene loses contact (fraction {})",
        rows.last().unwrap()[loss]
    );
    let first = run(&mut sim, 50, 1e-5);
    let mut fresh = TrainSimulation::new(&s).unwrap();
    fresh.restore(&snap).unwrap();
    assert_eq!(run(&mut fresh, 50, 1e-5), first);
}

#[test]
fn restore_rejects_states_of_other_trains_and_changes_nothing() {
    let idler = scene("idler_gearset");
    let mut sim = TrainSimulation::new(&idler).unwrap();
    sim.advance_to(1e-4).unwrap();
    let good = sim.snapshot();
    let before = sim.snapshot();
    let expect_err =
        |sim: &mut TrainSimulation, bad: &geardyn::model::train::TrainSimState, what: &str| {
            let e = sim.restore(bad).unwrap_err();
            assert!(e.contains(what), "{e}");
            assert_eq!(
                sim.snapshot(),
                before,
                "a rejected state changed the simulation"
            );
        };
    let other = TrainSimulation::new(&scene("countershaft_gearset")).unwrap();
    expect_err(&mut sim, &other.snapshot(), "entries");
    let mut bad = good.clone();
    bad.train.meshes.pop();
    expect_err(&mut sim, &bad, "meshes");
    let mut bad = good.clone();
    bad.train.meshes[0].interval = 99;
    expect_err(&mut sim, &bad, "interval 99");
    let mut bad = good.clone();
    let j = bad.train.meshes[0]
        .flags
        .iter()
        .position(|f| *f != SlotContact::Inactive)
        .unwrap();
    // Back-side contact does not exist with contact = "contact_loss".
    bad.train.meshes[0].flags[j] = SlotContact::Back;
    expect_err(&mut sim, &bad, "impossible");
    let mut bad = good.clone();
    bad.train.meshes[0].flags[j] = SlotContact::Inactive;
    expect_err(&mut sim, &bad, "impossible");
    let mut bad = good.clone();
    bad.y[3] = f64::NAN;
    expect_err(&mut sim, &bad, "not finite");
    let mut rk = idler.clone();
    rk.solver.method = MethodChoice::Rk;
    let rk_state = TrainSimulation::new(&rk).unwrap().snapshot();
    expect_err(&mut sim, &rk_state, "propagator");
    sim.restore(&good).unwrap();
}

// ---- through the C ABI ----------------------------------------------------------------

fn guid_of(name: &str) -> CString {
    let bytes = std::fs::read(dir(name).join("scene.toml")).unwrap();
    CString::new(blob::guid(&bytes)).unwrap()
}

struct Fmu(*mut c_void);

impl Fmu {
    fn new(name: &str) -> Fmu {
        let cb = CallbackFunctions {
            logger: None,
            allocate_memory: None,
            free_memory: None,
            step_finished: None,
            component_environment: null_mut(),
        };
        let inst = CString::new("t").unwrap();
        let uri = CString::new(format!("file://{}", dir(name).display())).unwrap();
        let g = guid_of(name);
        let c = unsafe { fmi2Instantiate(inst.as_ptr(), 1, g.as_ptr(), uri.as_ptr(), &cb, 0, 0) };
        assert!(!c.is_null(), "instantiate {name}");
        Fmu(c)
    }

    fn init(&self) {
        assert_eq!(
            unsafe { fmi2SetupExperiment(self.0, 0, 0.0, 0.0, 0, 0.0) },
            OK
        );
        assert_eq!(unsafe { fmi2EnterInitializationMode(self.0) }, OK);
        assert_eq!(unsafe { fmi2ExitInitializationMode(self.0) }, OK);
    }

    fn set(&self, vr: u32, x: f64) -> Status {
        unsafe { fmi2SetReal(self.0, &vr, 1, &x) }
    }

    fn step(&self, t: f64, h: f64) -> Status {
        unsafe { fmi2DoStep(self.0, t, h, 1) }
    }

    fn reals(&self, vrs: &[u32]) -> Vec<f64> {
        let mut v = vec![f64::NAN; vrs.len()];
        assert_eq!(
            unsafe { fmi2GetReal(self.0, vrs.as_ptr(), vrs.len(), v.as_mut_ptr()) },
            OK
        );
        v
    }

    fn state_bytes(&self) -> Vec<u8> {
        let mut st: *mut c_void = null_mut();
        assert_eq!(unsafe { fmi2GetFMUstate(self.0, &mut st) }, OK);
        let mut n = 0usize;
        assert_eq!(
            unsafe { fmi2SerializedFMUstateSize(self.0, st, &mut n) },
            OK
        );
        let mut buf = vec![0u8; n];
        let s = unsafe { fmi2SerializeFMUstate(self.0, st, buf.as_mut_ptr() as *mut c_char, n) };
        assert_eq!(s, OK);
        assert_eq!(unsafe { fmi2FreeFMUstate(self.0, &mut st) }, OK);
        buf
    }

    fn load_bytes(&self, buf: &[u8]) -> Status {
        let mut st: *mut c_void = null_mut();
        let s = unsafe {
            fmi2DeSerializeFMUstate(self.0, buf.as_ptr() as *const c_char, buf.len(), &mut st)
        };
        if s != OK {
            return s;
        }
        let s = unsafe { fmi2SetFMUstate(self.0, st) };
        unsafe { fmi2FreeFMUstate(self.0, &mut st) };
        s
    }
}

impl Drop for Fmu {
    fn drop(&mut self) {
        unsafe { fmi2FreeInstance(self.0) };
    }
}

/// Value references of the Real outputs and their indices in `output_names`.
fn real_outputs(name: &str) -> (Vec<u32>, Vec<usize>) {
    let loaded = geardyn::fmu::entry::load_scene(&dir(name).join("scene.toml")).unwrap();
    loaded
        .model
        .variables()
        .iter()
        .filter(|v| v.value_reference >= VR_OUTPUT0 && v.kind == VarKind::Real)
        .map(|v| (v.value_reference, (v.value_reference - VR_OUTPUT0) as usize))
        .unzip()
}

#[test]
fn do_step_equals_native_and_rollback_is_bit_identical() {
    for name in ["idler_gearset", "countershaft_gearset"] {
        let (vrs, idx) = real_outputs(name);
        let f = Fmu::new(name);
        f.init();
        let mut native = TrainSimulation::new(&scene(name)).unwrap();
        let h = 1e-5;
        let mut out = Vec::new();
        for k in 0..60 {
            let t = k as f64 * h;
            assert_eq!(f.step(t, (k + 1) as f64 * h - t), OK);
            native.advance_to((k + 1) as f64 * h).unwrap();
            native.outputs(&mut out);
            let want: Vec<f64> = idx.iter().map(|&i| out[i]).collect();
            assert_eq!(f.reals(&vrs), want, "{name} at step {k}");
        }
        let t = 60.0 * h;
        let blob = f.state_bytes();
        let replay = |fmu: &Fmu| {
            (0..5)
                .map(|k| {
                    let tk = t + k as f64 * 3.3e-5;
                    assert_eq!(fmu.step(tk, 3.3e-5), OK);
                    fmu.reals(&vrs)
                })
                .collect::<Vec<_>>()
        };
        let first = replay(&f);
        assert_eq!(f.load_bytes(&blob), OK);
        assert_eq!(replay(&f), first, "{name}: rollback");
        let g = Fmu::new(name);
        assert_eq!(g.load_bytes(&blob), OK);
        assert_eq!(replay(&g), first, "{name}: fresh instance");
    }
}

#[test]
fn foreign_payloads_and_blobs_are_rejected() {
    let f = Fmu::new("idler_gearset");
    f.init();
    assert_eq!(f.step(0.0, 1e-4), OK);
    let good = f.state_bytes();
    // A single-mesh model payload in an envelope with this FMU's GUID: only the payload's
    // own tag and version can refuse it.
    let mut spur = geardyn::fmu::entry::load_scene(&dir("spur_pair").join("scene.toml")).unwrap();
    let layer = LayerSnapshot {
        state: FmuState::StepComplete,
        time: 1e-4,
        start_time: 0.0,
        stop_time: None,
        last_successful_time: 1e-4,
        terminated: false,
        setup_done: true,
    };
    let guid = guid_of("idler_gearset").into_string().unwrap();
    let forged = blob::encode(&guid, &layer, &spur.model.save_state());
    assert_eq!(f.load_bytes(&forged), ERR);
    // The countershaft's payload (another train) under the idler's GUID.
    let mut other =
        geardyn::fmu::entry::load_scene(&dir("countershaft_gearset").join("scene.toml")).unwrap();
    let forged = blob::encode(&guid, &layer, &other.model.save_state());
    let g = Fmu::new("idler_gearset");
    g.init();
    assert_eq!(g.load_bytes(&forged), ERR);
    // A whole blob of another FMU (its GUID).
    let s = Fmu::new("countershaft_gearset");
    s.init();
    let h = Fmu::new("idler_gearset");
    h.init();
    assert_eq!(h.load_bytes(&s.state_bytes()), ERR);
    // Every single corrupted byte.
    for i in (0..good.len()).step_by(7) {
        let mut bad = good.clone();
        bad[i] ^= 0x10;
        let k = Fmu::new("idler_gearset");
        assert_eq!(k.load_bytes(&bad), ERR, "flipped byte {i}");
    }
    let k = Fmu::new("idler_gearset");
    assert_eq!(k.load_bytes(&good), OK, "the intact blob loads");
}

#[test]
fn parameters_before_initialization_only_and_checked() {
    let name = "idler_gearset";
    let (vrs, idx) = real_outputs(name);
    let f = Fmu::new(name);
    assert_eq!(f.set(VR_GEAR_INERTIA0, -1.0), ERR, "negative inertia");
    let f = Fmu::new(name);
    assert_eq!(f.set(VR_GEAR_INERTIA0, 0.004), OK);
    assert_eq!(f.set(VR_INPUT_TORQUE, 80.0), OK);
    f.init();
    assert_eq!(
        f.set(VR_GEAR_INERTIA0, 0.005),
        ERR,
        "fixed after initialization"
    );
    // Oracle: the native run of the edited scene.
    let mut s = scene(name);
    s.gears[0].inertia = 0.004;
    s.operating.input_torque = 80.0;
    let mut native = TrainSimulation::new(&s).unwrap();
    let f = {
        let g = Fmu::new(name);
        assert_eq!(g.set(VR_GEAR_INERTIA0, 0.004), OK);
        assert_eq!(g.set(VR_INPUT_TORQUE, 80.0), OK);
        g.init();
        g
    };
    let mut out = Vec::new();
    for k in 0..20 {
        // The host's communication points: tc + h, formed as the FMU forms them.
        let t = k as f64 * 2e-5;
        assert_eq!(f.step(t, 2e-5), OK);
        native.advance_to(t + 2e-5).unwrap();
    }
    native.outputs(&mut out);
    let want: Vec<f64> = idx.iter().map(|&i| out[i]).collect();
    assert_eq!(f.reals(&vrs), want);
    // Inputs stay settable; a negative speed is refused.
    assert_eq!(f.set(VR_INPUT_SPEED, 300.0), OK);
    assert_eq!(f.set(VR_INPUT_SPEED, -1.0), ERR);
}
