//! Naming spectral lines by mesh and shaft orders: `k·f_mesh(n) + j·f_shaft(g)`.

/// One gear's rotation, for order labels.
#[derive(Debug, Clone, PartialEq)]
pub struct ShaftFrequency {
    /// The gear's name (`pinion`/`gear` for the single pair, the scene's name in a drivetrain).
    pub name: String,
    pub teeth: u32,
    /// Rotation frequency at the nominal speed, Hz.
    pub frequency: f64,
}

/// The combination naming a line: `mesh_order` × mesh `mesh` plus `shaft_order` × shaft
/// `shaft`.
#[derive(Debug, Clone, PartialEq)]
pub struct OrderLabel {
    pub text: String,
    /// Frequency of the combination, Hz.
    pub frequency: f64,
}

/// Highest mesh harmonic and shaft order tried: beyond these a "label" is numerology.
const MAX_MESH_ORDER: i32 = 10;
const MAX_SHAFT_ORDER: i32 = 6;

/// For each frequency, the simplest combination `k·f_mesh(n) + j·f_shaft(g)`
/// (0 ≤ k ≤ 10, |j| ≤ 6, one mesh and at most one shaft) within `tolerance` Hz, preferring
/// the nearest, then the fewest orders; `None` when nothing lies that close. `meshes` are
/// (name, frequency Hz).
pub fn label_lines(
    frequencies: &[f64],
    meshes: &[(String, f64)],
    shafts: &[ShaftFrequency],
    tolerance: f64,
) -> Vec<Option<OrderLabel>> {
    let mut candidates: Vec<(f64, i32, String)> = vec![(0.0, 0, "DC".to_string())];
    for (name, fm) in meshes {
        for k in 1..=MAX_MESH_ORDER {
            candidates.push((k as f64 * fm, k, format!("{k}×{name}")));
            for s in shafts {
                for j in (-MAX_SHAFT_ORDER..=MAX_SHAFT_ORDER).filter(|&j| j != 0) {
                    let sign = if j > 0 { '+' } else { '-' };
                    let f = k as f64 * fm + j as f64 * s.frequency;
                    let text = format!("{k}×{name}{sign}{}×{}", j.abs(), s.name);
                    candidates.push((f, k + j.abs(), text));
                }
            }
        }
    }
    for s in shafts {
        for j in 1..=MAX_SHAFT_ORDER {
            candidates.push((j as f64 * s.frequency, j, format!("{j}×{}", s.name)));
        }
    }
    frequencies
        .iter()
        .map(|&f| {
            candidates
                .iter()
                .filter(|c| c.0 >= 0.0 && (c.0 - f).abs() <= tolerance)
                .min_by(|a, b| {
                    // Nearest first, but two candidates within rounding of each other are
                    // equally near: then the simpler one names the line.
                    let (da, db) = ((a.0 - f).abs(), (b.0 - f).abs());
                    if (da - db).abs() > 1e-9 * f.abs().max(1.0) {
                        da.total_cmp(&db)
                    } else {
                        a.1.cmp(&b.1)
                    }
                })
                .map(|c| OrderLabel {
                    text: c.2.clone(),
                    frequency: c.0,
                })
        })
        .collect()
}
