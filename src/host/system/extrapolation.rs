//! Extrapolation of a producer's output beyond the line, for the error-controlled master's
//! extrapolated connections whose consumer takes input derivatives of order 2 or 3 (its
//! vendor annotation, [`super::plan::Plan::extrapolation_order`]).
//!
//! An FMU gives its outputs' first derivatives only (`maxOutputDerivativeOrder="1"` for every
//! geardyn FMU), so the higher derivatives at a step's start `t` come from the last accepted
//! step `[t − H_b, t]`: the cubic Hermite interpolant of the values and first derivatives at
//! its two ends (de Boor, A Practical Guide to Splines, ch. IV), which matches `y(t)` and
//! `y'(t)` exactly, is differentiated at `t`. Its second and third derivatives there are
//! `y''(t) + O(H_b²)` and `y'''(t) + O(H_b)` for a smooth signal, so the extrapolated
//! polynomial `y + y'·s + y''·s²/2 + y'''·s³/6` over a step `H ≈ H_b` is off by `O(H⁴)`
//! (`O(H³)` with the quadratic alone). Why: the stateless compliances (the five-FMU system's
//! shafts) return torques that follow the flows they are given (angles, speeds) directly,
//! and a stiff compliance turns the line's `H²|y''|/2` into a torque error the master then
//! has to undo (the refresh term of `controlled::estimate`); docs/cosimulation.md, section
//! "The master's extrapolation into the compliances".

/// Per producer port: its value and first derivative at the start of the last accepted step;
/// and that step's length, the same for every port (0: no step accepted yet).
pub(super) struct History {
    value: Vec<f64>,
    der: Vec<f64>,
    step: f64,
}

impl History {
    pub(super) fn new(ports: usize) -> Self {
        History {
            value: vec![0.0; ports],
            der: vec![0.0; ports],
            step: 0.0,
        }
    }

    /// A step of length `h` from `start` (values), `der_start` (derivatives) was accepted.
    pub(super) fn accept(&mut self, start: &[f64], der_start: &[f64], h: f64) {
        self.value.copy_from_slice(start);
        self.der.copy_from_slice(der_start);
        self.step = h;
    }

    /// Whether the last accepted step is long enough for its higher derivatives to be
    /// extrapolated over a step of length `h`: at least an eighth of it (the polynomial's
    /// error grows as `(h/H_b)³` beyond its span).
    pub(super) fn reaches(&self, h: f64) -> bool {
        self.step * 8.0 >= h
    }

    /// The accepted step's end was a switch of the signals' slopes: no step gives higher
    /// derivatives until the next one is accepted.
    pub(super) fn forget(&mut self) {
        self.step = 0.0;
    }

    /// The second and third derivatives at the current point of port `p`, whose value and
    /// derivative there are `y` and `d`, up to `order` (2: the second only; below 2 or
    /// without an accepted step or with a non-finite result: zeros, the line).
    pub(super) fn higher(&self, p: usize, y: f64, d: f64, order: u8) -> [f64; 2] {
        let hb = self.step;
        if order < 2 || hb <= 0.0 {
            return [0.0; 2];
        }
        // The Hermite cubic on [0, hb] from (value, der) to (y, d), differentiated at hb.
        let [_, c2, c3] = super::master::hermite(self.value[p], y, self.der[p], d, hb);
        let second = c2 + c3 * hb;
        let third = if order >= 3 { c3 } else { 0.0 };
        if second.is_finite() && third.is_finite() {
            [second, third]
        } else {
            [0.0; 2]
        }
    }
}

/// The higher derivatives `c` (second, third) a connection of extrapolation order `order`
/// gives its consumer: the third only from order 3, none below order 2 (a port may feed
/// consumers of different orders).
pub(super) fn up_to(c: [f64; 2], order: u8) -> [f64; 2] {
    match order {
        0 | 1 => [0.0; 2],
        2 => [c[0], 0.0],
        _ => c,
    }
}

/// The integral over `[0, h]` of the extrapolated polynomial
/// ([`crate::fmi::model::input_polynomial`]) `y + d·s + c[0]·s²/2 + c[1]·s³/6`.
pub(super) fn integral(y: f64, d: f64, c: [f64; 2], h: f64) -> f64 {
    if c == [0.0; 2] {
        return h * y + h * h / 2.0 * d;
    }
    h * (y + h * (d / 2.0 + h * (c[0] / 6.0 + h * c[1] / 24.0)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fmi::model::input_polynomial as value_at;

    /// A cubic `y(t) = a + b·t + c·t² + e·t³` and its derivatives (the closed form).
    fn cubic(t: f64) -> [f64; 4] {
        let (a, b, c, e) = (0.7, -1.3, 2.9, -4.1);
        [
            a + t * (b + t * (c + t * e)),
            b + t * (2.0 * c + t * 3.0 * e),
            2.0 * c + 6.0 * e * t,
            6.0 * e,
        ]
    }

    /// From one accepted step the Hermite cubic is the signal itself when the signal is a
    /// cubic: its second and third derivatives at the step's end are the closed form's, and
    /// the extrapolated polynomial, its value and its integral over the next step are exact
    /// (to rounding); order 2 drops the third derivative, and without a step there is none.
    #[test]
    fn a_cubic_is_extrapolated_exactly_from_the_last_step() {
        let (t0, hb, h) = (0.2, 0.05, 0.08);
        let (start, end) = (cubic(t0 - hb), cubic(t0));
        let mut hist = History::new(1);
        assert_eq!(hist.higher(0, end[0], end[1], 3), [0.0; 2]);
        hist.accept(&[start[0]], &[start[1]], hb);
        let c = hist.higher(0, end[0], end[1], 3);
        assert!((c[0] - end[2]).abs() < 1e-9 * end[2].abs(), "{c:?} {end:?}");
        assert!((c[1] - end[3]).abs() < 1e-8 * end[3].abs(), "{c:?} {end:?}");
        let two = hist.higher(0, end[0], end[1], 2);
        assert_eq!(two, [c[0], 0.0]);
        assert_eq!(up_to(c, 2), two);
        assert_eq!(up_to(c, 1), [0.0; 2]);
        assert_eq!(hist.higher(0, end[0], end[1], 1), [0.0; 2]);
        for s in [0.0, 0.3 * h, h] {
            let exact = cubic(t0 + s)[0];
            let got = value_at(end[0], end[1], c, s);
            assert!((got - exact).abs() < 1e-12, "s = {s}: {got} vs {exact}");
        }
        // ∫ y over [t0, t0 + h] from the antiderivative of the closed form.
        let anti = |t: f64| {
            let (a, b, cc, e) = (0.7, -1.3, 2.9, -4.1);
            t * (a + t * (b / 2.0 + t * (cc / 3.0 + t * e / 4.0)))
        };
        let exact = anti(t0 + h) - anti(t0);
        let got = integral(end[0], end[1], c, h);
        assert!((got - exact).abs() < 1e-14, "{got} vs {exact}");
        // Without higher derivatives: the line, bit for bit.
        assert_eq!(value_at(1.5, 2.5, [0.0; 2], 0.1), 1.5 + 0.1 * 2.5);
        assert_eq!(
            integral(1.5, 2.5, [0.0; 2], 0.1),
            0.1 * 1.5 + 0.1 * 0.1 / 2.0 * 2.5
        );
    }
}
