//! Selecting nodes and boundary faces by geometric predicates.

use nalgebra::Vector3;

use super::{BoundaryFace, CellType, TetMesh};
use crate::base::error::{Error, Result};

/// [`Error::InvalidParameter`] unless `tolerance` (a selection distance, length units) is
/// finite and ≥ 0: a negative or NaN one silently selects nothing and an infinite one
/// everything.
fn check_tolerance(tolerance: f64) -> Result<()> {
    if tolerance.is_finite() && tolerance >= 0.0 {
        Ok(())
    } else {
        Err(Error::invalid_parameter(
            "selection tolerance",
            tolerance,
            "must be finite and >= 0 (a distance)",
        ))
    }
}

fn check_axis(axis: usize) -> Result<()> {
    if axis > 2 {
        return Err(Error::invalid_parameter(
            "axis",
            axis,
            "must be 0 (x), 1 (y) or 2 (z)",
        ));
    }
    Ok(())
}

impl<C: CellType> TetMesh<C> {
    /// Indices of the nodes whose position satisfies `predicate`, ascending.
    pub fn nodes_where(&self, predicate: impl Fn(&Vector3<f64>) -> bool) -> Vec<usize> {
        (0..self.node_count())
            .filter(|&n| predicate(&self.nodes()[n]))
            .collect()
    }

    /// Nodes with |x\[axis\] − value| ≤ tolerance (axis 0 = x, 1 = y, 2 = z).
    ///
    /// An `axis` above 2, a negative or NaN `tolerance` select nothing, an infinite one every
    /// node; [`try_nodes_on_plane`](Self::try_nodes_on_plane) makes those errors.
    pub fn nodes_on_plane(&self, axis: usize, value: f64, tolerance: f64) -> Vec<usize> {
        if axis > 2 {
            return Vec::new();
        }
        self.nodes_where(|p| (p[axis] - value).abs() <= tolerance)
    }

    /// [`nodes_on_plane`](Self::nodes_on_plane), with an [`Error::InvalidParameter`] for an
    /// axis above 2, a non-finite `value`, or a `tolerance` that is not finite and ≥ 0.
    pub fn try_nodes_on_plane(
        &self,
        axis: usize,
        value: f64,
        tolerance: f64,
    ) -> Result<Vec<usize>> {
        check_plane(axis, value, tolerance)?;
        Ok(self.nodes_on_plane(axis, value, tolerance))
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
    ///
    /// As [`nodes_on_plane`](Self::nodes_on_plane), bad arguments select nothing (or, for an
    /// infinite tolerance, everything); [`try_faces_on_plane`](Self::try_faces_on_plane) makes
    /// them errors.
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

    /// [`faces_on_plane`](Self::faces_on_plane), with an [`Error::InvalidParameter`] for an
    /// axis above 2, a non-finite `value`, or a `tolerance` that is not finite and ≥ 0.
    pub fn try_faces_on_plane(
        &self,
        boundary: &[BoundaryFace],
        axis: usize,
        value: f64,
        tolerance: f64,
    ) -> Result<Vec<BoundaryFace>> {
        check_plane(axis, value, tolerance)?;
        Ok(self.faces_on_plane(boundary, axis, value, tolerance))
    }
}

fn check_plane(axis: usize, value: f64, tolerance: f64) -> Result<()> {
    check_axis(axis)?;
    if !value.is_finite() {
        return Err(Error::invalid_parameter(
            "plane position",
            value,
            "must be finite",
        ));
    }
    check_tolerance(tolerance)
}
