//! Mesh stiffness from gear geometry: potential-energy tooth beams, Hertz contact, Sainsot
//! fillet foundation, load sharing and extended tooth contact (Liao, Zheng, Huang & Zhu 2025,
//! "Analysis of Nonlinear Dynamics of a Gear Transmission System Considering Effects of the
//! Extended Tooth Contact", Machines 13(2) 155, §2.1 eqs. (1)–(7); reconstructed formulas and
//! errata in `shared/reference/models-liao-2025-etc.md`). Format and conventions:
//! `docs/stiffness.md`.
//!
//! Data flow: [`spec`] (TOML) → [`gear`] (derived geometry, checks) → per contact position the
//! compliances of [`tooth`], [`fillet`], [`hertz`] → [`sharing`] (load sharing with gaps) →
//! [`curve`] (the secant stiffness over one mesh period, its contact zones, ETC angles and
//! Fourier coefficients) → a [`crate::mesh::MeshStiffness`] for the dynamic model, or the CSV,
//! SVG and summary of [`report`] for `geardyn stiffness`.

pub mod curve;
pub mod fillet;
pub mod gear;
pub mod hertz;
pub mod material;
pub mod pairs;
pub mod quadrature;
pub mod report;
pub mod sharing;
pub mod spec;
pub mod tooth;

pub use curve::{CurveOptions, StiffnessCurve};
pub use gear::{Gear, Pair};
pub use pairs::PairCurve;
pub use spec::{GearPairSpec, HertzLaw};

use hertz::Hertz;
use quadrature::GaussLegendre;

/// Load-independent compliances of one tooth pair in contact, m/N.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairCompliance {
    /// Tooth beams `1/K_t` of pinion and gear (eq. (1)).
    pub beam: [f64; 2],
    /// Fillet foundations `1/K_f` of pinion and gear.
    pub fillet: [f64; 2],
}

impl PairCompliance {
    pub fn total(&self) -> f64 {
        self.beam[0] + self.beam[1] + self.fillet[0] + self.fillet[1]
    }
}

/// The gear pair with everything needed to evaluate pair compliances.
#[derive(Debug, Clone)]
pub struct MeshModel {
    pub pair: Pair,
    pub hertz: Hertz,
    quadrature: GaussLegendre,
    /// Sainsot `[L*, M*, P*, Q*]` of pinion and gear.
    fillet: [[f64; 4]; 2],
    /// Samples per contact zone.
    pub samples: usize,
}

impl MeshModel {
    /// Builds the model; `prefix` is the TOML path of the gear-pair table in messages.
    pub fn new(spec: &GearPairSpec, prefix: &str) -> Result<MeshModel, String> {
        let pair = Pair::new(spec, prefix)?;
        let m = &spec.model;
        if !(4..=4096).contains(&m.quadrature) {
            return Err(format!(
                "{prefix}model.quadrature = {}: must be an integer in 4..=4096",
                m.quadrature
            ));
        }
        if !(2..=100_000).contains(&m.samples) {
            return Err(format!(
                "{prefix}model.samples = {}: must be an integer in 2..=100000",
                m.samples
            ));
        }
        let (p, g) = (&pair.pinion, &pair.gear);
        let hertz = Hertz {
            law: m.hertz,
            e: 2.0 * p.e * g.e / (p.e + g.e),
            nu: 0.5 * (p.nu + g.nu),
            width: p.face_width,
        };
        let fillet = [fillet::coefficients(p), fillet::coefficients(g)];
        Ok(MeshModel {
            hertz,
            quadrature: GaussLegendre::new(m.quadrature as usize),
            fillet,
            samples: m.samples as usize,
            pair,
        })
    }

    /// The same model with another number of Gauss–Legendre points.
    pub fn with_quadrature(mut self, n: usize) -> MeshModel {
        self.quadrature = GaussLegendre::new(n);
        self
    }

    /// Sainsot coefficients `[L*, M*, P*, Q*]` of pinion (0) and gear (1).
    pub fn fillet_coefficients(&self) -> &[[f64; 4]; 2] {
        &self.fillet
    }

    /// Load-independent compliance of a pair in contact at distance `x` from T1 on the line
    /// of action (`x` within the path of contact).
    pub fn compliance_at(&self, x: f64) -> PairCompliance {
        let (l1, l2) = self.pair.rolls(x);
        let gears = [&self.pair.pinion, &self.pair.gear];
        let alphas = [gears[0].load_angle(l1), gears[1].load_angle(l2)];
        let beam =
            [0, 1].map(|j| tooth::beam_compliance(gears[j], alphas[j], &self.quadrature).total());
        let fillet = [0, 1].map(|j| fillet::compliance(gears[j], &self.fillet[j], alphas[j]));
        PairCompliance { beam, fillet }
    }
}
