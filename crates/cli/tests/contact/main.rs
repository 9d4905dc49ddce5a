//! The CLI crate's contact tests, one binary (linked once) with a module per subject: each
//! module is what was one test file (`crates/cli/tests/<module>.rs`), its tests unchanged.
//! Scenes with obstacles: resting, friction, moving obstacles, dynamic drops, the shipped sphere
//! press and the obstacle frames.
//!
//! Shared helpers are `common` (crates/cli/tests/common, which includes the core's
//! tests/core/common). The modules' tests run on parallel threads of this one process: each
//! writes into a folder of its own (named after its module), and none changes the working
//! directory or the environment. Run one subject with
//! `cargo test --release -p tetfem-cli --test contact -- MODULE::` (e.g. `contact_dynamic_scenes::`).

#[path = "../common/mod.rs"]
mod common;

mod contact_dynamic_scenes;
mod contact_friction_scenes;
mod contact_scenes;
mod obstacle_frames;
mod sphere_press;
mod static_moving_obstacle;
