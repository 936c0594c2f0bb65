//! Rust peer of the work-precision benchmark: the single-mesh gear pair of `docs/model.md`,
//! integrated with the `differential-equations` crate (0.7.0: `ExplicitRungeKutta::dop853` and
//! `dopri5`, `IVP::…​.event(…)` with Brent root finding on the crate's dense output).
//!
//! Written from `docs/model.md` only (it reads the scene TOML itself; nothing of geardyn is
//! used), the way a careful user of the crate would set the problem up:
//! * the time axis is cut at every stiffness breakpoint (the rectangular jumps, the trapezoid's
//!   corners), and inside a segment the stiffness piece is frozen (its linear formula, never
//!   `frac`), so no stage sees the next piece;
//! * the contact state is frozen between events; the crate's terminal event on the guard of
//!   the current state stops the solve, the state is put on the switching surface and a new
//!   solve starts (numerics-notes §2.1);
//! * the output grid is taken from the crate's dense output (a solout), not by stopping.
//!
//! Usage: `geardyn-peer-bench DIR [--quick]`, DIR written by `cargo bench --bench workprecision
//! -- --write-problems DIR` (problems.csv + scenes/*.toml); writes DIR/peer.csv in the row
//! format of `scripts/workprecision_scipy.py`. `PEER_ONLY=NAME` runs one problem only.

use std::f64::consts::TAU;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use differential_equations::interpolate::Interpolation;
use differential_equations::prelude::*;
use differential_equations::solout::EventWrappedSolout;

// ---------------------------------------------------------------- model (docs/model.md)

#[derive(Debug, Clone, Copy)]
enum Law {
    Linear,
    ContactLoss,
    /// Total clearance 2b, m.
    Backlash(f64),
}

/// Linear piece `k = k0 + slope·(s − start)` on `s ∈ [start, end)` of the shifted phase.
#[derive(Debug, Clone, Copy)]
struct Piece {
    start: f64,
    end: f64,
    k0: f64,
    slope: f64,
}

#[derive(Debug, Clone)]
enum Stiffness {
    Pieces {
        phase: f64,
        pieces: Vec<Piece>,
    },
    Fourier {
        phase: f64,
        mean: f64,
        coef: Vec<(f64, f64)>,
    },
}

#[derive(Debug, Clone)]
struct Pair {
    m_e: f64,
    f_ext: f64,
    /// Mesh frequency z1 Ω / 2π, Hz.
    f_m: f64,
    p0: f64,
    stiffness: Stiffness,
    /// STE harmonics (c_h, s_h), m.
    ste: Vec<(f64, f64)>,
    damping: f64,
    law: Law,
    x0: f64,
    v0: f64,
}

fn num(v: &toml::Value, path: &str) -> Result<f64, String> {
    let mut cur = v;
    for key in path.split('.') {
        cur = cur.get(key).ok_or_else(|| format!("missing {path}"))?;
    }
    cur.as_float()
        .or_else(|| cur.as_integer().map(|i| i as f64))
        .ok_or_else(|| format!("{path} is not a number"))
}

fn opt_num(v: &toml::Value, path: &str) -> Option<f64> {
    num(v, path).ok()
}

fn list(v: Option<&toml::Value>) -> Vec<f64> {
    v.and_then(|l| l.as_array())
        .map(|a| {
            a.iter()
                .map(|x| {
                    x.as_float()
                        .unwrap_or_else(|| x.as_integer().unwrap_or(0) as f64)
                })
                .collect()
        })
        .unwrap_or_default()
}

/// The pieces of a `table` stiffness (docs/model.md, "Mesh stiffness": linear between the knots
/// `s_0 < … < s_{n−1}` in `[0, 1)`, periodic, the last knot joined to `s_0 + 1`) and its exact
/// mean (the trapezoid rule is exact for a piecewise-linear curve).
fn table_pieces(s: &[f64], k: &[f64]) -> Result<(Vec<Piece>, f64), String> {
    let n = s.len();
    if n < 2 || k.len() != n {
        return Err("table stiffness needs n ≥ 2 phase_points and as many values".into());
    }
    if s[0] < 0.0 || s[n - 1] >= 1.0 || s.windows(2).any(|w| w[0] >= w[1]) {
        return Err("table phase_points must increase strictly in [0, 1)".into());
    }
    let line = |a: f64, b: f64, ka: f64, kb: f64| Piece {
        start: a,
        end: b,
        k0: ka,
        slope: (kb - ka) / (b - a),
    };
    // The wrap segment [s_{n−1}, s_0 + 1], cut at s = 1.
    let wrap_slope = (k[0] - k[n - 1]) / (s[0] + 1.0 - s[n - 1]);
    let k_at_one = k[n - 1] + wrap_slope * (1.0 - s[n - 1]);
    let mut pieces = Vec::with_capacity(n + 1);
    if s[0] > 0.0 {
        pieces.push(line(0.0, s[0], k_at_one, k[0]));
    }
    for i in 0..n - 1 {
        pieces.push(line(s[i], s[i + 1], k[i], k[i + 1]));
    }
    pieces.push(Piece {
        start: s[n - 1],
        end: 1.0,
        k0: k[n - 1],
        slope: wrap_slope,
    });
    let mean = (0..n)
        .map(|i| {
            let (b, kb) = if i + 1 < n {
                (s[i + 1], k[i + 1])
            } else {
                (s[0] + 1.0, k[0])
            };
            0.5 * (k[i] + kb) * (b - s[i])
        })
        .sum();
    Ok((pieces, mean))
}

fn harmonics(cos: &[f64], sin: &[f64]) -> Vec<(f64, f64)> {
    (0..cos.len().max(sin.len()))
        .map(|i| {
            (
                cos.get(i).copied().unwrap_or(0.0),
                sin.get(i).copied().unwrap_or(0.0),
            )
        })
        .collect()
}

impl Pair {
    /// Reads the subset of the scene format the benchmark problems use; anything else is an
    /// error (so the peer never silently integrates a different model).
    fn from_toml(text: &str) -> Result<Pair, String> {
        let doc: toml::Value = toml::from_str(text).map_err(|e| e.to_string())?;
        let gears = doc
            .get("gear")
            .and_then(|g| g.as_array())
            .ok_or("no [[gear]]")?;
        if gears.len() != 2 {
            return Err("the peer models a single mesh (two gears)".into());
        }
        let (g1, g2) = (&gears[0], &gears[1]);
        let (z1, r1, i1) = (
            num(g1, "teeth")?,
            num(g1, "base_radius")?,
            num(g1, "inertia")?,
        );
        let (r2, i2) = (num(g2, "base_radius")?, num(g2, "inertia")?);
        let mesh = doc.get("mesh").ok_or("no [mesh]")?;
        for key in mesh.as_table().ok_or("[mesh] is not a table")?.keys() {
            if ![
                "pinion",
                "gear",
                "contact",
                "backlash",
                "damping",
                "damping_ratio",
                "stiffness",
                "ste",
                "initial_phase",
            ]
            .contains(&key.as_str())
            {
                return Err(format!("mesh.{key} is not supported by the peer"));
            }
        }
        let t1 = num(&doc, "operating.input_torque")?;
        let omega = num(&doc, "operating.pinion_speed")?;
        let t2 = opt_num(&doc, "operating.load_torque").unwrap_or(t1 * r2 / r1);
        // m_e x'' + F = F_ext (docs/model.md, "Coordinates and sign convention").
        let m_e = 1.0 / (r1 * r1 / i1 + r2 * r2 / i2);
        let f_ext = m_e * (r1 * t1 / i1 + r2 * t2 / i2);
        let st = mesh.get("stiffness").ok_or("no [mesh.stiffness]")?;
        let kind = st
            .get("kind")
            .and_then(|k| k.as_str())
            .ok_or("no stiffness kind")?;
        let phase = opt_num(st, "phase").unwrap_or(0.0);
        // A table's mean is that of its piecewise-linear curve; the other kinds state it.
        let (table, mean) = if kind == "table" {
            let (pieces, mean) =
                table_pieces(&list(st.get("phase_points")), &list(st.get("values")))?;
            (Some(Stiffness::Pieces { phase, pieces }), mean)
        } else {
            (None, num(st, "mean")?)
        };
        let stiffness = match kind {
            "table" => table.expect("built above for a table"),
            "rectangular" | "trapezoidal" => {
                let eps = num(st, "peak_to_peak_ratio")?;
                let c = num(st, "contact_ratio")?;
                let f = c - c.floor();
                let low = mean * (1.0 - f * eps);
                let high = low + eps * mean;
                let flat = |start, end, k0| Piece {
                    start,
                    end,
                    k0,
                    slope: 0.0,
                };
                let pieces = if kind == "rectangular" {
                    vec![flat(0.0, 1.0 - f, low), flat(1.0 - f, 1.0, high)]
                } else {
                    // Ramps of width w centred on the switches at s = 0 and s = 1 − f.
                    let w = num(st, "transition")?;
                    let mid = 0.5 * (low + high);
                    let rise = 1.0 - f;
                    vec![
                        Piece {
                            start: 0.0,
                            end: 0.5 * w,
                            k0: mid,
                            slope: (low - high) / w,
                        },
                        flat(0.5 * w, rise - 0.5 * w, low),
                        Piece {
                            start: rise - 0.5 * w,
                            end: rise + 0.5 * w,
                            k0: low,
                            slope: (high - low) / w,
                        },
                        flat(rise + 0.5 * w, 1.0 - 0.5 * w, high),
                        Piece {
                            start: 1.0 - 0.5 * w,
                            end: 1.0,
                            k0: high,
                            slope: (low - high) / w,
                        },
                    ]
                };
                Stiffness::Pieces { phase, pieces }
            }
            "fourier" => Stiffness::Fourier {
                phase,
                mean,
                coef: harmonics(&list(st.get("cos")), &list(st.get("sin"))),
            },
            other => {
                return Err(format!(
                    "stiffness kind {other} is not supported by the peer"
                ))
            }
        };
        let law = match mesh
            .get("contact")
            .and_then(|c| c.as_str())
            .unwrap_or("linear")
        {
            "linear" => Law::Linear,
            "contact_loss" => Law::ContactLoss,
            "backlash" => Law::Backlash(num(mesh, "backlash")?),
            other => return Err(format!("contact {other} is not supported by the peer")),
        };
        let damping = match (opt_num(mesh, "damping"), opt_num(mesh, "damping_ratio")) {
            (Some(c), None) => c,
            (None, Some(zeta)) => 2.0 * zeta * (mean * m_e).sqrt(),
            _ => return Err("give mesh.damping or mesh.damping_ratio".into()),
        };
        let ste = mesh
            .get("ste")
            .map(|s| harmonics(&list(s.get("cos")), &list(s.get("sin"))))
            .unwrap_or_default();
        let p0 = opt_num(mesh, "initial_phase").unwrap_or(0.0);
        if doc.get("initial").is_some() {
            return Err("[initial] is not supported by the peer (static start only)".into());
        }
        let mut pair = Pair {
            m_e,
            f_ext,
            f_m: z1 * omega / TAU,
            p0,
            stiffness,
            ste,
            damping,
            law,
            x0: 0.0,
            v0: 0.0,
        };
        // Initial DTE "static": F_ext / k̄ + e(p0), at rest.
        pair.x0 = f_ext / mean + pair.ste_at(p0).0;
        Ok(pair)
    }

    fn phase(&self, t: f64) -> f64 {
        self.p0 + self.f_m * t
    }

    /// `(e, ė)` at mesh phase `p`.
    fn ste_at(&self, p: f64) -> (f64, f64) {
        let (mut e, mut de) = (0.0, 0.0);
        for (h, &(c, s)) in self.ste.iter().enumerate() {
            let w = TAU * (h + 1) as f64;
            let (sn, cs) = (w * p).sin_cos();
            e += c * cs + s * sn;
            de += w * (s * cs - c * sn);
        }
        (e, de * self.f_m)
    }

    /// Breakpoint times in (0, t_end): where the shifted phase crosses a piece start.
    fn segments(&self, t_end: f64) -> Vec<(f64, f64)> {
        let mut cuts = vec![0.0];
        if let Stiffness::Pieces { phase, pieces } = &self.stiffness {
            let q0 = self.p0 + phase;
            let q1 = q0 + self.f_m * t_end;
            for n in (q0.floor() as i64)..=(q1.ceil() as i64) {
                for piece in pieces {
                    let t = (n as f64 + piece.start - q0) / self.f_m;
                    if t > 0.0 && t < t_end {
                        cuts.push(t);
                    }
                }
            }
        }
        cuts.sort_by(|a, b| a.partial_cmp(b).unwrap());
        cuts.dedup();
        cuts.push(t_end);
        cuts.windows(2).map(|w| (w[0], w[1])).collect()
    }

    /// The stiffness of segment `(ta, tb)` as a frozen function of time.
    fn frozen_stiffness(&self, ta: f64, tb: f64) -> FrozenK {
        match &self.stiffness {
            Stiffness::Pieces { phase, pieces } => {
                let q_mid = self.p0 + phase + self.f_m * 0.5 * (ta + tb);
                let cycle = q_mid.floor();
                let s_mid = q_mid - cycle;
                let piece = *pieces
                    .iter()
                    .find(|p| s_mid >= p.start && s_mid < p.end)
                    .unwrap_or(&pieces[pieces.len() - 1]);
                FrozenK::Piece {
                    piece,
                    offset: self.p0 + phase - cycle,
                }
            }
            Stiffness::Fourier { phase, mean, coef } => FrozenK::Fourier {
                offset: self.p0 + phase,
                mean: *mean,
                coef: coef.clone(),
            },
        }
    }

    fn classify(&self, x: f64, p: f64) -> i8 {
        let delta = x - self.ste_at(p).0;
        match self.law {
            Law::Linear => 1,
            Law::ContactLoss => i8::from(delta > 0.0),
            Law::Backlash(two_b) => {
                if delta > 0.0 {
                    1
                } else if delta >= -two_b {
                    0
                } else {
                    -1
                }
            }
        }
    }
}

enum FrozenK {
    /// `k = k0 + slope·(offset + f_m t − start)`.
    Piece { piece: Piece, offset: f64 },
    Fourier {
        offset: f64,
        mean: f64,
        coef: Vec<(f64, f64)>,
    },
}

impl FrozenK {
    fn at(&self, f_m: f64, t: f64) -> f64 {
        match self {
            FrozenK::Piece { piece, offset } => {
                piece.k0 + piece.slope * (offset + f_m * t - piece.start)
            }
            FrozenK::Fourier { offset, mean, coef } => {
                let s = offset + f_m * t;
                let mut k = *mean;
                for (h, &(a, b)) in coef.iter().enumerate() {
                    let (sn, cs) = (TAU * (h + 1) as f64 * s).sin_cos();
                    k += a * cs + b * sn;
                }
                k
            }
        }
    }
}

/// The right-hand side of one segment in one contact state.
struct SegmentOde<'a> {
    pair: &'a Pair,
    k: FrozenK,
    state: i8,
}

impl ODE<f64, [f64; 2]> for SegmentOde<'_> {
    fn diff(&self, t: f64, y: &[f64; 2], dydt: &mut [f64; 2]) {
        let pair = self.pair;
        let force = if self.state == 0 {
            0.0
        } else {
            let (e, de) = pair.ste_at(pair.phase(t));
            let delta = y[0] - e;
            let k = self.k.at(pair.f_m, t);
            let spring = match (self.state, pair.law) {
                (-1, Law::Backlash(two_b)) => k * (delta + two_b),
                _ => k * delta,
            };
            spring + pair.damping * (y[1] - de)
        };
        dydt[0] = y[1];
        dydt[1] = (pair.f_ext - force) / pair.m_e;
    }
}

/// Guard of the current contact state: ≥ 0 while the state holds, crossing zero downwards at
/// the surface being left (for the separated state of a backlash mesh, `min(−δ, δ + 2b)`).
///
/// After a contact change the solve starts on the surface just crossed, where the guard is 0.
/// The crate's Brent iteration, given a bracket whose left end is (almost) a root, converges
/// to points near that end that are not roots (seen on the smooth-stiffness problem, where a
/// whole free flight fits in one step: 170 contact changes instead of 54). So a solve that
/// starts from a snapped state uses the deflated guard `g(t)/(t − t0)`, which has the same
/// roots for `t > t0` and no root at `t0` (it tends to the guard's rate there, positive since
/// the motion enters the state).
struct Guard<'a> {
    pair: &'a Pair,
    state: i8,
    t0: f64,
    snapped: bool,
}

impl Guard<'_> {
    fn value(&self, t: f64, x: f64) -> f64 {
        let delta = x - self.pair.ste_at(self.pair.phase(t)).0;
        match (self.pair.law, self.state) {
            (Law::Linear, _) => 1.0,
            (_, 1) => delta,
            (Law::ContactLoss, _) => -delta,
            (Law::Backlash(two_b), 0) => (-delta).min(delta + two_b),
            (Law::Backlash(two_b), _) => -(delta + two_b),
        }
    }
}

impl Event<f64, [f64; 2]> for Guard<'_> {
    fn config(&self) -> EventConfig {
        EventConfig::default()
            .direction(CrossingDirection::Negative)
            .terminal()
    }

    fn event(&self, t: f64, y: &[f64; 2]) -> f64 {
        let g = self.value(t, y[0]);
        if !self.snapped {
            g
        } else if t > self.t0 {
            g / (t - self.t0)
        } else {
            1.0 // inside: the deflated guard's sign at the restart
        }
    }
}

/// Output strategy: the grid points inside each step from the dense output, then the step end
/// itself (so the state at the end of a solve is always the last point).
struct GridSolout<'g> {
    grid: &'g [f64],
    next: usize,
}

impl Solout<f64, [f64; 2]> for GridSolout<'_> {
    fn solout<I>(
        &mut self,
        t_curr: f64,
        t_prev: f64,
        y_curr: &[f64; 2],
        _y_prev: &[f64; 2],
        interpolator: &mut I,
        solution: &mut Solution<f64, [f64; 2]>,
    ) -> ControlFlag<f64, [f64; 2]>
    where
        I: Interpolation<f64, [f64; 2]> + ?Sized,
    {
        while self.next < self.grid.len() && self.grid[self.next] <= t_curr {
            let tg = self.grid[self.next];
            if tg >= t_prev {
                // At the step end (and at the start call, where t_prev == t_curr) the state
                // itself; inside the step the dense output.
                let y = if tg == t_curr {
                    *y_curr
                } else {
                    interpolator
                        .interpolate(tg)
                        .expect("grid point inside the step")
                };
                solution.push(tg, y);
            }
            self.next += 1;
        }
        if solution.t.last() != Some(&t_curr) {
            solution.push(t_curr, *y_curr);
        }
        ControlFlag::Continue
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum PeerMethod {
    Dop853,
    Dopri5,
}

/// How contact changes are located on the crate's dense output.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum EventMode {
    /// The crate's own `IVP::event` (`EventWrappedSolout`, Brent–Dekker).
    Crate,
    /// The crate's sign-change test per step, then a bracketing Illinois iteration on the
    /// crate's interpolant (`RefinedEventSolout`): what a user does after finding that the
    /// crate's Brent–Dekker loses its bracket (see `RefinedEventSolout`).
    Refined,
}

fn label(method: PeerMethod, mode: EventMode) -> &'static str {
    match (method, mode) {
        (PeerMethod::Dop853, EventMode::Refined) => "differential-equations DOP853",
        (PeerMethod::Dopri5, EventMode::Refined) => "differential-equations DOPRI5",
        (PeerMethod::Dop853, EventMode::Crate) => "differential-equations DOP853 (crate events)",
        (PeerMethod::Dopri5, EventMode::Crate) => "differential-equations DOPRI5 (crate events)",
    }
}

/// One `solve` of the crate from `(t0, y0)` to `tb` with the given output strategy.
#[allow(clippy::too_many_arguments)]
fn solve_with<O: Solout<f64, [f64; 2]>>(
    ode: &SegmentOde,
    t0: f64,
    tb: f64,
    y0: [f64; 2],
    solout: O,
    method: PeerMethod,
    rtol: f64,
    atol: f64,
) -> Result<Solution<f64, [f64; 2]>, String> {
    let ivp = IVP::ode(ode, t0, tb, y0).solout(solout);
    match method {
        PeerMethod::Dop853 => ivp
            .method(
                ExplicitRungeKutta::dop853()
                    .rtol(rtol)
                    .atol(atol)
                    .max_steps(10_000_000),
            )
            .solve(),
        PeerMethod::Dopri5 => ivp
            .method(
                ExplicitRungeKutta::dopri5()
                    .rtol(rtol)
                    .atol(atol)
                    .max_steps(10_000_000),
            )
            .solve(),
    }
    .map_err(|e| format!("{e:?}").replace([',', '\n'], ";"))
}

/// Grid output plus event location with a bracket that is kept: on a sign change of the guard
/// over a step (`g > 0` → `g ≤ 0`), the Illinois variant of regula falsi (Dowell & Jarratt
/// 1971) on `g(t, interpolant(t))` down to a few ulps of `t`, then the event point is pushed
/// last and the solve terminates (the same contract as the crate's terminal events).
///
/// Why not the crate's `EventWrappedSolout`: its Brent–Dekker iteration (0.7.0,
/// `src/solout/event.rs`) sets the contrapoint `c` to the previous iterate after every step, so
/// once two iterates fall on the same side of the root the bracket is lost and the iteration
/// "converges" on a point that is no root (seen here: guard values of 1e-10…1e-6 m at the
/// reported event, event times off by up to 1e-5 s at every tolerance).
struct RefinedEventSolout<'a, 'g> {
    grid: GridSolout<'g>,
    guard: &'a Guard<'a>,
    last_g: Option<f64>,
}

impl Solout<f64, [f64; 2]> for RefinedEventSolout<'_, '_> {
    fn solout<I>(
        &mut self,
        t_curr: f64,
        t_prev: f64,
        y_curr: &[f64; 2],
        y_prev: &[f64; 2],
        interpolator: &mut I,
        solution: &mut Solution<f64, [f64; 2]>,
    ) -> ControlFlag<f64, [f64; 2]>
    where
        I: Interpolation<f64, [f64; 2]> + ?Sized,
    {
        let g_curr = self.guard.event(t_curr, y_curr);
        let Some(g_prev) = self.last_g.replace(g_curr) else {
            // The call at the start of the solve (t_prev == t_curr).
            return self
                .grid
                .solout(t_curr, t_prev, y_curr, y_prev, interpolator, solution);
        };
        if !(g_prev > 0.0 && g_curr <= 0.0) {
            return self
                .grid
                .solout(t_curr, t_prev, y_curr, y_prev, interpolator, solution);
        }
        let mut g_at = |t: f64| {
            let y = interpolator.interpolate(t).expect("inside the step");
            (self.guard.event(t, &y), y)
        };
        let (mut a, mut fa, mut b, mut fb) = (t_prev, g_prev, t_curr, g_curr);
        let mut side = 0i8;
        for _ in 0..200 {
            if b - a <= 4.0 * f64::EPSILON * b.abs() {
                break;
            }
            let mut t = (a * fb - b * fa) / (fb - fa);
            if !(t > a && t < b) {
                t = 0.5 * (a + b);
            }
            let (ft, _) = g_at(t);
            if ft > 0.0 {
                a = t;
                fa = ft;
                if side == 1 {
                    fb *= 0.5;
                }
                side = 1;
            } else {
                b = t;
                fb = ft;
                if side == -1 {
                    fa *= 0.5;
                }
                side = -1;
            }
        }
        // The first point at or past the crossing, as the crate's terminal event reports.
        let (_, y_event) = g_at(b);
        let _ = self
            .grid
            .solout(b, t_prev, &y_event, y_prev, interpolator, solution);
        if solution.t.last() != Some(&b) {
            solution.push(b, y_event);
        }
        ControlFlag::Terminate
    }
}

#[derive(Debug, Default)]
struct Run {
    dte: Vec<f64>,
    final_state: [f64; 2],
    events: Vec<f64>,
    rhs: usize,
    steps: usize,
    rejected: usize,
}

fn simulate(
    pair: &Pair,
    t_end: f64,
    grid: &[f64],
    method: PeerMethod,
    mode: EventMode,
    rtol: f64,
    atol: f64,
) -> Result<Run, String> {
    let mut run = Run {
        dte: vec![f64::NAN; grid.len()],
        ..Run::default()
    };
    let mut y = [pair.x0, pair.v0];
    let mut state = pair.classify(y[0], pair.phase(0.0));
    let mut next = 0usize;
    let mut snapped = false;
    for (ta, tb) in pair.segments(t_end) {
        let mut t = ta;
        while t < tb {
            let ode = SegmentOde {
                pair,
                k: pair.frozen_stiffness(ta, tb),
                state,
            };
            let guard = Guard {
                pair,
                state,
                t0: t,
                snapped,
            };
            snapped = false;
            let base = GridSolout {
                grid: &grid[next..],
                next: 0,
            };
            let solution = match mode {
                EventMode::Crate => {
                    let solout = EventWrappedSolout::new(base, &guard, t, tb);
                    solve_with(&ode, t, tb, y, solout, method, rtol, atol)?
                }
                EventMode::Refined => {
                    let solout = RefinedEventSolout {
                        grid: base,
                        guard: &guard,
                        last_g: None,
                    };
                    solve_with(&ode, t, tb, y, solout, method, rtol, atol)?
                }
            };
            run.rhs += solution.evals.function;
            run.steps += solution.steps.accepted;
            run.rejected += solution.steps.rejected;
            let interrupted = matches!(solution.status, Status::Interrupted);
            let (&t_last, &y_last) = (
                solution.t.last().ok_or("empty solution")?,
                solution.y.last().ok_or("empty solution")?,
            );
            // Grid points strictly before the event (the step that crossed may have pushed
            // points beyond it, in the wrong mode), or all of them at the end of the segment.
            let body = solution.t.len() - usize::from(interrupted);
            for (&tt, yy) in solution.t[..body].iter().zip(&solution.y[..body]) {
                if next < grid.len() && tt == grid[next] && (!interrupted || tt < t_last) {
                    run.dte[next] = yy[0];
                    next += 1;
                }
            }
            y = y_last;
            if !interrupted {
                break;
            }
            // Contact change: snap onto the surface being crossed and switch the state.
            let e = pair.ste_at(pair.phase(t_last)).0;
            let delta = y[0] - e;
            let (new_state, surface) = match (pair.law, state) {
                (_, 1) => (0, e),
                (Law::ContactLoss, _) => (1, e),
                (Law::Backlash(two_b), 0) => {
                    if delta > -0.5 * two_b {
                        (1, e)
                    } else {
                        (-1, e - two_b)
                    }
                }
                (Law::Backlash(two_b), _) => (0, e - two_b),
                (Law::Linear, _) => unreachable!("no guard fires for a linear mesh"),
            };
            y[0] = surface;
            state = new_state;
            run.events.push(t_last);
            if run.events.len() > 1_000_000 {
                return Err("more than 1e6 contact events".into());
            }
            t = t_last;
            snapped = true;
        }
    }
    if next < grid.len() {
        // The last grid point is t_end itself: the final state.
        if next == grid.len() - 1 && grid[next] == t_end {
            run.dte[next] = y[0];
        } else {
            return Err(format!("grid point {} not reached", grid[next]));
        }
    }
    run.final_state = y;
    Ok(run)
}

// ---------------------------------------------------------------- harness

struct ProblemRow {
    name: String,
    stop_time: f64,
    samples: usize,
    x_scale: f64,
    ladder: Vec<f64>,
}

fn read_problems(dir: &Path) -> Vec<ProblemRow> {
    let text = std::fs::read_to_string(dir.join("problems.csv")).expect("read problems.csv");
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).expect("column");
    lines
        .filter_map(|line| {
            let f: Vec<&str> = line.split(',').collect();
            (f[col("kind")] == "pair").then(|| ProblemRow {
                name: f[col("problem")].to_string(),
                stop_time: f[col("stop_time")].parse().unwrap(),
                samples: f[col("samples")].parse().unwrap(),
                x_scale: f[col("x_scale")].parse().unwrap(),
                ladder: f[col("ladder")]
                    .split(';')
                    .map(|v| v.parse().unwrap())
                    .collect(),
            })
        })
        .collect()
}

fn join(v: &[f64]) -> String {
    v.iter()
        .map(|x| format!("{x:e}"))
        .collect::<Vec<_>>()
        .join(";")
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let dir = Path::new(
        args.first()
            .expect("usage: geardyn-peer-bench DIR [--quick]"),
    );
    let quick = args.iter().any(|a| a == "--quick");
    // Least timed runs and least total timed wall per configuration (median of N after a warm-up).
    let (min_runs, min_wall) = if quick { (2, 0.02) } else { (5, 0.25) };
    let mut out = String::from(
        "problem,method,tol,rtol,atol,status,wall_s,timed_runs,rhs,steps,rejected,events,final_x,final_v,dte,event_times\n",
    );
    for p in read_problems(dir) {
        if let Ok(only) = std::env::var("PEER_ONLY") {
            if p.name != only {
                continue;
            }
        }
        let text = std::fs::read_to_string(dir.join("scenes").join(format!("{}.toml", p.name)))
            .expect("read scene");
        let pair = Pair::from_toml(&text).unwrap_or_else(|e| panic!("{}: {e}", p.name));
        let grid: Vec<f64> = (0..=p.samples)
            .map(|k| {
                if k == p.samples {
                    p.stop_time
                } else {
                    k as f64 * p.stop_time / p.samples as f64
                }
            })
            .collect();
        let variants = [
            (PeerMethod::Dopri5, EventMode::Refined),
            (PeerMethod::Dop853, EventMode::Refined),
            (PeerMethod::Dopri5, EventMode::Crate),
            (PeerMethod::Dop853, EventMode::Crate),
        ];
        for (method, mode) in variants {
            for &tol in &p.ladder {
                let (rtol, atol) = (tol, tol * p.x_scale);
                // Warm-up run, also the one whose output is compared.
                let first = simulate(&pair, p.stop_time, &grid, method, mode, rtol, atol);
                let line = match first {
                    Err(e) => format!(
                        "{},{},{tol:e},{rtol:e},{atol:e},failed: {e},,,,,,,,,,\n",
                        p.name,
                        label(method, mode)
                    ),
                    Ok(run) => {
                        let (mut times, started) = (Vec::new(), Instant::now());
                        while times.len() < min_runs || started.elapsed().as_secs_f64() < min_wall {
                            let t0 = Instant::now();
                            let r = simulate(&pair, p.stop_time, &grid, method, mode, rtol, atol);
                            times.push(t0.elapsed().as_secs_f64());
                            std::hint::black_box(r).ok();
                            if times[0] > 1.0 {
                                break;
                            }
                        }
                        let runs = times.len();
                        times.sort_by(f64::total_cmp);
                        let median = if runs % 2 == 1 {
                            times[runs / 2]
                        } else {
                            0.5 * (times[runs / 2 - 1] + times[runs / 2])
                        };
                        format!(
                            "{},{},{tol:e},{rtol:e},{atol:e},ok,{median:e},{runs},{},{},{},{},{:e},{:e},{},{}\n",
                            p.name,
                            label(method, mode),
                            run.rhs,
                            run.steps,
                            run.rejected,
                            run.events.len(),
                            run.final_state[0],
                            run.final_state[1],
                            join(&run.dte),
                            join(&run.events)
                        )
                    }
                };
                let mut summary = String::new();
                let _ = write!(
                    summary,
                    "peer {} {} tol {tol:e}",
                    p.name,
                    label(method, mode)
                );
                eprintln!("{summary}");
                out += &line;
            }
        }
    }
    std::fs::write(dir.join("peer.csv"), out).expect("write peer.csv");
}
