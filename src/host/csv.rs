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
    // Both write a decimal fraction for 1e-4 <= |v| < 1e16 and for zero, scientific notation
    // otherwise: only then is there an exponent to respell.
    let abs = v.abs();
    if abs == 0.0 || (1e-4..1e16).contains(&abs) {
        return;
    }
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

/// About this many numbers are kept before they are formatted (32 KiB of `f64`).
const BLOCK_VALUES: usize = 4096;

/// Rows taken but not yet formatted: the times and the values of each type, flat. All rows
/// of a block have the same number of values of each type (`shape`).
#[derive(Default)]
struct Block {
    times: Vec<f64>,
    reals: Vec<f64>,
    integers: Vec<i32>,
    booleans: Vec<i32>,
    shape: (usize, usize, usize),
}

impl Block {
    fn push(&mut self, t: f64, row: &Row) {
        self.times.push(t);
        self.reals.extend_from_slice(row.reals);
        self.integers.extend_from_slice(row.integers);
        self.booleans.extend_from_slice(row.booleans);
    }

    /// The `k`-th row.
    fn row(&self, k: usize) -> Row<'_> {
        let (nr, ni, nb) = self.shape;
        Row {
            reals: &self.reals[k * nr..(k + 1) * nr],
            integers: &self.integers[k * ni..(k + 1) * ni],
            booleans: &self.booleans[k * nb..(k + 1) * nb],
        }
    }

    fn clear(&mut self) {
        self.times.clear();
        self.reals.clear();
        self.integers.clear();
        self.booleans.clear();
    }
}

/// Streams a result like `fmpy.util.write_csv`: `"time","a","b"`, then one line per sample.
/// Memory does not grow with the run length, and if the FMU crashes the whole process, the
/// rows up to the last block written are already on disk.
///
/// The rows are formatted and written in blocks of about [`BLOCK_VALUES`] numbers (512 rows
/// of 8 columns, 64 kB of text: one `write` each, so `out` needs no buffer of its own).
/// Formatting each row between two steps of the FMU makes the two alternate in the caches
/// and branch predictors, which cost about 5% of a run's CPU time (`scripts/bench-host.sh`);
/// a block keeps each in its own stretch, like `geardyn simulate` that formats after the
/// whole run.
pub struct CsvWriter<W: std::io::Write> {
    out: W,
    /// The text of a block, written to `out` at once.
    text: String,
    block: Block,
    rows: usize,
    last_time: Option<f64>,
}

impl<W: std::io::Write> CsvWriter<W> {
    /// Write the header.
    pub fn new(mut out: W, names: &[String]) -> std::io::Result<Self> {
        use std::fmt::Write as _;
        let mut text = String::from("\"time\"");
        for n in names {
            let _ = write!(text, ",\"{n}\"");
        }
        text.push('\n');
        out.write_all(text.as_bytes())?;
        Ok(CsvWriter {
            out,
            text,
            block: Block::default(),
            rows: 0,
            last_time: None,
        })
    }

    /// Take one row; it is written with its block (at the latest by [`Self::flush`]).
    pub fn row(&mut self, t: f64, row: &Row) -> std::io::Result<()> {
        let shape = (row.reals.len(), row.integers.len(), row.booleans.len());
        if shape != self.block.shape {
            self.write_block()?;
            self.block.shape = shape;
        }
        self.block.push(t, row);
        let block_rows = (BLOCK_VALUES / (1 + shape.0 + shape.1 + shape.2)).max(1);
        if self.block.times.len() >= block_rows {
            self.write_block()?;
        }
        Ok(())
    }

    /// Format the block, each value as fmpy writes it (`str()` of the numpy scalar), and
    /// write it.
    fn write_block(&mut self) -> std::io::Result<()> {
        use std::fmt::Write as _;
        let Some(&last) = self.block.times.last() else {
            return Ok(());
        };
        let text = &mut self.text;
        text.clear();
        for (k, &t) in self.block.times.iter().enumerate() {
            let row = self.block.row(k);
            write_real(text, t);
            for &v in row.reals {
                text.push(',');
                write_real(text, v);
            }
            for &v in row.integers {
                let _ = write!(text, ",{v}");
            }
            for &v in row.booleans {
                text.push_str(if v != 0 { ",True" } else { ",False" });
            }
            text.push('\n');
        }
        let n = self.block.times.len();
        self.block.clear();
        self.out.write_all(self.text.as_bytes())?;
        self.rows += n;
        self.last_time = Some(last);
        Ok(())
    }

    /// Rows written so far and the time of the last one.
    pub fn written(&self) -> (usize, Option<f64>) {
        (self.rows, self.last_time)
    }

    /// Write the rows taken so far and flush the output.
    pub fn flush(&mut self) -> std::io::Result<()> {
        self.write_block()?;
        self.out.flush()
    }
}

impl<W: std::io::Write> Drop for CsvWriter<W> {
    /// The rows taken are written also without [`CsvWriter::flush`] (errors cannot be
    /// reported here, as `BufWriter` does on drop).
    fn drop(&mut self) {
        let _ = self.write_block();
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
            // The two thresholds of scientific notation, from both sides.
            (9.999999999999999e-5, "9.999999999999999e-05"),
            (-0.0001, "-0.0001"),
            (9999999999999998.0, "9999999999999998.0"),
            (-1e16, "-1e+16"),
        ] {
            assert_eq!(format_real(v), s);
        }
    }

    /// Rows are written whole and in order across block boundaries and a change of shape;
    /// `flush` and `drop` write what is still pending.
    #[test]
    fn rows_in_blocks_give_the_same_text() {
        let names = ["x".to_string(), "n".to_string(), "b".to_string()];
        let mut expected = String::from("\"time\",\"x\",\"n\",\"b\"\n");
        let mut csv = CsvWriter::new(Vec::new(), &names).unwrap();
        for k in 0..2500 {
            let t = k as f64 * 1e-5;
            let x = [k as f64 / 3.0];
            let n = [k - 7];
            let b = [k % 2];
            let row = Row {
                reals: &x,
                integers: &n,
                booleans: &b,
            };
            csv.row(t, &row).unwrap();
            expected += &format!(
                "{},{},{},{}\n",
                format_real(t),
                format_real(x[0]),
                n[0],
                if b[0] == 1 { "True" } else { "False" }
            );
        }
        // Another shape (a Real only): the block before it is written first.
        csv.row(
            1.0,
            &Row {
                reals: &[2.5],
                integers: &[],
                booleans: &[],
            },
        )
        .unwrap();
        expected += "1.0,2.5\n";
        csv.flush().unwrap();
        assert_eq!(csv.written(), (2501, Some(1.0)));
        assert_eq!(String::from_utf8(csv.out.clone()).unwrap(), expected);

        let mut out = Vec::new();
        {
            let mut csv = CsvWriter::new(&mut out, &names[..1]).unwrap();
            csv.row(
                0.5,
                &Row {
                    reals: &[1e-7],
                    integers: &[],
                    booleans: &[],
                },
            )
            .unwrap();
        }
        assert_eq!(
            String::from_utf8(out).unwrap(),
            "\"time\",\"x\"\n0.5,1e-07\n"
        );
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
