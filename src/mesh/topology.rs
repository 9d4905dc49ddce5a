//! Face topology: which triangles are on the boundary and which tets share a face.

use nalgebra::Vector3;

use super::TetMesh;
use crate::element::FACES;
use crate::error::{Error, Result};

/// A boundary triangle: a tet face that no other tet shares.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BoundaryFace {
    /// The tet it belongs to.
    pub tet: usize,
    /// Its three nodes, ordered so that (n₁−n₀)×(n₂−n₀) points out of the body.
    pub nodes: [usize; 3],
}

impl BoundaryFace {
    /// Area vector ½(n₁−n₀)×(n₂−n₀): outward normal times area (length² units).
    pub fn area_vector(&self, mesh: &TetMesh) -> Vector3<f64> {
        let p = self.nodes.map(|n| mesh.nodes()[n]);
        (p[1] - p[0]).cross(&(p[2] - p[0])) * 0.5
    }

    /// Centroid of the triangle.
    pub fn centroid(&self, mesh: &TetMesh) -> Vector3<f64> {
        let p = self.nodes.map(|n| mesh.nodes()[n]);
        (p[0] + p[1] + p[2]) / 3.0
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

impl TetMesh {
    /// Classifies every tet face as boundary (one tet) or interior (two tets).
    ///
    /// A face shared by three or more tets is an error ([`Error::NonManifoldFace`]): the mesh
    /// overlaps itself or repeats a tet there.
    pub fn face_topology(&self) -> Result<FaceTopology> {
        // Sort all 4·n faces by their sorted node triple; equal neighbours share a face.
        let mut faces: Vec<([usize; 3], usize, usize)> = Vec::with_capacity(4 * self.tet_count());
        for (t, tet) in self.tets().iter().enumerate() {
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
            match j - i {
                1 => {
                    let (_, tet, local) = faces[i];
                    boundary.push(self.outward_face(tet, local));
                }
                2 => neighbours.push((faces[i].1, faces[i + 1].1)),
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

    fn outward_face(&self, tet: usize, local: usize) -> BoundaryFace {
        let (face, opposite) = FACES[local];
        let mut nodes = face.map(|i| self.tets()[tet][i]);
        let p = nodes.map(|n| self.nodes()[n]);
        let inside = self.nodes()[self.tets()[tet][opposite]];
        if (p[1] - p[0]).cross(&(p[2] - p[0])).dot(&(inside - p[0])) > 0.0 {
            nodes.swap(1, 2);
        }
        BoundaryFace { tet, nodes }
    }
}
