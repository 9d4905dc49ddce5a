//! Analyses of a problem, above the statics, nonlinear, dynamics and modal layers: what may be
//! combined with what ([`combination`]), said once for every front end (scenes, Python, the
//! PETSc engine).

pub mod combination;
pub mod definition;
pub mod modal_analysis;
pub mod static_analysis;

pub use combination::{Analysis, Combination};
pub use definition::{Definition, DefinitionBuilder};
pub use modal_analysis::{Modal, ModalOutcome};
pub use static_analysis::{Static, StaticOptions, StaticOutcome, StaticPath};
