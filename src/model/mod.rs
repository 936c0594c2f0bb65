//! Model assembly: turns a validated scene into one specialised system for the solvers.
//!
//! # Sign convention (the one place it is stated)
//!
//! The dynamic transmission error (DTE) is `x = r_b1·θ1 + r_b2·θ2` in metres along the line of
//! action, with `θ1` positive in the pinion's driving direction and `θ2` positive **against**
//! the gear's nominal rotation, so `x > 0` compresses the drive flanks. `T1` drives the pinion,
//! `T2` is the magnitude of the load torque on the gear. See `docs/model.md`.

mod clock;
pub mod drivetrain;
pub mod elements;
mod pair;
pub mod train;

pub use clock::{check_phase, PhaseClock, MAX_MESH_CYCLES, MAX_MESH_PERIODS_PER_ADVANCE};
pub use drivetrain::{
    parametric_period, response_frequencies, response_period, AnySimulation, Drivetrain,
    LinearPart, MeshColumns, MeshLaw, MeshSample, SceneSource, MAX_MESH_DIRECTIONS,
};
pub use pair::{ContactState, GearPair, Inputs, PairState, MAX_RATE, OUTPUT_NAMES};
