//! The drivetrain graph model (Liu 2007 Ch. 2–4): gears with rotation and optional bearing
//! translations, shafts, and meshes with lumped or per-tooth-pair contact, assembled into one
//! hybrid system for the solvers.
//!
//! - [`assembly`]: DOFs, `M`, `K_b`, `C_b`, mesh vectors `d_n`, rigid-body reduction;
//! - [`flanks`]: the back flanks' line of action (mirrored about the line of centres);
//! - [`frame`]: whether the rotating carrier frame's gyroscopic terms apply to a scene;
//! - [`friction`]: tooth friction of Model-1 meshes over the mesh cycle (Ch. 5);
//! - [`mesh`]: the mesh cycle as tooth-pair slots with stiffness and tip-relief gaps;
//! - [`statics`]: loaded STE / NLTE by active set, static equilibrium;
//! - [`modes`]: natural frequencies and shapes of the mean system;
//! - [`planetary`]: planetary stages' mesh vectors and planet pins in the carrier frame;
//! - [`system`]: [`GearTrain`], the `HybridSystem` + `PiecewiseLti` model;
//! - [`simulation`]: [`TrainSimulation`], the propagator driver.

pub mod assembly;
pub mod flanks;
pub mod frame;
pub mod friction;
pub mod mesh;
pub mod modes;
pub mod planetary;
pub mod simulation;
pub mod statics;
pub mod system;

pub use assembly::{Assembly, DofKind, Reduction};
pub use modes::{modes, Mode};
pub use simulation::TrainSimState;
pub use simulation::{run_train, run_train_limited, train_row, TrainSimulation, TrainTrajectory};
pub use system::{
    FrozenStatics, GearTrain, MeshRunState, MeshState, Neighbour, SlotContact, TrainInputs,
    TrainRunState,
};
