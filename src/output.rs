//! CSV output: `time` first, then the outputs by name, full double precision.
//!
//! The file is written to a temporary sibling and renamed into place, so a failed run never
//! leaves a partial CSV behind.

use std::fs;
use std::io::{BufWriter, Write};
use std::path::Path;

/// Writes a table with a `time` column to `path` atomically.
pub fn write_csv(
    path: &Path,
    names: &[&str],
    times: &[f64],
    rows: &[impl AsRef<[f64]>],
) -> Result<(), String> {
    let file_name = path
        .file_name()
        .ok_or_else(|| format!("output path '{}' names no file", path.display()))?;
    let tmp = path.with_file_name(format!(".{}.partial", file_name.to_string_lossy()));
    let result = (|| -> std::io::Result<()> {
        let mut w = BufWriter::new(fs::File::create(&tmp)?);
        write!(w, "time")?;
        for name in names {
            write!(w, ",{name}")?;
        }
        writeln!(w)?;
        for (t, row) in times.iter().zip(rows) {
            // `{:?}` prints the shortest representation that round-trips exactly.
            write!(w, "{t:?}")?;
            for v in row.as_ref() {
                write!(w, ",{v:?}")?;
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
