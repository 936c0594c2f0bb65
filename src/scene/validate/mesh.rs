//! What every mesh checks the same, whichever kernel runs it: the contact law with its
//! clearance, and the mesh damping with the time scales it gives. `f` turns a key of the mesh
//! table into its TOML path as the file wrote it (`mesh.backlash`, `mesh[1].backlash`).

use super::checks::{bounded, damping_ratio_range, err, mesh_rates};
use crate::scene::spec::{ContactLawSpec, MeshSpec};
use crate::scene::{ContactLaw, SceneError};

type Result<T> = std::result::Result<T, SceneError>;

/// `contact` and `backlash` (`docs/model.md`, "Mesh force and contact law").
pub(crate) fn contact_law(f: &dyn Fn(&str) -> String, m: &MeshSpec) -> Result<ContactLaw> {
    match (m.contact, m.backlash) {
        (ContactLawSpec::Backlash, Some(b)) => Ok(ContactLaw::Backlash {
            clearance: bounded(&f("backlash"), b)?,
        }),
        (ContactLawSpec::Backlash, None) => err(format!(
            "{}: missing; contact = \"backlash\" needs the total clearance 2b in m",
            f("backlash")
        )),
        (other, Some(b)) => err(format!(
            "{} = {b}: only allowed with contact = \"backlash\" (contact is {other:?})",
            f("backlash")
        )),
        (ContactLawSpec::Linear, None) => Ok(ContactLaw::Linear),
        (ContactLawSpec::ContactLoss, None) => Ok(ContactLaw::ContactLoss),
    }
}

/// The viscous mesh damping `c`, N·s/m, from `damping` or `damping_ratio` on the mean
/// stiffness `k_mean` and the equivalent mass `m_e` of the two gears (`c = 2ζ sqrt(k̄ m_e)`),
/// with the time scales it and the largest stiffness `k_max` give checked.
pub(crate) fn damping(
    f: &dyn Fn(&str) -> String,
    m: &MeshSpec,
    k_mean: f64,
    k_max: f64,
    m_e: f64,
) -> Result<f64> {
    let damping = match (m.damping, m.damping_ratio) {
        (Some(c), None) => bounded(&f("damping"), c)?,
        (None, Some(z)) => 2.0 * bounded(&f("damping_ratio"), z)? * (k_mean * m_e).sqrt(),
        (None, None) => 0.0,
        (Some(_), Some(_)) => {
            return err(format!(
                "{} and {}: give one of them, not both",
                f("damping"),
                f("damping_ratio")
            ))
        }
    };
    let damping_field = if m.damping.is_some() {
        f("damping")
    } else {
        f("damping_ratio")
    };
    mesh_rates(&f("stiffness"), k_max, &damping_field, damping, m_e)?;
    damping_ratio_range(&damping_field, damping, k_mean, m_e)?;
    Ok(damping)
}
