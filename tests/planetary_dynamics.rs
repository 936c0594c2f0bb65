//! The planetary stage's time-varying meshes (issue 33, second stage; `docs/planetary.md`):
//!
//! - the mesh phases of Parker & Lin (2004) (eq. PL1–PL3) against values worked out by hand
//!   from the tooth counts and planet angles, their override, and the refusals that name the
//!   field (pressure angles that differ, a planet that does not fit between sun and ring);
//! - acceptance 5 (kinematics): with torque ports on the sun and the carrier and a held ring,
//!   the mean speed ratio after the transient is Willis' `1 + Z_r/Z_s` (over whole mesh
//!   periods of the steady state, ≤ 1e-9), and an accelerating stage follows it too.
//!
//! The independent time-series oracle (acceptance 4) is
//! `tests/python/test_planetary_reference.py`.

use geardyn::mesh::MeshStiffness;
use geardyn::model::train::{planetary, run_train, statics, Assembly};
use geardyn::scene::train::MeshForceModel;
use geardyn::scene::Scene;

/// A stage with consistent geometry (module `m`, pressure angle α, standard gears): base
/// radii `m Z cos α / 2`, carrier radius `m (Z_s + Z_p)/2`, so `r_c cos α = r_s + r_p`.
struct Consistent {
    teeth: [u32; 3],
    planets: usize,
    angles: Option<Vec<f64>>,
    stiffness: String,
    contact: &'static str,
    extra_mesh: String,
    tail: String,
}

const MODULE: f64 = 2e-3;
const ALPHA_DEG: f64 = 20.0;

impl Consistent {
    fn new(teeth: [u32; 3], planets: usize) -> Consistent {
        Consistent {
            teeth,
            planets,
            angles: None,
            stiffness: "{ kind = \"rectangular\", mean = 5e8, peak_to_peak_ratio = 0.4, \
                        contact_ratio = 1.6 }"
                .into(),
            contact: "linear",
            extra_mesh: String::new(),
            tail: "[operating]\ninput_gear = \"sun\"\noutput_gear = \"carrier\"\n\
                   input_speed = 300.0\ninput_torque = 50.0\n"
                .into(),
        }
    }

    fn toml(&self) -> String {
        let [zs, zp, zr] = self.teeth;
        let alpha = ALPHA_DEG.to_radians();
        let rb = |z: u32| MODULE * f64::from(z) / 2.0 * alpha.cos();
        let rc = MODULE * f64::from(zs + zp) / 2.0;
        let member = |name: &str, z: u32, mass: f64, i_r2: f64, more: &str| {
            format!(
                "[[gear]]\nname = \"{name}\"\nteeth = {z}\nbase_radius = {:?}\ninertia = {:?}\n\
                 mass = {mass:?}\nbearing_stiffness = [1e8, 1e8]\n\
                 bearing_damping = [500.0, 500.0]\n{more}",
                rb(z),
                i_r2 * rb(z) * rb(z)
            )
        };
        let mut t = "name = \"consistent\"\n[model]\nbearings = \"compliant\"\n".to_string();
        t += &member("sun", zs, 0.4, 0.39, "");
        t += &member(
            "ring",
            zr,
            2.35,
            3.0,
            &format!(
                "internal = true\nground_stiffness = {:?}\nground_damping = {:?}\n",
                1e9 * rb(zr) * rb(zr),
                1e3 * rb(zr) * rb(zr)
            ),
        );
        for j in 0..self.planets {
            let angle = match &self.angles {
                Some(a) => a[j],
                None => 360.0 * j as f64 / self.planets as f64,
            };
            t += &member(
                &format!("planet{}", j + 1),
                zp,
                0.66,
                0.61,
                &format!("carrier = \"carrier\"\nposition_angle = {angle:?}\n"),
            );
        }
        t += &format!(
            "[[carrier]]\nname = \"carrier\"\nradius = {rc:?}\ninertia = {:?}\nmass = 5.43\n\
             bearing_stiffness = [1e8, 1e8]\nbearing_damping = [500.0, 500.0]\nfixed = \"ring\"\n",
            6.29 * rc * rc
        );
        for j in 1..=self.planets {
            for (pinion, gear, name) in [
                ("sun".to_string(), format!("planet{j}"), format!("sp{j}")),
                (format!("planet{j}"), "ring".to_string(), format!("rp{j}")),
            ] {
                t += &format!(
                    "[[mesh]]\nname = \"{name}\"\npinion = \"{pinion}\"\ngear = \"{gear}\"\n\
                     contact = \"{}\"\npressure_angle = {ALPHA_DEG:?}\ndamping = 400.0\n\
                     stiffness = {}\n",
                    self.contact, self.stiffness
                );
                if name == "sp2" {
                    t += &self.extra_mesh;
                }
            }
        }
        t + &self.tail
    }

    fn scene(&self) -> Result<Scene, String> {
        Scene::from_toml_str(&self.toml(), "consistent stage").map_err(|e| e.to_string())
    }
}

fn phase_of(scene: &Scene, name: &str) -> f64 {
    scene.meshes.iter().find(|m| m.name == name).unwrap().phase
}

fn assert_phases(scene: &Scene, expected: &[(&str, f64)]) {
    for &(name, want) in expected {
        let got = phase_of(scene, name);
        let d = (got - want).abs();
        assert!(
            d.min(1.0 - d) < 1e-12,
            "{name}: phase {got}, expected {want}"
        );
    }
}

#[test]
fn mesh_phases_follow_parker_and_lin() {
    // Z_s = 20, Z_p = 22, Z_r = 64, three planets at 0°, 120°, 240° ((Z_s + Z_r)/3 = 28: they
    // fit), the sun turning ccw relative to the carrier. By hand: a sun tooth that meets planet
    // 1 meets planet n after turning ψ_n, 20/3 teeth later: sun meshes lag by 2/3, 1/3 of a
    // cycle (lead 1/3, 2/3). The ring turns cw relative to the carrier: its meshes lead by
    // 64·(1/3) = 21 + 1/3 cycles. Even Z_p: the ring pitch point is reached (22 − 1)/2 = 10.5
    // tooth pitches after the sun pitch point.
    let stage = Consistent::new([20, 22, 64], 3);
    let scene = stage.scene().unwrap();
    assert_phases(
        &scene,
        &[
            ("sp1", 0.0),
            ("sp2", 1.0 / 3.0),
            ("sp3", 2.0 / 3.0),
            ("rp1", 0.5),
            ("rp2", 0.5 + 1.0 / 3.0),
            ("rp3", 0.5 + 2.0 / 3.0 - 1.0),
        ],
    );
    // The sun turning cw: the planet-to-planet phases change sign, the sun-ring phase stays.
    let cw = Consistent::new([20, 22, 64], 3).toml().replace(
        "bearings = \"compliant\"\n",
        "bearings = \"compliant\"\ninput_rotation = \"cw\"\n",
    );
    assert_phases(
        &Scene::from_toml_str(&cw, "cw").unwrap(),
        &[
            ("sp2", 2.0 / 3.0),
            ("sp3", 1.0 / 3.0),
            ("rp1", 0.5),
            ("rp2", 0.5 - 1.0 / 3.0),
        ],
    );
    // Odd Z_p: sun and ring mesh of a planet in phase; Z_s = 21 a multiple of N: in phase.
    let odd = Consistent::new([21, 21, 63], 3).scene().unwrap();
    assert_phases(
        &odd,
        &[("sp2", 0.0), ("sp3", 0.0), ("rp1", 0.0), ("rp2", 0.0)],
    );
    // An override keeps its value; the others are still derived.
    let mut given = Consistent::new([20, 22, 64], 3);
    given.extra_mesh = "phase = 0.125\n".into();
    assert_phases(
        &given.scene().unwrap(),
        &[("sp2", 0.125), ("sp3", 2.0 / 3.0), ("rp2", 0.5 + 1.0 / 3.0)],
    );
    // Unequal spacing where the planets fit: (20 + 64)·ψ/360° integer, ψ = 0°, 120°, 180°+
    // 360°/84·… here 0°, 30°·(…): planet 2 at 360°·29/84, planet 3 at 360°·57/84.
    let mut unequal = Consistent::new([20, 22, 64], 3);
    let psi = [0.0, 360.0 * 29.0 / 84.0, 360.0 * 57.0 / 84.0];
    unequal.angles = Some(psi.to_vec());
    let frac = |x: f64| x - x.floor();
    assert_phases(
        &unequal.scene().unwrap(),
        &[
            ("sp2", frac(-20.0 * 29.0 / 84.0)),
            ("sp3", frac(-20.0 * 57.0 / 84.0)),
            ("rp2", frac(0.5 + 64.0 * 29.0 / 84.0)),
            ("rp3", frac(0.5 + 64.0 * 57.0 / 84.0)),
        ],
    );
}

#[test]
fn stage_phasing_refusals_name_the_field() {
    // A planet that does not fit between sun and ring, with a varying stiffness.
    let mut misplaced = Consistent::new([20, 22, 64], 3);
    misplaced.angles = Some(vec![0.0, 100.0, 240.0]);
    let e = misplaced.scene().err().unwrap();
    assert!(
        e.contains("gear[3].position_angle = 100") && e.contains("fits between"),
        "{e}"
    );
    // With constant stiffness the phases do not matter: accepted.
    misplaced.stiffness = "{ kind = \"constant\", value = 5e8 }".into();
    assert!(misplaced.scene().is_ok());
    // Pressure angles that differ between planets.
    let stage = Consistent::new([20, 22, 64], 3);
    let text = stage.toml();
    let at = text.find("name = \"sp2\"").unwrap();
    let (head, rest) = text.split_at(at);
    let rest = rest.replacen("pressure_angle = 20.0", "pressure_angle = 21.0", 1);
    let e = Scene::from_toml_str(&format!("{head}{rest}"), "angles")
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("mesh[2].pressure_angle = 21") && e.contains("mesh[0].pressure_angle"),
        "{e}"
    );
}

/// A `kind = "geometry"` stiffness table for the pair `zp`/`zg` of [`Consistent`]'s module
/// and pressure angle (standard gears, steel-like), with `more` keys (e.g. `etc = false`).
fn geometry(zp: u32, zg: u32, more: &str) -> String {
    format!(
        "{{ kind = \"geometry\", {more}geometry = {{ module = 0.002, pressure_angle = 20.0, \
         face_width = 0.02, pinion = {{ teeth = {zp}, bore_radius = 0.01, youngs_modulus = \
         211.0e9, poisson_ratio = 0.3 }}, gear = {{ teeth = {zg}, bore_radius = 0.01, \
         youngs_modulus = 211.0e9, poisson_ratio = 0.3 }} }} }}"
    )
}

/// `text` with the `stiffness = …` line of the mesh named `mesh` replaced by `stiffness`.
fn with_mesh_stiffness(text: &str, mesh: &str, stiffness: &str) -> String {
    let at = text.find(&format!("name = \"{mesh}\"")).unwrap();
    let (head, rest) = text.split_at(at);
    let start = rest.find("stiffness = {").unwrap();
    let end = start + rest[start..].find('\n').unwrap();
    format!(
        "{head}{}stiffness = {stiffness}{}",
        &rest[..start],
        &rest[end..]
    )
}

/// Geometry stiffness (potential energy) on a ring mesh: refused naming the field, with the
/// reason (`docs/planetary.md`, "Geometry stiffness"): the internal tooth and the rim are not in
/// the method. The same on a sun mesh loads (`geometry_stiffness_on_sun_meshes_*`).
#[test]
fn geometry_stiffness_on_a_ring_mesh_is_refused_with_its_reason() {
    let text = Consistent::new([20, 22, 64], 3).toml();
    let e = Scene::from_toml_str(
        &with_mesh_stiffness(&text, "rp1", &geometry(22, 64, "")),
        "geometry",
    )
    .err()
    .unwrap()
    .to_string();
    assert!(
        e.contains("mesh[1].stiffness") && e.contains("internal (ring) mesh"),
        "{e}"
    );
    let sun = with_mesh_stiffness(&text, "sp1", &geometry(20, 22, ""));
    assert!(Scene::from_toml_str(&sun, "geometry").is_ok());
}

/// The lumped stiffness source of the mesh named `name` and its phase.
fn lumped(scene: &Scene, name: &str) -> (MeshStiffness, f64) {
    let m = scene.meshes.iter().find(|m| m.name == name).unwrap();
    match &m.force {
        MeshForceModel::Lumped { stiffness, .. } => (stiffness.clone(), m.phase),
        MeshForceModel::Pairs { .. } => panic!("{name}: not lumped"),
    }
}

/// Geometry stiffness on the sun meshes of a stage (`docs/planetary.md`, "Geometry
/// stiffness", eq. PL5), without extended tooth contact so that the contact zones are the
/// involute ones. Oracles:
///
/// - closed form: at the stage's mesh clock q, mesh n's pairs sit at `p_b (q + γ_n + k)` from the
///   pitch point along the path (γ_n the stage phases worked out by hand above: 0, 1/3, 2/3),
///   in contact between `−L_AP` and `L_PE`, the approach and recess lengths from the base and
///   tip radii (`r_b = m z cos α/2`, `r_a = m(z/2 + 1)`); the stiffness jumps down where a pair
///   leaves at the pinion tip and up where one enters at the gear tip, at those instants to
///   1e-9 mesh cycles, and every two-pair instant is stiffer than every one-pair instant;
/// - the parallel pair path: the same teeth as an ordinary drivetrain mesh (at the sun's torque
///   per planet) give the same curve, shifted by the hand-computed pitch-point origin
///   `s_P = −L_PE/p_b` and the stage phase: `k_n(q) = k_pair(q + γ_n + s_P)`, to 1e-12;
/// - statics: every planet carries 1/3 of the load to 1e-12.
#[test]
fn geometry_stiffness_on_sun_meshes_is_phased_from_the_pitch_point() {
    let (zs, zp) = (20.0_f64, 22.0_f64);
    let mut text = Consistent::new([20, 22, 64], 3).toml();
    for name in ["sp1", "sp2", "sp3"] {
        text = with_mesh_stiffness(&text, name, &geometry(20, 22, "etc = false, "));
    }
    let scene = Scene::from_toml_str(&text, "geometry sun").unwrap();

    let alpha = ALPHA_DEG.to_radians();
    let r_b = |z: f64| MODULE * z * alpha.cos() / 2.0;
    let r_a = |z: f64| MODULE * (z / 2.0 + 1.0);
    let beyond_pitch = |z: f64| (r_a(z).powi(2) - r_b(z).powi(2)).sqrt() - r_b(z) * alpha.tan();
    let (recess, approach) = (beyond_pitch(zs), beyond_pitch(zp));
    let p_b = std::f64::consts::PI * MODULE * alpha.cos();
    let gammas = [0.0, 1.0 / 3.0, 2.0 / 3.0];
    let pairs_in_contact = |q: f64| {
        (-4..=4)
            .filter(|&k| {
                let x = p_b * (q + k as f64);
                (-approach..=recess).contains(&x)
            })
            .count()
    };

    // The parallel path: sun and planet as an ordinary mesh at the sun's torque per planet.
    let pair_text = format!(
        "name = \"pair\"\n[[gear]]\nname = \"sun\"\nteeth = 20\ninertia = 1e-4\n\
         [[gear]]\nname = \"planet\"\nteeth = 22\ninertia = 1e-4\n\
         [[mesh]]\npinion = \"sun\"\ngear = \"planet\"\ncontact = \"linear\"\n\
         damping = 400.0\nstiffness = {}\n\
         [operating]\ninput_speed = 300.0\ninput_torque = {:?}\n",
        geometry(20, 22, "etc = false, "),
        50.0 / 3.0
    );
    let pair = Scene::from_toml_str(&pair_text, "pair").unwrap();
    let (k_pair, pair_phase) = lumped(&pair, "mesh1");
    assert_eq!(pair_phase, 0.0);
    let s_pitch = -recess / p_b;

    let samples = 3000;
    for (n, gamma) in gammas.iter().enumerate() {
        let name = format!("sp{}", n + 1);
        let (k, phase) = lumped(&scene, &name);
        let at = |q: f64| k.value(phase + q);
        // Jumps at the closed-form instants (one cycle: one exit and one entry).
        let exit = recess / p_b - gamma;
        let entry = -approach / p_b - gamma;
        let mean = k.mean();
        for (q, sign, what) in [(exit, -1.0, "exit"), (entry, 1.0, "entry")] {
            let jump = at(q + 1e-9) - at(q - 1e-9);
            assert!(
                sign * jump > 0.2 * mean,
                "{name}: {what} at q = {q}: jump {jump:e} (mean {mean:e})"
            );
        }
        let (mut single_max, mut double_min) = (0.0_f64, f64::INFINITY);
        let mut worst = 0.0_f64;
        for i in 0..samples {
            let q = (i as f64 + 0.5) / samples as f64;
            let near = [exit, entry]
                .iter()
                .any(|b| ((q - b) - (q - b).round()).abs() < 1e-6);
            if near {
                continue;
            }
            match pairs_in_contact(q + gamma) {
                1 => single_max = single_max.max(at(q)),
                2 => double_min = double_min.min(at(q)),
                c => panic!("{name}: {c} pairs at q = {q}"),
            }
            let want = k_pair.value(q + gamma + s_pitch);
            worst = worst.max((at(q) - want).abs() / want);
        }
        assert!(
            double_min > single_max,
            "{name}: two pairs from {double_min:e}, one pair up to {single_max:e}"
        );
        assert!(worst < 1e-12, "{name}: against the parallel pair {worst:e}");
    }

    // The sun's torque per planet is the curve's load: the parallel mesh's mean equals.
    let (k1, _) = lumped(&scene, "sp1");
    assert!((k1.mean() - k_pair.mean()).abs() <= 1e-12 * k_pair.mean());
    // Statics with the mean stiffness: each planet carries 1/3.
    let asm = Assembly::new(&scene);
    let force = statics::equilibrium(
        &asm,
        scene.operating.input_torque,
        scene.operating.load_torque,
        false,
    )
    .unwrap()
    .mesh_force;
    for l in &planetary::load_sharing(&scene, &force)[0] {
        assert!((l.share - 1.0 / 3.0).abs() <= 1e-12, "share {}", l.share);
    }

    // `[mesh.pairs] kind = "geometry"`: slot j of the pair model sits at `ξ = s + w − 1 − j` of
    // the window `w = c + 2e` (docs/train.md), `ξ = e` at the path start A, so a pair is at the
    // pitch point (`ξ = e + L_AP/p_b`) when `s ≡ 1 + L_AP/p_b − c − e = 1 − L_PE/p_b − e`: the
    // mesh runs at `γ_n − L_PE/p_b − e` (e = 0.01 with ETC, 0 without).
    for (etc, e) in [("", 0.01), ("etc = false, ", 0.0)] {
        let mut text = Consistent::new([20, 22, 64], 3).toml();
        for name in ["sp1", "sp2", "sp3"] {
            text = with_mesh_stiffness(&text, name, &geometry(20, 22, etc)).replace(
                "stiffness = { kind = \"geometry\"",
                "model = \"pairs\"\npairs = { kind = \"geometry\"",
            );
        }
        let scene = Scene::from_toml_str(&text, "geometry pairs").unwrap();
        let frac = |x: f64| x - x.floor();
        let expected: Vec<(String, f64)> = gammas
            .iter()
            .enumerate()
            .map(|(n, g)| (format!("sp{}", n + 1), frac(g - recess / p_b - e)))
            .collect();
        let expected: Vec<(&str, f64)> = expected.iter().map(|(n, p)| (n.as_str(), *p)).collect();
        assert_phases(&scene, &expected);
        // The ring meshes keep their stage phases (rectangular: origin taken as the pitch point).
        assert_phases(&scene, &[("rp1", 0.5), ("rp2", 0.5 + 1.0 / 3.0)]);
    }
}

/// The stage with torque ports on the sun (input) and the carrier (output), the ring held.
fn with_ports(teeth: [u32; 3], input: f64, output: f64) -> Scene {
    let mut stage = Consistent::new(teeth, 3);
    stage.contact = "contact_loss";
    stage.tail = format!(
        "[operating]\ninput_gear = \"sun\"\noutput_gear = \"carrier\"\ninput_speed = 300.0\n\
         [[port]]\nname = \"input\"\ngear = \"sun\"\ncausality = \"torque\"\ntorque = {input:?}\n\
         [[port]]\nname = \"output\"\ngear = \"carrier\"\ncausality = \"torque\"\n\
         torque = {output:?}\n"
    );
    stage.scene().unwrap()
}

#[test]
fn torque_ports_turn_the_stage_at_willis_ratio() {
    let teeth = [20, 22, 64];
    let willis = 1.0 + 64.0 / 20.0;
    // Balanced torques: the steady state. Over whole mesh periods after the transient the
    // elastic motion returns, so Δθ_s/Δθ_c is the rigid-body ratio.
    let scene = with_ports(teeth, 50.0, -50.0 * willis);
    let mesh_period = std::f64::consts::TAU / (20.0 * 300.0 * (1.0 - 1.0 / willis));
    let dt = mesh_period / 16.0;
    let run = run_train(&scene, 400.0 * mesh_period, dt).unwrap();
    let (s, c) = (
        run.column("sun.angle").unwrap(),
        run.column("carrier.angle").unwrap(),
    );
    let a = run
        .times
        .iter()
        .position(|&t| t >= 200.0 * mesh_period - dt / 2.0)
        .unwrap();
    let b = run.times.len() - 1;
    assert!(((run.times[b] - run.times[a]) / mesh_period - 200.0).abs() < 1e-6);
    let ratio = (run.rows[b][s] - run.rows[a][s]) / (run.rows[b][c] - run.rows[a][c]);
    println!(
        "steady state: Δθ_s/Δθ_c = {ratio:.15}, Willis {willis}, {:.3e}",
        ratio / willis - 1.0
    );
    assert!((ratio / willis - 1.0).abs() <= 1e-9, "{ratio}");
    // An accelerating stage (1 % more input torque): the mean speeds still follow Willis up
    // to the change of the elastic deflection over the window.
    let scene = with_ports(teeth, 50.5, -50.0 * willis);
    let run = run_train(&scene, 200.0 * mesh_period, dt).unwrap();
    let (s, c) = (
        run.column("sun.angle").unwrap(),
        run.column("carrier.angle").unwrap(),
    );
    let b = run.times.len() - 1;
    let a = b / 2;
    let ratio = (run.rows[b][s] - run.rows[a][s]) / (run.rows[b][c] - run.rows[a][c]);
    let speed = run.column("sun.speed").unwrap();
    let gain = run.rows[b][speed] - run.rows[0][speed];
    println!(
        "accelerating (+{gain:.3} rad/s): {:.3e}",
        ratio / willis - 1.0
    );
    assert!(gain > 1.0);
    assert!((ratio / willis - 1.0).abs() <= 1e-6, "{ratio}");
}

/// Harmonic amplitudes `|X_l|`, l = 1 … `count`, of samples over one period.
fn harmonics(samples: &[f64], count: usize) -> Vec<f64> {
    let m = samples.len() as f64;
    (1..=count)
        .map(|l| {
            let (mut re, mut im) = (0.0, 0.0);
            for (k, x) in samples.iter().enumerate() {
                let (s, c) = (std::f64::consts::TAU * (l * k) as f64 / m).sin_cos();
                re += x * c;
                im -= x * s;
            }
            2.0 * (re * re + im * im).sqrt() / m
        })
        .collect()
}

/// Acceptance 2 (Parker & Lin 2004; Parker 2000): in the periodic steady state of a linear
/// stage with N equally spaced planets, mesh harmonic l moves the central members (sun, ring,
/// carrier) only in rotation when `l Z_s/N` is an integer, only in translation when
/// `(l Z_s ± 1)/N` is, and not at all otherwise; the forbidden lines ≤ 1e-10 of the largest.
/// The orbit is `geardyn periodic`'s (shooting); one period is sampled 240 times (a multiple
/// of N, so that aliased harmonics keep their class) by the exact propagator from it.
/// The largest forbidden line of the phasing rules over the first 40 mesh harmonics, relative
/// to the largest line, whether each class (rotational, translational, none) occurs with its
/// allowed motion excited, and the largest line: the periodic orbit of `geardyn periodic`
/// (shooting), one period sampled 240 times (a multiple of N, so that aliased harmonics keep
/// their class) by the exact propagator from it.
fn forbidden_lines(scene: &Scene, z_sun: usize, planets: usize) -> (f64, [bool; 3], f64) {
    use geardyn::model::train::{DofKind, TrainSimulation};
    let orbit = geardyn::commands::steady::periodic(scene, 1, 100).unwrap();
    let mut sim = TrainSimulation::new(scene).unwrap();
    sim.set_state(0.0, &orbit.y0);
    let asm = sim.model().assembly().clone();
    let q = sim.model().reduction_matrix().clone();
    let m = sim.model().elastic_dim();
    let st = &scene.planetary[0];
    let central = [st.sun, st.ring, st.carrier];
    let (mut rotation, mut translation) = (Vec::new(), Vec::new());
    for (i, d) in asm.dofs.iter().enumerate() {
        match *d {
            DofKind::Rotation { gear } if central.contains(&gear) => rotation.push(i),
            DofKind::X { gear } | DofKind::Y { gear } if central.contains(&gear) => {
                translation.push(i)
            }
            _ => {}
        }
    }
    assert_eq!((rotation.len(), translation.len()), (3, 6));
    let samples = 240;
    let mut series = vec![Vec::with_capacity(samples); asm.dofs.len()];
    for k in 0..samples {
        sim.advance_to(orbit.period * k as f64 / samples as f64)
            .unwrap();
        let xi = nalgebra::DVector::from_column_slice(&sim.state()[..m]);
        let physical = &q * xi;
        for (i, s) in series.iter_mut().enumerate() {
            s.push(physical[i]);
        }
    }
    let count = 40;
    let group = |dofs: &[usize]| -> Vec<f64> {
        let mut best = vec![0.0f64; count];
        for &i in dofs {
            for (b, a) in best.iter_mut().zip(harmonics(&series[i], count)) {
                *b = b.max(a);
            }
        }
        best
    };
    let (rot, tra) = (group(&rotation), group(&translation));
    let largest = rot.iter().chain(&tra).fold(0.0f64, |a, &b| a.max(b));
    let n = planets;
    let (mut worst, mut seen) = (0.0f64, [false; 3]);
    for l in 1..=count {
        let (r, t) = (rot[l - 1] / largest, tra[l - 1] / largest);
        let rotational = (l * z_sun).is_multiple_of(n);
        let translational =
            (l * z_sun + 1).is_multiple_of(n) || (l * z_sun + n - 1).is_multiple_of(n);
        let forbidden = match (rotational, translational) {
            (true, _) => {
                seen[0] |= r > 1e-6;
                t
            }
            (_, true) => {
                seen[1] |= t > 1e-6;
                r
            }
            _ => {
                seen[2] = true;
                r.max(t)
            }
        };
        worst = worst.max(forbidden);
    }
    (worst, seen, largest)
}

/// Acceptance 2 (Parker & Lin 2004; Parker 2000): in the periodic steady state of a linear
/// stage with N equally spaced planets, mesh harmonic l moves the central members (sun, ring,
/// carrier) only in rotation when `l Z_s/N` is an integer, only in translation when
/// `(l Z_s ± 1)/N` is, and not at all otherwise; the forbidden lines ≤ 1e-10 of the largest.
/// Control: the same stage with every mesh phase forced to 0 (no phasing) breaks the rules.
#[test]
fn phasing_rules_hold_in_the_linear_steady_state() {
    for (teeth, planets) in [([21, 19, 59], 4), ([22, 23, 68], 5)] {
        let text = Consistent::new(teeth, planets).toml().replace(
            "bearings = \"compliant\"\n",
            "bearings = \"compliant\"\nmodal_damping_ratio = 0.05\n",
        );
        let scene = Scene::from_toml_str(&text, "phasing rules").unwrap();
        let zs = teeth[0] as usize;
        let (worst, seen, largest) = forbidden_lines(&scene, zs, planets);
        let unphased = text
            .replace("damping = 400.0\n", "damping = 400.0\nphase = 0.0\n")
            .replacen("damping = 400.0\nphase = 0.0\n", "damping = 400.0\n", 1);
        let unphased = Scene::from_toml_str(&unphased, "no phasing").unwrap();
        assert!(unphased.meshes.iter().all(|m| m.phase == 0.0));
        let (control, ..) = forbidden_lines(&unphased, zs, planets);
        println!(
            "N = {planets}, Z_s = {zs}: forbidden lines ≤ {worst:.2e} of the largest \
             ({largest:.3e} m); every mesh in phase instead: {control:.2e}"
        );
        assert!(
            seen == [true; 3],
            "every class occurs and is excited: {seen:?}"
        );
        assert!(worst <= 1e-10, "N = {planets}: forbidden line {worst:e}");
        assert!(control > 1e-3, "the control breaks the rules: {control:e}");
    }
}
