//! The CLI crate's outputs tests, one binary (linked once) with a module per subject: each
//! module is what was one test file (`crates/cli/tests/<module>.rs`), its tests unchanged.
//! What runs write: VTU (ASCII and binary), PVD, CSV series, probes, frames for viewers, original ids and markers, units, reactions, restarts.
//!
//! Shared helpers are `common` (crates/cli/tests/common, which includes the core's
//! tests/core/common). The modules' tests run on parallel threads of this one process: each
//! writes into a folder of its own (named after its module), and none changes the working
//! directory or the environment. Run one subject with
//! `cargo test --release -p tetfem-cli --test outputs -- MODULE::` (e.g. `binary_vtu::`).

#[path = "../common/mod.rs"]
mod common;

mod binary_vtu;
mod dynamic_reactions;
mod frames_for_viewers;
mod original_ids;
mod outputs;
mod point_probes;
mod reactions;
mod restart;
mod tetgen_markers;
mod units;
