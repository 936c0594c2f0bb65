//! The gear models as FMI 2.0 Co-Simulation models: one adapter, two kernels.
//!
//! The generic FMI layer [`crate::fmi`] knows no gear physics: it owns the C ABI, the state
//! machine, the set rules and the FMU-state envelope, and talks to a model through the
//! [`crate::fmi::model::CoSimModel`] trait. This module adapts the gear models to that trait,
//! the way the model layer drives both with one [`crate::simulation::Driver`]: one generic
//! [`Adapter`] does what is the same for every model (life cycle, rebuilds on parameter
//! changes, output cache, steps, reset, FMU state and its checks), and a small
//! [`Kernel`] per model says what differs (scene format, variable table, value references
//! onto the scene, inputs and outputs, payload layout).
//!
//! - [`entry`]: the one factory (`fmi2Instantiate` and the packager) that turns a scene file
//!   into a model, choosing the kernel by the scene's format,
//! - [`adapter`]: the adapter, [`kernel`]: what a kernel provides,
//! - [`pair`]: the single-mesh kernel, [`drivetrain`]: the drivetrain kernel (each with its
//!   variable table, documentation and payload layout),
//! - [`element`]: the drivetrain elements (inertia, shaft, motor, load), each its own
//!   co-simulation model with input interpolation and output derivatives,
//! - [`table`]: rows of a variable table, [`checks`]: checks of set and restored values,
//! - [`payload`]: the model part of an FMU state and the encoding both layouts share.

pub mod adapter;
pub mod checks;
pub mod drivetrain;
pub mod element;
pub mod entry;
pub mod kernel;
pub mod pair;
pub mod payload;
pub mod table;

pub use adapter::Adapter;
pub use kernel::Kernel;
