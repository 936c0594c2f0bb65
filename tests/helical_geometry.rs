//! Issue 6 part A, acceptance 3 and 6 (geometry side): the helical contact-line geometry and
//! the effective mesh stiffness with friction of He & Singh 2007, on the paper's NASA-ART pair
//! in its own units (in, lb; the geometry is unit-agnostic).
//!
//! Oracles: the derived numbers of `shared/reference/models-he-singh-2007.md` (§1.2 landmarks,
//! §2.5 breakpoints and normalised K_e, computed there independently), a brute-force
//! quadrature over the face width that counts the lines crossing each height (independent of
//! the clipping code), and the closed forms of the symmetric trapezoid (μ = 0) and of the
//! rectangular spur stiffness (β = 0).

use geardyn::mesh::helical::{
    FrictionStiffness, HelicalGearSpec, HelicalGeometry, HelicalPairSpec, HelixAngleReference,
};
use geardyn::mesh::MeshStiffness;

const J_P: f64 = 8.33e-3;
const J_G: f64 = 1.64e-2;

fn nasa_art(reference: HelixAngleReference, helix: f64) -> HelicalPairSpec {
    HelicalPairSpec {
        transverse_module: None,
        transverse_diametral_pitch: Some(8.0),
        transverse_pressure_angle: 25.0,
        helix_angle: helix,
        helix_angle_reference: reference.as_str().to_owned(),
        face_width: 1.25,
        centre_distance: Some(3.5),
        pinion: HelicalGearSpec {
            teeth: 25,
            outside_diameter: Some(3.38),
            root_diameter: Some(2.811),
        },
        gear: HelicalGearSpec {
            teeth: 31,
            outside_diameter: Some(4.13),
            root_diameter: Some(3.561),
        },
    }
}

fn geometry(reference: HelixAngleReference) -> HelicalGeometry {
    HelicalGeometry::new(&nasa_art(reference, 21.5), "helical.").expect("paper geometry")
}

fn params(mu: f64) -> FrictionStiffness {
    FrictionStiffness {
        density: 1.0,
        friction: mu,
        pinion_inertia: J_P,
        gear_inertia: J_G,
    }
}

fn close(a: f64, b: f64, tol: f64, what: &str) {
    assert!(
        (a - b).abs() <= tol,
        "{what}: {a} vs {b} (|Δ| = {:e})",
        (a - b).abs()
    );
}

#[test]
fn landmarks_match_the_standard_involute_relations() {
    let g = geometry(HelixAngleReference::Pitch);
    // Notes §1.2.
    close(g.pinion.base_radius, 1.416106, 1e-6, "r_bp");
    close(g.gear.base_radius, 1.755971, 1e-6, "r_bg");
    close(g.base_pitch, 0.355906, 1e-6, "λ");
    close(g.x_g, 1.479164, 1e-6, "x_g");
    close(g.l_t1a, 0.392522, 1e-6, "L_T1A");
    close(g.l_t1p, 0.660341, 1e-6, "L_T1P");
    close(g.l_t1d, 0.922358, 1e-6, "L_T1D");
    close(g.transverse_contact_ratio(), 1.4887, 1e-4, "ε_α");
    close(g.base_helix_angle.to_degrees(), 19.647, 1e-3, "β_b");
    close(g.helix_advance(), 0.446255, 1e-6, "W tan β_b");
    close(g.total_contact_ratio(), 2.7425, 1e-4, "ε pitch reading");
    assert_eq!(g.pairs_tracked(), 3, "the paper tracks 3 pairs");
    let b = geometry(HelixAngleReference::Base);
    close(b.helix_advance(), 0.492388, 1e-6, "W tan 21.5°");
    close(b.total_contact_ratio(), 2.872, 1e-3, "ε base reading");
}

#[test]
fn breakpoints_are_the_region_boundaries() {
    // Notes §2.5 (t_j/T, sorted); 0 is always a breakpoint.
    for (reference, expected) in [
        (
            HelixAngleReference::Pitch,
            [0.0, 0.00635, 0.25386, 0.48869, 0.74255, 0.75250],
        ),
        (
            HelixAngleReference::Base,
            [0.0, 0.13597, 0.38348, 0.48869, 0.75250, 0.87217],
        ),
    ] {
        let points = geometry(reference).breakpoints();
        assert_eq!(points.len(), 6, "{reference:?}: {points:?}");
        for (s, e) in points.iter().zip(expected) {
            close(*s, e, 6e-6, &format!("{reference:?} breakpoint"));
        }
    }
}

#[test]
fn contact_lines_follow_the_paper_zone_limits() {
    let g = geometry(HelixAngleReference::Base);
    let (half, t) = (0.625, g.base_helix_angle.tan());
    // Region 3 of Table 1 (s between 0.38348 and 0.48869): Z1, Z4, Z7.
    let s = 0.43;
    let lines = g.pair_lines(s);
    assert_eq!(lines.len(), 3);
    let x0 = g.l_t1a + s * g.base_pitch;
    let (x1, x2) = (x0 + g.base_pitch, x0 + 2.0 * g.base_pitch);
    let z1 = lines[0];
    close(z1.x_m, g.l_t1a, 1e-12, "Z1 x_m");
    close(z1.x_f, x0, 1e-12, "Z1 x_f");
    close(z1.z_m, half - (x0 - g.l_t1a) / t, 1e-12, "Z1 z_m");
    close(z1.z_p, z1.z_f, 0.0, "Z1 all approach");
    let z4 = lines[1];
    close(z4.x_m, x1 - g.face_width * t, 1e-12, "Z4 x_m");
    close(z4.z_m, -half, 1e-12, "Z4 z_m");
    close(z4.z_f, half, 1e-12, "Z4 z_f");
    close(z4.z_p, half - (x1 - g.l_t1p) / t, 1e-12, "Z4 z_p");
    let z7 = lines[2];
    close(z7.x_f, g.l_t1d, 1e-12, "Z7 x_f");
    close(z7.z_f, half - (x2 - g.l_t1d) / t, 1e-12, "Z7 z_f");
    close(z7.z_p, z7.z_m, 0.0, "Z7 all recess");
    // The split integrals add up, and the moment is the mean arm times the length.
    let i = z4.integrals();
    close(
        i.approach_length + i.recess_length,
        i.length,
        1e-15,
        "split",
    );
    close(
        i.approach_moment + i.recess_moment,
        0.5 * (z4.x_m + z4.x_f) * i.length,
        1e-14,
        "∫x dz",
    );
}

/// Brute force: at each height z (midpoint rule) every pair whose line lies inside
/// [L_T1A, L_T1D] there contributes dz to the length and sgn(x − x_p)·x dz to the friction arm.
fn brute_force(g: &HelicalGeometry, s: f64, n: usize) -> (f64, f64, f64) {
    let (w, t) = (g.face_width, g.base_helix_angle.tan());
    let dz = w / n as f64;
    let (mut length, mut arm_p, mut arm_g) = (0.0, 0.0, 0.0);
    for j in 0..n {
        let z = -0.5 * w + (j as f64 + 0.5) * dz;
        for i in 0..6 {
            let x = g.l_t1a + (s + i as f64) * g.base_pitch - (0.5 * w - z) * t;
            if x >= g.l_t1a && x <= g.l_t1d {
                let sign = if x > g.l_t1p { 1.0 } else { -1.0 };
                length += dz;
                arm_p += sign * x * dz;
                arm_g += sign * (g.x_g - x) * dz;
            }
        }
    }
    (length, arm_p, arm_g)
}

#[test]
fn stiffness_matches_brute_force_quadrature() {
    for reference in [HelixAngleReference::Pitch, HelixAngleReference::Base] {
        let g = geometry(reference);
        let cos_b = g.base_helix_angle.cos();
        let (rp, rg) = (g.pinion.base_radius, g.gear.base_radius);
        for mu in [0.0, 0.2, 0.4] {
            for k in 0..23 {
                let s = (k as f64 + 0.37) / 23.0;
                let (length, arm_p, arm_g) = brute_force(&g, s, 200_000);
                let kp = (rp * cos_b * length + mu * arm_p) / rp;
                let kg = (rg * cos_b * length + mu * arm_g) / rg;
                let got = g.stiffness_at(s, &params(mu));
                close(got.pinion, kp, 2e-5, "K_p");
                close(got.gear, kg, 2e-5, "K_g");
                let ke =
                    (rp * rp * J_G * kp + rg * rg * J_P * kg) / (rg * rg * J_P + rp * rp * J_G);
                close(got.effective, ke, 2e-5, "K_e");
            }
        }
    }
}

#[test]
fn normalised_stiffness_at_breakpoints_matches_the_notes() {
    let table = [
        (
            HelixAngleReference::Pitch,
            [
                [0.93354, 0.93694, 1.06954, 1.06954, 0.93354, 0.93354],
                [0.94894, 0.95272, 1.07347, 1.07347, 0.92271, 0.92269],
                [0.96435, 0.96850, 1.07741, 1.07741, 0.91187, 0.91184],
            ],
        ),
        (
            HelixAngleReference::Base,
            [
                [0.90901, 0.97503, 1.09520, 1.09520, 0.96711, 0.90901],
                [0.91688, 0.99021, 1.09952, 1.09952, 0.95735, 0.90445],
                [0.92475, 1.00539, 1.10384, 1.10384, 0.94758, 0.89989],
            ],
        ),
    ];
    for (reference, rows) in table {
        let g = geometry(reference);
        let scale = g.piecewise_stiffness(&params(0.0), 0.0).mean();
        let points = g.breakpoints();
        for (mu, row) in [0.0, 0.2, 0.4].into_iter().zip(rows) {
            for (s, expected) in points.iter().zip(row) {
                let v = g.stiffness_at(*s, &params(mu)).effective / scale;
                close(
                    v,
                    expected,
                    6e-5,
                    &format!("{reference:?} μ = {mu} s = {s}"),
                );
            }
        }
    }
}

#[test]
fn linear_interpolation_deviates_little_from_the_exact_quadratic_stiffness() {
    for reference in [HelixAngleReference::Pitch, HelixAngleReference::Base] {
        let g = geometry(reference);
        for (mu, bound) in [(0.0, 1e-12), (0.2, 2e-4), (0.4, 2e-4)] {
            let linear = g.piecewise_stiffness(&params(mu), 0.0);
            let mean = linear.mean();
            let worst = (0..4000)
                .map(|i| {
                    let s = (i as f64 + 0.5) / 4000.0;
                    (linear.value(s) - g.stiffness_at(s, &params(mu)).effective).abs() / mean
                })
                .fold(0.0, f64::max);
            println!("{reference:?} μ = {mu}: max |K_lin − K_exact| / mean = {worst:.3e}");
            assert!(worst < bound, "{reference:?} μ = {mu}: {worst:e}");
            if mu > 0.0 {
                assert!(
                    worst > 1e-7,
                    "friction makes K_e quadratic between breakpoints"
                );
            }
        }
    }
}

#[test]
fn without_friction_the_stiffness_is_a_symmetric_trapezoid() {
    for reference in [HelixAngleReference::Pitch, HelixAngleReference::Base] {
        let g = geometry(reference);
        let k = g.piecewise_stiffness(&params(0.0), 0.0);
        let pieces = k.pieces().unwrap();
        // K_p = K_g = K_e = k cos β_b Δz when μ = 0 (notes §2.5).
        let s = 0.3;
        let st = g.stiffness_at(s, &params(0.0));
        close(st.pinion, st.gear, 1e-14, "K_p = K_g");
        close(st.pinion, st.effective, 1e-14, "K_p = K_e");
        // Mean: k cos β_b W ε_α (every point of the zone is swept once per λ).
        close(
            k.mean(),
            g.base_helix_angle.cos() * g.face_width * g.transverse_contact_ratio(),
            1e-12,
            "mean",
        );
        // Symmetric about the centre of the upper plateau.
        let top = pieces
            .iter()
            .filter(|p| p.slope == 0.0 || p.slope.abs() < 1e-9)
            .max_by(|a, b| a.k_start.total_cmp(&b.k_start))
            .expect("a plateau");
        let c = 0.5 * (top.start + top.end);
        for i in 1..200 {
            let u = i as f64 / 400.0;
            close(k.value(c + u), k.value(c - u), 1e-12, "symmetry");
        }
        // Exactly two distinct non-zero slopes ±a and two levels.
        let slopes: Vec<f64> = pieces
            .iter()
            .map(|p| p.slope)
            .filter(|s| s.abs() > 1e-9)
            .collect();
        let a = slopes[0].abs();
        assert!(slopes.iter().all(|s| (s.abs() - a).abs() < 1e-9 * a));
    }
}

#[test]
fn without_helix_the_stiffness_is_the_rectangular_spur_wave() {
    let g = HelicalGeometry::new(&nasa_art(HelixAngleReference::Pitch, 0.0), "").unwrap();
    assert_eq!(g.overlap_ratio(), 0.0);
    let eps = g.transverse_contact_ratio();
    let w = g.face_width;
    let k = g.piecewise_stiffness(&params(0.0), 0.0);
    // One pair: k W; two pairs: 2 k W; two pairs on [0, ε_α − 1) (pair 0 just entered at A).
    let f = eps - eps.floor();
    let spur = MeshStiffness::rectangular(w * eps, 1.0 / eps, eps, 1.0 - f);
    for i in 0..1000 {
        let s = (i as f64 + 0.5) / 1000.0;
        if (s - f).abs() < 1e-3 {
            continue;
        }
        close(k.value(s), spur.value(s), 1e-12, "spur");
        close(
            g.stiffness_at(s, &params(0.0)).effective,
            spur.value(s),
            1e-12,
            "spur exact",
        );
    }
}

#[test]
fn bad_geometry_is_rejected_naming_field_and_value() {
    let p = HelixAngleReference::Pitch;
    type Edit = Box<dyn Fn(&mut HelicalPairSpec)>;
    let cases: Vec<(Edit, &str)> = vec![
        (Box::new(|s| s.helix_angle = 90.0), "h.helix_angle = 90"),
        (Box::new(|s| s.helix_angle = -1.0), "h.helix_angle = -1"),
        (
            Box::new(|s| s.helix_angle = f64::NAN),
            "h.helix_angle = NaN",
        ),
        (Box::new(|s| s.face_width = 0.0), "h.face_width = 0"),
        (Box::new(|s| s.face_width = -1.25), "h.face_width = -1.25"),
        (
            Box::new(|s| s.centre_distance = Some(3.6)),
            "h.centre_distance = 3.6",
        ),
        (Box::new(|s| s.pinion.teeth = 3), "h.pinion.teeth = 3"),
        (
            Box::new(|s| s.helix_angle_reference = "normal".into()),
            "h.helix_angle_reference = \"normal\"",
        ),
        (
            Box::new(|s| s.transverse_pressure_angle = 50.0),
            "h.transverse_pressure_angle = 50",
        ),
        (
            Box::new(|s| s.transverse_module = Some(0.125)),
            "h.transverse_module and h.transverse_diametral_pitch",
        ),
        (
            Box::new(|s| s.transverse_diametral_pitch = Some(0.0)),
            "h.transverse_diametral_pitch = 0",
        ),
        (
            Box::new(|s| s.gear.outside_diameter = Some(3.8)),
            "h.gear.outside_diameter = 3.8",
        ),
        (
            Box::new(|s| s.pinion.root_diameter = Some(2.95)),
            "h.pinion.root_diameter = 2.95",
        ),
    ];
    for (edit, expected) in cases {
        let mut spec = nasa_art(p, 21.5);
        edit(&mut spec);
        let err = HelicalGeometry::new(&spec, "h.").unwrap_err();
        assert!(err.contains(expected), "expected '{expected}' in: {err}");
    }
}
