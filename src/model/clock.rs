//! The nominal-speed clock: mesh phase as a function of time.

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

    /// Keeps the phase continuous at `t` and changes the frequency from then on.
    pub fn reanchor(&mut self, t: f64, mesh_frequency: f64) {
        self.p0 = self.phase_at(t);
        self.t0 = t;
        self.mesh_frequency = mesh_frequency;
    }
}
