//! File output: CSV tables (a header of column names, then one row of full-precision doubles
//! per line) and text (SVG plots).
//!
//! Every file is written to a temporary sibling and renamed into place, so a failed run never
//! leaves a partial file behind.

use std::fs;
use std::io::{BufWriter, Write};
use std::path::Path;

/// Writes a table with a `time` column first, then `names`, to `path` atomically.
pub fn write_csv(
    path: &Path,
    names: &[&str],
    times: &[f64],
    rows: &[impl AsRef<[f64]>],
) -> Result<(), String> {
    let columns: Vec<&str> = std::iter::once("time")
        .chain(names.iter().copied())
        .collect();
    write_table(
        path,
        &columns,
        times
            .iter()
            .zip(rows)
            .map(|(&t, row)| std::iter::once(t).chain(row.as_ref().iter().copied())),
    )
}

/// Writes `columns` and `rows` (no implicit `time` column) to `path` atomically.
pub fn write_table<R: IntoIterator<Item = f64>>(
    path: &Path,
    columns: &[&str],
    rows: impl IntoIterator<Item = R>,
) -> Result<(), String> {
    write_atomic(path, |w| {
        writeln!(w, "{}", columns.join(","))?;
        for row in rows {
            for (i, v) in row.into_iter().enumerate() {
                // `{:?}` prints the shortest representation that round-trips exactly.
                let sep = if i == 0 { "" } else { "," };
                write!(w, "{sep}{v:?}")?;
            }
            writeln!(w)?;
        }
        Ok(())
    })
}

/// Writes text (e.g. an SVG plot) atomically.
pub fn write_text(path: &Path, text: &str) -> Result<(), String> {
    write_atomic(path, |w| w.write_all(text.as_bytes()))
}

/// Writes through a temporary sibling renamed into place, so a failure leaves no partial file.
fn write_atomic(
    path: &Path,
    body: impl FnOnce(&mut BufWriter<fs::File>) -> std::io::Result<()>,
) -> Result<(), String> {
    let file_name = path
        .file_name()
        .ok_or_else(|| format!("output path '{}' names no file", path.display()))?;
    let tmp = path.with_file_name(format!(".{}.partial", file_name.to_string_lossy()));
    let result = (|| -> std::io::Result<()> {
        let mut w = BufWriter::new(fs::File::create(&tmp)?);
        body(&mut w)?;
        w.flush()?;
        drop(w);
        fs::rename(&tmp, path)
    })();
    result.map_err(|e| {
        let _ = fs::remove_file(&tmp);
        format!("cannot write '{}': {e}", path.display())
    })
}
