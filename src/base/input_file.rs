//! Reading input files safely: every file tetfem reads (a mesh, a scene, a checkpoint, the
//! `.pvd` and CSV a resume continues) goes through [`read_regular_file`], which refuses what is
//! not a regular file before opening it and reads no more than the file's size.

use std::io::Read;
use std::path::Path;

use crate::base::error::{Error, Result};

/// The bytes of the input file at `path`, which must be a regular file (a symbolic link to one
/// is followed): its size bounds everything read. A stream (a FIFO, `/dev/zero`,
/// `/dev/urandom`, a socket) has no size and may never end or never start, and a directory is
/// no file, so they are refused before the file is opened (opening a FIFO without a writer
/// blocks); a file that grows while being read is read up to the size it had when opened.
/// `what` names the input in the message ("a mesh", "a scene file", "a checkpoint").
///
/// Errors: [`Error::Parse`] naming the path (at line 0: nothing was read) for a file that is
/// not regular or larger than the memory can hold; [`Error::Io`] naming the path when it
/// cannot be opened or read.
pub fn read_regular_file(path: &Path, what: &str) -> Result<Vec<u8>> {
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    check_regular_file(path, what)?;
    let file = std::fs::File::open(path).map_err(io)?;
    let size = file.metadata().map_err(io)?.len();
    let mut bytes = Vec::new();
    bytes
        .try_reserve_exact(usize::try_from(size).unwrap_or(usize::MAX))
        .map_err(|_| {
            Error::parse(
                path,
                0,
                format!("{what} of {size} bytes is larger than the memory can hold"),
            )
        })?;
    file.take(size).read_to_end(&mut bytes).map_err(io)?;
    Ok(bytes)
}

/// [`read_regular_file`] decoded as UTF-8 text; invalid UTF-8 is an [`Error::Parse`] naming
/// the line of the first invalid byte.
pub fn read_regular_text(path: &Path, what: &str) -> Result<String> {
    let bytes = read_regular_file(path, what)?;
    String::from_utf8(bytes).map_err(|e| {
        let valid = e.utf8_error().valid_up_to();
        let line = 1 + e.as_bytes()[..valid]
            .iter()
            .filter(|&&b| b == b'\n')
            .count();
        Error::parse(
            path,
            line,
            format!("{what} must be UTF-8 text; this line is not"),
        )
    })
}

/// Refuses `path` unless it is a regular file (following symbolic links), without opening it:
/// the check [`read_regular_file`] makes, for a reader that opens the file itself (e.g. to
/// continue writing it). Errors as [`read_regular_file`]'s.
pub fn check_regular_file(path: &Path, what: &str) -> Result<()> {
    let kind = std::fs::metadata(path)
        .map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?
        .file_type();
    if kind.is_file() {
        return Ok(());
    }
    let found = if kind.is_dir() {
        "a directory"
    } else {
        "not a regular file (a FIFO, socket or device)"
    };
    Err(Error::parse(
        path,
        0,
        format!("{found}: {what} must be a regular file, whose size bounds what is read"),
    ))
}
