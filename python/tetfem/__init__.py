"""tetfem: elastic solids with the finite element method on linear tetrahedra, from Python.

The Rust library ``tetfem`` behind numpy arrays: meshes (``Mesh.box``, ``Mesh(points, tets)``,
``Mesh.read``), materials (``Material``, ``MaterialMap``), ``Constraints`` and ``Loads``,
static solves (``solve_static``, ``StaticSolver``), time integration (``Simulation``), natural
modes (``modal_analysis``), TOML scenes (``run_scene``) and meshio round trips
(``from_meshio``, ``to_meshio``, when meshio is installed). Errors are ``TetfemError``
subclasses carrying the library's messages (see ``tetfem.errors``).

Units are the caller's but must be consistent; the docstrings give SI (m, kg, s, N, Pa).
Node and tet indices start at 0; DOF ``3·node + axis``.

Example::

    import tetfem
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(40, 4, 4))
    steel = tetfem.Material.steel()
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh).add_total_force(mesh.faces_on_plane("x", 1.0), (0, 0, -1e4))
    result = tetfem.solve_static(mesh, steel, constraints, loads)
    tip = result.mean_displacement(mesh.nodes_on_plane("x", 1.0))   # m
"""

from . import errors
from ._tetfem import (
    STATIC_TIME,
    Amplitude,
    Constraints,
    Loads,
    Material,
    MaterialMap,
    Mesh,
    ModalResult,
    Obstacle,
    Simulation,
    StaticResult,
    StaticSolver,
    __version__,
    estimate_error,
    mass_matrix,
    mixed_modal_analysis,
    mixed_neo_hookean_transient,
    mixed_transient,
    modal_analysis,
    model_advice,
    run_scene,
    solve_static,
    solve_static_mixed,
    stiffness_matrix,
)
from .meshio_interop import from_meshio, to_meshio
from .errors import (
    DivergedError,
    InvalidInputError,
    MeshError,
    NotConstrainedError,
    SceneError,
    SolverError,
    TetfemError,
    TetfemIOError,
)

__all__ = [
    "Amplitude",
    "STATIC_TIME",
    "Constraints",
    "Loads",
    "Material",
    "MaterialMap",
    "Mesh",
    "ModalResult",
    "Obstacle",
    "Simulation",
    "StaticResult",
    "StaticSolver",
    "estimate_error",
    "model_advice",
    "modal_analysis",
    "run_scene",
    "solve_static",
    "solve_static_mixed",
    "mixed_modal_analysis",
    "mixed_transient",
    "mixed_neo_hookean_transient",
    "stiffness_matrix",
    "mass_matrix",
    "from_meshio",
    "to_meshio",
    "errors",
    "TetfemError",
    "InvalidInputError",
    "MeshError",
    "NotConstrainedError",
    "SolverError",
    "DivergedError",
    "SceneError",
    "TetfemIOError",
    "__version__",
]
