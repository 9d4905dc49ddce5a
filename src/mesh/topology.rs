//! Face topology: which triangles are on the boundary and which tets share a face.

use nalgebra::Vector3;

use super::{CellType, NodeList, TetMesh};
use crate::base::error::{Error, Result};
use crate::mesh::geometry::FACES;

/// A boundary triangle: a tet face that no other tet shares.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BoundaryFace {
    /// The tet it belongs to.
    pub tet: usize,
    /// Its three corner nodes, ordered so that (n₁−n₀)×(n₂−n₀) points out of the body.
    pub nodes: [usize; 3],
}

impl BoundaryFace {
    /// Area vector ½(n₁−n₀)×(n₂−n₀): outward normal times area (length² units).
    /// [`Error::UnknownNode`] if the face names a node `mesh` does not have.
    pub fn area_vector<C: CellType>(&self, mesh: &TetMesh<C>) -> Result<Vector3<f64>> {
        let p = self.positions(mesh)?;
        Ok((p[1] - p[0]).cross(&(p[2] - p[0])) * 0.5)
    }

    /// Centroid of the triangle ([`Error::UnknownNode`] as for [`area_vector`](Self::area_vector)).
    pub fn centroid<C: CellType>(&self, mesh: &TetMesh<C>) -> Result<Vector3<f64>> {
        let p = self.positions(mesh)?;
        Ok((p[0] + p[1] + p[2]) / 3.0)
    }

    /// All nodes of the face on a mesh of cell type `C`: its three corners (in the face's
    /// order), then, for cells with edge nodes, the nodes of its edges (0,1), (1,2), (2,0).
    /// [`Error::UnknownTet`] if the face's tet is not in `mesh`, [`Error::UnknownNode`] if a
    /// corner is not one of that tet's.
    pub fn element_nodes<C: CellType>(&self, mesh: &TetMesh<C>) -> Result<Vec<usize>> {
        mesh.check_tet("boundary face", self.tet)?;
        let cell = &mesh.tets()[self.tet];
        let corners = cell.corners();
        let mut local = [0usize; 3];
        for (l, &n) in local.iter_mut().zip(&self.nodes) {
            *l = corners
                .iter()
                .position(|&c| c == n)
                .ok_or(Error::UnknownNode {
                    context: "boundary face (a corner of its tet)",
                    node: n,
                    node_count: mesh.node_count(),
                })?;
        }
        let mut nodes = self.nodes.to_vec();
        for k in 0..3 {
            if let Some(edge) = C::edge_node(cell, local[k], local[(k + 1) % 3]) {
                nodes.push(edge);
            }
        }
        Ok(nodes)
    }

    fn positions<C: CellType>(&self, mesh: &TetMesh<C>) -> Result<[Vector3<f64>; 3]> {
        let mut p = [Vector3::zeros(); 3];
        for (p, &n) in p.iter_mut().zip(&self.nodes) {
            *p = *mesh.nodes().get(n).ok_or(Error::UnknownNode {
                context: "boundary face",
                node: n,
                node_count: mesh.node_count(),
            })?;
        }
        Ok(p)
    }
}

/// Boundary faces and face-neighbour pairs of a mesh.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FaceTopology {
    /// Faces that belong to exactly one tet, outward oriented.
    pub boundary: Vec<BoundaryFace>,
    /// Pairs of tets that share a face (each interior face once).
    pub neighbours: Vec<(usize, usize)>,
}

impl<C: CellType> TetMesh<C> {
    /// Classifies every tet face as boundary (one tet) or interior (two tets).
    ///
    /// Also checks how the tets fit together, which [`TetMesh::new`] (one tet at a time) cannot:
    /// a tet given twice is [`Error::DuplicateTet`]; two face neighbours on the same side of
    /// their face (a fold, an inverted element) are [`Error::InvertedTet`]; a face shared by three
    /// or more tets is [`Error::NonManifoldFace`]. Every solver runs this before it assembles.
    pub fn face_topology(&self) -> Result<FaceTopology> {
        // Sort all 4·n faces by their sorted node triple; equal neighbours share a face.
        let mut faces: Vec<([usize; 3], usize, usize)> = Vec::with_capacity(4 * self.tet_count());
        for (t, tet) in self.tets().iter().enumerate() {
            let tet = tet.corners();
            for (local, (face, _)) in FACES.iter().enumerate() {
                let mut key = face.map(|i| tet[i]);
                key.sort_unstable();
                faces.push((key, t, local));
            }
        }
        faces.sort_unstable();
        let mut boundary = Vec::new();
        let mut neighbours = Vec::new();
        let mut i = 0;
        while i < faces.len() {
            let mut j = i + 1;
            while j < faces.len() && faces[j].0 == faces[i].0 {
                j += 1;
            }
            self.check_no_duplicates(&faces[i..j])?;
            match j - i {
                1 => {
                    let (_, tet, local) = faces[i];
                    boundary.push(self.outward_face(tet, local));
                }
                2 => {
                    self.check_opposite_sides(faces[i], faces[i + 1])?;
                    neighbours.push((faces[i].1, faces[i + 1].1));
                }
                _ => {
                    return Err(Error::NonManifoldFace {
                        face: faces[i].0,
                        tets: [faces[i].1, faces[i + 1].1, faces[i + 2].1],
                    });
                }
            }
            i = j;
        }
        boundary.sort_unstable_by_key(|f| (f.tet, f.nodes));
        Ok(FaceTopology {
            boundary,
            neighbours,
        })
    }

    /// The boundary (surface) triangles, outward oriented.
    pub fn boundary_faces(&self) -> Result<Vec<BoundaryFace>> {
        Ok(self.face_topology()?.boundary)
    }

    /// Tets that share a face and also the node opposite it are the same tet twice.
    fn check_no_duplicates(&self, sharing: &[([usize; 3], usize, usize)]) -> Result<()> {
        for (k, &(_, first, first_local)) in sharing.iter().enumerate() {
            for &(_, tet, local) in &sharing[k + 1..] {
                let a = self.tets()[first].corners()[FACES[first_local].1];
                let b = self.tets()[tet].corners()[FACES[local].1];
                if a == b {
                    let mut nodes = self.tets()[tet].corners();
                    nodes.sort_unstable();
                    return Err(Error::DuplicateTet {
                        first: first.min(tet),
                        tet: first.max(tet),
                        nodes,
                    });
                }
            }
        }
        Ok(())
    }

    /// Two tets sharing a face must have their opposite nodes on opposite sides of it.
    ///
    /// Both tets are positively oriented, so the face's outward normal of one must be the
    /// inward normal of the other: the signed distances of the two opposite nodes from the
    /// face plane have opposite signs. Equal signs mean the tets overlap (a fold).
    fn check_opposite_sides(
        &self,
        (face, first, first_local): ([usize; 3], usize, usize),
        (_, tet, local): ([usize; 3], usize, usize),
    ) -> Result<()> {
        let p = face.map(|n| self.nodes()[n]);
        let normal = (p[1] - p[0]).cross(&(p[2] - p[0]));
        let side = |t: usize, l: usize| {
            normal.dot(&(self.nodes()[self.tets()[t].corners()[FACES[l].1]] - p[0]))
        };
        if side(first, first_local) * side(tet, local) > 0.0 {
            return Err(Error::InvertedTet {
                tet: first.max(tet),
                neighbour: first.min(tet),
                face,
            });
        }
        Ok(())
    }

    fn outward_face(&self, tet: usize, local: usize) -> BoundaryFace {
        let (face, opposite) = FACES[local];
        let corners = self.tets()[tet].corners();
        let mut nodes = face.map(|i| corners[i]);
        let p = nodes.map(|n| self.nodes()[n]);
        let inside = self.nodes()[corners[opposite]];
        if (p[1] - p[0]).cross(&(p[2] - p[0])).dot(&(inside - p[0])) > 0.0 {
            nodes.swap(1, 2);
        }
        BoundaryFace { tet, nodes }
    }
}
