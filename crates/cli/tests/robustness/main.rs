//! The CLI crate's robustness tests, one binary (linked once) with a module per subject: each
//! module is what was one test file (`crates/cli/tests/<module>.rs`), its tests unchanged.
//! Bad input and hostile conditions: every catalogued bad input is an error naming its culprit, no panic through the API, interrupts, memory limits, fuzz regressions, trusted inputs and outputs.
//!
//! Shared helpers are `common` (crates/cli/tests/common, which includes the core's
//! tests/core/common). The modules' tests run on parallel threads of this one process: each
//! writes into a folder of its own (named after its module), and none changes the working
//! directory or the environment. Run one subject with
//! `cargo test --release -p tetfem-cli --test robustness -- MODULE::` (e.g. `bad_input::`).

#[path = "../common/mod.rs"]
mod common;

mod bad_input;
mod clear_messages;
mod fuzz_regressions;
mod input_files;
mod interrupts;
mod memory;
mod no_panic;
mod step_limits;
mod trust_inputs;
mod trust_outputs;
