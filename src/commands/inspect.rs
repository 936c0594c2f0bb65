//! `geardyn info` and `geardyn validate`: an FMU's model description, and its checks.

use std::path::Path;

use crate::host::check::check;
use crate::host::cli::{open, supervised_load};
use crate::host::supervise::Supervisor;

/// `geardyn info`: prints the FMU's capabilities and variables.
pub fn info(fmu: &Path) -> Result<(), String> {
    let (_u, md) = open(fmu)?;
    print!("{}", crate::host::info::render(&md));
    Ok(())
}

/// `geardyn validate`: the modelDescription checks plus loading the linux64 binary with all
/// 34 functions. Returns an error (exit 1) when anything is wrong. The library is loaded in a
/// supervised child process, as `geardyn run` runs an FMU (issue 34): its initialisers may
/// crash, exit or block, and the parent then reports how, and removes the unpacked folder.
pub fn validate(fmu: &Path) -> Result<(), String> {
    // Before the temporary folder exists (see `crate::host::cli::supervised_run`).
    let supervisor = Supervisor::new()?;
    let (u, md) = open(fmu)?;
    let mut problems = u.zip_problems.clone();
    problems.extend(check(&md));
    if let Some(cs) = &md.co_simulation {
        if let Some(e) = supervised_load(&supervisor, u.root(), &cs.model_identifier)? {
            problems.push(e);
        }
    }
    if problems.is_empty() {
        println!("No problems found.");
        return Ok(());
    }
    for p in &problems {
        println!("- {p}");
    }
    Err(format!(
        "{}: {} problem{} found",
        fmu.display(),
        problems.len(),
        if problems.len() == 1 { "" } else { "s" }
    ))
}
