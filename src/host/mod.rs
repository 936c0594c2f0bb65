//! FMI 2.0 Co-Simulation importer and runner (issue 4).
//!
//! Data flow: [`archive`] unpacks the FMU into a temporary folder → [`description`] parses
//! `modelDescription.xml` → [`check`] reports validator problems → [`library`] loads
//! `binaries/linux64/<modelIdentifier>.so` and resolves the 34 FMI 2.0 CS functions →
//! [`runner`] drives the co-simulation loop (with the [`logger`] C shim for the variadic
//! logger) → [`csv`] writes the result. [`cli`] holds the `run`/`info`/`validate` commands.

pub mod csv;
pub mod description;
pub mod check;
pub mod archive;
pub mod library;
pub mod logger;
