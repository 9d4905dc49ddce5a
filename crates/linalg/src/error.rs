//! The linear algebra's error type.
//!
//! Each variant names the culprit (which argument, which pivot, which bound) so that a caller
//! can report it without guessing. tetfem's own `Error` has a variant of the same name and
//! message for each of these, and converts from this type one to one.

/// Result alias used throughout tetfem-linalg.
pub type Result<T> = std::result::Result<T, Error>;

/// Everything that can go wrong in the linear algebra.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A vector or matrix argument has the wrong length for the object it is used with.
    #[error("{what} has length {found}, expected {expected}")]
    DimensionMismatch {
        /// Which argument (e.g. `x` of `CscMatrix::mul_vec`).
        what: String,
        /// The length required.
        expected: usize,
        /// The length given.
        found: usize,
    },

    /// A parameter is invalid (a tolerance, a thread count, a block layout...).
    #[error("invalid parameter {name} = {value}: {requirement}")]
    InvalidParameter {
        /// Name of the parameter.
        name: String,
        /// The offending value, as text.
        value: String,
        /// What it must satisfy.
        requirement: String,
    },

    /// The sparse Cholesky factorization met a non-positive pivot.
    #[error(
        "the system matrix is not positive definite (pivot of row {pivot} of {dimension}); \
         likely causes: an unconstrained body, inverted elements, or ν very close to 0.5"
    )]
    NotPositiveDefinite {
        /// Row of the matrix, in its own numbering, whose pivot was not positive.
        pivot: usize,
        /// Dimension of the matrix.
        dimension: usize,
    },

    /// A linear-algebra routine failed for a reason other than a non-positive pivot.
    #[error("linear solver: {0}")]
    Solver(String),

    /// The caller's interrupt test ([`crate::interrupt::with_check`], e.g. Ctrl-C in a front
    /// end) stopped a computation between two of its iterations; its result was not written.
    #[error("stopped by the caller's interrupt during {during}")]
    Stopped {
        /// Where it stopped (e.g. "conjugate gradient iteration 12").
        during: String,
    },

    /// A computation would need more memory than the process may still take (the least of
    /// MemAvailable, the cgroup's limit and the resource limits; see [`crate::memory`]). Raised
    /// before the allocation, so that nothing is aborted halfway.
    #[error(
        "not enough memory for {what}: needs {}, but only {} is available ({limit}); {hint}",
        crate::bytes::format_bytes(*.needed),
        crate::bytes::format_bytes(*.available as u128),
    )]
    InsufficientMemory {
        /// What was to be built, with the estimate's parts.
        what: String,
        /// Bytes needed.
        needed: u128,
        /// Bytes available under the tightest bound.
        available: u64,
        /// Every bound found, the tightest first.
        limit: String,
        /// What to change, for the path that needs the memory (e.g. "use a coarser mesh").
        hint: String,
    },
}

impl Error {
    /// Shorthand for [`Error::InvalidParameter`].
    pub fn invalid_parameter(
        name: impl Into<String>,
        value: impl std::fmt::Display,
        requirement: impl Into<String>,
    ) -> Self {
        Error::InvalidParameter {
            name: name.into(),
            value: value.to_string(),
            requirement: requirement.into(),
        }
    }

    /// Checks `found == expected`, else [`Error::DimensionMismatch`] naming `what`.
    pub fn check_len(what: &str, expected: usize, found: usize) -> Result<()> {
        if found == expected {
            Ok(())
        } else {
            Err(Error::DimensionMismatch {
                what: what.to_string(),
                expected,
                found,
            })
        }
    }
}
