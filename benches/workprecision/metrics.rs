//! Error measures of a run against a reference, all normalised by the problem's static
//! deflection `x_scale` (numerics-notes §1.4 item 3).

#![allow(dead_code)]

/// Errors of one run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Errors {
    /// RMS over the dense grid and the meshes of `|x − x_ref| / x_scale` (SciML's `:L2` on the
    /// DTE). This is "the DTE error" of the report and of the acceptance ratios.
    pub dte_l2: f64,
    /// Largest `|x − x_ref| / x_scale` on the grid.
    pub dte_max: f64,
    /// `|x(T) − x_ref(T)| / x_scale`, worst mesh (SciML's `:final` on the DTE).
    pub final_point: f64,
    /// `|rms(x) − rms(x_ref)| / x_scale` with the mean removed (the engineering quantity).
    pub dte_rms: f64,
    /// Largest `|t_i − t_ref,i|` over the contact changes, s; `None` when the counts differ or
    /// the reference has none (nothing to measure).
    pub event_time: Option<f64>,
    /// Contact changes of the run minus those of the reference.
    pub event_count_mismatch: i64,
}

fn rms_about_mean(x: &[f64]) -> f64 {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt()
}

/// Errors of `dte[mesh][k]` and `events` against the reference's.
pub fn errors(
    dte: &[Vec<f64>],
    events: &[f64],
    ref_dte: &[Vec<f64>],
    ref_events: &[f64],
    x_scale: f64,
) -> Errors {
    assert_eq!(
        dte.len(),
        ref_dte.len(),
        "mesh count differs from the reference"
    );
    let (mut sq, mut count, mut max, mut final_point, mut dte_rms) =
        (0.0, 0usize, 0.0f64, 0.0f64, 0.0f64);
    for (x, r) in dte.iter().zip(ref_dte) {
        assert_eq!(x.len(), r.len(), "grid differs from the reference");
        for (a, b) in x.iter().zip(r) {
            let e = (a - b).abs() / x_scale;
            sq += e * e;
            max = max.max(e);
            count += 1;
        }
        final_point = final_point.max((x[x.len() - 1] - r[r.len() - 1]).abs() / x_scale);
        dte_rms = dte_rms.max((rms_about_mean(x) - rms_about_mean(r)).abs() / x_scale);
    }
    let event_time = (events.len() == ref_events.len() && !ref_events.is_empty()).then(|| {
        events
            .iter()
            .zip(ref_events)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max)
    });
    Errors {
        dte_l2: (sq / count as f64).sqrt(),
        dte_max: max,
        final_point,
        dte_rms,
        event_time,
        event_count_mismatch: events.len() as i64 - ref_events.len() as i64,
    }
}

/// Least-squares slope of `log10 y` over `log10 x`.
pub fn log_slope(x: &[f64], y: &[f64]) -> f64 {
    let lx: Vec<f64> = x.iter().map(|v| v.log10()).collect();
    let ly: Vec<f64> = y.iter().map(|v| v.log10()).collect();
    let n = lx.len() as f64;
    let mx = lx.iter().sum::<f64>() / n;
    let my = ly.iter().sum::<f64>() / n;
    let sxy: f64 = lx.iter().zip(&ly).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = lx.iter().map(|a| (a - mx).powi(2)).sum();
    sxy / sxx
}
