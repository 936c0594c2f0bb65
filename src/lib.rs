//! geardyn: gear-mesh drivetrain dynamics with an event-exact native integrator, delivered as
//! FMI 2.0 Co-Simulation FMUs.
//!
//! Data flow (see `DESIGN.md`): [`scene`] (TOML) → [`model`] (one specialised system) →
//! [`solve`] (RK with events | exact piecewise-LTI propagator) → outputs.

pub mod host;
pub mod solve;
