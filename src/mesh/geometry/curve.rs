//! The secant mesh stiffness `K(s, T) = W / δ(s)` over one mesh period, with its contact
//! zones, the extended-tooth-contact (ETC) angles and the Fourier coefficients (Liao et al.
//! 2025 eqs. (5)–(7); notes §1.6 "recommended implementation").
//!
//! **Phase convention** (as the `rectangular` source, `docs/model.md`): `s ∈ [0, 1)` is the
//! mesh phase, pinion angle `φ = s·2π/z1`; `s = 0` is the theoretical end of multiple contact
//! (a pair leaves at the pinion tip E). Tooth pair `k` sits at `x_k(s) = x_E + p_b (s + k)` on
//! the line of action (distance from T1) and is on the theoretical path of contact when
//! `x_A ≤ x_k ≤ x_E`. Without ETC the `floor(ε)`-pair zone is `[0, s_en)` and the
//! `ceil(ε)`-pair zone `[s_en, 1)`, with `s_en = ceil(ε) − ε`.
//!
//! **ETC**: outside the path a pair has the linearised gap `g = r_b1 ×` (pinion angle to the
//! path boundary) `= |x − x_{A|E}|` (the gap implied by eq. (6), ε_unloaded = 0), and its
//! contact stays at the path end (tip contact), where its compliance is evaluated. The
//! leaving pair stays loaded while the remaining pairs' deflection exceeds its gap, the
//! entering pair is loaded as soon as it does: the zone bounds solve `δ_low(s) = g(s)` (Brent),
//! which is eq. (6) without the small-deformation approximation of evaluating the
//! compliance at the theoretical bound.

use std::f64::consts::TAU;

use super::sharing::{self, Candidate, Sharing};
use super::MeshModel;
use crate::mesh::{MeshStiffness, Piece};
use crate::solve::roots::brent_bracket;

/// What to compute.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurveOptions {
    /// Pinion torque T, N·m (> 0).
    pub torque: f64,
    /// Extended tooth contact on/off.
    pub etc: bool,
}

/// One sample of the curve.
#[derive(Debug, Clone, PartialEq)]
pub struct Sample {
    /// Mesh phase (may exceed 1 in the zone that wraps; see [`StiffnessCurve::knots`]).
    pub phase: f64,
    pub stiffness: f64,
    pub deflection: f64,
    /// Forces of the zone's pairs, ordered from the pair nearest the exit E to the one
    /// nearest the entry A, N.
    pub forces: Vec<f64>,
    pub iterations: usize,
}

/// ETC bound: computed by the load-sharing solve vs eq. (6).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EtcBound {
    /// Extension of contact beyond the theoretical bound, pinion angle, rad (solver).
    pub solved: f64,
    /// The same from eq. (6): `(T/r_b1²)·Σ compliances at the theoretical bound`, rad.
    pub eq6: f64,
}

impl EtcBound {
    pub fn relative_error(&self) -> f64 {
        (self.solved - self.eq6).abs() / self.eq6
    }
}

/// The stiffness curve of one mesh period.
#[derive(Debug, Clone, PartialEq)]
pub struct StiffnessCurve {
    pub options: CurveOptions,
    /// Transmitted force `W = T / r_b1`, N.
    pub load: f64,
    pub contact_ratio: f64,
    pub teeth: u32,
    /// Theoretical phase where the extra pair enters, `ceil(ε) − ε`.
    pub theoretical_entry: f64,
    /// Phase where the fewer-pairs zone starts (0 without ETC; the late exit with ETC).
    pub exit: f64,
    /// Phase where the extra pair starts carrying load (`theoretical_entry` without ETC).
    pub entry: f64,
    /// Number of pairs in the low zone `[exit, entry)`; the high zone has one more.
    pub low_pairs: usize,
    /// Knots of the low zone `[exit, entry]` then the high zone `[entry, 1 + exit]`.
    pub low: Vec<Sample>,
    pub high: Vec<Sample>,
    /// `(entry, exit)` extensions with ETC; `None` without.
    pub etc_bounds: Option<(EtcBound, EtcBound)>,
}

impl MeshModel {
    fn candidate(&self, x: f64) -> Candidate {
        let p = &self.pair;
        let clamped = x.clamp(p.x_start, p.x_end);
        let gap = (p.x_start - x).max(x - p.x_end).max(0.0);
        Candidate {
            compliance: self.compliance_at(clamped).total(),
            gap,
        }
    }

    /// Position of pair `k` at phase `s`.
    fn position(&self, k: i64, s: f64) -> f64 {
        self.pair.x_end + self.pair.base_pitch * (s + k as f64)
    }

    /// Load sharing at phase `s` among the fixed pair set `ks`, all forced active.
    fn solve_zone(&self, ks: &[i64], s: f64, load: f64) -> Result<Sharing, String> {
        let pairs: Vec<Candidate> = ks
            .iter()
            .map(|&k| self.candidate(self.position(k, s)))
            .collect();
        sharing::share(&pairs, &self.hertz, load, true).map_err(|e| {
            format!(
                "{e} at phase {s} (pairs {ks:?}, gaps {:?})",
                pairs.iter().map(|p| p.gap).collect::<Vec<_>>()
            )
        })
    }

    /// Load sharing at phase `s` among every pair within one base pitch of the path (ETC) or
    /// on it (no ETC), the active set found by the solver. Public for tests and diagnostics.
    pub fn solve_free(&self, s: f64, load: f64, etc: bool) -> Result<(Vec<i64>, Sharing), String> {
        let p = &self.pair;
        let margin = if etc { p.base_pitch } else { 0.0 };
        let ks: Vec<i64> = (-(p.contact_ratio.ceil() as i64) - 3..=3)
            .filter(|&k| {
                let x = self.position(k, s);
                x >= p.x_start - margin && x <= p.x_end + margin
            })
            .collect();
        let pairs: Vec<Candidate> = ks
            .iter()
            .map(|&k| self.candidate(self.position(k, s)))
            .collect();
        Ok((ks, sharing::share(&pairs, &self.hertz, load, false)?))
    }

    /// The stiffness curve over one mesh period.
    pub fn curve(&self, options: CurveOptions) -> Result<StiffnessCurve, String> {
        let p = &self.pair;
        if !(options.torque.is_finite() && options.torque > 0.0) {
            return Err(format!(
                "torque = {}: must be a finite number > 0 N·m",
                options.torque
            ));
        }
        let load = options.torque / p.pinion.r_base;
        let eps = p.contact_ratio;
        let s_en = eps.ceil() - eps;
        let low_pairs = eps.floor() as usize;
        // Pairs on the path throughout the low zone: x_k(s) ∈ [x_A, x_E] for s ∈ (0, s_en).
        let k_low: Vec<i64> = (1..=low_pairs as i64).map(|j| -j).collect();
        let k_entry = -(eps.ceil() as i64);
        let delta_low = |s: f64| self.solve_zone(&k_low, s, load).map(|sh| sh.deflection);
        let theta_m = TAU / p.pinion.teeth as f64;
        let pb = p.base_pitch;

        let (exit, entry, etc_bounds) = if options.etc {
            // Late exit: the leaving pair (k = 0) has gap p_b s; entry pair: p_b (s_en − s).
            let f_exit = |s: f64| delta_low(s).map(|d| d - pb * s);
            let f_entry = |s: f64| delta_low(s).map(|d| d - pb * (s_en - s));
            let (fx0, fx1) = (f_exit(0.0)?, f_exit(s_en)?);
            let (fe0, fe1) = (f_entry(0.0)?, f_entry(s_en)?);
            if !(fx1 < 0.0 && fe0 < 0.0) {
                return Err(format!(
                    "torque = {} N·m: the extended contact would span a whole single-contact zone \
                     (deflection {:e} m vs base pitch {pb:e} m); the ETC model does not apply",
                    options.torque,
                    delta_low(0.0)?
                ));
            }
            let root =
                |f: &dyn Fn(f64) -> Result<f64, String>, fa: f64, fb: f64| -> Result<f64, String> {
                    let mut err = None;
                    let (lo, hi) = brent_bracket(
                        |s| match f(s) {
                            Ok(v) => v,
                            Err(e) => {
                                err = Some(e);
                                0.0
                            }
                        },
                        0.0,
                        s_en,
                        fa,
                        fb,
                        1e-15,
                    );
                    match err {
                        Some(e) => Err(e),
                        None => Ok(0.5 * (lo + hi)),
                    }
                };
            let exit = root(&f_exit, fx0, fx1)?;
            let entry = root(&f_entry, fe0, fe1)?;
            if exit >= entry {
                return Err(format!(
                    "torque = {} N·m: the late exit (phase {exit}) passes the early entry (phase {entry}); \
                     the fewer-pairs zone vanishes and the ETC model does not apply",
                    options.torque
                ));
            }
            // Eq. (6) with ε = 0 and K_f12 = 0: extension = W·C_loaded(bound)/r_b1, rad; with
            // several loaded pairs, their shared deflection at the bound.
            let r1 = p.pinion.r_base;
            let bounds = (
                EtcBound {
                    solved: (s_en - entry) * theta_m,
                    eq6: delta_low(s_en)? / r1,
                },
                EtcBound {
                    solved: exit * theta_m,
                    eq6: delta_low(0.0)? / r1,
                },
            );
            (exit, entry, Some(bounds))
        } else {
            (0.0, s_en, None)
        };

        let mut k_high = k_low.clone();
        k_high.push(k_entry);
        let n = self.samples;
        // Each sub-interval gets `n` intervals: with ETC the narrow extension zones, where the
        // entering/leaving pair picks up load, are resolved as finely as the rest.
        let sample_zone = |ks: &[i64], bounds: &[f64]| -> Result<Vec<Sample>, String> {
            let mut phases = vec![bounds[0]];
            for w in bounds.windows(2) {
                let (a, b) = (w[0], w[1]);
                phases.extend((1..n).map(|i| a + (b - a) * i as f64 / n as f64));
                phases.push(b);
            }
            phases
                .into_iter()
                .map(|s| {
                    let sh = self.solve_zone(ks, s, load)?;
                    Ok(Sample {
                        phase: s,
                        stiffness: load / sh.deflection,
                        deflection: sh.deflection,
                        forces: sh.forces,
                        iterations: sh.iterations,
                    })
                })
                .collect()
        };
        let low = sample_zone(&k_low, &[exit, entry])?;
        let high_bounds = if options.etc {
            vec![entry, s_en, 1.0, 1.0 + exit]
        } else {
            vec![entry, 1.0]
        };
        let high = sample_zone(&k_high, &high_bounds)?;
        Ok(StiffnessCurve {
            options,
            load,
            contact_ratio: eps,
            teeth: p.pinion.teeth,
            theoretical_entry: s_en,
            exit,
            entry,
            low_pairs,
            low,
            high,
            etc_bounds,
        })
    }
}

impl StiffnessCurve {
    /// All knots in phase order from `exit` to `1 + exit` (the zone bound appears twice).
    pub fn knots(&self) -> impl Iterator<Item = &Sample> {
        self.low.iter().chain(&self.high)
    }

    /// Width of the fewer-pairs (single-contact for 1 < ε < 2) zone, mesh cycles.
    pub fn low_extent(&self) -> f64 {
        self.entry - self.exit
    }

    /// Width of the more-pairs (double-contact) zone, mesh cycles.
    pub fn high_extent(&self) -> f64 {
        1.0 - self.low_extent()
    }

    /// The curve as linear pieces covering `[0, 1)` in order (jumps kept exactly at the
    /// zone bounds, the piece that crosses `s = 1` split and wrapped).
    pub fn pieces(&self) -> Vec<Piece> {
        let mut pieces = Vec::new();
        for zone in [&self.low, &self.high] {
            for w in zone.windows(2) {
                let (a, b) = (&w[0], &w[1]);
                if b.phase <= a.phase {
                    continue;
                }
                let slope = (b.stiffness - a.stiffness) / (b.phase - a.phase);
                let piece = Piece {
                    start: a.phase,
                    end: b.phase,
                    k_start: a.stiffness,
                    slope,
                };
                if piece.end <= 1.0 {
                    pieces.push(piece);
                } else if piece.start >= 1.0 {
                    pieces.push(Piece {
                        start: piece.start - 1.0,
                        end: piece.end - 1.0,
                        ..piece
                    });
                } else {
                    pieces.push(Piece { end: 1.0, ..piece });
                    pieces.push(Piece {
                        start: 0.0,
                        end: piece.end - 1.0,
                        k_start: piece.value(1.0),
                        slope,
                    });
                }
            }
        }
        pieces.sort_by(|a, b| a.start.total_cmp(&b.start));
        // Snap the wrap-around end exactly onto the next start (rounding of `1 + exit − 1`).
        if let (Some(first), Some(last)) = (pieces.first().copied(), pieces.last_mut()) {
            last.end = 1.0;
            debug_assert_eq!(first.start, 0.0);
        }
        pieces
    }

    /// The piecewise-linear source for the dynamic model (`phase` as in the scene).
    pub fn to_table(&self, phase: f64) -> MeshStiffness {
        MeshStiffness::Piecewise {
            phase,
            pieces: self.pieces(),
        }
    }

    /// Exact mean of the piecewise-linear curve, N/m.
    pub fn mean(&self) -> f64 {
        self.to_table(0.0).mean()
    }

    /// Fourier coefficients `(a_h, b_h)`, `h = 1..=harmonics`, of the piecewise-linear curve:
    /// `k(s) = mean + Σ a_h cos(2πhs) + b_h sin(2πhs)` (eq. (7) with `K_h = hypot(a_h, b_h)`,
    /// `ψ_h = atan2(b_h, a_h)`), integrated exactly piece by piece (no FFT aliasing).
    pub fn fourier(&self, harmonics: usize) -> Vec<(f64, f64)> {
        let pieces = self.pieces();
        (1..=harmonics)
            .map(|h| {
                let w = TAU * h as f64;
                let (mut a, mut b) = (0.0, 0.0);
                for p in &pieces {
                    // ∫ (k0 + m(s − s0)) cos ws ds and sin, by parts.
                    let (k0, m) = (p.k_start, p.slope);
                    let cos_int = |s: f64| {
                        let k = k0 + m * (s - p.start);
                        k * (w * s).sin() / w + m * (w * s).cos() / (w * w)
                    };
                    let sin_int = |s: f64| {
                        let k = k0 + m * (s - p.start);
                        -k * (w * s).cos() / w + m * (w * s).sin() / (w * w)
                    };
                    a += cos_int(p.end) - cos_int(p.start);
                    b += sin_int(p.end) - sin_int(p.start);
                }
                (2.0 * a, 2.0 * b)
            })
            .collect()
    }

    /// The Fourier source truncated to `harmonics` (the paper's IHB uses 4).
    pub fn to_fourier(&self, harmonics: usize, phase: f64) -> MeshStiffness {
        let c = self.fourier(harmonics);
        let cos: Vec<f64> = c.iter().map(|x| x.0).collect();
        let sin: Vec<f64> = c.iter().map(|x| x.1).collect();
        MeshStiffness::fourier(self.mean(), &cos, &sin, phase)
    }

    /// Largest number of Hertz fixed-point iterations over the samples.
    pub fn max_iterations(&self) -> usize {
        self.knots().map(|k| k.iterations).max().unwrap_or(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::geometry::spec::parse_gears_file;

    fn curve(etc: bool) -> StiffnessCurve {
        let text = include_str!("../../../fmu/geometry_pair/gears.toml");
        let spec = parse_gears_file(text, "t").unwrap();
        let model = MeshModel::new(&spec, "").unwrap();
        // A high torque makes the ETC zones wide enough to matter for the coefficients.
        model
            .curve(CurveOptions {
                torque: 1500.0,
                etc,
            })
            .unwrap()
    }

    #[test]
    fn pieces_tile_one_period_and_fourier_matches_quadrature() {
        for etc in [false, true] {
            let c = curve(etc);
            let pieces = c.pieces();
            assert_eq!(pieces[0].start, 0.0);
            assert_eq!(pieces.last().unwrap().end, 1.0);
            for w in pieces.windows(2) {
                assert!((w[0].end - w[1].start).abs() < 1e-15);
            }
            // Coefficients by the midpoint rule on the evaluated source (an independent path
            // through `MeshStiffness::value`), 2e5 points.
            let k = c.to_table(0.0);
            let n = 200_000;
            for (h, &(a, b)) in c.fourier(6).iter().enumerate() {
                let w = TAU * (h + 1) as f64;
                let (mut qa, mut qb) = (0.0, 0.0);
                for i in 0..n {
                    let s = (i as f64 + 0.5) / n as f64;
                    let v = k.value(s);
                    qa += v * (w * s).cos();
                    qb += v * (w * s).sin();
                }
                let (qa, qb) = (2.0 * qa / n as f64, 2.0 * qb / n as f64);
                let scale = c.mean();
                assert!(
                    (a - qa).abs() < 1e-6 * scale,
                    "etc {etc}, h {}: {a} vs {qa}",
                    h + 1
                );
                assert!(
                    (b - qb).abs() < 1e-6 * scale,
                    "etc {etc}, h {}: {b} vs {qb}",
                    h + 1
                );
            }
            // ETC makes the knots continuous at the zone bounds; without it they jump.
            let jump = (c.low.last().unwrap().stiffness - c.high[0].stiffness).abs();
            if etc {
                assert!(jump < 1e-9 * c.mean());
            } else {
                assert!(jump > 0.1 * c.mean());
            }
        }
    }
}
