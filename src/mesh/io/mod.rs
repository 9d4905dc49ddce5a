//! Mesh import and export: Gmsh `.msh` (4.1 ASCII and binary through the `mshio` crate, 2.2
//! ASCII with an own parser; 4.1 ASCII writer) and TetGen `.node`/`.ele` (reader and writer).
//!
//! Files of order 1 (4-node tets, Gmsh type 4) and order 2 (10-node tets: Gmsh type 11 with
//! 6-node triangles, type 9, for its surface groups; TetGen `-o2`) are read. The `_as::<C>`
//! readers build cells of type `C` (`Tet4`, or `tetfem::Tet10` for a quadratic file);
//! [`mesh_file_order`] tells which a file holds, and the plain readers build 4-node tets (of a
//! quadratic file its corners). Edge nodes keep the file's positions: off their edges'
//! midpoints (a curved mesh, as Gmsh makes on curved surfaces) the 10-node tet is curved
//! (isoparametric); one whose map folds (Jacobian determinant ≤ 0 anywhere in the tet: an edge
//! node far off, or the edge nodes in the wrong order) is an error naming the tet and the point.
//!
//! Readers return an [`ImportedMesh`]: the validated [`TetMesh`] plus what the file says about
//! its parts (Gmsh physical groups; TetGen node markers, `.face` markers, region attributes)
//! and the file's own node and element ids. Nodes that no tet uses (geometry points,
//! nodes of skipped elements) are dropped and counted, so that every remaining node carries
//! stiffness; the others keep their order. Every error is an [`Error::Parse`] naming the file
//! and the line (or, for binary data, the line count up to the byte offset).

mod gmsh;
mod gmsh22;
mod gmsh41_nodes;
mod raw;
mod tetgen;
mod text;

pub use gmsh::{parse_gmsh, parse_gmsh_as, read_gmsh, read_gmsh_as, write_gmsh};
pub use tetgen::{
    SKIPPED_EDGES, TetgenOptions, parse_tetgen, parse_tetgen_with_faces,
    parse_tetgen_with_faces_as, read_tetgen, read_tetgen_as, write_tetgen,
};

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::base::error::{Error, Result};
use crate::mesh::{BoundaryFace, CellType, NodeList, Tet4, TetMesh};

/// The [`ImportedMesh::skipped_elements`] entry that counts the 10-node tets of a quadratic
/// file read as 4-node cells (their corners kept, their edge nodes dropped).
pub const TET10_KEPT_AS_CORNERS: &str = "Tet10 (kept as Tet4 corners)";

/// A named or numbered set of mesh entities from a Gmsh physical group.
#[derive(Debug, Clone, PartialEq)]
pub struct PhysicalGroup {
    /// Dimension of the group's entities: 0 points, 1 curves, 2 surfaces, 3 volumes.
    pub dim: usize,
    /// The physical tag.
    pub tag: i32,
    /// The name from `$PhysicalNames`, if any.
    pub name: Option<String>,
    /// Triangles of a surface group, as mesh node triples in the file's order (not oriented);
    /// of 6-node triangles the corners.
    pub triangles: Vec<[usize; 3]>,
    /// Tets of a volume group (mesh tet indices).
    pub tets: Vec<usize>,
    /// Every mesh node the group's elements touch, ascending; on a mesh of 10-node tets with the
    /// edge nodes of its tets and of its triangles' edges.
    pub nodes: Vec<usize>,
}

impl PhysicalGroup {
    /// The boundary faces of `boundary` whose node triples are triangles of this group, in
    /// `boundary` order. Triangles inside the body (interfaces) match no boundary face.
    pub fn boundary_faces(&self, boundary: &[BoundaryFace]) -> Vec<BoundaryFace> {
        let mut keys: Vec<[usize; 3]> = self
            .triangles
            .iter()
            .map(|t| {
                let mut k = *t;
                k.sort_unstable();
                k
            })
            .collect();
        keys.sort_unstable();
        boundary
            .iter()
            .filter(|f| {
                let mut k = f.nodes;
                k.sort_unstable();
                keys.binary_search(&k).is_ok()
            })
            .copied()
            .collect()
    }

    /// A label for messages: `"name" (dim D, tag T)` or `(dim D, tag T)`.
    pub fn label(&self) -> String {
        match &self.name {
            Some(name) => format!("\"{name}\" (dim {}, tag {})", self.dim, self.tag),
            None => format!("(dim {}, tag {})", self.dim, self.tag),
        }
    }
}

/// A triangle of a TetGen `.face` file and its boundary marker.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MarkedFace {
    /// The triangle's mesh nodes in the file's order (not oriented).
    pub nodes: [usize; 3],
    /// The boundary marker.
    pub marker: i64,
}

/// A mesh read from a file as cells of type `C` (4-node tets by default), with the file's
/// extra information.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportedMesh<C: CellType = Tet4> {
    /// The validated mesh (tets reoriented where the file had them negative).
    pub mesh: TetMesh<C>,
    /// The file's id of each mesh node (Gmsh node tag, TetGen point number).
    pub node_ids: Vec<u64>,
    /// The file's id of each mesh tet (Gmsh element tag, TetGen tet number).
    pub tet_ids: Vec<u64>,
    /// Gmsh physical groups (empty for TetGen files), sorted by (dim, tag).
    pub groups: Vec<PhysicalGroup>,
    /// TetGen boundary marker of each mesh node, when the `.node` file has them.
    pub node_markers: Option<Vec<i64>>,
    /// TetGen regional attribute (the first attribute) of each tet, when the `.ele` file has one.
    pub tet_attributes: Option<Vec<f64>>,
    /// The marked triangles of a TetGen `.face` file, when one exists beside the `.node` file
    /// and has a marker column (triangles with a node no tet uses are dropped); of an `-o2`
    /// file the corners.
    pub face_markers: Option<Vec<MarkedFace>>,
    /// Elements of other types than tets and triangles that were skipped, counted per type
    /// name (e.g. `"Lin2"`, `"Pnt"`); the 10-node tets of a quadratic file read as 4-node
    /// cells as `"Tet10 (kept as Tet4 corners)"`.
    pub skipped_elements: BTreeMap<String, usize>,
    /// Nodes of the file that no tet uses (dropped).
    pub unused_nodes: usize,
}

impl<C: CellType> ImportedMesh<C> {
    /// The physical group with this name, or (if `key` is an integer) with this tag; surface
    /// groups are preferred when a tag exists in several dimensions.
    pub fn group(&self, key: &str) -> Option<&PhysicalGroup> {
        if let Some(g) = self.groups.iter().find(|g| g.name.as_deref() == Some(key)) {
            return Some(g);
        }
        let tag: i32 = key.trim().parse().ok()?;
        let mut matches: Vec<&PhysicalGroup> =
            self.groups.iter().filter(|g| g.tag == tag).collect();
        matches.sort_by_key(|g| if g.dim == 2 { 0 } else { 1 });
        matches.first().copied()
    }

    /// Nodes whose TetGen boundary marker equals `marker` (empty without markers).
    ///
    /// Equality, not bits: TetGen's markers are labels, not bit masks of groups. Its output
    /// `.node` copies each input point's marker and gives a point it inserts the marker of the
    /// facet it lies on (`tetgenmesh::outnodes`, TetGen 1.5), so a node where two marked
    /// facets meet carries one of their markers, never their combination. To select every node
    /// of a marked surface, select its faces' nodes (`.face` markers,
    /// [`nodes_with_face_marker`](Self::nodes_with_face_marker)).
    pub fn nodes_with_marker(&self, marker: i64) -> Vec<usize> {
        match &self.node_markers {
            Some(m) => (0..m.len()).filter(|&n| m[n] == marker).collect(),
            None => Vec::new(),
        }
    }

    /// The boundary faces of `boundary` whose node triples are `.face` triangles with this
    /// marker, in `boundary` order (empty without `.face` markers). Marked triangles inside the
    /// body (interfaces between regions) match no boundary face.
    pub fn faces_with_marker(&self, marker: i64, boundary: &[BoundaryFace]) -> Vec<BoundaryFace> {
        let Some(faces) = &self.face_markers else {
            return Vec::new();
        };
        let mut keys: Vec<[usize; 3]> = faces
            .iter()
            .filter(|f| f.marker == marker)
            .map(|f| sorted(f.nodes))
            .collect();
        keys.sort_unstable();
        boundary
            .iter()
            .filter(|f| keys.binary_search(&sorted(f.nodes)).is_ok())
            .copied()
            .collect()
    }

    /// The nodes of the `.face` triangles with this marker, ascending (empty without `.face`
    /// markers); on a mesh of 10-node tets with the edge nodes of the triangles' edges.
    pub fn nodes_with_face_marker(&self, marker: i64) -> Vec<usize> {
        let marked: Vec<[usize; 3]> = self
            .face_markers
            .iter()
            .flatten()
            .filter(|f| f.marker == marker)
            .map(|f| f.nodes)
            .collect();
        let mut nodes: Vec<usize> = marked.iter().flatten().copied().collect();
        if C::NODES > 4 && !marked.is_empty() {
            let mut edges = std::collections::HashMap::new();
            for cell in self.mesh.tets() {
                let corners = cell.corners();
                for a in 0..4 {
                    for b in a + 1..4 {
                        if let Some(m) = C::edge_node(cell, a, b) {
                            let (p, q) = (corners[a], corners[b]);
                            edges.insert((p.min(q), p.max(q)), m);
                        }
                    }
                }
            }
            for t in &marked {
                for k in 0..3 {
                    let (p, q) = (t[k], t[(k + 1) % 3]);
                    nodes.extend(edges.get(&(p.min(q), p.max(q))));
                }
            }
        }
        nodes.sort_unstable();
        nodes.dedup();
        nodes
    }

    /// Each TetGen node marker and how many nodes carry it (empty without node markers).
    pub fn node_marker_counts(&self) -> BTreeMap<i64, usize> {
        counts(self.node_markers.iter().flatten().copied())
    }

    /// Each `.face` marker and how many triangles carry it (empty without `.face` markers).
    pub fn face_marker_counts(&self) -> BTreeMap<i64, usize> {
        counts(self.face_markers.iter().flatten().map(|f| f.marker))
    }

    /// Each TetGen region attribute and how many tets carry it, in ascending order of the
    /// attribute (empty without attributes).
    pub fn attribute_counts(&self) -> Vec<(f64, usize)> {
        let mut values: Vec<f64> = self.tet_attributes.iter().flatten().copied().collect();
        values.sort_by(f64::total_cmp);
        let mut out: Vec<(f64, usize)> = Vec::new();
        for v in values {
            match out.last_mut() {
                Some((last, n)) if *last == v => *n += 1,
                _ => out.push((v, 1)),
            }
        }
        out
    }

    /// Total number of skipped elements.
    pub fn skipped_count(&self) -> usize {
        self.skipped_elements.values().sum()
    }
}

fn sorted(mut nodes: [usize; 3]) -> [usize; 3] {
    nodes.sort_unstable();
    nodes
}

fn counts(values: impl Iterator<Item = i64>) -> BTreeMap<i64, usize> {
    let mut out = BTreeMap::new();
    for v in values {
        *out.entry(v).or_insert(0) += 1;
    }
    out
}

/// Reads a mesh, choosing the format from the extension: `.msh` → Gmsh; `.node`, `.ele` or no
/// extension → TetGen (`<prefix>.node` + `<prefix>.ele`). As 4-node tets: of a quadratic file
/// the corners (see [`read_mesh_as`]).
pub fn read_mesh(path: &Path) -> Result<ImportedMesh> {
    read_mesh_as::<Tet4>(path)
}

/// [`read_mesh`] as cells of type `C`: `Tet4` for any file (of a quadratic one its corners),
/// `tetfem::Tet10` for a quadratic file (a linear one is an error naming the file).
pub fn read_mesh_as<C: CellType>(path: &Path) -> Result<ImportedMesh<C>> {
    match format_of(path)? {
        Format::Gmsh => read_gmsh_as(path),
        Format::Tetgen => read_tetgen_as(&path.with_extension("")),
    }
}

/// The element order of a mesh file's tets: 1 (4-node tets) or 2 (10-node tets), chosen by
/// the extension as [`read_mesh`] does. The file is parsed (a malformed one is the reader's
/// error) but no mesh is built or validated; of a TetGen pair only the `.ele` header is read.
/// To read the mesh too, [`MeshFile`] parses the file once for both.
pub fn mesh_file_order(path: &Path) -> Result<usize> {
    match format_of(path)? {
        Format::Gmsh => Ok(order_of(&gmsh::read_raw(path)?)),
        Format::Tetgen => tetgen::file_order(&path.with_extension("")),
    }
}

fn order_of(raw: &raw::RawMesh) -> usize {
    if raw.is_quadratic() { 2 } else { 1 }
}

/// A mesh file parsed but not yet built: its element [`order`](Self::order) is known, and
/// [`build_as`](Self::build_as) validates it and builds the cells of either order without
/// reading the file again (a caller that picks the cell type by the file's order parses the
/// file once, where [`mesh_file_order`] and then [`read_mesh_as`] parse it twice).
pub struct MeshFile {
    /// The path errors name (of a TetGen pair the `.ele` file).
    path: PathBuf,
    raw: raw::RawMesh,
}

impl std::fmt::Debug for MeshFile {
    /// The path and the counts (not the parsed data, which can be large).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MeshFile")
            .field("path", &self.path)
            .field("order", &self.order())
            .field("nodes", &self.raw.nodes.len())
            .field("tets", &self.raw.tets.len())
            .finish()
    }
}

impl MeshFile {
    /// Reads and parses a mesh file (the format from the extension, as [`read_mesh`]): every
    /// error of the file's syntax is reported here, those of the mesh itself (degenerate tets,
    /// edge nodes off their edges) by [`build_as`](Self::build_as).
    pub fn read(path: &Path) -> Result<MeshFile> {
        match format_of(path)? {
            Format::Gmsh => Ok(MeshFile {
                path: path.to_path_buf(),
                raw: gmsh::read_raw(path)?,
            }),
            Format::Tetgen => {
                let (raw, path) = tetgen::read_raw(&path.with_extension(""))?;
                Ok(MeshFile { path, raw })
            }
        }
    }

    /// The element order of the file's tets: 1 (4-node tets) or 2 (10-node tets).
    pub fn order(&self) -> usize {
        order_of(&self.raw)
    }

    /// The file this was read from (of a TetGen pair the `.ele` file).
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The mesh as cells of type `C`, as [`read_mesh_as`] builds it: `Tet4` for any file (of a
    /// quadratic one its corners), `tetfem::Tet10` for a quadratic file (a linear one is an
    /// error naming the file).
    pub fn build_as<C: CellType>(self) -> Result<ImportedMesh<C>> {
        self.raw.finish(&self.path)
    }
}

enum Format {
    Gmsh,
    Tetgen,
}

fn format_of(path: &Path) -> Result<Format> {
    match path.extension().and_then(|e| e.to_str()) {
        Some("msh") => Ok(Format::Gmsh),
        Some("node") | Some("ele") | None => Ok(Format::Tetgen),
        Some(other) => Err(Error::parse(
            path,
            0,
            format!(
                "unknown mesh format '.{other}': expected a Gmsh .msh file or a TetGen .node/.ele pair"
            ),
        )),
    }
}
