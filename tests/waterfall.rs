//! The run-up waterfall on a synthetic chirp with known order content (closed form):
//! a signal `Σ A_o cos(o·θ(t))` with shaft angle `θ` from a linear speed ramp has its ridges
//! on `f = o·rpm/60`, straight lines through the origin.

use geardyn::analysis::spectrum::{waterfall, WaterfallOptions, Window};
use std::f64::consts::PI;

/// Linear run-up from 600 to 6000 rpm over 20 s, sampled at 20 kHz; orders 12 (amplitude 1)
/// and 25 (amplitude 0.3).
fn chirp() -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let (r0, r1, duration, fs) = (600.0, 6000.0, 20.0, 20_000.0);
    let n = (duration * fs) as usize;
    let a = (r1 - r0) / duration;
    let mut t = Vec::with_capacity(n);
    let mut x = Vec::with_capacity(n);
    let mut rpm = Vec::with_capacity(n);
    for j in 0..n {
        let tj = j as f64 / fs;
        // θ = 2π ∫ rpm/60 dt, in closed form for the ramp.
        let theta = 2.0 * PI * (r0 * tj + 0.5 * a * tj * tj) / 60.0;
        t.push(tj);
        rpm.push(r0 + a * tj);
        x.push((12.0 * theta).cos() + 0.3 * (25.0 * theta).cos());
    }
    (t, x, rpm)
}

#[test]
fn ridges_lie_on_order_lines_through_the_origin() {
    let (t, x, rpm) = chirp();
    let options = WaterfallOptions {
        segment: 4096,
        overlap: 0.5,
        window: Window::Hann,
    };
    let map = waterfall(&t, &x, &rpm, &options).unwrap();
    assert!(map.rpm.len() > 150, "{} rows", map.rpm.len());
    let resolution = map.frequency[1] - map.frequency[0];
    for order in [12.0, 25.0] {
        // Least-squares line f = a + b·rpm through the ridge of every row.
        let (mut sx, mut sy, mut sxx, mut sxy, mut m) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for r in 0..map.rpm.len() {
            let expected = order * map.rpm[r] / 60.0;
            let f = map.ridge(r, expected - 20.0, expected + 20.0).unwrap();
            // The ridge is the bin nearest the closed form: within one bin (the speed changes
            // by 0.1 % of the mean over a window, far less than a bin).
            assert!(
                (f - expected).abs() <= resolution,
                "order {order}, row {r}: {f} vs {expected} Hz"
            );
            sx += map.rpm[r];
            sy += f;
            sxx += map.rpm[r] * map.rpm[r];
            sxy += map.rpm[r] * f;
            m += 1.0;
        }
        let slope = (m * sxy - sx * sy) / (m * sxx - sx * sx);
        let intercept = (sy - slope * sx) / m;
        assert!(
            (slope * 60.0 / order - 1.0).abs() < 1e-3,
            "order {order}: slope {slope}"
        );
        assert!(
            intercept.abs() < resolution,
            "order {order}: intercept {intercept} Hz"
        );
    }
    // Amplitudes: the Hann window reads a tone between bins at least 0.849 of its amplitude
    // (scallop loss 1.42 dB) and at most its amplitude (+ leakage).
    let mid = map.rpm.len() / 2;
    let f12 = 12.0 * map.rpm[mid] / 60.0;
    let c = map
        .frequency
        .iter()
        .position(|&f| f == map.ridge(mid, f12 - 20.0, f12 + 20.0).unwrap())
        .unwrap();
    let a = map.amplitude[mid][c];
    assert!((0.84..=1.01).contains(&a), "order-12 amplitude {a}");
}

#[test]
fn irregular_or_mismatched_records_are_refused() {
    let (mut t, x, rpm) = chirp();
    let options = WaterfallOptions::default();
    let e = waterfall(&t, &x[1..], &rpm, &options).unwrap_err();
    assert!(e.contains("signal samples"), "{e}");
    t[1000] += 1e-5;
    let e = waterfall(&t, &x, &rpm, &options).unwrap_err();
    assert!(e.contains("sample interval"), "{e}");
    let e = waterfall(
        &t,
        &x,
        &rpm,
        &WaterfallOptions {
            overlap: 1.0,
            ..options
        },
    )
    .unwrap_err();
    assert!(e.contains("overlap = 1"), "{e}");
}

#[test]
fn waterfall_csv_has_units_and_orders() {
    let (t, x, rpm) = chirp();
    let options = WaterfallOptions {
        segment: 4096,
        overlap: 0.0,
        window: Window::Hann,
    };
    let map = waterfall(&t[..40_000], &x[..40_000], &rpm[..40_000], &options).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("w.csv");
    map.write_csv(&path, "m").unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "time_s,rpm,frequency_Hz,order,amplitude_m"
    );
    assert_eq!(lines.count(), map.rpm.len() * map.frequency.len());
}
