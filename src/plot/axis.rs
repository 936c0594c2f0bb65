//! An axis: a quantity, its SI unit, and the engineering prefix the data asks for.

/// The quantity and SI unit of an axis, e.g. `Axis::new("DTE RMS", "m")`.
#[derive(Debug, Clone, Copy)]
pub struct Axis<'a> {
    pub quantity: &'a str,
    /// SI unit of the values handed to the plot (`m`, `N`, `Hz`, `rpm`, `N/m`, or "" for a
    /// number without unit).
    pub unit: &'a str,
    /// Logarithmic scale (positive values only; others are left out).
    pub log: bool,
}

/// Units that take an engineering prefix (µm, kN, kHz, MN/m, ms). Others — rpm, orders, ratios
/// — are drawn as they are.
const PREFIXABLE: [&str; 8] = ["m", "N", "Hz", "N/m", "s", "N·m", "Pa", "W"];

const PREFIXES: [(i32, &str); 9] = [
    (-12, "p"),
    (-9, "n"),
    (-6, "µ"),
    (-3, "m"),
    (0, ""),
    (3, "k"),
    (6, "M"),
    (9, "G"),
    (12, "T"),
];

impl<'a> Axis<'a> {
    pub fn new(quantity: &'a str, unit: &'a str) -> Axis<'a> {
        Axis {
            quantity,
            unit,
            log: false,
        }
    }

    pub fn log(quantity: &'a str, unit: &'a str) -> Axis<'a> {
        Axis {
            quantity,
            unit,
            log: true,
        }
    }

    /// The factor the values are multiplied by and the axis title, e.g. `(1e6, "DTE RMS (µm)")`
    /// for values whose largest magnitude is `largest` metres.
    pub fn scaled(&self, largest: f64) -> (f64, String) {
        let title = |prefix: &str| {
            if self.unit.is_empty() {
                self.quantity.to_string()
            } else {
                format!("{} ({prefix}{})", self.quantity, self.unit)
            }
        };
        if !(PREFIXABLE.contains(&self.unit) && largest.is_finite() && largest > 0.0) {
            return (1.0, title(""));
        }
        let exponent = 3 * (largest.log10() / 3.0).floor() as i32;
        let (e, prefix) = PREFIXES
            .iter()
            .copied()
            .min_by_key(|(e, _)| (e - exponent).abs())
            .expect("prefix table is not empty");
        (10f64.powi(-e), title(prefix))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metres_become_micrometres_and_rpm_stays() {
        let (f, t) = Axis::new("DTE RMS", "m").scaled(5.0e-5);
        assert_eq!((f, t.as_str()), (1e6, "DTE RMS (µm)"));
        let (f, t) = Axis::new("mesh force", "N").scaled(2.2e3);
        assert_eq!((f, t.as_str()), (1e-3, "mesh force (kN)"));
        let (f, t) = Axis::new("input speed", "rpm").scaled(9.5e4);
        assert_eq!((f, t.as_str()), (1.0, "input speed (rpm)"));
        let (f, t) = Axis::new("amplitude ratio", "").scaled(3.0);
        assert_eq!((f, t.as_str()), (1.0, "amplitude ratio"));
        let (f, _) = Axis::new("mesh frequency", "Hz").scaled(950.0);
        assert_eq!(f, 1.0);
    }
}
