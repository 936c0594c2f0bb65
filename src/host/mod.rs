//! FMI 2.0 Co-Simulation importer and runner (issue 4).
//!
//! Data flow: [`archive`] unpacks the FMU into a temporary folder → [`description`] parses
//! `modelDescription.xml` → [`check`] reports validator problems → [`library`] loads
//! `binaries/linux64/<modelIdentifier>.so` and resolves the 34 FMI 2.0 CS functions →
//! [`instance`] wraps one FMU instance (with the [`logger`] C shim for the variadic logger) →
//! [`runner`] drives the co-simulation loop with [`start`] values and [`input`] signals →
//! [`csv`] writes the result. [`cli`] holds the `run`/`info`/`validate` commands, [`info`]
//! renders `geardyn info`. [`supervise`] runs the FMU of `geardyn run` in a child process,
//! with [`shared`] memory for what must survive its crash. [`system`] runs SSP systems of
//! several FMUs (`geardyn run system.ssp`).

pub mod archive;
pub mod check;
pub mod cli;
pub mod csv;
pub mod description;
pub mod info;
pub mod input;
pub mod instance;
pub mod library;
pub mod logger;
pub mod runner;
pub mod shared;
pub mod start;
pub mod supervise;
pub mod system;
