//! `tetfem.Mesh`: a validated tetrahedral mesh with its boundary faces, from a box, numpy arrays
//! or a Gmsh/TetGen file; node, tet and face selections as numpy index arrays.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use nalgebra::Vector3;
use pyo3::exceptions::PyUserWarning;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use tetfem::fe::element::Tet10;
use tetfem::mesh::io::{ImportedMesh, MeshFile, PhysicalGroup, TET10_KEPT_AS_CORNERS};
use tetfem::mesh::{BoundaryFace, CellType, Tet4, TetMesh};

use crate::arrays::{self, floats, index_rows, index_vector, indices};
use crate::errors::{OrRaise, invalid, raise};
use crate::names;

pub(crate) use crate::cells::on_cells;
pub use crate::cells::{AnyImported, AnyMesh, Cells};

/// A mesh with what selections and loads need: its boundary faces (outward oriented) and, for
/// a mesh read from a file, the file's groups, markers and attributes.
#[derive(Debug)]
pub struct MeshData {
    /// The validated mesh.
    pub mesh: AnyMesh,
    /// Groups, markers and attributes of a mesh read from a file.
    pub imported: Option<AnyImported>,
    /// The boundary faces, outward oriented, in the library's order.
    pub boundary: Vec<BoundaryFace>,
    /// Each node's and tet's body, of a mesh made by `Mesh.bodies`.
    pub bodies: Option<crate::bodies::BodyIds>,
    /// Boundary face index by its sorted node triple.
    face_index: HashMap<[usize; 3], usize>,
    /// What reading the file changed, as sentences (a quadratic file read as its corners).
    read_notes: Vec<String>,
}

impl MeshData {
    /// The mesh with its boundary faces.
    pub fn new(mesh: AnyMesh, imported: Option<AnyImported>) -> tetfem::Result<Self> {
        let boundary = on_cells!(&mesh, m => m.boundary_faces())?;
        let face_index = boundary
            .iter()
            .enumerate()
            .map(|(i, f)| (sorted(f.nodes), i))
            .collect();
        Ok(MeshData {
            mesh,
            imported,
            bodies: None,
            boundary,
            face_index,
            read_notes: Vec::new(),
        })
    }

    /// The boundary faces named by rows of node triples (any node order), in the given order;
    /// a triple that is not a boundary face is an `InvalidInputError` naming it.
    pub fn faces_of(
        &self,
        py: Python<'_>,
        faces: &Bound<'_, PyAny>,
        name: &str,
    ) -> PyResult<Vec<BoundaryFace>> {
        let (flat, rows) = indices(py, faces, name, Some(3))?;
        let mut out = Vec::with_capacity(rows);
        for (r, triple) in flat.chunks_exact(3).enumerate() {
            let key = sorted([triple[0], triple[1], triple[2]]);
            match self.face_index.get(&key) {
                Some(&i) => out.push(self.boundary[i]),
                None => {
                    return Err(invalid(
                        py,
                        &format!("{name}[{r}]"),
                        format!("{triple:?}"),
                        "must be a boundary face of the mesh (three node indices, e.g. a row of \
                         mesh.boundary_faces())",
                    ));
                }
            }
        }
        if out.is_empty() {
            return Err(invalid(
                py,
                name,
                "[]",
                "must name at least one boundary face",
            ));
        }
        Ok(out)
    }

    /// Node indices of `name`, each checked to exist, ascending and without repeats; at least one.
    pub fn nodes_of(
        &self,
        py: Python<'_>,
        nodes: &Bound<'_, PyAny>,
        name: &str,
    ) -> PyResult<Vec<usize>> {
        let (mut list, _) = indices(py, nodes, name, None)?;
        let count = self.mesh.node_count();
        if let Some(&bad) = list.iter().find(|&&n| n >= count) {
            return Err(invalid(
                py,
                name,
                bad,
                &format!("node {bad} does not exist (the mesh has {count} nodes)"),
            ));
        }
        list.sort_unstable();
        list.dedup();
        if list.is_empty() {
            return Err(invalid(py, name, "[]", "must select at least one node"));
        }
        Ok(list)
    }

    /// The boundary faces all three of whose nodes are selected, in boundary order.
    fn faces_with_nodes(&self, selected: &[bool]) -> Vec<[usize; 3]> {
        self.boundary
            .iter()
            .filter(|f| f.nodes.iter().all(|&n| selected[n]))
            .map(|f| f.nodes)
            .collect()
    }

    /// The default plane tolerance of scenes: 1e-6 × the bounding-box diagonal.
    fn default_tolerance(&self) -> f64 {
        let (lo, hi) = self.mesh.bounding_box();
        1e-6 * (hi - lo).norm()
    }

    fn imported(&self, py: Python<'_>, what: &str) -> PyResult<&AnyImported> {
        self.imported.as_ref().ok_or_else(|| {
            raise(
                py,
                "InvalidInputError",
                format!("{what} needs a mesh read from a file (Mesh.read); this one was not"),
            )
        })
    }

    /// The imported mesh, if it has `.face` markers and `marker` among them; else an
    /// `InvalidInputError` naming the marker and listing those the file has.
    fn face_marker_mesh(&self, py: Python<'_>, marker: i64) -> PyResult<&AnyImported> {
        let imported = self.imported(py, "a face marker selection")?;
        let counts = on_cells!(imported, i => i.face_marker_counts());
        if on_cells!(imported, i => i.face_markers.is_none()) {
            return Err(invalid(
                py,
                "marker",
                marker,
                "needs a TetGen mesh with a .face file with a marker column",
            ));
        }
        if !counts.contains_key(&marker) {
            let known: Vec<String> = counts
                .iter()
                .map(|(m, n)| format!("{m} ({n} faces)"))
                .collect();
            return Err(invalid(
                py,
                "marker",
                marker,
                &format!(
                    "the mesh has no face marker {marker} (it has: {})",
                    known.join(", ")
                ),
            ));
        }
        Ok(imported)
    }

    fn group(&self, py: Python<'_>, name: &str) -> PyResult<&tetfem::mesh::io::PhysicalGroup> {
        let imported = self.imported(py, "a group selection")?;
        on_cells!(imported, i => i.group(name)).ok_or_else(|| {
            let known: Vec<String> = on_cells!(imported, i => &i.groups)
                .iter()
                .map(|g| g.label())
                .collect();
            invalid(
                py,
                "group",
                format!("'{name}'"),
                &format!(
                    "the mesh has no such physical group (it has: {})",
                    if known.is_empty() {
                        "none".into()
                    } else {
                        known.join(", ")
                    }
                ),
            )
        })
    }
}

/// `mesh` as if read from a file with the physical groups `groups` (see `Mesh(points, tets,
/// groups)`); every index checked against the mesh.
fn with_groups(
    py: Python<'_>,
    mesh: &TetMesh,
    groups: &Bound<'_, PyAny>,
) -> PyResult<ImportedMesh> {
    let mut out: Vec<PhysicalGroup> = Vec::new();
    for (i, group) in groups.try_iter()?.enumerate() {
        let group = group?;
        let key = format!("groups[{i}]");
        let group = group.cast::<PyDict>().map_err(|_| {
            invalid(
                py,
                &key,
                "not a dict",
                "must be a dict with dim, tag and optional name, nodes, triangles, tets",
            )
        })?;
        let dim = required(py, group, &key, "dim")?;
        let dim = match usize::try_from(dim) {
            Ok(d) if d <= 3 => d,
            _ => {
                return Err(invalid(
                    py,
                    &format!("{key}.dim"),
                    dim,
                    "must be 0, 1, 2 or 3",
                ));
            }
        };
        let tag = required(py, group, &key, "tag")?;
        let tag = i32::try_from(tag).map_err(|_| {
            invalid(
                py,
                &format!("{key}.tag"),
                tag,
                "must fit a 32-bit integer (a Gmsh tag)",
            )
        })?;
        let name: Option<String> = match group.get_item("name")? {
            Some(v) if !v.is_none() => Some(v.extract::<String>().map_err(|_| {
                invalid(
                    py,
                    &format!("{key}.name"),
                    v.to_string(),
                    "must be a str or None",
                )
            })?),
            _ => None,
        };
        let list = |field: &str, columns: Option<usize>| -> PyResult<Vec<usize>> {
            match group.get_item(field)? {
                Some(v) if !v.is_none() => {
                    Ok(indices(py, &v, &format!("{key}.{field}"), columns)?.0)
                }
                _ => Ok(Vec::new()),
            }
        };
        let mut nodes = list("nodes", None)?;
        let triangles: Vec<[usize; 3]> = list("triangles", Some(3))?
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect();
        let tets = list("tets", None)?;
        if let Some(&bad) = tets.iter().find(|&&t| t >= mesh.tet_count()) {
            return Err(invalid(
                py,
                &format!("{key}.tets"),
                bad,
                &format!(
                    "tet {bad} does not exist (the mesh has {} tets)",
                    mesh.tet_count()
                ),
            ));
        }
        nodes.extend(triangles.iter().flatten());
        nodes.extend(tets.iter().flat_map(|&t| mesh.tets()[t]));
        if let Some(&bad) = nodes.iter().find(|&&n| n >= mesh.node_count()) {
            return Err(invalid(
                py,
                &format!("{key}.nodes"),
                bad,
                &format!(
                    "node {bad} does not exist (the mesh has {} nodes)",
                    mesh.node_count()
                ),
            ));
        }
        nodes.sort_unstable();
        nodes.dedup();
        out.push(PhysicalGroup {
            dim,
            tag,
            name,
            triangles,
            tets,
            nodes,
        });
    }
    out.sort_by_key(|g| (g.dim, g.tag));
    Ok(ImportedMesh {
        mesh: mesh.clone(),
        node_ids: (0..mesh.node_count() as u64).collect(),
        tet_ids: (0..mesh.tet_count() as u64).collect(),
        groups: out,
        node_markers: None,
        tet_attributes: None,
        face_markers: None,
        skipped_elements: Default::default(),
        unused_nodes: 0,
    })
}

/// The integer entry `field` of a group dict, required.
fn required(py: Python<'_>, group: &Bound<'_, PyDict>, key: &str, field: &str) -> PyResult<i64> {
    let value = group
        .get_item(field)?
        .ok_or_else(|| invalid(py, &format!("{key}.{field}"), "missing", "is required"))?;
    value.extract::<i64>().map_err(|_| {
        invalid(
            py,
            &format!("{key}.{field}"),
            value.to_string(),
            "must be an integer",
        )
    })
}

/// The warning for a quadratic file read as 4-node tets (its corners), naming the file, the
/// order and what was dropped; `None` for a linear file.
fn quadratic_note<C: CellType>(path: &Path, imported: &ImportedMesh<C>) -> Option<String> {
    let tets = *imported.skipped_elements.get(TET10_KEPT_AS_CORNERS)?;
    Some(format!(
        "{}: the file holds {tets} 10-node tets (order 2, {} nodes); tetfem.Mesh has 4-node \
         tets (order 1) as asked (order=1), so it kept their corners ({} nodes) and dropped \
         the {} edge and other unused nodes: analyses of this Mesh are linear (P1). For P2, \
         read it with order=2 or None (the file's order)",
        path.display(),
        imported.mesh.node_count() + imported.unused_nodes,
        imported.mesh.node_count(),
        imported.unused_nodes
    ))
}

fn sorted(mut nodes: [usize; 3]) -> [usize; 3] {
    nodes.sort_unstable();
    nodes
}

/// A tetrahedral mesh (4-node tets, or 10-node with `order = 2`). Coordinates in length units
/// (m in SI, as in every shipped scene); node and tet indices start at 0.
///
/// Build one with ``Mesh.box(max, cells)``, ``Mesh(points, tets)`` or ``Mesh.read(path)``.
/// Invalid input raises ``MeshError`` (non-finite coordinates, degenerate or duplicate tets,
/// out-of-range indices) or ``InvalidInputError`` (wrong array shapes). Negatively oriented tets
/// are reoriented (their second and third nodes swapped).
#[pyclass(name = "Mesh", module = "tetfem", frozen)]
pub struct PyMesh {
    /// The mesh and its boundary, shared with the constraints, loads and analyses made on it.
    pub data: Arc<MeshData>,
}

impl PyMesh {
    /// A `Mesh` of `mesh`, its boundary found with the GIL released.
    fn of(py: Python<'_>, mesh: AnyMesh, imported: Option<AnyImported>) -> PyResult<Self> {
        let data = py.detach(|| MeshData::new(mesh, imported)).or_raise(py)?;
        Ok(PyMesh {
            data: Arc::new(data),
        })
    }
}

#[pymethods]
impl PyMesh {
    /// A mesh from node coordinates ``points`` (shape (n, 3), length units) and tets ``tets``
    /// (shape (m, 4), node indices from 0). Raises ``MeshError`` for NaN or infinite
    /// coordinates, out-of-range or repeated node indices, degenerate or duplicate tets.
    ///
    /// ``groups`` (optional) gives it physical groups as ``Mesh.read`` does for a Gmsh file
    /// (for ``nodes_in_group``, ``faces_in_group``, ``tets_in_group`` and region materials): a
    /// list of dicts with ``dim`` (0 points … 3 volumes), ``tag`` (int), ``name`` (str or
    /// None) and any of ``nodes`` (node indices), ``triangles`` (shape (f, 3), node indices)
    /// and ``tets`` (tet indices); a group's nodes are its ``nodes`` and those of its
    /// triangles and tets. ``tetfem.from_meshio`` builds them from Gmsh physical tags.
    #[new]
    #[pyo3(signature = (points, tets, groups = None))]
    fn new(
        py: Python<'_>,
        points: &Bound<'_, PyAny>,
        tets: &Bound<'_, PyAny>,
        groups: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        // Non-finite coordinates are left to the library, whose message names the node.
        let (flat, _) = floats(py, points, "points", Some(3), true)?;
        let (tet_flat, _) = indices(py, tets, "tets", Some(4))?;
        let nodes: Vec<Vector3<f64>> = flat
            .chunks_exact(3)
            .map(|p| Vector3::new(p[0], p[1], p[2]))
            .collect();
        let tets: Vec<[usize; 4]> = tet_flat
            .chunks_exact(4)
            .map(|t| [t[0], t[1], t[2], t[3]])
            .collect();
        let mesh = py.detach(|| TetMesh::new(nodes, tets)).or_raise(py)?;
        let imported = match groups {
            Some(groups) => Some(Cells::P1(with_groups(py, &mesh, groups)?)),
            None => None,
        };
        Self::of(py, Cells::P1(mesh), imported)
    }

    /// The box [min, max] (length units) in ``cells`` = (nx, ny, nz) cubes, each split into
    /// tets: ``"mirrored6"`` (6 per cell, the lecture's table mirrored in alternate cells: no
    /// sideways lean in bending), ``"lecture6"`` (6 per cell, one diagonal everywhere) or
    /// ``"five"`` (5 per cell, alternating). ``order`` 1 gives 4-node tets, 2 10-node tets
    /// (a node added at each edge's midpoint, as scenes' ``mesh.order = 2``). A box too large
    /// for the memory available raises ``SolverError`` before anything is allocated.
    #[staticmethod]
    #[pyo3(name = "box", signature = (max, cells, min = None, split = "mirrored6", order = 1))]
    fn box_grid(
        py: Python<'_>,
        max: &Bound<'_, PyAny>,
        cells: &Bound<'_, PyAny>,
        min: Option<&Bound<'_, PyAny>>,
        split: &str,
        order: usize,
    ) -> PyResult<Self> {
        let nodes_per_tet = match order {
            1 => Tet4::NODES,
            2 => Tet10::NODES,
            _ => {
                return Err(invalid(
                    py,
                    "order",
                    order,
                    "must be 1 (4-node tets) or 2 (10-node tets)",
                ));
            }
        };
        let max = arrays::vector3(py, max, "max")?;
        let min = match min {
            Some(m) => arrays::vector3(py, m, "min")?,
            None => Vector3::zeros(),
        };
        let cells = arrays::counts3(py, cells, "cells")?;
        let split = names::split(py, split)?;
        tetfem::base::memory::check_box_run(
            cells,
            split.tets_per_cell(),
            nodes_per_tet,
            false,
            tetfem::base::memory::RunPath::Iterative,
        )
        .or_raise(py)?;
        let mesh = py
            .detach(|| -> tetfem::Result<AnyMesh> {
                let linear = TetMesh::box_grid(min, max, cells, split)?;
                Ok(match order {
                    2 => Cells::P2(TetMesh::<Tet10>::from_linear(&linear)?),
                    _ => Cells::P1(linear),
                })
            })
            .or_raise(py)?;
        Self::of(py, mesh, None)
    }

    /// Reads a Gmsh ``.msh`` (4.1 or 2.2) or a TetGen ``.node``/``.ele`` pair (the path of
    /// either file, or their common prefix). Its physical groups (Gmsh), node markers, face
    /// markers and tet attributes (TetGen) are kept for selections. Raises ``MeshError`` for a
    /// file that does not parse or holds an invalid mesh, ``TetfemIOError`` if it cannot be read.
    ///
    /// ``order`` None reads the file's own order: 4-node tets (order 1) or 10-node tets
    /// (order 2, every analysis then runs on them). ``order=1`` reads a quadratic file as its
    /// corners, dropping the edge nodes, and says so in ``warnings`` and with a ``UserWarning``
    /// naming the file; ``order=2`` of a linear file raises ``MeshError`` naming the file.
    #[staticmethod]
    #[pyo3(signature = (path, order = None))]
    fn read(py: Python<'_>, path: PathBuf, order: Option<usize>) -> PyResult<Self> {
        if let Some(bad) = order.filter(|o| !matches!(o, 1 | 2)) {
            return Err(invalid(
                py,
                "order",
                bad,
                "must be None (the file's order), 1 (4-node tets) or 2 (10-node tets)",
            ));
        }
        let read = || -> tetfem::Result<(AnyImported, Option<String>)> {
            let file = MeshFile::read(&path)?;
            Ok(match order.unwrap_or(file.order()) {
                2 => (Cells::P2(file.build_as::<Tet10>()?), None),
                _ => {
                    let imported = file.build_as::<Tet4>()?;
                    let note = quadratic_note(&path, &imported);
                    (Cells::P1(imported), note)
                }
            })
        };
        let (imported, note) = py.detach(read).or_raise(py)?;
        let mesh = match &imported {
            Cells::P1(i) => Cells::P1(i.mesh.clone()),
            Cells::P2(i) => Cells::P2(i.mesh.clone()),
        };
        let mut data = py
            .detach(|| MeshData::new(mesh, Some(imported)))
            .or_raise(py)?;
        if let Some(note) = note {
            py.import("warnings")?
                .call_method1("warn", (note.clone(), py.get_type::<PyUserWarning>()))?;
            data.read_notes.push(note);
        }
        Ok(PyMesh {
            data: Arc::new(data),
        })
    }

    /// Node coordinates, shape (n, 3), length units (a copy).
    #[getter]
    fn points<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let flat: Vec<f64> = self
            .data
            .mesh
            .nodes()
            .iter()
            .flat_map(|p| [p.x, p.y, p.z])
            .collect();
        arrays::rows3(py, flat)
    }

    /// Several bodies in one mesh: ``meshes`` (Mesh objects of one order) each turned by
    /// ``rotations[i]`` (``(axis, degrees)``, right-handed, about the origin, or ``None``),
    /// then moved by ``translations[i]`` (shape (k, 3), m; default none), numbered one after
    /// another (nodes and tets of body 0 first). ``body_of_node`` and ``body_of_tet`` give
    /// each node's and tet's body; a ``Simulation(..., self_contact=True)`` on it keeps the
    /// bodies apart (and each from itself). Raises ``InvalidInputError`` naming the argument
    /// for counts that differ or meshes of two orders, and for bodies placed into each other
    /// (naming both bodies and a pair of their triangles). The meshes' file groups are not
    /// carried over: select on the placed mesh by plane, box or body.
    #[staticmethod]
    #[pyo3(signature = (meshes, translations = None, rotations = None))]
    fn bodies(
        py: Python<'_>,
        meshes: Vec<PyRef<'_, PyMesh>>,
        translations: Option<&Bound<'_, PyAny>>,
        rotations: crate::bodies::Rotations<'_>,
    ) -> PyResult<Self> {
        let parts: Vec<&AnyMesh> = meshes.iter().map(|m| &m.data.mesh).collect();
        let (mesh, ids) = crate::bodies::place(py, &parts, translations, rotations)?;
        let mut data = py.detach(|| MeshData::new(mesh, None)).or_raise(py)?;
        data.bodies = Some(ids);
        Ok(PyMesh {
            data: Arc::new(data),
        })
    }

    /// Each node's body (int64, shape (n,)) of a mesh made by ``Mesh.bodies``; ``None`` for
    /// any other mesh (one body).
    #[getter]
    fn body_of_node<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyAny>> {
        let ids = self.data.bodies.as_ref()?;
        Some(arrays::index_vector(py, &ids.of_node))
    }

    /// Each tet's body (int64, shape (m,)) of a mesh made by ``Mesh.bodies``; ``None`` for any
    /// other mesh (one body).
    #[getter]
    fn body_of_tet<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyAny>> {
        let ids = self.data.bodies.as_ref()?;
        Some(arrays::index_vector(py, &ids.of_tet))
    }

    /// Tets as node indices, shape (m, 4) (order 1) or (m, 10) (order 2), int64, positively oriented (a copy).
    #[getter]
    fn tets<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        on_cells!(&self.data.mesh, m => index_rows(py, m.tets()))
    }

    /// The element order: 1 (4-node tets) or 2 (10-node tets: four corners, then the nodes
    /// of edges 01, 12, 02, 03, 13, 23).
    #[getter]
    fn order(&self) -> usize {
        self.data.mesh.order()
    }

    /// Number of nodes.
    #[getter]
    fn node_count(&self) -> usize {
        self.data.mesh.node_count()
    }

    /// Number of tets.
    #[getter]
    fn tet_count(&self) -> usize {
        self.data.mesh.tet_count()
    }

    /// Degrees of freedom: 3 per node (DOF 3·node + axis).
    #[getter]
    fn dof_count(&self) -> usize {
        self.data.mesh.dof_count()
    }

    /// Total volume (length³ units).
    #[getter]
    fn volume(&self) -> f64 {
        on_cells!(&self.data.mesh, m => m.volume())
    }

    /// Number of tets that were given negatively oriented and reoriented.
    #[getter]
    fn reoriented_count(&self) -> usize {
        on_cells!(&self.data.mesh, m => m.reoriented_count())
    }

    /// (min, max) corners of the bounding box, each shape (3,), length units.
    #[getter]
    fn bounding_box<'py>(&self, py: Python<'py>) -> (Bound<'py, PyAny>, Bound<'py, PyAny>) {
        let (lo, hi) = self.data.mesh.bounding_box();
        (
            arrays::vector(py, vec![lo.x, lo.y, lo.z]),
            arrays::vector(py, vec![hi.x, hi.y, hi.z]),
        )
    }

    /// Physical groups of a Gmsh mesh: a list of dicts with ``name`` (or None), ``tag``,
    /// ``dim`` (0 points … 3 volumes), ``nodes`` and ``tets`` counts. Empty for other meshes.
    #[getter]
    fn groups<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        let Some(imported) = &self.data.imported else {
            return Ok(Vec::new());
        };
        on_cells!(imported, i => &i.groups)
            .iter()
            .map(|g| {
                let d = PyDict::new(py);
                d.set_item("name", g.name.clone())?;
                d.set_item("tag", g.tag)?;
                d.set_item("dim", g.dim)?;
                d.set_item("nodes", g.nodes.len())?;
                d.set_item("tets", g.tets.len())?;
                Ok(d)
            })
            .collect()
    }

    /// Warnings about valid but suspect input (poor tets, unused nodes, a quadratic file read
    /// as its corners), as sentences.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        let mut out = self.data.read_notes.clone();
        let warnings = on_cells!(&self.data.mesh, m => m.warnings());
        out.extend(warnings.iter().map(ToString::to_string));
        out
    }

    /// Nodes with |x[axis] − at| ≤ tolerance (axis 0/1/2 or "x"/"y"/"z"; length units; default
    /// tolerance 1e-6 × the bounding-box diagonal, as in scenes), ascending int64 array.
    #[pyo3(signature = (axis, at, tolerance = None))]
    fn nodes_on_plane<'py>(
        &self,
        py: Python<'py>,
        axis: &Bound<'py, PyAny>,
        at: f64,
        tolerance: Option<f64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let axis = names::axis(py, axis)?;
        let tolerance = tolerance.unwrap_or_else(|| self.data.default_tolerance());
        let nodes = on_cells!(&self.data.mesh, m => m.try_nodes_on_plane(axis, at, tolerance))
            .or_raise(py)?;
        Ok(index_vector(py, &nodes))
    }

    /// Nodes inside the closed box [min, max] (length units), ascending int64 array.
    fn nodes_in_box<'py>(
        &self,
        py: Python<'py>,
        min: &Bound<'py, PyAny>,
        max: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let min = arrays::vector3(py, min, "min")?;
        let max = arrays::vector3(py, max, "max")?;
        let nodes = on_cells!(&self.data.mesh, m => m.nodes_in_box(min, max));
        Ok(index_vector(py, &nodes))
    }

    /// Nodes whose entry of the boolean ``mask`` (shape (n,)) is true, e.g.
    /// ``mesh.nodes_where(mesh.points[:, 0] < 0.1)``.
    fn nodes_where<'py>(
        &self,
        py: Python<'py>,
        mask: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let mask = arrays::mask(py, mask, "mask", self.data.mesh.node_count())?;
        let nodes: Vec<usize> = (0..mask.len()).filter(|&n| mask[n]).collect();
        Ok(index_vector(py, &nodes))
    }

    /// Nodes of a Gmsh physical group (by name, or by tag as text), ascending.
    fn nodes_in_group<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyAny>> {
        Ok(index_vector(py, &self.data.group(py, name)?.nodes))
    }

    /// Nodes whose TetGen boundary marker equals ``marker``, ascending.
    fn nodes_with_marker<'py>(&self, py: Python<'py>, marker: i64) -> PyResult<Bound<'py, PyAny>> {
        let imported = self.data.imported(py, "a marker selection")?;
        if on_cells!(imported, i => i.node_markers.is_none()) {
            return Err(invalid(
                py,
                "marker",
                marker,
                "needs a TetGen mesh with node markers",
            ));
        }
        let nodes = on_cells!(imported, i => i.nodes_with_marker(marker));
        Ok(index_vector(py, &nodes))
    }

    /// The boundary faces that are triangles of the TetGen ``.face`` file with boundary marker
    /// ``marker``, shape (f, 3), in boundary order (``where = { face_marker = … }`` of scenes).
    /// A marker the file does not have raises ``InvalidInputError`` listing those it has.
    fn faces_with_marker<'py>(&self, py: Python<'py>, marker: i64) -> PyResult<Bound<'py, PyAny>> {
        let imported = self.data.face_marker_mesh(py, marker)?;
        let faces: Vec<[usize; 3]> = on_cells!(imported, i => i
            .faces_with_marker(marker, &self.data.boundary))
        .iter()
        .map(|f| f.nodes)
        .collect();
        index_rows(py, &faces)
    }

    /// The nodes of the TetGen ``.face`` triangles with boundary marker ``marker``, ascending
    /// (as ``faces_with_marker``, but interior triangles count too).
    fn nodes_with_face_marker<'py>(
        &self,
        py: Python<'py>,
        marker: i64,
    ) -> PyResult<Bound<'py, PyAny>> {
        let imported = self.data.face_marker_mesh(py, marker)?;
        let nodes = on_cells!(imported, i => i.nodes_with_face_marker(marker));
        Ok(index_vector(py, &nodes))
    }

    /// Tets whose centroid lies in the closed box [min, max] (length units), ascending: the
    /// rule of per-region materials in scenes.
    fn tets_in_box<'py>(
        &self,
        py: Python<'py>,
        min: &Bound<'py, PyAny>,
        max: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let min = arrays::vector3(py, min, "min")?;
        let max = arrays::vector3(py, max, "max")?;
        let mesh = &self.data.mesh;
        let nodes = mesh.nodes();
        let tets: Vec<usize> = (0..mesh.tet_count())
            .zip(mesh.corners())
            .filter(|(_, corners)| {
                let c = corners.iter().fold(Vector3::zeros(), |s, &n| s + nodes[n]) / 4.0;
                (0..3).all(|a| c[a] >= min[a] && c[a] <= max[a])
            })
            .map(|(t, _)| t)
            .collect();
        Ok(index_vector(py, &tets))
    }

    /// Tets of a Gmsh physical volume (by name or tag).
    fn tets_in_group<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyAny>> {
        let imported = self.data.imported(py, "a volume group selection")?;
        let tets = on_cells!(imported, i => tetfem::fe::materials::volume_group_tets(i, name))
            .or_raise(py)?;
        Ok(index_vector(py, tets))
    }

    /// Tets whose TetGen region attribute equals ``value``.
    fn tets_with_attribute<'py>(&self, py: Python<'py>, value: f64) -> PyResult<Bound<'py, PyAny>> {
        let imported = self.data.imported(py, "an attribute selection")?;
        let tets = on_cells!(imported, i => tetfem::fe::materials::attribute_tets(i, value))
            .or_raise(py)?;
        Ok(index_vector(py, &tets))
    }

    /// Every boundary triangle, shape (f, 3), node indices ordered so that the normal
    /// (n1 − n0) × (n2 − n0) points out of the body.
    fn boundary_faces<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let faces: Vec<[usize; 3]> = self.data.boundary.iter().map(|f| f.nodes).collect();
        index_rows(py, &faces)
    }

    /// The boundary faces all three of whose nodes are in ``nodes``, shape (f, 3), in boundary
    /// order: how scenes turn a node set into a face set.
    fn faces_of_nodes<'py>(
        &self,
        py: Python<'py>,
        nodes: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let nodes = self.data.nodes_of(py, nodes, "nodes")?;
        let mut selected = vec![false; self.data.mesh.node_count()];
        for n in nodes {
            selected[n] = true;
        }
        index_rows(py, &self.data.faces_with_nodes(&selected))
    }

    /// The boundary faces whose three nodes lie on the plane x[axis] = at (see
    /// ``nodes_on_plane``), shape (f, 3).
    #[pyo3(signature = (axis, at, tolerance = None))]
    fn faces_on_plane<'py>(
        &self,
        py: Python<'py>,
        axis: &Bound<'py, PyAny>,
        at: f64,
        tolerance: Option<f64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let nodes = self.nodes_on_plane(py, axis, at, tolerance)?;
        if nodes.len()? == 0 {
            return index_rows::<3>(py, &[]);
        }
        self.faces_of_nodes(py, &nodes)
    }

    /// The boundary faces whose three nodes lie in the closed box [min, max], shape (f, 3).
    fn faces_in_box<'py>(
        &self,
        py: Python<'py>,
        min: &Bound<'py, PyAny>,
        max: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let nodes = self.nodes_in_box(py, min, max)?;
        if nodes.len()? == 0 {
            return index_rows::<3>(py, &[]);
        }
        self.faces_of_nodes(py, &nodes)
    }

    /// The boundary faces all three of whose nodes have a true entry in the node ``mask``
    /// (shape (n,)), shape (f, 3).
    fn faces_where<'py>(
        &self,
        py: Python<'py>,
        mask: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let mask = arrays::mask(py, mask, "mask", self.data.mesh.node_count())?;
        index_rows(py, &self.data.faces_with_nodes(&mask))
    }

    /// The boundary faces that are triangles of a Gmsh physical surface (by name or tag).
    fn faces_in_group<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyAny>> {
        let faces: Vec<[usize; 3]> = self
            .data
            .group(py, name)?
            .boundary_faces(&self.data.boundary)
            .iter()
            .map(|f| f.nodes)
            .collect();
        index_rows(py, &faces)
    }

    /// A mesh from a ``meshio.Mesh`` (its points and ``tetra`` cells; needs meshio):
    /// ``tetfem.from_meshio``.
    #[staticmethod]
    fn from_meshio<'py>(py: Python<'py>, mesh: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        py.import("tetfem.meshio_interop")?
            .call_method1("from_meshio", (mesh,))
    }

    /// This mesh as a ``meshio.Mesh`` with optional ``point_data`` (one row per node) and
    /// ``cell_data`` (one entry per tet); needs meshio: ``tetfem.to_meshio``.
    #[pyo3(signature = (point_data = None, cell_data = None))]
    fn to_meshio<'py>(
        slf: &Bound<'py, Self>,
        point_data: Option<&Bound<'py, PyAny>>,
        cell_data: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        slf.py()
            .import("tetfem.meshio_interop")?
            .call_method1("to_meshio", (slf, point_data, cell_data))
    }

    fn __repr__(&self) -> String {
        format!(
            "Mesh({} nodes, {} tets of order {}, {} boundary faces)",
            self.data.mesh.node_count(),
            self.data.mesh.tet_count(),
            self.data.mesh.order(),
            self.data.boundary.len()
        )
    }
}
