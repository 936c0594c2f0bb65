//! Mesh-level functions of the mesh phase: stiffness sources and transmission-error series.
//!
//! Everything here is a function of the **mesh phase** `p` (mesh cycles), never of time: the
//! model turns time into phase with its nominal-speed clock (`docs/model.md`, "Mesh phase").

pub mod eccentricity;
pub mod errors;
pub mod geometry;
pub mod helical;
pub mod series;
pub mod stiffness;

pub use series::PhaseSeries;

/// The fraction `p − ⌊p⌋ ∈ [0, 1]` of a mesh phase: the same value as `p.rem_euclid(1.0)`
/// (both are one rounding of the exact fraction; only the sign of a zero may differ), without
/// the software `fmod`, which costs as much as the `sin_cos` of a harmonic.
#[inline]
pub fn cycle_fraction(p: f64) -> f64 {
    p - p.floor()
}

/// `2^52`: adding and subtracting it rounds an `0 ≤ x < 2^52` to an integer (to nearest, ties to
/// even) without a conversion.
const TWO_POW_52: f64 = 4_503_599_627_370_496.0;

/// `10^d` for `d ≤ 15`, each exact in `f64`.
static POWERS_OF_TEN: [f64; 16] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
];

/// The rounding a mesh phase `p` carries, `4ε·max(|p|, 1)` cycles: the clock's `p₀ + f·(t − t₀)`.
fn phase_resolution(magnitude: f64) -> f64 {
    4.0 * f64::EPSILON * magnitude
}

/// The decimals a resolution `r` resolves, at most 15 and at least 1: the largest `d` with
/// `10^d·r ≤ 1`, i.e. `⌊−log₁₀ r⌋`, with the products as `f64` evaluates them.
const fn resolved_digits(resolution: f64) -> usize {
    let mut digits = 15;
    while digits > 1 && POWERS_OF_TEN[digits] * resolution > 1.0 {
        digits -= 1;
    }
    digits
}

/// [`resolved_digits`] of the smallest resolution of each binade of `max(|p|, 1)`,
/// `4ε·2^e` for `e < 64` (larger phases resolve 1 decimal, as the last entry).
static DIGITS_BY_EXPONENT: [u8; 64] = {
    let mut table = [0u8; 64];
    let mut e = 0;
    while e < 64 {
        let magnitude = (1u64 << e) as f64;
        table[e] = resolved_digits(4.0 * f64::EPSILON * magnitude) as u8;
        e += 1;
    }
    table
};

/// `x.round()` (ties away from zero) for `0 ≤ x < 2^52`, bit for bit, without the library
/// call `round` is on the baseline x86-64 target (this runs on every output row): the nearest
/// integer with ties to even, moved up where `x` was a tie below it. Other `x` (NaN) go to
/// `round`.
#[inline]
fn round_non_negative(x: f64) -> f64 {
    if !(0.0..TWO_POW_52).contains(&x) {
        return x.round();
    }
    let nearest = (x + TWO_POW_52) - TWO_POW_52;
    // Exact: an integer within 1/2 of `x`.
    nearest + f64::from(u8::from(x - nearest == 0.5))
}

/// The cycle fraction of mesh phase `p` as an output reports it (the `phase` columns, issue 31
/// item 4): rounded to the decimals the phase resolves. `p` carries a rounding of about
/// `4ε·max(|p|, 1)` cycles (the clock's `p₀ + f·(t − t₀)`), so a fraction within that of a
/// whole cycle is the cycle's start, 0 (not 0.9999999999999858), and the digits below the
/// resolution are dropped: the value printed is the shortest decimal of that resolution.
#[inline]
pub fn output_phase(p: f64) -> f64 {
    let magnitude = p.abs().max(1.0);
    let resolution = phase_resolution(magnitude);
    // The decimals by the binade's table entry, and one fewer where the mantissa takes the
    // product past 1: within one binade `−log₁₀ r` moves by log₁₀ 2 < 1. The same digits as
    // [`resolved_digits`] (this runs on every row of every run).
    let exponent = ((magnitude.to_bits() >> 52) as usize)
        .saturating_sub(1023)
        .min(63);
    let mut digits = DIGITS_BY_EXPONENT[exponent] as usize;
    if digits > 1 && POWERS_OF_TEN[digits] * resolution > 1.0 {
        digits -= 1;
    }
    let scale = POWERS_OF_TEN[digits];
    let fraction = round_non_negative(cycle_fraction(p) * scale) / scale;
    if fraction >= 1.0 {
        0.0
    } else {
        fraction
    }
}
pub use stiffness::{MeshStiffness, Piece};

#[cfg(test)]
mod output_phase_tests {
    use super::output_phase;

    /// A phase a rounding below a whole cycle reports the cycle's start; the fraction is
    /// printed to the decimals the phase resolves; a phase a cycle further resolves fewer.
    #[test]
    fn output_phase_is_rounded_to_its_resolution() {
        let p = 57.0 - 1.42e-14;
        assert_eq!(output_phase(p), 0.0);
        assert_eq!(format!("{}", output_phase(0.0285 * 7.0)), "0.1995");
        assert_eq!(
            format!("{}", output_phase(2850.0 * 0.004_000_01)),
            "0.4000285"
        );
        let q = 12.3 + 4e-15;
        assert_eq!(format!("{}", output_phase(q)), "0.3");
        assert_eq!(output_phase(-0.25), 0.75);
        assert!((0..10_000).all(|k| {
            let v = output_phase(k as f64 * 0.0285);
            (0.0..1.0).contains(&v)
        }));
        assert!(output_phase(f64::NAN).is_nan());
    }

    /// The binade table and its one-step correction give the digits of the direct search, and
    /// the truncating round gives `f64::round`, on phases spread over 60 binades and at the
    /// binades' edges.
    #[test]
    fn output_phase_digits_and_rounding_match_the_direct_forms() {
        use super::{phase_resolution, resolved_digits, round_non_negative, POWERS_OF_TEN};
        let direct = |p: f64| {
            let scale = POWERS_OF_TEN[resolved_digits(phase_resolution(p.abs().max(1.0)))];
            let fraction = (super::cycle_fraction(p) * scale).round() / scale;
            if fraction >= 1.0 {
                0.0
            } else {
                fraction
            }
        };
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for e in 0..60 {
            let binade = (1u64 << e) as f64;
            for p in [binade, binade * (2.0 - f64::EPSILON), -binade * 1.5] {
                assert_eq!(output_phase(p).to_bits(), direct(p).to_bits(), "p = {p:e}");
            }
            for _ in 0..20_000 {
                let p = binade * (1.0 + next());
                assert_eq!(output_phase(p).to_bits(), direct(p).to_bits(), "p = {p:e}");
            }
        }
        for _ in 0..200_000 {
            let x = next() * 1e15;
            assert_eq!(round_non_negative(x), x.round(), "x = {x:e}");
            let y = next();
            assert_eq!(round_non_negative(y), y.round(), "x = {y:e}");
        }
        for x in [
            0.5,
            1.5,
            2.5,
            0.49999999999999994,
            4503599627370495.5,
            1e15 + 0.5,
        ] {
            assert_eq!(round_non_negative(x), x.round(), "x = {x:e}");
        }
    }
}
