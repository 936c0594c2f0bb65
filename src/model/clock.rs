//! The nominal-speed clock: mesh phase as a function of time, and the limits within which
//! phase and time keep the resolution the stiffness segments and the STE need.

/// The largest magnitude, in mesh cycles, of a mesh phase and of a time measured in mesh
/// periods (`|p|`, `|t|·f_m`): 2^32 cycles. An `f64` of that size still carries 20 bits below
/// one (a resolution of 2^-20 ≈ 1e-6 of a mesh cycle, for phase and time alike); beyond it the
/// phase loses the fractional bits the stiffness pieces and the STE harmonics are located by,
/// and at 2^53 ≈ 9.007e15 not even whole cycles advance any more, so a step never reaches its end
/// (issue 17). At the 2.85 kHz mesh frequency of `fmu/spur_pair` the bound is 1.5e6 s (17 days)
/// of simulated time.
pub const MAX_MESH_CYCLES: f64 = 4_294_967_296.0;

/// The largest number of mesh periods one advance of the driver may span (2^20 ≈ 1.05e6):
/// the work of one communication step (FMU) or output interval (`simulate`) grows with it
/// (`fmu/spur_pair` does 1e6 periods in ~0.23 s; a drivetrain costs more per period), so a
/// step of 1e300 s or a pinion speed of 1e11 rad/s is refused at once instead of grinding
/// (issue 17). Documented in `docs/fmu.md`, "Limits of one step".
pub const MAX_MESH_PERIODS_PER_ADVANCE: f64 = 1_048_576.0;

/// `name = value` as a mesh phase (cycles): finite and within [`MAX_MESH_CYCLES`]. The one
/// check of a phase given from outside (FMU parameter, restored FMU state).
pub fn check_phase(name: &str, value: f64) -> Result<(), String> {
    if value.is_finite() && value.abs() <= MAX_MESH_CYCLES {
        Ok(())
    } else {
        Err(format!(
            "{name} = {value:?} cycles: must be finite with magnitude <= 2^32 = {MAX_MESH_CYCLES} \
             (beyond it the phase has lost the resolution the stiffness and STE need)"
        ))
    }
}

/// Mesh phase `p(t) = p0 + f_m (t − t0) + ½ ḟ_m (t − t0)²` (mesh cycles), `f_m = z1 Ω / 2π`
/// at the anchor and `ḟ_m = z1 Ω̇ / 2π` (`docs/model.md`, "Mesh phase"; `docs/runup.md`): the
/// exact integral of a speed that is constant (`ḟ_m = 0`, every scene without a speed profile)
/// or linear in time (one segment of a piecewise-linear speed profile). The clock is
/// re-anchored whenever the nominal speed or its rate changes (an FMU input between
/// communication points, a profile knot), so the phase is continuous and stiffness never
/// depends on raw time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhaseClock {
    t0: f64,
    p0: f64,
    mesh_frequency: f64,
    /// `ḟ_m`, Hz/s: 0 except on a ramp segment of a speed profile.
    rate: f64,
}

impl PhaseClock {
    pub fn new(t0: f64, p0: f64, mesh_frequency: f64) -> Self {
        PhaseClock {
            t0,
            p0,
            mesh_frequency,
            rate: 0.0,
        }
    }

    /// Mesh phase at time `t`. The constant-speed branch is the historical expression, so
    /// scenes without a speed profile keep their results bit for bit.
    pub fn phase_at(&self, t: f64) -> f64 {
        if self.rate == 0.0 {
            self.p0 + self.mesh_frequency * (t - self.t0)
        } else {
            let d = t - self.t0;
            self.p0 + d * (self.mesh_frequency + 0.5 * self.rate * d)
        }
    }

    /// [`PhaseClock::phase_at`] of a clock known to run at constant speed (`ḟ_m = 0`): the
    /// constant-speed kernels of the single pair call it, so their hot path is the
    /// historical expression without the test of the rate.
    #[inline(always)]
    pub fn phase_at_constant_speed(&self, t: f64) -> f64 {
        debug_assert!(self.rate == 0.0);
        self.p0 + self.mesh_frequency * (t - self.t0)
    }

    /// `(phase_at(t), frequency_at(t))` with one test of the rate.
    #[inline(always)]
    pub fn phase_and_frequency(&self, t: f64) -> (f64, f64) {
        if self.rate == 0.0 {
            (
                self.p0 + self.mesh_frequency * (t - self.t0),
                self.mesh_frequency,
            )
        } else {
            let d = t - self.t0;
            (
                self.p0 + d * (self.mesh_frequency + 0.5 * self.rate * d),
                self.mesh_frequency + self.rate * d,
            )
        }
    }

    /// Instantaneous mesh frequency `dp/dt` at `t`, Hz (the anchor's on a constant speed).
    pub fn frequency_at(&self, t: f64) -> f64 {
        if self.rate == 0.0 {
            self.mesh_frequency
        } else {
            self.mesh_frequency + self.rate * (t - self.t0)
        }
    }

    /// `ḟ_m`, Hz/s.
    pub fn rate(&self) -> f64 {
        self.rate
    }

    /// The anchor `(t0, p0)`: with [`PhaseClock::new`] it rebuilds this clock bit for bit
    /// (FMU state snapshots; re-deriving the anchor would change rounding).
    pub fn anchor(&self) -> (f64, f64) {
        (self.t0, self.p0)
    }

    /// Mesh frequency f_m at the anchor, Hz (the mesh frequency of a constant speed; on a ramp
    /// see [`PhaseClock::frequency_at`]).
    pub fn mesh_frequency(&self) -> f64 {
        self.mesh_frequency
    }

    /// The time at which the phase reaches `p` (`+inf` when the clock stands still or, on a
    /// decelerating ramp, stops before `p`; whether `p` lies in the past of a forward-running
    /// clock is not checked here).
    ///
    /// On a ramp, `½ ḟ τ² + f τ − Δ = 0` with `Δ = p − p0` is solved in the form
    /// `τ = 2Δ / (f + sqrt(f² + 2ḟΔ))`, which does not cancel for `f ≥ 0` (the root of the
    /// textbook form `(−f + sqrt(…))/ḟ` loses every digit when `ḟΔ ≪ f²`) and stays defined
    /// at `f = 0` (a run-up from standstill: `τ = sqrt(2Δ/ḟ)`). The segments advance by
    /// counting pieces, never from a rounded phase, so this only places the stop times.
    pub fn time_of(&self, p: f64) -> f64 {
        if self.rate == 0.0 {
            return if self.mesh_frequency > 0.0 {
                self.t0 + (p - self.p0) / self.mesh_frequency
            } else {
                f64::INFINITY
            };
        }
        let delta = p - self.p0;
        let f = self.mesh_frequency;
        let disc = f * f + 2.0 * self.rate * delta;
        if disc < 0.0 {
            // Never reached ahead (a decelerating clock stops first), or reached in the past.
            return if delta > 0.0 { f64::INFINITY } else { self.t0 };
        }
        let denom = f + disc.sqrt();
        if denom > 0.0 {
            self.t0 + 2.0 * delta / denom
        } else if delta == 0.0 {
            self.t0
        } else {
            f64::INFINITY
        }
    }

    /// Checks a clock restored from outside (FMU state) against the one this model would
    /// have: an anchor within the range of [`check_phase`] and the mesh frequency the restored
    /// inputs give (`expected`, bit for bit: both come from the same product).
    pub fn check_restored(&self, expected_frequency: f64) -> Result<(), String> {
        let (t0, p0) = self.anchor();
        if !t0.is_finite() {
            return Err(format!("clock anchor time {t0} s is not finite"));
        }
        check_phase("clock anchor phase", p0)?;
        if self.mesh_frequency.to_bits() != expected_frequency.to_bits() {
            return Err(format!(
                "clock mesh frequency {} Hz differs from {expected_frequency} Hz, the one its inputs give",
                self.mesh_frequency
            ));
        }
        Ok(())
    }

    /// Checks that advancing from `t` to `t_end` stays within the limits of this clock: at
    /// most [`MAX_MESH_PERIODS_PER_ADVANCE`] mesh periods, and phase and time (in mesh periods)
    /// at `t_end` within [`MAX_MESH_CYCLES`]. O(1): called before every advance, so the test is
    /// inlined and the message is built out of line.
    #[inline]
    pub fn check_advance(&self, t: f64, t_end: f64) -> Result<(), String> {
        let (periods, phase) = self.advance_extent(t, t_end);
        if periods <= MAX_MESH_PERIODS_PER_ADVANCE
            && phase.abs() <= MAX_MESH_CYCLES
            && (self.mesh_frequency * t_end).abs() <= MAX_MESH_CYCLES
        {
            Ok(())
        } else {
            Err(self.advance_refusal(t, t_end))
        }
    }

    /// The mesh periods an advance from `t` to `t_end` spans, and the phase at `t_end`.
    #[inline]
    fn advance_extent(&self, t: f64, t_end: f64) -> (f64, f64) {
        let phase = self.phase_at(t_end);
        let periods = if self.rate == 0.0 {
            self.mesh_frequency * (t_end - t)
        } else {
            phase - self.phase_at(t)
        };
        (periods, phase)
    }

    /// Why [`PhaseClock::check_advance`] refuses the advance from `t` to `t_end`.
    #[cold]
    #[inline(never)]
    fn advance_refusal(&self, t: f64, t_end: f64) -> String {
        let f = self.mesh_frequency;
        let (periods, phase) = self.advance_extent(t, t_end);
        if !(periods <= MAX_MESH_PERIODS_PER_ADVANCE) {
            return format!(
                "advancing from t = {t:e} s to {t_end:e} s at mesh frequency {f:e} Hz spans \
                 {periods:e} mesh periods, more than the {MAX_MESH_PERIODS_PER_ADVANCE:e} one \
                 step may take (shorten the communication step or output interval)"
            );
        }
        format!(
            "at t = {t_end:e} s the mesh phase would be {phase:e} cycles and the time \
             {:e} mesh periods (mesh frequency {f:e} Hz): beyond 2^32 cycles phase and \
             time lose the resolution the stiffness and STE need",
            f * t_end
        )
    }

    /// Keeps the phase continuous at `t` and changes the frequency from then on (constant).
    pub fn reanchor(&mut self, t: f64, mesh_frequency: f64) {
        self.reanchor_ramp(t, mesh_frequency, 0.0);
    }

    /// Keeps the phase continuous at `t`; from then on the frequency is
    /// `mesh_frequency + rate·(t' − t)` (one segment of a piecewise-linear speed profile).
    pub fn reanchor_ramp(&mut self, t: f64, mesh_frequency: f64, rate: f64) {
        self.p0 = self.phase_at(t);
        self.t0 = t;
        self.mesh_frequency = mesh_frequency;
        self.rate = rate;
    }
}

#[cfg(test)]
mod tests {
    use super::PhaseClock;

    /// The quadratic clock against its closed form, and `time_of` as its inverse, from
    /// standstill and on a slow ramp where the textbook root cancels.
    #[test]
    fn ramp_phase_and_its_inverse() {
        let mut c = PhaseClock::new(0.0, 0.25, 0.0);
        c.reanchor_ramp(1.0, 0.0, 3000.0);
        // From standstill: p = 0.25 + 1500 (t − 1)².
        assert_eq!(c.phase_at(1.0), 0.25);
        let t = c.time_of(0.25 + 1500.0 * 0.04);
        assert!((t - 1.2).abs() < 1e-15, "{t}");
        assert_eq!(c.frequency_at(1.5), 1500.0);
        // A slow ramp at 3 kHz: ḟΔ/f² ~ 1e-12.
        let mut c = PhaseClock::new(0.0, 0.0, 3000.0);
        c.reanchor_ramp(0.0, 3000.0, 1e-2);
        for k in 1..2000 {
            let p = k as f64 * 0.37;
            let t = c.time_of(p);
            let exact = (p - 3000.0 * t - 0.5e-2 * t * t).abs();
            assert!(exact < 1e-12 * p.max(1.0), "p = {p}: residual {exact}");
        }
        // Decelerating to a stop before the phase: never.
        let mut c = PhaseClock::new(0.0, 0.0, 100.0);
        c.reanchor_ramp(0.0, 100.0, -100.0);
        let t = c.time_of(49.0);
        assert!((t - (1.0 - 0.02f64.sqrt())).abs() < 1e-15, "{t}");
        assert_eq!(c.time_of(51.0), f64::INFINITY);
    }
}
