//! Model adequacy of a run: is the linear (small-strain) model enough for the deformation it
//! computed, and does an implicit step resolve the motion it integrates?
//!
//! - [`rotation`]: the largest element rotation (polar decomposition of F = I + ∇u) and
//!   strain of a displacement, mapped through a measured curve to the expected error of the
//!   linear model ([`rotation::LINEAR_MODEL_ERROR_CURVE`]);
//! - [`time_step`]: steps per period of the lowest excited mode, and backward Euler's
//!   amplitude decay per period at that step.

pub mod rotation;
pub mod time_step;
