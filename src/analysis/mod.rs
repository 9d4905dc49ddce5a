//! Analyses of a problem, above the statics, nonlinear, dynamics and modal layers: what may be
//! combined with what ([`combination`]), said once for every front end (scenes, Python, the
//! PETSc engine).

pub mod combination;
pub mod definition;

pub use combination::{Analysis, Combination};
pub use definition::{Definition, DefinitionBuilder};
