//! Bracketed scalar root finding shared by the integrators' event location and harmonic
//! balance's split quadratures.

/// An end of the bracket that is an exact zero, as `(x, x)` (the common start of the bracketed
/// searches, which require `fa·fb <= 0`).
fn zero_end(a: f64, b: f64, fa: f64, fb: f64) -> Option<(f64, f64)> {
    debug_assert!(fa * fb <= 0.0);
    if fa == 0.0 {
        Some((a, a))
    } else if fb == 0.0 {
        Some((b, b))
    } else {
        None
    }
}

/// Brent's method (Brent 1973, *Algorithms for Minimization without Derivatives*, ch. 4) on a
/// bracket `[a, b]` with `f(a)·f(b) <= 0`, `fa = f(a)`, `fb = f(b)`.
///
/// Returns the bracket `(lo, hi)` of width `<= tol` (or an exact zero as `(x, x)`) such that
/// `f(lo)` has the sign of `fa` and `f(hi)` the sign of `fb`: event location wants the point
/// *after* the crossing so that the guard has really changed sign there.
pub fn brent_bracket<F: FnMut(f64) -> f64>(
    mut f: F,
    a: f64,
    b: f64,
    fa: f64,
    fb: f64,
    tol: f64,
) -> (f64, f64) {
    if let Some(end) = zero_end(a, b, fa, fb) {
        return end;
    }
    // Brent state: b_ is the best estimate, a_ the previous one, c_ the counter-point.
    let (mut a_, mut fa_) = (a, fa);
    let (mut b_, mut fb_) = (b, fb);
    let (mut c_, mut fc_) = (a_, fa_);
    let mut d = b_ - a_;
    let mut e = d;
    for _ in 0..200 {
        if fb_.signum() == fc_.signum() {
            c_ = a_;
            fc_ = fa_;
            d = b_ - a_;
            e = d;
        }
        if fc_.abs() < fb_.abs() {
            a_ = b_;
            fa_ = fb_;
            b_ = c_;
            fb_ = fc_;
            c_ = a_;
            fc_ = fa_;
        }
        let m = 0.5 * (c_ - b_);
        let tol1 = 0.5 * tol;
        if m.abs() <= tol1 || fb_ == 0.0 {
            break;
        }
        if e.abs() >= tol1 && fa_.abs() > fb_.abs() {
            let s = fb_ / fa_;
            let (mut p, mut q);
            if a_ == c_ {
                p = 2.0 * m * s;
                q = 1.0 - s;
            } else {
                let qq = fa_ / fc_;
                let r = fb_ / fc_;
                p = s * (2.0 * m * qq * (qq - r) - (b_ - a_) * (r - 1.0));
                q = (qq - 1.0) * (r - 1.0) * (s - 1.0);
            }
            if p > 0.0 {
                q = -q;
            } else {
                p = -p;
            }
            if 2.0 * p < (3.0 * m * q - (tol1 * q).abs()).min((e * q).abs()) {
                e = d;
                d = p / q;
            } else {
                d = m;
                e = m;
            }
        } else {
            d = m;
            e = m;
        }
        a_ = b_;
        fa_ = fb_;
        b_ += if d.abs() > tol1 { d } else { tol1.copysign(m) };
        fb_ = f(b_);
        if fb_ == 0.0 {
            return (b_, b_);
        }
    }
    if fb_.signum() == fc_.signum() {
        c_ = a_;
    }
    // [b_, c_] brackets the root; order it by sign.
    if fb_.signum() == fa.signum() {
        (b_, c_)
    } else {
        (c_, b_)
    }
}

/// Safeguarded Newton on a bracket `[a, b]` with `f(a)·f(b) <= 0`, `f` returning the value
/// and the derivative, with the contract of [`brent_bracket`] (a bracket `(lo, hi)` of width
/// `<= tol`, `f(lo)` with the sign of `fa`, `f(hi)` with that of `fb`, or an exact zero as
/// `(x, x)`). It starts at `guess` (e.g. the root of an interpolant), or at the secant point
/// when `guess` is not inside the bracket; a Newton step that leaves the bracket or is not
/// at most half the previous one is replaced by bisection (`rtsafe`, Press et al.,
/// *Numerical Recipes* 3rd ed. §9.4). Converged (a step below `tol/4`), the next point lies
/// just past the estimated root (twice the step or a few ulp, doubled after a miss, at most
/// `tol/4`), so the bracket closes from both sides with the far end close to the root. Where the
/// derivative comes at the price of the value (a polynomial), this takes fewer evaluations
/// than Brent.
pub fn newton_bracket<F: FnMut(f64) -> (f64, f64)>(
    mut f: F,
    a: f64,
    b: f64,
    fa: f64,
    fb: f64,
    guess: f64,
    tol: f64,
) -> (f64, f64) {
    if let Some(end) = zero_end(a, b, fa, fb) {
        return end;
    }
    // `same` keeps the sign of fa, `other` the sign of fb.
    let (mut same, mut other) = (a, b);
    let inside = |x: f64, p: f64, q: f64| x > p.min(q) && x < p.max(q);
    let secant = a + (b - a) * (fa / (fa - fb));
    let mut x = if inside(guess, a, b) {
        guess
    } else if inside(secant, a, b) {
        secant
    } else {
        0.5 * (a + b)
    };
    let mut previous_step = (b - a).abs();
    let mut past = 0.0;
    for _ in 0..200 {
        let (fx, slope) = f(x);
        if fx == 0.0 {
            return (x, x);
        }
        if (fx > 0.0) == (fa > 0.0) {
            same = x;
        } else {
            other = x;
        }
        if (other - same).abs() <= tol {
            break;
        }
        let step = fx / slope;
        let mut next = x - step;
        if step.abs() < 0.25 * tol {
            // Converged: the next point lies just past the estimated root, on the side away
            // from x, and closes the bracket. The closer, the smaller the overshoot of the
            // point after the crossing (an event snaps the state onto the surface there, so
            // an overshoot of tol/4 every event adds up); twice as far after each miss.
            past = if past == 0.0 {
                (2.0 * step.abs()).max(16.0 * f64::EPSILON * x.abs())
            } else {
                2.0 * past
            };
            let away = if x == same { other - x } else { same - x };
            next += past.min(0.25 * tol).copysign(away);
        }
        if !inside(next, same, other) || step.abs() > 0.5 * previous_step {
            next = 0.5 * (same + other);
            previous_step = (other - same).abs();
        } else {
            previous_step = step.abs();
        }
        x = next;
    }
    (same, other)
}

/// The largest value of a function on `[a, b]` by Brent's minimisation of `−f` (golden-section
/// steps guarding parabolic interpolation; Brent 1973, ch. 5, procedure `localmin`), located to
/// `tol` in the abscissa: `(x, f(x))`. For a function with one maximum in the bracket (the
/// callers bracket it between the samples beside the best one), or one that rises to an end
/// (a one-sided limit at a switching instant), the result is that maximum or that end to
/// `tol`; the value is then exact to `O(tol²·f'')` at an interior maximum.
pub fn brent_maximum<F: FnMut(f64) -> f64>(mut f: F, a: f64, b: f64, tol: f64) -> (f64, f64) {
    const GOLD: f64 = 0.381_966_011_250_105_1;
    let (mut lo, mut hi) = (a.min(b), a.max(b));
    let mut x = lo + GOLD * (hi - lo);
    let (mut w, mut v) = (x, x);
    let mut fx = -f(x);
    let (mut fw, mut fv) = (fx, fx);
    let (mut d, mut e) = (0.0f64, 0.0f64);
    for _ in 0..200 {
        let m = 0.5 * (lo + hi);
        let tol1 = f64::EPSILON.sqrt() * 1e-3 * x.abs() + tol / 3.0;
        let tol2 = 2.0 * tol1;
        if (x - m).abs() <= tol2 - 0.5 * (hi - lo) {
            break;
        }
        let mut golden = true;
        if e.abs() > tol1 {
            let r = (x - w) * (fx - fv);
            let mut q = (x - v) * (fx - fw);
            let mut p = (x - v) * q - (x - w) * r;
            q = 2.0 * (q - r);
            if q > 0.0 {
                p = -p;
            }
            q = q.abs();
            let etemp = e;
            e = d;
            if p.abs() < (0.5 * q * etemp).abs() && p > q * (lo - x) && p < q * (hi - x) {
                d = p / q;
                let u = x + d;
                if u - lo < tol2 || hi - u < tol2 {
                    d = if m >= x { tol1 } else { -tol1 };
                }
                golden = false;
            }
        }
        if golden {
            e = if x >= m { lo - x } else { hi - x };
            d = GOLD * e;
        }
        let u = if d.abs() >= tol1 {
            x + d
        } else {
            x + tol1.copysign(d)
        };
        let fu = -f(u);
        if fu <= fx {
            if u >= x {
                lo = x;
            } else {
                hi = x;
            }
            (v, fv, w, fw, x, fx) = (w, fw, x, fx, u, fu);
        } else {
            if u < x {
                lo = u;
            } else {
                hi = u;
            }
            if fu <= fw || w == x {
                (v, fv, w, fw) = (w, fw, u, fu);
            } else if fu <= fv || v == x || v == w {
                (v, fv) = (u, fu);
            }
        }
    }
    // A maximum at an end of the bracket (a one-sided limit) is the end itself.
    let (fa, fb) = (f(a.min(b)), f(a.max(b)));
    let mut best = (x, -fx);
    for (xe, fe) in [(a.min(b), fa), (a.max(b), fb)] {
        if fe > best.1 {
            best = (xe, fe);
        }
    }
    best
}

/// The root of `g` in `(lo, hi)`, where it changes sign (Illinois variant of regula falsi:
/// superlinear and bracketing), to a few ulps of the bracket: the contact switches of
/// harmonic balance's split quadratures (`analysis::hb`).
pub fn illinois(mut g: impl FnMut(f64) -> f64, (mut lo, mut hi): (f64, f64)) -> f64 {
    let mut glo = g(lo);
    let mut ghi = g(hi);
    let positive_lo = glo > 0.0;
    let mut side = 0i8;
    for _ in 0..200 {
        if hi - lo <= 4.0 * f64::EPSILON * hi.abs().max(1e-3) {
            break;
        }
        let mut mid = if glo != ghi {
            (lo * ghi - hi * glo) / (ghi - glo)
        } else {
            0.5 * (lo + hi)
        };
        if !(mid > lo && mid < hi) {
            mid = 0.5 * (lo + hi);
        }
        let gm = g(mid);
        if gm == 0.0 {
            return mid;
        }
        if (gm > 0.0) == positive_lo {
            lo = mid;
            glo = gm;
            if side == -1 {
                ghi *= 0.5;
            }
            side = -1;
        } else {
            hi = mid;
            ghi = gm;
            if side == 1 {
                glo *= 0.5;
            }
            side = 1;
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_roots_with_the_sign_convention() {
        let (lo, hi) = brent_bracket(|x| x.cos() - x, 0.0, 1.0, 1.0, 1f64.cos() - 1.0, 1e-15);
        let root = 0.739_085_133_215_160_6;
        assert!((lo - root).abs() < 2e-15 && (hi - root).abs() < 2e-15);
        assert!(lo.cos() - lo >= 0.0 && hi.cos() - hi <= 0.0);
        let mut calls = 0;
        let (lo, hi) = brent_bracket(
            |x| {
                calls += 1;
                x.powi(3) - 2.0
            },
            2.0,
            0.0,
            6.0,
            -2.0,
            1e-14,
        );
        assert!((lo - 2f64.cbrt()).abs() < 1e-14 && (hi - 2f64.cbrt()).abs() < 1e-14);
        assert!(calls < 20, "{calls} evaluations");
    }

    #[test]
    fn newton_keeps_the_contract_and_is_quick() {
        // cos x = x (root 0.7390851332151607, Dottie number), both orientations.
        let f = |x: f64| (x.cos() - x, -x.sin() - 1.0);
        let root = 0.739_085_133_215_160_6;
        for (a, b) in [(0.0, 1.0), (1.0, 0.0)] {
            let mut calls = 0;
            let (lo, hi) = newton_bracket(
                |x| {
                    calls += 1;
                    f(x)
                },
                a,
                b,
                f(a).0,
                f(b).0,
                f64::NAN,
                1e-15,
            );
            assert!((lo - root).abs() < 2e-15 && (hi - root).abs() < 2e-15);
            assert!((lo - hi).abs() <= 1e-15);
            assert!(f(lo).0.signum() == f(a).0.signum() || f(lo).0 == 0.0);
            assert!(f(hi).0.signum() == f(b).0.signum() || f(hi).0 == 0.0);
            assert!(calls <= 6, "{calls} evaluations");
        }
        // A flat start (zero derivative at the secant point's side) falls back to bisection:
        // x³ on [-1, 2] with the root at 0.
        let (lo, hi) = newton_bracket(
            |x| (x * x * x, 3.0 * x * x),
            -1.0,
            2.0,
            -1.0,
            8.0,
            f64::NAN,
            1e-12,
        );
        assert!(lo <= 0.0 && hi >= 0.0 && hi - lo <= 1e-12, "{lo} {hi}");
    }

    #[test]
    fn brent_maximum_finds_an_interior_maximum_and_an_end() {
        // cos has its maximum 1 at 0; on [−0.3, 0.5] Brent locates it.
        let (x, v) = super::brent_maximum(f64::cos, -0.3, 0.5, 1e-12);
        assert!(x.abs() < 1e-9 && (v - 1.0).abs() < 1e-16, "{x} {v}");
        // A function rising to the right end: the end.
        let (x, v) = super::brent_maximum(|t| t * t, 0.1, 0.7, 1e-12);
        assert_eq!((x, v), (0.7, 0.7 * 0.7));
        // The maximum of sin(5t) + 0.3 t on [0, 0.6] is at 5 cos(5t) = −0.3.
        let (x, _) = super::brent_maximum(|t| (5.0 * t).sin() + 0.3 * t, 0.0, 0.6, 1e-13);
        let exact = (-0.3f64 / 5.0).acos() / 5.0;
        assert!((x - exact).abs() < 1e-10, "{x} {exact}");
    }
}
