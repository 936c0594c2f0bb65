//! Prints a benchmark chain's scene text (`ChainSpec::toml`, `src/scene/train/chain.rs`), so
//! that any chain of the benchmarks can be run, timed or profiled through the ordinary CLI
//! (`geardyn simulate`, `sweep`, …) like any other scene. `examples/chain_16.toml` is
//! `chain_scene 16 compliant linear`.
//!
//! ```text
//! cargo run --release --example chain_scene -- MESHES rigid|compliant linear|loss|holds [free] > chain.toml
//! ```
//!
//! `free` gives the free chain of issue 37 (`ChainSpec::free`); without it the grounded chain
//! of issue 20 (`ChainSpec::new`), which has no `holds` variant.

use geardyn::scene::train::{ChainBearings, ChainContact, ChainSpec};

fn main() {
    let usage = "usage: chain_scene MESHES rigid|compliant linear|loss|holds [free]";
    let args: Vec<String> = std::env::args().skip(1).collect();
    let fail = |what: String| -> ! {
        eprintln!("{what}\n{usage}");
        std::process::exit(2)
    };
    if !(3..=4).contains(&args.len()) {
        fail(format!("{} arguments given, 3 or 4 expected", args.len()));
    }
    let meshes: usize = args[0]
        .parse()
        .unwrap_or_else(|_| fail(format!("MESHES = {:?}: not a mesh count", args[0])));
    let bearings = match args[1].as_str() {
        "rigid" => ChainBearings::Rigid,
        "compliant" => ChainBearings::Compliant,
        other => fail(format!("bearings = {other:?}: rigid or compliant")),
    };
    let contact = match args[2].as_str() {
        "linear" => ChainContact::Linear,
        "loss" => ChainContact::ContactLoss,
        "holds" => ChainContact::ContactHolds,
        other => fail(format!("contact = {other:?}: linear, loss or holds")),
    };
    let spec = match args.get(3).map(String::as_str) {
        None => ChainSpec::new(meshes, bearings, contact),
        Some("free") => ChainSpec::free(meshes, bearings, contact),
        Some(other) => fail(format!("layout = {other:?}: `free` or nothing (grounded)")),
    };
    match spec.toml() {
        Ok(text) => print!("{text}"),
        Err(e) => fail(e.to_string()),
    }
}
