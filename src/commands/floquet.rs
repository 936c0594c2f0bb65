//! `floquet` and `band`: the monodromy of any linear scene (closed form for a single pair with
//! piecewise-linear stiffness, `docs/helical.md`; exact segment transitions or RK variational
//! equations for a drivetrain), and its parametric instability bands over speed, with the
//! reports `geardyn floquet | band` print.

use std::fmt::Write as _;

use crate::analysis::band::mean_natural_frequency;
use crate::analysis::shooting::NEUTRAL_TOLERANCE;
use crate::analysis::{
    instability_bands, monodromy, multiplier_line, Floquet, LinearPeriodMap, Stability,
};
use crate::model::Drivetrain;
use crate::scene::Scene;
use crate::units::{both_units, parse_speed, parse_speed_interval, rpm, significant};
use crate::with_drivetrain;

/// The scene with the friction coefficient of its `helical` stiffness replaced (`--mu`).
pub fn with_friction(scene: Scene, mu: Option<f64>) -> Result<Scene, String> {
    let Some(mu) = mu else { return Ok(scene) };
    match scene.pair() {
        Some(s) => s
            .with_friction_coefficient(mu)
            .map(Scene::from)
            .map_err(|e| format!("--mu {mu}: {e}")),
        None => Err(format!(
            "--mu {mu}: scene {} is a drivetrain; its tooth friction is set per mesh in \
             [mesh.friction] (docs/train.md)",
            scene.name
        )),
    }
}

/// `geardyn floquet`: the monodromy at `speed` (`--speed` text; default the scene's) as the
/// text (or with `json` the JSON) the command prints.
pub fn floquet(mut scene: Scene, speed: Option<&str>, json: bool) -> Result<String, String> {
    if let Some(text) = speed {
        let speed = parse_speed("--speed", text)?;
        eprintln!("floquet: input speed {}", both_units(speed));
        scene.set_input_speed(speed);
    }
    let floquet = monodromy(&scene)?;
    let closed_form = match scene.pair() {
        Some(s) if floquet.method.starts_with("closed form") => Some(s),
        _ => None,
    };
    let Some(scene) = closed_form else {
        return Ok(floquet_report(&scene, &floquet, json));
    };
    let map = LinearPeriodMap::new(&scene)?;
    let floquet = map.floquet()?;
    let phi = &floquet.monodromy;
    let g = map.load_response();
    let speed_rpm = rpm(scene.operating.pinion_speed);
    // Writing to a String cannot fail.
    let mut out = String::new();
    if json {
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
        let _ = writeln!(
            out,
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
        return Ok(out);
    }
    let _ = writeln!(
        out,
        "scene {}: closed-form monodromy at {speed_rpm:.6} rpm (T = {:.6e} s, {} stiffness segments)",
        scene.name,
        map.period,
        map.segments().len()
    );
    let _ = writeln!(
        out,
        "  Φ = [[{:+.12e}, {:+.12e}],",
        phi[(0, 0)],
        phi[(0, 1)]
    );
    let _ = writeln!(
        out,
        "       [{:+.12e}, {:+.12e}]]",
        phi[(1, 0)],
        phi[(1, 1)]
    );
    let _ = writeln!(
        out,
        "  tr Φ = {:+.12}  det Φ = {:.12}",
        phi.trace(),
        phi.determinant()
    );
    for m in &floquet.multipliers {
        let _ = writeln!(out, "{}", multiplier_line(m));
    }
    // Undamped (det Φ = 1 up to rounding) and outside the bands (|tr Φ| < 2): both multipliers
    // on the unit circle, neutral, not stable.
    let _ = writeln!(out, "  stability: {}", verdict(&floquet));
    let _ = writeln!(
        out,
        "  load response over one period g = [{:e} m, {:e} m/s]",
        g[0], g[1]
    );
    let _ = match map.periodic_state() {
        Some(x) => writeln!(
            out,
            "  periodic steady state x(0) = (I − Φ)⁻¹ g = [{:e} m, {:e} m/s]",
            x[0], x[1]
        ),
        None => writeln!(out, "  periodic steady state: I − Φ is singular"),
    };
    Ok(out)
}

/// `geardyn band`: the instability bands over the `--speed` interval `speed` from `points`
/// scan points, as the text the command prints.
pub fn band(scene: &Scene, speed: &str, points: usize) -> Result<String, String> {
    let range = parse_speed_interval("--speed", speed)?;
    let (from, to) = (range.from, range.to);
    if to <= from {
        return Err(format!(
            "--speed '{speed}': the upper end {} must be greater than the lower end {}",
            both_units(to),
            both_units(from)
        ));
    }
    eprintln!(
        "band: input speed {} to {}, {points} scan points",
        both_units(from),
        both_units(to),
    );
    let bands = instability_bands(scene, from, to, points)?;
    let f_n = mean_natural_frequency(scene);
    let mut out = String::new();
    let _ = writeln!(
        out,
        "scene {}: instability bands between {} and {} rpm ({points} scan points{})",
        scene.name,
        significant(rpm(from)),
        significant(rpm(to)),
        f_n.map_or(String::new(), |f| format!("; mean f_n = {f:.3} Hz"))
    );
    if bands.is_empty() {
        let _ = writeln!(out, "  none found (stable over the scanned speeds)");
    }
    let mesh_frequency = |speed: f64| {
        let mut at = scene.clone();
        at.set_input_speed(speed);
        Ok::<f64, String>(with_drivetrain!(at.simulation()?, sim => {
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
        let _ = writeln!(
            out,
            "  unstable {:.3} – {:.3} rpm  ({detail}; max |μ| {:.6})",
            rpm(b.from_speed),
            rpm(b.to_speed),
            b.peak_spectral_radius
        );
    }
    Ok(out)
}

/// The report of a monodromy that is not the single pair's closed form: method, period,
/// multipliers and stability.
fn floquet_report(scene: &Scene, floquet: &Floquet, json: bool) -> String {
    let speed_rpm = rpm(scene.input_speed());
    let rho = floquet.spectral_radius();
    let mut out = String::new();
    if json {
        let multipliers = multipliers_json(floquet);
        let _ = writeln!(
            out,
            "{{\"scene\": {:?}, \"rpm\": {:e}, \"period\": {:e}, \"method\": {:?}, \
             \"spectral_radius\": {:e}, \"multipliers\": [{}]}}",
            scene.name, speed_rpm, floquet.period, floquet.method, rho, multipliers
        );
        return out;
    }
    let _ = writeln!(
        out,
        "scene {}: monodromy at {speed_rpm:.6} rpm over one response period T = {:.6e} s \
         ({} states; {})",
        scene.name,
        floquet.period,
        floquet.monodromy.nrows(),
        floquet.method
    );
    for m in &floquet.multipliers {
        let _ = writeln!(out, "{}", multiplier_line(m));
    }
    let _ = writeln!(out, "  spectral radius {rho:.12}: {}", verdict(floquet));
    out
}

/// The verdict the reports print: stable, neutral (the largest multiplier on the unit circle
/// within [`NEUTRAL_TOLERANCE`]: an undamped system outside its instability bands) or
/// unstable.
fn verdict(floquet: &Floquet) -> String {
    match Stability::of(&floquet.multipliers) {
        Stability::Stable => "stable".into(),
        Stability::Neutral => {
            format!("neutral (|μ| within {NEUTRAL_TOLERANCE:.0e} of 1)")
        }
        _ => "unstable".into(),
    }
}

/// The multipliers as a JSON array of `[re, im]` pairs.
fn multipliers_json(floquet: &Floquet) -> String {
    let pairs: Vec<String> = floquet
        .multipliers
        .iter()
        .map(|m| format!("[{:e}, {:e}]", m.re, m.im))
        .collect();
    pairs.join(", ")
}
