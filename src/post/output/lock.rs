//! One run per output folder: a lock file `.tetfem.lock` in the folder holds the PID of the run
//! that writes there, under an operating-system file lock (`flock`), so that a second run into
//! the same folder stops with [`Error::OutputLocked`] instead of mixing its frames with the
//! first run's.
//!
//! The OS drops the file lock when its process dies, however it dies (SIGKILL, abort), so a lock
//! file left by a killed run is recognised as stale — nobody holds it — and taken over, with a
//! warning. Taking the lock also removes the stale temporary files (`*.tmp-<pid>`, see
//! [`write_atomically`](super::write_atomically)) that a killed run left in the folder: while
//! the lock is held, no other run writes there, so every such file is a leftover.

use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use crate::base::error::{Error, Result};

/// Name of the lock file inside an output folder.
pub const LOCK_FILE_NAME: &str = ".tetfem.lock";

/// Lock files held by this process, so that a signal handler about to exit the process can
/// remove them ([`remove_held_lock_files`]).
static HELD: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// The right to write into one output folder, held until dropped (which removes the lock file).
#[derive(Debug)]
pub struct OutputLock {
    path: PathBuf,
    file: Option<File>,
    stale_pid: Option<String>,
    removed_temporaries: Vec<PathBuf>,
    /// The folders `acquire` created, innermost first: removed again when the run leaves them
    /// empty (a run stopped by bad input before it wrote anything leaves no folder behind).
    created_directories: Vec<PathBuf>,
}

impl OutputLock {
    /// Takes the lock of `directory` (created if missing): fails with [`Error::OutputLocked`]
    /// naming the PID of the run that holds it, takes over (see [`Self::warning`]) a lock file
    /// whose run is gone, and removes the stale `*.tmp-<digits>` files of the folder. Cheap:
    /// take it before any expensive work.
    pub fn acquire(directory: &Path) -> Result<OutputLock> {
        let path = directory.join(LOCK_FILE_NAME);
        let io_error = |path: &Path| {
            let path = path.to_path_buf();
            move |source| Error::Io { path, source }
        };
        let created_directories: Vec<PathBuf> = directory
            .ancestors()
            .take_while(|d| !d.as_os_str().is_empty() && !d.exists())
            .map(Path::to_path_buf)
            .collect();
        // The nearest existing ancestor must be a folder: `create_dir_all` would say only
        // "File exists" or "Not a directory".
        if let Some(file) = directory
            .ancestors()
            .find(|d| !d.as_os_str().is_empty() && d.exists())
            .filter(|d| !d.is_dir())
        {
            return Err(Error::Io {
                path: file.to_path_buf(),
                source: std::io::Error::new(
                    std::io::ErrorKind::NotADirectory,
                    format!(
                        "the output folder {} cannot be made: this path is a file, not a folder; choose another output folder",
                        directory.display()
                    ),
                ),
            });
        }
        std::fs::create_dir_all(directory).map_err(io_error(directory))?;
        // A run releasing its lock removes the file before unlocking it, so a run that opened
        // the file just before may lock a file that no longer has a name; then it tries again.
        for _ in 0..100 {
            let mut file = OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .open(&path)
                .map_err(io_error(&path))?;
            match file.try_lock() {
                Ok(()) => {}
                Err(TryLockError::WouldBlock) => {
                    return Err(Error::OutputLocked {
                        directory: directory.to_path_buf(),
                        lock_file: path.clone(),
                        pid: read_pid(&mut file),
                    });
                }
                Err(TryLockError::Error(source)) => return Err(Error::Io { path, source }),
            }
            if !names_this_file(&path, &file) {
                continue;
            }
            // Locked and still named: whoever wrote a PID here is gone (else it would hold the
            // lock), so the file is stale.
            let stale_pid = read_pid(&mut file);
            (|| {
                file.set_len(0)?;
                file.seek(SeekFrom::Start(0))?;
                writeln!(file, "{}", std::process::id())?;
                file.flush()
            })()
            .map_err(io_error(&path))?;
            if let Ok(mut held) = HELD.lock() {
                held.push(path.clone());
            }
            let mut lock = OutputLock {
                path,
                file: Some(file),
                stale_pid,
                removed_temporaries: Vec::new(),
                created_directories,
            };
            lock.removed_temporaries = remove_stale_temporaries(directory)?;
            return Ok(lock);
        }
        Err(Error::Io {
            path,
            source: std::io::Error::other(
                "the lock file keeps being removed while it is being taken (another run is starting and stopping here)",
            ),
        })
    }

    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The PID (as written in the lock file) of a run that died holding this folder, whose
    /// lock this one took over.
    pub fn stale_pid(&self) -> Option<&str> {
        self.stale_pid.as_deref()
    }

    /// The temporary files of a killed run that were removed when the lock was taken.
    pub fn removed_temporaries(&self) -> &[PathBuf] {
        &self.removed_temporaries
    }

    /// A sentence for the run's warnings when a stale lock was taken over, else `None`.
    pub fn warning(&self) -> Option<String> {
        let pid = self.stale_pid.as_ref()?;
        Some(format!(
            "{}: took over the lock of process {pid}, which is gone (a killed run); removed {} temporary file(s) it left",
            self.path.display(),
            self.removed_temporaries.len()
        ))
    }
}

impl Drop for OutputLock {
    fn drop(&mut self) {
        // Remove the name first, then unlock (closing the file): see `acquire`.
        let _ = std::fs::remove_file(&self.path);
        if let Ok(mut held) = HELD.lock() {
            held.retain(|p| p != &self.path);
        }
        self.file.take();
        // `remove_dir` fails on a folder that holds anything, so only empty ones go.
        for directory in &self.created_directories {
            if std::fs::remove_dir(directory).is_err() {
                break;
            }
        }
    }
}

/// Removes the lock files this process holds. For a signal handler that is about to end the
/// process with [`std::process::exit`], which runs no destructors: without it the next run
/// would find the lock file (unlocked, so it would take it over, with a warning).
pub fn remove_held_lock_files() {
    if let Ok(held) = HELD.lock() {
        for path in held.iter() {
            let _ = std::fs::remove_file(path);
        }
    }
}

/// The first line of the lock file, if any (the PID of the run that wrote it).
fn read_pid(file: &mut File) -> Option<String> {
    let mut text = String::new();
    file.seek(SeekFrom::Start(0)).ok()?;
    file.read_to_string(&mut text).ok()?;
    let pid = text.lines().next()?.trim();
    (!pid.is_empty()).then(|| pid.to_string())
}

/// Whether `path` still names the open `file` (same device and inode).
#[cfg(unix)]
fn names_this_file(path: &Path, file: &File) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (std::fs::metadata(path), file.metadata()) {
        (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
        _ => false,
    }
}

#[cfg(not(unix))]
fn names_this_file(path: &Path, _file: &File) -> bool {
    path.exists()
}

/// Removes the regular files of `directory` named `<anything>.tmp-<digits>`.
fn remove_stale_temporaries(directory: &Path) -> Result<Vec<PathBuf>> {
    let entries = std::fs::read_dir(directory).map_err(|source| Error::Io {
        path: directory.to_path_buf(),
        source,
    })?;
    let mut removed = Vec::new();
    for entry in entries.flatten() {
        let name = entry.file_name();
        let is_temporary = name
            .to_str()
            .and_then(|n| n.rsplit_once(".tmp-"))
            .is_some_and(|(stem, pid)| {
                !stem.is_empty() && !pid.is_empty() && pid.bytes().all(|b| b.is_ascii_digit())
            });
        if is_temporary && entry.file_type().is_ok_and(|t| t.is_file()) {
            let path = entry.path();
            std::fs::remove_file(&path).map_err(|source| Error::Io {
                path: path.clone(),
                source,
            })?;
            removed.push(path);
        }
    }
    Ok(removed)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn folder(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("tetfem-lock-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        dir
    }

    #[test]
    fn a_second_lock_on_the_same_folder_fails_naming_the_holder() {
        let dir = folder("second");
        let first = OutputLock::acquire(&dir).unwrap();
        let pid = std::process::id().to_string();
        assert_eq!(std::fs::read_to_string(first.path()).unwrap().trim(), pid);
        match OutputLock::acquire(&dir) {
            Err(Error::OutputLocked { pid: Some(p), .. }) => assert_eq!(p, pid),
            other => panic!("expected OutputLocked, got {other:?}"),
        }
        drop(first);
        assert!(!dir.join(LOCK_FILE_NAME).exists());
        let again = OutputLock::acquire(&dir).unwrap();
        assert!(again.stale_pid().is_none() && again.warning().is_none());
    }

    #[test]
    fn a_stale_lock_file_is_taken_over_and_leftovers_removed() {
        let dir = folder("stale");
        std::fs::create_dir_all(&dir).unwrap();
        // What a SIGKILLed run leaves: its lock file (no process holds the OS lock) and a
        // temporary file it was writing.
        std::fs::write(dir.join(LOCK_FILE_NAME), "4194999\n").unwrap();
        std::fs::write(dir.join("run_0010.vtu.tmp-4194999"), "<VTKFile").unwrap();
        std::fs::write(dir.join("notes.tmp-x"), "kept: not a temporary name").unwrap();
        let lock = OutputLock::acquire(&dir).unwrap();
        assert_eq!(lock.stale_pid(), Some("4194999"));
        assert!(lock.warning().unwrap().contains("4194999"));
        assert_eq!(lock.removed_temporaries().len(), 1);
        assert!(!dir.join("run_0010.vtu.tmp-4194999").exists());
        assert!(dir.join("notes.tmp-x").exists());
    }
}
