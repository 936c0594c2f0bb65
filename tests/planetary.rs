//! The planetary stage's mean system (issue 33, acceptance 1 and 3; `docs/planetary.md`):
//!
//! - the modal structure of Lin & Parker (1999) for N = 3, 4 and 5 equally spaced planets:
//!   every mode is rotational (distinct), translational (multiplicity 2) or a planet mode
//!   (multiplicity N − 3), multiplicities exact to 1e-9, planet-mode frequencies unchanged by
//!   the central members' masses and supports (1e-12);
//! - the natural frequencies of the paper's example system against the values printed in its
//!   Table 2 (≤ 0.5 %);
//! - statics: equal load sharing 1/N to 1e-12 with equal spacing and no errors, and the sun's
//!   torque balance. The pin-error load sharing is checked against the independent numpy model
//!   of `tests/python/test_planetary_statics.py`.
//!
//! Every scene goes through the one scene format (`[[carrier]]` and the planet keys of
//! `[[gear]]`), the validation and the drivetrain assembly.

use geardyn::model::train::{modes, planetary, statics, Assembly, DofKind};
use geardyn::scene::Scene;

/// Lin & Parker (1999) Table 1 parameters (SI), with the knobs the tests turn.
#[derive(Clone)]
struct Stage {
    planets: usize,
    /// Masses of sun, ring, carrier, planet, kg.
    mass: [f64; 4],
    /// `I/r²` of sun, ring, carrier, planet, kg.
    inertia_over_r2: [f64; 4],
    /// Bearing stiffness of sun, ring, carrier, N/m (isotropic), and of the planet pins.
    bearing: [f64; 4],
    /// Torsional supports k_su, k_ru, k_cu on `u = rθ`, N/m.
    torsional: [f64; 3],
    /// Pin errors `[radial, tangential]` per planet, m.
    pin_errors: Vec<[f64; 2]>,
    input: &'static str,
    output: &'static str,
    fixed: &'static str,
}

/// Base radii of sun, ring, carrier (planet circle), planet, m (Table 1 diameters / 2).
const RADIUS: [f64; 4] = [0.0387, 0.1375, 0.0884, 0.05015];
const MESH_STIFFNESS: f64 = 5e8;
const PRESSURE_ANGLE_DEG: f64 = 24.6;

impl Stage {
    fn lin_parker(planets: usize) -> Stage {
        Stage {
            planets,
            mass: [0.4, 2.35, 5.43, 0.66],
            inertia_over_r2: [0.39, 3.0, 6.29, 0.61],
            bearing: [1e8; 4],
            torsional: [0.0, 1e9, 0.0],
            pin_errors: vec![[0.0, 0.0]; planets],
            input: "sun",
            output: "carrier",
            fixed: "ring",
        }
    }

    fn toml(&self) -> String {
        let n = self.planets;
        let inertia = |i: usize| self.inertia_over_r2[i] * RADIUS[i] * RADIUS[i];
        let ground = |i: usize| self.torsional[i] * RADIUS[i] * RADIUS[i];
        let mut t = format!(
            "name = \"planetary_{n}\"\n[model]\nbearings = \"compliant\"\n\
             [[gear]]\nname = \"sun\"\nteeth = 27\nbase_radius = {:e}\ninertia = {:e}\n\
             mass = {:e}\nbearing_stiffness = [{:e}, {:e}]\nground_stiffness = {:e}\n\
             [[gear]]\nname = \"ring\"\nteeth = 96\ninternal = true\nbase_radius = {:e}\n\
             inertia = {:e}\nmass = {:e}\nbearing_stiffness = [{:e}, {:e}]\n\
             ground_stiffness = {:e}\n",
            RADIUS[0],
            inertia(0),
            self.mass[0],
            self.bearing[0],
            self.bearing[0],
            ground(0),
            RADIUS[1],
            inertia(1),
            self.mass[1],
            self.bearing[1],
            self.bearing[1],
            ground(1),
        );
        for p in 0..n {
            t += &format!(
                "[[gear]]\nname = \"planet{}\"\nteeth = 35\nbase_radius = {:e}\ninertia = {:e}\n\
                 mass = {:e}\nbearing_stiffness = [{:e}, {:e}]\ncarrier = \"carrier\"\n\
                 position_angle = {:e}\npin_error = [{:e}, {:e}]\n",
                p + 1,
                RADIUS[3],
                inertia(3),
                self.mass[3],
                self.bearing[3],
                self.bearing[3],
                360.0 * p as f64 / n as f64,
                self.pin_errors[p][0],
                self.pin_errors[p][1],
            );
        }
        t += &format!(
            "[[carrier]]\nname = \"carrier\"\nradius = {:e}\ninertia = {:e}\nmass = {:e}\n\
             bearing_stiffness = [{:e}, {:e}]\nground_stiffness = {:e}\nfixed = \"{}\"\n",
            RADIUS[2],
            inertia(2),
            self.mass[2],
            self.bearing[2],
            self.bearing[2],
            ground(2),
            self.fixed,
        );
        for p in 1..=n {
            for (pinion, gear, name) in [
                ("sun".to_string(), format!("planet{p}"), format!("sp{p}")),
                (format!("planet{p}"), "ring".to_string(), format!("rp{p}")),
            ] {
                t += &format!(
                    "[[mesh]]\nname = \"{name}\"\npinion = \"{pinion}\"\ngear = \"{gear}\"\n\
                     contact = \"linear\"\npressure_angle = {PRESSURE_ANGLE_DEG}\n\
                     stiffness = {{ kind = \"constant\", value = {MESH_STIFFNESS:e} }}\n"
                );
            }
        }
        t += &format!(
            "[operating]\ninput_gear = \"{}\"\noutput_gear = \"{}\"\ninput_speed = 100.0\n\
             input_torque = 100.0\n",
            self.input, self.output
        );
        t
    }

    fn scene(&self) -> Scene {
        Scene::from_toml_str(&self.toml(), "planetary test scene")
            .unwrap_or_else(|e| panic!("{e}\n{}", self.toml()))
    }
}

/// Lin & Parker (1999) Table 2: natural frequencies of the example system, Hz, by mode type
/// (rotational; translational, each twice; planet modes, each N − 3 times).
fn printed(planets: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    match planets {
        3 => (
            vec![0.0, 1475.7, 1930.3, 2658.3, 7462.8, 11775.3],
            vec![743.2, 1102.4, 1896.0, 2276.4, 6986.3, 9647.9],
            vec![],
        ),
        4 => (
            vec![0.0, 1536.6, 1970.6, 2625.7, 7773.6, 13071.1],
            vec![727.0, 1091.0, 1892.8, 2342.5, 7189.9, 10437.6],
            vec![1808.2, 5963.8, 6981.7],
        ),
        5 => (
            vec![0.0, 1567.4, 2006.1, 2614.8, 8065.4, 14253.1],
            vec![710.0, 1072.0, 1888.1, 2425.3, 7382.4, 11172.3],
            vec![1808.2, 5963.8, 6981.7],
        ),
        _ => unreachable!(),
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ModeType {
    Rotational,
    Translational,
    Planet,
}

/// The central members' translation, the central members' rotation and the planets'
/// coordinates of a mode shape, as index lists.
struct Parts {
    central_translation: Vec<usize>,
    central_rotation: Vec<usize>,
    /// Per planet: its radial, tangential and rotation coordinates.
    planet: Vec<[usize; 3]>,
}

fn parts(scene: &Scene, asm: &Assembly) -> Parts {
    let st = &scene.planetary[0];
    let central = [st.sun, st.ring, st.carrier];
    let find = |kind: DofKind| asm.dofs.iter().position(|&d| d == kind).unwrap();
    Parts {
        central_translation: central
            .iter()
            .flat_map(|&g| [find(DofKind::X { gear: g }), find(DofKind::Y { gear: g })])
            .collect(),
        central_rotation: central
            .iter()
            .map(|&g| find(DofKind::Rotation { gear: g }))
            .collect(),
        planet: st
            .planets
            .iter()
            .map(|p| {
                [
                    find(DofKind::Radial { gear: p.gear }),
                    find(DofKind::Tangential { gear: p.gear }),
                    find(DofKind::Rotation { gear: p.gear }),
                ]
            })
            .collect(),
    }
}

/// Relative size below which a part of a mode shape counts as not moving (the shapes are
/// scaled to a largest entry of 1; the eigenvectors are accurate to ~1e-13 here).
const STILL: f64 = 1e-9;

/// The type of a mode shape by Lin & Parker's (1999) definitions, or `None` if it is none.
fn mode_type(p: &Parts, shape: &[f64]) -> Option<ModeType> {
    let size = |idx: &[usize]| idx.iter().fold(0.0f64, |a, &i| a.max(shape[i].abs()));
    let top = shape.iter().fold(0.0f64, |a, &x| a.max(x.abs()));
    let planets_alike = p
        .planet
        .iter()
        .all(|q| (0..3).all(|k| (shape[q[k]] - shape[p.planet[0][k]]).abs() <= STILL * top));
    let still_translation = size(&p.central_translation) <= STILL * top;
    let still_rotation = size(&p.central_rotation) <= STILL * top;
    if still_translation && still_rotation {
        Some(ModeType::Planet)
    } else if still_translation && planets_alike {
        Some(ModeType::Rotational)
    } else if still_rotation {
        Some(ModeType::Translational)
    } else {
        None
    }
}

/// Groups the modes into clusters of equal frequency (1e-6 relative; the types' frequencies of
/// the example lie ≥ 1e-3 apart) and checks each cluster's type and multiplicity.
fn check_structure(stage: &Stage) -> Vec<(ModeType, f64, usize)> {
    let scene = stage.scene();
    let asm = Assembly::new(&scene);
    let all = modes(&asm);
    let p = parts(&scene, &asm);
    let n = stage.planets;
    assert_eq!(all.len(), 3 * (n + 3));
    let mut clusters: Vec<(ModeType, f64, usize)> = Vec::new();
    let mut i = 0;
    while i < all.len() {
        let f0 = all[i].frequency;
        let mut j = i + 1;
        while j < all.len() && (all[j].frequency - f0).abs() <= 1e-6 * f0.max(1.0) {
            j += 1;
        }
        let f_last = all[j - 1].frequency;
        assert!(
            (f_last - f0).abs() <= 1e-9 * f0,
            "N = {n}: modes {i}..{j} at {f0} .. {f_last} Hz differ by more than 1e-9"
        );
        let types: Vec<Option<ModeType>> = all[i..j]
            .iter()
            .map(|m| mode_type(&p, m.shape.as_slice()))
            .collect();
        let kind = types[0].unwrap_or_else(|| {
            panic!(
                "N = {n}: mode {i} at {f0} Hz is none of the three types: {:?}",
                all[i].shape
            )
        });
        assert!(
            types.iter().all(|&t| t == Some(kind)),
            "N = {n}: modes at {f0} Hz mix types {types:?}"
        );
        let expected = match kind {
            ModeType::Rotational => 1,
            ModeType::Translational => 2,
            ModeType::Planet => n - 3,
        };
        assert_eq!(
            j - i,
            expected,
            "N = {n}: {kind:?} mode at {f0} Hz has multiplicity {}",
            j - i
        );
        clusters.push((kind, f0, j - i));
        i = j;
    }
    let count = |k: ModeType| clusters.iter().filter(|c| c.0 == k).count();
    assert_eq!(count(ModeType::Rotational), 6, "N = {n}: {clusters:?}");
    assert_eq!(count(ModeType::Translational), 6, "N = {n}: {clusters:?}");
    assert_eq!(
        count(ModeType::Planet),
        if n > 3 { 3 } else { 0 },
        "N = {n}: {clusters:?}"
    );
    clusters
}

#[test]
fn modal_structure_of_lin_parker_1999_for_3_4_5_planets() {
    for n in [3, 4, 5] {
        check_structure(&Stage::lin_parker(n));
    }
}

#[test]
fn modal_structure_holds_off_the_example() {
    // Other masses, supports and a held carrier: the structure is a property of the cyclic
    // symmetry, not of the example's numbers.
    for n in [3, 4, 5] {
        let mut s = Stage::lin_parker(n);
        s.mass = [1.3, 4.1, 2.2, 0.9];
        s.inertia_over_r2 = [0.8, 2.5, 3.1, 0.45];
        s.bearing = [3e8, 7e7, 2e8, 1.5e8];
        s.torsional = [2e7, 4e8, 1e8];
        check_structure(&s);
    }
}

#[test]
fn natural_frequencies_match_lin_parker_1999_table_2() {
    for n in [3, 4, 5] {
        let clusters = check_structure(&Stage::lin_parker(n));
        let (rotational, translational, planet) = printed(n);
        for (kind, expected) in [
            (ModeType::Rotational, rotational),
            (ModeType::Translational, translational),
            (ModeType::Planet, planet),
        ] {
            let got: Vec<f64> = clusters
                .iter()
                .filter(|c| c.0 == kind)
                .map(|c| c.1)
                .collect();
            assert_eq!(got.len(), expected.len(), "N = {n} {kind:?}: {got:?}");
            for (g, e) in got.iter().zip(&expected) {
                let error = if *e == 0.0 {
                    g.abs()
                } else {
                    (g - e).abs() / e
                };
                println!(
                    "N = {n} {kind:?}: {g:.2} Hz vs printed {e} Hz ({:.3} %)",
                    100.0 * error
                );
                assert!(error <= 0.005, "N = {n} {kind:?}: {g} Hz vs printed {e} Hz");
            }
        }
    }
}

#[test]
fn planet_modes_do_not_depend_on_the_central_members() {
    for n in [4, 5] {
        let base = Stage::lin_parker(n);
        let planet_modes = |s: &Stage| -> Vec<f64> {
            check_structure(s)
                .iter()
                .filter(|c| c.0 == ModeType::Planet)
                .map(|c| c.1)
                .collect()
        };
        let reference = planet_modes(&base);
        let mut other = base.clone();
        other.mass[..3].copy_from_slice(&[3.0, 0.7, 11.0]);
        other.inertia_over_r2[..3].copy_from_slice(&[2.1, 0.9, 17.0]);
        other.bearing[..3].copy_from_slice(&[4e7, 6e8, 2.5e9]);
        other.torsional = [3e8, 2e7, 5e9];
        let changed = planet_modes(&other);
        assert_eq!(reference.len(), 3);
        for (a, b) in reference.iter().zip(&changed) {
            assert!(
                (a - b).abs() <= 1e-12 * a,
                "N = {n}: planet mode {a} Hz became {b} Hz ({:e} relative)",
                (a - b) / a
            );
        }
        // The planet-mode frequencies do change with the planets' own parameters: the check
        // above can fail.
        let mut planet = base.clone();
        planet.mass[3] *= 1.1;
        assert!((planet_modes(&planet)[0] - reference[0]).abs() > 1e-3 * reference[0]);
    }
}

/// The static mesh forces of a scene (input torque on the input gear, the balanced load on
/// the output gear, the held member reacting).
fn mesh_forces(scene: &Scene) -> Vec<f64> {
    let asm = Assembly::new(scene);
    statics::equilibrium(
        &asm,
        scene.operating.input_torque,
        scene.operating.load_torque,
        false,
    )
    .unwrap()
    .mesh_force
}

#[test]
fn equal_spacing_shares_the_load_equally() {
    for n in [3, 4, 5] {
        for (input, output, fixed) in [
            ("sun", "carrier", "ring"),
            ("carrier", "sun", "ring"),
            ("sun", "ring", "carrier"),
        ] {
            let mut stage = Stage::lin_parker(n);
            (stage.input, stage.output, stage.fixed) = (input, output, fixed);
            // The held member's support: a torsional spring on it alone.
            stage.torsional = match fixed {
                "ring" => [0.0, 1e9, 0.0],
                _ => [0.0, 0.0, 1e9],
            };
            let scene = stage.scene();
            let force = mesh_forces(&scene);
            let sharing = &planetary::load_sharing(&scene, &force)[0];
            for l in sharing {
                assert!(
                    (l.share - 1.0 / n as f64).abs() <= 1e-12,
                    "N = {n}, {input} → {output}: share {}",
                    l.share
                );
            }
            // The sun's moment balance: Σ F_sn r_s = T_s (the sun's torque is the input torque,
            // or the balanced load when the sun is the output).
            let sun_torque = if input == "sun" {
                scene.operating.input_torque
            } else {
                scene.operating.load_torque
            };
            // Positive mesh forces: σ follows the sun's torque, whichever member drives.
            assert!(sharing
                .iter()
                .all(|l| l.sun_force > 0.0 && l.ring_force > 0.0));
            let total: f64 = sharing.iter().map(|l| l.sun_force).sum();
            assert!(
                (total * RADIUS[0] - sun_torque.abs()).abs() <= 1e-12 * sun_torque.abs(),
                "N = {n}, {input} → {output}: Σ F_sn r_s = {} vs {sun_torque}",
                total * RADIUS[0]
            );
        }
    }
}

#[test]
fn a_pin_error_unbalances_the_load() {
    // The direction of the effect (the oracle of its size is tests/python): a planet whose pin
    // sits ahead in the sense the sun pushes it (σ) is further from the sun's flanks and
    // carries less of the load; its neighbours carry more.
    let mut stage = Stage::lin_parker(4);
    stage.pin_errors[0] = [0.0, 2e-6];
    let scene = stage.scene();
    let sharing = &planetary::load_sharing(&scene, &mesh_forces(&scene))[0];
    let total: f64 = sharing.iter().map(|l| l.share).sum();
    assert!((total - 1.0).abs() < 1e-12);
    assert!(sharing[0].share < 0.25 - 1e-3, "{sharing:?}");
    assert!(sharing[1].share > 0.25 + 1e-3, "{sharing:?}");
    assert!(
        (sharing[1].share - sharing[3].share).abs() < 1e-12,
        "{sharing:?}"
    );
}

#[test]
fn the_nominal_speed_form_runs_and_carried_rotation_needs_consistent_geometry() {
    // Lin & Parker's Table 1 is not geometrically consistent (r_c cos α ≠ r_s + r_p): the
    // nominal-speed form runs it, a torque port (carried rotation at Willis' speeds) is refused
    // with the relation it breaks.
    let stage = Stage::lin_parker(3);
    let scene = stage.scene();
    assert!(scene.run().is_ok());
    let text = format!(
        "{}[[port]]\nname = \"input\"\ngear = \"sun\"\ncausality = \"torque\"\ntorque = 100.0\n",
        stage.toml().replace("input_torque = 100.0\n", "")
    );
    let scene = Scene::from_toml_str(&text, "ports").unwrap();
    let why = match scene.run() {
        Ok(_) => panic!("an inconsistent stage ran with carried rotation"),
        Err(e) => e,
    };
    assert!(
        why.contains("Carried rotation") && why.contains("not in the ratio of their teeth"),
        "{why}"
    );
    let why = geardyn::model::train::GearTrain::new(&scene).err().unwrap();
    assert!(why.contains("planetary"), "{why}");
}

/// A shipped scene, the speed range of its sweeps, and the commands that refuse it with the
/// reason they give.
type Shipped = (
    &'static str,
    &'static str,
    &'static [(&'static str, &'static str)],
);

/// Every command on each shipped planetary scene (`examples/planetary/`) runs (exit 0) or, where
/// it cannot apply, exits 1 naming why: `floquet` and `band` (the linear periodic system) on the
/// contact-loss stage, `waterfall` without a run-up, and `modes --rigid-bearings` (rigid planet
/// pins are a constraint, not removed DOFs). Never a panic.
#[test]
fn every_command_runs_or_refuses_with_the_reason() {
    let bin = env!("CARGO_BIN_EXE_geardyn");
    let dir = std::env::temp_dir().join(format!("geardyn_planetary_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = |name: &str| dir.join(name).to_string_lossy().into_owned();
    let run = |args: &[&str]| {
        let o = std::process::Command::new(bin).args(args).output().unwrap();
        (
            o.status.code(),
            String::from_utf8_lossy(&o.stdout).into_owned(),
            String::from_utf8_lossy(&o.stderr).into_owned(),
        )
    };
    // (scene, speed range, commands that refuse and the reason they give)
    let shipped: [Shipped; 3] = [
        ("lin_parker_1999", "50:100", &[]),
        (
            "ev_reducer_3p",
            "800:1000",
            &[
                ("floquet", "needs contact = \"linear\""),
                ("band", "needs contact = \"linear\""),
            ],
        ),
        ("five_planet_stage", "250:300", &[]),
    ];
    for (name, speeds, refusals) in shipped {
        let scene = format!(
            "{}/examples/planetary/{name}.toml",
            env!("CARGO_MANIFEST_DIR")
        );
        let scene = scene.as_str();
        let (code, stdout, stderr) = run(&["modes", scene]);
        assert_eq!(code, Some(0), "{stderr}");
        assert!(stdout.contains("planet load sharing"), "{stdout}");
        let commands: Vec<Vec<String>> = vec![
            vec![
                "simulate".into(),
                scene.into(),
                "--out".into(),
                out("a.csv"),
                "--stop-time".into(),
                "0.01".into(),
            ],
            vec![
                "spectrum".into(),
                scene.into(),
                "--out".into(),
                out("s.csv"),
            ],
            vec!["periodic".into(), scene.into()],
            vec![
                "sweep".into(),
                scene.into(),
                "--speed".into(),
                format!("{speeds}:3"),
                "--out".into(),
                out("w.csv"),
            ],
            vec![
                "hb".into(),
                scene.into(),
                "--speed".into(),
                speeds.into(),
                "--out".into(),
                out("h.csv"),
            ],
            vec!["floquet".into(), scene.into()],
            vec!["band".into(), scene.into(), "--speed".into(), speeds.into()],
            vec![
                "fmu".into(),
                "build".into(),
                scene.into(),
                "--out".into(),
                out("fmu"),
            ],
            vec![
                "waterfall".into(),
                scene.into(),
                "--out".into(),
                out("wf.png"),
            ],
        ];
        for args in commands {
            let args: Vec<&str> = args.iter().map(String::as_str).collect();
            let (code, _, stderr) = run(&args);
            let why = match args[0] {
                "waterfall" => Some("needs a run-up"),
                c => refusals.iter().find(|r| r.0 == c).map(|r| r.1),
            };
            assert!(!stderr.contains("panicked"), "{name} {args:?}: {stderr}");
            match why {
                None => assert_eq!(code, Some(0), "{name} {args:?}: {stderr}"),
                Some(why) => {
                    assert_eq!(code, Some(1), "{name} {args:?}: {stderr}");
                    assert!(stderr.contains(why), "{name} {args:?}: {stderr}");
                }
            }
        }
        let (code, _, stderr) = run(&["modes", scene, "--rigid-bearings"]);
        assert_eq!(code, Some(1), "{stderr}");
        assert!(stderr.contains("planetary stage"), "{stderr}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// The LP stage (N = 4) with a parallel stage on the carrier's shaft: pinion `out_pinion`
/// (rigid shaft to the carrier) driving `out_wheel`, the output.
fn with_parallel_stage(stage: &Stage, load_torque: f64) -> String {
    let text = stage.toml().replace(
        "output_gear = \"carrier\"",
        &format!("output_gear = \"out_wheel\"\nload_torque = {load_torque:e}"),
    );
    let (head, operating) = text.split_at(text.find("[operating]").unwrap());
    format!(
        "{head}[[gear]]\nname = \"out_pinion\"\nteeth = 23\nbase_radius = 0.03\ninertia = 2e-4\n\
         [[gear]]\nname = \"out_wheel\"\nteeth = 41\nbase_radius = 0.0534782608695652\n\
         inertia = 4e-3\n\
         [[shaft]]\ngears = [\"carrier\", \"out_pinion\"]\nrigid = true\n\
         [[mesh]]\nname = \"parallel\"\npinion = \"out_pinion\"\ngear = \"out_wheel\"\n\
         contact = \"linear\"\nstiffness = {{ kind = \"constant\", value = 3e8 }}\n{operating}"
    )
}

#[test]
fn a_planetary_stage_followed_by_a_parallel_stage() {
    let stage = Stage::lin_parker(4);
    let alone = stage.scene();
    let w_c = RADIUS[2] * 2.0 * PRESSURE_ANGLE_DEG.to_radians().cos();
    let carrier_torque = 100.0 * w_c / RADIUS[0];
    let load = carrier_torque * 0.0534782608695652 / 0.03;
    let scene = Scene::from_toml_str(&with_parallel_stage(&stage, load), "combined").unwrap();

    // Kinematics: Willis through the stage, then the fixed-axis ratio (closed forms).
    let g = |name: &str| scene.gear_index(name).unwrap();
    let carrier = 27.0 / (27.0 + 96.0);
    let planet = carrier - 27.0 / 35.0 * (1.0 - carrier);
    let signed = |i: usize| scene.speed_ratio[i] * scene.rotation[i];
    for (name, expected) in [
        ("carrier", carrier),
        ("ring", 0.0),
        ("planet3", planet),
        ("out_pinion", carrier),
        ("out_wheel", -carrier * 23.0 / 41.0),
    ] {
        assert!(
            (signed(g(name)) - expected).abs() <= 1e-15,
            "{name}: {} vs {expected}",
            signed(g(name))
        );
    }
    let stage_mesh = scene.planetary[0].planets[0].sun_mesh;
    assert!((scene.meshes[stage_mesh].cycles_per_input_rev - 27.0 * (1.0 - carrier)).abs() < 1e-12);

    // Planet and translational modes leave the carrier's rotation still, so the parallel
    // stage on its shaft keeps them (with their multiplicity); the rotational modes change.
    let clusters = check_structure(&stage);
    let combined: Vec<f64> = modes(&Assembly::new(&scene))
        .iter()
        .map(|m| m.frequency)
        .collect();
    let alone_f: Vec<f64> = modes(&Assembly::new(&alone))
        .iter()
        .map(|m| m.frequency)
        .collect();
    assert_eq!(combined.len(), alone_f.len() + 1);
    let count = |f: f64, tol: f64| {
        combined
            .iter()
            .filter(|&&c| (c - f).abs() <= tol * f)
            .count()
    };
    let mut moved = 0;
    for (kind, f, multiplicity) in clusters {
        match kind {
            ModeType::Planet | ModeType::Translational => {
                assert_eq!(
                    count(f, 1e-9),
                    multiplicity,
                    "{kind:?} {f} Hz in {combined:?}"
                )
            }
            // The low rotational modes, where the carrier moves most, shift by ~1 %.
            ModeType::Rotational => moved += usize::from(f > 0.0 && count(f, 1e-3) == 0),
        }
    }
    assert!(moved >= 3, "{combined:?}");

    // Statics through both stages: equal sharing, and the parallel mesh carries the carrier's
    // torque.
    let force = mesh_forces(&scene);
    for l in &planetary::load_sharing(&scene, &force)[0] {
        assert!((l.share - 0.25).abs() <= 1e-12, "{}", l.share);
    }
    let parallel = scene
        .meshes
        .iter()
        .position(|m| m.name == "parallel")
        .unwrap();
    let expected = carrier_torque / 0.03;
    assert!(
        (force[parallel] - expected).abs() <= 1e-9 * expected,
        "{} vs {expected}",
        force[parallel]
    );
}

#[test]
fn bad_planetary_input_is_refused_naming_the_field() {
    let extra_gear = |name: &str, internal: &str| {
        format!(
            "[[gear]]\nname = \"{name}\"\nteeth = 27\nbase_radius = {:e}\ninertia = 1e-3\n{internal}",
            RADIUS[0]
        )
    };
    let extra_mesh = |pinion: &str, gear: &str| {
        format!(
            "[[mesh]]\nname = \"extra\"\npinion = \"{pinion}\"\ngear = \"{gear}\"\n\
             contact = \"linear\"\npressure_angle = {PRESSURE_ANGLE_DEG}\n\
             stiffness = {{ kind = \"constant\", value = {MESH_STIFFNESS:e} }}\n"
        )
    };
    let base = Stage::lin_parker(3).toml();
    let cases = [
        (
            base.replacen("position_angle = 0e0\n", "", 1),
            "gear[2].position_angle: missing",
        ),
        (
            base.replacen(
                "bearing_stiffness = [1e8, 1e8]",
                "bearing_stiffness = [1e8, 2e8]",
                1,
            ),
            "gear[0].bearing_stiffness",
        ),
        (
            base.replacen(
                "pressure_angle = 24.6\n",
                "pressure_angle = 24.6\ncentre_angle = 0.3\n",
                1,
            ),
            "mesh[0].centre_angle = 0.3",
        ),
        (
            base.replacen(
                "ground_stiffness = 0e0\n",
                "ground_stiffness = 0e0\nposition_angle = 5.0\n",
                1,
            ),
            "gear[0].position_angle",
        ),
        (
            base.replace("fixed = \"ring\"", "fixed = \"planet1\""),
            "carrier[0].fixed = \"planet1\"",
        ),
        (
            base.replacen("internal = true\n", "", 1),
            "a planet drives the ring",
        ),
        (
            format!(
                "{base}{}{}",
                extra_gear("sun2", ""),
                extra_mesh("sun2", "planet1")
            ),
            "mesh[6].pinion: planet \"planet1\" meshes with a second sun",
        ),
        (
            format!(
                "{base}{}{}",
                extra_gear("ring2", "internal = true\n"),
                extra_mesh("planet1", "ring2")
            ),
            "mesh[6].gear: planet \"planet1\" meshes with a second ring",
        ),
    ];
    let mut ring_input = Stage::lin_parker(3);
    ring_input.input = "ring";
    let cases = [
        cases.as_slice(),
        &[(ring_input.toml(), "its fixed member \"ring\" would turn")],
    ]
    .concat();
    for (text, expected) in cases {
        let e = Scene::from_toml_str(&text, "bad")
            .err()
            .unwrap_or_else(|| panic!("accepted: {expected}"));
        assert!(
            e.to_string().contains(expected),
            "expected {expected:?} in: {e}"
        );
    }
}
