//! The Campbell diagram of `geardyn modes --campbell` (`docs/spectrum.md`, "Campbell
//! diagram"): the natural frequencies `geardyn modes` computes (the same modes, the same code
//! path) as lines over the input speed, with each mesh's orders 1–3 and the input shaft's
//! order 1 as rays, and the critical speeds where they cross.

use std::fmt::Write;
use std::path::Path;

use super::modes::Modes;
use crate::plot::Campbell;
use crate::scene::Scene;

/// The speed range a Campbell diagram of `scene` covers by default, rpm: the run-up's speeds,
/// else from 0 to twice the operating speed.
pub fn default_rpm(scene: &Scene) -> (f64, f64) {
    let rpm = |w: f64| w * 60.0 / std::f64::consts::TAU;
    match &scene.profiles.speed {
        Some(p) => {
            let (lo, hi) = p
                .values()
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                    (a.min(v), b.max(v))
                });
            (0.0, rpm(hi.max(lo)))
        }
        None => (0.0, 2.0 * rpm(scene.operating.input_speed)),
    }
}

/// The rays of `scene`: mesh orders `mesh_orders` of each mesh (meshes with the same mesh
/// frequency, as both meshes of an idler, share theirs) and the input shaft's order 1.
pub fn rays(scene: &Scene, mesh_orders: &[f64]) -> Vec<(String, f64)> {
    let mut distinct: Vec<(Vec<&str>, f64)> = Vec::new();
    for m in &scene.meshes {
        let z = m.cycles_per_input_rev;
        match distinct.iter_mut().find(|(_, o)| (o - z).abs() <= 1e-9 * z) {
            Some((names, _)) => names.push(&m.name),
            None => distinct.push((vec![&m.name], z)),
        }
    }
    let single = distinct.len() == 1;
    let mut out = Vec::new();
    for (names, z) in &distinct {
        for &k in mesh_orders {
            let who = if single {
                "mesh".to_string()
            } else {
                names.join("/")
            };
            out.push((
                format!("{who} order {k} ({}×)", super::runup::order_text(k * z)),
                k * z,
            ));
        }
    }
    out.push(("input shaft order 1 (1×)".into(), 1.0));
    out
}

/// Draws the Campbell diagram of `scene` over `rpm` with the elastic modes of `modes` to
/// `path`, and returns the report: each critical speed in the range.
pub fn campbell(
    scene: &Scene,
    modes: &Modes,
    rpm: Option<(f64, f64)>,
    path: &Path,
) -> Result<String, String> {
    crate::plot::Format::of(path)?;
    let rpm = rpm.unwrap_or_else(|| default_rpm(scene));
    let elastic: Vec<(String, f64)> = (modes.modes.iter().enumerate())
        .filter(|(_, m)| !m.rigid)
        .map(|(i, m)| {
            (
                format!("mode {}: {:.0} Hz", i + 1, m.frequency),
                m.frequency,
            )
        })
        .collect();
    let title = format!("{}: Campbell diagram", scene.name);
    let diagram = Campbell {
        title: &title,
        rpm,
        modes: elastic,
        orders: rays(scene, &[1.0, 2.0, 3.0]),
    };
    diagram.save(path)?;
    let top = diagram.top();
    let mut text = format!(
        "Campbell diagram → {} ({:.0}–{:.0} rpm, up to {:.0} Hz)\n",
        path.display(),
        rpm.0,
        rpm.1,
        top
    );
    let above = diagram.modes.iter().filter(|m| m.1 > top).count();
    if above > 0 {
        let _ = writeln!(text, "  {above} mode(s) above {top:.0} Hz are not drawn");
    }
    for c in diagram.crossings() {
        let _ = writeln!(
            text,
            "  critical speed {:>8.0} rpm ({:>8.2} rad/s): {} meets {} ({:.1} Hz)",
            c.rpm,
            c.rpm * std::f64::consts::TAU / 60.0,
            diagram.orders[c.order].0,
            diagram.modes[c.mode].0.split(':').next().unwrap_or(""),
            c.frequency
        );
    }
    Ok(text)
}
