//! Time series as CSV, streamed: one header line of column names, then one line per row of
//! numbers, appended as a run goes so that memory stays flat and an interrupted run keeps its
//! rows.

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};

use crate::base::error::{Error, Result};

/// Rows are buffered up to about this many bytes before they are written out (at a row
/// boundary), so that memory does not grow with the number of rows.
pub const CSV_BUFFER_BYTES: usize = 64 * 1024;

/// One CSV cell: an integer (a step, a count, an index: written as digits, `12`, never `1.2e1`)
/// or a number (written `{:e}`, the shortest form that reads back to the same f64; −0 is
/// written `0`, NaN `NaN`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CsvValue {
    /// An integer column's value.
    Int(i64),
    /// A real column's value.
    Real(f64),
}

impl From<f64> for CsvValue {
    fn from(value: f64) -> Self {
        CsvValue::Real(value)
    }
}

impl From<usize> for CsvValue {
    /// Saturates at `i64::MAX` (no step or count gets there).
    fn from(value: usize) -> Self {
        CsvValue::Int(i64::try_from(value).unwrap_or(i64::MAX))
    }
}

/// A CSV file of rows under fixed column names, written as it grows.
///
/// [`CsvSeries::new`] creates (truncates) the file and writes the header; [`push`](Self::push)
/// formats a row into an in-memory buffer; the buffer goes to the file only whole, at row
/// boundaries: when it exceeds [`CSV_BUFFER_BYTES`], on [`write`](Self::write) (a flush), and
/// on drop. So the file always ends with the last row of the last flush, complete — unless the
/// process dies or the disk fills during a flush's single `write`, which can leave a partial
/// last line beyond the rows of the previous flush. Memory: at most one buffer, whatever the
/// number of rows.
#[derive(Debug)]
pub struct CsvSeries {
    path: PathBuf,
    columns: Vec<String>,
    file: Option<File>,
    buffer: Vec<u8>,
    rows: usize,
}

impl CsvSeries {
    /// Creates (or truncates) the CSV file at `path`, its folder too if missing, and writes the
    /// header of these columns. Errors: no column, or the file cannot be created.
    pub fn new(path: impl Into<PathBuf>, columns: Vec<String>) -> Result<Self> {
        let path = path.into();
        if columns.is_empty() {
            return Err(Error::invalid_parameter(
                "columns",
                0,
                "need at least one column",
            ));
        }
        let io_error = |source| Error::Io {
            path: path.clone(),
            source,
        };
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(io_error)?;
        }
        let file = File::create(&path).map_err(io_error)?;
        let header: Vec<String> = columns.iter().map(|c| csv_field(c)).collect();
        let mut series = CsvSeries {
            path,
            columns,
            file: Some(file),
            buffer: Vec::with_capacity(CSV_BUFFER_BYTES),
            rows: 0,
        };
        series.buffer.extend_from_slice(header.join(",").as_bytes());
        series.buffer.push(b'\n');
        series.write()?;
        Ok(series)
    }

    /// Reopens the CSV file at `path`, written by a series of these `columns`, to continue it:
    /// keeps its header and first `rows` rows, cuts everything after them (rows a stopped run
    /// wrote later, or a partial last line) and appends from there. Errors (naming the file):
    /// it cannot be read, its header is not these columns, or it has fewer than `rows` complete
    /// rows.
    pub fn reopen(path: impl Into<PathBuf>, columns: Vec<String>, rows: usize) -> Result<Self> {
        let path = path.into();
        let io_error = |source| Error::Io {
            path: path.clone(),
            source,
        };
        let text = crate::base::input_file::read_regular_file(&path, "a CSV time series")?;
        let header: Vec<String> = columns.iter().map(|c| csv_field(c)).collect();
        let header = format!("{}\n", header.join(","));
        let parse_error = |line, message: String| Error::Parse {
            path: path.clone(),
            line,
            message,
        };
        if !text.starts_with(header.as_bytes()) {
            return Err(parse_error(
                1,
                format!(
                    "the header is not the run's columns ({})",
                    header.trim_end()
                ),
            ));
        }
        // The byte after the `rows`-th complete row.
        let mut end = header.len();
        for row in 0..rows {
            match text[end..].iter().position(|&b| b == b'\n') {
                Some(n) => end += n + 1,
                None => {
                    return Err(parse_error(
                        row + 2,
                        format!("{row} complete rows, {rows} needed"),
                    ));
                }
            }
        }
        let file = std::fs::OpenOptions::new()
            .write(true)
            .open(&path)
            .map_err(io_error)?;
        file.set_len(end as u64).map_err(io_error)?;
        let mut file = file;
        std::io::Seek::seek(&mut file, std::io::SeekFrom::End(0)).map_err(io_error)?;
        Ok(CsvSeries {
            path,
            columns,
            file: Some(file),
            buffer: Vec::with_capacity(CSV_BUFFER_BYTES),
            rows,
        })
    }

    /// The file path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Column names.
    pub fn columns(&self) -> &[String] {
        &self.columns
    }

    /// Rows pushed so far (written or still buffered).
    pub fn row_count(&self) -> usize {
        self.rows
    }

    /// Bytes of rows pushed but not yet written to the file (below [`CSV_BUFFER_BYTES`] plus
    /// one row after every push).
    pub fn buffered_bytes(&self) -> usize {
        self.buffer.len()
    }

    /// Appends one row of reals (one value per column, in `{:e}` format; −0 is written `0`,
    /// NaN `NaN`), writing the buffer out first when it is full. See [`push_values`](Self::push_values)
    /// for rows with integer columns.
    pub fn push(&mut self, row: &[f64]) -> Result<()> {
        let values: Vec<CsvValue> = row.iter().map(|&v| CsvValue::Real(v)).collect();
        self.push_values(&values)
    }

    /// Appends one row of typed values ([`CsvValue`]: integers as digits, reals in `{:e}`
    /// format with −0 written `0`), writing the buffer out first when it is full.
    pub fn push_values(&mut self, row: &[CsvValue]) -> Result<()> {
        if row.len() != self.columns.len() {
            return Err(Error::invalid_parameter(
                "CSV row",
                format!("{} values", row.len()),
                format!("must have one value per column ({})", self.columns.len()),
            ));
        }
        if self.buffer.len() >= CSV_BUFFER_BYTES {
            self.write()?;
        }
        for (i, v) in row.iter().enumerate() {
            if i > 0 {
                self.buffer.push(b',');
            }
            // Writing into a Vec cannot fail. −0 == 0, so `0.0` is written for both.
            let _ = match *v {
                CsvValue::Int(i) => write!(self.buffer, "{i}"),
                CsvValue::Real(0.0) => write!(self.buffer, "0"),
                CsvValue::Real(x) => write!(self.buffer, "{x:e}"),
            };
        }
        self.buffer.push(b'\n');
        self.rows += 1;
        Ok(())
    }

    /// Writes the buffered rows to the file (whole, in one `write_all`), so that every row
    /// pushed so far is on disk once it returns (in the OS's cache: it survives the process,
    /// not a power cut; [`finish`](Self::finish) syncs).
    pub fn write(&mut self) -> Result<()> {
        if self.buffer.is_empty() {
            return Ok(());
        }
        let Some(file) = self.file.as_mut() else {
            return Ok(());
        };
        let written = file.write_all(&self.buffer);
        // A failed write may have written part of the buffer; never write that part again.
        self.buffer.clear();
        written.map_err(|source| Error::Io {
            path: self.path.clone(),
            source,
        })
    }

    /// Writes the buffered rows and syncs the file to the disk.
    pub fn finish(mut self) -> Result<()> {
        self.write()?;
        match self.file.take() {
            Some(file) => file.sync_all().map_err(|source| Error::Io {
                path: self.path.clone(),
                source,
            }),
            None => Ok(()),
        }
    }
}

impl Drop for CsvSeries {
    /// Writes the buffered rows (a run that stops on an error keeps them); an error here has
    /// no one to go to.
    fn drop(&mut self) {
        let _ = self.write();
    }
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Memory stays flat: however many rows, the buffer never holds more than its bound plus
    /// one row, and every row ends up in the file, whole.
    #[test]
    fn the_buffer_is_bounded_and_every_row_reaches_the_file() {
        let path = std::env::temp_dir().join(format!("tetfem-csv-flat-{}.csv", std::process::id()));
        let mut csv = CsvSeries::new(&path, vec!["step".into(), "value".into()]).unwrap();
        let rows = 100_000;
        let mut largest = 0;
        for step in 0..rows {
            csv.push(&[step as f64, -1.0 / (step + 1) as f64]).unwrap();
            largest = largest.max(csv.buffered_bytes());
        }
        // One row is at most two numbers in `{:e}` (≤ 24 bytes each), a comma and a newline.
        assert!(largest <= CSV_BUFFER_BYTES + 50, "{largest}");
        assert_eq!(csv.row_count(), rows);
        csv.finish().unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let mut lines = text.lines();
        assert_eq!(lines.next(), Some("step,value"));
        for (step, line) in lines.enumerate() {
            let values: Vec<f64> = line.split(',').map(|v| v.parse().unwrap()).collect();
            assert_eq!(
                values,
                vec![step as f64, -1.0 / (step + 1) as f64],
                "{line}"
            );
        }
        assert_eq!(text.lines().count(), rows + 1);
        assert!(text.ends_with('\n'));
        let _ = std::fs::remove_file(&path);
    }

    /// A reopened series keeps the rows asked for, drops the rest (a partial line too) and
    /// continues after them; a header of other columns or too few rows are refused.
    #[test]
    fn a_reopened_series_keeps_its_first_rows_and_continues() {
        let path =
            std::env::temp_dir().join(format!("tetfem-csv-reopen-{}.csv", std::process::id()));
        let columns = || vec!["step".to_string(), "x".to_string()];
        std::fs::write(&path, "step,x\n0,1e0\n1,2e0\n2,3e0\n3,4").unwrap();
        let mut csv = CsvSeries::reopen(&path, columns(), 2).unwrap();
        assert_eq!(csv.row_count(), 2);
        csv.push(&[2.0, 5.0]).unwrap();
        csv.finish().unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert_eq!(text, "step,x\n0,1e0\n1,2e0\n2e0,5e0\n");
        let too_many = CsvSeries::reopen(&path, columns(), 4)
            .unwrap_err()
            .to_string();
        assert!(too_many.contains("3 complete rows, 4 needed"), "{too_many}");
        let other = CsvSeries::reopen(&path, vec!["t".into()], 1)
            .unwrap_err()
            .to_string();
        assert!(other.contains(":1: the header"), "{other}");
        let _ = std::fs::remove_file(&path);
    }

    /// Integer columns are digits; −0 and 0 are both `0`; reals read back exactly.
    #[test]
    fn integers_are_digits_and_negative_zero_is_zero() {
        let path =
            std::env::temp_dir().join(format!("tetfem-csv-typed-{}.csv", std::process::id()));
        let mut csv = CsvSeries::new(&path, vec!["step".into(), "x".into(), "y".into()]).unwrap();
        csv.push_values(&[0usize.into(), (-0.0).into(), 0.1.into()])
            .unwrap();
        csv.push_values(&[1000usize.into(), (-2.5e-300).into(), 0.0.into()])
            .unwrap();
        csv.push(&[-0.0, 3.0, f64::NAN]).unwrap();
        csv.finish().unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert_eq!(text, "step,x,y\n0,0,1e-1\n1000,-2.5e-300,0\n0,3e0,NaN\n");
        let _ = std::fs::remove_file(&path);
    }
}
