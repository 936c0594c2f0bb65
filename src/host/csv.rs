//! CSV in/out in fmpy's conventions.
//!
//! Output (`fmpy.util.write_csv`): a header of double-quoted names, `"time"` first; one row
//! per communication point; Reals in Python `repr` form (shortest text that round-trips, so
//! no precision is lost), Integers as decimal, Booleans as `True`/`False` (what fmpy writes).
//!
//! Input (`fmpy.util.read_csv`): the first line holds the column names (quotes optional), the
//! first column is the time, every cell is a number (read as `f64`, as fmpy does).

use super::shared::SharedMemory;

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

/// The bookkeeping of a [`CsvWriter`]. It sits in shared memory next to the pending rows, so
/// that the supervising parent of `geardyn run` can complete the file when the process that
/// was writing it died (the FMU crashed or was killed): it knows which rows are pending and
/// how many bytes of the file are whole blocks.
#[repr(C)]
struct BlockState {
    /// Values per row of each type: Reals, Integers, Booleans.
    shape: [usize; 3],
    /// Values held: whole rows of `1 + shape` values each (the time first).
    len: usize,
    /// Bytes written to the output (the header included).
    bytes_written: u64,
    /// Rows written to the output.
    rows_written: u64,
    /// The time of the last row written; NaN before the first.
    last_time_written: f64,
}

/// Rows taken but not yet formatted, flat: per row the time, then the Reals, the Integers and
/// the Booleans (fmi2Boolean), every value as an `f64` (exact for `i32`). All rows of a block
/// have the same shape. The storage is a [`SharedMemory`] mapping (see [`BlockState`]).
struct Block {
    memory: SharedMemory,
    /// Values the mapping holds after the state.
    capacity: usize,
}

impl Block {
    /// Room for [`BLOCK_VALUES`] values, or for one row of `row_len` values if that is more.
    fn new(row_len: usize) -> std::io::Result<Block> {
        let capacity = BLOCK_VALUES.max(row_len);
        let memory = SharedMemory::new(
            std::mem::size_of::<BlockState>() + capacity * std::mem::size_of::<f64>(),
        )?;
        let mut block = Block { memory, capacity };
        *block.state_mut() = BlockState {
            shape: [0; 3],
            len: 0,
            bytes_written: 0,
            rows_written: 0,
            last_time_written: f64::NAN,
        };
        Ok(block)
    }

    fn state(&self) -> &BlockState {
        // SAFETY: the mapping starts with a BlockState (page-aligned), written in `new`.
        unsafe { &*self.memory.as_ptr().cast::<BlockState>() }
    }

    fn state_mut(&mut self) -> &mut BlockState {
        // SAFETY: as in `state`; `&mut self` makes the access unique in this process.
        unsafe { &mut *self.memory.as_ptr().cast::<BlockState>() }
    }

    /// The first value slot: `capacity` f64 follow the state (its size is a multiple of 8).
    fn first_value(&self) -> *mut f64 {
        // SAFETY: the offset stays inside the mapping made in `new`.
        unsafe {
            self.memory
                .as_ptr()
                .add(std::mem::size_of::<BlockState>())
                .cast::<f64>()
        }
    }

    /// The values storage (all `capacity` slots).
    fn storage(&mut self) -> &mut [f64] {
        // SAFETY: see `first_value`; `&mut self` makes the access unique in this process.
        unsafe { std::slice::from_raw_parts_mut(self.first_value(), self.capacity) }
    }

    /// The values held.
    fn values(&self) -> &[f64] {
        // SAFETY: see `first_value`; `len <= capacity` is kept by `push`.
        unsafe { std::slice::from_raw_parts(self.first_value(), self.state().len) }
    }

    /// Append one row; the caller made room (`len + 1 + shape <= capacity`).
    fn push(&mut self, t: f64, row: &Row) {
        let at = self.state().len;
        let storage = self.storage();
        let mut k = at;
        storage[k] = t;
        k += 1;
        storage[k..k + row.reals.len()].copy_from_slice(row.reals);
        k += row.reals.len();
        for &v in row.integers.iter().chain(row.booleans) {
            storage[k] = f64::from(v);
            k += 1;
        }
        // Published after the values: a crash between the two loses this row, never garbles it.
        self.state_mut().len = k;
    }
}

/// Append the rows of `values` (laid out as in [`Block`], with `shape`) to `text`, each value
/// as fmpy writes it (`str()` of the numpy scalar).
fn format_rows(text: &mut String, shape: [usize; 3], values: &[f64]) {
    use std::fmt::Write as _;
    let [nr, ni, nb] = shape;
    for row in values.chunks_exact(1 + nr + ni + nb) {
        write_real(text, row[0]);
        for &v in &row[1..1 + nr] {
            text.push(',');
            write_real(text, v);
        }
        for &v in &row[1 + nr..1 + nr + ni] {
            let _ = write!(text, ",{}", v as i32);
        }
        for &v in &row[1 + nr + ni..] {
            text.push_str(if v != 0.0 { ",True" } else { ",False" });
        }
        text.push('\n');
    }
}

/// Streams a result like `fmpy.util.write_csv`: `"time","a","b"`, then one line per sample.
/// Memory does not grow with the run length.
///
/// The rows are formatted and written in blocks of about [`BLOCK_VALUES`] numbers (512 rows
/// of 8 columns, 64 kB of text: one `write` each, so `out` needs no buffer of its own).
/// Formatting each row between two steps of the FMU makes the two alternate in the caches
/// and branch predictors, which cost about 5% of a run's CPU time (`scripts/bench-host.sh`);
/// a block keeps each in its own stretch, like `geardyn simulate` that formats after the
/// whole run.
///
/// The pending rows live in shared memory: when `geardyn run` forks the process that runs
/// the FMU, the parent's copy of the writer sees the child's rows, and if the child dies,
/// [`CsvWriter::complete_after_writer_died`] writes them. Nothing is written on drop (a
/// parent's copy must not write what the child already wrote): call [`CsvWriter::flush`].
pub struct CsvWriter<W: std::io::Write> {
    out: W,
    /// The text of a block, written to `out` at once.
    text: String,
    block: Block,
    /// Variables in the header (after the time): no row may be longer.
    columns: usize,
}

/// An output that can be cut back to a length, so that a block left half-written by a
/// process that died is replaced by the whole block. A stream (stdout) cannot be cut back,
/// and keeps what reached it.
pub trait CutBack: std::io::Write {
    fn cut_back_to(&mut self, bytes: u64) -> std::io::Result<()>;
}

impl CutBack for std::fs::File {
    fn cut_back_to(&mut self, bytes: u64) -> std::io::Result<()> {
        use std::io::Seek as _;
        self.set_len(bytes)?;
        self.seek(std::io::SeekFrom::Start(bytes)).map(|_| ())
    }
}

impl CutBack for std::io::Stdout {
    fn cut_back_to(&mut self, _bytes: u64) -> std::io::Result<()> {
        Ok(())
    }
}

impl<C: CutBack + ?Sized> CutBack for Box<C> {
    fn cut_back_to(&mut self, bytes: u64) -> std::io::Result<()> {
        (**self).cut_back_to(bytes)
    }
}

impl CutBack for Vec<u8> {
    fn cut_back_to(&mut self, bytes: u64) -> std::io::Result<()> {
        self.truncate(usize::try_from(bytes).unwrap_or(usize::MAX));
        Ok(())
    }
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
        let mut block = Block::new(1 + names.len())?;
        out.write_all(text.as_bytes())?;
        block.state_mut().bytes_written = text.len() as u64;
        Ok(CsvWriter {
            out,
            text,
            block,
            columns: names.len(),
        })
    }

    /// Take one row; it is written with its block (at the latest by [`Self::flush`]).
    pub fn row(&mut self, t: f64, row: &Row) -> std::io::Result<()> {
        let shape = [row.reals.len(), row.integers.len(), row.booleans.len()];
        let row_len = 1 + shape[0] + shape[1] + shape[2];
        if row_len - 1 > self.columns {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!(
                    "a row of {} values at t = {t} is longer than the header's {} variables",
                    row_len - 1,
                    self.columns
                ),
            ));
        }
        if shape != self.block.state().shape {
            self.write_block()?;
            self.block.state_mut().shape = shape;
        }
        self.block.push(t, row);
        if self.block.state().len + row_len > BLOCK_VALUES {
            self.write_block()?;
        }
        Ok(())
    }

    /// Format the rows held and write them.
    fn write_block(&mut self) -> std::io::Result<()> {
        let state = self.block.state();
        let (shape, len) = (state.shape, state.len);
        if len == 0 {
            return Ok(());
        }
        let row_len = 1 + shape.iter().sum::<usize>();
        let values = self.block.values();
        let last_time = values[len - row_len];
        self.text.clear();
        format_rows(&mut self.text, shape, values);
        self.out.write_all(self.text.as_bytes())?;
        // The bookkeeping follows the write: if the process dies during the write, the parent
        // cuts the file back to `bytes_written` and writes the rows still held, each once. Only
        // a SIGKILL from the parent (after a second interrupt, or 0.9 s without a step) landing
        // exactly between the stores of `bytes_written` and `len` below would repeat the block.
        let state = self.block.state_mut();
        state.bytes_written += self.text.len() as u64;
        state.rows_written += (len / row_len) as u64;
        state.last_time_written = last_time;
        state.len = 0;
        Ok(())
    }

    /// Rows written so far and the time of the last one.
    pub fn written(&self) -> (usize, Option<f64>) {
        let state = self.block.state();
        let last = state.last_time_written;
        (
            state.rows_written as usize,
            (!last.is_nan()).then_some(last),
        )
    }

    /// Write the rows taken so far and flush the output.
    pub fn flush(&mut self) -> std::io::Result<()> {
        self.write_block()?;
        self.out.flush()
    }
}

impl<W: CutBack> CsvWriter<W> {
    /// In the parent of the process that wrote through this writer (a copy made by `fork`,
    /// sharing the pending rows), after that process died: cut the output back to the whole
    /// blocks it wrote, then write the rows it had taken but not yet written.
    pub fn complete_after_writer_died(&mut self) -> std::io::Result<()> {
        let bytes = self.block.state().bytes_written;
        self.out.cut_back_to(bytes)?;
        self.flush()
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

        // Nothing is written on drop: a forked parent's copy must not repeat the child's rows.
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
        assert_eq!(String::from_utf8(out).unwrap(), "\"time\",\"x\"\n");
        // A row longer than the header is refused, naming both lengths.
        let mut csv = CsvWriter::new(Vec::new(), &names[..1]).unwrap();
        let e = csv.row(
            0.5,
            &Row {
                reals: &[1.0, 2.0],
                integers: &[],
                booleans: &[],
            },
        );
        assert!(e.unwrap_err().to_string().contains("2 values at t = 0.5"));
    }

    /// After the writing process died in the middle of a block, the output is cut back to
    /// the whole blocks and the pending rows are written once.
    #[test]
    fn completion_after_the_writer_died_cuts_back_and_writes_pending_rows() {
        let names = ["x".to_string()];
        let mut csv = CsvWriter::new(Vec::new(), &names).unwrap();
        let mut expected = String::from("\"time\",\"x\"\n");
        for k in 0..3000 {
            let t = k as f64;
            csv.row(
                t,
                &Row {
                    reals: &[-t],
                    integers: &[],
                    booleans: &[],
                },
            )
            .unwrap();
            expected += &format!("{},{}\n", format_real(t), format_real(-t));
        }
        let (rows, _) = csv.written();
        assert!(rows > 0 && rows < 3000, "{rows}");
        // The start of a block that a killed process did not finish writing.
        let pending = &expected.lines().nth(1 + rows).unwrap()[..4];
        csv.out.extend_from_slice(pending.as_bytes());
        csv.complete_after_writer_died().unwrap();
        assert_eq!(String::from_utf8(csv.out.clone()).unwrap(), expected);
        assert_eq!(csv.written(), (3000, Some(2999.0)));
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
