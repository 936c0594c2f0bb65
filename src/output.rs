//! CSV output: a header of column names, then one row of full-precision doubles per line.
//!
//! The file is written to a temporary sibling and renamed into place, so a failed run never
//! leaves a partial CSV behind.

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

/// Writes `columns` and `rows` to `path` atomically.
pub fn write_table<R: IntoIterator<Item = f64>>(
    path: &Path,
    columns: &[&str],
    rows: impl IntoIterator<Item = R>,
) -> Result<(), String> {
    let file_name = path
        .file_name()
        .ok_or_else(|| format!("output path '{}' names no file", path.display()))?;
    let tmp = path.with_file_name(format!(".{}.partial", file_name.to_string_lossy()));
    let result = (|| -> std::io::Result<()> {
        let mut w = BufWriter::new(fs::File::create(&tmp)?);
        writeln!(w, "{}", columns.join(","))?;
        for row in rows {
            for (i, v) in row.into_iter().enumerate() {
                // `{:?}` prints the shortest representation that round-trips exactly.
                let sep = if i == 0 { "" } else { "," };
                write!(w, "{sep}{v:?}")?;
            }
            writeln!(w)?;
        }
        w.flush()?;
        drop(w);
        fs::rename(&tmp, path)
    })();
    result.map_err(|e| {
        let _ = fs::remove_file(&tmp);
        format!("cannot write '{}': {e}", path.display())
    })
}
