//! Helpers of the port tests (`tests/ports.rs`, `tests/port_stages.rs`): columns of a carried
//! run by name, the shipped stage scenes, and the trapezoid quadratures their oracles use.

use std::path::PathBuf;

use geardyn::model::train::TrainTrajectory;
use geardyn::scene::Scene;

/// The text of the shipped scene `fmu/<name>/scene.toml`.
pub fn stage_text(name: &str) -> String {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("fmu")
        .join(name)
        .join("scene.toml");
    std::fs::read_to_string(path).unwrap()
}

pub fn scene(text: &str) -> Scene {
    Scene::from_toml_str(text, "test").unwrap()
}

/// Column `name` of a run, as a function of the sample index.
pub fn col<'a>(run: &'a TrainTrajectory, name: &str) -> impl Fn(usize) -> f64 + 'a {
    let c = run
        .column(name)
        .unwrap_or_else(|| panic!("no column {name}"));
    move |i| run.rows[i][c]
}

/// Over `[t_a, t_end]` (trapezoid): `mean(ω_out)/mean(ω_in)` and `mean(ω_out/ω_in)`, each
/// relative to `ratio`, minus 1.
pub fn ratio_errors(
    run: &TrainTrajectory,
    speed_in: &str,
    speed_out: &str,
    ratio: f64,
    t_a: f64,
) -> (f64, f64) {
    let (w1, w2) = (col(run, speed_in), col(run, speed_out));
    let t = &run.times;
    let (mut a1, mut a2, mut q, mut span) = (0.0, 0.0, 0.0, 0.0);
    for i in 1..t.len() {
        if t[i - 1] < t_a {
            continue;
        }
        let h = t[i] - t[i - 1];
        a1 += 0.5 * h * (w1(i - 1) + w1(i));
        a2 += 0.5 * h * (w2(i - 1) + w2(i));
        q += 0.5 * h * (w2(i - 1) / w1(i - 1) + w2(i) / w1(i));
        span += h;
    }
    ((a2 / a1) / ratio - 1.0, (q / span) / ratio - 1.0)
}

/// `∫ f dt` by the trapezoid rule over the run's samples.
pub fn integral(run: &TrainTrajectory, f: &dyn Fn(usize) -> f64) -> f64 {
    let t = &run.times;
    (1..t.len())
        .map(|i| 0.5 * (t[i] - t[i - 1]) * (f(i - 1) + f(i)))
        .sum()
}

/// `∫ f dg` (Stieltjes, trapezoid): the work of a force `f` over a displacement `g`, without
/// differentiating `g`.
pub fn stieltjes(n: usize, f: &dyn Fn(usize) -> f64, g: &dyn Fn(usize) -> f64) -> f64 {
    (1..n)
        .map(|i| 0.5 * (f(i - 1) + f(i)) * (g(i) - g(i - 1)))
        .sum()
}
