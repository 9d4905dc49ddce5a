//! Replays every file under `fuzz/regressions/<target>/` through the fuzz target's own body
//! (`fuzz/harness.rs`, shared with `fuzz/fuzz_targets/<target>.rs`), on the stable toolchain.
//!
//! Every input must come back without a panic. The file name says what else is expected:
//! `err-*` must be rejected with an `Err` (the crash inputs the fuzzer found, fixed since),
//! `ok-*` must be accepted; other names only must not panic. An `err-*` file may have a
//! companion `<name>.expect` holding text that the error message must contain (the culprit it
//! must name).

#[path = "../../../../fuzz/harness.rs"]
mod harness;

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};

fn inputs(target: &str) -> Vec<PathBuf> {
    let dir = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
        .join("fuzz/regressions")
        .join(target);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file() && p.extension().is_none_or(|e| e != "expect"))
        .collect();
    files.sort();
    assert!(!files.is_empty(), "{}: no inputs", dir.display());
    files
}

fn replay(target: &str, run: fn(&[u8]) -> tetfem::Result<()>) {
    let mut failures = Vec::new();
    for path in inputs(target) {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let data = std::fs::read(&path).unwrap();
        let outcome = catch_unwind(AssertUnwindSafe(|| run(&data)));
        match outcome {
            Err(_) => failures.push(format!("{target}/{name}: panicked")),
            Ok(Ok(())) if name.starts_with("err-") => {
                failures.push(format!("{target}/{name}: accepted, but must be an error"))
            }
            Ok(Err(e)) if name.starts_with("ok-") => {
                failures.push(format!("{target}/{name}: rejected: {e}"))
            }
            Ok(Err(e)) => {
                let expect = path.with_file_name(format!("{name}.expect"));
                if let Ok(needle) = std::fs::read_to_string(&expect) {
                    let message = e.to_string();
                    if !message.contains(needle.trim()) {
                        failures.push(format!(
                            "{target}/{name}: error '{message}' lacks '{}'",
                            needle.trim()
                        ));
                    }
                }
            }
            Ok(Ok(())) => {}
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn gmsh_regressions() {
    replay("gmsh", harness::gmsh);
}

#[test]
fn tetgen_regressions() {
    replay("tetgen", harness::tetgen);
}

#[test]
fn scene_regressions() {
    replay("scene", harness::scene);
}

#[test]
fn mesh_regressions() {
    replay("mesh", harness::mesh);
}

#[test]
fn tetgen_inputs_split_at_the_first_ff_byte() {
    assert_eq!(
        harness::split_tetgen(b"a\xffb\xffc"),
        (&b"a"[..], &b"b\xffc"[..])
    );
    assert_eq!(harness::split_tetgen(b"abc"), (&b"abc"[..], &b""[..]));
}
