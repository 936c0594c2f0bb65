//! geardyn: gear-mesh drivetrain dynamics with an event-exact native integrator, delivered as
//! FMI 2.0 Co-Simulation FMUs.
//!
//! Data flow (see `DESIGN.md`): [`scene`] (TOML) → [`model`] (one specialised system) →
//! [`solve`] (RK with events | exact piecewise-LTI propagator) → outputs.

// `!(x > 0.0)` is how this crate rejects NaN together with out-of-range values; the
// lint's `partial_cmp` rewrite would hide that intent.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod analysis;
pub mod commands;
pub mod fmi;
pub mod fmu;
pub mod host;
pub mod mesh;
pub mod model;
pub mod output;
pub mod pipe;
pub mod plot;
pub mod scene;
pub mod simulation;
pub mod solve;
pub mod units;
