//! Work-precision benchmark (issue 9; numerics-notes §1.4 and §6): geardyn's propagators
//! against scipy's `solve_ivp` and the Rust peer crate `differential-equations`, on the gear
//! problems of `problems.rs`, along one tolerance ladder, all in one run of
//! `scripts/bench-workprecision.sh`, which calls this binary twice:
//!
//! 1. `-- --write-problems DIR`: the scene files and `DIR/problems.csv` (name, kind, simulated
//!    time, grid, error scale, ladder) for the other harnesses;
//! 2. (the scipy and peer harnesses write `DIR/scipy.csv` and `DIR/peer.csv`; the extended-
//!    precision reference `scripts/workprecision_mpmath.py` writes `DIR/mpmath.csv`)
//! 3. `-- --report DIR [--quick] [--doc FILE]`: runs geardyn's propagators, checks the
//!    references, computes every error, writes `FILE` (default `docs/benchmarks.md`), its SVG
//!    plots next to it (`docs/benchmarks/`) and `DIR/results.csv`.

mod geardyn_run;
mod metrics;
mod problems;
mod report;
mod rows;

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use geardyn::solve::rk::Method;

use geardyn_run::{exact_eligible, run, x_scale, Propagator, RunOutput};
use metrics::{errors, Errors};
use problems::{problems, tolerance_pair, Kind, Problem, LADDER, REFERENCE_TOL, SAMPLES};
use report::{fmt_e, fmt_u, footer, pass, plot, write_doc_head, OBSERVATIONS};
use rows::{find, read_rows, Row};

#[path = "../common/stats.rs"]
mod stats;
use stats::median;

/// References must agree to this (largest DTE difference over the grid / largest |DTE| of the
/// reference, numerics-notes §1.4 item 1) with the same contact-change count before they are
/// used.
const AGREEMENT: f64 = 1e-9;
/// The accuracy at which the acceptance ratios are read off each method's curve.
const TARGET_ERROR: f64 = 1e-8;
/// Method name of the extended-precision reference rows (`scripts/workprecision_mpmath.py`).
const MPMATH: &str = "mpmath reference";

/// Median time of the runs after the warm-up, at least `min_runs` runs and `min_wall` seconds
/// (a single run when it takes more than 1 s).
fn median_time(min_runs: u32, min_wall: f64, mut f: impl FnMut()) -> (f64, u64) {
    let (mut times, started) = (Vec::new(), Instant::now());
    while times.len() < min_runs as usize || started.elapsed().as_secs_f64() < min_wall {
        let t0 = Instant::now();
        f();
        times.push(t0.elapsed().as_secs_f64());
        if times[0] > 1.0 {
            break;
        }
    }
    (median(&mut times), times.len() as u64)
}

fn geardyn_row(
    problem: &Problem,
    prop: Propagator,
    tol: f64,
    scale: f64,
    timing: (u32, f64),
) -> Row {
    let (rtol, atol) = tolerance_pair(tol, scale);
    let mut row = Row {
        problem: problem.name.into(),
        method: prop.label().into(),
        tol,
        status: "ok".into(),
        wall: None,
        timed_runs: None,
        rhs: None,
        steps: None,
        rejected: None,
        events: None,
        dte: Vec::new(),
        event_times: Vec::new(),
        errors: None,
    };
    match run(problem, prop, rtol, atol) {
        Err(e) => row.status = format!("failed: {e}"),
        Ok(out) => {
            let (wall, runs) = median_time(timing.0, timing.1, || {
                std::hint::black_box(run(problem, prop, rtol, atol)).ok();
            });
            // Reference runs are not timed (no timed run, no wall time).
            row.wall = (runs > 0).then_some(wall);
            row.timed_runs = Some(runs);
            fill_stats(&mut row, &out);
        }
    }
    row
}

fn fill_stats(row: &mut Row, out: &RunOutput) {
    row.rhs = Some(out.stats.rhs_evals);
    row.steps = Some(out.stats.steps);
    row.rejected = Some(out.stats.rejected);
    row.events = Some(out.stats.events);
    row.dte = out.dte.clone();
    row.event_times = out.event_times.clone();
}

fn write_problems(dir: &Path) {
    std::fs::create_dir_all(dir.join("scenes")).expect("create scene directory");
    let mut csv = String::from("problem,kind,stop_time,samples,x_scale,exact_eligible,ladder\n");
    for p in problems() {
        std::fs::write(
            dir.join("scenes").join(format!("{}.toml", p.name)),
            harness_scene_text(&p),
        )
        .expect("write scene");
        let ladder: Vec<String> = LADDER.iter().map(|t| format!("{t:e}")).collect();
        let _ = writeln!(
            csv,
            "{},{},{},{},{:e},{},{}",
            p.name,
            if p.kind == Kind::Pair {
                "pair"
            } else {
                "train"
            },
            p.stop_time,
            SAMPLES,
            x_scale(&p),
            exact_eligible(&p),
            ladder.join(";")
        );
    }
    std::fs::write(dir.join("problems.csv"), csv).expect("write problems.csv");
}

/// The scene text given to the scipy and peer harnesses. Their models know the stiffness kinds
/// of docs/model.md up to `table`; a `helical` stiffness (He & Singh 2007, docs/helical.md) is
/// handed over as the `table` of its resolved piecewise-linear curve (knots and values, exact
/// binary64 numbers). Only this stiffness data is shared: the dynamics, segment cutting and
/// event location stay independent in each harness.
fn harness_scene_text(p: &Problem) -> String {
    if p.kind != Kind::Pair {
        return p.toml.clone();
    }
    let mut doc: toml::Table = p.toml.parse().expect("problem scene is TOML");
    let stiffness_kind = doc["mesh"]["stiffness"]["kind"].as_str().map(str::to_owned);
    if stiffness_kind.as_deref() != Some("helical") {
        return p.toml.clone();
    }
    let scene = p.pair_scene();
    let source = &scene.mesh.stiffness;
    let pieces = source
        .pieces()
        .expect("the helical source is piecewise linear");
    // A table is continuous; the helical curve must be too (its pieces meet at the knots).
    for (a, b) in pieces
        .iter()
        .zip(pieces.iter().skip(1).chain(pieces.first()))
    {
        let end = a.value(a.end);
        assert!(
            (end - b.k_start).abs() <= 1e-9 * end.abs(),
            "{}: the helical stiffness jumps at s = {} ({end} → {}): not a table",
            p.name,
            a.end,
            b.k_start
        );
    }
    let mut table = toml::Table::new();
    table.insert("kind".into(), "table".into());
    table.insert("phase".into(), source.phase().into());
    table.insert(
        "phase_points".into(),
        pieces.iter().map(|q| q.start).collect::<Vec<_>>().into(),
    );
    table.insert(
        "values".into(),
        pieces.iter().map(|q| q.k_start).collect::<Vec<_>>().into(),
    );
    doc["mesh"]
        .as_table_mut()
        .expect("[mesh] is a table")
        .insert("stiffness".into(), toml::Value::Table(table));
    format!(
        "# Work-precision problem {} for the scipy and peer harnesses, written by `cargo bench --bench \
         workprecision -- --write-problems`: benches/workprecision/problems/{}.toml with its helical \
         stiffness (mean {:.6e} N/m) resolved into the equivalent table.\n{}",
        p.id,
        p.name,
        source.mean(),
        toml::to_string(&doc).expect("scene serialises")
    )
}

/// The reference of one problem and how it was obtained.
struct Reference {
    primary: String,
    /// The primary's method name (its own row is measured against the secondary).
    primary_method: String,
    secondary: String,
    /// Largest DTE difference of the two / x_scale, the same over the reference's largest
    /// |DTE|, and the contact-change counts.
    difference: f64,
    relative: f64,
    events: (usize, usize),
    agreed: bool,
    dte: Vec<Vec<f64>>,
    event_times: Vec<f64>,
    /// The secondary's output (the primary's own row is measured against it).
    secondary_dte: Vec<Vec<f64>>,
    secondary_events: Vec<f64>,
}

fn reference(
    problem: &Problem,
    eligible: bool,
    rows: &[Row],
    scale: f64,
) -> Result<Reference, String> {
    let mpmath = find(rows, problem.name, MPMATH);
    let (primary, secondary): (Row, Row) = match (problem.kind, eligible) {
        // The extended-precision closed form is the reference of every method; the exact
        // propagator must agree with it (and is measured against it).
        (Kind::Pair, true) if mpmath.is_some() => (
            mpmath.expect("checked").clone(),
            find(rows, problem.name, Propagator::Exact.label())
                .ok_or("the exact propagator failed")?
                .clone(),
        ),
        (_, true) => {
            let exact = find(rows, problem.name, Propagator::Exact.label())
                .ok_or("the exact propagator failed")?
                .clone();
            let other = match problem.kind {
                Kind::Pair => find(rows, problem.name, "scipy reference DOP853"),
                Kind::Train => find(rows, problem.name, "geardyn reference DOP853"),
            }
            .ok_or("no tight DOP853 run")?
            .clone();
            (exact, other)
        }
        (Kind::Pair, false) => (
            find(rows, problem.name, "scipy reference DOP853")
                .ok_or("scipy DOP853 at 1e-13 failed")?
                .clone(),
            find(rows, problem.name, "scipy reference Radau")
                .ok_or("scipy Radau at 1e-13 failed")?
                .clone(),
        ),
        (Kind::Train, false) => {
            return Err("no second independent method for this drivetrain".into())
        }
    };
    let e = errors(
        &secondary.dte,
        &secondary.event_times,
        &primary.dte,
        &primary.event_times,
        scale,
    );
    let amplitude = primary
        .dte
        .iter()
        .flatten()
        .fold(0.0f64, |m, v| m.max(v.abs()));
    let relative = e.dte_max * scale / amplitude;
    Ok(Reference {
        primary_method: primary.method.clone(),
        primary: labelled(&primary),
        secondary: labelled(&secondary),
        difference: e.dte_max,
        relative,
        events: (primary.event_times.len(), secondary.event_times.len()),
        agreed: relative <= AGREEMENT && e.event_count_mismatch == 0,
        dte: primary.dte,
        event_times: primary.event_times,
        secondary_dte: secondary.dte,
        secondary_events: secondary.event_times,
    })
}

/// A reference's name with its tolerance (none for the tolerance-free methods).
fn labelled(row: &Row) -> String {
    if row.method == Propagator::Exact.label() || row.method == MPMATH {
        format!("{} (no tolerance)", row.method)
    } else {
        format!("{} (tol {:.0e})", row.method, row.tol)
    }
}

/// Least wall time (or RHS count) at which a method's curve reaches `target`: a rung at or
/// below the target, or the log-log interpolation between the two rungs that bracket it.
fn cost_at(rows: &[&Row], target: f64, work: impl Fn(&Row) -> Option<f64>) -> Option<f64> {
    let mut pts: Vec<(f64, f64, f64)> = rows
        .iter()
        .filter(|r| r.ok())
        .filter_map(|r| Some((r.tol, r.errors?.dte_l2, work(r)?)))
        .collect();
    pts.sort_by(|a, b| b.0.partial_cmp(&a.0).unwrap()); // loose → tight
    let mut best: Option<f64> = None;
    let mut consider = |w: f64| best = Some(best.map_or(w, |b: f64| b.min(w)));
    for p in &pts {
        if p.1 <= target {
            consider(p.2);
        }
    }
    for w in pts.windows(2) {
        let ((_, e0, w0), (_, e1, w1)) = (w[0], w[1]);
        if (e0 - target) * (e1 - target) < 0.0 && e0 > 0.0 && e1 > 0.0 {
            let f = (target.log10() - e0.log10()) / (e1.log10() - e0.log10());
            consider(10f64.powf(w0.log10() + f * (w1.log10() - w0.log10())));
        }
    }
    best
}

fn main() {
    let mut args = std::env::args().skip(1);
    let (mut quick, mut write_dir, mut report_dir) = (false, None::<PathBuf>, None::<PathBuf>);
    let mut doc = PathBuf::from("docs/benchmarks.md");
    while let Some(a) = args.next() {
        match a.as_str() {
            "--bench" => {}
            "--quick" => quick = true,
            "--write-problems" => write_dir = Some(args.next().expect("--write-problems DIR").into()),
            "--report" => report_dir = Some(args.next().expect("--report DIR").into()),
            "--doc" => doc = args.next().expect("--doc FILE").into(),
            other => panic!("unknown argument {other:?} (--write-problems DIR | --report DIR [--quick] [--doc FILE])"),
        }
    }
    if let Some(dir) = write_dir {
        write_problems(&dir);
        println!("wrote {}/problems.csv and scenes/", dir.display());
        return;
    }
    let dir = report_dir.expect("--write-problems DIR or --report DIR");
    let started = Instant::now();
    let timing = if quick { (2, 0.02) } else { (5, 0.25) };

    let mut rows: Vec<Row> = Vec::new();
    let mut notes: Vec<String> = Vec::new();
    for (file, who) in [
        ("scipy.csv", "scipy"),
        ("peer.csv", "differential-equations"),
        ("mpmath.csv", "mpmath reference"),
    ] {
        match read_rows(&dir.join(file)) {
            Ok(r) => rows.extend(r),
            Err(e) => notes.push(format!(
                "{who} results missing ({e}): its columns are empty"
            )),
        }
    }

    let problems = problems();
    let mut scales = BTreeMap::new();
    let mut eligibility = BTreeMap::new();
    for p in &problems {
        let scale = x_scale(p);
        let eligible = exact_eligible(p);
        scales.insert(p.name, scale);
        eligibility.insert(p.name, eligible);
        eprintln!("geardyn {}", p.name);
        for method in Method::ALL {
            for &tol in &LADDER {
                rows.push(geardyn_row(p, Propagator::Rk(method), tol, scale, timing));
            }
        }
        if eligible {
            rows.push(geardyn_row(p, Propagator::Exact, 0.0, scale, timing));
        } else {
            notes.push(format!(
                "{}: the exact propagator does not apply (segments not LTI); no exact row",
                p.name
            ));
        }
        if eligible || p.kind == Kind::Train {
            // A second look at the exact propagator (and the drivetrain's second reference).
            let mut r = geardyn_row(
                p,
                Propagator::Rk(Method::Dop853),
                REFERENCE_TOL,
                scale,
                (0, 0.0),
            );
            r.method = "geardyn reference DOP853".into();
            rows.push(r);
        }
        if p.kind == Kind::Train {
            notes.push(format!(
                "{}: drivetrain; the scipy and differential-equations models are single-mesh, so \
                 only geardyn runs it (reference: exact propagator vs geardyn DOP853 at 1e-13)",
                p.name
            ));
        }
    }

    // References and errors.
    let mut references: BTreeMap<&str, Result<Reference, String>> = BTreeMap::new();
    for p in &problems {
        let scale = scales[p.name];
        let r = reference(p, eligibility[p.name], &rows, scale);
        if let Ok(reference) = &r {
            for row in rows
                .iter_mut()
                .filter(|row| row.problem == p.name && row.ok())
            {
                // The primary reference is measured against the independent secondary one
                // (against itself its error would be 0 by construction).
                let (dte, ev) = if row.method == reference.primary_method {
                    (&reference.secondary_dte, &reference.secondary_events)
                } else {
                    (&reference.dte, &reference.event_times)
                };
                if row.dte.len() == dte.len() && row.dte[0].len() == dte[0].len() {
                    row.errors = Some(errors(&row.dte, &row.event_times, dte, ev, scale));
                }
            }
        }
        references.insert(p.name, r);
    }

    let doc_dir = doc.parent().unwrap_or(Path::new(".")).join("benchmarks");
    std::fs::create_dir_all(&doc_dir).expect("create plot directory");
    let method_order: Vec<String> = [
        "geardyn DP5",
        "geardyn DOP853",
        "geardyn exact",
        "scipy DOP853",
        "scipy RK45",
        "scipy Radau",
        "differential-equations DOPRI5",
        "differential-equations DOP853",
        "differential-equations DOPRI5 (crate events)",
        "differential-equations DOP853 (crate events)",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();

    let mut md = String::new();
    write_doc_head(&mut md, quick, &problems, &scales, &eligibility);

    // References.
    md += "\n## References and their agreement\n\n";
    let _ = writeln!(md, "Each problem's reference comes from two independent methods that must agree \
        (largest DTE difference on the grid ≤ {AGREEMENT:.0e} of the largest |DTE|, same number of \
        contact changes) before either is used. The first is the reference of every method; its own \
        row is measured against the second. Where the stiffness is piecewise constant the first is the \
        extended-precision closed form of `scripts/workprecision_mpmath.py` (mpmath, 30 digits, contact \
        changes bisected to 1e-28 s) and the second the exact propagator. The difference is also given in units of \
        the static deflection, the unit of every error below: it bounds how far down the errors of a \
        problem can be resolved.\n");
    md += "| problem | reference | checked against | largest difference / max abs DTE | … / x_st | contact changes | agreed |\n|---|---|---|---|---|---|---|\n";
    for p in &problems {
        match &references[p.name] {
            Ok(r) => {
                let _ = writeln!(
                    md,
                    "| {} | {} | {} | {:.1e} | {:.1e} | {} / {} | {} |",
                    p.name,
                    r.primary,
                    r.secondary,
                    r.relative,
                    r.difference,
                    r.events.0,
                    r.events.1,
                    if r.agreed {
                        "yes"
                    } else {
                        "**no: errors below are not trustworthy**"
                    }
                );
                println!(
                    "reference {:16} {} vs {}: {:.1e} of max |DTE| ({:.1e} x_st), events {}/{}: {}",
                    p.name,
                    r.primary,
                    r.secondary,
                    r.relative,
                    r.difference,
                    r.events.0,
                    r.events.1,
                    if r.agreed { "agreed" } else { "NOT AGREED" }
                );
            }
            Err(e) => {
                let _ = writeln!(
                    md,
                    "| {} | – | – | – | – | – | **no reference: {e}** |",
                    p.name
                );
                println!("reference {:16} NONE: {e}", p.name);
            }
        }
    }

    // Acceptance (issue 9 item 1) on G1.
    let g1 = &problems[0];
    let g1_rows: Vec<&Row> = rows.iter().filter(|r| r.problem == g1.name).collect();
    let cost = |m: &str| {
        let rs: Vec<&Row> = g1_rows.iter().copied().filter(|r| r.method == m).collect();
        cost_at(&rs, TARGET_ERROR, |r| r.wall)
    };
    let geardyn_best = ["geardyn DP5", "geardyn DOP853", "geardyn exact"]
        .iter()
        .filter_map(|m| cost(m).map(|c| (c, *m)))
        .min_by(|a, b| a.0.partial_cmp(&b.0).unwrap());
    let scipy_dop853 = cost("scipy DOP853");
    let peer_best = [
        "differential-equations DOPRI5",
        "differential-equations DOP853",
    ]
    .iter()
    .filter_map(|m| cost(m).map(|c| (c, *m)))
    .min_by(|a, b| a.0.partial_cmp(&b.0).unwrap());
    let exact_error = find(&rows, g1.name, Propagator::Exact.label()).and_then(|r| r.errors);
    // Against what the exact propagator was measured: the primary reference, unless it is the
    // primary itself (no mpmath rows), then the secondary.
    let exact_measured_against = match &references[g1.name] {
        Ok(r) if r.primary_method == Propagator::Exact.label() => r.secondary.clone(),
        Ok(r) => r.primary.clone(),
        Err(_) => "no reference".into(),
    };
    let scipy_error = find(&rows, g1.name, "scipy reference DOP853").and_then(|r| r.errors);
    // A third, tighter look at the exact propagator: against geardyn's DOP853 at 1e-13 (RK with
    // event location, an independent method in the same code base), and that run against
    // scipy's, to show which of the two checks limits the comparison.
    let g1_scale = scales[g1.name];
    let versus = |a: &str, b: &str| -> Option<Errors> {
        let (ra, rb) = (find(&rows, g1.name, a)?, find(&rows, g1.name, b)?);
        Some(errors(
            &ra.dte,
            &ra.event_times,
            &rb.dte,
            &rb.event_times,
            g1_scale,
        ))
    };
    let exact_vs_rk = versus(Propagator::Exact.label(), "geardyn reference DOP853");
    let scipy_vs_rk = versus("scipy reference DOP853", "geardyn reference DOP853");
    md += "\n## Acceptance (issue 9, item 1): single-mesh backlash problem G1\n\n";
    let _ = writeln!(md, "Wall time at which each method's curve reaches a DTE error of {TARGET_ERROR:.0e} \
        (a rung at or below it, or log-log interpolation between the two rungs that bracket it), all \
        measured in this run:\n");
    md += "| method | wall time at DTE error 1e-8 |\n|---|---|\n";
    for m in &method_order {
        let _ = writeln!(
            md,
            "| {m} | {} |",
            cost(m).map_or("not reached".into(), |c| format!("{:.3} ms", c * 1e3))
        );
    }
    let ratio = |a: Option<f64>, b: Option<(f64, &str)>| match (a, b) {
        (Some(a), Some((b, _))) => Some(a / b),
        _ => None,
    };
    let r_scipy = ratio(scipy_dop853, geardyn_best);
    let r_peer = ratio(peer_best.map(|p| p.0), geardyn_best);
    let _ = writeln!(
        md,
        "\n- geardyn's best method at 1e-8: **{}**.\n- scipy DOP853 / geardyn best: **{}** (required ≥ 100): {}.\n\
         - Rust peer's best ({}) / geardyn best: **{}** (required ≥ 3): {}.\n\
         - exact propagator's DTE error (RMS; max) against the independent reference ({}): **{}; {}** (required ≤ 1e-12): {}.\n\
         - scipy DOP853 at rtol 1e-13 against the same reference: {}; {}.\n\
         - exact propagator against geardyn DOP853 at 1e-13: **{}; {}** ({}); scipy DOP853 at 1e-13 against geardyn DOP853 at 1e-13: {}; {} \
         (RK checks of the exact propagator, limited by the RK runs' own error).",
        geardyn_best.map_or("none reached 1e-8".into(), |g| format!("{} ({:.3} ms)", g.1, g.0 * 1e3)),
        r_scipy.map_or("n/a".into(), |r| format!("{r:.0}×")),
        pass(r_scipy.map(|r| r >= 100.0)),
        peer_best.map_or("none", |p| p.1),
        r_peer.map_or("n/a".into(), |r| format!("{r:.1}×")),
        pass(r_peer.map(|r| r >= 3.0)),
        exact_measured_against,
        fmt_e(exact_error.map(|e| e.dte_l2)),
        fmt_e(exact_error.map(|e| e.dte_max)),
        pass(exact_error.map(|e| e.dte_l2 <= 1e-12)),
        fmt_e(scipy_error.map(|e| e.dte_l2)),
        fmt_e(scipy_error.map(|e| e.dte_max)),
        fmt_e(exact_vs_rk.map(|e| e.dte_l2)),
        fmt_e(exact_vs_rk.map(|e| e.dte_max)),
        pass(exact_vs_rk.map(|e| e.dte_l2 <= 1e-12)),
        fmt_e(scipy_vs_rk.map(|e| e.dte_l2)),
        fmt_e(scipy_vs_rk.map(|e| e.dte_max)),
    );

    // Cost at the target for every problem.
    md += "\n## Wall time at DTE error 1e-8, every problem\n\n";
    md += "| problem |";
    for m in &method_order {
        let _ = write!(md, " {m} |");
    }
    md += "\n|---|";
    md += &"---|".repeat(method_order.len());
    md += "\n";
    for p in &problems {
        let _ = write!(md, "| {} |", p.name);
        for m in &method_order {
            let rs: Vec<&Row> = rows
                .iter()
                .filter(|r| r.problem == p.name && &r.method == m)
                .collect();
            let _ = write!(
                md,
                " {} |",
                if rs.is_empty() {
                    "–".into()
                } else {
                    cost_at(&rs, TARGET_ERROR, |r| r.wall)
                        .map_or("not reached".into(), |c| format!("{:.3} ms", c * 1e3))
                }
            );
        }
        md += "\n";
    }

    // Per problem: plots and the full table.
    md += "\n## Results per problem\n\nColumns: DTE error = RMS over the grid of |x − x_ref| / x_st; max = largest; \
        final = at the end time; RMS err = |RMS(x) − RMS(x_ref)| / x_st (mean removed); event-time error = largest \
        |t_i − t_ref,i| over the contact changes (s; – when the counts differ or there are none); Δevents = count minus the \
        reference's; wall = median of the timed runs after a warm-up; rhs, steps (accepted), rej (rejected; scipy \
        does not report it), events = contact changes located. Dashed lines in the plots are the other \
        libraries.\n";
    let mut csv = String::from("problem,method,tol,status,wall_s,timed_runs,rhs,steps,rejected,events,dte_l2,dte_max,final,dte_rms,event_time,event_mismatch\n");
    for p in &problems {
        let prows: Vec<&Row> = rows.iter().filter(|r| r.problem == p.name).collect();
        let methods: Vec<String> = method_order
            .iter()
            .filter(|m| prows.iter().any(|r| &r.method == *m))
            .cloned()
            .collect();
        for (rhs, suffix) in [(false, "time"), (true, "rhs")] {
            plot(
                p,
                &prows,
                &methods,
                rhs,
                &doc_dir.join(format!("{}_{suffix}.svg", p.name)),
            );
        }
        let _ = writeln!(md, "\n### {} ({})\n\n{}\n", p.name, p.id, p.what);
        let _ = writeln!(
            md,
            "![{0} error vs time](benchmarks/{0}_time.svg)\n![{0} error vs RHS evaluations](benchmarks/{0}_rhs.svg)\n\n\
             (d-e = differential-equations; the exact propagator evaluates no right-hand side and is \
             absent from the second plot.)\n",
            p.name
        );
        md += "| method | tol | DTE error | max | final | RMS err | event-time error | Δevents | wall [ms] | rhs | steps | rej | events | status |\n";
        md += "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
        for r in &prows {
            let e = r.errors;
            let _ = writeln!(
                md,
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                r.method,
                if r.method == Propagator::Exact.label() || r.method == MPMATH {
                    "–".into()
                } else {
                    format!("{:.0e}", r.tol)
                },
                fmt_e(e.map(|e| e.dte_l2)),
                fmt_e(e.map(|e| e.dte_max)),
                fmt_e(e.map(|e| e.final_point)),
                fmt_e(e.map(|e| e.dte_rms)),
                fmt_e(e.and_then(|e| e.event_time)),
                e.map_or("–".into(), |e| e.event_count_mismatch.to_string()),
                r.wall.map_or("–".into(), |w| format!("{:.3}", w * 1e3)),
                fmt_u(r.rhs),
                fmt_u(r.steps),
                fmt_u(r.rejected),
                fmt_u(r.events),
                r.status,
            );
            let _ = writeln!(
                csv,
                "{},{},{:e},{},{},{},{},{},{},{},{},{},{},{},{},{}",
                r.problem,
                r.method,
                r.tol,
                r.status.replace(',', ";"),
                r.wall.map_or(String::new(), |v| format!("{v:e}")),
                r.timed_runs.map_or(String::new(), |v| v.to_string()),
                r.rhs.map_or(String::new(), |v| v.to_string()),
                r.steps.map_or(String::new(), |v| v.to_string()),
                r.rejected.map_or(String::new(), |v| v.to_string()),
                r.events.map_or(String::new(), |v| v.to_string()),
                e.map_or(String::new(), |e| format!("{:e}", e.dte_l2)),
                e.map_or(String::new(), |e| format!("{:e}", e.dte_max)),
                e.map_or(String::new(), |e| format!("{:e}", e.final_point)),
                e.map_or(String::new(), |e| format!("{:e}", e.dte_rms)),
                e.and_then(|e| e.event_time)
                    .map_or(String::new(), |v| format!("{v:e}")),
                e.map_or(String::new(), |e| e.event_count_mismatch.to_string()),
            );
        }
    }
    std::fs::write(dir.join("results.csv"), csv).expect("write results.csv");

    md += OBSERVATIONS;
    md += "\n## Omissions and failures\n\n";
    let failed: Vec<&Row> = rows.iter().filter(|r| !r.ok()).collect();
    if failed.is_empty() && notes.is_empty() {
        md += "None: every method ran every rung of every problem it models.\n";
    }
    for n in &notes {
        let _ = writeln!(md, "- {n}");
    }
    for r in failed {
        let _ = writeln!(
            md,
            "- {} {} tol {:.0e}: {}",
            r.problem, r.method, r.tol, r.status
        );
    }
    let _ = writeln!(
        md,
        "\n---\n\n{}{}. geardyn part of the run: {:.0} s.\n",
        if quick {
            "**Quick mode** (fewer timed runs: numbers for iteration, not for quoting). "
        } else {
            ""
        },
        footer(),
        started.elapsed().as_secs_f64()
    );
    std::fs::write(&doc, md).expect("write doc");
    println!(
        "wrote {} and {}/*.svg; G1 at 1e-8: geardyn best {}, scipy DOP853 / geardyn best = {}, \
         peer best ({}) / geardyn best = {}, exact error {} (vs {}), {} (vs geardyn DOP853 1e-13), \
         scipy DOP853 1e-13 error {}",
        doc.display(),
        doc_dir.display(),
        geardyn_best.map_or("none", |g| g.1),
        r_scipy.map_or("n/a".into(), |r| format!("{r:.0}x")),
        peer_best.map_or("none", |p| p.1),
        r_peer.map_or("n/a".into(), |r| format!("{r:.1}x")),
        fmt_e(exact_error.map(|e| e.dte_l2)),
        exact_measured_against,
        fmt_e(exact_vs_rk.map(|e| e.dte_l2)),
        fmt_e(scipy_error.map(|e| e.dte_l2)),
    );
}
