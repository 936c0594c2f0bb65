//! A resolved planetary stage (`docs/planetary.md`): which gears of the scene are its sun,
//! ring and planets, which body is its carrier, where the planets sit, and the stage's
//! kinematics (Willis) and static torque balance.
//!
//! The stage's members are ordinary entries of `Scene::gears` (the carrier is one too, with no
//! teeth and its planet-circle radius `r_c` as base radius), so shafts, ports, the input and
//! output gear and every other part of a drivetrain scene name them as they name gears; its
//! meshes are ordinary entries of `Scene::meshes`, sun → planet (external) and planet → ring
//! (internal). What makes them planetary is this record: the assembly
//! (`crate::model::train::planetary`) gives their translations in the rotating carrier frame,
//! the planet bearings on the carrier pins, and the mesh lines of action at the planet angles
//! ψ_n (Lin & Parker 1999).

/// One planet of a stage.
#[derive(Debug, Clone, PartialEq)]
pub struct Planet {
    /// Gear index.
    pub gear: usize,
    /// Position angle ψ_n on the carrier, rad, ccw from the carrier's x axis.
    pub angle: f64,
    /// Pin position error `[radial, tangential]`, m: the pin sits this far from its nominal
    /// place, tangential positive in the stage's sense σ.
    pub pin_error: [f64; 2],
    /// Sun → planet mesh index.
    pub sun_mesh: usize,
    /// Planet → ring mesh index.
    pub ring_mesh: usize,
}

/// A planetary stage: sun, ring, carrier and N planets.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanetaryStage {
    /// Gear index of the carrier body.
    pub carrier: usize,
    pub sun: usize,
    pub ring: usize,
    /// The central member whose nominal speed is zero (sun, ring or carrier).
    pub fixed: usize,
    pub planets: Vec<Planet>,
    /// Sense σ (+1 ccw, −1 cw) of the sun's static torque, or without one of its rotation
    /// relative to the carrier: it picks the loaded flanks of every stage mesh, and the sense
    /// in which the stage's rotations and tangential translations count (`docs/planetary.md`,
    /// eq. P3).
    pub sense: f64,
}

impl PlanetaryStage {
    /// Whether gear `g` is a central member (sun, ring or carrier) of the stage.
    pub fn is_central(&self, g: usize) -> bool {
        g == self.sun || g == self.ring || g == self.carrier
    }

    /// The planet of gear `g`, if it is one.
    pub fn planet(&self, g: usize) -> Option<&Planet> {
        self.planets.iter().find(|p| p.gear == g)
    }
}

/// The stage of which gear `g` is a member (central or planet), with its index.
pub fn stage_of(stages: &[PlanetaryStage], g: usize) -> Option<(usize, &PlanetaryStage)> {
    stages
        .iter()
        .enumerate()
        .find(|(_, s)| s.is_central(g) || s.planet(g).is_some())
}

/// Willis' equation with tooth counts (`docs/planetary.md`, eq. P1): the signed nominal
/// speeds of the three central members satisfy `Z_s(ω_s − ω_c) + Z_r(ω_r − ω_c) = 0`.
/// Given two of `[sun, ring, carrier]` (signed speeds), the third.
pub fn willis_third(z_sun: f64, z_ring: f64, known: [Option<f64>; 3]) -> Option<[f64; 3]> {
    match known {
        [Some(s), Some(r), None] => Some([s, r, (z_sun * s + z_ring * r) / (z_sun + z_ring)]),
        [Some(s), None, Some(c)] => Some([s, c - z_sun * (s - c) / z_ring, c]),
        [None, Some(r), Some(c)] => Some([c - z_ring * (r - c) / z_sun, r, c]),
        [Some(s), Some(r), Some(c)] => Some([s, r, c]),
        _ => None,
    }
}

/// Signed nominal speed of a planet from the sun's and the carrier's (eq. P2):
/// `ω_p = ω_c − (Z_s/Z_p)(ω_s − ω_c)`.
pub fn planet_speed(z_sun: f64, z_planet: f64, sun: f64, carrier: f64) -> f64 {
    carrier - z_sun / z_planet * (sun - carrier)
}

/// The static torque weights `w = [w_s, w_r, w_c]` of a stage (eq. P9): the mean torques on
/// the central members, counted in the stage's sense, are proportional to `w`,
/// `T_s/w_s = T_r/w_r = T_c/w_c`, with `w_s = r_s`, `w_r = r_r`,
/// `w_c = −r_c (cos α_s + cos α_r)`: the rigid-body motion of the lumped model with every
/// spring unloaded is `r_s θ_s + r_r θ_r = r_c (cos α_s + cos α_r) θ_c`, and the torques do
/// no work on it.
pub fn torque_weights(
    r_sun: f64,
    r_ring: f64,
    r_carrier: f64,
    alpha_s: f64,
    alpha_r: f64,
) -> [f64; 3] {
    [r_sun, r_ring, -r_carrier * (alpha_s.cos() + alpha_r.cos())]
}
