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

/// Mesh phase `p(t) = p0 + f_m (t − t0)` (mesh cycles), `f_m = z1 Ω / 2π` (`docs/model.md`,
/// "Mesh phase"). The clock is re-anchored whenever the nominal speed changes (an FMU input
/// between communication points), so the phase is continuous and stiffness never depends on
/// raw time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhaseClock {
    t0: f64,
    p0: f64,
    mesh_frequency: f64,
}

impl PhaseClock {
    pub fn new(t0: f64, p0: f64, mesh_frequency: f64) -> Self {
        PhaseClock {
            t0,
            p0,
            mesh_frequency,
        }
    }

    /// Mesh phase at time `t`.
    pub fn phase_at(&self, t: f64) -> f64 {
        self.p0 + self.mesh_frequency * (t - self.t0)
    }

    /// The anchor `(t0, p0)`: with [`PhaseClock::new`] it rebuilds this clock bit for bit
    /// (FMU state snapshots; re-deriving the anchor would change rounding).
    pub fn anchor(&self) -> (f64, f64) {
        (self.t0, self.p0)
    }

    /// Mesh frequency f_m, Hz.
    pub fn mesh_frequency(&self) -> f64 {
        self.mesh_frequency
    }

    /// The time at which the phase reaches `p` (`+inf` when the clock stands still or `p`
    /// lies in the past of a forward-running clock is not checked here).
    pub fn time_of(&self, p: f64) -> f64 {
        if self.mesh_frequency > 0.0 {
            self.t0 + (p - self.p0) / self.mesh_frequency
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
    /// at `t_end` within [`MAX_MESH_CYCLES`]. O(1): called before every advance.
    pub fn check_advance(&self, t: f64, t_end: f64) -> Result<(), String> {
        let f = self.mesh_frequency;
        let periods = f * (t_end - t);
        if !(periods <= MAX_MESH_PERIODS_PER_ADVANCE) {
            return Err(format!(
                "advancing from t = {t:e} s to {t_end:e} s at mesh frequency {f:e} Hz spans \
                 {periods:e} mesh periods, more than the {MAX_MESH_PERIODS_PER_ADVANCE:e} one \
                 step may take (shorten the communication step or output interval)"
            ));
        }
        let phase = self.phase_at(t_end);
        if !(phase.abs() <= MAX_MESH_CYCLES && (f * t_end).abs() <= MAX_MESH_CYCLES) {
            return Err(format!(
                "at t = {t_end:e} s the mesh phase would be {phase:e} cycles and the time \
                 {:e} mesh periods (mesh frequency {f:e} Hz): beyond 2^32 cycles phase and \
                 time lose the resolution the stiffness and STE need",
                f * t_end
            ));
        }
        Ok(())
    }

    /// Keeps the phase continuous at `t` and changes the frequency from then on.
    pub fn reanchor(&mut self, t: f64, mesh_frequency: f64) {
        self.p0 = self.phase_at(t);
        self.t0 = t;
        self.mesh_frequency = mesh_frequency;
    }
}
