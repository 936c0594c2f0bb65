//! Steady-state and stability analysis on top of the model and the propagators.

pub mod floquet;
pub mod shooting;
pub mod sweep;

pub use floquet::{exact_monodromy, Floquet};
pub use shooting::{shoot, PeriodicOrbit, ShootingOptions, Stability};
pub use sweep::{sweep, Direction, SweepOptions, SweepPoint, SWEEP_COLUMNS};
