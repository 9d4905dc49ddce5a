//! "Files are written atomically": a write that fails part-way leaves the previous content of the
//! file intact and no temporary file behind. (Tests run as root, for whom read-only permissions
//! are not enforced, so the failures here are ones that happen for root too.)

use std::io::Write;
use std::path::{Path, PathBuf};

use tetfem::post::output::write_atomically;

fn folder(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("atomic-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn temporaries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".tmp-"))
        .collect()
}

const OLD: &str = "<VTKFile>the complete previous frame</VTKFile>\n";

/// The writer fails after writing half of the new content (a full disk, a failed field
/// computation): the file keeps its old content, whole.
#[test]
fn a_write_that_fails_midway_keeps_the_old_content() {
    let dir = folder("midway");
    let path = dir.join("frame.vtu");
    write_atomically(&path, |out: &mut dyn Write| out.write_all(OLD.as_bytes())).unwrap();
    let failed = write_atomically(&path, |out: &mut dyn Write| {
        out.write_all(b"<VTKFile>half of a new fr")?;
        out.flush()?;
        Err(std::io::Error::other("disk full"))
    });
    assert!(
        matches!(failed, Err(tetfem::Error::Io { .. })),
        "{failed:?}"
    );
    assert_eq!(std::fs::read_to_string(&path).unwrap(), OLD);
    assert!(temporaries(&dir).is_empty(), "{:?}", temporaries(&dir));
}

/// The final rename fails (the target is a directory that is not empty): nothing in it changes
/// and the temporary file, fully written by then, is removed.
#[test]
fn a_failed_rename_leaves_no_temporary_file() {
    let dir = folder("rename");
    let target = dir.join("frame.vtu");
    std::fs::create_dir_all(&target).unwrap();
    std::fs::write(target.join("inside.txt"), OLD).unwrap();
    let failed = write_atomically(&target, |out: &mut dyn Write| out.write_all(b"new"));
    assert!(
        matches!(failed, Err(tetfem::Error::Io { .. })),
        "{failed:?}"
    );
    assert!(target.is_dir());
    assert_eq!(
        std::fs::read_to_string(target.join("inside.txt")).unwrap(),
        OLD
    );
    assert!(temporaries(&dir).is_empty(), "{:?}", temporaries(&dir));
}

/// A path whose parent is a regular file: an error naming the path, the file untouched.
#[test]
fn a_parent_that_is_a_file_is_an_error_and_the_file_is_untouched() {
    let dir = folder("parent");
    let parent = dir.join("not_a_folder");
    std::fs::write(&parent, OLD).unwrap();
    let failed = write_atomically(&parent.join("frame.vtu"), |out: &mut dyn Write| {
        out.write_all(b"new")
    });
    match failed {
        Err(tetfem::Error::Io { path, .. }) => assert!(path.starts_with(&parent), "{path:?}"),
        other => panic!("expected an Io error, got {other:?}"),
    }
    assert_eq!(std::fs::read_to_string(&parent).unwrap(), OLD);
    assert!(temporaries(&dir).is_empty(), "{:?}", temporaries(&dir));
}
