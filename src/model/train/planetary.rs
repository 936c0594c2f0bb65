//! The planetary terms of the drivetrain assembly (`docs/planetary.md`; Lin & Parker 1999):
//! the mesh vectors of sun → planet and planet → ring meshes with their lines of action at
//! the planet angles ψ_n, and the planet bearings on the carrier pins, which couple a planet's
//! translations to the carrier's translation and rotation. Everything is written in the
//! carrier frame; the gyroscopic and centripetal terms of its rotation are not included (as
//! in the paper's free-vibration analysis).
//!
//! Coordinates (eq. P3): a central member h (sun, ring, carrier) has `x_h, y_h` in the carrier
//! frame and the rotation of its body; a planet has `ζ_n` (radial, along
//! `e_r = (cos ψ_n, sin ψ_n)`) and `η_n` (tangential, along `σ e_t`, `e_t = (−sin ψ_n, cos ψ_n)`)
//! and the rotation of its body. `θ̃_g = σ ρ_g θ_g` is a rotation counted in the stage's
//! sense σ (`ρ_g` the gear's nominal rotation sense, in which the assembly counts `θ_g`).

use nalgebra::{DMatrix, DVector};

use crate::scene::train::{Planet, PlanetaryStage};
use crate::scene::Scene;

/// How the assembly reaches a gear's coordinates: `theta(g)` is the vector `v` with
/// `vᵀq = θ_g` (the gear's rotation in its nominal sense), `trans[g]` its two translation DOF
/// indices (`usize::MAX`: none).
pub(crate) struct Coordinates<'a> {
    pub n: usize,
    pub theta: &'a dyn Fn(usize) -> DVector<f64>,
    pub trans: &'a [[usize; 2]],
}

impl Coordinates<'_> {
    /// `r_g θ̃_g` as a vector: the gear's rotation in the stage's sense times `r_g`.
    fn arc(&self, scene: &Scene, st: &PlanetaryStage, g: usize) -> DVector<f64> {
        (self.theta)(g) * (st.sense * scene.rotation[g] * scene.gears[g].base_radius)
    }

    /// `w_h · v` for a central member's translation `w_h = (x_h, y_h)`.
    fn central_along(&self, g: usize, v: (f64, f64)) -> DVector<f64> {
        let mut d = DVector::zeros(self.n);
        let [ix, iy] = self.trans[g];
        if ix != usize::MAX {
            d[ix] += v.0;
        }
        if iy != usize::MAX {
            d[iy] += v.1;
        }
        d
    }

    /// `w_n · v` for a planet's translation `w_n = ζ e_r + σ η e_t`.
    fn planet_along(&self, st: &PlanetaryStage, p: &Planet, v: (f64, f64)) -> DVector<f64> {
        let (s, c) = p.angle.sin_cos();
        let (e_r, e_t) = ((c, s), (-s, c));
        let dot = |a: (f64, f64)| a.0 * v.0 + a.1 * v.1;
        let mut d = DVector::zeros(self.n);
        let [iz, ie] = self.trans[p.gear];
        d[iz] += dot(e_r);
        d[ie] += st.sense * dot(e_t);
        d
    }
}

/// The unit vector at angle `a`.
fn unit(a: f64) -> (f64, f64) {
    let (s, c) = a.sin_cos();
    (c, s)
}

/// Line of action of the sun → planet mesh, the direction along which the sun's translation
/// compresses it (eq. P4): `ℓ_sn` at `ψ_n + σ(π/2 − α_s)`.
pub fn sun_line_of_action(st: &PlanetaryStage, p: &Planet, alpha_s: f64) -> (f64, f64) {
    unit(p.angle + st.sense * (std::f64::consts::FRAC_PI_2 - alpha_s))
}

/// Line of action of the planet → ring mesh, along which the ring's translation compresses it
/// (eq. P5): `ℓ_rn` at `ψ_n + σ(π/2 + α_r)`.
pub fn ring_line_of_action(st: &PlanetaryStage, p: &Planet, alpha_r: f64) -> (f64, f64) {
    unit(p.angle + st.sense * (std::f64::consts::FRAC_PI_2 + alpha_r))
}

/// The mesh vector `d` (`δ = dᵀq`) and its rotational part (the DTE) of a stage mesh, if mesh
/// `n` is one: eq. (P4) `δ_sn = (w_s − w_n)·ℓ_sn + r_s θ̃_s + r_p θ̃_n` for the sun mesh and
/// eq. (P5) `δ_rn = (w_r − w_n)·ℓ_rn + r_r θ̃_r − r_p θ̃_n` for the ring mesh (Lin & Parker
/// 1999, with σ = +1 their δ_sn and δ_rn).
///
/// Also the back-flank vector: the same with the line of action mirrored about the line of
/// centres, here the planet's radial direction `e_r` for both meshes
/// ([`super::flanks::back_line_of_action`]; `docs/planetary.md`, "Back flanks").
pub(crate) fn mesh_vector(
    scene: &Scene,
    at: &Coordinates,
    mesh: usize,
) -> Option<(DVector<f64>, DVector<f64>, DVector<f64>)> {
    let alpha = scene.meshes[mesh].pressure_angle;
    for st in &scene.planetary {
        for p in &st.planets {
            let (central, loa, planet_sign) = if p.sun_mesh == mesh {
                (st.sun, sun_line_of_action(st, p, alpha), 1.0)
            } else if p.ring_mesh == mesh {
                (st.ring, ring_line_of_action(st, p, alpha), -1.0)
            } else {
                continue;
            };
            let dte = at.arc(scene, st, central) + at.arc(scene, st, p.gear) * planet_sign;
            let along = |l| &dte + at.central_along(central, l) - at.planet_along(st, p, l);
            let back = super::flanks::back_line_of_action(loa, unit(p.angle));
            return Some((along(loa), along(back), dte));
        }
    }
    None
}

/// One planet-bearing direction: deflection `δ = bᵀq + e` with stiffness `k`, damping `c`
/// and the pin position error `e` along it.
pub(crate) struct PinSpring {
    pub b: DVector<f64>,
    pub stiffness: f64,
    pub damping: f64,
    pub error: f64,
}

/// The two bearing springs of every planet on its carrier pin (eq. P6, P7): radial
/// `δ_ζ = (w_c − w_n)·e_r − ζ_n`-part, tangential `δ_η = σ w_c·e_t + r_c θ̃_c − η_n`, each plus
/// the pin's position error along it.
pub(crate) fn pin_springs(scene: &Scene, at: &Coordinates) -> Vec<PinSpring> {
    let mut springs = Vec::new();
    for st in &scene.planetary {
        for p in &st.planets {
            let bearing = scene.gears[p.gear]
                .bearing
                .expect("validated: a planet has a pin bearing");
            let (s, c) = p.angle.sin_cos();
            let [iz, ie] = at.trans[p.gear];
            let mut radial = at.central_along(st.carrier, (c, s));
            radial[iz] -= 1.0;
            let mut tangential = at.central_along(st.carrier, (-s * st.sense, c * st.sense))
                + at.arc(scene, st, st.carrier);
            tangential[ie] -= 1.0;
            for (axis, b) in [radial, tangential].into_iter().enumerate() {
                springs.push(PinSpring {
                    b,
                    stiffness: bearing.stiffness[axis],
                    damping: bearing.damping[axis],
                    error: p.pin_error[axis],
                });
            }
        }
    }
    springs
}

/// Signed nominal speed of a stage's carrier, rad/s (counter-clockwise positive): the speed
/// of its rotating frame.
pub fn carrier_speed(scene: &Scene, st: &PlanetaryStage) -> f64 {
    let c = st.carrier;
    scene.rotation[c] * scene.speed_ratio[c] * scene.operating.input_speed
}

/// The terms of the rotating carrier frames of the stages with `gyroscopic = true`, at the
/// carriers' nominal speeds Ω_c (Lin & Parker 1999 eq. 1,
/// `M q'' + Ω_c G q' + (K_b + K_m − Ω_c² K_Ω) q = T`): the skew gyroscopic matrix `Ω_c G`
/// and the centripetal softening `Ω_c² K_Ω`, block-diagonal per member, `G_j = 2 m_j J`,
/// `K_Ω,j = m_j I` on its two translations (no rotational entries), `J = [[0, −1], [1, 0]]`.
/// They are the Coriolis and centrifugal forces `2 m Ω ẑ × w' − m Ω² w` of a translation
/// `w` seen in a frame turning at Ω. A central member's `(x, y)` is right-handed; a planet's
/// `w = ζ e_r + σ η e_t` (eq. P3), so its block of `G` carries the stage's sense σ. The
/// planets' mean centrifugal force `m r_c Ω_c²` (a constant radial pin load) and the
/// geometric stiffness of that preload are not in the paper's model and not here.
pub(crate) fn frame_terms(
    scene: &Scene,
    trans: &[[usize; 2]],
    n: usize,
) -> Option<(DMatrix<f64>, DMatrix<f64>)> {
    let stages: Vec<&PlanetaryStage> = scene.planetary.iter().filter(|s| s.gyroscopic).collect();
    if stages.is_empty() {
        return None;
    }
    let mut gyroscopic = DMatrix::zeros(n, n);
    let mut centripetal = DMatrix::zeros(n, n);
    for st in stages {
        let omega = carrier_speed(scene, st);
        let members = [(st.sun, 1.0), (st.ring, 1.0), (st.carrier, 1.0)]
            .into_iter()
            .chain(st.planets.iter().map(|p| (p.gear, st.sense)));
        for (g, handed) in members {
            let Some(m) = scene.gears[g].mass else {
                continue;
            };
            let [i, j] = trans[g];
            for k in [i, j].into_iter().filter(|&k| k != usize::MAX) {
                centripetal[(k, k)] += m * omega * omega;
            }
            if i != usize::MAX && j != usize::MAX {
                gyroscopic[(i, j)] -= 2.0 * m * omega * handed;
                gyroscopic[(j, i)] += 2.0 * m * omega * handed;
            }
        }
    }
    Some((gyroscopic, centripetal))
}

/// Refuses a tool that changes the speed of one built model (`what`: a speed sweep, a
/// continuation in speed) on a scene with `gyroscopic = true`: the frame's terms are
/// assembled at one carrier speed.
pub fn require_fixed_frame_speed(scene: &Scene, what: &str) -> Result<(), String> {
    match scene.planetary.iter().find(|s| s.gyroscopic) {
        Some(st) => Err(format!(
            "{what} changes the input speed of one assembled model, but carrier {:?} has \
             gyroscopic = true, whose terms are assembled at one carrier speed and not \
             reassembled: run `periodic`, `spectrum`, `floquet` or `band` per speed (they \
             assemble each speed anew), or set gyroscopic = false (docs/planetary.md, \
             \"Gyroscopic terms\")",
            scene.gears[st.carrier].name
        )),
        None => Ok(()),
    }
}

/// Whether gear `g` translates in a planetary stage's carrier frame (a central member with a
/// bearing, or a planet): both its axes carry force whatever the mesh angles.
pub(crate) fn in_carrier_frame(scene: &Scene, g: usize) -> bool {
    scene
        .planetary
        .iter()
        .any(|s| s.is_central(g) || s.planet(g).is_some())
}

/// Whether gear `g` is a planet (its bearing is on the carrier pin, not to ground).
pub(crate) fn is_planet(scene: &Scene, g: usize) -> bool {
    scene.planetary.iter().any(|s| s.planet(g).is_some())
}

/// The static load of one planet of a stage.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanetLoad {
    /// Gear index of the planet.
    pub gear: usize,
    /// Static mesh force of its sun mesh and of its ring mesh, N.
    pub sun_force: f64,
    pub ring_force: f64,
    /// Its share of the stage's sun-mesh load, `F_sn / Σ_m F_sm` (1/N when the load is shared
    /// equally).
    pub share: f64,
}

/// The planet load sharing of every stage from the static mesh forces (indexed like
/// `scene.meshes`).
pub fn load_sharing(scene: &Scene, mesh_force: &[f64]) -> Vec<Vec<PlanetLoad>> {
    scene
        .planetary
        .iter()
        .map(|st| {
            let total: f64 = st.planets.iter().map(|p| mesh_force[p.sun_mesh]).sum();
            st.planets
                .iter()
                .map(|p| PlanetLoad {
                    gear: p.gear,
                    sun_force: mesh_force[p.sun_mesh],
                    ring_force: mesh_force[p.ring_mesh],
                    share: mesh_force[p.sun_mesh] / total,
                })
                .collect()
        })
        .collect()
}

/// Why the time-domain kernel cannot run `scene`, if it cannot: with ports or elements the
/// rigid-body rotation is carried as a reference rotation at the nominal speeds (Willis with
/// tooth counts, eq. P1–P2), which must be a rigid-body motion of the lumped model (every
/// spring unloaded, eq. P4–P7); otherwise the reference rotation itself would load the
/// meshes more and more. That holds when the base radii are proportional to the tooth counts
/// and the planet circle is where the lines of action put it, `r_c cos α_s = r_s + r_p` and
/// `r_c cos α_r = r_r − r_p` (relative tolerance 1e-9). The nominal-speed form (no ports) has
/// no reference rotation and runs any stage. Checked where the kernel is built (`Scene::run`,
/// `GearTrain::new`).
pub fn refusal(scene: &Scene) -> Option<String> {
    if !scene.carries_rotation() {
        return None;
    }
    for st in &scene.planetary {
        if let Some(why) = inconsistent_geometry(scene, st) {
            return Some(format!(
                "scene {:?}: with [[port]] or elements the rigid-body rotation of the planetary \
                 stage (carrier {:?}) is carried at the nominal speeds of Willis' equation, \
                 which must turn the lumped model without loading it (docs/planetary.md, \
                 \"Carried rotation\"); {why}",
                scene.name, scene.gears[st.carrier].name
            ));
        }
    }
    None
}

/// The first relation of consistent stage geometry that `st` breaks (see [`refusal`]).
fn inconsistent_geometry(scene: &Scene, st: &PlanetaryStage) -> Option<String> {
    const TOL: f64 = 1e-9;
    let gear = |g: usize| &scene.gears[g];
    let pitch = |g: usize| gear(g).base_radius / f64::from(gear(g).teeth);
    let r_c = gear(st.carrier).base_radius;
    let off = |a: f64, b: f64| (a - b).abs() > TOL * a.abs().max(b.abs());
    for p in &st.planets {
        for member in [st.sun, st.ring] {
            if off(pitch(member), pitch(p.gear)) {
                return Some(format!(
                    "the base radii of {:?} ({} m, {} teeth) and {:?} ({} m, {} teeth) are not \
                     in the ratio of their teeth (base pitch {} against {} m per tooth)",
                    gear(member).name,
                    gear(member).base_radius,
                    gear(member).teeth,
                    gear(p.gear).name,
                    gear(p.gear).base_radius,
                    gear(p.gear).teeth,
                    pitch(member),
                    pitch(p.gear)
                ));
            }
        }
        let r_p = gear(p.gear).base_radius;
        for (n, sum, what) in [
            (p.sun_mesh, gear(st.sun).base_radius + r_p, "r_s + r_p"),
            (p.ring_mesh, gear(st.ring).base_radius - r_p, "r_r − r_p"),
        ] {
            let along = r_c * scene.meshes[n].pressure_angle.cos();
            if off(along, sum) {
                return Some(format!(
                    "mesh {:?}: carrier radius × cos(pressure angle) = {along} m, but {what} = \
                     {sum} m (base radii): the planet circle and the pressure angle do not fit \
                     the base circles",
                    scene.meshes[n].name
                ));
            }
        }
    }
    None
}
