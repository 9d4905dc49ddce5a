//! Helpers shared by the CLI crate's test binaries: the core's test helpers
//! (tests/core/common: VTU parsing, the manufactured solution, restart helpers, a small RNG)
//! and the scratch folders the tests write into.
#![allow(dead_code)]

#[path = "../../../../tests/core/common/mod.rs"]
mod core_common;

pub use core_common::*;

use std::path::PathBuf;

/// A fresh, empty scratch folder `<target tmp>/<module>/<name>` for one test. The tests of a
/// binary run on parallel threads, so each test needs a folder no other test writes: the
/// module's name keeps two modules' tests apart, `name` the tests of one module. Under the
/// target's tmp (not /tmp), so that two checkouts testing at once do not share it either.
pub fn scratch_dir(module: &str, name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join(module)
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch folder");
    dir
}
