"""Round trips with meshio (optional: ``pip install meshio``), for the many formats it reads
and writes (VTK/VTU, XDMF, Abaqus, Exodus, ...)."""

from typing import Any, Dict, List, Optional, Tuple

import numpy as np

from ._tetfem import Mesh
from .errors import InvalidInputError


def _meshio():
    try:
        import meshio
    except ImportError as error:  # pragma: no cover - depends on the environment
        raise ImportError("tetfem's meshio round trip needs meshio: pip install meshio") from error
    return meshio


# The dimension of each meshio cell type that can carry a Gmsh physical tag.
_DIMENSION = {
    "vertex": 0,
    "line": 1,
    "line3": 1,
    "triangle": 2,
    "triangle6": 2,
    "quad": 2,
    "quad8": 2,
    "quad9": 2,
    "tetra": 3,
    "tetra10": 3,
    "hexahedron": 3,
    "wedge": 3,
    "pyramid": 3,
}


def from_meshio(mesh: Any) -> Mesh:
    """A ``tetfem.Mesh`` from a ``meshio.Mesh``: its points (length units) and its ``tetra``
    cells (4-node tets; other cell blocks give no tets). Raises ``InvalidInputError`` if it has
    no ``tetra`` block; second-order ``tetra10`` cells are refused (``tetfem.Mesh`` has linear
    tets).

    The Gmsh physical groups of a mesh meshio read from a ``.msh`` file (its
    ``cell_data["gmsh:physical"]`` tags, named by ``field_data``) become the mesh's groups, as
    ``Mesh.read`` gives them: a surface group's triangles select faces (``faces_in_group``), a
    volume group's tets select tets (``tets_in_group``), and every group its nodes."""
    blocks = [block.data for block in mesh.cells if block.type == "tetra"]
    if not blocks:
        kinds = sorted({block.type for block in mesh.cells}) or ["none"]
        raise InvalidInputError(
            f"invalid parameter mesh.cells = {', '.join(kinds)}: needs a 'tetra' block (4-node tets)"
        )
    points = np.asarray(mesh.points, dtype=np.float64)
    if points.ndim == 2 and points.shape[1] == 2:
        raise InvalidInputError("invalid parameter mesh.points.shape = (n, 2): tetfem needs 3-D points")
    return Mesh(points, np.concatenate(blocks).astype(np.int64), groups=_physical_groups(mesh))


def _physical_groups(mesh: Any) -> Optional[List[Dict[str, Any]]]:
    """The Gmsh physical groups of a ``meshio.Mesh`` in the form ``Mesh(points, tets,
    groups)`` takes, or None if it has no ``gmsh:physical`` cell data. Tet indices count the
    ``tetra`` blocks in order, as ``from_meshio`` concatenates them."""
    tags_per_block = (getattr(mesh, "cell_data", None) or {}).get("gmsh:physical")
    if tags_per_block is None:
        return None
    names = {}
    for name, value in (getattr(mesh, "field_data", None) or {}).items():
        value = np.asarray(value).ravel()
        if value.size >= 2:
            names[(int(value[1]), int(value[0]))] = name
    groups: Dict[Tuple[int, int], Dict[str, Any]] = {}
    first_tet = 0
    for block, tags in zip(mesh.cells, tags_per_block):
        dim = _DIMENSION.get(block.type)
        data = np.asarray(block.data, dtype=np.int64)
        tags = np.asarray(tags).ravel()
        if dim is not None:
            for tag in np.unique(tags):
                rows = np.flatnonzero(tags == tag)
                key = (dim, int(tag))
                group = groups.setdefault(
                    key,
                    {"dim": dim, "tag": int(tag), "name": names.get(key), "nodes": [], "triangles": [], "tets": []},
                )
                group["nodes"].append(data[rows].ravel())
                if block.type == "triangle":
                    group["triangles"].append(data[rows])
                elif block.type == "triangle6":
                    group["triangles"].append(data[rows, :3])
                if block.type == "tetra":
                    group["tets"].append(rows + first_tet)
        if block.type == "tetra":
            first_tet += len(data)
    out = []
    for group in groups.values():
        group["nodes"] = np.concatenate(group["nodes"]) if group["nodes"] else None
        group["triangles"] = np.concatenate(group["triangles"]) if group["triangles"] else None
        group["tets"] = np.concatenate(group["tets"]) if group["tets"] else None
        out.append(group)
    return out


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
