//! The preconditioner interface that conjugate gradients ([`crate::iterative`]) applies and that
//! every preconditioner implements: block Jacobi and incomplete Cholesky
//! ([`crate::iterative`]), smoothed-aggregation multigrid ([`crate::amg`]).

use crate::error::Result;

/// An approximation P ≈ A whose inverse is cheap to apply: z = P⁻¹·r.
pub trait Preconditioner: Sync + Send + std::fmt::Debug {
    /// The dimension it acts on.
    fn dim(&self) -> usize;
    /// z = P⁻¹·r ([`Error::DimensionMismatch`](crate::Error::DimensionMismatch) unless both have length [`dim`](Self::dim)).
    fn apply(&self, r: &[f64], z: &mut [f64]) -> Result<()>;
}
