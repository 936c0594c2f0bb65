//! The operations behind the `geardyn` subcommands, shared by the CLI (`src/cli/`) and the
//! Python module (`python/`): option checks with the CLI's messages, the analyses, and their
//! tables, plots and text reports. Keeping them here (not in the binary crate) is what makes
//! a Python call and a CLI run of the same scene give identical numbers and messages; the CLI
//! (`src/cli/`) only parses arguments and hands them to the function of its command here.

pub mod campbell;
pub mod floquet;
pub mod fmu;
pub mod hb;
pub mod inspect;
pub mod modes;
pub mod run;
pub mod runup;
pub mod simulate;
pub mod simulate_run;
pub mod spectrum;
pub mod steady;
pub mod stiffness;
pub mod time_plot;

/// A finite, positive command-line number; `name` is the option without its dashes.
pub fn positive(name: &str, v: f64) -> Result<f64, String> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(format!("--{name} {v}: must be a finite number > 0"))
    }
}
