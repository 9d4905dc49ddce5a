//! The format-independent last step of every reader: drop unused nodes, renumber, validate the
//! mesh, and point validation errors at the file line of the culprit.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

use nalgebra::Vector3;

use super::{ImportedMesh, MarkedFace, PhysicalGroup};
use crate::base::error::{Error, Result};
use crate::mesh::{CellType, NodeList, TetMesh};

/// A group as read, in file-order node indices.
#[derive(Debug, Default)]
pub(crate) struct RawGroup {
    pub dim: usize,
    pub tag: i32,
    pub name: Option<String>,
    /// Corner triples of the group's triangles (3- or 6-node).
    pub triangles: Vec<[usize; 3]>,
    pub tets: Vec<usize>,
    /// Nodes of elements of other types (points, lines) that belong to the group, and the
    /// mid-side nodes of its 6-node triangles.
    pub other_nodes: Vec<usize>,
}

/// The mid-side nodes a file gives a triangle (a Gmsh 6-node triangle, a TetGen `-o2` face),
/// checked against the tets' edge nodes: `mids[k]` sits on the edge (`corners[k]`,
/// `corners[(k + 1) % 3]`).
#[derive(Debug)]
pub(crate) struct RawTriangleMids {
    pub corners: [usize; 3],
    pub mids: [usize; 3],
    pub line: usize,
}

/// The edge nodes a TetGen `-o2` `.face` row lists (in an order TetGen does not fix), checked
/// to be the tets' edge nodes of the face's edges once the tets are known to be sound.
#[derive(Debug)]
pub(crate) struct ListedEdgeNodes {
    pub path: PathBuf,
    pub line: usize,
    pub corners: [usize; 3],
    /// The listed nodes (file-order indices; `usize::MAX`-wrapped when out of range).
    pub listed: [usize; 3],
    /// The file's first index, for messages.
    pub base: usize,
}

/// What a reader collected, indices into its own node list (file order, 0-based).
#[derive(Debug, Default)]
pub(crate) struct RawMesh {
    pub nodes: Vec<Vector3<f64>>,
    pub node_lines: Vec<usize>,
    pub node_ids: Vec<u64>,
    pub node_markers: Option<Vec<i64>>,
    /// The corners of each tet, in the file's order.
    pub tets: Vec<[usize; 4]>,
    /// The edge nodes of each tet of a quadratic (10-node) file, in [`VTK_EDGES`] order of its
    /// corners; empty for a linear file (else as long as `tets`).
    pub edge_nodes: Vec<[usize; 6]>,
    /// The line of the first element of the other order, when a file mixes 4- and 10-node
    /// tets (an error).
    pub mixed_order_line: Option<usize>,
    pub tet_lines: Vec<usize>,
    /// The file's id of each tet (same length as `tets`).
    pub tet_ids: Vec<u64>,
    /// TetGen `.face` triangles with their markers.
    pub face_markers: Option<Vec<MarkedFace>>,
    /// Triangles with mid-side nodes of their own, to check against the tets.
    pub triangle_mids: Vec<RawTriangleMids>,
    /// `.face` rows with edge nodes, to check against the tets after the tets' own checks.
    pub listed_edge_nodes: Vec<ListedEdgeNodes>,
    pub tet_attributes: Option<Vec<f64>>,
    pub groups: Vec<RawGroup>,
    pub skipped: BTreeMap<String, usize>,
    /// The 3-D elements among `skipped` (other than 4- and 10-node tets), per type name, and
    /// the line of the first one: they are part of the body, so the mesh cannot run without
    /// them.
    pub skipped_volume: BTreeMap<String, usize>,
    pub skipped_volume_line: usize,
}

/// 3-D element types of order 1 other than tets (Gmsh names); every other 3-D type but Tet4
/// and Tet10 is of higher order.
const LINEAR_NON_TET: [&str; 3] = ["Hex8", "Pri6", "Pyr5"];

/// The edges of a tet as pairs of its local corners, in the order of VTK's quadratic tet (type
/// 24) — the order [`RawMesh::edge_nodes`] holds its edge nodes in.
pub(crate) const VTK_EDGES: [(usize, usize); 6] = [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)];

/// A corner pair as a key, smaller node first.
fn edge_key(a: usize, b: usize) -> (usize, usize) {
    (a.min(b), a.max(b))
}

impl RawMesh {
    /// Adds a 10-node tet: its corners and its edge nodes in [`VTK_EDGES`] order. A file that
    /// mixes it with 4-node tets is an error (reported by [`finish`](Self::finish)).
    pub fn push_quadratic(&mut self, corners: [usize; 4], edges: [usize; 6], line: usize, id: u64) {
        if self.edge_nodes.len() != self.tets.len() {
            self.mixed_order_line.get_or_insert(line);
        }
        self.tets.push(corners);
        self.edge_nodes.push(edges);
        self.tet_lines.push(line);
        self.tet_ids.push(id);
    }

    /// Adds a 4-node tet (see [`push_quadratic`](Self::push_quadratic)).
    pub fn push_linear(&mut self, corners: [usize; 4], line: usize, id: u64) {
        if !self.edge_nodes.is_empty() {
            self.mixed_order_line.get_or_insert(line);
        }
        self.tets.push(corners);
        self.tet_lines.push(line);
        self.tet_ids.push(id);
    }

    /// Whether the file's tets are 10-node tets.
    pub fn is_quadratic(&self) -> bool {
        !self.edge_nodes.is_empty()
    }

    /// The edge node of each edge (corner pair) of the file's 10-node tets.
    fn edge_map(&self) -> HashMap<(usize, usize), usize> {
        let mut map = HashMap::with_capacity(self.edge_nodes.len() * 2);
        for (tet, edges) in self.tets.iter().zip(&self.edge_nodes) {
            for (&(i, j), &m) in VTK_EDGES.iter().zip(edges) {
                map.entry(edge_key(tet[i], tet[j])).or_insert(m);
            }
        }
        map
    }

    /// Checks that the tets of the file agree on each edge's node, and that the mid-side nodes
    /// of triangles are the edge nodes of the tets (where the triangle's edge is a tet edge).
    fn check_edge_nodes(&self, path: &Path, map: &HashMap<(usize, usize), usize>) -> Result<()> {
        for (t, (tet, edges)) in self.tets.iter().zip(&self.edge_nodes).enumerate() {
            for (&(i, j), &m) in VTK_EDGES.iter().zip(edges) {
                let first = map[&edge_key(tet[i], tet[j])];
                if first != m {
                    return Err(Error::parse(
                        path,
                        self.tet_lines[t],
                        format!(
                            "tet {} gives the edge of nodes {} and {} the mid-side node {}, another tet gives it node {}: the tets must share their edge nodes",
                            self.tet_ids[t],
                            self.node_ids[tet[i]],
                            self.node_ids[tet[j]],
                            self.node_ids[m],
                            self.node_ids[first]
                        ),
                    ));
                }
            }
        }
        for tri in &self.triangle_mids {
            for k in 0..3 {
                let (a, b) = (tri.corners[k], tri.corners[(k + 1) % 3]);
                if let Some(&m) = map.get(&edge_key(a, b))
                    && m != tri.mids[k]
                {
                    return Err(Error::parse(
                        path,
                        tri.line,
                        format!(
                            "the triangle's mid-side node {} on the edge of nodes {} and {} is not the tets' node {} on that edge",
                            self.node_ids[tri.mids[k]],
                            self.node_ids[a],
                            self.node_ids[b],
                            self.node_ids[m]
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    /// The `.face` rows' listed edge nodes against the tets' (see [`ListedEdgeNodes`]).
    fn check_listed_edge_nodes(&self, map: &HashMap<(usize, usize), usize>) -> Result<()> {
        for face in &self.listed_edge_nodes {
            for k in 0..3 {
                let (a, b) = (face.corners[k], face.corners[(k + 1) % 3]);
                if let Some(&m) = map.get(&edge_key(a, b))
                    && !face.listed.contains(&m)
                {
                    return Err(Error::parse(
                        &face.path,
                        face.line,
                        format!(
                            "the face's edge nodes {:?} do not include node {}, the tets' node \
                             on the edge of nodes {} and {}",
                            face.listed.map(|n| n.wrapping_add(face.base)),
                            self.node_ids[m],
                            self.node_ids[a],
                            self.node_ids[b]
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    /// Compacts, validates and packages the mesh as cells of type `C`; `path` is named in
    /// errors, with the file line of the culprit (a tet's from `tet_lines`).
    ///
    /// A quadratic file read as 4-node cells keeps its tets' corners (the mid-side nodes are
    /// dropped as unused, and the tets are counted in `skipped` as `"Tet10 (kept as Tet4
    /// corners)"`); a linear file read as 10-node cells is an error, as are cells of another
    /// node count.
    pub fn finish<C: CellType>(mut self, path: &Path) -> Result<ImportedMesh<C>> {
        self.check_volume_elements(path)?;
        self.check_tets_present(path)?;
        let edges = self.is_quadratic().then(|| self.edge_map());
        let as_quadratic = self.read_order::<C>(path)?;
        let (new_index, kept) = self.numbering(as_quadratic);
        let unused_nodes = self.nodes.len() - kept.len();
        let nodes: Vec<Vector3<f64>> = kept.iter().map(|&o| self.nodes[o]).collect();
        let cells = self.cells::<C>(as_quadratic, &new_index);
        self.check_cells::<C>(path, &cells, &nodes)?;
        // After each tet's own check, so that a tet with misplaced edge nodes is named itself
        // rather than as a neighbour's disagreement.
        if let Some(map) = &edges {
            self.check_edge_nodes(path, map)?;
            self.check_listed_edge_nodes(map)?;
        }
        let mesh = TetMesh::from_cells(nodes, cells).map_err(|e| {
            let line = match &e {
                Error::DegenerateTet { tet, .. } | Error::RepeatedNode { tet, .. } => {
                    self.line_of_tet(*tet)
                }
                Error::NonFiniteCoordinate { node, .. } => kept
                    .get(*node)
                    .and_then(|&o| self.node_lines.get(o))
                    .copied()
                    .unwrap_or(0),
                _ => 0,
            };
            Error::parse(path, line, format!("invalid mesh: {e}"))
        })?;
        let groups = self.physical_groups(as_quadratic, edges.as_ref(), &new_index);
        let keep = |v: Vec<i64>| kept.iter().map(|&o| v[o]).collect();
        // A marked triangle with a node no tet uses cannot be a face of the mesh.
        let face_markers = self.face_markers.map(|faces| {
            faces
                .into_iter()
                .filter(|f| f.nodes.iter().all(|&n| is_kept(&new_index, n)))
                .map(|f| MarkedFace {
                    nodes: f.nodes.map(|n| new_index[n]),
                    marker: f.marker,
                })
                .collect()
        });
        Ok(ImportedMesh {
            node_ids: kept.iter().map(|&o| self.node_ids[o]).collect(),
            tet_ids: self.tet_ids,
            face_markers,
            node_markers: self.node_markers.map(keep),
            tet_attributes: self.tet_attributes,
            groups,
            skipped_elements: self.skipped,
            unused_nodes,
            mesh,
        })
    }

    /// The file line of tet `t` (0 when unknown).
    fn line_of_tet(&self, t: usize) -> usize {
        self.tet_lines.get(t).copied().unwrap_or(0)
    }

    /// A file with tets, all of one order (named at the last node's line or the first tet of
    /// the other order).
    fn check_tets_present(&self, path: &Path) -> Result<()> {
        if self.tets.is_empty() {
            let skipped: usize = self.skipped.values().sum();
            return Err(Error::parse(
                path,
                self.node_lines.last().copied().unwrap_or(0),
                format!(
                    "the file holds no 4- or 10-node tetrahedra ({} nodes, {skipped} other elements skipped: {:?})",
                    self.nodes.len(),
                    self.skipped
                ),
            ));
        }
        if let Some(line) = self.mixed_order_line {
            return Err(Error::parse(
                path,
                line,
                "the file mixes 4-node and 10-node tets from this element on: a mesh is of one \
                 order (mesh it again at order 1 or 2 throughout)",
            ));
        }
        Ok(())
    }

    /// Whether the tets are read as 10-node cells: a quadratic file as `Tet10`, or as `Tet4`
    /// keeping the corners (counted in `skipped`); a linear file read as 10-node cells, or a
    /// cell type of another node count, is an error.
    fn read_order<C: CellType>(&mut self, path: &Path) -> Result<bool> {
        match (C::NODES, self.is_quadratic()) {
            (4, false) => Ok(false),
            (10, true) => Ok(true),
            (4, true) => {
                self.skipped
                    .insert(super::TET10_KEPT_AS_CORNERS.into(), self.tets.len());
                Ok(false)
            }
            (10, false) => Err(Error::parse(
                path,
                self.line_of_tet(0),
                format!(
                    "the file holds 4-node (linear) tets, not the 10-node tets asked for \
                     ({}): mesh at order 2 (gmsh -order 2, tetgen -o2) or read it as a \
                     linear mesh",
                    C::NAME
                ),
            )),
            (n, _) => Err(Error::parse(
                path,
                0,
                format!(
                    "the mesh readers build 4- and 10-node tets, not {n}-node cells ({})",
                    C::NAME
                ),
            )),
        }
    }

    /// The new index of each file node (`usize::MAX` for a node no kept cell uses), in file
    /// order, and the file index of each kept node.
    fn numbering(&self, as_quadratic: bool) -> (Vec<usize>, Vec<usize>) {
        let mut new_index = vec![usize::MAX; self.nodes.len()];
        for tet in &self.tets {
            for &n in tet {
                new_index[n] = 0;
            }
        }
        if as_quadratic {
            for tet in &self.edge_nodes {
                for &n in tet {
                    new_index[n] = 0;
                }
            }
        }
        let mut kept = Vec::new();
        for (old, slot) in new_index.iter_mut().enumerate() {
            if *slot == 0 {
                *slot = kept.len();
                kept.push(old);
            }
        }
        (new_index, kept)
    }

    /// The element's own checks of each cell (a curved 10-node tet's map does not fold),
    /// naming the tet's line and file id.
    fn check_cells<C: CellType>(
        &self,
        path: &Path,
        cells: &[C::Nodes],
        nodes: &[Vector3<f64>],
    ) -> Result<()> {
        for (t, cell) in cells.iter().enumerate() {
            C::check_cell(t, cell, nodes).map_err(|e| {
                Error::parse(
                    path,
                    self.line_of_tet(t),
                    format!(
                        "invalid mesh: {e} (file tet {}; edge nodes in another order than the \
                         reader's, or moved too far: Gmsh's Mesh.SecondOrderLinear = 1 keeps \
                         them at the midpoints)",
                        self.tet_ids[t]
                    ),
                )
            })?;
        }
        Ok(())
    }

    /// The physical groups in new node numbers, sorted by (dimension, tag): each with its
    /// triangles that are faces of the kept mesh, its tets, and every node it holds (with a
    /// quadratic mesh, the edge nodes of its tets and of its triangles' edges too).
    fn physical_groups(
        &self,
        as_quadratic: bool,
        edges: Option<&HashMap<(usize, usize), usize>>,
        new_index: &[usize],
    ) -> Vec<PhysicalGroup> {
        let remap = |list: &[usize]| -> Vec<usize> {
            let mut out: Vec<usize> = list
                .iter()
                .filter_map(|&n| new_index.get(n).copied())
                .filter(|&n| n != usize::MAX)
                .collect();
            out.sort_unstable();
            out.dedup();
            out
        };
        let mut groups: Vec<PhysicalGroup> = self
            .groups
            .iter()
            .map(|g| {
                // Triangles with a node outside the tet mesh cannot be faces of it.
                let triangles: Vec<[usize; 3]> = g
                    .triangles
                    .iter()
                    .filter(|t| t.iter().all(|&n| is_kept(new_index, n)))
                    .map(|t| t.map(|n| new_index[n]))
                    .collect();
                let mut all: Vec<usize> = g.other_nodes.clone();
                all.extend(g.triangles.iter().flatten());
                all.extend(g.tets.iter().filter_map(|&t| self.tets.get(t)).flatten());
                if as_quadratic {
                    // The edge nodes of the group's tets and of its triangles' edges (a
                    // 3-node triangle on a 10-node mesh has none of its own).
                    all.extend(
                        g.tets
                            .iter()
                            .filter_map(|&t| self.edge_nodes.get(t))
                            .flatten(),
                    );
                    if let Some(map) = edges {
                        for t in &g.triangles {
                            for k in 0..3 {
                                all.extend(map.get(&edge_key(t[k], t[(k + 1) % 3])));
                            }
                        }
                    }
                }
                PhysicalGroup {
                    dim: g.dim,
                    tag: g.tag,
                    name: g.name.clone(),
                    triangles,
                    tets: g.tets.clone(),
                    nodes: remap(&all),
                }
            })
            .collect();
        groups.sort_by_key(|g| (g.dim, g.tag));
        groups
    }

    /// The cells of type `C` in new node indices: the corners, and (`quadratic`) each edge node
    /// in the slot `C` keeps for its edge ([`CellType::edge_node`] of a cell numbered 0…n−1).
    fn cells<C: CellType>(&self, quadratic: bool, new_index: &[usize]) -> Vec<C::Nodes> {
        let identity: Vec<usize> = (0..C::NODES).collect();
        // Both exist: `finish` admits 4-node cells and 10-node cells of a quadratic file only.
        let Some(probe) = C::Nodes::from_slice(&identity) else {
            return Vec::new();
        };
        let slots: Vec<usize> = VTK_EDGES
            .iter()
            .map(|&(i, j)| C::edge_node(&probe, i, j).unwrap_or(0))
            .collect();
        let mut cell = vec![0; C::NODES];
        self.tets
            .iter()
            .enumerate()
            .filter_map(|(t, corners)| {
                cell[..4].copy_from_slice(&corners.map(|n| new_index[n]));
                if quadratic {
                    for (k, &slot) in slots.iter().enumerate() {
                        cell[slot] = new_index[self.edge_nodes[t][k]];
                    }
                }
                C::Nodes::from_slice(&cell)
            })
            .collect()
    }
}

impl RawMesh {
    /// Counts a skipped element of type `name`; `volume` if it is 3-D (part of the body).
    pub fn skip(&mut self, name: &str, volume: bool, line: usize) {
        *self.skipped.entry(name.to_string()).or_insert(0) += 1;
        if volume {
            if self.skipped_volume.is_empty() {
                self.skipped_volume_line = line;
            }
            *self.skipped_volume.entry(name.to_string()).or_insert(0) += 1;
        }
    }

    /// Rejects a mesh whose body holds 3-D elements other than 4- and 10-node tets: running on the tets
    /// alone would cut the body silently (a mesh of tets and prisms would lose the prisms).
    fn check_volume_elements(&self, path: &Path) -> Result<()> {
        if self.skipped_volume.is_empty() {
            return Ok(());
        }
        let counts: Vec<String> = self
            .skipped_volume
            .iter()
            .map(|(name, n)| format!("{n} {name}"))
            .collect();
        let higher_order = self
            .skipped_volume
            .keys()
            .any(|name| !LINEAR_NON_TET.contains(&name.as_str()));
        let fix = if higher_order {
            "tetfem has 4-node and 10-node tets (orders 1 and 2): mesh at order 1 or 2 \
             (gmsh -3 -order 2, or Mesh.ElementOrder = 2; curved or serendipity elements are \
             not supported)"
        } else {
            "tetfem meshes are tets only: mesh the volumes with tetrahedra alone \
             (drop Recombine and the recombined Extrude Layers from the .geo)"
        };
        Err(Error::parse(
            path,
            self.skipped_volume_line,
            format!(
                "the mesh has 3-D elements other than 4- and 10-node tets ({}, besides {} {}); \
                 running without them would cut the body: {fix}",
                counts.join(", "),
                self.tets.len(),
                if self.is_quadratic() { "Tet10" } else { "Tet4" }
            ),
        ))
    }
}

/// Whether file node `n` is used by a kept cell (`new_index` from `RawMesh::numbering`).
fn is_kept(new_index: &[usize], n: usize) -> bool {
    new_index.get(n).is_some_and(|&i| i != usize::MAX)
}
