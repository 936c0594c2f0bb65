//! Lines of a planetary stage's central-member translation seen from the fixed (ground) frame
//! (`docs/planetary.md`, "Fixed-frame spectra"): the model's translations `(x, y)` live in the
//! frame turning with the carrier at its nominal angle `θ_c = Ω_c t`; a fixed sensor sees
//! `X = x cos θ_c − y sin θ_c`, `Y = x sin θ_c + y cos θ_c`. Each carrier-frame line at f
//! appears at `f ± f_c` (McFadden & Smith 1985: the modulation sidebands of a fixed sensor).

use rustfft::num_complex::Complex;

use super::Spectrum;

/// Two-sided Fourier coefficient of `s` at bin `k` (negative: the conjugate line), from the
/// one-sided amplitudes and phases (`amplitude[0]` the mean's magnitude, `amplitude[k]` the
/// cosine's amplitude `2|c_k|`); zero beyond the spectrum.
fn coefficient(s: &Spectrum, k: i64) -> Complex<f64> {
    let i = k.unsigned_abs() as usize;
    if i >= s.amplitude.len() {
        return Complex::new(0.0, 0.0);
    }
    let scale = if i == 0 { 1.0 } else { 0.5 };
    let c = Complex::from_polar(scale * s.amplitude[i], s.phase[i]);
    if k < 0 {
        c.conj()
    } else {
        c
    }
}

/// The fixed-frame spectra `(X, Y)` from the carrier-frame spectra of `x` and `y` on the same
/// bins (spacing `resolution`), with the carrier turning `shift` bins per record (signed, ccw
/// positive: `f_c = shift·resolution`, which must be a whole number of bins, the record an
/// integer number of carrier revolutions). Exact for the lines given: with `θ = 2π f_c t`,
/// `C_X(f) = ½[c_x(f − f_c) + c_x(f + f_c)] + ½ i [c_y(f − f_c) − c_y(f + f_c)]` and
/// `C_Y(f) = −½ i [c_x(f − f_c) − c_x(f + f_c)] + ½[c_y(f − f_c) + c_y(f + f_c)]`. The lines
/// shifted beyond the last bin are dropped (the caller keeps the band below it).
pub fn fixed_frame_lines(x: &Spectrum, y: &Spectrum, shift: i64) -> (Spectrum, Spectrum) {
    let bins = x.amplitude.len();
    let half = Complex::new(0.5, 0.0);
    let half_i = Complex::new(0.0, 0.5);
    let mut out = [x.clone(), x.clone()];
    for k in 0..bins as i64 {
        let (xm, xp) = (coefficient(x, k - shift), coefficient(x, k + shift));
        let (ym, yp) = (coefficient(y, k - shift), coefficient(y, k + shift));
        let cx = half * (xm + xp) + half_i * (ym - yp);
        let cy = -half_i * (xm - xp) + half * (ym + yp);
        for (s, c) in out.iter_mut().zip([cx, cy]) {
            let scale = if k == 0 { 1.0 } else { 2.0 };
            s.amplitude[k as usize] = scale * c.norm();
            s.phase[k as usize] = c.arg();
        }
    }
    let [fx, fy] = out;
    (fx, fy)
}
