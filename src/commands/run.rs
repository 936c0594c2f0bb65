//! `geardyn run`: a system of FMUs (`host::system`) or a single FMU (`host::cli`), each run
//! supervised from a parent process. The dispatch lives here, above both, so that the
//! single-FMU runner and the system runner (which shares its options and output helpers) do
//! not import each other.

use std::process::ExitCode;

use crate::host::cli::{report, supervised_run, RunArgs};
use crate::host::system;

/// `geardyn run`, with its exit status (see `RunArgs`' help).
pub fn run(args: RunArgs) -> ExitCode {
    ExitCode::from(match status(&args) {
        Ok(code) => code,
        Err(message) => report(Err(message)),
    })
}

/// Runs the FMU or system of `args`: `Ok` with the exit status the run reported (0, or 1 after
/// a failure it printed itself), `Err` with the message of a failure before or around the run.
/// The Python module's `geardyn.run` calls this, so both run the same code.
pub fn status(args: &RunArgs) -> Result<u8, String> {
    if system::is_system(&args.fmu) {
        system::run(args)
    } else {
        supervised_run(args)
    }
}
