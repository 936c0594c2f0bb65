//! Helical gear pair with sliding friction: contact-line geometry and the effective torsional
//! mesh stiffness (He & Singh 2007, "Analytical study of helical gear dynamics with sliding
//! friction using Floquet theory", ASME DETC2007-34078; notes and errata in
//! `shared/reference/models-he-singh-2007.md`). Format and conventions: `docs/helical.md`.
//!
//! Data flow: [`spec`] (TOML) → [`geometry`] (radii, base pitch, landmarks A, P, D, x_g;
//! checks) → [`lines`] (each pair's contact line at a mesh phase, clipped to the contact
//! rectangle and split at the pitch line, with its integrals) → [`stiffness`] (K_p, K_g, K_e
//! with friction, and the paper's piecewise-linear K_e as a [`crate::mesh::MeshStiffness`]).
//!
//! Public API for models built on the geometry (e.g. a 6-DOF model): construct a
//! [`HelicalGeometry`] from a [`HelicalPairSpec`], then per mesh phase
//! [`HelicalGeometry::pair_lines`] → [`ContactLine::integrals`] → [`ContactLineIntegrals`];
//! the sorted [`HelicalGeometry::breakpoints`] are where those integrals change formula.

pub mod geometry;
pub mod lines;
pub mod spec;
pub mod stiffness;

pub use geometry::{HelicalGear, HelicalGeometry};
pub use lines::{ContactLine, ContactLineIntegrals};
pub use spec::{HelicalGearSpec, HelicalPairSpec, HelixAngleReference};
pub use stiffness::{FrictionStiffness, TorsionalStiffness};
