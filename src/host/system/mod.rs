//! Multi-FMU systems in `geardyn run` (issue 18, point 4): SSP 1.0 system structures run by a
//! fixed-step master in one process.
//!
//! Data flow: [`open`] finds `SystemStructure.ssd` (an `.ssp` archive is unpacked to a
//! temporary folder; a folder or a `.ssd` file is read in place) → [`ssd`] parses it (over the
//! [`xml`] tree, with [`units`]) → every component's FMU is unpacked and its
//! modelDescription parsed → [`check`] resolves connectors and connections against the FMUs
//! → [`graph`] orders the elements and refuses algebraic loops → [`master`] steps the
//! instances (with `--tolerance`, [`controlled`] chooses and undoes the steps) and streams the
//! rows into the CSV writer of single-FMU runs.
//!
//! The run is supervised like a single FMU ([`crate::host::supervise`]): the parent checks
//! everything and writes the CSV header, a forked child loads the FMUs and runs the master;
//! if an FMU crashes the child, the parent writes the rows computed before and says where.

pub mod check;
pub mod controlled;
pub mod divergence;
mod extrapolation;
pub mod graph;
pub mod master;
mod parallel;
pub mod plan;
pub mod shipped;
pub mod ssd;
mod step;
pub mod units;
pub mod xml;

use crate::host::archive::{self, unpack, Unpacked};
use crate::host::cli::{self, RunArgs};
use crate::host::csv::{CsvWriter, CutBack};
use crate::host::description::{parse as parse_md, ModelDescription, VarType};
use crate::host::instance::Instance;
use crate::host::library::{FmuLibrary, Status, PLATFORM};
use crate::host::logger::Logger;
use crate::host::runner;
use crate::host::supervise::{Activity, ChildEnd, HostPhase, SharedActivity, Supervisor};
use master::{Algorithm, Column, Coupling, Plan};
use std::path::{Path, PathBuf};

/// Is `path` a system (`.ssp`, `.ssd`, or a folder holding `SystemStructure.ssd`) rather than
/// an FMU?
pub fn is_system(path: &Path) -> bool {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    matches!(ext.as_deref(), Some("ssp" | "ssd"))
        || (path.is_dir() && path.join("SystemStructure.ssd").is_file())
}

/// An opened system: the folder sources are relative to, the `.ssd` text, and the temporary
/// folder of an unpacked `.ssp` (removed on drop).
struct Opened {
    _temp: Option<tempfile::TempDir>,
    root: PathBuf,
    ssd_text: String,
    /// "the archive x.ssp" or "the folder x", for messages about missing sources.
    place: String,
}

fn read_text(p: &Path) -> Result<String, String> {
    let bytes = std::fs::read(p).map_err(|e| format!("{}: cannot read: {e}", p.display()))?;
    String::from_utf8(bytes).map_err(|_| format!("{}: not UTF-8 text", p.display()))
}

/// Unpack an `.ssp` (a ZIP archive, SSP 1.0 §3) into a temporary folder, with the checks of
/// FMU unpacking: no entry outside the folder, no links, a bound on the bytes written.
fn unpack_ssp(path: &Path) -> Result<tempfile::TempDir, String> {
    use std::io::Read;
    let file = std::fs::File::open(path).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => format!("{}: no such file", path.display()),
        _ => format!("{}: cannot open: {e}", path.display()),
    })?;
    let mut zip = zip::ZipArchive::new(std::io::BufReader::new(file)).map_err(|e| {
        format!(
            "{}: not an SSP: not a valid ZIP archive ({e})",
            path.display()
        )
    })?;
    crate::host::archive::refuse_duplicates(&mut zip, path)?;
    let temp = tempfile::Builder::new()
        .prefix("geardyn-ssp-")
        .tempdir()
        .map_err(|e| format!("cannot create a temporary folder: {e}"))?;
    let mut budget = crate::host::archive::MAX_UNPACKED_BYTES;
    for i in 0..zip.len() {
        let mut entry = zip
            .by_index(i)
            .map_err(|e| format!("{}: ZIP entry #{i}: {e}", path.display()))?;
        let raw = entry.name().map(|n| n.into_owned()).unwrap_or_default();
        let rel = match entry.enclosed_name() {
            Some(r) if !raw.starts_with('/') && !raw.contains('\\') && !entry.is_symlink() => r,
            _ => {
                return Err(format!(
                    "{}: ZIP entry \"{raw}\" has an unsafe path or is a link",
                    path.display()
                ))
            }
        };
        let out = temp.path().join(rel);
        if entry.is_dir() {
            std::fs::create_dir_all(&out).map_err(|e| format!("{}: {e}", out.display()))?;
            continue;
        }
        if let Some(parent) = out.parent() {
            std::fs::create_dir_all(parent).map_err(|e| format!("{}: {e}", parent.display()))?;
        }
        let mut f = std::fs::File::create(&out).map_err(|e| format!("{}: {e}", out.display()))?;
        let n = std::io::copy(&mut (&mut entry).take(budget + 1), &mut f)
            .map_err(|e| format!("{}: cannot extract \"{raw}\": {e}", path.display()))?;
        if n > budget {
            return Err(format!(
                "{}: the archive expands to more than {} bytes; refusing to unpack it",
                path.display(),
                crate::host::archive::MAX_UNPACKED_BYTES
            ));
        }
        budget -= n;
    }
    Ok(temp)
}

fn open(path: &Path) -> Result<Opened, String> {
    let is_ssp = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("ssp"));
    if is_ssp && !path.is_dir() {
        let temp = unpack_ssp(path)?;
        let root = temp.path().to_path_buf();
        let ssd = root.join("SystemStructure.ssd");
        if !ssd.is_file() {
            return Err(format!(
                "{}: not an SSP: the archive has no SystemStructure.ssd at its top level",
                path.display()
            ));
        }
        return Ok(Opened {
            ssd_text: read_text(&ssd)?,
            _temp: Some(temp),
            root,
            place: format!("the archive {}", path.display()),
        });
    }
    let (root, ssd) = if path.is_dir() {
        (path.to_path_buf(), path.join("SystemStructure.ssd"))
    } else {
        let parent = path.parent().unwrap_or(Path::new("."));
        let parent = if parent.as_os_str().is_empty() {
            Path::new(".")
        } else {
            parent
        };
        (parent.to_path_buf(), path.to_path_buf())
    };
    if !ssd.is_file() {
        return Err(format!("{}: no such file", ssd.display()));
    }
    Ok(Opened {
        ssd_text: read_text(&ssd)?,
        _temp: None,
        place: format!("the folder {}", root.display()),
        root,
    })
}

/// A source named in the SSD, as a path relative to the root, without URI scheme. In an
/// archive it must stay inside (no `..`); a system folder may refer to FMUs beside it
/// (`../../out/fmus/spur_pair.fmu`), so that an example can use the FMUs built in `out/`.
fn source_path(root: &Path, source: &str, archive: bool) -> Result<PathBuf, String> {
    let s = source.strip_prefix("./").unwrap_or(source);
    let rel = Path::new(s);
    let up = rel
        .components()
        .any(|c| matches!(c, std::path::Component::ParentDir));
    if s.contains("://") || s.starts_with("file:") || rel.is_absolute() || (archive && up) {
        return Err(format!(
            "source=\"{source}\": geardyn resolves sources relative to the system's root (e.g. resources/a.fmu), without URI schemes{}",
            if archive { " or '..' (it would leave the archive)" } else { "" }
        ));
    }
    Ok(root.join(rel))
}

impl ssd::Resources for Opened {
    fn read(&self, source: &str) -> Result<String, String> {
        let p = source_path(&self.root, source, self._temp.is_some())?;
        if !p.is_file() {
            return Err(format!("\"{source}\" is not in {}", self.place));
        }
        read_text(&p)
    }
}

/// The FMUs of a system, unpacked and parsed (one per distinct source).
struct Fmus {
    unpacked: Vec<Unpacked>,
    mds: Vec<ModelDescription>,
    sources: Vec<String>,
    /// Per component: its FMU.
    fmu_of: Vec<usize>,
    /// The FMUs whose binary is a link to an identical one unpacked before them
    /// ([`archive::unpack_sharing`]).
    shared: Vec<String>,
}

/// Unpacks the FMU at `p` and parses its model description. With `shared`, an FMU whose
/// description announces `<SharedBinary/>` gets its binary linked to an identical one
/// unpacked before (`true` then).
fn unpack_fmu(
    p: &Path,
    source: &str,
    shared: Option<&mut archive::SharedBinaries>,
) -> Result<(Unpacked, ModelDescription, bool), String> {
    let md_name = format!("{source}/modelDescription.xml");
    // With sharing, the description is read from the archive first, to see whether the
    // binary may be shared; where that read fails, unpacking checks the archive and the
    // description is read from the unpacked folder, whose errors say what is wrong.
    let read_first = shared
        .is_some()
        .then(|| parse_md(&archive::model_description_in(p)?, &md_name).ok())
        .flatten();
    let Some(md) = read_first else {
        let u = unpack(p)?;
        let md = parse_md(&u.model_description_text()?, &md_name)?;
        return Ok((u, md, false));
    };
    let announced = md.co_simulation.as_ref().filter(|c| c.shares_binary);
    match (announced, shared) {
        (Some(cs), Some(sh)) => {
            let binary = format!("binaries/{PLATFORM}/{}.so", cs.model_identifier);
            let (u, linked) = archive::unpack_sharing(p, &binary, sh)?;
            Ok((u, md, linked))
        }
        _ => Ok((unpack(p)?, md, false)),
    }
}

fn load_fmus(opened: &Opened, sys: &ssd::Ssd, share_binaries: bool) -> Result<Fmus, String> {
    let mut f = Fmus {
        unpacked: Vec::new(),
        mds: Vec::new(),
        sources: Vec::new(),
        fmu_of: Vec::new(),
        shared: Vec::new(),
    };
    let mut binaries = archive::SharedBinaries::default();
    let mut paths: Vec<PathBuf> = Vec::new();
    for c in &sys.components {
        let p = source_path(&opened.root, &c.source, opened._temp.is_some())
            .map_err(|e| format!("component \"{}\": {e}", c.name))?;
        if !p.exists() {
            let at = format!(
                "SystemStructure.ssd line {}: component \"{}\"",
                c.line, c.name
            );
            match shipped::scene_of(&p).filter(|_| opened._temp.is_none()) {
                Some(scene) => eprintln!("note: {}", shipped::build(&p, &scene).map_err(|e| format!("{at}: {e}"))?),
                None => return Err(format!(
                    "{at}: its FMU source=\"{}\" is not in {} (a geardyn FMU is built from its scene with `geardyn fmu build <scene folder> --out <folder>`)",
                    c.source, opened.place
                )),
            }
        }
        let canonical = std::fs::canonicalize(&p).unwrap_or(p.clone());
        if let Some(i) = paths.iter().position(|q| *q == canonical) {
            f.fmu_of.push(i);
            continue;
        }
        let (u, md, linked) = unpack_fmu(&p, &c.source, share_binaries.then_some(&mut binaries))
            .map_err(|e| format!("component \"{}\": {e}", c.name))?;
        if linked {
            f.shared.push(c.source.clone());
        }
        if md.co_simulation.is_none() {
            return Err(format!(
                "component \"{}\": {} declares no <CoSimulation> interface (geardyn runs FMI 2.0 Co-Simulation FMUs)",
                c.name, c.source
            ));
        }
        paths.push(canonical);
        f.unpacked.push(u);
        f.mds.push(md);
        f.sources.push(c.source.clone());
        f.fmu_of.push(f.mds.len() - 1);
    }
    for (i, md) in f.mds.iter().enumerate() {
        let users: Vec<&str> = sys
            .components
            .iter()
            .zip(&f.fmu_of)
            .filter(|(_, &k)| k == i)
            .map(|(c, _)| c.name.as_str())
            .collect();
        let once = md
            .co_simulation
            .as_ref()
            .is_some_and(|cs| cs.can_be_instantiated_only_once_per_process);
        if once && users.len() > 1 {
            return Err(format!(
                "{} declares canBeInstantiatedOnlyOncePerProcess=\"true\" but the elements {} all use it",
                f.sources[i],
                users.join(", ")
            ));
        }
    }
    Ok(f)
}

fn parse_algorithm(s: Option<&str>) -> Result<Algorithm, String> {
    match s.unwrap_or("gauss-seidel") {
        "jacobi" => Ok(Algorithm::Jacobi),
        "gauss-seidel" => Ok(Algorithm::GaussSeidel),
        other => Err(format!(
            "--algorithm \"{other}\": expected jacobi or gauss-seidel"
        )),
    }
}

fn parse_extrapolation(s: Option<&str>) -> Result<bool, String> {
    match s.unwrap_or("linear") {
        "linear" => Ok(true),
        "none" => Ok(false),
        other => Err(format!(
            "--extrapolation \"{other}\": expected none or linear"
        )),
    }
}

/// Build the plan: order, loops, couplings (with a note for each connection that falls back
/// to a hold), columns and the grid.
fn plan<'a>(
    args: &RunArgs,
    sys: &ssd::Ssd,
    fmus: &Fmus,
    activity: &'a Activity,
    notes: &mut Vec<String>,
) -> Result<Plan<'a>, String> {
    let algorithm = parse_algorithm(args.algorithm.as_deref())?;
    let extrapolate = parse_extrapolation(args.extrapolation.as_deref())?;
    let pairs = args
        .start
        .iter()
        .map(|a| crate::host::start::parse_arg(a))
        .collect::<Result<Vec<_>, _>>()?;
    let system = check::check(sys, &fmus.mds, &fmus.fmu_of, &pairs)?;
    let md_of = |e: usize| &fmus.mds[fmus.fmu_of[e]];
    if let Some(cycle) = graph::algebraic_loop(&system.links, md_of) {
        return Err(format!(
            "algebraic loop between direct-feedthrough ports: {cycle} (every output on it depends directly on the input before it, ModelStructure/Outputs dependencies); a fixed-step master cannot solve it: break it with an element that has no direct feedthrough"
        ));
    }
    let start_time = args.start_time.or(sys.start_time).unwrap_or(0.0);
    let stop_time = args.stop_time.or(sys.stop_time).unwrap_or(start_time + 1.0);
    if !start_time.is_finite() || !stop_time.is_finite() || stop_time <= start_time {
        return Err(format!(
            "stop time {stop_time} must be finite and after the start time {start_time}"
        ));
    }
    let h = match args.output_interval {
        Some(h) => h,
        None => fmus
            .fmu_of
            .iter()
            .map(|&i| runner::default_interval(&fmus.mds[i], start_time, stop_time))
            .fold(f64::INFINITY, f64::min),
    };
    if !(h.is_finite() && h > 0.0) {
        return Err(format!(
            "--output-interval {h}: must be a finite number > 0"
        ));
    }
    runner::check_grid(start_time, stop_time, h, args.max_rows)?;
    let can_vary = fmus.mds.iter().all(|md| {
        md.co_simulation
            .as_ref()
            .is_some_and(|c| c.can_handle_variable_communication_step_size)
    });
    let control = controlled::settings(args, h, can_vary, fmus, notes)?;
    let n = system.elements.len();
    let (ports, port_of) = master::producer_ports(&system.links);
    let feedthrough = graph::feedthrough(&system.links, &port_of, md_of);
    let (mut order, mut cut) = graph::order(n, &system.links);
    if control.is_some() {
        (order, cut) = graph::compliances_first(&order, &system.links, &feedthrough);
    }
    let mut needs_derivative = vec![false; ports.len()];
    let mut coupling = Vec::new();
    for (l, link) in system.links.iter().enumerate() {
        let cs = |e: usize| md_of(e).co_simulation.clone().unwrap_or_default();
        let (prod, cons) = (cs(link.from.element), cs(link.to.element));
        let c = if !extrapolate || link.to.var_type != VarType::Real {
            Coupling::Hold
        } else if algorithm == Algorithm::GaussSeidel && !cut[l] {
            if cons.can_interpolate_inputs {
                Coupling::Interpolate
            } else {
                notes.push(format!(
                    "{}: zero-order hold: {} does not declare canInterpolateInputs=\"true\"",
                    link.label, system.elements[link.to.element].name
                ));
                Coupling::Hold
            }
        } else if cons.can_interpolate_inputs && prod.max_output_derivative_order >= 1 {
            needs_derivative[port_of[l]] = true;
            Coupling::Extrapolate
        } else {
            let mut why = Vec::new();
            if prod.max_output_derivative_order < 1 {
                why.push(format!(
                    "{} declares maxOutputDerivativeOrder=\"{}\"",
                    system.elements[link.from.element].name, prod.max_output_derivative_order
                ));
            }
            if !cons.can_interpolate_inputs {
                why.push(format!(
                    "{} does not declare canInterpolateInputs=\"true\"",
                    system.elements[link.to.element].name
                ));
            }
            notes.push(format!(
                "{}: zero-order hold: {}",
                link.label,
                why.join(" and ")
            ));
            Coupling::Hold
        };
        coupling.push(c);
    }
    // Columns: the connected signals (each producer output once), then --outputs.
    let mut columns: Vec<Column> = Vec::new();
    for (p, &(e, vr, t)) in ports.iter().enumerate() {
        let l = port_of.iter().position(|&x| x == p).unwrap_or(0);
        columns.push(Column {
            element: e,
            vr,
            var_type: t,
            name: system.links[l].from.name.clone(),
            port: Some(p),
        });
    }
    for name in args
        .outputs
        .iter()
        .flatten()
        .map(|s| s.trim())
        .filter(|s| !s.is_empty())
    {
        let (en, vn) = name.split_once('.').ok_or_else(|| {
            format!("--outputs \"{name}\": name a variable of a system as Element.variable")
        })?;
        let e = system
            .elements
            .iter()
            .position(|x| x.name == en)
            .ok_or_else(|| format!("--outputs \"{name}\": the system has no element \"{en}\""))?;
        let v = md_of(e).variable(vn).ok_or_else(|| {
            format!("--outputs \"{name}\": the FMU of \"{en}\" has no variable \"{vn}\"")
        })?;
        let t = match v.var_type {
            VarType::String => {
                return Err(format!(
                    "--outputs \"{name}\": String variables cannot be recorded"
                ))
            }
            VarType::Enumeration => VarType::Integer,
            t => t,
        };
        if columns.iter().any(|c| c.name == name) {
            continue;
        }
        columns.push(Column {
            element: e,
            vr: v.value_reference,
            var_type: t,
            name: name.to_string(),
            port: None,
        });
    }
    columns.sort_by_key(|c| match c.var_type {
        VarType::Real => 0,
        VarType::Boolean => 2,
        _ => 1,
    });
    let divergence_factor = args.divergence_factor.unwrap_or(DIVERGENCE_FACTOR);
    if !(divergence_factor == 0.0 || divergence_factor.is_finite() && divergence_factor > 1.0) {
        return Err(format!(
            "--divergence-factor {divergence_factor}: must be a finite number > 1, or 0 to turn the check off"
        ));
    }
    let watched = divergence::watched(&ports, &md_of);
    if control.is_some() {
        // The error estimate of an interpolated connection uses its producer's derivative
        // at both ends of the step.
        for (l, c) in coupling.iter().enumerate() {
            let prod = system.links[l].from.element;
            let order = md_of(prod)
                .co_simulation
                .as_ref()
                .map_or(0, |c| c.max_output_derivative_order);
            if *c == Coupling::Interpolate && order >= 1 {
                needs_derivative[port_of[l]] = true;
            }
        }
    }
    // The error-controlled master gives the cubic Hermite input over an interpolated
    // connection whose consumer takes input derivatives up to order 3 (its producer's
    // derivative is read at both ends).
    let hermite: Vec<bool> = (system.links.iter().enumerate())
        .map(|(l, link)| {
            let takes = md_of(link.to.element)
                .co_simulation
                .as_ref()
                .is_some_and(|c| c.max_input_derivative_order >= 3);
            control.is_some()
                && coupling[l] == Coupling::Interpolate
                && needs_derivative[port_of[l]]
                && takes
        })
        .collect();
    // The error-controlled master extrapolates a flow into a consumer that takes input
    // derivatives of order 2 or 3 with a quadratic or cubic (`extrapolation`).
    let extrapolation_order: Vec<u8> = (system.links.iter().enumerate())
        .map(|(l, link)| {
            let takes = md_of(link.to.element)
                .co_simulation
                .as_ref()
                .map_or(1, |c| c.max_input_derivative_order.clamp(1, 3));
            if control.is_some() && coupling[l] == Coupling::Extrapolate {
                takes as u8
            } else {
                1
            }
        })
        .collect();
    let threads = match (&control, args.threads) {
        (Some(_), Some(k)) if k > 1 => {
            return Err(format!(
                "--threads {k}: the error-controlled master (--tolerance) steps the elements on one thread"
            ))
        }
        (Some(_), _) => 1,
        (None, asked) => threads(asked, algorithm, n, fmus)?,
    };
    Ok(Plan {
        threads,
        threads_asked: args.threads.is_some(),
        watched,
        divergence_factor,
        control,
        system,
        algorithm,
        order,
        cut,
        coupling,
        ports,
        port_of,
        needs_derivative,
        hermite,
        extrapolation_order,
        feedthrough,
        columns,
        start_time,
        stop_time,
        h,
        can_vary,
        interrupt: Some(activity.stop_request()),
    })
}

/// The threads of a Jacobi step ([`parallel`]): `--threads`, else as many as there are
/// cores (at most one per element) for a Jacobi system of ≥ 3 elements whose FMUs all allow
/// several instances per process (`canBeInstantiatedOnlyOncePerProcess="false"`: an FMU
/// that does not may keep global state); 1 otherwise.
fn threads(
    asked: Option<usize>,
    algorithm: Algorithm,
    n: usize,
    fmus: &Fmus,
) -> Result<usize, String> {
    let once: Vec<&str> = fmus
        .mds
        .iter()
        .zip(&fmus.sources)
        .filter(|(md, _)| {
            md.co_simulation
                .as_ref()
                .is_some_and(|c| c.can_be_instantiated_only_once_per_process)
        })
        .map(|(_, s)| s.as_str())
        .collect();
    match asked {
        Some(0) => Err("--threads 0: give at least 1".into()),
        Some(1) => Ok(1),
        Some(k) if algorithm != Algorithm::Jacobi => Err(format!(
            "--threads {k}: only Jacobi steps the elements in parallel (Gauss–Seidel steps them one after another)"
        )),
        Some(k) if !once.is_empty() => Err(format!(
            "--threads {k}: {} declares canBeInstantiatedOnlyOncePerProcess=\"true\" (it may keep global state), so the system is stepped on one thread",
            once.join(", ")
        )),
        Some(k) => Ok(k.min(n)),
        None if algorithm == Algorithm::Jacobi && n >= 3 && once.is_empty() => Ok(
            std::thread::available_parallelism().map_or(1, |c| c.get()).min(n),
        ),
        None => Ok(1),
    }
}

/// The default growth factor of the divergence check ([`divergence`]).
pub const DIVERGENCE_FACTOR: f64 = 1000.0;

/// `geardyn run` on a system: the exit code, or the message of a failure.
pub fn run(args: &RunArgs) -> Result<u8, String> {
    if args.input.is_some() {
        return Err("--input is for single FMUs; in a system, bind parameter values (ssd:ParameterBindings) or connect an element".into());
    }
    if args.timing {
        return Err("--timing is for single FMUs".into());
    }
    let log_level = Status::parse_level(&args.log_level).ok_or_else(|| {
        format!(
            "--log-level \"{}\": expected all, warning, discard, error or fatal",
            args.log_level
        )
    })?;
    let supervisor = Supervisor::new()?;
    let opened = open(&args.fmu)?;
    let sys = ssd::parse(&opened.ssd_text, &opened)?;
    let fmus = load_fmus(&opened, &sys, !args.no_shared_binaries)?;
    let shared = SharedActivity::new()?;
    let activity = shared.get();
    let mut notes = Vec::new();
    let plan = plan(args, &sys, &fmus, activity, &mut notes)?;
    for n in &notes {
        eprintln!("note: {n}");
    }
    let names: Vec<String> = plan.columns.iter().map(|c| c.name.clone()).collect();
    let where_to = args
        .out
        .as_ref()
        .map_or_else(|| "stdout".to_string(), |p| p.display().to_string());
    let mut csv = CsvWriter::new(cli::open_output(&args.out)?, &names)
        .map_err(|e| format!("{where_to}: cannot write: {e}"))?;
    if let Some(signal) = supervisor.pending_interrupt() {
        return Err(format!(
            "interrupted by {signal} before the FMUs were loaded"
        ));
    }
    let child = || {
        cli::report(child_run(
            args, &fmus, &plan, activity, log_level, &mut csv, &where_to,
        ))
    };
    match supervisor.run(activity, child)? {
        ChildEnd::Reported(code) => {
            // A run that failed before its first row (an FMU that cannot be loaded or
            // instantiated, a failing initialization) leaves no file: only the rows computed
            // before a failure are kept.
            if code != 0 && csv.written().0 == 0 {
                if let Some(p) = &args.out {
                    let _ = std::fs::remove_file(p);
                }
            }
            Ok(code)
        }
        ChildEnd::Abnormal(what) => Err(match csv.complete_after_writer_died() {
            Ok(()) if csv.written().0 == 0 => {
                if let Some(p) = &args.out {
                    let _ = std::fs::remove_file(p);
                }
                what
            }
            Ok(()) => format!("{what}{}", cli::rows_kept(&args.out, csv.written())),
            Err(e) => {
                format!("{what}; also: {where_to}: cannot write the rows computed before: {e}")
            }
        }),
    }
}

/// Where the error-controlled master writes its step sequence: `<out>.steps.csv`.
pub fn steps_path(out: &Path) -> PathBuf {
    let mut name = out.file_name().unwrap_or_default().to_os_string();
    name.push(".steps.csv");
    out.with_file_name(name)
}

/// The child's part: load each FMU's library once, instantiate every element, run, free.
fn child_run(
    args: &RunArgs,
    fmus: &Fmus,
    plan: &Plan,
    activity: &Activity,
    log_level: Status,
    csv: &mut CsvWriter<Box<dyn CutBack>>,
    where_to: &str,
) -> Result<(), String> {
    activity.phase(HostPhase::Preloading);
    crate::host::library::preload(&args.preload)?;
    activity.phase(HostPhase::LoadingLibrary);
    let mut libs = Vec::new();
    for (i, u) in fmus.unpacked.iter().enumerate() {
        let cs = fmus.mds[i]
            .co_simulation
            .as_ref()
            .ok_or("no CoSimulation")?;
        libs.push(
            FmuLibrary::load(u.root(), &cs.model_identifier)
                .map_err(|e| format!("{}: {e}", fmus.sources[i]))?,
        );
    }
    if !fmus.shared.is_empty() && Logger::new(log_level).prints_all() {
        eprintln!(
            "note: {} load the identical binary of an FMU before them (<SharedBinary/>; --no-shared-binaries loads each its own)",
            fmus.shared.join(", ")
        );
    }
    let mut insts: Vec<Instance> = Vec::new();
    for el in &plan.system.elements {
        let md = &fmus.mds[el.fmu];
        let root = fmus.unpacked[el.fmu].root();
        let logger = Logger::new(log_level);
        let debug = logger.prints_all();
        let mut inst = Instance::instantiate(
            &libs[el.fmu],
            &el.name,
            &md.guid,
            &cli::file_uri(&root.join("resources")),
            logger,
            args.fmi_trace,
            activity,
        )
        .map_err(|e| format!("element \"{}\": {e}", el.name))?;
        if debug {
            if let Err(e) = inst.set_debug_logging(true) {
                eprintln!("warning: element \"{}\": {e}", el.name);
            }
        }
        insts.push(inst);
    }
    let outcome = match &plan.control {
        Some(ctl) => controlled::run(&mut insts, plan, ctl, csv),
        None => master::run(&mut insts, plan, csv),
    };
    drop(insts); // fmi2FreeInstance before the libraries are unloaded
    let flushed = csv
        .flush()
        .map_err(|e| format!("{where_to}: cannot write: {e}"));
    for n in &outcome.notes {
        eprintln!("note: {n}");
    }
    if let (Some(out), false) = (&args.out, outcome.steps.is_empty()) {
        let path = steps_path(out);
        match std::fs::write(&path, controlled::steps_csv(&outcome.steps)) {
            Ok(()) => eprintln!("note: the step sequence is in {}", path.display()),
            Err(e) => eprintln!(
                "warning: {}: cannot write the step sequence: {e}",
                path.display()
            ),
        }
    }
    match (&outcome.failure, flushed) {
        (Some(f), Ok(())) => Err(format!("{f}{}", cli::rows_kept(&args.out, csv.written()))),
        (Some(f), Err(w)) => Err(format!("{f}; also: {w}")),
        (None, r) => r,
    }
}
