//! Rows of the work-precision results: one run of one method at one rung, from any harness
//! (geardyn in-process, `scripts/workprecision_scipy.py`, `benches/peer`).

use std::path::Path;

use crate::metrics::Errors;

/// One run of one method at one rung, from any harness.
#[derive(Debug, Clone)]
pub struct Row {
    pub problem: String,
    pub method: String,
    pub tol: f64,
    pub status: String,
    pub wall: Option<f64>,
    pub timed_runs: Option<u64>,
    pub rhs: Option<u64>,
    pub steps: Option<u64>,
    pub rejected: Option<u64>,
    pub events: Option<u64>,
    pub dte: Vec<Vec<f64>>,
    pub event_times: Vec<f64>,
    pub errors: Option<Errors>,
}

impl Row {
    pub fn ok(&self) -> bool {
        self.status == "ok"
    }
}

pub fn parse_list(s: &str) -> Vec<f64> {
    if s.is_empty() {
        Vec::new()
    } else {
        s.split(';').map(|v| v.parse().expect("number")).collect()
    }
}

/// Reads a harness CSV (`scripts/workprecision_scipy.py`, `benches/peer`).
pub fn read_rows(path: &Path) -> Result<Vec<Row>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().ok_or("empty file")?.split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).expect("column");
    let opt = |s: &str| s.parse::<f64>().ok();
    let opt_u = |s: &str| s.parse::<u64>().ok();
    Ok(lines
        .map(|line| {
            let f: Vec<&str> = line.split(',').collect();
            Row {
                problem: f[col("problem")].into(),
                method: f[col("method")].into(),
                tol: f[col("tol")].parse().expect("tol"),
                status: f[col("status")].into(),
                wall: opt(f[col("wall_s")]),
                timed_runs: opt_u(f[col("timed_runs")]),
                rhs: opt_u(f[col("rhs")]),
                steps: opt_u(f[col("steps")]),
                rejected: opt_u(f[col("rejected")]),
                events: opt_u(f[col("events")]),
                dte: vec![parse_list(f[col("dte")])],
                event_times: parse_list(f[col("event_times")]),
                errors: None,
            }
        })
        .collect())
}

pub fn find<'a>(rows: &'a [Row], problem: &str, method: &str) -> Option<&'a Row> {
    rows.iter()
        .find(|r| r.problem == problem && r.method == method && r.ok())
}
