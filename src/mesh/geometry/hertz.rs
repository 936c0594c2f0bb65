//! Hertzian contact compliance of one tooth pair.

use super::spec::HertzLaw;

/// The contact law of a pair: `δ_h(F)` along the line of action.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hertz {
    pub law: HertzLaw,
    /// Young's modulus of the pair, Pa (harmonic mean `2E1E2/(E1+E2)` for unlike materials,
    /// which is `E` for like ones; the paper's eq. (3) has a single `E`).
    pub e: f64,
    /// Poisson's ratio (linear law only; mean of the two).
    pub nu: f64,
    /// Face width L, m.
    pub width: f64,
}

impl Hertz {
    /// Contact stiffness `K_h` at pair force `force` (N), N/m.
    ///
    /// - Nonlinear, Liao et al. 2025 eq. (3) (after Ma et al. [19]), SI units:
    ///   `K_h = E^0.9 L^0.8 F^0.1 / 1.275`.
    /// - Linear, Yang & Lin 1987: `K_h = π E L / (4 (1 − ν²))`.
    pub fn stiffness(&self, force: f64) -> f64 {
        match self.law {
            HertzLaw::Nonlinear => {
                self.e.powf(0.9) * self.width.powf(0.8) * force.powf(0.1) / 1.275
            }
            HertzLaw::Linear => {
                std::f64::consts::PI * self.e * self.width / (4.0 * (1.0 - self.nu * self.nu))
            }
        }
    }

    /// Contact compliance `1/K_h(F)`, m/N. In eq. (5) it enters as `1/(2K_h)` per gear, i.e.
    /// `1/K_h` for the pair.
    pub fn compliance(&self, force: f64) -> f64 {
        1.0 / self.stiffness(force)
    }

    /// True when `K_h` depends on the force (the load-sharing solve must iterate).
    pub fn is_nonlinear(&self) -> bool {
        self.law == HertzLaw::Nonlinear
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nonlinear_law_scales_as_published() {
        let h = Hertz {
            law: HertzLaw::Nonlinear,
            e: 2.06e11,
            nu: 0.3,
            width: 0.02,
        };
        // Deflection F/K_h ∝ F^0.9: doubling F multiplies it by 2^0.9.
        let d = |f: f64| f * h.compliance(f);
        assert!((d(2000.0) / d(1000.0) - 2f64.powf(0.9)).abs() < 1e-13);
        // Direct evaluation of eq. (3) at F = 1 N, L = 1 m: K = E^0.9/1.275.
        let unit = Hertz { width: 1.0, ..h };
        assert!((unit.stiffness(1.0) - 2.06e11f64.powf(0.9) / 1.275).abs() < 1e-3);
    }
}
