"""Round trips with meshio (optional: ``pip install meshio``), for the many formats it reads
and writes (VTK/VTU, XDMF, Abaqus, Exodus, ...)."""

from typing import Any, Dict, Optional

import numpy as np

from ._tetfem import Mesh
from .errors import InvalidInputError


def _meshio():
    try:
        import meshio
    except ImportError as error:  # pragma: no cover - depends on the environment
        raise ImportError("tetfem's meshio round trip needs meshio: pip install meshio") from error
    return meshio


def from_meshio(mesh: Any) -> Mesh:
    """A ``tetfem.Mesh`` from a ``meshio.Mesh``: its points (length units) and its ``tetra``
    cells (4-node tets; other cell blocks are ignored). Raises ``InvalidInputError`` if it has
    no ``tetra`` block; second-order ``tetra10`` cells are refused (tetfem has linear tets)."""
    blocks = [block.data for block in mesh.cells if block.type == "tetra"]
    if not blocks:
        kinds = sorted({block.type for block in mesh.cells}) or ["none"]
        raise InvalidInputError(
            f"invalid parameter mesh.cells = {', '.join(kinds)}: needs a 'tetra' block (4-node tets)"
        )
    points = np.asarray(mesh.points, dtype=np.float64)
    if points.ndim == 2 and points.shape[1] == 2:
        raise InvalidInputError("invalid parameter mesh.points.shape = (n, 2): tetfem needs 3-D points")
    return Mesh(points, np.concatenate(blocks).astype(np.int64))


def to_meshio(
    mesh: Mesh,
    point_data: Optional[Dict[str, Any]] = None,
    cell_data: Optional[Dict[str, Any]] = None,
) -> Any:
    """A ``meshio.Mesh`` of ``mesh`` (one ``tetra`` block) with optional ``point_data`` (arrays
    with one row per node, e.g. ``{"displacement": result.displacement}``) and ``cell_data``
    (one entry per tet, e.g. ``{"von_mises": result.von_mises}``); write it with
    ``.write("out.vtu")``."""
    meshio = _meshio()
    cells = [("tetra", mesh.tets)]
    cell_data = {name: [np.asarray(values)] for name, values in (cell_data or {}).items()}
    return meshio.Mesh(mesh.points, cells, point_data=point_data or {}, cell_data=cell_data)
