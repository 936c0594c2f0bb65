//! CSV in/out in fmpy's conventions.
//!
//! Output (`fmpy.util.write_csv`): a header of double-quoted names, `"time"` first; one row
//! per communication point; Reals in Python `repr` form (shortest text that round-trips, so
//! no precision is lost), Integers as decimal, Booleans as `True`/`False` (what fmpy writes).
//!
//! Input (`fmpy.util.read_csv`): the first line holds the column names (quotes optional), the
//! first column is the time, every cell is a number (read as `f64`, as fmpy does).

/// Format an `f64` exactly like Python's `repr(float)`: shortest round-trip digits, scientific
/// notation when the decimal exponent is < -4 or >= 16, exponent with sign and at least two
/// digits (`1e-05`, `1.5e+16`), `inf`/`-inf`/`nan`.
pub fn format_real(v: f64) -> String {
    if v.is_nan() {
        return "nan".into();
    }
    if v.is_infinite() {
        return if v > 0.0 { "inf".into() } else { "-inf".into() };
    }
    // Rust's `{:?}` uses the same shortest-digits algorithm and the same thresholds as
    // Python's repr; only the exponent spelling differs.
    let s = format!("{v:?}");
    match s.find('e') {
        None => s,
        Some(p) => {
            let (mant, exp) = s.split_at(p);
            let exp = &exp[1..];
            let (sign, digits) = match exp.strip_prefix('-') {
                Some(d) => ('-', d),
                None => ('+', exp),
            };
            format!("{mant}e{sign}{digits:0>2}")
        }
    }
}
