//! The gear models as FMI 2.0 Co-Simulation models.
//!
//! The generic FMI layer [`crate::fmi`] knows no gear physics: it owns the C ABI, the state
//! machine, the set rules and the FMU-state envelope, and talks to a model through the
//! [`crate::fmi::model::CoSimModel`] trait. This module adapts the gear models to that trait:
//!
//! - [`entry`]: the one factory (`fmi2Instantiate` and the packager) that turns a scene file
//!   into a model,
//! - [`pair`]: the single-mesh adapter, [`drivetrain`]: the drivetrain adapter,
//! - [`checks`]: parameter checks and variable-table helpers both share,
//! - [`payload`]: the encoding both FMU-state payload layouts share.

pub mod checks;
pub mod drivetrain;
pub mod entry;
pub mod pair;
pub mod payload;
