"""The exceptions tetfem raises: every one derives from :class:`TetfemError`.

The message is the Rust library's error message, word for word: it names the culprit (a node,
a tet, a parameter), its value and what is allowed.
"""


class TetfemError(Exception):
    """Base class of every error tetfem raises."""


class InvalidInputError(TetfemError, ValueError):
    """An argument is invalid: a wrong array shape or type, a negative or non-finite value, an
    unknown name (method, model, split, axis), a node or tet that does not exist, a material
    value out of range, a conflicting constraint, an empty selection."""


class MeshError(TetfemError, ValueError):
    """The mesh is invalid: non-finite coordinates, degenerate, inverted or duplicate tets,
    node indices out of range, a non-manifold face, or a mesh file that does not parse."""


class NotConstrainedError(TetfemError):
    """The constraints leave a rigid-body motion free (the stiffness is singular)."""


class SolverError(TetfemError):
    """The linear solver failed: a matrix that is not positive definite, an inaccurate solve,
    not enough memory, or an iteration that did not converge."""


class DivergedError(SolverError):
    """A dynamic run blew up (e.g. an explicit step above the critical step)."""


class SceneError(TetfemError, ValueError):
    """A scene file is invalid: the message names the file, the line and the key."""


class TetfemIOError(TetfemError, OSError):
    """A file could not be read or written, or an output folder is in use by another run."""


__all__ = [
    "TetfemError",
    "InvalidInputError",
    "MeshError",
    "NotConstrainedError",
    "SolverError",
    "DivergedError",
    "SceneError",
    "TetfemIOError",
]
