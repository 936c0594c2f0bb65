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
    /// Sense (+1 ccw, −1 cw) of the sun's nominal rotation relative to the carrier: the
    /// direction in which the stage's tooth pairs pass, which sets the planet-to-planet mesh
    /// phases (eq. PL1, PL2); +1 when the sun does not turn relative to the carrier.
    pub relative_sense: f64,
    /// The gyroscopic and centripetal terms of the rotating carrier frame are included
    /// (`[[carrier]] gyroscopic = true`; `crate::model::train::planetary::frame_terms`).
    pub gyroscopic: bool,
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

/// The mesh phases of a planet's sun and ring meshes after Parker & Lin (2004), in cycles in
/// `[0, 1)`, relative to the sun mesh of the stage's first planet (`docs/planetary.md`,
/// eq. PL1–PL3). The planet sits `dpsi` (rad, ccw) from the first planet; `relative_sense` is
/// the sense of the sun's rotation relative to the carrier. A mesh's phase counts its tooth
/// pairs passing, and phase 0 of every stage mesh is the instant a loaded pair passes that
/// mesh's pitch point (the paper's reference point):
///
/// - (PL1) sun meshes: a sun tooth that meets the first planet meets this one after turning
///   `dpsi` with the sun: `γ_sn = −s Z_s Δψ_n / 2π`;
/// - (PL2) ring meshes: the ring turns the other way relative to the carrier:
///   `γ_rn = γ_r1 + s Z_r Δψ_n / 2π`;
/// - (PL3) ring against sun mesh of one planet: the planet's sun-mesh pitch point and ring-mesh
///   pitch point are diametrically opposite on it and load opposite flanks of its teeth, so with
///   the standard tooth thickness (half the circular pitch) a loaded flank reaches the ring
///   pitch point `Z_p/2 − 1/2` planet tooth pitches after one reached the sun pitch point:
///   `γ_r1 = −(Z_p − 1)/2` (0 for odd, ½ for even Z_p).
///
/// PL1 and PL3 with PL2 agree for every planet when `(Z_s + Z_r) Δψ_n / 2π` is an integer,
/// the condition for the planet to fit between sun and ring ([`assembly_residual`]).
pub fn mesh_phases(
    (z_sun, z_ring, z_planet): (f64, f64, f64),
    dpsi: f64,
    relative_sense: f64,
) -> (f64, f64) {
    let turns = dpsi / std::f64::consts::TAU;
    let fraction = |x: f64| x - x.floor();
    let sun = -relative_sense * z_sun * turns;
    let ring = -(z_planet - 1.0) / 2.0 + relative_sense * z_ring * turns;
    (fraction(sun), fraction(ring))
}

/// Distance of `(Z_s + Z_r) Δψ / 2π` from the nearest integer (in planet-position "teeth"):
/// zero where a planet `Δψ` from the first one fits between the sun and the ring.
pub fn assembly_residual(z_sun: f64, z_ring: f64, dpsi: f64) -> f64 {
    let x = (z_sun + z_ring) * dpsi / std::f64::consts::TAU;
    (x - x.round()).abs()
}
