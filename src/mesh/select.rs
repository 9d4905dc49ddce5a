//! Selecting nodes and boundary faces by geometric predicates.

use nalgebra::Vector3;

use super::{BoundaryFace, TetMesh};

impl TetMesh {
    /// Indices of the nodes whose position satisfies `predicate`, ascending.
    pub fn nodes_where(&self, predicate: impl Fn(&Vector3<f64>) -> bool) -> Vec<usize> {
        (0..self.node_count())
            .filter(|&n| predicate(&self.nodes()[n]))
            .collect()
    }

    /// Nodes with |x\[axis\] − value| ≤ tolerance (axis 0 = x, 1 = y, 2 = z).
    ///
    /// An `axis` above 2 selects nothing.
    pub fn nodes_on_plane(&self, axis: usize, value: f64, tolerance: f64) -> Vec<usize> {
        if axis > 2 {
            return Vec::new();
        }
        self.nodes_where(|p| (p[axis] - value).abs() <= tolerance)
    }

    /// Nodes inside the closed axis-aligned box [min, max].
    pub fn nodes_in_box(&self, min: Vector3<f64>, max: Vector3<f64>) -> Vec<usize> {
        self.nodes_where(|p| (0..3).all(|a| p[a] >= min[a] && p[a] <= max[a]))
    }

    /// Boundary faces all three of whose nodes satisfy `predicate`. A face naming a node this
    /// mesh does not have (a face of another mesh) never matches.
    pub fn faces_where(
        &self,
        boundary: &[BoundaryFace],
        predicate: impl Fn(&Vector3<f64>) -> bool,
    ) -> Vec<BoundaryFace> {
        boundary
            .iter()
            .filter(|f| {
                f.nodes
                    .iter()
                    .all(|&n| self.nodes().get(n).is_some_and(&predicate))
            })
            .copied()
            .collect()
    }

    /// Boundary faces lying in the plane x\[axis\] = value (all three nodes within `tolerance`).
    pub fn faces_on_plane(
        &self,
        boundary: &[BoundaryFace],
        axis: usize,
        value: f64,
        tolerance: f64,
    ) -> Vec<BoundaryFace> {
        if axis > 2 {
            return Vec::new();
        }
        self.faces_where(boundary, |p| (p[axis] - value).abs() <= tolerance)
    }
}
