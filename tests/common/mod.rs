//! Scene builders shared by the integration tests.
//!
//! The test pair is chosen so that closed forms are easy to state: two equal gears with
//! `r_b = 0.05 m`, `I = 0.0025 kg·m²`, hence `m_e = 1/(r1²/I1 + r2²/I2) = 0.5 kg`, and 20
//! pinion teeth, hence mesh frequency `f_m = 20·Ω/2π`.

#![allow(dead_code)]

pub mod fmu;
pub mod idler2;
pub mod idler3;
pub mod meissner;
pub mod ports;
pub mod rng;

use geardyn::scene::PairScene;

pub const M_E: f64 = 0.5;
pub const TEETH: f64 = 20.0;

/// A scene with the test pair; `mesh` is the body of `[mesh]` after `pinion`/`gear` (contact
/// law, damping, stiffness and STE tables), `operating` the body of `[operating]`, `extra`
/// anything after (`[initial]`, `[solver]`).
pub fn scene_text(mesh: &str, operating: &str, extra: &str) -> String {
    format!(
        r#"name = "test_pair"

[[gear]]
name = "pinion"
teeth = 20
base_radius = 0.05
inertia = 0.0025

[[gear]]
name = "gear"
teeth = 20
base_radius = 0.05
inertia = 0.0025

[mesh]
pinion = "pinion"
gear = "gear"
{mesh}

[operating]
{operating}

{extra}
"#
    )
}

pub fn scene(mesh: &str, operating: &str, extra: &str) -> PairScene {
    let text = scene_text(mesh, operating, extra);
    PairScene::from_toml_str(&text, "test scene").unwrap_or_else(|e| panic!("{e}\n{text}"))
}

/// Pinion speed (rad/s) that puts the mesh frequency at `f_mesh` Hz.
pub fn pinion_speed_for_mesh_frequency(f_mesh: f64) -> f64 {
    std::f64::consts::TAU * f_mesh / TEETH
}

/// Largest |a_i − b_i|.
pub fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}
