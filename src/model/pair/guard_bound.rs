//! A bound that proves a contact guard of the pair positive for a whole mode, so the exact
//! propagator evaluates no root function there (a loaded pair that never separates does no
//! event work).
//!
//! In contact with constant stiffness `k` (one piece of a piecewise-constant stiffness) the
//! deflection `δ = x − e(p)` obeys `m δ'' + c δ' + k δ = F − k b − m ë` (`b` the back-side
//! offset; `docs/model.md`). Its forced response is `δ_p = u_c + Re Σ_h U_h e^{i h ω t}` with
//! `u_c = (F − k b)/k` and, for the STE harmonic `e_h = Re(E_h e^{iθ_h})`,
//! `U_h = m (hω)² E_h / (k − m (hω)² + i c hω)`. The rest `u = δ − δ_p` is a free damped
//! oscillation whose energy `½ m u'² + ½ k u²` does not grow for `c ≥ 0`, so
//! `|u(t)| ≤ r = √(u² + m u'²/k)` at all later times and
//! `δ(t) ∈ [u_c − Σ|U_h| − r, u_c + Σ|U_h| + r]` while the mode lasts.

use std::f64::consts::TAU;

use super::{ContactState, GearPair};

/// A lower bound of the contact guard (drive `δ`, back `−(δ + 2b)`) for all time in the
/// current mode from the lifted state `z`; `None` when separated or without a usable bound.
pub fn contact_guard_lower_bound(pair: &GearPair, z: &[f64]) -> Option<f64> {
    let (sign, offset) = match pair.contact {
        ContactState::Drive => (1.0, 0.0),
        ContactState::Back => (-1.0, pair.clearance()),
        ContactState::Separated => return None,
    };
    let (k, c, m) = (pair.segment_stiffness(), pair.damping, pair.m_e);
    if !(k > 0.0 && c >= 0.0) {
        return None;
    }
    let omega = TAU * pair.clock.mesh_frequency();
    let u_c = (pair.f_ext - k * offset) / k;
    let (mut e, mut e_rate) = (0.0, 0.0);
    let (mut forced, mut forced_rate, mut amplitude) = (u_c, 0.0, 0.0);
    for (i, &(a, b)) in pair.ste.coefficients().iter().enumerate() {
        let hw = (i + 1) as f64 * omega;
        let (ch, sh) = (z[2 * (i + 1)], z[2 * (i + 1) + 1]);
        e += a * ch + b * sh;
        e_rate += hw * (b * ch - a * sh);
        // U = m (hω)² (a − i b) / (k − m (hω)² + i c hω), then U·(ch + i sh).
        let (num_re, num_im) = (m * hw * hw * a, -m * hw * hw * b);
        let (den_re, den_im) = (k - m * hw * hw, c * hw);
        let den = den_re * den_re + den_im * den_im;
        let u_re = (num_re * den_re + num_im * den_im) / den;
        let u_im = (num_im * den_re - num_re * den_im) / den;
        let (uz_re, uz_im) = (u_re * ch - u_im * sh, u_re * sh + u_im * ch);
        forced += uz_re;
        forced_rate -= hw * uz_im;
        amplitude += u_re.hypot(u_im);
    }
    let free = z[0] - e - forced;
    let free_rate = z[1] - e_rate - forced_rate;
    let radius = (free * free + m * free_rate * free_rate / k).sqrt();
    let lower = sign * (u_c + offset) - amplitude - radius;
    // Rounding of the terms above is ~1e-16 of their size: keep a wide margin.
    let scale = u_c.abs() + offset + amplitude + radius;
    (lower > 1e-9 * scale).then_some(lower)
}
