//! `geardyn run`: a system of FMUs (`host::system`) or a single FMU (`host::cli`), each run
//! supervised from a parent process. The dispatch lives here, above both, so that the
//! single-FMU runner and the system runner (which shares its options and output helpers) do
//! not import each other.

use std::process::ExitCode;

use crate::host::cli::{report, supervised_run, RunArgs};
use crate::host::system;

/// `geardyn run`, with its exit status (see `RunArgs`' help).
pub fn run(args: RunArgs) -> ExitCode {
    if system::is_system(&args.fmu) {
        return ExitCode::from(match system::run(&args) {
            Ok(code) => code,
            Err(message) => report(Err(message)),
        });
    }
    ExitCode::from(match supervised_run(&args) {
        Ok(code) => code,
        Err(message) => report(Err(message)),
    })
}
