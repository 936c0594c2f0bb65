//! A motor's full-load curve `T_max(ω)`: piecewise linear between the points, held constant
//! beyond the first and the last point (`docs/elements.md`).

use schemars::JsonSchema;
use serde::Deserialize;

use super::field;

/// `[element.curve]`: `speed` (rad/s, strictly increasing, >= 2 points) and `torque`
/// (N·m, >= 0), the same number of points.
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TorqueCurve {
    /// Speeds of the points, rad/s, strictly increasing.
    #[schemars(extend("x-unit" = "rad/s"))]
    pub speed: Vec<f64>,
    /// Full-load torque at the points, N·m (>= 0).
    #[schemars(transform = crate::scene::schema::non_negative, extend("x-unit" = "N.m"))]
    pub torque: Vec<f64>,
}

impl TorqueCurve {
    /// Checks the points; messages name `<prefix>.speed[i]` or `<prefix>.torque[i]` and the
    /// value.
    pub fn validate(&self, prefix: &str) -> Result<(), String> {
        let (s, t) = (&self.speed, &self.torque);
        if s.len() < 2 {
            return Err(format!(
                "{} has {} point(s): at least 2 are needed",
                field(prefix, "speed"),
                s.len()
            ));
        }
        if t.len() != s.len() {
            return Err(format!(
                "{} has {} points but {} has {}: one torque per speed",
                field(prefix, "torque"),
                t.len(),
                field(prefix, "speed"),
                s.len()
            ));
        }
        for (i, &w) in s.iter().enumerate() {
            let name = field(prefix, &format!("speed[{i}]"));
            if !w.is_finite() {
                return Err(format!("{name} = {w}: must be finite (rad/s)"));
            }
            if i > 0 && w <= s[i - 1] {
                return Err(format!(
                    "{name} = {w}: speeds must be strictly increasing (previous {})",
                    s[i - 1]
                ));
            }
        }
        for (i, &x) in t.iter().enumerate() {
            if !(x.is_finite() && x >= 0.0) {
                let name = field(prefix, &format!("torque[{i}]"));
                return Err(format!("{name} = {x}: must be a finite number >= 0 N.m"));
            }
        }
        Ok(())
    }

    /// The segment index `i` with `speed[i] <= ω < speed[i + 1]`, or `None` beyond the ends
    /// or for a NaN speed (a diverged state: issue 34 found `partition_point` then returning
    /// 0 and the index underflowing).
    fn segment(&self, speed: f64) -> Option<usize> {
        let s = &self.speed;
        if !(speed >= s[0] && speed < s[s.len() - 1]) {
            return None;
        }
        // First point above `speed`, minus one (the curve has few points; a linear scan
        // would do, but this keeps long tabulated curves cheap).
        Some(s.partition_point(|&x| x <= speed) - 1)
    }

    /// `T_max(ω)`, N·m.
    pub fn max_torque(&self, speed: f64) -> f64 {
        let (s, t) = (&self.speed, &self.torque);
        match self.segment(speed) {
            Some(i) => t[i] + (t[i + 1] - t[i]) * (speed - s[i]) / (s[i + 1] - s[i]),
            None if speed < s[0] => t[0],
            // NaN in, NaN out: the solver's finiteness checks report the diverged state.
            None if speed.is_nan() => f64::NAN,
            None => t[t.len() - 1],
        }
    }

    /// `dT_max/dω` (the slope of the segment holding `ω`, right-continuous; 0 beyond the
    /// ends), N·m·s/rad.
    pub fn slope(&self, speed: f64) -> f64 {
        let (s, t) = (&self.speed, &self.torque);
        self.segment(speed)
            .map_or(0.0, |i| (t[i + 1] - t[i]) / (s[i + 1] - s[i]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn curve() -> TorqueCurve {
        TorqueCurve {
            speed: vec![0.0, 100.0, 200.0],
            torque: vec![150.0, 150.0, 75.0],
        }
    }

    #[test]
    fn interpolates_and_holds_the_ends() {
        let c = curve();
        assert_eq!(c.max_torque(-5.0), 150.0);
        assert_eq!(c.max_torque(50.0), 150.0);
        assert_eq!(c.max_torque(150.0), 112.5);
        assert_eq!(c.max_torque(300.0), 75.0);
        assert_eq!(c.slope(150.0), -0.75);
        assert_eq!(c.slope(300.0), 0.0);
    }

    #[test]
    fn a_nan_speed_gives_nan_not_a_panic() {
        let c = curve();
        assert!(c.max_torque(f64::NAN).is_nan());
        assert_eq!(c.slope(f64::NAN), 0.0);
    }

    #[test]
    fn bad_points_are_named() {
        let mut c = curve();
        c.speed[2] = 100.0;
        assert!(c
            .validate("element.curve")
            .unwrap_err()
            .contains("element.curve.speed[2] = 100"));
        let mut c = curve();
        c.torque[1] = -1.0;
        assert!(c
            .validate("curve")
            .unwrap_err()
            .contains("curve.torque[1] = -1"));
        let mut c = curve();
        c.torque.pop();
        assert!(c
            .validate("curve")
            .unwrap_err()
            .contains("one torque per speed"));
    }
}
