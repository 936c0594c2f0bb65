//! The Meissner equation `m x'' + c x' + k(p) x = 0` with rectangular stiffness (docs/model.md):
//! the scene and its closed-form monodromy, the product of the two segments' transition
//! matrices (shared by `tests/floquet.rs` and the stress suite's parametric-instability check).

use std::f64::consts::TAU;

use super::{pinion_speed_for_mesh_frequency, scene, M_E};
use geardyn::scene::PairScene;
use nalgebra::Matrix2;

pub const K_MEAN: f64 = 2.0e8;
pub const EPS: f64 = 0.35;
pub const CONTACT_RATIO: f64 = 1.5;

pub fn f_n() -> f64 {
    (K_MEAN / M_E).sqrt() / TAU
}

pub fn meissner(f_mesh: f64, zeta: f64) -> PairScene {
    scene(
        &format!(
            "contact = \"linear\"\ndamping_ratio = {zeta}\n\
             [mesh.stiffness]\nkind = \"rectangular\"\nmean = {K_MEAN:e}\n\
             peak_to_peak_ratio = {EPS}\ncontact_ratio = {CONTACT_RATIO}"
        ),
        &format!(
            "pinion_speed = {}\ninput_torque = 0.0",
            pinion_speed_for_mesh_frequency(f_mesh)
        ),
        "[initial]\ndte = 1e-6\n[solver]\nmethod = \"rk\"\nrk_method = \"dop853\"\n\
         rtol = 1e-10\natol = 1e-22",
    )
}

/// Transition matrix of `m x'' + c x' + k x = 0` over `tau` (underdamped closed form).
pub fn segment(k: f64, c: f64, tau: f64) -> Matrix2<f64> {
    let sigma = c / (2.0 * M_E);
    let w0sq = k / M_E;
    let wd = (w0sq - sigma * sigma).sqrt();
    let (s, co) = (wd * tau).sin_cos();
    let e = (-sigma * tau).exp();
    Matrix2::new(
        co + sigma / wd * s,
        s / wd,
        -w0sq / wd * s,
        co - sigma / wd * s,
    ) * e
}

/// Closed-form monodromy: low stiffness on [0, 1 − f) of the period, then high (docs/model.md).
pub fn closed_form_monodromy(f_mesh: f64, zeta: f64) -> Matrix2<f64> {
    let f = CONTACT_RATIO - CONTACT_RATIO.floor();
    let k_low = K_MEAN * (1.0 - f * EPS);
    let k_high = k_low + EPS * K_MEAN;
    let c = 2.0 * zeta * (K_MEAN * M_E).sqrt();
    let period = 1.0 / f_mesh;
    segment(k_high, c, f * period) * segment(k_low, c, (1.0 - f) * period)
}
