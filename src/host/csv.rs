//! CSV in/out in fmpy's conventions.
//!
//! Output (`fmpy.util.write_csv`): a header of double-quoted names, `"time"` first; one row
//! per communication point; Reals in Python `repr` form (shortest text that round-trips, so
//! no precision is lost), Integers as decimal, Booleans as `True`/`False` (what fmpy writes).
//!
//! Input (`fmpy.util.read_csv`): the first line holds the column names (quotes optional), the
//! first column is the time, every cell is a number (read as `f64`, as fmpy does).

/// Format an `f64` exactly like Python's `repr(float)`: shortest round-trip digits, scientific
/// notation when the decimal exponent is < -4 or >= 16, exponent with sign and at least two
/// digits (`1e-05`, `1.5e+16`), `inf`/`-inf`/`nan`.
pub fn format_real(v: f64) -> String {
    let mut s = String::with_capacity(24);
    write_real(&mut s, v);
    s
}

/// [`format_real`] appended to `out` without allocating (the output hot path).
pub fn write_real(out: &mut String, v: f64) {
    use std::fmt::Write as _;
    if v.is_nan() {
        out.push_str("nan");
        return;
    }
    if v.is_infinite() {
        out.push_str(if v > 0.0 { "inf" } else { "-inf" });
        return;
    }
    // Rust's `{:?}` uses the same shortest-digits algorithm and the same thresholds as
    // Python's repr; only the exponent spelling differs (`1e-5` vs `1e-05`, `1e16` vs `1e+16`).
    let start = out.len();
    let _ = write!(out, "{v:?}");
    // The exponent is written last and has at most three digits and a sign ("1e-308"), so
    // an 'e' is among the last five bytes (the digits before it are no 'e').
    let tail = out.len().saturating_sub(5).max(start);
    if let Some(p) = out.as_bytes()[tail..].iter().rposition(|&b| b == b'e') {
        let mut at = tail + p + 1;
        if out.as_bytes()[at] == b'-' {
            at += 1;
        } else {
            out.insert(at, '+');
            at += 1;
        }
        if out.len() - at < 2 {
            out.insert(at, '0');
        }
    }
}

/// Read a CSV table in fmpy's input layout (`fmpy.util.read_csv`): a header line of column
/// names (double quotes optional), then one row of numbers per line. The first column must be
/// named `time`. Blank lines are skipped. Errors name the line, the column and the text.
///
/// Returns the names and the columns (`columns[k][row]`).
pub fn read_table(text: &str) -> Result<(Vec<String>, Vec<Vec<f64>>), String> {
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let (_, header) = lines
        .next()
        .ok_or("the CSV file is empty (expected a header line starting with \"time\")")?;
    let names: Vec<String> = header
        .trim_end()
        .split(',')
        .map(|n| n.trim().trim_matches('"').to_string())
        .collect();
    if names[0] != "time" {
        return Err(format!(
            "line 1: the first column must be \"time\", found \"{}\"",
            names[0]
        ));
    }
    if let Some(e) = names.iter().position(|n| n.is_empty()) {
        return Err(format!("line 1: column {} has an empty name", e + 1));
    }
    for (i, n) in names.iter().enumerate() {
        if names[..i].contains(n) {
            return Err(format!("line 1: column \"{n}\" appears twice"));
        }
    }
    let mut columns: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
    for (i, line) in lines {
        let cells: Vec<&str> = line.trim_end().split(',').collect();
        if cells.len() != names.len() {
            return Err(format!(
                "line {}: {} values, but the header has {} columns",
                i + 1,
                cells.len(),
                names.len()
            ));
        }
        for (k, cell) in cells.iter().enumerate() {
            let c = cell.trim();
            let v = parse_number(c).ok_or_else(|| {
                format!(
                    "line {}, column \"{}\": \"{c}\" is not a number",
                    i + 1,
                    names[k]
                )
            })?;
            if k == 0 && !v.is_finite() {
                return Err(format!("line {}: time \"{c}\" is not finite", i + 1));
            }
            columns[k].push(v);
        }
    }
    if columns[0].is_empty() {
        return Err("the CSV file has a header but no data rows".into());
    }
    Ok((names, columns))
}

/// A number as Python's `float()` reads it (decimal, exponent, inf/nan in any case).
fn parse_number(s: &str) -> Option<f64> {
    let l = s.to_ascii_lowercase();
    match l.trim_start_matches(['+', '-']) {
        "inf" | "infinity" | "nan" => return l.parse::<f64>().ok(),
        _ => {}
    }
    if s.is_empty()
        || s.chars()
            .any(|c| c.is_ascii_alphabetic() && c != 'e' && c != 'E')
    {
        return None;
    }
    s.parse::<f64>().ok()
}

/// The recorded values at one communication point, in fmpy's column order: the Reals, then
/// the Integers (and Enumerations), then the Booleans (fmi2Boolean: 0 is false).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Row<'a> {
    pub reals: &'a [f64],
    pub integers: &'a [i32],
    pub booleans: &'a [i32],
}

/// Streams a result like `fmpy.util.write_csv`: `"time","a","b"`, then one line per sample,
/// written as the samples are taken: memory does not grow with the run length, and if the FMU
/// crashes the whole process, the rows up to the last buffer flush are already on disk.
pub struct CsvWriter<W: std::io::Write> {
    out: W,
    line: String,
    rows: usize,
    last_time: Option<f64>,
}

impl<W: std::io::Write> CsvWriter<W> {
    /// Write the header.
    pub fn new(mut out: W, names: &[String]) -> std::io::Result<Self> {
        use std::fmt::Write as _;
        let mut line = String::from("\"time\"");
        for n in names {
            let _ = write!(line, ",\"{n}\"");
        }
        line.push('\n');
        out.write_all(line.as_bytes())?;
        Ok(CsvWriter {
            out,
            line,
            rows: 0,
            last_time: None,
        })
    }

    /// Write one row, each value as fmpy writes it (`str()` of the numpy scalar).
    pub fn row(&mut self, t: f64, row: &Row) -> std::io::Result<()> {
        use std::fmt::Write as _;
        let line = &mut self.line;
        line.clear();
        write_real(line, t);
        for &v in row.reals {
            line.push(',');
            write_real(line, v);
        }
        for &v in row.integers {
            let _ = write!(line, ",{v}");
        }
        for &v in row.booleans {
            line.push_str(if v != 0 { ",True" } else { ",False" });
        }
        line.push('\n');
        self.out.write_all(self.line.as_bytes())?;
        self.rows += 1;
        self.last_time = Some(t);
        Ok(())
    }

    /// Rows written so far and the time of the last one.
    pub fn written(&self) -> (usize, Option<f64>) {
        (self.rows, self.last_time)
    }

    pub fn flush(&mut self) -> std::io::Result<()> {
        self.out.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn python_repr() {
        for (v, s) in [
            (0.0, "0.0"),
            (0.1, "0.1"),
            (1e-5, "1e-05"),
            (1.5e16, "1.5e+16"),
            (1e16, "1e+16"),
            (123456789012345.6, "123456789012345.6"),
            (0.30000000000000004, "0.30000000000000004"),
            (-2.5e-7, "-2.5e-07"),
            (1e100, "1e+100"),
            (0.0001, "0.0001"),
            (5e-324, "5e-324"),
            (-1e-300, "-1e-300"),
            (1.7976931348623157e308, "1.7976931348623157e+308"),
            (1e22, "1e+22"),
            (123.0, "123.0"),
            (-0.0, "-0.0"),
        ] {
            assert_eq!(format_real(v), s);
        }
    }

    #[test]
    fn table_errors_name_line_and_column() {
        assert!(read_table("").unwrap_err().contains("empty"));
        assert!(read_table("t,u\n0,1\n").unwrap_err().contains("\"time\""));
        let e = read_table("\"time\",\"u\"\n0,1\n1,abc\n").unwrap_err();
        assert!(
            e.contains("line 3") && e.contains("\"u\"") && e.contains("abc"),
            "{e}"
        );
        let e = read_table("time,u\n0,1,2\n").unwrap_err();
        assert!(e.contains("line 2") && e.contains("3 values"), "{e}");
        assert!(read_table("time,u\n").unwrap_err().contains("no data rows"));
        let (n, c) = read_table("\"time\",\"u\"\n0,1\n\n1,-2.5e-3\n").unwrap();
        assert_eq!(n, ["time", "u"]);
        assert_eq!(c, vec![vec![0.0, 1.0], vec![1.0, -2.5e-3]]);
    }
}
