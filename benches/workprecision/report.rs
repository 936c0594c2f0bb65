//! The parts of `docs/benchmarks.md` that do not depend on the run's numbers (head, methods,
//! observations, footer), the plots, and number formatting.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use geardyn::plot::{Axis, Plot, Series};

use crate::problems::{Problem, LADDER, SAMPLES};
use crate::rows::Row;

pub const COLORS: [(&str, &str); 11] = [
    ("geardyn DP5", "#1f77b4"),
    ("geardyn DOP853", "#d62728"),
    ("geardyn exact", "#000000"),
    ("scipy DOP853", "#ff7f0e"),
    ("scipy RK45", "#bcbd22"),
    ("scipy Radau", "#8c564b"),
    ("differential-equations DOPRI5", "#17becf"),
    ("differential-equations DOP853", "#2ca02c"),
    ("geardyn reference DOP853", "#7f7f7f"),
    ("differential-equations DOPRI5 (crate events)", "#9edae5"),
    ("differential-equations DOP853 (crate events)", "#98df8a"),
];

pub fn color(method: &str) -> &'static str {
    COLORS
        .iter()
        .find(|(m, _)| *m == method)
        .map_or("#9467bd", |(_, c)| c)
}

pub fn plot(problem: &Problem, rows: &[&Row], methods: &[String], rhs: bool, path: &Path) {
    let title = format!(
        "{} ({}): DTE error vs {}",
        problem.name,
        problem.id,
        if rhs { "RHS evaluations" } else { "wall time" }
    );
    // Legend labels: the peer's crate name shortened so the legend fits the plot.
    let labels: Vec<String> = methods
        .iter()
        .map(|m| {
            m.replace("differential-equations", "d-e")
                .replace("(crate events)", "crate ev.")
        })
        .collect();
    let series: Vec<Series> = methods
        .iter()
        .zip(&labels)
        .filter_map(|(m, label)| {
            let mut points: Vec<(f64, f64, f64)> = rows
                .iter()
                .filter(|r| &r.method == m && r.ok())
                .filter_map(|r| {
                    let e = r.errors?.dte_l2;
                    let w = if rhs { r.rhs? as f64 } else { r.wall? };
                    (e > 0.0 && w > 0.0).then(|| (r.tol, e.log10(), w.log10()))
                })
                .collect();
            points.sort_by(|a, b| b.0.partial_cmp(&a.0).unwrap());
            (!points.is_empty()).then(|| Series {
                label: label.as_str(),
                color: color(m),
                points: points.iter().map(|p| (p.1, p.2)).collect(),
                dashed: !m.starts_with("geardyn"),
                markers: true,
                line: true,
            })
        })
        .collect();
    Plot {
        title: &title,
        x: Axis::new(
            "log10 DTE error (RMS on 201 points / static deflection)",
            "",
        ),
        y: Axis::new(
            if rhs {
                "log10 RHS evaluations"
            } else {
                "log10 wall time [s]"
            },
            "",
        ),
        series,
        bands: Vec::new(),
        band_label: "",
        markers: Vec::new(),
    }
    .save(path)
    .expect("write plot");
}

pub fn command_output(cmd: &str, args: &[&str]) -> String {
    std::process::Command::new(cmd)
        .args(args)
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_else(|| "n/a".into())
}

pub fn footer() -> String {
    let commit = command_output("git", &["rev-parse", "--short", "HEAD"]);
    // The run's own outputs (the plots, written before this footer) do not count as changes.
    let dirty = !command_output(
        "git",
        &[
            "status",
            "--porcelain",
            "--untracked-files=no",
            "--",
            ".",
            ":!docs/benchmarks.md",
            ":!docs/benchmarks",
        ],
    )
    .is_empty();
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|s| s.trim().to_string())
        })
        .unwrap_or_else(|| "n/a".into());
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    let load = std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "n/a".into());
    format!(
        "commit {commit}{}, {}, {}, CPU {cpu} ({cores} logical cores), load average at the end {load}, \
         generated {}",
        if dirty { " (with uncommitted changes)" } else { "" },
        command_output("rustc", &["--version"]),
        command_output(".venv/bin/python", &["-c", "import scipy, sys; print(f'scipy {scipy.__version__}, Python {sys.version.split()[0]}')"]),
        command_output("date", &["-u", "+%Y-%m-%d %H:%M UTC"]),
    )
}

pub fn fmt_e(v: Option<f64>) -> String {
    v.map_or("–".into(), |v| format!("{v:.1e}"))
}

pub fn fmt_u(v: Option<u64>) -> String {
    v.map_or("–".into(), |v| v.to_string())
}

/// What the harness showed about the methods beyond the numbers (checked while building it;
/// the evidence is in the tables above and in `benches/peer/src/main.rs`).
pub const OBSERVATIONS: &str = "\n## Observations\n\n\
- **The peer crate's own event location is unreliable** (rows \"(crate events)\"). Its Brent–Dekker \
iteration (`differential-equations` 0.7.0, `src/solout/event.rs`) makes the previous iterate the \
contrapoint after every step, so the bracket is lost once two iterates fall on the same side of \
the root, and it returns points that are no roots (guard values of 1e-10…1e-6 m): contact times \
off by up to ~6e-5 s at every tolerance, DTE errors of order 0.1–1. The peer's main rows keep the \
crate's integrators, dense output and per-step sign test, and locate the root with a bracketing \
Illinois iteration on the crate's interpolant (`RefinedEventSolout` in `benches/peer`), as a user \
would after finding this.\n\
- **The peer's DOP853 dense output is much less accurate than its steps**: on the linear-contact \
variant of G1 at tol 1e-10 its grid values are 1.2e-6 x_st off where DOPRI5's are 1e-8 off. In \
`src/methods/erk/dormandprince/ordinary.rs` (`interpolate`) the factors `s` and `1 − s` of the \
higher-order terms appear swapped relative to Hairer's `contd8`. Grid values and event times of \
the peer's DOP853 inherit this, so its curves level off near 1e-6…1e-7.\n\
- **geardyn DOP853 at loose tolerances is stop-bound**: its natural step exceeds the spacing of \
the stops (two stiffness switches per mesh period, the contact events and the 200 grid points), \
so every step ends on a stop and the loosest rungs give the same steps and error \
(`tests/tolerance_proportionality.rs` checks exactly this case).\n\
- **References**: where the stiffness is piecewise constant (G1, G6, G7) the reference is the \
closed-form solution in 30-digit arithmetic (`scripts/workprecision_mpmath.py`, from docs/model.md; \
unchanged to the last binary64 digit at 40 digits), checked against the exact propagator. scipy's \
DOP853 at rtol 1e-13 is a few 1e-12 x_st from it on G1, the exact propagator a few 1e-14. On `rattle` \
(50 µm motion, 112 impacts) the exact propagator is ~1e-10 x_st and scipy's DOP853 ~2e-9 x_st from it: \
the impacts amplify every perturbation, so errors below ~1e-9 x_st are not resolved for the RK \
methods there.\n";

pub fn pass(ok: Option<bool>) -> &'static str {
    match ok {
        Some(true) => "met",
        Some(false) => "**not met**",
        None => "**not measured**",
    }
}

pub fn write_doc_head(
    md: &mut String,
    quick: bool,
    problems: &[Problem],
    scales: &BTreeMap<&str, f64>,
    eligibility: &BTreeMap<&str, bool>,
) {
    let _ = writeln!(
        md,
        "# Work-precision benchmarks\n\n\
         Generated by `scripts/bench-workprecision.sh{}` (do not edit by hand: the next run overwrites \
         it). geardyn's propagators, scipy's `solve_ivp` and the Rust crate `differential-equations` \
         0.7.0 on the same gear problems and the same tolerance ladder, all measured in one run on one \
         machine (footer). Method after SciMLBenchmarks / DiffEqDevTools and Hairer–Wanner \
         (`shared/reference/numerics-notes.md` §1).\n",
        if quick { " --quick" } else { "" }
    );
    md.push_str("## Problems\n\n| id | problem | what | simulated | x_st (static deflection) | exact propagator |\n|---|---|---|---|---|---|\n");
    for p in problems {
        let _ = writeln!(
            md,
            "| {} | `{}` | {} | {} s | {:.3} µm | {} |",
            p.id,
            p.name,
            p.what,
            p.stop_time,
            scales[p.name] * 1e6,
            if eligibility[p.name] {
                "eligible"
            } else {
                "not eligible"
            }
        );
    }
    let _ = writeln!(
        md,
        "\nScene files: `benches/workprecision/problems/*.toml` (G3 is `fmu/idler_gearset` with its tip \
         relief removed, so its segments are LTI). G4 is the helical pair of `fmu/helical_pair_friction` \
         (`helical` stiffness source, docs/helical.md) with damping and STE added; the scipy and peer \
         models have no helical source, so `--write-problems` hands them its resolved piecewise-linear \
         stiffness as the equivalent `table` (only the stiffness data is shared; each harness's \
         dynamics, segment stops and event location stay its own).\n\n\
         ## Methods\n\n\
         - **geardyn DP5, DOP853** (`src/solve/rk`): the library path of `geardyn simulate` and the FMUs \
         (`Simulation::advance_to` at every grid point, stiffness switches as stops, contact changes \
         located on the interpolant, guards also sampled at 4 interior points per step).\n\
         - **geardyn exact** (`src/solve/exact.rs`): piecewise-LTI propagation, no tolerance (one point), \
         where every segment is LTI.\n\
         - **scipy DOP853, RK45, Radau** (`solve_ivp`, scipy's own tolerances): the independent model of \
         `tests/python/gear_reference.py`, as a careful user writes it: one `solve_ivp` call per \
         stiffness segment and contact state, terminal events on the contact guards, the state snapped \
         onto the surface, restart; the grid from the dense output (`scripts/workprecision_scipy.py`).\n\
         - **differential-equations DOPRI5, DOP853** (crates.io `differential-equations` = 0.7.0, \
         pinned): the same model written from `docs/model.md` in `benches/peer` (a separate cargo \
         project, not part of geardyn's build), with the crate's terminal events (Brent root finding \
         on its dense output), one solve per segment and contact state, the grid from a solout.\n\n\
         **Tolerance mapping** (every method): `rtol = tol`, `atol = tol · x_st` for both states, \
         ladder tol = {}.\n\n\
         **Errors** against the problem's reference on {} equally spaced points of `[0, T]`, normalised \
         by the static deflection x_st: the **DTE error** is the RMS of |x − x_ref| / x_st over the grid \
         (and, for G3, both meshes); also the largest, the final-point and the DTE-RMS error, the \
         event-time error and the contact-change count mismatch.\n\n\
         **Work**: wall time = median of ≥ {} timed runs (≥ {} s in all) after a warm-up run (geardyn and \
         the peer; scipy: ≥ 2 runs, ≥ 1 s, or one run when it takes > 2 s); the three harnesses run one \
         after the other in separate processes, so ratios across them are not side by side; RHS \
         evaluations; accepted and \
         rejected steps; contact events. Failures are listed, never dropped.",
        LADDER.iter().map(|t| format!("{t:.0e}")).collect::<Vec<_>>().join(", "),
        SAMPLES + 1,
        if quick { 2 } else { 5 },
        if quick { 0.02 } else { 0.25 },
    );
}
