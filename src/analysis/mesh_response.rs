//! The steady-state response of one mesh: one type and one column list for every analysis
//! that reports it (`sweep`, `periodic`, `hb`, the Python module and the studies), so that the
//! three tables read alike and a column means the same thing in each (issue 30 item 3).
//!
//! How each analysis computes the values from its solution (event times, segment integrals,
//! the harmonic series) is in [`crate::analysis::orbit_statistics`] and
//! [`crate::analysis::hb`]; `docs/sweep.md` states the accuracy.

/// The steady-state response of one mesh over a recorded stretch (a periodic orbit, or the
/// recording of an aperiodic sweep point).
#[derive(Debug, Clone, PartialEq)]
pub struct MeshResponse {
    /// Column prefix ([`crate::model::Drivetrain::mesh_prefix`]; `""` for the single pair).
    pub prefix: String,
    /// Mesh frequency, Hz.
    pub mesh_frequency: f64,
    /// Mean DTE, m.
    pub dte_mean: f64,
    /// RMS of the DTE with the mean removed, m.
    pub dte_rms: f64,
    /// Largest minus smallest DTE, m.
    pub dte_peak_to_peak: f64,
    /// Amplitudes of the first three harmonics of this mesh's frequency in its DTE, m (0 when
    /// harmonic balance does not retain the order).
    pub harmonics: [f64; 3],
    /// Fraction of the time with total contact loss (no tooth pair in contact; for the single
    /// pair: neither drive-side nor back-side contact), from the switching instants.
    pub contact_loss_fraction: f64,
    /// Per tooth-pair slot of a Model-1 mesh ([`crate::model::Drivetrain::mesh_pair_slots`]:
    /// slot `j` holds the pair at window position `ξ_j = s + c − 1 − j`), the fraction of the
    /// time that pair is engaged but in contact on neither flank, from the switching instants
    /// (partial contact loss where another pair still carries the load); empty for a mesh
    /// without pairs, and from harmonic balance (whose series has no contact events).
    pub pair_contact_loss_fractions: Vec<f64>,
    /// Mesh phase (cycles, `[0, 1)`) at which contact is first lost in the stretch: the
    /// separation angle over `2π`; NaN without contact loss.
    pub separation_phase: f64,
    /// Largest |mesh force|, N.
    pub peak_force: f64,
    /// RMS of the mesh force with its mean removed, N.
    pub force_rms: f64,
    /// Peak mesh force over the static mesh force
    /// ([`crate::model::Drivetrain::static_mesh_forces`]).
    pub dynamic_factor: f64,
    /// The DTE at the start of every mesh period of the first mesh in the stretch (a sweep's
    /// Poincaré section; empty unless asked for).
    pub poincare: Vec<f64>,
}

/// Per-mesh columns (after the mesh's prefix) of `sweep` and `hb`, and the names `periodic`
/// prints; the single pair has no `mesh_frequency` among them (its mesh frequency is a point
/// column).
pub const MESH_COLUMNS: [&str; 12] = [
    "dte_mean",
    "dte_rms",
    "dte_peak_to_peak",
    "a1",
    "a2",
    "a3",
    "contact_loss_fraction",
    "separation_phase",
    "peak_force",
    "force_rms",
    "dynamic_factor",
    "mesh_frequency",
];

/// The per-mesh column names of a model with the given mesh prefixes.
pub fn mesh_columns(prefixes: &[String]) -> Vec<String> {
    let mut names = Vec::new();
    for p in prefixes {
        for c in MESH_COLUMNS {
            // The first mesh's frequency is already a point column.
            if c == "mesh_frequency" && p.is_empty() {
                continue;
            }
            names.push(format!("{p}{c}"));
        }
    }
    names
}

impl MeshResponse {
    /// A mesh whose run failed: every statistic NaN.
    pub fn failed(prefix: String, mesh_frequency: f64) -> MeshResponse {
        MeshResponse {
            prefix,
            mesh_frequency,
            dte_mean: f64::NAN,
            dte_rms: f64::NAN,
            dte_peak_to_peak: f64::NAN,
            harmonics: [f64::NAN; 3],
            contact_loss_fraction: f64::NAN,
            pair_contact_loss_fractions: Vec::new(),
            separation_phase: f64::NAN,
            peak_force: f64::NAN,
            force_rms: f64::NAN,
            dynamic_factor: f64::NAN,
            poincare: Vec::new(),
        }
    }

    /// The values in [`mesh_columns`] order for this mesh.
    pub fn values(&self) -> Vec<f64> {
        let mut row = vec![
            self.dte_mean,
            self.dte_rms,
            self.dte_peak_to_peak,
            self.harmonics[0],
            self.harmonics[1],
            self.harmonics[2],
            self.contact_loss_fraction,
            self.separation_phase,
            self.peak_force,
            self.force_rms,
            self.dynamic_factor,
        ];
        if !self.prefix.is_empty() {
            row.push(self.mesh_frequency);
        }
        row
    }

    /// `name = value unit` pairs in column order, for reports (`geardyn periodic`); the
    /// mesh frequency first (also for the single pair, whose table has it as a point column).
    pub fn report_line(&self) -> String {
        let mut names = mesh_columns(std::slice::from_ref(&self.prefix));
        let mut values = self.values();
        if self.prefix.is_empty() {
            names.insert(0, "mesh_frequency".to_owned());
            values.insert(0, self.mesh_frequency);
        }
        // Then each tooth pair's contact-loss fraction (a Model-1 mesh).
        for (j, &v) in self.pair_contact_loss_fractions.iter().enumerate() {
            names.push(format!("{}pair{j}_contact_loss_fraction", self.prefix));
            values.push(v);
        }
        names
            .iter()
            .zip(values)
            .map(|(n, v)| match crate::units::column_unit(n) {
                None | Some("1") => format!("{n} = {v:e}"),
                Some(unit) => format!("{n} = {v:e} {unit}"),
            })
            .collect::<Vec<_>>()
            .join(", ")
    }
}
