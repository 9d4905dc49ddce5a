//! tetfem's errors as Python exceptions: each [`tetfem::Error`] variant is raised as one class of
//! `tetfem.errors` (all derived from `TetfemError`) with the Rust error's message, word for word.

use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;

/// The `tetfem.errors` class that a library error is raised as.
fn class_name(error: &tetfem::Error) -> &'static str {
    use tetfem::Error as E;
    match error {
        E::EmptyMesh { .. }
        | E::NonFiniteCoordinate { .. }
        | E::NodeIndexOutOfRange { .. }
        | E::RepeatedNode { .. }
        | E::DegenerateTet { .. }
        | E::NonManifoldFace { .. }
        | E::DuplicateTet { .. }
        | E::InvertedTet { .. }
        | E::Parse { .. } => "MeshError",
        E::UnknownTet { .. }
        | E::DimensionMismatch { .. }
        | E::InvalidMaterial { .. }
        | E::InvalidParameter { .. }
        | E::UnknownNode { .. }
        | E::EmptySelection { .. }
        | E::ConflictingConstraint { .. } => "InvalidInputError",
        E::NotConstrained { .. } => "NotConstrainedError",
        E::Diverged { .. } => "DivergedError",
        E::NotPositiveDefinite { .. }
        | E::InaccurateSolve { .. }
        | E::Solver(_)
        | E::NotConverged { .. }
        | E::InsufficientMemory { .. } => "SolverError",
        E::Scene { .. } => "SceneError",
        E::Io { .. } | E::OutputLocked { .. } => "TetfemIOError",
        _ => "TetfemError",
    }
}

/// A `tetfem.errors.<class_name>` exception with `message` (a `RuntimeError` if that module
/// cannot be imported, which only a broken installation causes).
pub fn raise(py: Python<'_>, class_name: &str, message: String) -> PyErr {
    let class = py
        .import("tetfem.errors")
        .and_then(|module| module.getattr(class_name));
    match class {
        Ok(class) => match class.call1((message.clone(),)) {
            Ok(instance) => PyErr::from_value(instance),
            Err(e) => e,
        },
        Err(_) => PyRuntimeError::new_err(message),
    }
}

/// A library error as the Python exception of its kind, with the same message.
pub fn library_error(py: Python<'_>, error: tetfem::Error) -> PyErr {
    raise(py, class_name(&error), error.to_string())
}

/// An invalid argument: `InvalidInputError` naming the argument, its value and what is allowed.
pub fn invalid(py: Python<'_>, name: &str, value: impl std::fmt::Display, allowed: &str) -> PyErr {
    raise(
        py,
        "InvalidInputError",
        format!("invalid parameter {name} = {value}: {allowed}"),
    )
}

/// Converts a library result into a Python one.
pub trait OrRaise<T> {
    /// The value, or the error raised as its Python exception.
    fn or_raise(self, py: Python<'_>) -> PyResult<T>;
}

impl<T> OrRaise<T> for tetfem::Result<T> {
    fn or_raise(self, py: Python<'_>) -> PyResult<T> {
        self.map_err(|e| library_error(py, e))
    }
}
