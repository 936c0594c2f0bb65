//! Which side carries a disagreement on the free compliant chains of issue 37
//! (`ChainSpec::free`, `docs/chains.md`, "Free chains"): one method's DTE and deflection of
//! every mesh at every mesh-period end, and its contact events, written to a file; and the
//! per-period distance of two such files (or of one and the long-double period map of
//! `scripts/free_chain_long_double.py`).
//!
//! ```text
//! cargo run --release --example free_chain_rows -- MESHES PERIODS METHOD RTOL OUT [linear]
//! cargo run --release --example free_chain_rows -- --compare A B
//! ```
//!
//! `METHOD` is `exact` or an RK method (`dp5`, `dop853`, `rodas4`), `atol` 1e-15 as in
//! `tests/chains.rs`; the chain has its 15 µm STE and the contact-loss law, or the linear law
//! without STE with `linear`. `--compare` prints, per period, `max |Δ|/δ` over both columns of
//! every mesh, and whether the contact events up to that period end are the same (count,
//! mesh and slot in order) with the largest difference of their times in periods.

use geardyn::model::train::TrainSimulation;
use geardyn::scene::train::{ChainBearings, ChainContact, ChainSpec};
use geardyn::scene::Scene;
use std::io::Write;

const PERIOD: f64 = 1.0 / 2000.0;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("--compare") {
        compare(&args[1], &args[2]);
        return;
    }
    let usage = "MESHES PERIODS METHOD RTOL OUT [linear] | --compare A B";
    let [meshes, periods, method, rtol, out] = [0, 1, 2, 3, 4].map(|i| args.get(i).expect(usage));
    let meshes: usize = meshes.parse().expect(usage);
    let periods: usize = periods.parse().expect(usage);
    let rtol: f64 = rtol.parse().expect(usage);
    let contact = match args.get(5).map(String::as_str) {
        Some("linear") => ChainContact::Linear,
        _ => ChainContact::ContactLoss,
    };
    let mut s = Scene::chain(ChainSpec::free(meshes, ChainBearings::Compliant, contact))
        .expect("a free chain");
    s.solver
        .set_propagator(method)
        .expect("exact, dp5, dop853 or rodas4");
    s.solver.rtol = rtol;
    s.solver.atol = 1e-15;
    let delta = s.operating.input_torque / s.gears[0].base_radius / s.meshes[0].mean_stiffness();
    let mut sim = TrainSimulation::new(&s).expect("the chain assembles");
    sim.model_mut().record_events();
    let columns: Vec<usize> = (0..s.meshes.len())
        .flat_map(|n| ["dte", "deflection"].map(|c| format!("{}.{c}", s.meshes[n].name)))
        .map(|name| sim.output_names().iter().position(|c| *c == name).unwrap())
        .collect();
    let mut f = std::fs::File::create(out).expect("OUT can be written");
    writeln!(
        f,
        "# delta {delta:e} {method} rtol {rtol:e}, {}",
        sim.method_choice()
    )
    .unwrap();
    let mut row = Vec::new();
    let started = std::time::Instant::now();
    for k in 1..=periods {
        sim.advance_to(k as f64 * PERIOD)
            .expect("the run completes");
        sim.outputs(&mut row);
        let values: Vec<String> = columns.iter().map(|&i| format!("{:e}", row[i])).collect();
        writeln!(f, "P {k} {}", values.join(" ")).unwrap();
        eprintln!("{method} {rtol:e}: period {k} at {:?}", started.elapsed());
    }
    for &(t, mesh, slot, _) in sim.model().events() {
        writeln!(f, "E {t:e} {mesh} {slot}").unwrap();
    }
}

type Rows = (f64, Vec<Vec<f64>>, Vec<(f64, usize, usize)>);

/// `δ`, the period rows (1, 2, …) and the events of a file written by this program.
fn load(path: &str) -> Rows {
    let text = std::fs::read_to_string(path).expect("a rows file");
    let (mut delta, mut rows, mut events) = (f64::NAN, Vec::new(), Vec::new());
    for line in text.lines() {
        let f: Vec<&str> = line.split_whitespace().collect();
        match f.first() {
            Some(&"#") => delta = f[2].parse().unwrap(),
            Some(&"P") => rows.push(f[2..].iter().map(|x| x.parse().unwrap()).collect()),
            Some(&"E") => events.push((
                f[1].parse().unwrap(),
                f[2].parse().unwrap(),
                f[3].parse().unwrap(),
            )),
            _ => {}
        }
    }
    (delta, rows, events)
}

fn compare(a: &str, b: &str) {
    let (delta, ra, ea) = load(a);
    let (_, rb, eb) = load(b);
    for (k, (x, y)) in ra.iter().zip(&rb).enumerate() {
        let d = (x.iter().zip(y))
            .map(|(p, q)| (p - q).abs())
            .fold(0.0, f64::max);
        let end = (k + 1) as f64 * PERIOD;
        let upto = |e: &[(f64, usize, usize)]| e.iter().filter(|v| v.0 <= end).count();
        let (na, nb) = (upto(&ea[..]), upto(&eb[..]));
        let same = na == nb && (ea.iter().zip(&eb).take(na)).all(|(p, q)| (p.1, p.2) == (q.1, q.2));
        let times = (ea.iter().zip(&eb).take(na.min(nb)))
            .map(|(p, q)| (p.0 - q.0).abs() / PERIOD)
            .fold(0.0, f64::max);
        println!(
            "period {}: max |Δ|/δ = {:.2e}; events {na} / {nb}, same: {same}, times within {times:.1e} periods",
            k + 1,
            d / delta
        );
    }
}
