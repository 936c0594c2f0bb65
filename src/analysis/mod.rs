//! Steady-state and stability analysis on top of the model and the propagators.

pub mod band;
pub mod floquet;
pub mod hb;
pub mod linear_period;
pub mod mesh_force;
pub mod multipliers;
pub mod shooting;
pub mod spectrum;
pub mod sweep;

pub use band::{instability_bands, InstabilityBand};
pub use floquet::monodromy;
pub use linear_period::LinearPeriodMap;
pub use multipliers::{multiplier_line, Floquet};
pub use shooting::{period_map, shoot, PeriodicOrbit, ShootingOptions, Stability};
pub use sweep::{sweep, Direction, MeshResponse, Periodicity, Sweep, SweepOptions, SweepPoint};
