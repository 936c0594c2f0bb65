//! Drivetrain scenes: a graph of gears (rotation, optional translations on bearings), shafts
//! and meshes (Liu 2007, Ch. 2–4; notes `models-liu-parker-2007.md` §1–§3).
//!
//! [`Scene`] is the resolved scene of the drivetrain kernel, with the kinematics
//! resolved (nominal speed ratio and rotation sense of every gear). The file is read by the
//! one scene description (`crate::scene::spec`) and checked by `crate::scene::validate`; the
//! format is specified in `docs/train.md`. A single-mesh scene of `docs/model.md` reads as a
//! train with one mesh, so the single pair is one case of the graph.

pub mod chain;
pub mod elements;
pub(crate) mod friction;
pub mod planetary;
pub mod ports;

use crate::mesh::{MeshStiffness, PhaseSeries, Piece};

pub use chain::{ChainBearings, ChainContact, ChainLayout, ChainSpec};
pub use friction::{HelicalPair, MeshFriction};
pub use planetary::{Planet, PlanetaryStage};
pub use ports::{Port, PortEnd, SpeedCoupling};

/// Bearing stiffness and damping of a gear with translational DOFs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bearing {
    pub stiffness: [f64; 2],
    pub damping: [f64; 2],
}

/// How two coaxial gears are coupled.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ShaftCoupling {
    /// The gears share one rotation DOF.
    Rigid,
    /// A torsional spring and damper, N·m/rad and N·m·s/rad.
    Elastic { stiffness: f64, damping: f64 },
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shaft {
    pub gears: [usize; 2],
    pub coupling: ShaftCoupling,
}

/// Which of Liu's (2007, §2.2–2.3) mesh-force models a pair-based mesh uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PairModel {
    /// Model-1: per-tooth-pair stiffness, gaps and contact flags (eq. 2.2, 2.4).
    PerPair,
    /// Model-2: mean stiffness with the loaded STE (mean removed) as excitation (eq. 2.10).
    LoadedSte,
    /// Model-3: total stiffness with the no-load TE as excitation (eq. 2.11).
    Nlte,
}

/// Stiffness of one tooth pair over its engagement window `ξ ∈ [0, c)` in mesh cycles,
/// replicated every mesh cycle (Liu 2007 §2.2, Fig. 2.2).
#[derive(Debug, Clone, PartialEq)]
pub struct PairStiffness {
    pub contact_ratio: f64,
    /// Linear pieces covering `[0, c)`.
    pub pieces: Vec<Piece>,
}

impl PairStiffness {
    /// Liu 2007 §2.5 rectangular idealisation, with the single/double labels of the printed
    /// text swapped back (notes §1.4 [R], erratum §8 item 4): `K_s = k̂[1 + ε(1 − c)]` alone,
    /// `K_d/2` per pair in double contact with `K_d = k̂[1 + ε(2 − c)]`; mean `k̂`, p-p `εk̂`.
    pub fn rectangular(mean: f64, ratio: f64, c: f64) -> Self {
        let k_single = mean * (1.0 + ratio * (1.0 - c));
        let k_double = mean * (1.0 + ratio * (2.0 - c));
        let flat = |start: f64, end: f64, k: f64| Piece {
            start,
            end,
            k_start: k,
            slope: 0.0,
        };
        PairStiffness {
            contact_ratio: c,
            pieces: vec![
                flat(0.0, c - 1.0, 0.5 * k_double),
                flat(c - 1.0, 1.0, k_single),
                flat(1.0, c, 0.5 * k_double),
            ],
        }
    }

    /// Liu 2007 §5.2 (frictionless part of eq. 4.43): the rectangular idealisation with a
    /// linear load share in double contact. The leaving pair carries `α K_d` when double
    /// contact starts and `(1 − α) K_d` when it ends, the entering pair the rest, so the mesh
    /// stiffness is the rectangular wave of [`PairStiffness::rectangular`] (which is `α = ½`).
    pub fn rectangular_shared(mean: f64, ratio: f64, c: f64, alpha: f64) -> Self {
        let k_single = mean * (1.0 + ratio * (1.0 - c));
        let k_double = mean * (1.0 + ratio * (2.0 - c));
        let slope = (2.0 * alpha - 1.0) * k_double / (c - 1.0);
        PairStiffness {
            contact_ratio: c,
            pieces: vec![
                Piece {
                    start: 0.0,
                    end: c - 1.0,
                    k_start: (1.0 - alpha) * k_double,
                    slope,
                },
                Piece {
                    start: c - 1.0,
                    end: 1.0,
                    k_start: k_single,
                    slope: 0.0,
                },
                Piece {
                    start: 1.0,
                    end: c,
                    k_start: alpha * k_double,
                    slope: -slope,
                },
            ],
        }
    }

    /// The friction-bending pair stiffness of Liu 2007 eq. (4.42), applied pair by pair (the
    /// "physical" variant of notes §4.2 [R]): `k(1 + β)` in approach (`ξ < pitch`, sliding
    /// velocity positive), `k(1 − β)` in recess, `β = β̃μ`. The pieces are split at the pitch
    /// point, which therefore is a knot of the mesh cycle even for `β = 0`.
    pub fn with_friction_bending(&self, pitch: f64, beta: f64) -> Self {
        let mut pieces = Vec::with_capacity(self.pieces.len() + 1);
        for p in &self.pieces {
            let mut parts = vec![*p];
            if p.start < pitch && pitch < p.end {
                parts = vec![
                    Piece { end: pitch, ..*p },
                    Piece {
                        start: pitch,
                        k_start: p.value(pitch),
                        ..*p
                    },
                ];
            }
            for q in parts {
                let scale = if q.start < pitch {
                    1.0 + beta
                } else {
                    1.0 - beta
                };
                pieces.push(Piece {
                    k_start: q.k_start * scale,
                    slope: q.slope * scale,
                    ..q
                });
            }
        }
        PairStiffness {
            contact_ratio: self.contact_ratio,
            pieces,
        }
    }

    /// Piecewise-linear interpolation of `(points, values)`, `points[0] = 0`, last `= c`.
    pub fn table(c: f64, points: &[f64], values: &[f64]) -> Self {
        let pieces = points
            .windows(2)
            .zip(values.windows(2))
            .map(|(s, k)| Piece {
                start: s[0],
                end: s[1],
                k_start: k[0],
                slope: (k[1] - k[0]) / (s[1] - s[0]),
            })
            .collect();
        PairStiffness {
            contact_ratio: c,
            pieces,
        }
    }

    /// The piece containing `ξ` (the last one at `ξ = c`).
    pub fn piece_at(&self, xi: f64) -> &Piece {
        let j = self
            .pieces
            .partition_point(|p| p.start <= xi)
            .saturating_sub(1);
        &self.pieces[j]
    }

    pub fn value(&self, xi: f64) -> f64 {
        self.piece_at(xi).value(xi)
    }

    /// Mean of the total mesh stiffness `Σ_p k_p` over a mesh cycle = `∫_0^c k dξ`.
    pub fn mesh_mean(&self) -> f64 {
        self.pieces
            .iter()
            .map(|p| {
                let w = p.end - p.start;
                w * (p.k_start + 0.5 * p.slope * w)
            })
            .sum()
    }
}

/// Linear tip relief (Liu 2007 §2.4, notes §1.5 [R]): magnitudes in m, lengths in mesh cycles
/// (roll-angle length over the angular pitch). A zero magnitude means no relief.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TipRelief {
    pub driver_magnitude: f64,
    pub driver_length: f64,
    pub driven_magnitude: f64,
    pub driven_length: f64,
}

impl TipRelief {
    /// Gap of a pair at `ξ ∈ [0, c)` (notes §1.5 [R]):
    /// `g = ρ_dr·max(0, ξ − (c − ς_dr))/ς_dr + ρ_dn·max(0, ς_dn − ξ)/ς_dn`.
    /// The driver's tip meets the driven flank at the end of the window (recess), the driven
    /// tip at its start (approach).
    pub fn gap(&self, c: f64, xi: f64) -> f64 {
        self.gap_and_slope(c, xi).0
    }

    /// Gap and `dg/dξ` at `ξ` (right-sided slope at the kinks).
    pub fn gap_and_slope(&self, c: f64, xi: f64) -> (f64, f64) {
        let mut g = 0.0;
        let mut slope = 0.0;
        if self.driver_magnitude > 0.0 && xi >= c - self.driver_length {
            g += self.driver_magnitude * (xi - (c - self.driver_length)) / self.driver_length;
            slope += self.driver_magnitude / self.driver_length;
        }
        if self.driven_magnitude > 0.0 && xi < self.driven_length {
            g += self.driven_magnitude * (self.driven_length - xi) / self.driven_length;
            slope -= self.driven_magnitude / self.driven_length;
        }
        (g, slope)
    }

    /// The kinks of the gap in `ξ`.
    pub fn kinks(&self, c: f64) -> Vec<f64> {
        let mut k = Vec::new();
        if self.driver_magnitude > 0.0 {
            k.push(c - self.driver_length);
        }
        if self.driven_magnitude > 0.0 {
            k.push(self.driven_length);
        }
        k
    }

    pub fn is_zero(&self) -> bool {
        self.driver_magnitude == 0.0 && self.driven_magnitude == 0.0
    }
}

/// The gap of a tooth pair as a function of `ξ ∈ [0, c)`: what the pair-based models need.
pub trait GapFunction {
    /// Gap (m) and `dg/dξ` at `ξ` (right-sided slope at kinks).
    fn gap_and_slope(&self, c: f64, xi: f64) -> (f64, f64);
    /// The kinks in `ξ` (the gap is affine between them).
    fn kinks(&self, c: f64) -> Vec<f64>;
}

impl GapFunction for TipRelief {
    fn gap_and_slope(&self, c: f64, xi: f64) -> (f64, f64) {
        TipRelief::gap_and_slope(self, c, xi)
    }
    fn kinks(&self, c: f64) -> Vec<f64> {
        TipRelief::kinks(self, c)
    }
}

/// A tabulated pair gap (profile modification or error seen along the line of action),
/// piecewise linear over `points` = `[0, …, c]` in mesh cycles of the pair's window.
#[derive(Debug, Clone, PartialEq)]
pub struct GapTable {
    pub points: Vec<f64>,
    pub values: Vec<f64>,
}

impl GapFunction for GapTable {
    fn gap_and_slope(&self, _c: f64, xi: f64) -> (f64, f64) {
        let n = self.points.len();
        let j = self
            .points
            .partition_point(|&p| p <= xi)
            .saturating_sub(1)
            .min(n - 2);
        let slope = (self.values[j + 1] - self.values[j]) / (self.points[j + 1] - self.points[j]);
        (self.values[j] + slope * (xi - self.points[j]), slope)
    }
    fn kinks(&self, _c: f64) -> Vec<f64> {
        self.points[1..self.points.len() - 1].to_vec()
    }
}

/// The gap source of a pair-based mesh.
#[derive(Debug, Clone, PartialEq)]
pub enum PairGap {
    Relief(TipRelief),
    Table(GapTable),
}

impl Default for PairGap {
    fn default() -> Self {
        PairGap::Relief(TipRelief::default())
    }
}

impl GapFunction for PairGap {
    fn gap_and_slope(&self, c: f64, xi: f64) -> (f64, f64) {
        match self {
            PairGap::Relief(r) => r.gap_and_slope(c, xi),
            PairGap::Table(t) => t.gap_and_slope(c, xi),
        }
    }
    fn kinks(&self, c: f64) -> Vec<f64> {
        match self {
            PairGap::Relief(r) => r.kinks(c),
            PairGap::Table(t) => t.kinks(c),
        }
    }
}

/// How the mesh force of a mesh is formed.
#[derive(Debug, Clone, PartialEq)]
pub enum MeshForceModel {
    /// One spring `k(p)` on the deflection minus the static TE `e(p)` (`docs/model.md`).
    Lumped {
        stiffness: MeshStiffness,
        ste: PhaseSeries,
    },
    /// Tooth-pair based: Model-1, 2 or 3 (Liu 2007 §2.2–2.3).
    Pairs {
        model: PairModel,
        pair: PairStiffness,
        /// Tip relief or tabulated gaps.
        relief: PairGap,
    },
}

/// Built-in drivetrain scenes (`fmu/<name>/scene.toml`, `examples/<name>.toml`).
pub const TRAIN_EXAMPLES: &[(&str, &str)] = &[
    (
        "idler_gearset",
        include_str!("../../../fmu/idler_gearset/scene.toml"),
    ),
    (
        "countershaft_gearset",
        include_str!("../../../fmu/countershaft_gearset/scene.toml"),
    ),
    (
        "friction_pair",
        include_str!("../../../examples/friction_pair.toml"),
    ),
];
