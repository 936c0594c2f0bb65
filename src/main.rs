//! The `geardyn` command line: a thin layer over the library; each subcommand lives in
//! `src/cli/`.

use std::io::Write as _;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod cli;

#[derive(Parser)]
#[command(
    name = "geardyn",
    version,
    about = "Gear-mesh dynamics: DTE, mesh force and contact loss"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Also print which kernel runs the scene (single pair or drivetrain) and why.
    #[arg(long, global = true)]
    verbose: bool,
}

#[derive(Subcommand)]
enum Command {
    /// Simulate a scene (single mesh or drivetrain) and write its outputs to CSV.
    Simulate(cli::simulate::SimulateArgs),
    /// Exact spectrum of the periodic steady state, lines named in mesh and shaft orders.
    Spectrum(cli::spectrum::SpectrumArgs),
    /// Natural frequencies and mode shapes of a drivetrain's mean system, and its statics.
    Modes(cli::modes::ModesArgs),
    /// Periodic steady state by shooting, with Floquet multipliers and stability.
    Periodic(cli::analysis::PeriodicArgs),
    /// Frequency-response sweep over pinion speed (warm start, up/down branches).
    Sweep(cli::analysis::SweepArgs),
    /// Harmonic balance with arclength continuation and stability (FRF branch).
    Hb(cli::analysis::HbArgs),
    /// Closed-form monodromy of a linear scene with piecewise-linear stiffness (docs/helical.md).
    Floquet(cli::floquet::FloquetArgs),
    /// Parametric instability bands over the input speed, from the closed-form monodromy.
    Band(cli::floquet::BandArgs),
    /// Mesh stiffness over one mesh period from gear geometry (docs/stiffness.md).
    Stiffness(cli::stiffness::StiffnessArgs),
    /// Order map (waterfall) of a run-up scene: short-time spectra over speed (docs/runup.md).
    Waterfall(cli::runup::WaterfallArgs),
    /// FMI 2.0 Co-Simulation FMUs: build, print or check model descriptions.
    Fmu(cli::fmu::FmuArgs),
    /// Run any FMI 2.0 Co-Simulation FMU (the host runner, like `fmpy simulate`).
    Run(geardyn::host::cli::RunArgs),
    /// Show an FMU's model description: capabilities and variables.
    Info(cli::fmu::FmuArg),
    /// Check an FMU (modelDescription.xml and its linux64 binary); exit 1 on problems.
    Validate(cli::fmu::FmuArg),
}

fn main() -> ExitCode {
    // A closed pipe (`geardyn … | head`) ends the run quietly: `println!` panics on it, and
    // that panic is neither printed nor reported as a crash (`geardyn::pipe`).
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        if !geardyn::pipe::is_broken_pipe_panic(info.payload()) {
            default_hook(info)
        }
    }));
    #[cfg(geardyn_embedded_cdylib)]
    geardyn::fmi::package::embed_cdylib(include_bytes!(env!("GEARDYN_EMBEDDED_CDYLIB")));
    let cli = Cli::parse();
    cli::set_verbose(cli.verbose);
    let result = match std::panic::catch_unwind(|| dispatch(cli)) {
        Ok(Ok(code)) => return code,
        Ok(Err(message)) => message,
        Err(payload) if geardyn::pipe::is_broken_pipe_panic(payload.as_ref()) => {
            return ExitCode::from(geardyn::pipe::BROKEN_PIPE_STATUS)
        }
        Err(payload) => std::panic::resume_unwind(payload),
    };
    if geardyn::pipe::is_broken_pipe(&result) {
        return ExitCode::from(geardyn::pipe::BROKEN_PIPE_STATUS);
    }
    // Not `eprintln!`: stderr may be the closed pipe.
    let _ = writeln!(std::io::stderr(), "error: {result}");
    ExitCode::FAILURE
}

/// Runs the subcommand: its exit status, or the message of its failure.
fn dispatch(cli: Cli) -> Result<ExitCode, String> {
    match cli.command {
        Command::Simulate(args) => cli::simulate::run(args),
        Command::Spectrum(args) => cli::spectrum::run(args),
        Command::Modes(args) => cli::modes::run(args),
        Command::Periodic(args) => cli::analysis::periodic(args),
        Command::Floquet(args) => cli::floquet::floquet(args),
        Command::Band(args) => cli::floquet::band(args),
        Command::Sweep(args) => cli::analysis::sweep(args),
        Command::Hb(args) => cli::analysis::hb(args),
        Command::Stiffness(args) => cli::stiffness::run(args),
        Command::Waterfall(args) => cli::runup::run(args),
        Command::Fmu(args) => cli::fmu::run(args),
        // Prints its own errors: its exit status also tells how the FMU's process ended.
        Command::Run(args) => return Ok(geardyn::commands::run::run(args)),
        Command::Info(args) => cli::fmu::info(args),
        Command::Validate(args) => cli::fmu::validate(args),
    }
    .map(|()| ExitCode::SUCCESS)
}
