//! `modes`: natural frequencies and mode shapes of a drivetrain's mean system, and its
//! statics, as `geardyn modes` reports them.

use std::io::Write;

use crate::model::train::mesh::CycleTable;
use crate::model::train::{self, statics, Assembly, GearTrain, Mode};
use crate::scene::train::MeshForceModel;
use crate::scene::Scene;

/// The modes of a drivetrain's mean system, in the order the report lists them.
pub struct Modes {
    /// Physical coordinate of every mode-shape entry.
    pub labels: Vec<String>,
    pub modes: Vec<Mode>,
}

/// Computes the modes of `scene` (with `rigid_bearings`, of the purely rotational model) and
/// writes the report of `geardyn modes` to `out` as it goes: the CLI streams it to stdout,
/// so a failure late in the report (the friction statics) still shows everything before it.
pub fn modes(scene: &Scene, rigid_bearings: bool, out: &mut dyn Write) -> Result<Modes, String> {
    let io = |e: std::io::Error| format!("cannot write the report: {e}");
    if let (true, Some(st)) = (rigid_bearings, scene.planetary.first()) {
        // Rigid planet pins slave each planet's translation to the carrier (a constraint, not
        // a removed DOF); the purely torsional planetary model is not built yet.
        return Err(format!(
            "--rigid-bearings: scene {:?} has a planetary stage (carrier {:?}) whose planets sit \
             on the carrier's pins; the purely torsional planetary model is not available yet \
             (docs/planetary.md), run modes with the scene's bearings",
            scene.name, scene.gears[st.carrier].name
        ));
    }
    if let Some(why) = train::frame::gyroscopic_refusal(scene) {
        return Err(why);
    }
    let scene = if rigid_bearings {
        scene.with_rigid_bearings()
    } else {
        scene.clone()
    };
    let asm = Assembly::new(&scene);
    let all = train::modes(&asm);
    writeln!(
        out,
        "scene {} ({} DOF, mean mesh stiffness, {} bearings)",
        scene.name,
        asm.dim(),
        if rigid_bearings { "rigid" } else { "scene" }
    )
    .map_err(io)?;
    for st in scene.planetary.iter().filter(|s| s.gyroscopic) {
        writeln!(
            out,
            "carrier {} frame at {} rad/s, gyroscopic = true: frequencies of M q'' + Ω_c G q' + \
             (K_b + K_m − Ω_c² K_Ω) q = 0 (Lin & Parker 1999 eq. 1); the shapes are complex, \
             listed as the real part of each divided by its largest entry",
            scene.gears[st.carrier].name,
            train::planetary::carrier_speed(&scene, st)
        )
        .map_err(io)?;
    }
    write!(out, "{:>4} {:>12}  {:<6}", "mode", "f [Hz]", "kind").map_err(io)?;
    for label in &asm.labels {
        write!(out, " {label:>12}").map_err(io)?;
    }
    writeln!(out).map_err(io)?;
    for (i, m) in all.iter().enumerate() {
        write!(
            out,
            "{:>4} {:>12.3}  {:<6}",
            i + 1,
            m.frequency,
            if m.rigid { "rigid" } else { "" }
        )
        .map_err(io)?;
        for v in m.shape.iter() {
            write!(out, " {v:>12.5}").map_err(io)?;
        }
        writeln!(out).map_err(io)?;
    }
    let t_in = scene.operating.input_torque;
    let t_load = scene.operating.load_torque;
    writeln!(out, "statics (input {t_in} N·m, load {t_load} N·m; ground couplings carry no mean torque, Liu 2007 eq. 2.8):").map_err(io)?;
    match statics::equilibrium(&asm, t_in, t_load, false) {
        Ok(st) => {
            for (n, m) in scene.meshes.iter().enumerate() {
                writeln!(
                    out,
                    "  {:<10} mesh force {:>12.4} N   mean deflection {:>12.6e} m   DTE {:>12.6e} m",
                    m.name, st.mesh_force[n], st.deflection[n], st.dte[n]
                )
                .map_err(io)?;
                if let MeshForceModel::Pairs { pair, relief, .. } = &m.force {
                    // Loaded STE and NLTE by active set (Liu 2007 eq. 2.8).
                    let table = CycleTable::pairs(pair, relief);
                    let ste = statics::loaded_ste(&table, st.mesh_force[n]);
                    let nlte = statics::loaded_ste(&table, 0.0);
                    writeln!(
                        out,
                        "  {:<10} loaded STE mean {:.6e} m, p-p {:.6e} m; NLTE p-p {:.6e} m",
                        "",
                        ste.mean(),
                        ste.peak_to_peak(),
                        nlte.peak_to_peak()
                    )
                    .map_err(io)?;
                }
            }
        }
        Err(e) => writeln!(out, "  {e}").map_err(io)?,
    }
    if !scene.planetary.is_empty() {
        if let Ok(st) = statics::equilibrium(&asm, t_in, t_load, false) {
            planet_loads(&scene, &st.mesh_force, out).map_err(io)?;
        }
    }
    if scene.meshes.iter().any(|m| m.friction.is_some()) {
        // The statics above are of the frictionless mean system (modes too); with friction
        // the static mesh force depends on the phase (Liu 2007 eq. 4.40).
        let train = GearTrain::new(&scene)?;
        writeln!(
            out,
            "with tooth friction, frozen at the initial mesh phases (Liu 2007 eq. 4.40):"
        )
        .map_err(io)?;
        match train.frozen_equilibrium(0.0) {
            Ok(st) => {
                for (n, m) in scene.meshes.iter().enumerate() {
                    writeln!(
                        out,
                        "  {:<10} mesh force {:>12.4} N   friction force {:>12.4} N",
                        m.name, st.mesh_force[n], st.friction_force[n]
                    )
                    .map_err(io)?;
                }
            }
            Err(e) => writeln!(out, "  {e}").map_err(io)?,
        }
    }
    Ok(Modes {
        labels: asm.labels.clone(),
        modes: all,
    })
}

/// The planets' load sharing of every planetary stage (docs/planetary.md), forces in full
/// precision (shortest round-trip form) for the independent oracle of `tests/python`.
fn planet_loads(scene: &Scene, mesh_force: &[f64], out: &mut dyn Write) -> std::io::Result<()> {
    for (st, loads) in scene
        .planetary
        .iter()
        .zip(train::planetary::load_sharing(scene, mesh_force))
    {
        writeln!(
            out,
            "planet load sharing, carrier {} (share of the sun-mesh load; 1/N = {:e}):",
            scene.gears[st.carrier].name,
            1.0 / st.planets.len() as f64
        )?;
        for l in loads {
            writeln!(
                out,
                "  {:<10} share {:e}   sun mesh force {:e} N   ring mesh force {:e} N",
                scene.gears[l.gear].name, l.share, l.sun_force, l.ring_force
            )?;
        }
    }
    Ok(())
}
