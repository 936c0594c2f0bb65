//! The lines of action of a mesh's two flanks: the back flanks' line from the drive line and
//! the line of centres (`docs/train.md`, "Back flanks"), for parallel and planetary meshes
//! alike.

/// The line of centres of a mesh from its line of action `ℓ` (a unit vector), the pinion's
/// sense of rotation `σ_a` and the pressure angle `α`: involute geometry puts the line of
/// action at `90° − α` from the line of centres, on the side the pinion turns to, so the line
/// of centres is `ℓ` turned by `−σ_a(90° − α)` (`docs/errors.md`, "Assumptions").
pub(crate) fn centre_line(l: (f64, f64), sense: f64, alpha: f64) -> (f64, f64) {
    let (s, c) = (-sense * (std::f64::consts::FRAC_PI_2 - alpha)).sin_cos();
    (c * l.0 - s * l.1, s * l.0 + c * l.1)
}

/// The back flanks' line of action, in the sign of the drive line `ℓ`: `ℓ̃ = ℓ − 2(ℓ·ĉ)ĉ`,
/// `ĉ` the line of centres (a unit vector, either orientation).
///
/// When the back flanks touch, the contact force acts along the other common tangent of the
/// base circles: the drive line mirrored about the line of centres. Its component along the
/// line of centres (the separating force) keeps its sense, the tangential one reverses with
/// the force. Written as the deflection `S̃ = r_a θ_a − r_b θ_b + (w_a − w_b)·ℓ̃` (the drive
/// deflection's rotational part, back contact at `S̃ ≤ −2b`), the translations see `ℓ̃`: the
/// drive line with the pressure angle's sign reversed (`ℓ` at `ĉ + σ_a(90° − α)`, `ℓ̃` at
/// `ĉ + σ_a(90° + α)`); the base radii, the arms of the torques, stay (docs/train.md, "Back
/// flanks"). With `α = 0` the two lines coincide.
pub(crate) fn back_line_of_action(l: (f64, f64), c: (f64, f64)) -> (f64, f64) {
    let along = l.0 * c.0 + l.1 * c.1;
    (l.0 - 2.0 * along * c.0, l.1 - 2.0 * along * c.1)
}
