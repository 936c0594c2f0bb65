//! Back flanks on their own line of action (issue 33; `docs/train.md`, "Back flanks"): closed
//! forms for a spur pair on compliant bearings held in drive and in back contact, by `simulate`
//! and by harmonic balance. The time series against an independent scipy
//! model (a planetary stage and this pair) are `tests/python/test_backflank_reference.py`.

use std::path::{Path, PathBuf};
use std::process::Command;

const ALPHA_DEG: f64 = 20.0;
const R_A: f64 = 0.03;
const K_X: f64 = 2e8;
const K_Y: f64 = 1.5e8;

/// A free pair on bearings, the pinion turning ccw at 200 rad/s, `centre_angle = 0`: the drive
/// line at α, the line of centres at α − 90°, the back line (the drive line mirrored about the
/// line of centres) at 3α. Heavy damping so that the run settles; constant stiffness.
fn pair_scene(torque: f64) -> String {
    let gear = |name: &str, teeth: u32, r: f64, inertia: f64, mass: f64| {
        format!(
            "[[gear]]\nname = \"{name}\"\nteeth = {teeth}\nbase_radius = {r:?}\ninertia = \
             {inertia:?}\nmass = {mass:?}\nbearing_stiffness = [{K_X:?}, {K_Y:?}]\n\
             bearing_damping = [3000.0, 3000.0]\n"
        )
    };
    format!(
        "name = \"back_flank_pair\"\n[model]\nbearings = \"compliant\"\n{}{}[[mesh]]\nname = \
         \"m\"\npinion = \"pinion\"\ngear = \"wheel\"\ncontact = \"backlash\"\nbacklash = 2e-7\n\
         pressure_angle = {ALPHA_DEG:?}\ncentre_angle = 0.0\ndamping = 3000.0\nstiffness = {{ \
         kind = \"constant\", value = 4e8 }}\n[operating]\ninput_gear = \"pinion\"\noutput_gear \
         = \"wheel\"\ninput_speed = 200.0\ninput_torque = {torque:?}\n",
        gear("pinion", 25, R_A, 3e-4, 1.2),
        gear("wheel", 38, 0.0456, 9e-4, 2.0),
    )
}

fn write(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("geardyn_back_flanks_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// The last row of `geardyn simulate` as (column, value) pairs.
fn settled(scene: &Path) -> Vec<(String, f64)> {
    let out = scene.with_extension("csv");
    let done = Command::new(env!("CARGO_BIN_EXE_geardyn"))
        .args([
            "simulate",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .args([
            "--stop-time",
            "0.05",
            "--output-interval",
            "0.001",
            "--method",
            "exact",
        ])
        .output()
        .unwrap();
    assert!(
        done.status.success(),
        "{}",
        String::from_utf8_lossy(&done.stderr)
    );
    let text = std::fs::read_to_string(out).unwrap();
    let mut lines = text.lines();
    let names: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    let last = lines.last().unwrap();
    names
        .into_iter()
        .zip(last.split(',').map(|v| v.parse::<f64>().unwrap()))
        .collect()
}

fn column(row: &[(String, f64)], name: &str) -> f64 {
    row.iter().find(|(n, _)| n == name).unwrap().1
}

/// Held at a steady torque the pinion's bearings react the mesh force: `k·w_a` is the force on
/// the pinion, `−F ℓ` in drive contact (at α + 180°) and `−F̃ ℓ̃` in back contact (F̃ < 0: at
/// 3α, the mirrored line), of magnitude `|T|/r_a` (the torque's arm is the base radius on both
/// flanks).
#[test]
fn bearing_reaction_follows_the_flank_in_contact() {
    for (torque, state, angle) in [(8.0, 1.0, ALPHA_DEG + 180.0), (-8.0, -1.0, 3.0 * ALPHA_DEG)] {
        let row = settled(&write(&format!("pair_{torque}.toml"), &pair_scene(torque)));
        assert_eq!(column(&row, "m.contact_state"), state, "torque {torque}");
        let (fx, fy) = (
            K_X * column(&row, "pinion.x"),
            K_Y * column(&row, "pinion.y"),
        );
        let got = fy.atan2(fx).to_degrees().rem_euclid(360.0);
        let magnitude = fx.hypot(fy);
        println!(
            "torque {torque}: bearing reaction at {got:.12}° (expected {angle}°), {magnitude} N"
        );
        assert!(
            (got - angle).abs() < 1e-9,
            "torque {torque}: {got}° against {angle}°"
        );
        assert!(
            (magnitude - 8.0 / R_A).abs() < 1e-9 * magnitude,
            "{magnitude}"
        );
        assert!((column(&row, "m.force").abs() - 8.0 / R_A).abs() < 1e-9 * magnitude);
    }
}

/// Harmonic balance takes the back flanks' own deflection as a second coordinate of the mesh
/// (`docs/train.md`, "Back flanks"): on the pair held at ±8 N·m (constant stiffness, so the
/// orbit is the static state) its orbit puts the pinion's bearing reaction at `α + 180°` in
/// drive contact and at `3α` in back contact (the mirrored line; on the drive line it would
/// lie at `α`), with the mesh force `|T|/r_a`: the closed form of the test above.
#[test]
fn harmonic_balance_puts_the_back_force_on_the_back_line() {
    use geardyn::analysis::hb::{self, HbOptions};
    use geardyn::model::Drivetrain;
    for (torque, angle) in [(8.0, ALPHA_DEG + 180.0), (-8.0, 3.0 * ALPHA_DEG)] {
        let scene = geardyn::scene::Scene::from_toml_str(&pair_scene(torque), "pair").unwrap();
        let sol = hb::solve(&scene, 200.0, None, &HbOptions::new(3)).unwrap();
        let y = sol.state_at(0.0);
        let row = geardyn::with_drivetrain!(scene.simulation().unwrap(), sim => {
            let model = sim.model();
            let mut row = Vec::new();
            model.output_row(0.0, &y, &mut row);
            model.row_names().into_iter().zip(row).collect::<Vec<_>>()
        });
        let (fx, fy) = (
            K_X * column(&row, "pinion.x"),
            K_Y * column(&row, "pinion.y"),
        );
        let got = fy.atan2(fx).to_degrees().rem_euclid(360.0);
        let force = sol.meshes[0].peak_force;
        println!("hb, torque {torque}: bearing reaction at {got:.12}° (expected {angle}°), mesh force {force} N");
        assert!(
            (got - angle).abs() < 1e-9,
            "torque {torque}: {got}° against {angle}°"
        );
        assert!((fx.hypot(fy) - 8.0 / R_A).abs() < 1e-9 * 8.0 / R_A);
        assert!((force - 8.0 / R_A).abs() < 1e-9 * force, "{force}");
    }
}
