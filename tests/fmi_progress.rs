//! Issue 17, FMU side: every step makes progress or says why not. Each failing case of the
//! issue through the C ABI (in-process, as `tests/fmi_abi.rs`), now with a status and a
//! logged reason that names the quantity and its value, within a time bound; after a failed
//! step the outputs are the last good values. Every call runs under a watchdog
//! ([`fmu_harness::within`]): a hang fails the test instead of stalling the suite.

mod fmu_harness;

use std::time::Duration;

use fmu_harness::{within, Fmu, SplitMix, DISCARD, ERR, OK};
use geardyn::fmi::blob;
use geardyn::fmi::logger::Status;
use geardyn::fmu::pair::state::{decode, encode};
use geardyn::fmu::pair::*;
use geardyn::scene::PairScene;
use geardyn::simulation::Simulation;
use geardyn::solve::SolveError;

/// Far above any of these calls on a loaded machine (each returns in milliseconds), far below
/// the hangs of the issue (> 10 s, or never).
const LIMIT: Duration = Duration::from_secs(10);

const REAL_OUTPUTS: [u32; 6] = [
    VR_OUTPUT0,
    VR_OUTPUT0 + 1,
    VR_OUTPUT0 + 2,
    VR_OUTPUT0 + 4,
    VR_OUTPUT0 + 5,
    VR_OUTPUT0 + 6,
];

/// `spur_pair` with `vr = x` set before initialization (`static_start` false:
/// `initial.static_dte = false`): the statuses of the set, enter and exit, and the messages.
fn set_before_init(vr: u32, x: f64, static_start: bool) -> (Fmu, [Status; 3], String) {
    let f = Fmu::new("spur_pair");
    assert_eq!(f.setup(None), OK);
    if !static_start {
        assert_eq!(f.set_bool(VR_INITIAL_STATIC, false), OK);
    }
    let set = f.set(vr, x);
    let statuses = if set == OK {
        [set, f.enter(), f.exit()]
    } else {
        [set, set, set]
    };
    let log = f.messages();
    (f, statuses, log)
}

/// A step of an initialized instance that is discarded or refused with a message containing
/// every one of `words`, leaves the time at `tc` and the outputs at their values before it.
fn assert_step_refused(f: &Fmu, tc: f64, h: f64, words: &[&str]) {
    let (s, before) = f.get(&REAL_OUTPUTS);
    assert_eq!(s, OK);
    f.messages();
    let status = f.step(tc, h);
    let log = f.messages();
    assert!(
        status == DISCARD || status == ERR,
        "step tc = {tc}, h = {h:e}: {status:?}"
    );
    for w in words {
        assert!(log.contains(w), "message lacks '{w}': {log}");
    }
    let (s, after) = f.get(&REAL_OUTPUTS);
    assert_eq!(s, OK, "outputs readable after {status:?}");
    assert_eq!(
        after, before,
        "outputs after {status:?} are the last good ones"
    );
    if status == DISCARD {
        assert_eq!(f.last_successful_time(), tc);
    }
}

/// `mesh.initial_phase >= 9.1e15` (also 1e20, ±1e300): the first step never returned. The
/// phase is refused where it is set, naming it and the value; within the limit it works.
#[test]
fn a_phase_beyond_its_resolution_is_refused_where_it_is_set() {
    within(LIMIT, "initial phases", || {
        for x in [9.1e15, 1e20, 1e300, -1e300, 4.3e9] {
            let (_f, s, log) = set_before_init(VR_INITIAL_PHASE, x, true);
            assert_eq!(s[0], ERR, "initial_phase = {x:e}");
            assert!(
                log.contains("mesh.initial_phase") && log.contains(&format!("{x:?}")),
                "{log}"
            );
        }
        let (f, s, _) = set_before_init(VR_INITIAL_PHASE, 4.2e9, true);
        assert_eq!(s, [OK; 3]);
        assert_eq!(f.step(0.0, 2e-4), OK);
    });
    // The drivetrain's phase parameter goes through the same check.
    within(LIMIT, "train initial phase", || {
        let f = Fmu::new("idler_gearset");
        assert_eq!(
            f.set(geardyn::fmu::drivetrain::VR_INITIAL_PHASE, 9.1e15),
            ERR
        );
        assert!(f.messages().contains("9100000000000000.0"));
    });
}

/// A phase that grows past the limit during a run is refused before the step that would
/// take it there (the clock's check of every advance), naming the phase.
#[test]
fn a_step_that_would_take_the_phase_past_its_resolution_is_refused() {
    within(LIMIT, "phase growth", || {
        let (f, s, _) = set_before_init(VR_INITIAL_PHASE, 4.294967e9, true);
        assert_eq!(s, [OK; 3]);
        assert_eq!(f.step(0.0, 1e-3), OK);
        // 2850 Hz: 0.5 s is ~1400 cycles, past 2^32 = 4294967296.
        assert_step_refused(&f, 1e-3, 0.5, &["mesh phase", "resolution"]);
    });
}

/// `fmi2DoStep(h = 1e300)` without a stop time never returned; now the mesh-period bound of
/// one step refuses it at once. A step below the time resolution of its communication point
/// is refused too, naming both.
#[test]
fn steps_beyond_the_work_bound_or_below_the_time_resolution_are_refused() {
    within(LIMIT, "h = 1e300", || {
        let f = Fmu::ready("spur_pair");
        assert_eq!(f.step(0.0, 1e-5), OK);
        assert_step_refused(&f, 1e-5, 1e300, &["mesh periods", "1.048576e6"]);
    });
    within(LIMIT, "h below resolution", || {
        let f = Fmu::ready("spur_pair");
        assert_eq!(f.step(0.0, 1e-3), OK);
        let status = f.step(1e-3, 1e-16);
        assert_eq!(status, ERR);
        let log = f.messages();
        assert!(
            log.contains("communicationStepSize = 1e-16") && log.contains("resolution"),
            "{log}"
        );
    });
}

/// `pinion.base_radius = 34317.8` with `initial.static_dte = false`: one 1e-5 s step took
/// more than 10 s. Why: the equivalent mass becomes 2.2e-12 kg, so the mesh damping gives the
/// mode a rate c/m_e ≈ 7e14 1/s, and the exact propagator samples the contact guards every
/// quarter of the fastest period (~4.5e9 samples for 1e-5 s). The crossing search's bound of
/// guard samples per advance refuses it before sampling; a less extreme radius still runs.
#[test]
fn a_mode_too_fast_for_the_step_is_refused_by_the_guard_sample_bound() {
    within(LIMIT, "base radius 34317.8", || {
        let (f, s, _) = set_before_init(VR_PINION_BASE_RADIUS, 34317.8, false);
        assert_eq!(s, [OK; 3]);
        assert_step_refused(&f, 0.0, 1e-5, &["guard samples", "fastest rate"]);
        let (f, s, _) = set_before_init(VR_PINION_BASE_RADIUS, 343.178, false);
        assert_eq!(s, [OK; 3]);
        assert_eq!(f.step(0.0, 1e-5), OK);
    });
}

/// `pinion_speed` of 1e9…1e308 as an input: the step cost grew without bound (1e11: 8.5 s per
/// 2e-4 s step) and nothing said why. Now the mesh-period bound of one step refuses the step,
/// naming the speed; a speed whose mesh rate leaves the arithmetic is refused where it is
/// set. The drivetrain's `operating.input_speed` alike.
#[test]
fn input_speeds_beyond_the_work_bound_are_refused_naming_the_speed() {
    within(LIMIT, "pinion speeds", || {
        for speed in [1e9, 1e11, 1e100] {
            let f = Fmu::ready("spur_pair");
            assert_eq!(f.step(0.0, 2e-4), OK);
            assert_eq!(f.set(VR_PINION_SPEED, speed), OK);
            assert_step_refused(&f, 2e-4, 2e-4, &["operating.pinion_speed", "mesh periods"]);
        }
        for speed in [1e200, 1e308] {
            let f = Fmu::ready("spur_pair");
            assert_eq!(f.set(VR_PINION_SPEED, speed), ERR);
            let log = f.messages();
            assert!(
                log.contains(&format!("operating.pinion_speed = {speed:?}")),
                "{log}"
            );
        }
        // Below the bound a fast speed is simply computed: 1e8 rad/s, 1.2e5 periods.
        let f = Fmu::ready("spur_pair");
        assert_eq!(f.set(VR_PINION_SPEED, 1e8), OK);
        assert_eq!(f.step(0.0, 2e-4), OK);
    });
    within(LIMIT, "train input speed", || {
        let f = Fmu::ready("idler_gearset");
        assert_eq!(f.set(geardyn::fmu::drivetrain::VR_INPUT_SPEED, 1e11), OK);
        assert_eq!(f.step(0.0, 2e-4), DISCARD);
        let log = f.messages();
        assert!(
            log.contains("operating.input_speed") && log.contains("mesh periods"),
            "{log}"
        );
    });
}

/// A native run refuses the same advance with the same reason (the bound lives in the
/// driver, not in the FMU adapters).
#[test]
fn a_native_run_refuses_an_advance_beyond_the_work_bound() {
    let mut scene = PairScene::from_path(&fmu_harness::scene_dir("spur_pair")).unwrap();
    scene.operating.pinion_speed = 1e12;
    let mut sim = Simulation::new(&scene).unwrap();
    let e = sim.advance_to(2e-4).unwrap_err();
    assert!(matches!(e, SolveError::BeyondLimits { .. }), "{e}");
    assert!(e.to_string().contains("pinion_speed = 1e12"), "{e}");
    assert_eq!(sim.t(), 0.0, "nothing was integrated");
}

/// Inertia 1e-300, damping 1e300 or base radius 1e300 gave fmi2Discard and NaN outputs. The
/// parameters are now refused where their combination leaves the range of the arithmetic
/// (equivalent mass, rates), with a message naming the parameter, its value and the quantity.
#[test]
fn parameters_beyond_the_arithmetic_are_refused_naming_the_quantity() {
    within(LIMIT, "extreme parameters", || {
        for (vr, x, name, quantity) in [
            (VR_PINION_INERTIA, 1e-300, "pinion.inertia", "1/s"),
            (VR_DAMPING, 1e300, "mesh.damping", "damping rate"),
            (
                VR_PINION_BASE_RADIUS,
                1e300,
                "pinion.base_radius",
                "equivalent mass",
            ),
            (VR_GEAR_INERTIA, 1e-300, "gear.inertia", "1/s"),
        ] {
            let (f, s, log) = set_before_init(vr, x, true);
            assert_eq!(s[0], ERR, "{name} = {x:e}");
            assert!(
                log.contains(name) && log.contains(&format!("{x:?}")) && log.contains(quantity),
                "{log}"
            );
            // The refused value changed nothing: the instance still runs.
            assert_eq!(unsafe { geardyn::fmi::abi::fmi2Reset(f.c) }, OK);
            assert_eq!(f.setup(None), OK);
            assert_eq!(f.enter(), OK);
            assert_eq!(f.exit(), OK);
            assert_eq!(f.step(0.0, 1e-5), OK);
            let (s, v) = f.get(&REAL_OUTPUTS);
            assert_eq!(s, OK);
            assert!(v.iter().all(|x| x.is_finite()), "{v:?}");
        }
    });
}

/// A start value whose initial outputs are not finite (a DTE rate of 1e308 gives a damping
/// force of 1.6e311 N) is refused where it is set, naming the output, instead of being read
/// back as an infinite output (found by the long run of `tests/fmi_fuzz.rs`).
#[test]
fn start_values_with_non_finite_initial_outputs_are_refused() {
    let (_f, s, log) = set_before_init(VR_INITIAL_DTE_RATE, 1e308, true);
    assert_eq!(s[0], ERR);
    assert!(
        log.contains("initial.dte_rate") && log.contains("mesh.force") && log.contains("inf"),
        "{log}"
    );
}

/// The model part of a `spur_pair` state after a few steps, with its envelope.
fn state_parts(f: &Fmu) -> (blob::LayerSnapshot, Vec<u8>) {
    let bytes = f.state_bytes();
    let g = fmu_harness::guid("spur_pair");
    let (layer, payload) = blob::decode(&bytes, g.to_str().unwrap()).unwrap();
    (layer, payload.to_vec())
}

fn envelope(layer: &blob::LayerSnapshot, payload: &[u8]) -> Vec<u8> {
    let g = fmu_harness::guid("spur_pair");
    blob::encode(g.to_str().unwrap(), layer, payload)
}

/// A state blob whose checksum is recomputed after changing the stored inertia, damping or
/// phase anchor was accepted, and the next step hung. A restored state now passes the
/// checks of fmi2SetReal (the same functions), and its clock must be the one its inputs give
/// within the phase limit: such a blob is refused naming the value, and the instance keeps
/// running from a good state.
#[test]
fn restored_states_are_validated_like_set_values() {
    within(LIMIT, "corrupted states", || {
        let f = Fmu::ready("spur_pair");
        for k in 0..5 {
            assert_eq!(f.step(k as f64 * 1e-4, 1e-4), OK);
        }
        let (layer, payload) = state_parts(&f);
        let good = decode(&payload).unwrap();
        let param = |vr: u32, x: f64| {
            let mut s = good.clone();
            s.params.iter_mut().find(|p| p.0 == vr).unwrap().1 = x;
            s
        };
        let mut anchor = good.clone();
        let (t0, _) = anchor.sim.pair.clock.anchor();
        anchor.sim.pair.clock =
            geardyn::model::PhaseClock::new(t0, 1e300, anchor.sim.pair.clock.mesh_frequency());
        let mut frequency = good.clone();
        frequency.sim.pair.clock = geardyn::model::PhaseClock::new(t0, 0.5, 1e15);
        let mut speed = good.clone();
        speed.sim.pair.inputs.pinion_speed = -1.0;
        let cases = [
            (param(VR_PINION_INERTIA, 1e-300), "pinion.inertia"),
            (param(VR_DAMPING, 1e300), "mesh.damping"),
            (param(VR_INITIAL_PHASE, 1e20), "mesh.initial_phase"),
            (param(VR_DAMPING, f64::NAN), "mesh.damping"),
            (anchor, "clock anchor phase = 1e300"),
            (frequency, "clock mesh frequency"),
            (speed, "operating.pinion_speed"),
        ];
        for (bad, what) in cases {
            let status = f.load_bytes(&envelope(&layer, &encode(&bad)));
            assert_eq!(status, ERR, "{what}");
            let log = f.messages();
            assert!(log.contains(what), "message lacks '{what}': {log}");
            // The good state restores and continues.
            assert_eq!(f.load_bytes(&envelope(&layer, &payload)), OK);
            assert_eq!(f.step(5e-4, 1e-4), OK);
            assert_eq!(f.load_bytes(&envelope(&layer, &payload)), OK);
        }
    });
}

/// The mutation run: bits flipped in the numbers of a state's model part (parameters,
/// time, state, inputs, clock), the envelope re-encoded with a valid checksum. Every blob is
/// refused or accepted, and an accepted one steps within the time bound with finite outputs
/// or refuses the step with a reason (173 of 15,000 such blobs hung before).
#[test]
fn states_with_flipped_bits_are_refused_or_step_within_bounds() {
    within(Duration::from_secs(120), "state mutations", || {
        let f = Fmu::ready("spur_pair");
        for k in 0..5 {
            assert_eq!(f.step(k as f64 * 1e-4, 1e-4), OK);
        }
        let (layer, payload) = state_parts(&f);
        // The f64 fields: after the parameter list (u32 count, 12-byte entries) and flags.
        let n = u32::from_le_bytes(payload[..4].try_into().unwrap()) as usize;
        let params: Vec<usize> = (0..n).map(|i| 4 + 12 * i + 4).collect();
        let numbers_at = 4 + 12 * n + 1;
        let fields: Vec<usize> = params
            .into_iter()
            .chain((0..12).map(|i| numbers_at + 8 * i))
            .collect();
        let mut rng = SplitMix(17);
        let (mut refused, mut stepped, mut step_refused) = (0, 0, 0);
        for case in 0..3000 {
            let mut p = payload.clone();
            let field = fields[(rng.next() % fields.len() as u64) as usize];
            for _ in 0..1 + rng.next() % 3 {
                let bit = (rng.next() % 64) as usize;
                p[field + bit / 8] ^= 1 << (bit % 8);
            }
            if f.load_bytes(&envelope(&layer, &p)) != OK {
                refused += 1;
                assert!(
                    !f.messages().is_empty(),
                    "case {case}: refused without a reason"
                );
                continue;
            }
            f.messages();
            let tc = {
                let mut t = 0.0;
                assert_eq!(
                    unsafe { geardyn::fmi::abi::fmi2GetRealStatus(f.c, 2, &mut t) },
                    OK
                );
                t
            };
            match f.step(tc, 1e-4) {
                OK => stepped += 1,
                s => {
                    assert!(s == DISCARD || s == ERR, "case {case}: {s:?}");
                    assert!(
                        !f.messages().is_empty(),
                        "case {case}: {s:?} without a reason"
                    );
                    step_refused += 1;
                }
            }
            let (s, v) = f.get(&REAL_OUTPUTS);
            assert_eq!(s, OK, "case {case}");
            assert!(
                v.iter().all(|x| x.is_finite()),
                "case {case}: outputs {v:?}"
            );
        }
        eprintln!(
            "state mutations: 3000 blobs, {refused} refused, {stepped} stepped, \
             {step_refused} steps refused with a reason"
        );
        assert!(refused > 0 && stepped > 0);
    });
}
