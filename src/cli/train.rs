//! The drivetrain commands of the `geardyn` CLI: `modes`, and `simulate` for train scenes.

use std::path::{Path, PathBuf};

use clap::Args;

use geardyn::model::train::mesh::CycleTable;
use geardyn::model::train::{modes, statics, Assembly, GearTrain};
use geardyn::scene::train::{MeshForceModel, TrainScene};

#[derive(Args)]
pub struct ModesArgs {
    /// Scene file or folder (e.g. `fmu/idler_gearset`).
    pub scene: PathBuf,
    /// Remove the bearing translations (purely rotational model).
    #[arg(long)]
    pub rigid_bearings: bool,
}

/// `geardyn modes`: natural frequencies and mode shapes of the mean system, and the statics.
pub fn modes_command(path: &Path, rigid_bearings: bool) -> Result<(), String> {
    let mut scene = TrainScene::from_path(path).map_err(|e| e.to_string())?;
    if rigid_bearings {
        scene = scene.with_rigid_bearings();
    }
    let asm = Assembly::new(&scene);
    let all = modes(&asm);
    println!(
        "scene {} ({} DOF, mean mesh stiffness, {} bearings)",
        scene.name,
        asm.dim(),
        if rigid_bearings { "rigid" } else { "scene" }
    );
    print!("{:>4} {:>12}  {:<6}", "mode", "f [Hz]", "kind");
    for label in &asm.labels {
        print!(" {label:>12}");
    }
    println!();
    for (i, m) in all.iter().enumerate() {
        print!(
            "{:>4} {:>12.3}  {:<6}",
            i + 1,
            m.frequency,
            if m.rigid { "rigid" } else { "" }
        );
        for v in m.shape.iter() {
            print!(" {v:>12.5}");
        }
        println!();
    }
    let t_in = scene.operating.input_torque;
    let t_load = scene.operating.load_torque;
    println!("statics (input {t_in} N·m, load {t_load} N·m; ground couplings carry no mean torque, Liu 2007 eq. 2.8):");
    match statics::equilibrium(&asm, t_in, t_load, false) {
        Ok(st) => {
            for (n, m) in scene.meshes.iter().enumerate() {
                println!(
                    "  {:<10} mesh force {:>12.4} N   mean deflection {:>12.6e} m   DTE {:>12.6e} m",
                    m.name, st.mesh_force[n], st.deflection[n], st.dte[n]
                );
                if let MeshForceModel::Pairs { pair, relief, .. } = &m.force {
                    // Loaded STE and NLTE by active set (Liu 2007 eq. 2.8).
                    let table = CycleTable::pairs(pair, relief);
                    let ste = statics::loaded_ste(&table, st.mesh_force[n]);
                    let nlte = statics::loaded_ste(&table, 0.0);
                    println!(
                        "  {:<10} loaded STE mean {:.6e} m, p-p {:.6e} m; NLTE p-p {:.6e} m",
                        "",
                        ste.mean(),
                        ste.peak_to_peak(),
                        nlte.peak_to_peak()
                    );
                }
            }
        }
        Err(e) => println!("  {e}"),
    }
    if scene.meshes.iter().any(|m| m.friction.is_some()) {
        // The statics above are of the frictionless mean system (modes too); with friction
        // the static mesh force depends on the phase (Liu 2007 eq. 4.40).
        let train = GearTrain::new(&scene)?;
        println!("with tooth friction, frozen at the initial mesh phases (Liu 2007 eq. 4.40):");
        match train.frozen_equilibrium(0.0) {
            Ok(st) => {
                for (n, m) in scene.meshes.iter().enumerate() {
                    println!(
                        "  {:<10} mesh force {:>12.4} N   friction force {:>12.4} N",
                        m.name, st.mesh_force[n], st.friction_force[n]
                    );
                }
            }
            Err(e) => println!("  {e}"),
        }
    }
    Ok(())
}
