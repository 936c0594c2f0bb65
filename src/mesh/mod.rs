//! Mesh-level functions of the mesh phase: stiffness sources and transmission-error series.
//!
//! Everything here is a function of the **mesh phase** `p` (mesh cycles), never of time: the
//! model turns time into phase with its nominal-speed clock (`docs/model.md`, "Mesh phase").

pub mod geometry;
pub mod helical;
pub mod series;
pub mod stiffness;

pub use series::PhaseSeries;
pub use stiffness::{MeshStiffness, Piece};
