//! The format-independent last step of every reader: drop unused nodes, renumber, validate the
//! mesh, and point validation errors at the file line of the culprit.

use std::collections::BTreeMap;
use std::path::Path;

use nalgebra::Vector3;

use super::{ImportedMesh, MarkedFace, PhysicalGroup};
use crate::error::{Error, Result};
use crate::mesh::TetMesh;

/// A group as read, in file-order node indices.
#[derive(Debug, Default)]
pub(crate) struct RawGroup {
    pub dim: usize,
    pub tag: i32,
    pub name: Option<String>,
    pub triangles: Vec<[usize; 3]>,
    pub tets: Vec<usize>,
    /// Nodes of elements of other types (points, lines) that belong to the group.
    pub other_nodes: Vec<usize>,
}

/// What a reader collected, indices into its own node list (file order, 0-based).
#[derive(Debug, Default)]
pub(crate) struct RawMesh {
    pub nodes: Vec<Vector3<f64>>,
    pub node_lines: Vec<usize>,
    pub node_ids: Vec<u64>,
    pub node_markers: Option<Vec<i64>>,
    pub tets: Vec<[usize; 4]>,
    pub tet_lines: Vec<usize>,
    /// The file's id of each tet (same length as `tets`).
    pub tet_ids: Vec<u64>,
    /// TetGen `.face` triangles with their markers.
    pub face_markers: Option<Vec<MarkedFace>>,
    pub tet_attributes: Option<Vec<f64>>,
    pub groups: Vec<RawGroup>,
    pub skipped: BTreeMap<String, usize>,
    /// The 3-D elements among `skipped` (other than 4-node tets), per type name, and the line
    /// of the first one: they are part of the body, so the mesh cannot run without them.
    pub skipped_volume: BTreeMap<String, usize>,
    pub skipped_volume_line: usize,
}

/// 3-D element types of order 1 other than tets (Gmsh names); every other 3-D type but Tet4
/// is of higher order.
const LINEAR_NON_TET: [&str; 3] = ["Hex8", "Pri6", "Pyr5"];

impl RawMesh {
    /// Compacts, validates and packages the mesh; `path` is named in errors.
    pub fn finish(self, path: &Path) -> Result<ImportedMesh> {
        self.check_volume_elements(path)?;
        if self.tets.is_empty() {
            let skipped: usize = self.skipped.values().sum();
            return Err(Error::parse(
                path,
                self.node_lines.last().copied().unwrap_or(0),
                format!(
                    "the file holds no 4-node tetrahedra ({} nodes, {skipped} other elements skipped: {:?})",
                    self.nodes.len(),
                    self.skipped
                ),
            ));
        }
        // New index of each used node, in file order.
        let mut new_index = vec![usize::MAX; self.nodes.len()];
        for tet in &self.tets {
            for &n in tet {
                new_index[n] = 0;
            }
        }
        let mut kept = Vec::new();
        for (old, slot) in new_index.iter_mut().enumerate() {
            if *slot == 0 {
                *slot = kept.len();
                kept.push(old);
            }
        }
        let unused_nodes = self.nodes.len() - kept.len();
        let nodes: Vec<Vector3<f64>> = kept.iter().map(|&o| self.nodes[o]).collect();
        let tets: Vec<[usize; 4]> = self.tets.iter().map(|t| t.map(|n| new_index[n])).collect();
        let mesh = TetMesh::new(nodes, tets).map_err(|e| {
            let line = match &e {
                Error::DegenerateTet { tet, .. } | Error::RepeatedNode { tet, .. } => {
                    self.tet_lines.get(*tet).copied().unwrap_or(0)
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
            .into_iter()
            .map(|g| {
                // Triangles with a node outside the tet mesh cannot be faces of it.
                let triangles: Vec<[usize; 3]> = g
                    .triangles
                    .iter()
                    .filter(|t| {
                        t.iter()
                            .all(|&n| new_index.get(n).is_some_and(|&i| i != usize::MAX))
                    })
                    .map(|t| t.map(|n| new_index[n]))
                    .collect();
                let mut all: Vec<usize> = g.other_nodes.clone();
                all.extend(g.triangles.iter().flatten());
                all.extend(g.tets.iter().filter_map(|&t| self.tets.get(t)).flatten());
                PhysicalGroup {
                    dim: g.dim,
                    tag: g.tag,
                    name: g.name,
                    triangles,
                    tets: g.tets,
                    nodes: remap(&all),
                }
            })
            .collect();
        groups.sort_by_key(|g| (g.dim, g.tag));
        let keep = |v: Vec<i64>| kept.iter().map(|&o| v[o]).collect();
        // A marked triangle with a node no tet uses cannot be a face of the mesh.
        let face_markers = self.face_markers.map(|faces| {
            faces
                .into_iter()
                .filter(|f| {
                    f.nodes
                        .iter()
                        .all(|&n| new_index.get(n).is_some_and(|&i| i != usize::MAX))
                })
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

    /// Rejects a mesh whose body holds 3-D elements other than 4-node tets: running on the tets
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
            "tetfem has linear 4-node tets only (no quadratic element yet): mesh at order 1 \
             (gmsh -3 -order 1, or Mesh.ElementOrder = 1)"
        } else {
            "tetfem meshes are 4-node tets only: mesh the volumes with tetrahedra alone \
             (drop Recombine and the recombined Extrude Layers from the .geo)"
        };
        Err(Error::parse(
            path,
            self.skipped_volume_line,
            format!(
                "the mesh has 3-D elements other than 4-node tets ({}, besides {} Tet4); \
                 running without them would cut the body: {fix}",
                counts.join(", "),
                self.tets.len()
            ),
        ))
    }
}
