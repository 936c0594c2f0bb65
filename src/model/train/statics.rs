//! Statics: the loaded static transmission error of a tooth-pair mesh by active-set iteration
//! (Liu 2007 eq. 2.8; notes §1.6 [R]) and the static equilibrium of the whole train.

use nalgebra::DVector;

use super::assembly::{generalized_eigen, Assembly};
use super::mesh::CycleTable;

/// An affine piece `v(s) = v0 + slope·(s − start)` on `[start, end)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinPiece {
    pub start: f64,
    pub end: f64,
    pub v0: f64,
    pub slope: f64,
}

impl LinPiece {
    pub fn value(&self, s: f64) -> f64 {
        self.v0 + self.slope * (s - self.start)
    }
}

/// A piecewise-affine function of the cycle coordinate `s ∈ [0, 1)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Ste {
    pub pieces: Vec<LinPiece>,
}

impl Ste {
    pub fn value(&self, s: f64) -> f64 {
        let j = self
            .pieces
            .partition_point(|p| p.start <= s)
            .saturating_sub(1);
        self.pieces[j].value(s)
    }

    /// Mean over the cycle (exact).
    pub fn mean(&self) -> f64 {
        self.pieces
            .iter()
            .map(|p| {
                let w = p.end - p.start;
                w * (p.v0 + 0.5 * p.slope * w)
            })
            .sum()
    }

    /// Peak-to-peak over the cycle (exact: extremes of affine pieces are at their ends).
    pub fn peak_to_peak(&self) -> f64 {
        let (lo, hi) = self
            .pieces
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |acc, p| {
                let (a, b) = (p.v0, p.value(p.end));
                (acc.0.min(a).min(b), acc.1.max(a).max(b))
            });
        hi - lo
    }
}

/// Sub-pieces per interval when a pair stiffness varies inside it (the STE is then rational
/// in `s` and is represented by its chords).
const CHORDS: usize = 32;

/// The loaded STE `δ̃(s)` of a tooth-pair mesh under the static mesh force `force` (N); with
/// `force = 0` the no-load TE (NLTE), which is the minimum of the engaged pairs' gaps.
///
/// Eq. (2.8): `δ̃ = (F + Σ_p h_p g_p k_p) / Σ_p h_p k_p` with the pairs in contact (`h_p = 1`)
/// those with `g_p < δ̃`. Active set (notes §1.6 [R]): start with every engaged pair, drop
/// the pairs whose gap exceeds `δ̃`, repeat. On an interval where the pair stiffnesses are
/// constant and the gaps affine, `δ̃` is affine between the points where a gap crosses it;
/// those points are found exactly, so the result is exact.
pub fn loaded_ste(table: &CycleTable, force: f64) -> Ste {
    let mut pieces = Vec::new();
    for iv in &table.intervals {
        let w = iv.end - iv.start;
        let constant = iv.laws.iter().flatten().all(|l| l.k1 == 0.0);
        if !constant {
            for c in 0..CHORDS {
                let (a, b) = (
                    c as f64 * w / CHORDS as f64,
                    (c + 1) as f64 * w / CHORDS as f64,
                );
                let va = ste_at(iv, a, force);
                let vb = ste_at(iv, b, force);
                pieces.push(LinPiece {
                    start: iv.start + a,
                    end: iv.start + b,
                    v0: va,
                    slope: (vb - va) / (b - a),
                });
            }
            continue;
        }
        let mut r = 0.0;
        for _ in 0..(4 * iv.laws.len() + 8) {
            if r >= w {
                break;
            }
            let probe = r + (1e-9 * w).min(0.5 * (w - r));
            let active = active_set(iv, probe, force);
            let (ksum, kg0, kg1) = active.iter().fold((0.0, 0.0, 0.0), |acc, &j| {
                let l = iv.laws[j].expect("active slots are engaged");
                (acc.0 + l.k0, acc.1 + l.k0 * l.g0, acc.2 + l.k0 * l.g1)
            });
            // δ(r) = d0 + d1 r on this stretch.
            let (d0, d1) = ((force + kg0) / ksum, kg1 / ksum);
            let mut next = w;
            for (j, law) in iv.laws.iter().enumerate() {
                let Some(l) = law else { continue };
                if l.k0 <= 0.0 || l.g1 == d1 {
                    continue;
                }
                let cross = (d0 - l.g0) / (l.g1 - d1);
                let leaves = active.contains(&j) && l.g1 > d1;
                let joins = !active.contains(&j) && l.g1 < d1;
                if (leaves || joins) && cross > r + 1e-14 && cross < next {
                    next = cross;
                }
            }
            pieces.push(LinPiece {
                start: iv.start + r,
                end: iv.start + next,
                v0: d0 + d1 * r,
                slope: d1,
            });
            r = next;
        }
    }
    Ste { pieces }
}

/// The pairs in contact at `r` by the active-set iteration.
fn active_set(iv: &super::mesh::Interval, r: f64, force: f64) -> Vec<usize> {
    let mut active: Vec<usize> = iv
        .laws
        .iter()
        .enumerate()
        .filter(|(_, l)| l.is_some_and(|l| l.k(r) > 0.0))
        .map(|(j, _)| j)
        .collect();
    loop {
        let (ks, kg) = active.iter().fold((0.0, 0.0), |acc, &j| {
            let l = iv.laws[j].unwrap();
            (acc.0 + l.k(r), acc.1 + l.k(r) * l.g(r))
        });
        let delta = (force + kg) / ks;
        let keep: Vec<usize> = active
            .iter()
            .copied()
            .filter(|&j| iv.laws[j].unwrap().g(r) <= delta)
            .collect();
        if keep.is_empty() {
            // Only at zero load with rounding: the pair with the smallest gap carries it.
            let best = *active
                .iter()
                .min_by(|&&a, &&b| {
                    iv.laws[a]
                        .unwrap()
                        .g(r)
                        .total_cmp(&iv.laws[b].unwrap().g(r))
                })
                .expect("an engaged pair exists");
            return vec![best];
        }
        if keep.len() == active.len() {
            return active;
        }
        active = keep;
    }
}

fn ste_at(iv: &super::mesh::Interval, r: f64, force: f64) -> f64 {
    let active = active_set(iv, r, force);
    let (ks, kg) = active.iter().fold((0.0, 0.0), |acc, &j| {
        let l = iv.laws[j].unwrap();
        (acc.0 + l.k(r), acc.1 + l.k(r) * l.g(r))
    });
    (force + kg) / ks
}

/// Static equilibrium of the mean system.
#[derive(Debug, Clone)]
pub struct Statics {
    /// Physical displacements (rigid-body part removed).
    pub q: DVector<f64>,
    /// Static mesh force `k̄_n S_n`, N.
    pub mesh_force: Vec<f64>,
    /// Mean mesh deflection `S_n`, m.
    pub deflection: Vec<f64>,
    /// Rotational part (DTE), m.
    pub dte: Vec<f64>,
}

/// Solves `K̄ q = F_T` for the mean system, with the ground couplings included or not.
///
/// Without them (`include_ground = false`) the external torques are reacted through the
/// meshes alone, as in Liu 2007 eq. (2.8), where the static mesh force is `F = T_1/r_1`
/// (notes §1.10: 2205.07 N): the couplings `k_s` are vibratory and carry no mean torque. The
/// rigid-body component of `F_T` must vanish (balanced torques); otherwise there is no static
/// state and the message says by how much the torques are out of balance.
pub fn equilibrium(
    asm: &Assembly,
    t_in: f64,
    t_load: f64,
    include_ground: bool,
) -> Result<Statics, String> {
    let mut k = asm.mean_stiffness_matrix();
    if !include_ground {
        k -= &asm.k_ground;
    }
    // The planets' pin errors preload their bearings (docs/planetary.md eq. P8).
    let f = asm.load(t_in, t_load) + &asm.pin_load;
    let (values, vectors) = generalized_eigen(&k, &asm.mass);
    let top = values.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
    let n = asm.dim();
    let mut q = DVector::zeros(n);
    let fnorm = f.norm();
    for (i, value) in values.iter().enumerate() {
        let phi = vectors.column(i);
        let modal_force = phi.dot(&f);
        if value.abs() <= 1e-10 * top {
            if modal_force.abs() > 1e-9 * fnorm * phi.norm() {
                return Err(format!(
                    "no static equilibrium: the torques (input {t_in} N·m, load {t_load} N·m) are \
                     not balanced, the train accelerates as a rigid body"
                ));
            }
            continue;
        }
        q += phi * (modal_force / value);
    }
    let deflection: Vec<f64> = asm.mesh.iter().map(|d| d.dot(&q)).collect();
    Ok(Statics {
        mesh_force: deflection
            .iter()
            .zip(&asm.mean_stiffness)
            .map(|(s, k)| s * k)
            .collect(),
        dte: asm.dte.iter().map(|d| d.dot(&q)).collect(),
        deflection,
        q,
    })
}
