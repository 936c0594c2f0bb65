//! Mesh-level functions of the mesh phase: stiffness sources and transmission-error series.
//!
//! Everything here is a function of the **mesh phase** `p` (mesh cycles), never of time: the
//! model turns time into phase with its nominal-speed clock (`docs/model.md`, "Mesh phase").

pub mod eccentricity;
pub mod errors;
pub mod geometry;
pub mod helical;
pub mod series;
pub mod stiffness;

pub use series::PhaseSeries;

/// The fraction `p − ⌊p⌋ ∈ [0, 1]` of a mesh phase: the same value as `crate::mesh::cycle_fraction(p)`
/// (both are one rounding of the exact fraction; only the sign of a zero may differ), without
/// the software `fmod`, which costs as much as the `sin_cos` of a harmonic.
#[inline]
pub fn cycle_fraction(p: f64) -> f64 {
    p - p.floor()
}
pub use stiffness::{MeshStiffness, Piece};
