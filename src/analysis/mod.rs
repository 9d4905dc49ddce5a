//! Analyses of a problem, above the statics, nonlinear, dynamics and modal layers: what may be
//! combined with what ([`combination`]), said once for every front end (scenes, Python, the
//! PETSc engine).
//!
//! The analysis room also holds every solve of a problem: the set-up made once ([`problem`]),
//! one linear solve ([`statics`]), its mixed displacement–pressure form for nearly
//! incompressible materials ([`mixed_statics`]), Newton with load steps ([`nonlinear`]), time
//! integration ([`dynamics`]) and modes ([`modal`]); the one Newton loop both nonlinear solves
//! iterate in (`newton`).

pub mod combination;
pub mod definition;
pub mod dynamics;
pub mod mixed_analysis;
pub mod mixed_dynamics;
pub mod mixed_modal;
pub mod mixed_nonlinear;
pub mod mixed_nonlinear_dynamics;
pub mod mixed_operator;
pub mod mixed_statics;
pub mod modal;
pub mod modal_analysis;
pub(crate) mod newton;
pub mod nonlinear;
pub mod problem;
pub mod static_analysis;
pub mod statics;
pub mod transient;

pub use combination::{Analysis, Combination};
pub use definition::{Definition, DefinitionBuilder, SurfaceContactData};
pub use modal_analysis::{Modal, ModalOutcome};
pub use static_analysis::{Static, StaticOptions, StaticOutcome, StaticPath, static_load_of};
pub use transient::{Transient, TransientOptions};
