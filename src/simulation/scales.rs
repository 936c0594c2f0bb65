//! The time scales of a model that decide the work of a run: read by the driver's models,
//! the run limits of a streamed run and the work budget's messages.

/// The time scales of a model that decide the work of a run, from the model itself (see
/// [`super::DrivenModel::run_scales`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunScales {
    /// Mesh frequency of the fastest mesh, Hz (0 at standstill).
    pub mesh_frequency: f64,
    /// How fast the torques change the fastest mesh frequency, Hz/s: 0 for a prescribed speed;
    /// with the rotation carried (ports, `docs/ports.md`) the rigid-body acceleration the port
    /// torques give. A run spans about `(f + ½ḟt) t` mesh periods.
    pub mesh_frequency_slope: f64,
    /// Largest |mesh phase| at t = 0, cycles.
    pub start_phase: f64,
    /// The input speed: its TOML field and value, rad/s.
    pub speed: (&'static str, f64),
    /// An upper bound of the fastest rate of any mode (angular frequency or damping rate),
    /// rad/s, and what sets it (the fields to look at).
    pub fastest_rate: (f64, &'static str),
}
