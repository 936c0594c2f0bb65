//! Issue 31, acceptance 3: order tracking in the angle domain (`geardyn waterfall
//! --order-cuts`, `docs/spectrum.md`, "Order cuts").
//!
//! 1. On a slow run-up of `spur_pair` and of `idler_gearset`, the order-tracked amplitude of
//!    mesh order 1 equals the line of the constant-speed `spectrum` (the exact spectrum of the
//!    shot periodic orbit) at the block's speed to ≤ 1 %.
//! 2. With runout and a pitch-error table on the pinion of `runup_spur`, the shaft-order
//!    sidebands of mesh order 1 are resolved at their exact orders on the shipped ramp
//!    (3500 rpm/s), where a time-domain window smears them.

use std::f64::consts::TAU;

use geardyn::analysis::spectrum::Window;
use geardyn::commands::runup::{runup_order_cuts, OrderTrackRequest, RunupSignal};
use geardyn::commands::spectrum::{periodic_spectrum, SpectrumRequest};
use geardyn::scene::Scene;

const SPUR: &str = include_str!("../fmu/spur_pair/scene.toml");
const IDLER: &str = include_str!("../fmu/idler_gearset/scene.toml");
const RUNUP: &str = include_str!("../examples/runup_spur.toml");

fn scene(text: &str) -> Scene {
    Scene::from_toml_str(text, "test").map_err(|e| e.0).unwrap()
}

/// `text` with its `speed_line` replaced by `replacement`, and the solver's stop time set.
fn with(text: &str, speed_line: &str, replacement: &str, stop: &str) -> String {
    let start = text.find(speed_line).expect("the scene's speed line");
    let end = start + text[start..].find('\n').unwrap();
    let mut t = format!("{}{replacement}{}", &text[..start], &text[end..]);
    if let Some(s) = t.find("stop_time = ") {
        let e = s + t[s..].find('\n').unwrap();
        t = format!("{}stop_time = {stop}{}", &t[..s], &t[e..]);
    } else {
        t = t.replacen("[solver]", &format!("[solver]\nstop_time = {stop}"), 1);
    }
    t
}

/// The slow run-up: `rpm ± 60 rpm` at `rate` rpm/s, from which the block nearest `rpm` is
/// compared with the constant-speed spectrum at that block's speed, for the DTE and the
/// force of mesh `mesh`.
///
/// Why this ramp is slow enough: the response follows the periodic orbit when the mesh
/// frequency moves little within the decay time of the free vibration, `τ = 1/(ζ ω_n)`,
/// against the resonance's half-power bandwidth `2ζ f_n`. At 60 rpm/s, `ḟ_m = 38 Hz/s` and
/// `τ ≤ 1/(0.02·2π·2000 Hz) = 4 ms` (the idler's 2 % modal damping; 1.1 ms for the pair),
/// so the mesh frequency moves 0.15 Hz per decay time against a bandwidth of ≥ 80 Hz:
/// 2e-3 of it. A block of 8 revolutions spans ≤ 10 rpm, over which the amplitude's
/// curvature moves the centre value by far less than 1e-3 at the speeds chosen (away from
/// the jumps). The transient of the start (static deflection) is gone after 0.5 s, ≥ 100 decay
/// times, before the compared block.
fn slow_runup_matches_the_spectrum(
    text: &str,
    speed_line: &str,
    rpm: f64,
    mesh: usize,
    column: [&str; 2],
) {
    const RATE: f64 = 60.0; // rpm/s
    let (from, to) = (rpm - RATE, rpm + RATE);
    let duration = (to - from) / RATE;
    let w = |n: f64| n * TAU / 60.0;
    let profile = format!(
        "[operating.speed_profile]\nkind = \"ramp\"\nfrom = {:?}\nto = {:?}\nstart = 0.0\nend = {duration:?}\n",
        w(from),
        w(to)
    );
    let runup_text = with(text, speed_line, "", &format!("{duration:?}")).replacen(
        "[solver]",
        &format!("{profile}\n[solver]"),
        1,
    );
    let runup = scene(&runup_text);
    let request = OrderTrackRequest {
        mesh_orders: vec![1.0],
        ..OrderTrackRequest::default()
    };
    for (signal, name) in [
        (RunupSignal::Dte, column[0]),
        (RunupSignal::Force, column[1]),
    ] {
        let tracked = runup_order_cuts(&runup, mesh, signal, &request, &|_, _| {}).unwrap();
        let c = &tracked.cuts;
        let b = (0..c.speed.len())
            .min_by(|&a, &b| {
                (c.speed[a] - w(rpm))
                    .abs()
                    .total_cmp(&(c.speed[b] - w(rpm)).abs())
            })
            .unwrap();
        let speed = c.speed[b];
        let steady = scene(&with(
            text,
            speed_line,
            &format!("{} = {speed:?}", speed_line.split(' ').next().unwrap()),
            "0.02",
        ));
        let spectrum = periodic_spectrum(
            &steady,
            &SpectrumRequest {
                signals: vec![name.to_string()],
                ..SpectrumRequest::default()
            },
        )
        .unwrap();
        let s = &spectrum.signals[0].spectrum;
        let f_mesh = tracked.mesh_order * speed / TAU;
        let k = s.peak_in(0.999 * f_mesh, 1.001 * f_mesh).unwrap();
        assert!((s.frequency[k] - f_mesh).abs() < 1e-6 * f_mesh);
        let (tracked_a, steady_a) = (c.amplitude[b][0], s.amplitude[k]);
        let error = tracked_a / steady_a - 1.0;
        println!(
            "{name} at {:.3} rpm (block {b} of {}): order-tracked {tracked_a:.6e}, spectrum \
             {steady_a:.6e}, relative difference {error:+.3e}",
            speed * 60.0 / TAU,
            c.speed.len()
        );
        assert!(error.abs() <= 0.01, "{name}: {error:e}");
    }
}

#[test]
fn slow_runup_of_spur_pair_tracks_the_constant_speed_spectrum() {
    slow_runup_matches_the_spectrum(
        SPUR,
        "pinion_speed = ",
        3000.0,
        0,
        ["mesh.dte", "mesh.force"],
    );
}

#[test]
fn slow_runup_of_idler_gearset_tracks_the_constant_speed_spectrum() {
    slow_runup_matches_the_spectrum(
        IDLER,
        "input_speed = ",
        3000.0,
        0,
        ["mesh1.dte", "mesh1.force"],
    );
}

/// `runup_spur` (1000 → 8000 rpm in 2 s, 3500 rpm/s) with a 10 µm pinion runout and a pinion
/// cumulative pitch-error table of two harmonics (5 µm at order 1, 2 µm at order 2): lines at
/// shaft orders 38 ± 1 and 38 ± 2 around mesh order 1 (38). In the angle domain each is a
/// peak at its exact order, separated from mesh order 1 by a valley, in every block away from
/// the resonance crossing (where the free vibration, a constant frequency, sweeps through the
/// orders 36–40 within one block).
#[test]
fn runout_and_pitch_sidebands_are_resolved_at_their_exact_orders_on_the_shipped_ramp() {
    let pitch: Vec<String> = (0..38)
        .map(|i| {
            let a = TAU * i as f64 / 38.0;
            format!("{:e}", 5e-6 * a.sin() + 2e-6 * (2.0 * a + 1.0).sin())
        })
        .collect();
    let errors = format!(
        "inertia = 0.002621\nrunout = {{ amplitude = 1.0e-5, phase = 0.3 }}\n\
         cumulative_pitch_errors = [{}]",
        pitch.join(", ")
    );
    assert!(RUNUP.contains("inertia = 0.002621\n"));
    // A runout moves the operating centre distance, so the mesh needs its pressure angle.
    let runup = scene(
        &RUNUP
            .replacen("inertia = 0.002621\n", &(errors + "\n"), 1)
            .replacen("[mesh]\n", "[mesh]\npressure_angle = 20.0\n", 1),
    );
    // A fine order grid, 1/32 order, from 35 to 41: mesh order 1 and both sideband pairs.
    let step = 1.0 / 32.0;
    let grid: Vec<f64> = (0..=192).map(|j| 35.0 + j as f64 * step).collect();
    let request = OrderTrackRequest {
        mesh_orders: Vec::new(),
        shaft_orders: grid.clone(),
        ..OrderTrackRequest::default()
    };
    let tracked = runup_order_cuts(&runup, 0, RunupSignal::Dte, &request, &|_, _| {}).unwrap();
    assert!((tracked.mesh_order - 38.0).abs() < 1e-12 * 38.0);
    let c = &tracked.cuts;
    let at = |o: f64| ((o - 35.0) / step).round() as usize;
    let n_res = 4713.0;
    let (mut checked, mut worst_valley, mut worst_offset) = (0, 0.0f64, 0.0f64);
    for b in 0..c.speed.len() {
        let rpm = c.speed[b] * 60.0 / TAU;
        if (rpm - n_res).abs() < 800.0 {
            continue;
        }
        let a = &c.amplitude[b];
        for sideband in [36.0, 37.0, 39.0, 40.0] {
            // The largest value within ±0.375 order is at the exact order.
            let (lo, hi) = (at(sideband - 0.375), at(sideband + 0.375));
            let peak = (lo..=hi).max_by(|&x, &y| a[x].total_cmp(&a[y])).unwrap();
            // On the order grid the peak sits at the exact order, within one step (1/32 order,
            // a quarter of the resolution 1/8): near a resonance the response's phase turns
            // within a block, which leans a line by a fraction of its width.
            let offset = (grid[peak] - sideband).abs();
            worst_offset = worst_offset.max(offset);
            assert!(
                offset <= step + 1e-9,
                "block {b} at {rpm:.0} rpm: the peak near order {sideband} is at {}",
                grid[peak]
            );
            // Separated: the spectrum falls below a tenth of the smaller peak between it and
            // its neighbour towards mesh order 1.
            let toward = if sideband < 38.0 {
                sideband + 1.0
            } else {
                sideband - 1.0
            };
            let (s, e) = (at(sideband.min(toward)), at(sideband.max(toward)));
            let valley = (s..=e).map(|j| a[j]).fold(f64::INFINITY, f64::min);
            let ratio = valley / a[at(sideband)].min(a[at(toward)]);
            worst_valley = worst_valley.max(ratio);
            assert!(
                ratio < 0.1,
                "block {b} at {rpm:.0} rpm: order {sideband} not separated from {toward} \
                 (valley {ratio:.3} of the smaller peak)"
            );
        }
        checked += 1;
    }
    println!(
        "{checked} of {} blocks checked (1000–{:.0} and {:.0}–8000 rpm); largest valley between \
         neighbouring orders: {worst_valley:.2e} of the smaller peak; largest peak offset \
         {worst_offset} order",
        c.speed.len(),
        n_res - 800.0,
        n_res + 800.0
    );
    assert!(
        checked >= c.speed.len() / 2,
        "{checked} of {}",
        c.speed.len()
    );
}

/// The block length in revolutions must hold at least one block; the window's name and the
/// orders are checked before the run.
#[test]
fn order_tracking_refuses_what_it_cannot_do() {
    let runup = scene(RUNUP);
    let request = OrderTrackRequest {
        shaft_orders: vec![5000.0],
        ..OrderTrackRequest::default()
    };
    let e = runup_order_cuts(&runup, 0, RunupSignal::Dte, &request, &|_, _| {}).unwrap_err();
    assert!(
        e.contains("order 5000") && e.contains("--order-samples"),
        "{e}"
    );
    let steady = scene(SPUR);
    let e = runup_order_cuts(
        &steady,
        0,
        RunupSignal::Dte,
        &OrderTrackRequest::default(),
        &|_, _| {},
    )
    .unwrap_err();
    assert!(e.contains("speed_profile"), "{e}");
    let request = OrderTrackRequest {
        window: Window::FlatTop,
        revolutions: 100_000,
        ..OrderTrackRequest::default()
    };
    let e = runup_order_cuts(&runup, 0, RunupSignal::Dte, &request, &|_, _| {}).unwrap_err();
    assert!(e.contains("--revolutions = 100000"), "{e}");
}
