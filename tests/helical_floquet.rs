//! Issue 6 part A, acceptance 1, 2 and 6 (model side): the SDOF torsional model of He & Singh
//! 2007 (eq. 24, undamped) on the shipped NASA-ART scene, solved in closed form over the
//! piecewise-linear K_e(t) (eq. 25) by `LinearPeriodMap`, against RK (DOP853, rtol 1e-11) of the
//! same model through the ordinary simulation path, and the paper's stability statement
//! (μ = 0.2: stable at 18,000 rpm, unstable at 19,000 rpm).

use geardyn::analysis::{instability_bands, LinearPeriodMap};
use geardyn::mesh::helical::{HelicalGeometry, HelicalPairSpec};
use geardyn::scene::PairScene;
use geardyn::simulation::Simulation;
use geardyn::units::{from_rpm, rpm};

const SCENE: &str = include_str!("../fmu/helical_pair_friction/scene.toml");
const INCH: f64 = 0.0254;
/// The paper's initial conditions (Figs. 6–9): 2e-6 in, 20 in/s.
const Y0: [f64; 2] = [2e-6 * INCH, 20.0 * INCH];

/// The shipped scene with μ, speed, torque, helix reading and RK settings replaced. For the
/// pitch reading the density is recalibrated as in the scene comments (f_n = 9.5 f_mesh at
/// 1000 rpm, μ = 0), so both readings share the paper's frequency ratio.
fn scene(mu: f64, rpm_: f64, torque: f64, reference: &str) -> PairScene {
    let mut text = SCENE
        .replace(
            "friction_coefficient = 0.2",
            &format!("friction_coefficient = {mu:?}"),
        )
        .replace(
            "helix_angle_reference = \"base\"",
            &format!("helix_angle_reference = \"{reference}\""),
        )
        .replace(
            "input_torque = 225.96965805523337",
            &format!("input_torque = {torque:?}"),
        )
        .replace("rtol = 1e-10", "rtol = 1e-11\nmethod = \"rk\"")
        .replace("atol = 1e-16", "atol = 1e-18");
    if reference == "pitch" {
        let base = PairScene::from_toml_str(&text, "base").unwrap();
        let table: toml::Table = toml::from_str(&text).unwrap();
        let helical: HelicalPairSpec = table["mesh"]["stiffness"]["helical"]
            .clone()
            .try_into()
            .unwrap();
        let g = HelicalGeometry::new(&helical, "").unwrap();
        let f_n = 9.5 * 25.0 * 1000.0 / 60.0;
        let k_mean = base.equivalent_mass() * (std::f64::consts::TAU * f_n).powi(2);
        let density =
            k_mean / (g.base_helix_angle.cos() * g.face_width * g.transverse_contact_ratio());
        text = text.replace(
            "stiffness_density = 5.745e9",
            &format!("stiffness_density = {density:?}"),
        );
    }
    let mut s = PairScene::from_toml_str(&text, "helical test").expect("scene");
    s.operating.pinion_speed = from_rpm(rpm_);
    s.operating.load_torque = torque * s.gear.base_radius / s.pinion.base_radius;
    s
}

/// RK states at `times` from `y0`.
fn rk(scene: &PairScene, y0: [f64; 2], times: &[f64]) -> Vec<[f64; 2]> {
    let mut sim = Simulation::new(scene).expect("simulation");
    assert_eq!(sim.method_name(), "dop853", "the oracle is the RK path");
    sim.set_state(0.0, y0);
    times
        .iter()
        .map(|&t| {
            sim.advance_to(t).expect("advance");
            sim.state()
        })
        .collect()
}

/// max |a − b| / max |b| per state component, the larger of the two.
fn relative_deviation(a: &[[f64; 2]], b: &[[f64; 2]]) -> f64 {
    (0..2)
        .map(|c| {
            let scale = b.iter().map(|y| y[c].abs()).fold(0.0, f64::max);
            a.iter()
                .zip(b)
                .map(|(p, q)| (p[c] - q[c]).abs())
                .fold(0.0, f64::max)
                / scale
        })
        .fold(0.0, f64::max)
}

#[test]
fn floquet_solution_equals_rk_over_two_mesh_periods() {
    // Free (no load) and forced (T_p = 2000 lb·in), undamped, 1000 rpm (Figs. 6 and 7).
    let torque = 2000.0 * 0.1129848;
    for reference in ["base", "pitch"] {
        for mu in [0.0, 0.2, 0.4] {
            for (case, t) in [("free", 0.0), ("forced", torque)] {
                let s = scene(mu, 1000.0, t, reference);
                let map = LinearPeriodMap::new(&s).unwrap();
                let times: Vec<f64> = (1..=400)
                    .map(|i| i as f64 * 2.0 * map.period / 400.0)
                    .collect();
                let closed: Vec<[f64; 2]> = times.iter().map(|&t| map.response(Y0, t)).collect();
                let numeric = rk(&s, Y0, &times);
                let dev = relative_deviation(&closed, &numeric);
                println!(
                    "{reference} μ = {mu} {case}: max |Floquet − RK| / max |RK| = {dev:.2e} \
                     ({} segments, x(2T) = {:.6e} m)",
                    map.segments().len(),
                    closed.last().unwrap()[0]
                );
                assert!(dev <= 1e-8, "{reference} μ = {mu} {case}: {dev:e}");
                // Undamped: Liouville, det Φ = 1.
                assert!((map.monodromy().determinant() - 1.0).abs() < 1e-9);
            }
        }
    }
}

#[test]
fn periodic_steady_state_repeats_under_rk() {
    let s = scene(0.2, 1000.0, 2000.0 * 0.1129848, "base");
    let map = LinearPeriodMap::new(&s).unwrap();
    let x_ss = map.periodic_state().expect("I − Φ regular");
    // Near the static deflection F_e / mean K_e (notes §5: ≈ 9.8e-4 in = 2.5e-5 m).
    let static_deflection = map.force() / s.mesh.stiffness.mean();
    assert!((x_ss[0] / static_deflection - 1.0).abs() < 0.2, "{x_ss:?}");
    let after = rk(&s, x_ss, &[map.period])[0];
    let dev = relative_deviation(&[after], &[x_ss]);
    println!("periodic steady state {x_ss:?}, RK after one period {after:?}: dev {dev:.2e}");
    assert!(dev < 1e-8, "{dev:e}");
}

/// max |x| over each of `periods` mesh periods, RK from the paper's initial conditions.
fn rk_period_amplitudes(s: &PairScene, periods: usize) -> Vec<f64> {
    let map = LinearPeriodMap::new(s).unwrap();
    let per = 40;
    let times: Vec<f64> = (1..=periods * per)
        .map(|i| i as f64 * map.period / per as f64)
        .collect();
    let y = rk(s, Y0, &times);
    y.chunks(per)
        .map(|c| c.iter().map(|v| v[0].abs()).fold(0.0, f64::max))
        .collect()
}

#[test]
fn paper_stability_statement_holds() {
    let periods = 150;
    for (rpm_, unstable) in [(18_000.0, false), (19_000.0, true)] {
        let s = scene(0.2, rpm_, 0.0, "base");
        let floquet = LinearPeriodMap::new(&s).unwrap().floquet().unwrap();
        let rho = floquet.spectral_radius();
        let trace = floquet.monodromy.trace();
        let amp = rk_period_amplitudes(&s, periods);
        let growth = amp[periods - 1] / amp[0];
        println!(
            "μ = 0.2, {rpm_} rpm: tr Φ = {trace:.9}, max |μ| = {rho:.9}, RK amplitude ratio period {periods} / period 1 = {growth:.3e}, max over all periods / first = {:.3}",
            amp.iter().fold(0.0f64, |a, &b| a.max(b)) / amp[0]
        );
        assert_eq!(trace.abs() > 2.0, unstable, "trace {trace}");
        if unstable {
            assert!(rho > 1.05, "{rho}");
            assert!(growth > 1e3, "RK response must grow: {growth:e}");
            // Once the decaying multiplier has died out (0.93^50 ≈ 0.03), the RK amplitude
            // grows by ρ per period.
            let rate = (amp[periods - 1] / amp[49]).ln() / (periods - 50) as f64;
            println!(
                "  RK growth rate per period {rate:.6} vs ln ρ = {:.6}",
                rho.ln()
            );
            assert!(
                (rate / rho.ln() - 1.0).abs() < 0.02,
                "{rate} vs {}",
                rho.ln()
            );
        } else {
            assert!((rho - 1.0).abs() < 1e-9, "{rho}");
            let worst = amp.iter().fold(0.0f64, |a, &b| a.max(b)) / amp[0];
            assert!(worst < 3.0, "RK response must stay bounded: {worst}");
        }
    }
}

#[test]
fn primary_instability_bands() {
    let mut table = Vec::new();
    for reference in ["base", "pitch"] {
        for mu in [0.0, 0.2, 0.4] {
            let s = scene(mu, 1000.0, 0.0, reference);
            let bands = instability_bands(&s, from_rpm(15_000.0), from_rpm(25_000.0), 200).unwrap();
            let primary: Vec<_> = bands.iter().filter(|b| b.order == Some(1)).collect();
            assert_eq!(primary.len(), 1, "{reference} μ = {mu}: {bands:?}");
            let b = primary[0];
            let (lo, hi) = (rpm(b.from_speed), rpm(b.to_speed));
            table.push(format!(
                "{reference:>5} μ = {mu}: primary band {lo:.1} – {hi:.1} rpm, max |μ| {:.5}",
                b.peak_spectral_radius
            ));
            if mu == 0.2 {
                assert!(
                    lo > 18_000.0 && lo < 19_000.0 && hi > 19_000.0,
                    "{lo} – {hi}"
                );
            }
        }
    }
    println!("{}", table.join("\n"));
}

/// `geardyn ARGS…` on the shipped helical FMU folder.
fn geardyn_on_helical_fmu(command: &str, args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_geardyn"))
        .args([command, "fmu/helical_pair_friction"])
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn band_and_floquet_cli() {
    let band = ["--speed", "15000rpm:25000rpm", "--mu"];
    let out = geardyn_on_helical_fmu("band", &[&band[..], &["0.2"]].concat());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text} {}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains("primary"), "{text}");
    let out = geardyn_on_helical_fmu("floquet", &["--speed", "19000rpm", "--json"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("\"monodromy\"") && text.contains("\"segments\""),
        "{text}"
    );
    // The same speed in rad/s (19000·2π/60) gives the same monodromy, to the last digit of
    // the speed's rounding.
    let rad_s = format!("{:?}rad/s", geardyn::units::from_rpm(19000.0));
    let same = geardyn_on_helical_fmu("floquet", &["--speed", &rad_s, "--json"]);
    assert_eq!(String::from_utf8_lossy(&same.stdout), text);
    let bare = geardyn_on_helical_fmu("floquet", &["--speed", &rad_s[..rad_s.len() - 5], "--json"]);
    assert_eq!(String::from_utf8_lossy(&bare.stdout), text);
    let out = geardyn_on_helical_fmu("band", &[&band[..], &["-0.1"]].concat());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("mesh.stiffness.friction_coefficient = -0.1"),
        "{err}"
    );
}

#[test]
fn bad_scene_input_is_rejected_naming_field_and_value() {
    let cases = [
        (
            "friction_coefficient = 0.2",
            "friction_coefficient = -0.2",
            "mesh.stiffness.friction_coefficient = -0.2",
        ),
        (
            "friction_coefficient = 0.2",
            "friction_coefficient = nan",
            "mesh.stiffness.friction_coefficient = NaN",
        ),
        (
            "stiffness_density = 5.745e9",
            "stiffness_density = 0.0",
            "mesh.stiffness.stiffness_density = 0",
        ),
        (
            "helix_angle = 21.5",
            "helix_angle = 90.0",
            "mesh.stiffness.helical.helix_angle = 90",
        ),
        (
            "helix_angle = 21.5",
            "helix_angle = -3.0",
            "mesh.stiffness.helical.helix_angle = -3",
        ),
        (
            "face_width = 0.03175",
            "face_width = 0.0",
            "mesh.stiffness.helical.face_width = 0",
        ),
        (
            "face_width = 0.03175",
            "face_width = -0.01",
            "mesh.stiffness.helical.face_width = -0.01",
        ),
        (
            "centre_distance = 0.0889",
            "centre_distance = 0.09",
            "mesh.stiffness.helical.centre_distance = 0.09",
        ),
        (
            "helix_angle_reference = \"base\"",
            "helix_angle_reference = \"normal\"",
            "mesh.stiffness.helical.helix_angle_reference = \"normal\"",
        ),
        (
            "face_width = 0.03175",
            "face_width = 0.03175\nlead = 1.0",
            "unknown field `lead`",
        ),
        (
            "base_radius = 0.0359690903",
            "base_radius = 0.036",
            "mesh.pinion (\"pinion\").base_radius = 0.036",
        ),
    ];
    for (from, to, expected) in cases {
        assert!(SCENE.contains(from), "{from}");
        let text = SCENE.replacen(from, to, 1);
        let err = PairScene::from_toml_str(&text, "bad")
            .unwrap_err()
            .to_string();
        assert!(err.contains(expected), "expected '{expected}' in: {err}");
    }
    // The teeth of the dynamic model and the geometry must agree.
    let text = SCENE.replacen("teeth = 25\nbase_radius", "teeth = 24\nbase_radius", 1);
    let err = PairScene::from_toml_str(&text, "bad")
        .unwrap_err()
        .to_string();
    assert!(err.contains("teeth = 24"), "{err}");
}

#[test]
fn phase_offsets_shift_the_segments_consistently() {
    // A start inside a stiffness piece (mesh.initial_phase and the source's own phase): the
    // closed-form map must walk the pieces from there, as the simulation does.
    let text = SCENE
        .replace(
            "contact = \"linear\"",
            "contact = \"linear\"\ninitial_phase = 0.37",
        )
        .replace(
            "friction_coefficient = 0.2",
            "friction_coefficient = 0.4\nphase = 0.1",
        )
        .replace("rtol = 1e-10", "rtol = 1e-11\nmethod = \"rk\"")
        .replace("atol = 1e-16", "atol = 1e-18");
    let mut s = PairScene::from_toml_str(&text, "phase test").unwrap();
    s.operating.pinion_speed = from_rpm(3000.0);
    let map = LinearPeriodMap::new(&s).unwrap();
    assert_eq!(map.segments().len(), 7, "a start inside a piece splits it");
    let times: Vec<f64> = (1..=300)
        .map(|i| i as f64 * 3.0 * map.period / 300.0)
        .collect();
    let closed: Vec<[f64; 2]> = times.iter().map(|&t| map.response(Y0, t)).collect();
    let dev = relative_deviation(&closed, &rk(&s, Y0, &times));
    println!("initial_phase 0.37, phase 0.1, μ = 0.4, 3000 rpm, forced: dev {dev:.2e}");
    assert!(dev <= 1e-8, "{dev:e}");
}

#[test]
fn cli_rejects_friction_override_on_other_sources_and_bad_ranges() {
    let bin = env!("CARGO_BIN_EXE_geardyn");
    let run = |args: &[&str]| {
        let out = std::process::Command::new(bin).args(args).output().unwrap();
        assert!(!out.status.success(), "{args:?} must fail");
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let err = run(&["floquet", "--example", "bugaru_pair", "--mu", "0.1"]);
    assert!(
        err.contains("--mu 0.1") && err.contains("not \"helical\""),
        "{err}"
    );
    let err = run(&[
        "band",
        "fmu/helical_pair_friction",
        "--speed",
        "2000rpm:1000rpm",
    ]);
    assert!(err.contains("--speed '2000rpm:1000rpm'"), "{err}");
    assert!(err.contains("104.72 rad/s (1000 rpm)"), "{err}");
    let err = run(&["floquet", "--example", "spur_pair"]);
    assert!(err.contains("mesh.contact"), "{err}");
}

/// The closed form's multipliers (capped Schur iteration, issue 34) are the roots of the
/// characteristic polynomial of its 2×2 monodromy, `μ² − tr Φ μ + det Φ` (an independent
/// oracle: the quadratic formula), on both sides of the paper's stability boundary.
#[test]
fn closed_form_multipliers_are_the_roots_of_the_characteristic_polynomial() {
    for rpm_ in [18_000.0, 19_000.0] {
        let s = scene(0.2, rpm_, 0.0, "base");
        let floquet = LinearPeriodMap::new(&s).unwrap().floquet().unwrap();
        let m = &floquet.monodromy;
        let (tr, det) = (m.trace(), m.determinant());
        let disc = tr * tr / 4.0 - det;
        let roots: Vec<(f64, f64)> = if disc >= 0.0 {
            vec![(tr / 2.0 + disc.sqrt(), 0.0), (tr / 2.0 - disc.sqrt(), 0.0)]
        } else {
            vec![(tr / 2.0, (-disc).sqrt()), (tr / 2.0, -(-disc).sqrt())]
        };
        assert_eq!(floquet.multipliers.len(), 2);
        for (re, im) in roots {
            let nearest = floquet
                .multipliers
                .iter()
                .map(|mu| ((mu.re - re).powi(2) + (mu.im - im).powi(2)).sqrt())
                .fold(f64::INFINITY, f64::min);
            assert!(
                nearest < 1e-9 * (1.0 + tr.abs()),
                "{rpm_} rpm: root {re} {im}i, multipliers {:?}",
                floquet.multipliers
            );
        }
    }
}
