//! `geardyn floquet` and `geardyn band`: closed-form monodromy of a linear single-mesh scene
//! with piecewise-linear stiffness, and its parametric instability bands over speed
//! (`docs/helical.md`).

use std::path::PathBuf;

use clap::Args;

use geardyn::analysis::band::{from_rpm, mean_natural_frequency, rpm};
use geardyn::analysis::{instability_bands, LinearPeriodMap};
use geardyn::scene::Scene;

use super::{load_scene, positive};

#[derive(Args)]
pub struct FloquetArgs {
    /// Scene file (`scene.toml`) or a folder holding one.
    #[arg(required_unless_present = "example", conflicts_with = "example")]
    scene: Option<PathBuf>,
    /// A built-in example scene instead of a file (e.g. `helical_pair_friction`).
    #[arg(long)]
    example: Option<String>,
    /// Pinion speed, rpm (default: the scene's `operating.pinion_speed`).
    #[arg(long, allow_negative_numbers = true)]
    rpm: Option<f64>,
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
    /// Lower end of the scanned pinion speed, rpm.
    #[arg(long)]
    from_rpm: f64,
    /// Upper end of the scanned pinion speed, rpm.
    #[arg(long)]
    to_rpm: f64,
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
) -> Result<Scene, String> {
    let scene = load_scene(path, example)?;
    match mu {
        Some(mu) => scene
            .with_friction_coefficient(mu)
            .map_err(|e| format!("--mu {mu}: {e}")),
        None => Ok(scene),
    }
}

pub fn floquet(args: FloquetArgs) -> Result<(), String> {
    let mut scene = scene_with(&args.scene, &args.example, args.mu)?;
    if let Some(r) = args.rpm {
        scene.operating.pinion_speed = from_rpm(positive("rpm", r)?);
    }
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
        let multipliers: Vec<String> = floquet
            .multipliers
            .iter()
            .map(|m| format!("[{:e}, {:e}]", m.re, m.im))
            .collect();
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
            multipliers.join(", "),
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
        println!(
            "  multiplier {:+.12} {:+.12}i  |μ| = {:.12}",
            m.re,
            m.im,
            m.norm()
        );
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
    let from = positive("from-rpm", args.from_rpm)?;
    let to = positive("to-rpm", args.to_rpm)?;
    if to <= from {
        return Err(format!(
            "--to-rpm {to}: must be greater than --from-rpm {from}"
        ));
    }
    let bands = instability_bands(&scene, from_rpm(from), from_rpm(to), args.points)?;
    let f_n = mean_natural_frequency(&scene);
    println!(
        "scene {}: instability bands between {from} and {to} rpm ({} scan points; mean f_n = {:.3} Hz)",
        scene.name, args.points, f_n
    );
    if bands.is_empty() {
        println!("  none found (stable over the scanned speeds)");
    }
    for b in &bands {
        let kind = if b.order == 1 {
            "primary".to_owned()
        } else {
            format!("order {}", b.order)
        };
        println!(
            "  unstable {:.3} – {:.3} rpm  ({kind}; f_mesh/f_n {:.4} – {:.4}; max |μ| {:.6})",
            rpm(b.from_speed),
            rpm(b.to_speed),
            scene.pinion.teeth as f64 * b.from_speed / std::f64::consts::TAU / f_n,
            scene.pinion.teeth as f64 * b.to_speed / std::f64::consts::TAU / f_n,
            b.peak_spectral_radius
        );
    }
    Ok(())
}
