//! File output: CSV tables (a header of column names, then one row of full-precision doubles
//! per line) and text (SVG plots).
//!
//! Every file is written to a temporary sibling and renamed into place, so a failed run never
//! leaves a partial file behind. Tables are streamed: [`CsvWriter`] writes each row as it is
//! given, so a long run needs memory for one buffer, not for its whole result.

use std::fs;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Writes `columns` and `rows` (no implicit `time` column) to `path` atomically.
pub fn write_table<R: IntoIterator<Item = f64>>(
    path: &Path,
    columns: &[impl AsRef<str>],
    rows: impl IntoIterator<Item = R>,
) -> Result<(), String> {
    let columns: Vec<&str> = columns.iter().map(AsRef::as_ref).collect();
    let mut w = CsvWriter::create(path, &columns)?;
    for row in rows {
        w.row(row)?;
    }
    w.finish()
}

/// [`write_table`] with each column's unit in the header when `units` is set (`dte [m]`,
/// the `--units` option; [`crate::units::with_units`]).
pub fn write_table_with_units<R: IntoIterator<Item = f64>>(
    path: &Path,
    columns: &[impl AsRef<str>],
    rows: impl IntoIterator<Item = R>,
    units: bool,
) -> Result<(), String> {
    if units {
        write_table(path, &crate::units::with_units(columns)?, rows)
    } else {
        write_table(path, columns, rows)
    }
}

/// Writes text (a report) atomically.
pub fn write_text(path: &Path, text: &str) -> Result<(), String> {
    write_bytes(path, text.as_bytes())
}

/// Writes bytes (an image) atomically.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), String> {
    let mut f = AtomicFile::create(path)?;
    let written = f.writer().write_all(bytes);
    f.check(written)?;
    f.commit()
}

/// Bytes of the CSV writer's buffer: large enough that the write system call is rare next to
/// the formatting of the rows, small enough to be irrelevant to the memory of a run.
const BUFFER_BYTES: usize = 64 * 1024;

/// A file being written through a temporary sibling `.<name>.partial`: [`AtomicFile::commit`]
/// renames it into place; dropping it uncommitted (an error, a panic unwinding) removes it,
/// so no path ever holds a partial result.
///
/// A destination that exists and is not a regular file (`/dev/stdout`, `/dev/null`, a named
/// pipe) is written in place as a stream: renaming onto it would replace the device node or
/// the pipe by a regular file (issue 34), and a stream cannot hold a partial file anyway.
struct AtomicFile {
    path: PathBuf,
    /// The temporary sibling; `None` for a stream written in place.
    tmp: Option<PathBuf>,
    w: Option<BufWriter<fs::File>>,
}

/// Whether `path` exists and is something else than a regular file (after symlinks): a
/// character device, a pipe or a socket.
fn is_stream(path: &Path) -> bool {
    fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir())
}

impl AtomicFile {
    fn create(path: &Path) -> Result<AtomicFile, String> {
        if is_stream(path) {
            let file = fs::OpenOptions::new()
                .write(true)
                .open(path)
                .map_err(|e| format!("cannot write '{}': {e}", path.display()))?;
            return Ok(AtomicFile {
                path: path.to_path_buf(),
                tmp: None,
                w: Some(BufWriter::with_capacity(BUFFER_BYTES, file)),
            });
        }
        let file_name = path
            .file_name()
            .ok_or_else(|| format!("output path '{}' names no file", path.display()))?;
        let tmp = path.with_file_name(format!(".{}.partial", file_name.to_string_lossy()));
        let file = fs::File::create(&tmp)
            .map_err(|e| format!("cannot write '{}': {e}", path.display()))?;
        Ok(AtomicFile {
            path: path.to_path_buf(),
            tmp: Some(tmp),
            w: Some(BufWriter::with_capacity(BUFFER_BYTES, file)),
        })
    }

    fn writer(&mut self) -> &mut BufWriter<fs::File> {
        self.w.as_mut().expect("writer is open until commit")
    }

    /// Maps an I/O error to the message naming the destination.
    fn check(&self, r: std::io::Result<()>) -> Result<(), String> {
        r.map_err(|e| format!("cannot write '{}': {e}", self.path.display()))
    }

    fn commit(mut self) -> Result<(), String> {
        let w = self.w.take().expect("committed once");
        let done = w.into_inner().map_err(|e| e.into_error()).and_then(|f| {
            drop(f);
            match &self.tmp {
                Some(tmp) => fs::rename(tmp, &self.path),
                None => Ok(()),
            }
        });
        self.check(done)
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        let Some(tmp) = &self.tmp else {
            return;
        };
        if self.w.take().is_some() || tmp.exists() {
            let _ = fs::remove_file(tmp);
        }
    }
}

/// A CSV table written row by row to its atomic file: the rows are formatted into a fixed
/// buffer as they come, so memory stays flat in the number of rows.
pub struct CsvWriter {
    file: AtomicFile,
    rows: u64,
    peak_buffered: usize,
}

impl CsvWriter {
    /// Creates the temporary file and writes the header.
    pub fn create(path: &Path, columns: &[&str]) -> Result<CsvWriter, String> {
        let mut file = AtomicFile::create(path)?;
        let header = writeln!(file.writer(), "{}", columns.join(","));
        file.check(header)?;
        Ok(CsvWriter {
            file,
            rows: 0,
            peak_buffered: 0,
        })
    }

    /// Appends one row.
    pub fn row(&mut self, values: impl IntoIterator<Item = f64>) -> Result<(), String> {
        let w = self.file.writer();
        let line = || -> std::io::Result<()> {
            for (i, v) in values.into_iter().enumerate() {
                // `{:?}` prints the shortest representation that round-trips exactly.
                let sep = if i == 0 { "" } else { "," };
                write!(w, "{sep}{v:?}")?;
            }
            writeln!(w)
        };
        let written = line();
        self.peak_buffered = self.peak_buffered.max(self.file.writer().buffer().len());
        self.file.check(written)?;
        self.rows += 1;
        Ok(())
    }

    /// Rows written so far.
    pub fn rows(&self) -> u64 {
        self.rows
    }

    /// The most bytes the writer held in memory at once: bounded by its buffer, whatever the
    /// number of rows (the property `tests/simulate_memory.rs` checks).
    pub fn peak_buffered_bytes(&self) -> usize {
        self.peak_buffered
    }

    /// Flushes and renames the file into place.
    pub fn finish(self) -> Result<(), String> {
        self.file.commit()
    }
}
