//! Units compared through their SI base units (FMI 2.0.5 §2.2.2, SSP 1.0 `ssc:BaseUnit`: a
//! value v in the unit is `factor·v + offset` in the base units kg^a·m^b·s^c·A^d·K^e·mol^f·
//! cd^g·rad^h). Two units are *compatible* when their exponents agree (N·m and kg·m²/s²), and
//! *equivalent* when factor and offset agree too.

/// Exponents of kg, m, s, A, K, mol, cd, rad, with factor and offset.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BaseUnit {
    pub exponents: [i32; 8],
    pub factor: f64,
    pub offset: f64,
}

const NAMES: [&str; 8] = ["kg", "m", "s", "A", "K", "mol", "cd", "rad"];

impl BaseUnit {
    /// From the attributes of `<BaseUnit>` / `<ssc:BaseUnit>` (absent exponents are 0, factor
    /// 1, offset 0).
    pub fn from_attrs(attrs: &[(String, String)]) -> Result<BaseUnit, String> {
        let mut b = BaseUnit {
            exponents: [0; 8],
            factor: 1.0,
            offset: 0.0,
        };
        for (k, v) in attrs {
            if let Some(i) = NAMES.iter().position(|n| n == k) {
                b.exponents[i] = v
                    .trim()
                    .parse()
                    .map_err(|_| format!("BaseUnit {k}=\"{v}\" is not an integer"))?;
            } else if k == "factor" || k == "offset" {
                let x: f64 = v
                    .trim()
                    .parse()
                    .ok()
                    .filter(|x: &f64| x.is_finite())
                    .ok_or_else(|| format!("BaseUnit {k}=\"{v}\" is not a finite number"))?;
                if k == "factor" {
                    if x == 0.0 {
                        return Err("BaseUnit factor=\"0\" (must not be zero)".into());
                    }
                    b.factor = x;
                } else {
                    b.offset = x;
                }
            }
        }
        Ok(b)
    }

    /// `kg·m2·s-2` (or `1` when dimensionless), for messages.
    pub fn dimension(&self) -> String {
        let parts: Vec<String> = NAMES
            .iter()
            .zip(self.exponents)
            .filter(|(_, e)| *e != 0)
            .map(|(n, e)| {
                if e == 1 {
                    n.to_string()
                } else {
                    format!("{n}{e}")
                }
            })
            .collect();
        if parts.is_empty() {
            "1".into()
        } else {
            parts.join("·")
        }
    }

    pub fn compatible(&self, other: &BaseUnit) -> bool {
        self.exponents == other.exponents
    }

    pub fn equivalent(&self, other: &BaseUnit) -> bool {
        self.compatible(other) && self.factor == other.factor && self.offset == other.offset
    }

    /// `(a, b)` with value_in_`to` = a · value_in_`self` + b (both compatible).
    pub fn conversion_to(&self, to: &BaseUnit) -> (f64, f64) {
        (
            self.factor / to.factor,
            (self.offset - to.offset) / to.factor,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn b(attrs: &[(&str, &str)]) -> BaseUnit {
        let a: Vec<(String, String)> = attrs
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        BaseUnit::from_attrs(&a).unwrap()
    }

    #[test]
    fn compatibility_and_conversion() {
        let nm = b(&[("kg", "1"), ("m", "2"), ("s", "-2")]);
        let j = b(&[("m", "2"), ("kg", "1"), ("s", "-2")]);
        assert!(nm.equivalent(&j));
        let m = b(&[("m", "1")]);
        let mps = b(&[("m", "1"), ("s", "-1")]);
        assert!(!m.compatible(&mps));
        assert_eq!(mps.dimension(), "m·s-1");
        // rpm → rad/s: 1 rpm = 2π/60 rad/s.
        let rads = b(&[("rad", "1"), ("s", "-1")]);
        let rpm = b(&[("rad", "1"), ("s", "-1"), ("factor", "0.10471975511965977")]);
        let (a, o) = rpm.conversion_to(&rads);
        assert_eq!((a, o), (0.10471975511965977, 0.0));
        // °C → K: offset.
        let k = b(&[("K", "1")]);
        let c = b(&[("K", "1"), ("offset", "273.15")]);
        let (a, o) = c.conversion_to(&k);
        assert_eq!(a * 20.0 + o, 293.15);
        assert!(BaseUnit::from_attrs(&[("m".into(), "x".into())]).is_err());
    }
}
