//! `geardyn floquet` and `geardyn band`: the monodromy of any linear scene (closed form for a
//! single pair with piecewise-linear stiffness, `docs/helical.md`; exact segment transitions or
//! RK variational equations for a drivetrain), and its parametric instability bands over
//! speed.

use std::path::PathBuf;

use clap::Args;

use geardyn::analysis::band::mean_natural_frequency;
use geardyn::analysis::{instability_bands, monodromy, multiplier_line, LinearPeriodMap};
use geardyn::model::AnyScene;
use geardyn::units::{both_units, parse_speed, parse_speed_interval, rpm, significant};

use super::load_any_scene;

#[derive(Args)]
pub struct FloquetArgs {
    /// Scene file (`scene.toml`) or a folder holding one.
    #[arg(required_unless_present = "example", conflicts_with = "example")]
    scene: Option<PathBuf>,
    /// A built-in example scene instead of a file (e.g. `helical_pair_friction`).
    #[arg(long)]
    example: Option<String>,
    /// Input-gear speed: `19000rpm` or `1989.7rad/s`; a bare number is rad/s (default: the
    /// scene's `operating.pinion_speed` or `operating.input_speed`).
    #[arg(long, allow_hyphen_values = true)]
    speed: Option<String>,
    /// Friction coefficient μ of a `helical` stiffness (default: the scene's).
    #[arg(long, allow_negative_numbers = true)]
    mu: Option<f64>,
    /// Print JSON (monodromy, multipliers, load response, stiffness segments) instead of text.
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
pub struct BandArgs {
    /// Scene file (`scene.toml`) or a folder holding one.
    #[arg(required_unless_present = "example", conflicts_with = "example")]
    scene: Option<PathBuf>,
    /// A built-in example scene instead of a file.
    #[arg(long)]
    example: Option<String>,
    /// Scanned input-gear speeds `from:to`, e.g. `15000rpm:25000rpm`; a bare number is
    /// rad/s.
    #[arg(long, allow_hyphen_values = true)]
    speed: String,
    /// Scan points (band edges are then bisected); narrower bands than the spacing are missed.
    #[arg(long, default_value_t = 400)]
    points: usize,
    /// Friction coefficient μ of a `helical` stiffness (default: the scene's).
    #[arg(long, allow_negative_numbers = true)]
    mu: Option<f64>,
}

fn scene_with(
    path: &Option<PathBuf>,
    example: &Option<String>,
    mu: Option<f64>,
) -> Result<AnyScene, String> {
    let scene = load_any_scene(path, example)?;
    match (mu, scene) {
        (Some(mu), AnyScene::Pair(s)) => s
            .with_friction_coefficient(mu)
            .map(|s| AnyScene::Pair(Box::new(s)))
            .map_err(|e| format!("--mu {mu}: {e}")),
        (Some(mu), AnyScene::Train(s)) => Err(format!(
            "--mu {mu}: scene {} is a drivetrain; its tooth friction is set per mesh in \
             [mesh.friction] (docs/train.md)",
            s.name
        )),
        (None, scene) => Ok(scene),
    }
}

pub fn floquet(args: FloquetArgs) -> Result<(), String> {
    let mut scene = scene_with(&args.scene, &args.example, args.mu)?;
    if let Some(text) = &args.speed {
        let speed = parse_speed("--speed", text)?;
        eprintln!("floquet: input speed {}", both_units(speed));
        scene.set_input_speed(speed);
    }
    let floquet = monodromy(&scene)?;
    let closed_form = match &scene {
        AnyScene::Pair(s) if floquet.method.starts_with("closed form") => Some(s.clone()),
        _ => None,
    };
    let Some(scene) = closed_form else {
        return floquet_report(&scene, &floquet, args.json);
    };
    let map = LinearPeriodMap::new(&scene)?;
    let floquet = map.floquet();
    let phi = &floquet.monodromy;
    let g = map.load_response();
    let speed_rpm = rpm(scene.operating.pinion_speed);
    if args.json {
        let segments: Vec<String> = map
            .segments()
            .iter()
            .map(|s| {
                format!(
                    "{{\"start\": {:e}, \"duration\": {:e}, \"k_start\": {:e}, \"slope\": {:e}}}",
                    s.start, s.duration, s.k_start, s.slope
                )
            })
            .collect();
        let multipliers = multipliers_json(&floquet);
        println!(
            "{{\"scene\": {:?}, \"rpm\": {:e}, \"period\": {:e}, \"equivalent_mass\": {:e}, \
             \"force\": {:e}, \"damping\": {:e}, \"monodromy\": [[{:e}, {:e}], [{:e}, {:e}]], \
             \"trace\": {:e}, \"determinant\": {:e}, \"spectral_radius\": {:e}, \
             \"multipliers\": [{}], \"load_response\": [{:e}, {:e}], \"segments\": [{}]}}",
            scene.name,
            speed_rpm,
            map.period,
            map.equivalent_mass(),
            map.force(),
            scene.mesh.damping,
            phi[(0, 0)],
            phi[(0, 1)],
            phi[(1, 0)],
            phi[(1, 1)],
            phi.trace(),
            phi.determinant(),
            floquet.spectral_radius(),
            multipliers,
            g[0],
            g[1],
            segments.join(", ")
        );
        return Ok(());
    }
    println!(
        "scene {}: closed-form monodromy at {speed_rpm:.6} rpm (T = {:.6e} s, {} stiffness segments)",
        scene.name,
        map.period,
        map.segments().len()
    );
    println!("  Φ = [[{:+.12e}, {:+.12e}],", phi[(0, 0)], phi[(0, 1)]);
    println!("       [{:+.12e}, {:+.12e}]]", phi[(1, 0)], phi[(1, 1)]);
    println!(
        "  tr Φ = {:+.12}  det Φ = {:.12}",
        phi.trace(),
        phi.determinant()
    );
    for m in &floquet.multipliers {
        println!("{}", multiplier_line(m));
    }
    // |tr Φ| < 1 + det Φ with det Φ ≤ 1 (Jury test); undamped, det Φ = 1 up to rounding.
    let stable = phi.trace().abs() < 1.0 + phi.determinant() && phi.determinant() <= 1.0 + 1e-9;
    println!(
        "  stability: {}",
        if stable { "stable" } else { "unstable" }
    );
    println!(
        "  load response over one period g = [{:e} m, {:e} m/s]",
        g[0], g[1]
    );
    match map.periodic_state() {
        Some(x) => println!(
            "  periodic steady state x(0) = (I − Φ)⁻¹ g = [{:e} m, {:e} m/s]",
            x[0], x[1]
        ),
        None => println!("  periodic steady state: I − Φ is singular"),
    }
    Ok(())
}

pub fn band(args: BandArgs) -> Result<(), String> {
    let scene = scene_with(&args.scene, &args.example, args.mu)?;
    let range = parse_speed_interval("--speed", &args.speed)?;
    let (from, to) = (range.from, range.to);
    if to <= from {
        return Err(format!(
            "--speed '{}': the upper end {} must be greater than the lower end {}",
            args.speed,
            both_units(to),
            both_units(from)
        ));
    }
    eprintln!(
        "band: input speed {} to {}, {} scan points",
        both_units(from),
        both_units(to),
        args.points
    );
    let bands = instability_bands(&scene, from, to, args.points)?;
    let f_n = mean_natural_frequency(&scene);
    println!(
        "scene {}: instability bands between {} and {} rpm ({} scan points{})",
        scene.name(),
        significant(rpm(from)),
        significant(rpm(to)),
        args.points,
        f_n.map_or(String::new(), |f| format!("; mean f_n = {f:.3} Hz"))
    );
    if bands.is_empty() {
        println!("  none found (stable over the scanned speeds)");
    }
    let mesh_frequency = |speed: f64| {
        let mut at = scene.clone();
        at.set_input_speed(speed);
        Ok::<f64, String>(geardyn::with_drivetrain!(at.simulation()?, sim => {
            use geardyn::model::Drivetrain;
            sim.model().mesh_frequency(0)
        }))
    };
    for b in &bands {
        let (f_from, f_to) = (mesh_frequency(b.from_speed)?, mesh_frequency(b.to_speed)?);
        let detail = match (b.order, f_n) {
            (Some(1), Some(f_n)) => format!(
                "primary; f_mesh/f_n {:.4} – {:.4}",
                f_from / f_n,
                f_to / f_n
            ),
            (Some(order), Some(f_n)) => {
                format!(
                    "order {order}; f_mesh/f_n {:.4} – {:.4}",
                    f_from / f_n,
                    f_to / f_n
                )
            }
            _ => format!("mesh-1 frequency {f_from:.3} – {f_to:.3} Hz"),
        };
        println!(
            "  unstable {:.3} – {:.3} rpm  ({detail}; max |μ| {:.6})",
            rpm(b.from_speed),
            rpm(b.to_speed),
            b.peak_spectral_radius
        );
    }
    Ok(())
}

/// The report of a monodromy that is not the single pair's closed form: method, period,
/// multipliers and stability.
fn floquet_report(
    scene: &AnyScene,
    floquet: &geardyn::analysis::Floquet,
    json: bool,
) -> Result<(), String> {
    let speed_rpm = rpm(scene.input_speed());
    let rho = floquet.spectral_radius();
    if json {
        let multipliers = multipliers_json(floquet);
        println!(
            "{{\"scene\": {:?}, \"rpm\": {:e}, \"period\": {:e}, \"method\": {:?}, \
             \"spectral_radius\": {:e}, \"multipliers\": [{}]}}",
            scene.name(),
            speed_rpm,
            floquet.period,
            floquet.method,
            rho,
            multipliers
        );
        return Ok(());
    }
    println!(
        "scene {}: monodromy at {speed_rpm:.6} rpm over one response period T = {:.6e} s \
         ({} states; {})",
        scene.name(),
        floquet.period,
        floquet.monodromy.nrows(),
        floquet.method
    );
    for m in &floquet.multipliers {
        println!("{}", multiplier_line(m));
    }
    println!(
        "  spectral radius {rho:.12}: {}",
        if rho < 1.0 { "stable" } else { "unstable" }
    );
    Ok(())
}

/// The multipliers as a JSON array of `[re, im]` pairs.
fn multipliers_json(floquet: &geardyn::analysis::Floquet) -> String {
    let pairs: Vec<String> = floquet
        .multipliers
        .iter()
        .map(|m| format!("[{:e}, {:e}]", m.re, m.im))
        .collect();
    pairs.join(", ")
}
