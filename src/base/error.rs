//! The crate's one error type.
//!
//! Every fallible public function returns [`Result<T>`](Result). Each variant names the
//! culprit (which tet, which node, which field) so that a caller can report it without
//! guessing.

use std::path::PathBuf;

/// Result alias used throughout tetfem.
pub type Result<T> = std::result::Result<T, Error>;

/// Everything that can go wrong in tetfem.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The mesh has no nodes or no tetrahedra.
    #[error("empty mesh: {nodes} nodes and {tets} tetrahedra (need at least 4 nodes and 1 tet)")]
    EmptyMesh {
        /// Number of nodes given.
        nodes: usize,
        /// Number of tets given.
        tets: usize,
    },

    /// A node coordinate is NaN or infinite.
    #[error("node {node}: coordinate {axis} is not finite ({value})")]
    NonFiniteCoordinate {
        /// Index of the node.
        node: usize,
        /// Axis (0 = x, 1 = y, 2 = z).
        axis: usize,
        /// The offending value.
        value: f64,
    },

    /// A tet refers to a node index that does not exist.
    #[error("tet {tet}: node index {node} is out of range (the mesh has {node_count} nodes)")]
    NodeIndexOutOfRange {
        /// Index of the tet.
        tet: usize,
        /// The out-of-range node index.
        node: usize,
        /// Number of nodes in the mesh.
        node_count: usize,
    },

    /// A tet lists the same node twice.
    #[error("tet {tet}: node {node} appears more than once in {nodes:?}")]
    RepeatedNode {
        /// Index of the tet.
        tet: usize,
        /// The repeated node.
        node: usize,
        /// The tet's node indices.
        nodes: Vec<usize>,
    },

    /// A tet is flat (zero volume up to round-off, relative to its longest edge cubed).
    #[error(
        "tet {tet} (nodes {nodes:?}) is degenerate: quality 6√2·|V|/l_max³ = {quality:.3e} is below {threshold:.0e}"
    )]
    DegenerateTet {
        /// Index of the tet.
        tet: usize,
        /// The tet's four node indices.
        nodes: [usize; 4],
        /// Its shape quality (1 for a regular tet, 0 for a flat one).
        quality: f64,
        /// The threshold below which a tet is rejected.
        threshold: f64,
    },

    /// More than two tets share one face; in a conforming mesh a face belongs to one tet
    /// (boundary) or two (interior).
    #[error("face {face:?} is shared by more than two tets (first: tets {tets:?})")]
    NonManifoldFace {
        /// Sorted node indices of the face.
        face: [usize; 3],
        /// Three tets that share it.
        tets: [usize; 3],
    },

    /// Two tets have the same four nodes (a repeated element doubles the stiffness and mass
    /// there).
    #[error("tets {first} and {tet} are duplicates: both have nodes {nodes:?}")]
    DuplicateTet {
        /// The earlier of the two.
        first: usize,
        /// The repeat.
        tet: usize,
        /// Their (sorted) node indices.
        nodes: [usize; 4],
    },

    /// Two tets that share a face lie on the same side of it: the mesh folds over itself there,
    /// one of them is inverted relative to its neighbour. (A tet given with negative orientation
    /// alone is not an error: [`TetMesh::new`](crate::mesh::TetMesh::new) reorients it.)
    #[error(
        "tets {tet} and {neighbour} overlap: both lie on the same side of their shared face {face:?}, \
         so the mesh folds over itself there (an inverted element)"
    )]
    InvertedTet {
        /// One of the two tets (the later in tet order).
        tet: usize,
        /// The tet it overlaps.
        neighbour: usize,
        /// Sorted node indices of the shared face.
        face: [usize; 3],
    },

    /// A tet index is out of range.
    #[error("{context}: tet {tet} does not exist (the mesh has {tet_count} tets)")]
    UnknownTet {
        /// What referred to it.
        context: &'static str,
        /// The tet index.
        tet: usize,
        /// Number of tets in the mesh.
        tet_count: usize,
    },

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

    /// A material parameter is outside its physical range.
    #[error("material: {field} = {value} is invalid: {requirement}")]
    InvalidMaterial {
        /// The field (`youngs_modulus`, `poisson_ratio`, `density`).
        field: &'static str,
        /// The offending value.
        value: f64,
        /// What it must satisfy.
        requirement: &'static str,
    },

    /// A parameter other than a material one is invalid (a grid size, an extent, a load, a time step...).
    #[error("invalid parameter {name} = {value}: {requirement}")]
    InvalidParameter {
        /// Name of the parameter.
        name: String,
        /// The offending value, as text.
        value: String,
        /// What it must satisfy.
        requirement: String,
    },

    /// A constraint or load refers to a node that does not exist.
    #[error("{context}: node {node} does not exist (the mesh has {node_count} nodes)")]
    UnknownNode {
        /// What referred to it (a constraint, a nodal load...).
        context: &'static str,
        /// The node index.
        node: usize,
        /// Number of nodes in the mesh.
        node_count: usize,
    },

    /// A selection of nodes or faces that a load or constraint was applied to is empty.
    #[error("{context}: the selection is empty (no node or face matched)")]
    EmptySelection {
        /// What the selection was for.
        context: String,
    },

    /// The body can still move rigidly: the stiffness matrix of the free DOFs is singular.
    #[error(
        "the body is not fully constrained: {free_modes} of the 6 rigid-body modes \
         (3 translations, 3 rotations) of the part containing tet {tet} ({part_tets} tets) are not \
         held by any constraint; fix more nodes or axes there"
    )]
    NotConstrained {
        /// A tet of the part that can move.
        tet: usize,
        /// Number of tets in that face-connected part.
        part_tets: usize,
        /// Number of independent rigid motions left free.
        free_modes: usize,
    },

    /// The sparse Cholesky factorization met a non-positive pivot.
    #[error(
        "the system matrix is not positive definite (pivot of row {pivot} of {dimension}); \
         likely causes: an unconstrained body, inverted elements, or ν very close to 0.5"
    )]
    NotPositiveDefinite {
        /// Row (DOF) of the matrix, in its own numbering, whose pivot was not positive.
        pivot: usize,
        /// Dimension of the matrix.
        dimension: usize,
    },

    /// Two constraints prescribe different values on one DOF (the same value twice is fine).
    #[error(
        "node {node}, axis {axis}: constrained twice with different values ({first:e}, then \
         {second:e}); one DOF takes one prescribed displacement: remove or narrow one of them"
    )]
    ConflictingConstraint {
        /// The node.
        node: usize,
        /// The axis (0 = x, 1 = y, 2 = z).
        axis: usize,
        /// The value prescribed first (length units; 0 for a fixed axis).
        first: f64,
        /// The value then prescribed.
        second: f64,
    },

    /// A direct static solve whose relative residual ‖K_ff·u_f − r_f‖/‖r_f‖ stays above
    /// `limit` after iterative refinement with the same factor: the answer cannot be trusted.
    #[error(
        "the static solve is inaccurate: relative residual {relative_residual:.2e} after \
         {refinements} steps of iterative refinement (at most {limit:e} is accepted); the \
         stiffness matrix is too ill-conditioned for double precision. Likely cause: {cause}"
    )]
    InaccurateSolve {
        /// The relative residual reached.
        relative_residual: f64,
        /// The largest relative residual accepted ([`crate::analysis::statics::RESIDUAL_LIMIT`]).
        limit: f64,
        /// Refinement steps taken.
        refinements: usize,
        /// The likely cause, as a sentence naming the culprit value.
        cause: String,
    },

    /// A time integration blew up (non-finite values or runaway energy).
    #[error("the run diverged at step {step} (t = {time:e}): {reason}")]
    Diverged {
        /// The step at which it was caught.
        step: usize,
        /// The simulated time at that step.
        time: f64,
        /// What the guard saw.
        reason: String,
    },

    /// A run was stopped by its caller (e.g. Ctrl-C) at a step boundary. The outputs hold the
    /// frames completed up to there, and the `.pvd` lists exactly those.
    #[error(
        "interrupted after step {step} (t = {time:e}); {frames} frames were written completely"
    )]
    Interrupted {
        /// The last step completed.
        step: usize,
        /// The simulated time after it.
        time: f64,
        /// Frames written (each complete, all listed in the `.pvd`).
        frames: usize,
    },

    /// The caller's interrupt test ([`crate::linalg::interrupt::with_check`]: Ctrl-C in the
    /// Python package) stopped a solve or a time step between two iterations. Nothing was
    /// written: a time step leaves the state of the step before, a solve returns no result.
    #[error("stopped by the caller's interrupt during {during}")]
    Stopped {
        /// Where it stopped (e.g. "conjugate gradient iteration 12", "Newton iteration 3 of
        /// load step 2/10").
        during: String,
    },

    /// A nonlinear iteration (Newton's method, its line search) ended without reaching its
    /// tolerance: `method` names it, `message` the iterations taken, the residual reached and
    /// the one asked for.
    #[error("{method}: {message}")]
    NotConverged {
        /// What failed, e.g. "Newton's method".
        method: String,
        /// Where and how far it got.
        message: String,
    },

    /// Another run holds the output folder (its lock file): two runs into one folder would mix
    /// their frames.
    #[error(
        "{directory} is in use by another tetfem run (PID {}, lock file {lock_file}); wait for it to \
         finish or choose another output folder",
        pid.as_deref().unwrap_or("not yet written")
    )]
    OutputLocked {
        /// The output folder.
        directory: PathBuf,
        /// Its lock file.
        lock_file: PathBuf,
        /// The PID written in the lock file by the run holding it.
        pid: Option<String>,
    },

    /// A linear-algebra routine failed for a reason other than a non-positive pivot.
    #[error("linear solver: {0}")]
    Solver(String),

    /// A run would need more memory than the process may still take (the least of
    /// MemAvailable, the cgroup's limit and the resource limits; see [`crate::base::memory`]). Raised
    /// before the allocation, so that nothing is aborted halfway.
    #[error(
        "not enough memory for {what}: needs {}, but only {} is available ({limit}); {hint}",
        tetfem_linalg::memory::format_bytes(*.needed),
        tetfem_linalg::memory::format_bytes(*.available as u128),
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

    /// A mesh or data file is malformed: truncated, wrong counts, a bad index, an unsupported
    /// version, a non-numeric field...
    #[error("{path}:{line}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line of the culprit (for binary files: the line count up to the byte offset,
        /// which the message also names).
        line: usize,
        /// What is wrong there.
        message: String,
    },

    /// A scene file is invalid: an unknown key, a value of the wrong type or range, a selection
    /// that matches nothing...
    #[error("{source_name}:{line}: {key}: {message}")]
    Scene {
        /// The scene file (or `<string>` for a scene parsed from memory).
        source_name: String,
        /// The key (dotted path where known) at fault.
        key: String,
        /// 1-based line of the key (0 when unknown).
        line: usize,
        /// What is wrong.
        message: String,
    },

    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
}

/// Each linear-algebra error becomes the variant of the same name and message: callers of the
/// analyses match one error type whichever layer failed.
impl From<tetfem_linalg::Error> for Error {
    fn from(error: tetfem_linalg::Error) -> Self {
        use tetfem_linalg::Error as Linalg;
        match error {
            Linalg::DimensionMismatch {
                what,
                expected,
                found,
            } => Error::DimensionMismatch {
                what,
                expected,
                found,
            },
            Linalg::InvalidParameter {
                name,
                value,
                requirement,
            } => Error::InvalidParameter {
                name,
                value,
                requirement,
            },
            Linalg::NotPositiveDefinite { pivot, dimension } => {
                Error::NotPositiveDefinite { pivot, dimension }
            }
            Linalg::Solver(message) => Error::Solver(message),
            Linalg::Stopped { during } => Error::Stopped { during },
            Linalg::InsufficientMemory {
                what,
                needed,
                available,
                limit,
                hint,
            } => Error::InsufficientMemory {
                what,
                needed,
                available,
                limit,
                hint,
            },
            // `tetfem_linalg::Error` is non-exhaustive: a variant added there reads as a solver
            // failure here until it gets its own.
            other => Error::Solver(other.to_string()),
        }
    }
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

    /// Shorthand for [`Error::Parse`].
    pub fn parse(path: impl Into<PathBuf>, line: usize, message: impl Into<String>) -> Self {
        Error::Parse {
            path: path.into(),
            line,
            message: message.into(),
        }
    }
}

/// A number for a message, never hundreds of digits: `{}` (shortest round trip, fixed point)
/// for magnitudes in [1e-3, 1e6) and for 0, `{:e}` (shortest round trip, scientific) otherwise,
/// so 1e300 prints as `1e300`, not as 301 digits, and 1e-320 as `1e-320`, not as 0.000….
pub fn short_number(value: f64) -> String {
    if value == 0.0 || !value.is_finite() || (1e-3..1e6).contains(&value.abs()) {
        format!("{value}")
    } else {
        format!("{value:e}")
    }
}
