//! The CLI crate's scenes tests, one binary (linked once) with a module per subject: each
//! module is what was one test file (`crates/cli/tests/<module>.rs`), its tests unchanged.
//! Scenes run through the library: analyses (static, dynamic, modal), force models, P2, regions, moving supports, accuracy targets and estimates.
//!
//! Shared helpers are `common` (crates/cli/tests/common, which includes the core's
//! tests/core/common). The modules' tests run on parallel threads of this one process: each
//! writes into a folder of its own (named after its module), and none changes the working
//! directory or the environment. Run one subject with
//! `cargo test --release -p tetfem-cli --test scenes -- MODULE::` (e.g. `accuracy_target::`).

#[path = "../common/mod.rs"]
mod common;

mod accuracy_target;
mod bodies_scenes;
mod dynamic_accuracy;
mod estimate_scene;
mod large_deformation;
mod mixed_corotational_dynamics;
mod mixed_corotational_scene;
mod mixed_neo_hookean_p1;
mod mixed_p1p1_scenes;
mod modal_scene;
mod moving_supports_scenes;
mod nonlinear_dynamics;
mod nonlinear_solver_key;
mod p2_nonlinear_scenes;
mod p2_scenes;
mod quadratic_file_scenes;
mod regions;
mod scenes;
mod static_newton;
