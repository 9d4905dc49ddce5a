//! Line-oriented tokenizing for the ASCII mesh formats, with 1-based line numbers in every
//! error.

use std::path::Path;
use std::str::FromStr;

use crate::base::error::{Error, Result};

/// The bytes of a mesh file, which must be a regular file (see
/// [`crate::base::input_file::read_regular_file`]).
pub(crate) fn read_regular_file(path: &Path) -> Result<Vec<u8>> {
    crate::base::input_file::read_regular_file(path, "a mesh")
}

/// Decodes a whole file as UTF-8, or names the line of the first invalid byte.
pub(crate) fn decode<'a>(path: &Path, bytes: &'a [u8]) -> Result<&'a str> {
    std::str::from_utf8(bytes).map_err(|e| {
        let line = line_of_offset(bytes, e.valid_up_to());
        Error::parse(path, line, "the file is not valid UTF-8 text")
    })
}

/// 1-based line number of byte `offset` in `bytes`.
pub(crate) fn line_of_offset(bytes: &[u8], offset: usize) -> usize {
    let end = offset.min(bytes.len());
    1 + bytes[..end].iter().filter(|&&b| b == b'\n').count()
}

/// The non-blank lines of a text, split into whitespace-separated fields; with a comment
/// character, everything from it to the end of the line is ignored (TetGen's `#`).
pub(crate) struct Records<'a> {
    path: &'a Path,
    lines: std::iter::Enumerate<std::str::Lines<'a>>,
    comment: Option<char>,
    last_line: usize,
}

/// One record: its line number and fields.
pub(crate) struct Record<'a> {
    path: &'a Path,
    /// 1-based line number.
    pub line: usize,
    /// The whole line, comment stripped and trimmed.
    pub text: &'a str,
    /// Whitespace-separated fields.
    pub fields: Vec<&'a str>,
}

impl<'a> Records<'a> {
    /// Records of `text`, read from `path` (named in errors).
    pub fn new(path: &'a Path, text: &'a str, comment: Option<char>) -> Self {
        Records {
            path,
            lines: text.lines().enumerate(),
            comment,
            last_line: 0,
        }
    }

    /// The next non-blank record, or `None` at the end of the text.
    pub fn try_next(&mut self) -> Option<Record<'a>> {
        for (index, raw) in self.lines.by_ref() {
            let text = match self.comment {
                Some(c) => raw.split(c).next().unwrap_or(""),
                None => raw,
            }
            .trim();
            self.last_line = index + 1;
            if !text.is_empty() {
                return Some(Record {
                    path: self.path,
                    line: index + 1,
                    text,
                    fields: text.split_whitespace().collect(),
                });
            }
        }
        None
    }

    /// The next non-blank record; at the end of the text, an error saying the file is truncated
    /// and what was expected.
    pub fn next(&mut self, expected: &str) -> Result<Record<'a>> {
        self.try_next().ok_or_else(|| {
            Error::parse(
                self.path,
                self.last_line + 1,
                format!("unexpected end of file: the file is truncated (expected {expected})"),
            )
        })
    }

    /// An error at the last record's line.
    pub fn error(&self, message: impl Into<String>) -> Error {
        Error::parse(self.path, self.last_line, message)
    }
}

impl<'a> Record<'a> {
    /// An error at this record's line.
    pub fn error(&self, message: impl Into<String>) -> Error {
        Error::parse(self.path, self.line, message)
    }

    /// Field `i` (0-based), or an error naming what was expected there.
    pub fn field(&self, i: usize, what: &str) -> Result<&'a str> {
        self.fields.get(i).copied().ok_or_else(|| {
            self.error(format!(
                "expected {what} in field {} but the line has only {} field(s)",
                i + 1,
                self.fields.len()
            ))
        })
    }

    /// Field `i` parsed as a number of type `T`.
    pub fn number<T: FromStr>(&self, i: usize, what: &str) -> Result<T> {
        let text = self.field(i, what)?;
        text.parse().map_err(|_| {
            self.error(format!(
                "field {} ({what}) is not a valid {}: '{text}'",
                i + 1,
                std::any::type_name::<T>()
            ))
        })
    }

    /// Field `i` as a finite f64.
    pub fn finite(&self, i: usize, what: &str) -> Result<f64> {
        let value: f64 = self.number(i, what)?;
        if value.is_finite() {
            Ok(value)
        } else {
            Err(self.error(format!("field {} ({what}) is not finite: {value}", i + 1)))
        }
    }

    /// The text after the first `n` fields, trimmed (e.g. a name with spaces).
    pub fn rest_after(&self, n: usize) -> &'a str {
        let mut rest = self.text;
        for _ in 0..n {
            rest = rest.trim_start();
            let end = rest.find(char::is_whitespace).unwrap_or(rest.len());
            rest = &rest[end..];
        }
        rest.trim()
    }

    /// Checks that the record has at least `count` fields.
    pub fn expect_at_least(&self, count: usize, what: &str) -> Result<()> {
        if self.fields.len() < count {
            return Err(self.error(format!(
                "expected {count} fields ({what}), found {}",
                self.fields.len()
            )));
        }
        Ok(())
    }
}
