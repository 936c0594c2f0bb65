//! The work-precision problems (numerics-notes §6, G1–G7) and the tolerance ladder, shared by
//! the benchmark (`benches/workprecision.rs`), the scipy and Rust-peer harnesses (through the
//! scene files and `problems.csv` the benchmark writes) and the tolerance-proportionality test
//! (`tests/tolerance_proportionality.rs`).
//!
//! Tolerance mapping, the same for every method of every harness: one number `tol` per ladder
//! rung, `rtol = tol` and `atol = tol · x_scale` (one absolute tolerance for all states, the
//! way geardyn's scene takes it), where `x_scale` is the problem's static deflection.

#![allow(dead_code)]

use geardyn::scene::train::TRAIN_EXAMPLES;
use geardyn::scene::PairScene;
use geardyn::scene::Scene;

/// What kind of scene a problem is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// Single mesh (`[mesh]`): every harness (geardyn, scipy, Rust peer) runs it.
    Pair,
    /// Drivetrain (`[[mesh]]`): geardyn only (the scipy and peer models are single-mesh).
    Train,
}

pub struct Problem {
    /// Short name (file names, table rows).
    pub name: &'static str,
    /// numerics-notes §6 label.
    pub id: &'static str,
    /// One line for the report.
    pub what: &'static str,
    pub kind: Kind,
    /// Scene text.
    pub toml: String,
    /// Simulated time, s.
    pub stop_time: f64,
}

/// Dense error grid: `SAMPLES + 1` equally spaced points on `[0, stop_time]` (SciML's `:L2`
/// uses 100; every output point is also a stop of geardyn's integrator, as in `advance_to`
/// from a co-simulation master).
pub const SAMPLES: usize = 200;

/// The full ladder `tol = 1e-3 … 1e-11` (rtol = tol, atol = tol · x_scale).
pub const LADDER: [f64; 9] = [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11];

/// Tolerance of the tight runs that make references (scipy DOP853 and Radau).
pub const REFERENCE_TOL: f64 = 1e-13;

/// `(rtol, atol)` of ladder rung `tol` for a problem with static deflection `x_scale`.
pub fn tolerance_pair(tol: f64, x_scale: f64) -> (f64, f64) {
    (tol, tol * x_scale)
}

/// The idler gearset of `fmu/idler_gearset` without tip relief (the reduced variant: its
/// segments are then LTI, so the exact propagator gives the reference).
fn idler_without_tip_relief() -> String {
    let (_, text) = TRAIN_EXAMPLES
        .iter()
        .find(|(n, _)| *n == "idler_gearset")
        .expect("idler_gearset is a built-in drivetrain example");
    let mut out = String::new();
    let mut skipping = false;
    for line in text.lines() {
        let trimmed = line.trim_start();
        if trimmed.starts_with('[') {
            skipping = trimmed.starts_with("[mesh.tip_relief]");
        }
        if !skipping {
            out.push_str(line);
            out.push('\n');
        }
    }
    out.replace("name = \"idler_gearset\"", "name = \"idler_no_relief\"")
}

/// Every problem, in report order.
pub fn problems() -> Vec<Problem> {
    vec![
        Problem {
            name: "backlash_rect",
            id: "G1",
            what: "spur_pair: rectangular stiffness, backlash 0.1 mm, STE 1 µm, 4500 rpm (separates every period)",
            kind: Kind::Pair,
            toml: include_str!("problems/backlash_rect.toml").to_string(),
            stop_time: 0.01,
        },
        Problem {
            name: "backlash_smooth",
            id: "G2",
            what: "G1 with a 3-harmonic Fourier stiffness (smooth; exact propagator not eligible)",
            kind: Kind::Pair,
            toml: include_str!("problems/backlash_smooth.toml").to_string(),
            stop_time: 0.01,
        },
        Problem {
            name: "idler_no_relief",
            id: "G3",
            what: "idler_gearset (2 meshes, 8 DOF, contact loss) without tip relief",
            kind: Kind::Train,
            toml: idler_without_tip_relief(),
            stop_time: 0.01,
        },
        Problem {
            name: "helical",
            id: "G4",
            what: "NASA-ART helical pair (He & Singh 2007 piecewise-linear K_e, μ = 0.2), 5 % damping, 6000 rpm, never loses contact",
            kind: Kind::Pair,
            toml: include_str!("problems/helical.toml").to_string(),
            stop_time: 0.01,
        },
        Problem {
            name: "rattle",
            id: "G6",
            what: "G1 at 20 N·m with 50 µm STE: separation and back-side impacts every period",
            kind: Kind::Pair,
            toml: include_str!("problems/rattle.toml").to_string(),
            stop_time: 0.01,
        },
        Problem {
            name: "stiff",
            id: "G7",
            what: "G1 with k̄ = 1e9 N/m and a tenth of the inertias (17.3 kHz mode)",
            kind: Kind::Pair,
            toml: include_str!("problems/stiff.toml").to_string(),
            stop_time: 0.01,
        },
    ]
}

impl Problem {
    /// The validated single-mesh scene (panics for a drivetrain problem).
    pub fn pair_scene(&self) -> PairScene {
        assert_eq!(
            self.kind,
            Kind::Pair,
            "{} is not a single-mesh problem",
            self.name
        );
        PairScene::from_toml_str(&self.toml, self.name).expect("problem scene is valid")
    }

    /// The validated drivetrain scene (panics for a single-mesh problem).
    pub fn train_scene(&self) -> Scene {
        assert_eq!(
            self.kind,
            Kind::Train,
            "{} is not a drivetrain problem",
            self.name
        );
        Scene::from_toml_str(&self.toml, self.name).expect("problem scene is valid")
    }

    /// The dense error grid `t_k = k · stop_time / SAMPLES`.
    pub fn sample_times(&self) -> Vec<f64> {
        (0..=SAMPLES)
            .map(|k| {
                if k == SAMPLES {
                    self.stop_time
                } else {
                    k as f64 * self.stop_time / SAMPLES as f64
                }
            })
            .collect()
    }
}
