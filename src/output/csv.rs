//! Time series as CSV: one header line of column names, then one line per row of numbers.

use std::io::Write;
use std::path::{Path, PathBuf};

use super::write_atomically;
use crate::error::{Error, Result};

/// A table of f64 rows under fixed column names, written atomically as CSV.
#[derive(Debug, Clone, PartialEq)]
pub struct CsvSeries {
    path: PathBuf,
    columns: Vec<String>,
    rows: Vec<Vec<f64>>,
}

impl CsvSeries {
    /// A series with these columns, to be written at `path`.
    pub fn new(path: impl Into<PathBuf>, columns: Vec<String>) -> Result<Self> {
        if columns.is_empty() {
            return Err(Error::invalid_parameter(
                "columns",
                0,
                "need at least one column",
            ));
        }
        Ok(CsvSeries {
            path: path.into(),
            columns,
            rows: Vec::new(),
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

    /// Rows so far.
    pub fn rows(&self) -> &[Vec<f64>] {
        &self.rows
    }

    /// Appends one row (one value per column; NaN is written as `nan`).
    pub fn push(&mut self, row: &[f64]) -> Result<()> {
        if row.len() != self.columns.len() {
            return Err(Error::invalid_parameter(
                "CSV row",
                format!("{} values", row.len()),
                format!("must have one value per column ({})", self.columns.len()),
            ));
        }
        self.rows.push(row.to_vec());
        Ok(())
    }

    /// Writes the whole table (atomically); call it at the end of a run or whenever a
    /// consistent snapshot on disk is wanted.
    pub fn write(&self) -> Result<()> {
        write_atomically(&self.path, |out: &mut dyn Write| {
            let header: Vec<String> = self.columns.iter().map(|c| csv_field(c)).collect();
            writeln!(out, "{}", header.join(","))?;
            for row in &self.rows {
                let line: Vec<String> = row.iter().map(|v| format!("{v:e}")).collect();
                writeln!(out, "{}", line.join(","))?;
            }
            Ok(())
        })
    }
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}
