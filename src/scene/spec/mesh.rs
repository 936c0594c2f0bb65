//! The `[mesh]` / `[[mesh]]` tables of a scene file: one mesh description for both kernels.

use schemars::JsonSchema;
use serde::Deserialize;

use crate::scene::schema::{fraction, non_negative, positive};

pub use crate::mesh::geometry::GearPairSpec;
pub use crate::mesh::helical::HelicalPairSpec;

/// One mesh between a driving and a driven gear: `[mesh]` in a single-mesh scene
/// (`docs/model.md`), each `[[mesh]]` of a drivetrain (`docs/train.md`). Which fields a mesh
/// may use depends on the kernel that runs the scene ([`crate::scene::kernel`]): the
/// drivetrain fields (`name`, `phase`, angles, tooth-pair models, friction) send a scene to the
/// drivetrain kernel; the smooth terms of Bugaru (2006) (`cubic`, `damping_variation`,
/// `damping_acts`) are the pair kernel's.
#[derive(Debug, Clone, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MeshSpec {
    /// Name used in output columns (default `mesh1`, `mesh2`, …).
    pub name: Option<String>,
    /// Driving gear (its nominal speed sets the mesh phase).
    pub pinion: String,
    /// Driven gear.
    pub gear: String,
    /// Contact law: `linear` (the spring acts in tension too), `contact_loss` (single-sided
    /// contact) or `backlash` (drive and back flanks with a clearance).
    pub contact: ContactLawSpec,
    /// Total clearance 2b, m (only with `contact = "backlash"`).
    #[schemars(transform = non_negative, extend("x-unit" = "m"))]
    pub backlash: Option<f64>,
    /// Viscous mesh damping, N·s/m.
    #[schemars(transform = non_negative, extend("x-unit" = "N.s/m"))]
    pub damping: Option<f64>,
    /// Damping ratio on the mean stiffness and the equivalent mass (at most 100).
    #[schemars(transform = non_negative, extend("x-unit" = "1"))]
    pub damping_ratio: Option<f64>,
    /// Amplitude `c̃` of a mesh-damping variation `c(p) = c + c̃ cos 2πp`, N·s/m (Bugaru 2006
    /// eq. 8; only with `contact = "linear"`).
    #[schemars(extend("x-unit" = "N.s/m"))]
    pub damping_variation: Option<f64>,
    /// Cubic spring terms (Bugaru 2006 eq. 13; only with `contact = "linear"`).
    pub cubic: Option<CubicSpec>,
    /// Where the viscous damping acts: `in_contact` (default) or `always` (the
    /// Kahraman–Singh form `x'' + 2ζx' + k f(x) = F`, damping also during separation).
    pub damping_acts: Option<String>,
    /// Mesh phase at t = 0 (first mesh only), mesh cycles.
    #[schemars(extend("x-unit" = "cycles"))]
    pub initial_phase: Option<f64>,
    /// Mesh phasing φ relative to the first mesh (meshes 2, 3, …), cycles of this mesh.
    #[schemars(extend("x-unit" = "cycles"))]
    pub phase: Option<f64>,
    /// Operating pressure angle, degrees, in [5, 90) (needed with translational DOFs).
    #[schemars(range(min = 5.0), extend("exclusiveMaximum" = 90.0, "x-unit" = "degree"))]
    pub pressure_angle: Option<f64>,
    /// Direction of the centre line from the pinion's to the gear's centre, rad.
    #[schemars(extend("x-unit" = "rad"))]
    pub centre_angle: Option<f64>,
    /// `"lumped"` (default), `"pairs"` (Model-1), `"loaded_ste"` (Model-2), `"nlte"` (Model-3).
    pub model: Option<String>,
    /// Mesh stiffness source (lumped model).
    pub stiffness: Option<StiffnessSpec>,
    /// Static transmission error `e(p)` (lumped model).
    pub ste: Option<FourierSpec>,
    /// Single tooth-pair stiffness (pair-based models).
    pub pairs: Option<PairStiffnessSpec>,
    /// Linear tip relief (pair-based models).
    pub tip_relief: Option<TipReliefSpec>,
    /// Tabulated pair gap over the engagement window (instead of tip_relief).
    pub gaps: Option<GapTableSpec>,
    /// Coulomb tooth friction of the tooth pairs (Model-1 only; Liu 2007 Ch. 5).
    pub friction: Option<FrictionSpec>,
}

/// Contact law of a mesh (`docs/model.md`, "Mesh force and contact law").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum ContactLawSpec {
    Linear,
    ContactLoss,
    Backlash,
}

/// Mesh-stiffness source, a function of mesh phase.
#[derive(Debug, Clone, Deserialize, JsonSchema)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum StiffnessSpec {
    /// A constant mesh stiffness.
    Constant {
        /// Mesh stiffness, N/m.
        #[schemars(transform = positive, extend("x-unit" = "N/m"))]
        value: f64,
    },
    /// A square wave between single and double tooth contact.
    Rectangular {
        /// Mean mesh stiffness k̄, N/m.
        #[schemars(transform = positive, extend("x-unit" = "N/m"))]
        mean: f64,
        /// Peak-to-peak variation over the mean.
        #[schemars(transform = non_negative, extend("x-unit" = "1"))]
        peak_to_peak_ratio: f64,
        /// Contact ratio: the share of a mesh cycle in double contact plus one (>= 1).
        #[schemars(range(min = 1.0), extend("x-unit" = "1"))]
        contact_ratio: f64,
        /// Phase shift of the stiffness, mesh cycles.
        #[serde(default)]
        #[schemars(extend("x-unit" = "cycles"))]
        phase: f64,
    },
    /// A rectangular wave with linear transitions.
    Trapezoidal {
        /// Mean mesh stiffness k̄, N/m.
        #[schemars(transform = positive, extend("x-unit" = "N/m"))]
        mean: f64,
        /// Peak-to-peak variation over the mean.
        #[schemars(transform = non_negative, extend("x-unit" = "1"))]
        peak_to_peak_ratio: f64,
        /// Contact ratio (>= 1).
        #[schemars(range(min = 1.0), extend("x-unit" = "1"))]
        contact_ratio: f64,
        /// Length of each transition, mesh cycles (> 0, at most the shorter contact zone).
        #[schemars(transform = positive, extend("x-unit" = "cycles"))]
        transition: f64,
        /// Phase shift of the stiffness, mesh cycles.
        #[serde(default)]
        #[schemars(extend("x-unit" = "cycles"))]
        phase: f64,
    },
    /// A Fourier series in mesh phase.
    Fourier {
        /// Mean mesh stiffness k̄, N/m.
        #[schemars(transform = positive, extend("x-unit" = "N/m"))]
        mean: f64,
        /// Cosine coefficients of harmonics 1, 2, …, N/m.
        #[serde(default)]
        #[schemars(extend("x-unit" = "N/m"))]
        cos: Vec<f64>,
        /// Sine coefficients of harmonics 1, 2, …, N/m.
        #[serde(default)]
        #[schemars(extend("x-unit" = "N/m"))]
        sin: Vec<f64>,
        /// Phase shift of the stiffness, mesh cycles.
        #[serde(default)]
        #[schemars(extend("x-unit" = "cycles"))]
        phase: f64,
    },
    /// A periodic piecewise-linear table over one mesh cycle.
    Table {
        /// Knots in mesh cycles, increasing, in [0, 1).
        #[schemars(extend("x-unit" = "cycles"))]
        phase_points: Vec<f64>,
        /// Stiffness at the knots, N/m (> 0).
        #[schemars(transform = positive, extend("x-unit" = "N/m"))]
        values: Vec<f64>,
        /// Phase shift of the stiffness, mesh cycles.
        #[serde(default)]
        #[schemars(extend("x-unit" = "cycles"))]
        phase: f64,
    },
    /// Computed at scene load from gear geometry (`docs/stiffness.md`).
    Geometry {
        /// Pinion torque of the load-dependent curve, N·m (default `operating.input_torque`).
        #[schemars(transform = positive, extend("x-unit" = "N.m"))]
        torque: Option<f64>,
        /// Extended tooth contact (default on).
        #[serde(default = "default_true")]
        etc: bool,
        /// `table` (piecewise linear through the knots, default) or `fourier`.
        #[serde(default)]
        form: GeometryForm,
        /// Harmonics of the `fourier` form (default 4, as Liao et al. 2025 §3).
        harmonics: Option<i64>,
        /// Phase shift of the stiffness, mesh cycles.
        #[serde(default)]
        #[schemars(extend("x-unit" = "cycles"))]
        phase: f64,
        /// The gear pair, as in a gears file.
        geometry: Box<GearPairSpec>,
    },
    /// Helical pair with sliding friction, constant stiffness density along the contact lines
    /// (He & Singh 2007; `docs/helical.md`): the paper's piecewise-linear K_e(t), eq. (25).
    Helical {
        /// Stiffness density k per unit contact-line length (projected on the face), N/m².
        #[schemars(transform = positive, extend("x-unit" = "N/m^2"))]
        stiffness_density: f64,
        /// Coulomb friction coefficient μ >= 0 (default 0).
        #[serde(default)]
        #[schemars(transform = non_negative, extend("x-unit" = "1"))]
        friction_coefficient: f64,
        /// Phase shift of the stiffness, mesh cycles.
        #[serde(default)]
        #[schemars(extend("x-unit" = "cycles"))]
        phase: f64,
        /// The helical gear pair.
        helical: Box<HelicalPairSpec>,
    },
}

fn default_true() -> bool {
    true
}

/// How a `geometry` stiffness enters the model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, serde::Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum GeometryForm {
    #[default]
    Table,
    Fourier,
}

/// A Fourier series in mesh phase without mean (static transmission error), m.
#[derive(Debug, Clone, Default, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FourierSpec {
    /// Cosine coefficients of mesh harmonics 1, 2, …, m.
    #[serde(default)]
    #[schemars(extend("x-unit" = "m"))]
    pub cos: Vec<f64>,
    /// Sine coefficients of mesh harmonics 1, 2, …, m.
    #[serde(default)]
    #[schemars(extend("x-unit" = "m"))]
    pub sin: Vec<f64>,
}

/// Cubic terms of the mesh force: `k(p)(δ + stiffness_factor·δ³) + spring·δ³`.
#[derive(Debug, Clone, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CubicSpec {
    /// δ̄, 1/m²: the cubic "backlash spring" scaled by the time-varying stiffness.
    #[serde(default)]
    #[schemars(transform = non_negative, extend("x-unit" = "m^-2"))]
    pub stiffness_factor: f64,
    /// γ, N/m³: a constant cubic spring (e.g. the input/output linkage).
    #[serde(default)]
    #[schemars(transform = non_negative, extend("x-unit" = "N/m^3"))]
    pub spring: f64,
}

/// `[mesh.friction]`: Coulomb sliding friction on every tooth pair (Liu 2007 Ch. 5).
#[derive(Debug, Clone, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FrictionSpec {
    /// Friction coefficient μ (>= 0).
    #[schemars(transform = non_negative, extend("x-unit" = "1"))]
    pub coefficient: f64,
    /// Friction-bending factor β̃ of eq. (4.42): pair stiffness `k(1 ± β̃μ)` (default 0).
    #[serde(default)]
    #[schemars(extend("x-unit" = "1"))]
    pub bending_factor: f64,
    /// Position of the pitch point in the pair's engagement window, mesh cycles
    /// (default: from the gear geometry with standard addenda).
    #[schemars(extend("x-unit" = "cycles"))]
    pub pitch_point: Option<f64>,
}

/// A pair gap table: `points` from 0 to the contact ratio (mesh cycles), `values` in m.
#[derive(Debug, Clone, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct GapTableSpec {
    /// Knots from 0 to the contact ratio, mesh cycles.
    #[schemars(extend("x-unit" = "cycles"))]
    pub points: Vec<f64>,
    /// Gap at the knots, m.
    #[schemars(extend("x-unit" = "m"))]
    pub values: Vec<f64>,
}

/// Stiffness of one tooth pair over its engagement window `ξ ∈ [0, c)` (mesh cycles).
#[derive(Debug, Clone, Deserialize, JsonSchema)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum PairStiffnessSpec {
    /// Liu 2007 §2.5 rectangular idealisation: the mesh has mean `mean` and peak-to-peak
    /// `peak_to_peak_ratio·mean`; each pair carries `K_d/2` in double contact, `K_s` alone.
    Rectangular {
        /// Mean mesh stiffness, N/m.
        #[schemars(transform = positive, extend("x-unit" = "N/m"))]
        mean: f64,
        /// Peak-to-peak variation of the mesh stiffness over its mean.
        #[schemars(transform = non_negative, extend("x-unit" = "1"))]
        peak_to_peak_ratio: f64,
        /// Contact ratio, 1 < c < 2.
        #[schemars(extend("exclusiveMinimum" = 1.0, "exclusiveMaximum" = 2.0, "x-unit" = "1"))]
        contact_ratio: f64,
        /// Liu 2007 §5.2: share α of `K_d` the leaving pair carries when double contact
        /// starts, falling linearly to `1 − α` (default ½: the constant halves of §2.5).
        #[schemars(transform = fraction, extend("x-unit" = "1"))]
        load_share: Option<f64>,
    },
    /// Helical pair of He & Singh (2007): a constant stiffness density along the contact lines
    /// of the helical geometry (`src/mesh/helical`, `docs/helical.md`); the pair stiffness is
    /// `k cos β_b Δz(ξ)`, its window the total contact ratio ε_α + ε_β.
    Helical {
        /// Stiffness density k per unit contact-line length projected on the face, N/m².
        #[schemars(transform = positive, extend("x-unit" = "N/m^2"))]
        density: f64,
        /// The helical gear pair.
        geometry: crate::mesh::helical::HelicalPairSpec,
    },
    /// Each pair's stiffness from the gear geometry: potential-energy tooth beams, Sainsot
    /// fillets and Hertz contact, with extended tooth contact acting as a gap
    /// (`crate::mesh::geometry::pairs`, `docs/stiffness.md`, "Tooth pairs from geometry").
    Geometry {
        /// Pinion torque of the Hertz term, N·m (default: the mesh's static pinion torque).
        #[schemars(transform = positive, extend("x-unit" = "N.m"))]
        torque: Option<f64>,
        /// Extended tooth contact (default on).
        #[serde(default = "default_true")]
        etc: bool,
        /// The gear pair, as in a gears file.
        geometry: Box<GearPairSpec>,
    },
    /// Piecewise-linear table over `ξ ∈ [0, contact_ratio]`.
    Table {
        /// Contact ratio (>= 1): the table's window, mesh cycles.
        #[schemars(range(min = 1.0), extend("x-unit" = "1"))]
        contact_ratio: f64,
        /// Knots over `[0, contact_ratio]`, mesh cycles.
        #[schemars(extend("x-unit" = "cycles"))]
        points: Vec<f64>,
        /// Pair stiffness at the knots, N/m.
        #[schemars(transform = non_negative, extend("x-unit" = "N/m"))]
        values: Vec<f64>,
    },
}

/// Linear tip relief of driver and driven teeth: magnitude (m) and length (mesh cycles).
#[derive(Debug, Clone, Default, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TipReliefSpec {
    /// Relief at the driver's tip, m.
    #[serde(default)]
    #[schemars(transform = non_negative, extend("x-unit" = "m"))]
    pub driver_magnitude: f64,
    /// Length of the driver's relief, mesh cycles.
    #[schemars(transform = positive, extend("x-unit" = "cycles"))]
    pub driver_length: Option<f64>,
    /// Relief at the driven gear's tip, m.
    #[serde(default)]
    #[schemars(transform = non_negative, extend("x-unit" = "m"))]
    pub driven_magnitude: f64,
    /// Length of the driven gear's relief, mesh cycles.
    #[schemars(transform = positive, extend("x-unit" = "cycles"))]
    pub driven_length: Option<f64>,
}
