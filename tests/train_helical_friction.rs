//! He & Singh (2007) 6-DOF helical pair with sliding friction in the drivetrain graph (issue 6,
//! part B, acceptance 4): per-tooth-pair stiffness `k cos β_b Δz` and friction distributed along
//! the contact lines (eqs. 7, 10; restoring signs of notes §2.4 [SIGN]) on a mesh between two
//! gears with bearings (x along the line of action, y off it, θ_z). As the bearings stiffen the
//! DTE must approach the SDOF torsional model of eq. (24), `m_e δ̈ + K_e(t) δ = F_e`, whose
//! `K_e` comes from the helical geometry module's own closed form (`K_p`, `K_g` of eqs. 18–21,
//! inertia-weighted), integrated here by a fixed-step RK4.
//!
//! Data: the NASA-ART pair of the paper (notes §1, SI conversions §1.1), μ = 0.2,
//! T_p = 2000 lb·in, 1000 rpm, undamped (as every result of the paper), stiffness density
//! k = 8.23e5 lb/in² (notes §3 calibration: f_n ≈ 9.5 f_mesh).

use std::f64::consts::TAU;

use geardyn::mesh::helical::{FrictionStiffness, HelicalGeometry, HelicalPairSpec};
use geardyn::model::train::{run_train, GearTrain};
use geardyn::scene::PairScene;
use geardyn::scene::Scene;
use geardyn::simulation::Simulation;

const GEOMETRY: &str = r#"
transverse_diametral_pitch = 314.96062992125985   # 8 per inch
transverse_pressure_angle = 25.0
helix_angle = 21.5
helix_angle_reference = "pitch"
face_width = 0.03175                              # 1.25 in
centre_distance = 0.0889                          # 3.5 in
[pinion]
teeth = 25
outside_diameter = 0.085852                       # 3.38 in
[gear]
teeth = 31
outside_diameter = 0.104902                       # 4.13 in
"#;

const DENSITY: f64 = 8.23e5 * 6894.757293168; // lb/in² → N/m²
const MU: f64 = 0.2;
const J_P: f64 = 8.33e-3 * 0.1129848290276167;
const J_G: f64 = 1.64e-2 * 0.1129848290276167;
const M_P: f64 = 1.26e-2 * 175.12683524647636;
const M_G: f64 = 1.58e-2 * 175.12683524647636;
const T_P: f64 = 2000.0 * 0.1129848290276167;
const RPM: f64 = 1000.0;

fn geometry() -> HelicalGeometry {
    let spec: HelicalPairSpec = toml::from_str(GEOMETRY).unwrap();
    HelicalGeometry::new(&spec, "").unwrap()
}

/// The pair as a drivetrain scene; `bearing = None` means rigid bearings.
fn scene(bearing: Option<f64>) -> Scene {
    let g = geometry();
    let bearings = |m: f64| match bearing {
        Some(k) => format!("mass = {m:?}\nbearing_stiffness = [{k:?}, {k:?}]\n"),
        None => String::new(),
    };
    let geometry_tables = GEOMETRY
        .replace("[pinion]", "[mesh.pairs.geometry.pinion]")
        .replace("[gear]", "[mesh.pairs.geometry.gear]");
    let alpha = 25f64.to_radians();
    let gears = gear_blocks(&g, &bearings(M_P), &bearings(M_G));
    // The mesh's pressure angle is in degrees, as the geometry's transverse one.
    let alpha_deg = 25.0f64;
    let text = format!(
        r#"
name = "nasa_art_helical"
[model]
bearings = "{}"
{gears}
[[mesh]]
pinion = "pinion"
gear = "gear"
contact = "linear"
model = "pairs"
pressure_angle = {alpha_deg:?}
centre_angle = {:?}
[mesh.pairs]
kind = "helical"
density = {DENSITY:?}
[mesh.pairs.geometry]
{geometry_tables}
[mesh.friction]
coefficient = {MU:?}
[operating]
input_speed = {:?}
input_torque = {T_P:?}
{SOLVER}
"#,
        if bearing.is_some() {
            "compliant"
        } else {
            "rigid"
        },
        -alpha,
        RPM * TAU / 60.0,
    );
    Scene::from_toml_str(&text, "helical").unwrap()
}

fn params() -> FrictionStiffness {
    FrictionStiffness {
        density: DENSITY,
        friction: MU,
        pinion_inertia: J_P,
        gear_inertia: J_G,
    }
}

/// `K_e` of the geometry module at the graph's mesh phase `p`. The graph's cycle starts where
/// the number of pairs drops (docs/train.md: slot j holds the pair at window position
/// `ξ = s + c − 1 − j`); the geometry's phase `s_h` has pair i at `ξ = s_h + i`, so
/// `s_h = frac(p + c − 1)`.
fn k_e(g: &HelicalGeometry, p: f64) -> f64 {
    let c = g.total_contact_ratio();
    g.stiffness_at((p + c - 1.0).rem_euclid(1.0), &params())
        .effective
}

/// The SDOF model (eq. 24, C_e = 0, ε = 0) by classical RK4 with `n` steps per mesh period.
fn sdof(delta0: f64, f_mesh: f64, times: &[f64], n: usize) -> Vec<f64> {
    let g = geometry();
    let r_bp = g.pinion.base_radius;
    let r_bg = g.gear.base_radius;
    let m_e = J_P * J_G / (r_bg * r_bg * J_P + r_bp * r_bp * J_G);
    let f_e = T_P / r_bp;
    let acc = |t: f64, x: f64| (f_e - k_e(&g, f_mesh * t) * x) / m_e;
    let h = 1.0 / (f_mesh * n as f64);
    let (mut t, mut x, mut v) = (0.0, delta0, 0.0);
    let mut out = Vec::with_capacity(times.len());
    for &target in times {
        while t < target - 1e-12 * h {
            let step = h.min(target - t);
            let (k1x, k1v) = (v, acc(t, x));
            let (k2x, k2v) = (
                v + 0.5 * step * k1v,
                acc(t + 0.5 * step, x + 0.5 * step * k1x),
            );
            let (k3x, k3v) = (
                v + 0.5 * step * k2v,
                acc(t + 0.5 * step, x + 0.5 * step * k2x),
            );
            let (k4x, k4v) = (v + step * k3v, acc(t + step, x + step * k3x));
            x += step / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
            v += step / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
            t += step;
        }
        out.push(x);
    }
    out
}

#[test]
fn rigid_bearing_statics_give_the_geometry_stiffness() {
    // One elastic coordinate: the frozen statics give δ = F_e/K_e(s) with the friction moments
    // of the contact-line integrals; K_e is the geometry module's closed form.
    let g = geometry();
    for p in [0.0, 0.1, 0.37, 0.5, 0.74, 0.9] {
        let mut sc = scene(None);
        sc.meshes[0].initial_phase = p;
        let train = GearTrain::new(&sc).unwrap();
        let st = train.frozen_equilibrium(0.0).unwrap();
        let delta = st.xi[0] * train.mesh_row(0)[0];
        let closed = T_P / g.pinion.base_radius / k_e(&g, p);
        println!("p = {p}: δ = {delta:e} m, F_e/K_e = {closed:e} m");
        assert!(
            (delta - closed).abs() < 1e-12 * closed,
            "{delta} vs {closed}"
        );
    }
}

#[test]
fn six_dof_approaches_sdof_as_bearings_stiffen() {
    let f_mesh = 25.0 * RPM / 60.0;
    let periods = 5.0;
    let (stop, dt) = (periods / f_mesh, 0.02 / f_mesh);
    let mut errors = Vec::new();
    let mut cases: Vec<Option<f64>> = [1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14].map(Some).to_vec();
    cases.push(None);
    println!("6-DOF vs SDOF DTE over {periods} mesh periods (μ = {MU}, undamped):");
    for kb in cases {
        let sc = scene(kb);
        let run = run_train(&sc, stop, dt).unwrap();
        let col = run.column("mesh1.dte").unwrap();
        let dte: Vec<f64> = run.rows.iter().map(|r| r[col]).collect();
        let reference = sdof(dte[0], f_mesh, &run.times, 20_000);
        let scale = reference.iter().fold(0.0f64, |a, b| a.max(b.abs()));
        let err = dte
            .iter()
            .zip(&reference)
            .fold(0.0f64, |a, (x, y)| a.max((x - y).abs()))
            / scale;
        let label = kb.map_or("rigid".to_owned(), |k| format!("{k:.0e} N/m"));
        let y = run.column("pinion.y").map_or(0.0, |c| {
            run.rows.iter().fold(0.0f64, |a, r| a.max(r[c].abs()))
        });
        println!("  bearings {label:>10}: max |DTE_6dof − DTE_sdof| / max|DTE| = {err:.3e}  (max |pinion.y| {y:.2e} m)");
        errors.push(err);
    }
    for w in errors[..7].windows(2) {
        assert!(
            w[1] < w[0],
            "the error must fall as the bearings stiffen: {errors:?}"
        );
    }
    // Once k_b ≫ k_mesh the compliance enters as k_mesh/k_b: a decade per decade of k_b.
    for w in errors[3..7].windows(2) {
        assert!(w[1] < 0.15 * w[0], "not first order in 1/k_b: {errors:?}");
    }
    assert!(errors[6] < 1e-4, "stiffest bearings: {}", errors[6]);
    // Rigid bearings: the graph model is the SDOF model (up to the integrators' tolerances).
    assert!(errors[7] < 1e-8, "rigid bearings: {}", errors[7]);
}

#[test]
fn bad_helical_friction_input_is_rejected() {
    let text = |from: &str, to: &str| {
        let sc = scene(Some(1e9));
        let mut t = sc.source.clone();
        assert!(t.contains(from), "{from}");
        t = t.replacen(from, to, 1);
        Scene::from_toml_str(&t, "t").unwrap_err().0
    };
    let msg = text(
        "coefficient = 0.2",
        "coefficient = 0.2\nbending_factor = 0.5",
    );
    assert!(
        msg.contains("mesh[0].friction.bending_factor = 0.5") && msg.contains("helical"),
        "{msg}"
    );
    let msg = text("coefficient = 0.2", "coefficient = 0.2\npitch_point = 1.0");
    assert!(
        msg.contains("mesh[0].friction.pitch_point = 1") && msg.contains("geometry"),
        "{msg}"
    );
    let msg = text("coefficient = 0.2", "coefficient = -0.2");
    assert!(msg.contains("mesh[0].friction.coefficient = -0.2"), "{msg}");
    let r = geometry().pinion.base_radius;
    let msg = text(
        &format!("base_radius = {r:?}"),
        &format!("base_radius = {:?}", r * 1.000001),
    );
    assert!(
        msg.contains("mesh[0].pairs.geometry") && msg.contains("base radius"),
        "{msg}"
    );
    let msg = text("density = ", "density = -");
    assert!(msg.contains("mesh[0].pairs.density = -"), "{msg}");
    let msg = text("helix_angle = 21.5", "helix_angle = 95.0");
    assert!(
        msg.contains("mesh[0].pairs.geometry.helix_angle = 95"),
        "{msg}"
    );
    // The single-mesh `[mesh.stiffness] kind = "helical"` source is not a graph source.
    let lumped = sc_text_lumped();
    let msg = Scene::from_toml_str(&lumped, "t").unwrap_err().0;
    assert!(
        msg.contains("mesh[0].stiffness.kind = \"helical\""),
        "{msg}"
    );
    let msg = text("pressure_angle = 25.0", "pressure_angle = 24.0");
    assert!(
        msg.contains("mesh[0].pairs.geometry.transverse_pressure_angle") && msg.contains("24"),
        "{msg}"
    );
}

/// Both scenes' solver: DOP853 at a tolerance far below the compared differences.
const SOLVER: &str = "[solver]\nmethod = \"rk\"\nrk_method = \"dop853\"\nrtol = 1e-11";

/// The NASA-ART pinion and gear (`extra_*`: further lines of each `[[gear]]` table).
fn gear_blocks(g: &HelicalGeometry, extra_pinion: &str, extra_gear: &str) -> String {
    format!(
        "[[gear]]\nname = \"pinion\"\nteeth = 25\nbase_radius = {:?}\ninertia = {J_P:?}\n{extra_pinion}\n\
         [[gear]]\nname = \"gear\"\nteeth = 31\nbase_radius = {:?}\ninertia = {J_G:?}\n{extra_gear}",
        g.pinion.base_radius, g.gear.base_radius
    )
}

/// The single-mesh SDOF scene of the helical module (`[mesh.stiffness] kind = "helical"`:
/// He & Singh's eq. 24 with the piecewise-linear K_e of eq. 25) for the same pair, its phase
/// shifted to the graph's reference (`s = frac(p + phase)`, `phase = c − 1`, see [`k_e`]).
fn single_mesh_text(delta0: f64) -> String {
    let g = geometry();
    let phase = g.total_contact_ratio() - 1.0;
    let tables = GEOMETRY
        .replace("[pinion]", "[mesh.stiffness.helical.pinion]")
        .replace("[gear]", "[mesh.stiffness.helical.gear]");
    let gears = gear_blocks(&g, "", "");
    format!(
        r#"
name = "nasa_art_sdof"
{gears}
[mesh]
pinion = "pinion"
gear = "gear"
contact = "linear"
[mesh.stiffness]
kind = "helical"
stiffness_density = {DENSITY:?}
friction_coefficient = {MU:?}
phase = {phase:?}
[mesh.stiffness.helical]
{tables}
[operating]
pinion_speed = {:?}
input_torque = {T_P:?}
[initial]
dte = {delta0:?}
{SOLVER}
"#,
        RPM * TAU / 60.0,
    )
}

fn sc_text_lumped() -> String {
    single_mesh_text(2.5e-5).replace("[mesh]\n", "[model]\nbearings = \"rigid\"\n[[mesh]]\n")
}

#[test]
fn six_dof_approaches_the_single_mesh_helical_model() {
    // The shipped single-mesh SDOF (`geardyn::Simulation`, K_e linear between the region
    // boundaries, eq. 25): the 6-DOF converges to it down to the linearisation of K_e
    // (< 2e-4 of the mean for these data, notes §2.5).
    let f_mesh = 25.0 * RPM / 60.0;
    let n = 100;
    let dt = 0.05 / f_mesh;
    println!("6-DOF vs the single-mesh helical SDOF (eq. 25 K_e), 5 mesh periods:");
    let mut errors = Vec::new();
    for kb in [1e8, 1e10, 1e12, 1e14] {
        let run = run_train(&scene(Some(kb)), n as f64 * dt, dt).unwrap();
        let col = run.column("mesh1.dte").unwrap();
        let sdof_scene =
            PairScene::from_toml_str(&single_mesh_text(run.rows[0][col]), "sdof").unwrap();
        let mut sim = Simulation::new(&sdof_scene).unwrap();
        let (mut err, mut scale) = (0.0f64, 0.0f64);
        for (k, row) in run.rows.iter().enumerate().skip(1) {
            sim.advance_to(k as f64 * dt).unwrap();
            let d = sim.outputs()[0];
            err = err.max((row[col] - d).abs());
            scale = scale.max(d.abs());
        }
        println!("  bearings {kb:.0e} N/m: {:.3e}", err / scale);
        errors.push(err / scale);
    }
    for w in errors.windows(2) {
        assert!(w[1] < w[0], "{errors:?}");
    }
    assert!(errors[3] < 1e-3, "{errors:?}");
}
