//! The base room: what every other room uses and which knows no mechanics — the one error
//! type ([`error`]: each variant names its culprit), the warning type ([`warning`]: valid but
//! suspect input), whole-file atomic writes ([`atomic_file`]), input file reading
//! ([`input_file`]: sizes and line numbers), peak-memory estimates made before allocating
//! ([`memory`]) and dense vector arithmetic on slices (`vector`).

pub mod atomic_file;
pub mod error;
pub mod input_file;
pub mod memory;
pub(crate) mod vector;
pub mod warning;
