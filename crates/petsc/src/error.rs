//! The engine's one error type: tetfem's errors, PETSc's and MPI's error codes (with the
//! function that returned them), a solve that did not converge, and bad input.

use std::path::PathBuf;

/// An error of the PETSc engine.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// An error of the tetfem core or of the scene (parsing, building the mesh, ...).
    #[error(transparent)]
    Tetfem(#[from] tetfem::Error),
    /// A PETSc function returned a non-zero `PetscErrorCode`.
    #[error("PETSc's {function} failed with error code {code}: {message}")]
    Petsc {
        /// The PETSc function.
        function: &'static str,
        /// Its `PetscErrorCode`.
        code: i32,
        /// PETSc's text for the code (`PetscErrorMessage`).
        message: String,
    },
    /// An MPI function returned a code other than `MPI_SUCCESS`.
    #[error("MPI's {function} failed with error code {code}")]
    Mpi {
        /// The MPI function.
        function: &'static str,
        /// Its return code.
        code: i32,
    },
    /// The Krylov solver stopped without converging.
    #[error(
        "the PETSc solve did not converge: {reason} (KSPConvergedReason {code}) after \
         {iterations} iterations, residual norm {residual_norm:e}; try another preconditioner \
         (--solver mumps for a direct solve) or raise -ksp_max_it"
    )]
    NotConverged {
        /// PETSc's name of the reason (`KSP_DIVERGED_ITS`, ...).
        reason: &'static str,
        /// The `KSPConvergedReason` value (negative).
        code: i32,
        /// Iterations done.
        iterations: i32,
        /// The last residual norm PETSc computed.
        residual_norm: f64,
    },
    /// A value the engine cannot take.
    #[error("{what} = {value}: {allowed}")]
    Invalid {
        /// What was given (a command-line argument, a scene key, a size).
        what: String,
        /// The value given.
        value: String,
        /// What is allowed.
        allowed: String,
    },
    /// The ranks disagree on something every rank computes alike (the partition).
    #[error("the ranks disagree on {what}: {detail}")]
    RanksDisagree {
        /// What they should agree on.
        what: &'static str,
        /// The values seen.
        detail: String,
    },
    /// Other ranks failed (each also reports its own error); this one stopped with them.
    #[error("rank(s) {ranks:?} failed ({}); this rank stopped with them", messages.join("; "))]
    OtherRanksFailed {
        /// The ranks that failed.
        ranks: Vec<usize>,
        /// Their errors, in the order of `ranks` (each cut at 1 KiB).
        messages: Vec<String>,
    },
    /// A file could not be written.
    #[error("cannot write {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

impl Error {
    /// An [`Error::Invalid`].
    pub fn invalid(
        what: impl Into<String>,
        value: impl std::fmt::Display,
        allowed: impl Into<String>,
    ) -> Self {
        Error::Invalid {
            what: what.into(),
            value: value.to_string(),
            allowed: allowed.into(),
        }
    }
}

/// The engine's result type.
pub type Result<T> = std::result::Result<T, Error>;
