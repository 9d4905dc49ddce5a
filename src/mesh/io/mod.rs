//! Mesh import and export: Gmsh `.msh` (4.1 ASCII and binary through the `mshio` crate, 2.2
//! ASCII with an own parser; 4.1 ASCII writer) and TetGen `.node`/`.ele` (reader and writer).
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

pub use gmsh::{parse_gmsh, read_gmsh, write_gmsh};
pub use tetgen::{TetgenOptions, parse_tetgen, parse_tetgen_with_faces, read_tetgen, write_tetgen};

use std::collections::BTreeMap;
use std::path::Path;

use crate::error::{Error, Result};
use crate::mesh::{BoundaryFace, TetMesh};

/// A named or numbered set of mesh entities from a Gmsh physical group.
#[derive(Debug, Clone, PartialEq)]
pub struct PhysicalGroup {
    /// Dimension of the group's entities: 0 points, 1 curves, 2 surfaces, 3 volumes.
    pub dim: usize,
    /// The physical tag.
    pub tag: i32,
    /// The name from `$PhysicalNames`, if any.
    pub name: Option<String>,
    /// Triangles of a surface group, as mesh node triples in the file's order (not oriented).
    pub triangles: Vec<[usize; 3]>,
    /// Tets of a volume group (mesh tet indices).
    pub tets: Vec<usize>,
    /// Every mesh node the group's elements touch, ascending.
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

/// A mesh read from a file, with the file's extra information.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportedMesh {
    /// The validated mesh (tets reoriented where the file had them negative).
    pub mesh: TetMesh,
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
    /// and has a marker column (triangles with a node no tet uses are dropped).
    pub face_markers: Option<Vec<MarkedFace>>,
    /// Elements of other types than 4-node tets and 3-node triangles that were skipped, counted
    /// per type name (e.g. `"Lin2"`, `"Pnt"`, `"Tet10"`).
    pub skipped_elements: BTreeMap<String, usize>,
    /// Nodes of the file that no tet uses (dropped).
    pub unused_nodes: usize,
}

impl ImportedMesh {
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
    /// markers).
    pub fn nodes_with_face_marker(&self, marker: i64) -> Vec<usize> {
        let mut nodes: Vec<usize> = self
            .face_markers
            .iter()
            .flatten()
            .filter(|f| f.marker == marker)
            .flat_map(|f| f.nodes)
            .collect();
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
/// extension → TetGen (`<prefix>.node` + `<prefix>.ele`).
pub fn read_mesh(path: &Path) -> Result<ImportedMesh> {
    match path.extension().and_then(|e| e.to_str()) {
        Some("msh") => read_gmsh(path),
        Some("node") | Some("ele") | None => read_tetgen(&path.with_extension("")),
        Some(other) => Err(Error::parse(
            path,
            0,
            format!(
                "unknown mesh format '.{other}': expected a Gmsh .msh file or a TetGen .node/.ele pair"
            ),
        )),
    }
}
