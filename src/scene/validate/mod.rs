//! Validation of a scene: the one tree that turns a parsed [`super::spec::SceneSpec`] into
//! the resolved scene of the kernel [`super::kernel`] chose (ranges, consistency, defaults,
//! kinematics). Every message names the field as the file wrote it, with its value; nothing
//! is clamped.
//!
//! - [`checks`]: the field checks, `[solver]` and `[initial]`, shared by everything below;
//! - [`stiffness`], [`geometry`], [`helical`]: the mesh-stiffness sources of any mesh;
//! - [`mesh`]: what every mesh checks the same (contact law, damping);
//! - [`errors`]: runout and pitch errors of a gear;
//! - [`friction`]: `[mesh.friction]` of a Model-1 or helical mesh;
//! - [`planetary`]: carriers, planets and the stages they form (`docs/planetary.md`);
//! - [`drivetrain`]: the scene and each of its meshes, whichever kernel runs it (topology,
//!   kinematics, bearings, shafts, ports and elements; the single-pair kernel's own terms).

pub(crate) mod checks;
pub(crate) mod drivetrain;
pub(crate) mod errors;
pub(crate) mod friction;
pub(crate) mod geometry;
pub(crate) mod helical;
pub(crate) mod mesh;
pub(crate) mod planetary;
pub(crate) mod stiffness;
