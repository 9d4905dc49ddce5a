//! The CLI crate's cli tests, one binary (linked once) with a module per subject: each
//! module is what was one test file (`crates/cli/tests/<module>.rs`), its tests unchanged.
//! The command line: arguments, help, `info`, the default run and the shipped scenes through the `tetfem` binary, the hand-off to another engine.
//!
//! Shared helpers are `common` (crates/cli/tests/common, which includes the core's
//! tests/core/common). The modules' tests run on parallel threads of this one process: each
//! writes into a folder of its own (named after its module), and none changes the working
//! directory or the environment. Run one subject with
//! `cargo test --release -p tetfem-cli --test cli -- MODULE::` (e.g. `cli::`).

#[path = "../common/mod.rs"]
mod common;

mod cli;
mod cli_scenes;
mod default_run;
mod engine_handoff;
