//! The exported FMI 2.0 functions, called as a host would (through the C ABI of the rlib,
//! the same code as in the cdylib), on the shipped `spur_pair` scene.
//!
//! Oracles: the state table of FMI 2.0.x §4.2.4 and the set rules of §2.2.7 (as listed in
//! the tests, not taken from `src/fmi/state.rs`), the native `Simulation` for values, and
//! bit equality for rollback.

use std::ffi::{c_char, c_int, c_void, CString};
use std::path::PathBuf;
use std::ptr::{null, null_mut};

use geardyn::fmi::abi::*;
use geardyn::fmi::logger::{CallbackFunctions, Status};
use geardyn::fmu::pair::*;
use geardyn::scene::PairScene;
use geardyn::simulation::Simulation;

const OK: Status = Status::Ok;
const ERR: Status = Status::Error;

fn scene_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fmu/spur_pair")
}

fn guid() -> CString {
    let bytes = std::fs::read(scene_dir().join("scene.toml")).unwrap();
    CString::new(geardyn::fmi::blob::guid(&bytes)).unwrap()
}

fn callbacks() -> CallbackFunctions {
    CallbackFunctions {
        logger: None,
        allocate_memory: None,
        free_memory: None,
        step_finished: None,
        component_environment: null_mut(),
    }
}

/// One instance, freed on drop.
struct Fmu(*mut c_void);

impl Fmu {
    fn try_new(guid: &CString, uri: &str) -> Option<Fmu> {
        let name = CString::new("test").unwrap();
        let uri = CString::new(uri).unwrap();
        let cb = callbacks();
        let c =
            unsafe { fmi2Instantiate(name.as_ptr(), 1, guid.as_ptr(), uri.as_ptr(), &cb, 0, 0) };
        (!c.is_null()).then_some(Fmu(c))
    }

    fn new() -> Fmu {
        let uri = format!("file://{}", scene_dir().display());
        Fmu::try_new(&guid(), &uri).expect("instantiate")
    }

    /// An instance of the shipped scene switched to the RK integrator (written to a
    /// temporary resources folder; the GUID follows the changed bytes).
    fn rk() -> (Fmu, PairScene) {
        let text = std::fs::read_to_string(scene_dir().join("scene.toml"))
            .unwrap()
            .replace("method = \"auto\"", "method = \"rk\"");
        let dir = std::env::temp_dir().join(format!("geardyn-rk-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("scene.toml"), &text).unwrap();
        let g = CString::new(geardyn::fmi::blob::guid(text.as_bytes())).unwrap();
        let f = Fmu::try_new(&g, &format!("file://{}", dir.display())).expect("instantiate rk");
        for call in [fmi2EnterInitializationMode, fmi2ExitInitializationMode] {
            assert_eq!(unsafe { call(f.0) }, OK);
        }
        (f, PairScene::from_toml_str(&text, "rk").unwrap())
    }

    /// Instantiated, set up with stopTime 1 s, initialized.
    fn ready() -> Fmu {
        let f = Fmu::new();
        assert_eq!(unsafe { fmi2SetupExperiment(f.0, 0, 0.0, 0.0, 1, 1.0) }, OK);
        assert_eq!(unsafe { fmi2EnterInitializationMode(f.0) }, OK);
        assert_eq!(unsafe { fmi2ExitInitializationMode(f.0) }, OK);
        f
    }

    fn get(&self, vrs: &[u32]) -> (Status, Vec<f64>) {
        let mut v = vec![f64::NAN; vrs.len()];
        let s = unsafe { fmi2GetReal(self.0, vrs.as_ptr(), vrs.len(), v.as_mut_ptr()) };
        (s, v)
    }

    fn set(&self, vr: u32, x: f64) -> Status {
        unsafe { fmi2SetReal(self.0, &vr, 1, &x) }
    }

    fn step(&self, t: f64, h: f64) -> Status {
        unsafe { fmi2DoStep(self.0, t, h, 1) }
    }

    fn outputs(&self) -> Vec<f64> {
        let vrs: Vec<u32> = (0..7)
            .map(|i| VR_OUTPUT0 + i)
            .filter(|vr| *vr != VR_CONTACT_STATE)
            .collect();
        let (s, v) = self.get(&vrs);
        assert_eq!(s, OK);
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
        assert!(st.is_null(), "FreeFMUstate sets the pointer to NULL");
        buf
    }

    /// DeSerialize + SetFMUstate; returns the first non-OK status.
    fn load_bytes(&self, buf: &[u8]) -> Status {
        let mut st: *mut c_void = null_mut();
        let s = unsafe {
            fmi2DeSerializeFMUstate(self.0, buf.as_ptr() as *const c_char, buf.len(), &mut st)
        };
        if s != OK {
            assert!(
                st.is_null(),
                "no state object is handed out for a rejected blob"
            );
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

fn native() -> Simulation {
    Simulation::new(&PairScene::from_path(&scene_dir()).unwrap()).unwrap()
}

#[test]
fn platform_and_version() {
    let s = |p: *const c_char| unsafe { std::ffi::CStr::from_ptr(p) }.to_str().unwrap();
    assert_eq!(s(fmi2GetTypesPlatform()), "default");
    assert_eq!(s(fmi2GetVersion()), "2.0");
}

#[test]
fn instantiate_rejects_wrong_guid_type_and_location() {
    let uri = format!("file://{}", scene_dir().display());
    let other = CString::new("{00000000-0000-0000-0000-000000000000}").unwrap();
    assert!(
        Fmu::try_new(&other, &uri).is_none(),
        "GUID mismatch accepted"
    );
    assert!(Fmu::try_new(&guid(), "http://example.com/resources").is_none());
    assert!(Fmu::try_new(&guid(), "file:///nonexistent/resources").is_none());
    let name = CString::new("x").unwrap();
    let uri_c = CString::new(uri).unwrap();
    let cb = callbacks();
    let g = guid();
    // fmi2ModelExchange = 0 is not provided; NULL callbacks and NULL strings are refused.
    unsafe {
        assert!(fmi2Instantiate(name.as_ptr(), 0, g.as_ptr(), uri_c.as_ptr(), &cb, 0, 0).is_null());
        assert!(
            fmi2Instantiate(name.as_ptr(), 1, g.as_ptr(), uri_c.as_ptr(), null(), 0, 0).is_null()
        );
        assert!(fmi2Instantiate(null(), 1, g.as_ptr(), uri_c.as_ptr(), &cb, 0, 0).is_null());
        assert!(fmi2Instantiate(name.as_ptr(), 1, null(), uri_c.as_ptr(), &cb, 0, 0).is_null());
        fmi2FreeInstance(null_mut()); // a no-op
    }
}

#[test]
fn do_step_matches_native_integrator_bit_for_bit() {
    let f = Fmu::ready();
    let mut sim = native();
    let h = 1e-5;
    for k in 0..500 {
        let t = k as f64 * h;
        assert_eq!(f.step(t, (k + 1) as f64 * h - t), OK);
        sim.advance_to((k + 1) as f64 * h).unwrap();
        let o = sim.outputs();
        let want = [o[0], o[1], o[2], o[4], o[5], o[6]];
        assert_eq!(f.outputs(), want, "step {k}");
    }
    let mut t = 0.0;
    assert_eq!(unsafe { fmi2GetRealStatus(f.0, 2, &mut t) }, OK);
    assert_eq!(t, 500.0 * h - 499.0 * h + 499.0 * h);
}

#[test]
fn outputs_are_consistent_in_initialization_mode() {
    let f = Fmu::new();
    // Inputs set before initialization define the operating point of the static start.
    assert_eq!(f.set(VR_INPUT_TORQUE, 200.0), OK);
    assert_eq!(f.set(VR_LOAD_TORQUE, 200.0 * 0.06564 / 0.04535), OK);
    assert_eq!(unsafe { fmi2EnterInitializationMode(f.0) }, OK);
    let (s, v) = f.get(&[VR_OUTPUT0, VR_OUTPUT0 + 6, VR_EQUIVALENT_MASS]);
    assert_eq!(s, OK);
    let mut scene = PairScene::from_path(&scene_dir()).unwrap();
    scene.operating.input_torque = 200.0;
    scene.operating.load_torque = 200.0 * 0.06564 / 0.04535;
    let sim = Simulation::new(&scene).unwrap();
    assert_eq!(v[0], sim.outputs()[0]);
    assert_eq!(v[1], sim.outputs()[6]);
    // F_ext = T1/r_b1 for a balanced load: static deflection = 200/0.04535/k̄.
    assert!((v[1] - 200.0 / 0.04535 / 2.9831e8).abs() < 1e-12 * v[1]);
    assert_eq!(v[2], sim.model().equivalent_mass());
}

#[test]
fn calls_in_the_wrong_state_return_error_and_enter_error_state() {
    // (call, state it was made in) per FMI 2.0.x §4.2.4.
    let f = Fmu::new();
    assert_eq!(f.step(0.0, 1e-5), ERR, "DoStep in instantiated");
    // After an error only Reset/FreeInstance (and debug getters, state restore) remain.
    assert_eq!(
        unsafe { fmi2EnterInitializationMode(f.0) },
        ERR,
        "error state"
    );
    assert_eq!(unsafe { fmi2Reset(f.0) }, OK);
    assert_eq!(unsafe { fmi2EnterInitializationMode(f.0) }, OK);
    assert_eq!(
        unsafe { fmi2SetupExperiment(f.0, 0, 0.0, 0.0, 0, 0.0) },
        ERR,
        "setup in init"
    );
    assert_eq!(unsafe { fmi2Reset(f.0) }, OK);
    let f = Fmu::ready();
    assert_eq!(
        unsafe { fmi2ExitInitializationMode(f.0) },
        ERR,
        "exit twice"
    );
    let f = Fmu::ready();
    assert_eq!(unsafe { fmi2Terminate(f.0) }, OK);
    assert_eq!(f.step(0.0, 1e-5), ERR, "DoStep after terminate");
    let f = Fmu::ready();
    assert_eq!(
        unsafe { fmi2CancelStep(f.0) },
        ERR,
        "no asynchronous step to cancel"
    );
    let f = Fmu::new();
    let (s, _) = f.get(&[VR_OUTPUT0]);
    assert_eq!(s, ERR, "GetReal before initialization mode");
}

#[test]
fn fixed_parameters_only_before_initialization_ends() {
    let f = Fmu::new();
    assert_eq!(f.set(VR_PINION_INERTIA, 0.003), OK, "instantiated");
    assert_eq!(unsafe { fmi2EnterInitializationMode(f.0) }, OK);
    assert_eq!(f.set(VR_GEAR_INERTIA, 0.02), OK, "initialization mode");
    let (_, v) = f.get(&[VR_EQUIVALENT_MASS]);
    let m_e = 1.0 / (0.04535f64.powi(2) / 0.003 + 0.06564f64.powi(2) / 0.02);
    assert!(
        (v[0] - m_e).abs() < 1e-14 * m_e,
        "calculated parameter follows: {}",
        v[0]
    );
    assert_eq!(unsafe { fmi2ExitInitializationMode(f.0) }, OK);
    assert_eq!(f.set(VR_PINION_INERTIA, 0.004), ERR, "fixed after init");
    let f = Fmu::ready();
    assert_eq!(
        f.set(VR_PINION_SPEED, 400.0),
        OK,
        "inputs at communication points"
    );
    assert_eq!(f.set(VR_EQUIVALENT_MASS, 1.0), ERR, "calculated parameter");
    let f = Fmu::ready();
    assert_eq!(f.set(VR_OUTPUT0, 1.0), ERR, "output");
}

#[test]
fn bad_values_are_errors() {
    for (vr, x) in [
        (VR_PINION_INERTIA, -1.0),
        (VR_PINION_INERTIA, 0.0),
        (VR_BACKLASH, 0.0),
        (VR_DAMPING, -1.0),
        (VR_PINION_SPEED, -1.0),
        (VR_INPUT_TORQUE, f64::NAN),
        (VR_LOAD_TORQUE, f64::INFINITY),
        (VR_INITIAL_DTE, f64::NAN),
    ] {
        let f = Fmu::new();
        assert_eq!(f.set(vr, x), ERR, "vr {vr} = {x}");
        let g = Fmu::new();
        assert_eq!(g.set(vr, 0.5), OK, "vr {vr} = 0.5");
    }
}

#[test]
fn arrays_value_references_and_types() {
    let f = Fmu::ready();
    unsafe {
        // nvr = 0 with NULL arrays is a valid no-op.
        assert_eq!(fmi2GetReal(f.0, null(), 0, null_mut()), OK);
        assert_eq!(fmi2SetReal(f.0, null(), 0, null()), OK);
        let vr = VR_OUTPUT0;
        let mut x = 0.0;
        assert_eq!(fmi2GetReal(f.0, null(), 1, &mut x), ERR);
        let f = Fmu::ready();
        assert_eq!(fmi2GetReal(f.0, &vr, 1, null_mut()), ERR);
        let f = Fmu::ready();
        assert_eq!(fmi2GetReal(f.0, &999, 1, &mut x), ERR, "unknown vr");
        let f = Fmu::ready();
        assert_eq!(
            fmi2GetReal(f.0, &VR_CONTACT_STATE, 1, &mut x),
            ERR,
            "Integer vr as Real"
        );
        let f = Fmu::ready();
        let mut i: c_int = 7;
        assert_eq!(fmi2GetInteger(f.0, &VR_CONTACT_STATE, 1, &mut i), OK);
        assert_eq!(i, 1, "drive-side contact at the static start");
        let mut b: c_int = 7;
        assert_eq!(fmi2GetBoolean(f.0, &VR_INITIAL_STATIC, 1, &mut b), OK);
        assert_eq!(b, 1);
        let mut s: *const c_char = null();
        assert_eq!(
            fmi2GetString(f.0, &VR_OUTPUT0, 1, &mut s),
            ERR,
            "no String variables"
        );
    }
}

/// A host reads the same Real outputs after every step, so the layer skips the type check
/// of a repeated list and the model answers the full output list in one pass: a list that
/// differs from the last good one must still be checked, and the one-pass answer must equal
/// the per-reference one.
#[test]
fn repeated_get_real_lists_are_still_checked_when_they_change() {
    let f = Fmu::ready();
    let reals: Vec<u32> = (VR_OUTPUT0..VR_OUTPUT0 + 7)
        .filter(|&vr| vr != VR_CONTACT_STATE)
        .collect();
    unsafe {
        let mut all = vec![f64::NAN; reals.len()];
        for _ in 0..2 {
            assert_eq!(
                fmi2GetReal(f.0, reals.as_ptr(), reals.len(), all.as_mut_ptr()),
                OK
            );
        }
        for (&vr, &x) in reals.iter().zip(&all) {
            let mut one = f64::NAN;
            assert_eq!(fmi2GetReal(f.0, &vr, 1, &mut one), OK);
            assert_eq!(one.to_bits(), x.to_bits(), "vr {vr}");
        }
        // Same length, one reference replaced by the Integer contact state.
        let mut wrong = reals.clone();
        wrong[2] = VR_CONTACT_STATE;
        let mut x = vec![0.0; wrong.len()];
        assert_eq!(
            fmi2GetReal(f.0, wrong.as_ptr(), wrong.len(), x.as_mut_ptr()),
            ERR
        );
        // A longer list that starts with the good one.
        let f = Fmu::ready();
        assert_eq!(
            fmi2GetReal(f.0, reals.as_ptr(), reals.len(), all.as_mut_ptr()),
            OK
        );
        let mut longer = reals.clone();
        longer.push(999);
        let mut x = vec![0.0; longer.len()];
        assert_eq!(
            fmi2GetReal(f.0, longer.as_ptr(), longer.len(), x.as_mut_ptr()),
            ERR
        );
    }
}

#[test]
fn do_step_arguments_and_stop_time() {
    for (tc, h) in [
        (0.0, 0.0),
        (0.0, -1e-5),
        (0.0, f64::NAN),
        (f64::NAN, 1e-5),
        (1e-3, 1e-5), // tc is not the FMU's time
        (0.0, 1.5),   // past stopTime = 1
    ] {
        let f = Fmu::ready();
        assert_eq!(f.step(tc, h), ERR, "tc = {tc}, h = {h}");
    }
    let f = Fmu::ready();
    assert_eq!(f.step(0.0, 1.0), OK, "a step landing on stopTime");
}

#[test]
fn uneven_steps_land_exactly_and_agree_with_even_steps() {
    let even = Fmu::ready();
    let uneven = Fmu::ready();
    let h = 1e-4;
    let mut t = 0.0;
    let mut rng = 0x2545_f491_4f6c_dd1du64;
    for k in 1..=100 {
        let t_next = k as f64 * h;
        assert_eq!(even.step((k - 1) as f64 * h, h), OK);
        // Split each interval into 1..4 pieces of random lengths.
        while t < t_next {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            let piece = (rng % 1000 + 1) as f64 * 1e-7;
            let step = piece.min(t_next - t);
            assert_eq!(uneven.step(t, step), OK);
            let mut last = 0.0;
            unsafe { fmi2GetRealStatus(uneven.0, 2, &mut last) };
            assert_eq!(last, t + step, "lands exactly on tc + h");
            t += step;
        }
        let (a, b) = (even.outputs(), uneven.outputs());
        // Exact propagator: partition-independent up to rounding (1e-8 of the static deflection).
        assert!(
            (a[0] - b[0]).abs() <= 1e-8 * a[5],
            "k = {k}: {} vs {}",
            a[0],
            b[0]
        );
    }
}

#[test]
fn rollback_is_bit_identical() {
    let f = Fmu::ready();
    let h = 3.3e-5;
    let mut t = 0.0;
    for _ in 0..20 {
        assert_eq!(f.step(t, h), OK);
        t += h;
    }
    let mut st: *mut c_void = null_mut();
    assert_eq!(unsafe { fmi2GetFMUstate(f.0, &mut st) }, OK);
    let run = |t0: f64| {
        let mut t = t0;
        let mut rows = Vec::new();
        for _ in 0..5 {
            assert_eq!(f.step(t, h), OK);
            t += h;
            rows.push(f.outputs());
        }
        rows
    };
    let first = run(t);
    assert_eq!(unsafe { fmi2SetFMUstate(f.0, st) }, OK);
    assert_eq!(run(t), first, "get/set state");
    let blob = {
        assert_eq!(unsafe { fmi2SetFMUstate(f.0, st) }, OK);
        f.state_bytes()
    };
    unsafe { fmi2FreeFMUstate(f.0, &mut st) };
    // Serialized state into a fresh instance that was never initialized.
    let g = Fmu::new();
    assert_eq!(g.load_bytes(&blob), OK);
    let second = {
        let mut t2 = t;
        let mut rows = Vec::new();
        for _ in 0..5 {
            assert_eq!(g.step(t2, h), OK);
            t2 += h;
            rows.push(g.outputs());
        }
        rows
    };
    assert_eq!(second, first, "serialize/deserialize");
}

/// A state object overwritten by `fmi2GetFMUstate` (a master saving before every step) holds
/// the new state: serialized after it was serialized once before (the checksum is written at
/// serialization), it gives the bytes of a fresh object, which load.
#[test]
fn an_overwritten_state_object_serializes_as_a_fresh_one() {
    let f = Fmu::ready();
    let h = 3.3e-5;
    let serialize = |st: *mut c_void| {
        let mut n = 0usize;
        assert_eq!(unsafe { fmi2SerializedFMUstateSize(f.0, st, &mut n) }, OK);
        let mut buf = vec![0u8; n];
        let s = unsafe { fmi2SerializeFMUstate(f.0, st, buf.as_mut_ptr() as *mut c_char, n) };
        assert_eq!(s, OK);
        buf
    };
    let mut st: *mut c_void = null_mut();
    assert_eq!(unsafe { fmi2GetFMUstate(f.0, &mut st) }, OK);
    let before = serialize(st);
    assert_eq!(f.step(0.0, h), OK);
    let kept = st;
    assert_eq!(unsafe { fmi2GetFMUstate(f.0, &mut st) }, OK);
    assert_eq!(st, kept, "the object is overwritten, not replaced");
    let after = serialize(st);
    assert_ne!(after, before);
    assert_eq!(after, f.state_bytes());
    let g = Fmu::new();
    assert_eq!(g.load_bytes(&after), OK);
    unsafe { fmi2FreeFMUstate(f.0, &mut st) };
}

#[test]
fn corrupt_and_foreign_blobs_are_rejected() {
    let f = Fmu::ready();
    assert_eq!(f.step(0.0, 1e-4), OK);
    let blob = f.state_bytes();
    for i in 0..blob.len() {
        let mut bad = blob.clone();
        bad[i] ^= 0x40;
        let g = Fmu::ready();
        assert_eq!(g.load_bytes(&bad), ERR, "flipped byte {i}");
    }
    for n in [0, 1, 8, 20, blob.len() - 1] {
        let g = Fmu::ready();
        assert_eq!(g.load_bytes(&blob[..n]), ERR, "truncated to {n}");
    }
    // The same bytes are fine: the rejection above is the corruption, not the instance.
    let g = Fmu::ready();
    assert_eq!(g.load_bytes(&blob), OK);
    let g = Fmu::ready();
    assert_eq!(g.load_bytes(b"not an FMU state at all"), ERR);
}

#[test]
fn a_refused_step_is_a_discard_with_status() {
    let f = Fmu::ready();
    assert_eq!(f.step(0.0, 1e-4), OK);
    // Torques whose mean mesh force overflows are refused where they are set (issue 17:
    // range checks where the arithmetic breaks down), so they no longer reach a step.
    assert_eq!(f.set(VR_INPUT_TORQUE, 1e308), ERR);
    let f = Fmu::ready();
    assert_eq!(f.step(0.0, 1e-4), OK);
    // A finite speed whose next step spans more mesh periods than one step may take: the
    // step cannot complete.
    assert_eq!(f.set(VR_PINION_SPEED, 1e11), OK);
    assert_eq!(f.step(1e-4, 1e-4), Status::Discard);
    let mut last = f64::NAN;
    let mut term: c_int = 0;
    unsafe {
        assert_eq!(fmi2GetRealStatus(f.0, 2, &mut last), OK);
        assert_eq!(fmi2GetBooleanStatus(f.0, 3, &mut term), OK);
    }
    assert!((1e-4..2e-4).contains(&last), "last successful time {last}");
    // A failure, not the model ending the run: fmi2Terminated stays false, so a host (fmpy,
    // geardyn run) reports the step as refused instead of ending normally (issue 39).
    assert_eq!(term, 0);
    // stepFailed allows Terminate (FMI 2.0.x §4.2.4) but no further DoStep.
    assert_eq!(unsafe { fmi2Terminate(f.0) }, OK);
    assert_eq!(f.step(last, 1e-4), ERR);
}

#[test]
fn unsupported_functions_return_error() {
    let f = Fmu::ready();
    let vr = VR_OUTPUT0;
    let mut x = 0.0;
    let order: c_int = 1;
    unsafe {
        assert_eq!(
            fmi2GetDirectionalDerivative(f.0, &vr, 1, &VR_INPUT_TORQUE, 1, &1.0, &mut x),
            ERR
        );
        let f = Fmu::ready();
        assert_eq!(
            fmi2SetRealInputDerivatives(f.0, &VR_INPUT_TORQUE, 1, &order, &1.0),
            ERR
        );
        let f = Fmu::ready();
        assert_eq!(
            fmi2GetRealOutputDerivatives(f.0, &vr, 1, &order, &mut x),
            ERR
        );
    }
}

#[test]
fn instances_are_independent() {
    // Interleaved instances with different inputs give the same results as alone.
    let solo = Fmu::ready();
    let a = Fmu::ready();
    let b = Fmu::ready();
    assert_eq!(b.set(VR_PINION_SPEED, 300.0), OK);
    let h = 2e-5;
    for k in 0..200 {
        let t = k as f64 * h;
        for f in [&solo, &a, &b] {
            assert_eq!(f.step(t, h), OK);
        }
        assert_eq!(solo.outputs(), a.outputs());
    }
    assert_ne!(a.outputs(), b.outputs());
}

#[test]
fn rk_path_matches_native_and_rolls_back_bit_identically() {
    let (f, scene) = Fmu::rk();
    let mut sim = Simulation::new(&scene).unwrap();
    assert_eq!(sim.method_name(), "dop853");
    let h = 1e-5;
    for k in 0..300 {
        let t = k as f64 * h;
        assert_eq!(f.step(t, (k + 1) as f64 * h - t), OK);
        sim.advance_to((k + 1) as f64 * h).unwrap();
        assert_eq!(f.outputs()[0], sim.outputs()[0], "step {k}");
    }
    // Rollback: the controller memory (step-size proposal) is part of the state.
    let t0 = 300.0 * h;
    let blob = f.state_bytes();
    let run = |f: &Fmu| {
        (0..5)
            .map(|k| {
                let t = t0 + k as f64 * 1.3e-4;
                assert_eq!(f.step(t, 1.3e-4), OK);
                f.outputs()
            })
            .collect::<Vec<_>>()
    };
    let first = run(&f);
    assert_eq!(f.load_bytes(&blob), OK);
    assert_eq!(run(&f), first);
}
