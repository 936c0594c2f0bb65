//! Outputs of `geardyn stiffness`: the curve as CSV rows, an SVG plot, and a text summary
//! (geometry, contact extents, mean, per-unit-width value, Fourier coefficients, ETC angles vs
//! eq. (6), iteration counts).

use std::f64::consts::TAU;
use std::fmt::Write;

use super::{fillet, MeshModel, StiffnessCurve};
use std::path::Path;

use crate::plot::{Axis, Plot, Series};

/// CSV column names for a curve whose high zone has `pairs` pairs.
pub fn csv_names(pairs: usize) -> Vec<String> {
    let mut names: Vec<String> = [
        "phase",
        "pinion.angle",
        "stiffness",
        "deflection",
        "pairs_loaded",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    names.extend((1..=pairs).map(|i| format!("force_{i}")));
    names
}

/// One row per knot; a jump appears as two rows at the same phase. Forces are padded with 0
/// for the zone with fewer pairs.
pub fn csv_rows(curve: &StiffnessCurve) -> Vec<Vec<f64>> {
    let pairs = curve.low_pairs + 1;
    let theta_m = TAU / curve.teeth as f64;
    curve
        .knots()
        .map(|k| {
            let loaded = k.forces.iter().filter(|&&f| f > 0.0).count();
            let mut row = vec![
                k.phase,
                k.phase * theta_m,
                k.stiffness,
                k.deflection,
                loaded as f64,
            ];
            row.extend((0..pairs).map(|i| k.forces.get(i).copied().unwrap_or(0.0)));
            row
        })
        .collect()
}

/// The plot of one or more curves (e.g. with and without ETC) over the mesh phase, the
/// more-pairs zone of the first curve shaded, written to `path` (PNG or SVG by its extension).
pub fn plot(curves: &[(&str, &StiffnessCurve)], title: &str, path: &Path) -> Result<(), String> {
    let colors = ["#1f4e9c", "#c0392b", "#2e8b57", "#8e44ad"];
    let series = curves
        .iter()
        .zip(colors.iter().cycle())
        .enumerate()
        .map(|(i, ((label, c), color))| Series {
            label,
            color,
            // Wrapped onto [0, 1) through the pieces, so jumps show as vertical segments.
            points: c
                .pieces()
                .iter()
                .flat_map(|p| [(p.start, p.k_start), (p.end, p.value(p.end))])
                .collect(),
            // Later curves dashed, so that coinciding curves stay visible.
            dashed: i > 0,
            markers: false,
            line: true,
        })
        .collect();
    let bands = curves
        .first()
        .map(|(_, c)| vec![(0.0, c.exit), (c.entry, 1.0)])
        .unwrap_or_default();
    Plot {
        title,
        x: Axis::new(
            "mesh phase s (pinion angle / (2π/z1)); s = 0: end of multiple contact",
            "",
        ),
        y: Axis::new("mesh stiffness K", "N/m"),
        series,
        bands,
        band_label: "more pairs in contact",
        markers: Vec::new(),
    }
    .save(path)
}

/// The text summary.
pub fn summary(model: &MeshModel, curve: &StiffnessCurve, harmonics: usize) -> String {
    let p = &model.pair;
    let mut s = String::new();
    let w = p.pinion.face_width;
    let mean = curve.mean();
    let _ = writeln!(
        s,
        "gear pair z1/z2 = {}/{}, m = {} mm, α = {:.3}°, α_w = {:.4}°, a = {:.6} mm, L = {} mm",
        p.pinion.teeth,
        p.gear.teeth,
        p.pinion.module * 1e3,
        p.pinion.alpha.to_degrees(),
        p.alpha_w.to_degrees(),
        p.center_distance * 1e3,
        w * 1e3
    );
    for (name, g) in [("pinion", &p.pinion), ("gear", &p.gear)] {
        let _ = writeln!(
            s,
            "  {name:6} r_b = {:.4} mm, r_a = {:.4} mm, r_f = {:.4} mm, r_form = {:.4} mm, θ_b = {:.5} rad, θ_f = {:.5} rad",
            g.r_base * 1e3,
            g.r_tip * 1e3,
            g.r_root * 1e3,
            g.r_form * 1e3,
            g.theta_b,
            g.theta_f
        );
    }
    for (name, c) in ["pinion", "gear"].iter().zip(model.fillet_coefficients()) {
        let _ = writeln!(
            s,
            "  {name:6} Sainsot L* = {:.4}, M* = {:.4}, P* = {:.4}, Q* = {:.4}{}",
            c[0],
            c[1],
            c[2],
            c[3],
            if fillet::within_fitted_range(c) {
                ""
            } else {
                " (outside the fitted ranges: extrapolated)"
            }
        );
    }
    let _ = writeln!(
        s,
        "contact ratio ε = {:.6} (path of contact {:.4} mm, base pitch {:.4} mm)",
        p.contact_ratio,
        (p.x_end - p.x_start) * 1e3,
        p.base_pitch * 1e3
    );
    let _ = writeln!(
        s,
        "torque T = {} N·m, W = T/r_b1 = {:.3} N, ETC {}, Hertz {:?}",
        curve.options.torque,
        curve.load,
        if curve.options.etc { "on" } else { "off" },
        model.hertz.law
    );
    let _ = writeln!(
        s,
        "zones (mesh cycles): {} pair(s) on [{:.6}, {:.6}) = {:.6}, {} pair(s) on [{:.6}, {:.6}) = {:.6} (theoretical {:.6} / {:.6})",
        curve.low_pairs,
        curve.exit,
        curve.entry,
        curve.low_extent(),
        curve.low_pairs + 1,
        curve.entry,
        1.0 + curve.exit,
        curve.high_extent(),
        curve.theoretical_entry,
        1.0 - curve.theoretical_entry,
    );
    if let Some((entry, exit)) = curve.etc_bounds {
        let _ = writeln!(
            s,
            "ETC early entry β2 − φ1 = {:.6e} rad (eq. 6: {:.6e}, rel. diff {:.2e}); late exit φ2 − β3 = {:.6e} rad (eq. 6: {:.6e}, rel. diff {:.2e})",
            entry.solved,
            entry.eq6,
            entry.relative_error(),
            exit.solved,
            exit.eq6,
            exit.relative_error()
        );
    }
    let (kmin, kmax) = curve.knots().fold((f64::INFINITY, 0.0f64), |(lo, hi), k| {
        (lo.min(k.stiffness), hi.max(k.stiffness))
    });
    let _ = writeln!(
        s,
        "mean stiffness K0 = {mean:.6e} N/m ({:.4} N/(mm·µm) per unit face width), min {kmin:.6e}, max {kmax:.6e} N/m",
        mean / w * 1e-9
    );
    let _ = writeln!(s, "Fourier (k = K0 + Σ a_h cos 2πhs + b_h sin 2πhs):");
    for (h, (a, b)) in curve.fourier(harmonics).iter().enumerate() {
        let _ = writeln!(
            s,
            "  h = {}: a = {a:+.6e}, b = {b:+.6e}, |K_h| = {:.6e} N/m, ψ_h = {:+.5} rad",
            h + 1,
            a.hypot(*b),
            b.atan2(*a)
        );
    }
    let _ = writeln!(
        s,
        "load sharing: {} knots, Hertz fixed point converged in at most {} iterations",
        curve.low.len() + curve.high.len(),
        curve.max_iterations()
    );
    s
}
