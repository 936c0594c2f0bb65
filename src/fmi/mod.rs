//! FMI 2.0 Co-Simulation export (FMI 2.0.x, modelica/fmi-standard v2.0.5).
//!
//! A generic layer that knows no gear physics and talks to a model through
//! [`model::CoSimModel`]:
//!
//! - [`model`]: the trait and the variable table (shared by the C ABI and the XML writer),
//! - [`state`]: the CS state machine and the set rules (§4.2.4, §2.2.7),
//! - [`logger`]: the host's variadic logger with log categories (§2.1.5),
//! - [`instance`]: the semantics of every call on one instance,
//! - [`abi`]: the 34 exported `extern "C"` functions (thin, panic-free),
//! - [`blob`]: FMU-state envelope (version, length, checksum, GUID) and hashes,
//!   [`bytes`]: the little-endian reader the envelope and the models' payloads share,
//! - [`description`]: `modelDescription.xml` writer (§2.2, §4.3),
//! - [`package`]: the `.fmu` ZIP writer (§2.3; `geardyn fmu` is `crate::commands::fmu`),
//! - [`uri`]: `file:` URI decoding, [`vr_index`]: value reference → variable lookup.
//!
//! The model is created by [`crate::fmu::entry`], the one factory used by both the binary and
//! the packager; the gear models' adapters are [`crate::fmu::pair`] (single mesh) and
//! [`crate::fmu::drivetrain`] (drivetrains).

pub mod abi;
pub mod attributes;
pub mod blob;
pub mod bytes;
pub mod description;
pub mod instance;
pub mod logger;
pub mod model;
pub mod package;
pub mod state;
pub mod uri;
pub mod vr_index;
