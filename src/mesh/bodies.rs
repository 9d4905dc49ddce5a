//! Several bodies in one mesh (issue 36, item 1): each body's mesh placed by a rigid motion and
//! numbered after the bodies before it, so that the bodies share one DOF space — one assembly,
//! one time step, one Newton solve — and, sharing no node, touch one another only through
//! contact. Which body each node and tet belongs to is kept, for per-body outputs, initial
//! velocities and, for contact, the exclusion of pairs by topology (bodies share no vertex).

use std::ops::Range;

use nalgebra::{Rotation3, Unit, Vector3};

use crate::base::error::{Error, Result};
use crate::mesh::{CellType, Tet4, TetMesh};

/// A rigid placement of a body, x ↦ R·x + t: its rest positions (m, in the body's own
/// coordinates) turned by the rotation R about the origin, then moved by the translation t (m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// t (m).
    pub translation: Vector3<f64>,
    /// R.
    pub rotation: Rotation3<f64>,
}

impl Default for Placement {
    fn default() -> Self {
        Self::identity()
    }
}

impl Placement {
    /// x ↦ x: the body where its mesh puts it.
    pub fn identity() -> Self {
        Placement {
            translation: Vector3::zeros(),
            rotation: Rotation3::identity(),
        }
    }

    /// x ↦ x + t, t in m; [`Error::InvalidParameter`] naming `translation` if not finite.
    pub fn translated(translation: Vector3<f64>) -> Result<Self> {
        if !translation.iter().all(|v| v.is_finite()) {
            return Err(Error::invalid_parameter(
                "placement translation",
                format!("{translation:?}"),
                "must be finite (m)",
            ));
        }
        Ok(Placement {
            translation,
            ..Self::identity()
        })
    }

    /// This placement after a turn by `angle` (rad, right-handed) about `axis` through the
    /// body's origin: x ↦ R·x + t becomes x ↦ R(axis, angle)·R·x + t. An axis of zero length or
    /// a non-finite axis or angle is [`Error::InvalidParameter`] naming it.
    pub fn rotated(self, axis: Vector3<f64>, angle: f64) -> Result<Self> {
        let length = axis.norm();
        if !(length.is_finite() && length > 0.0) {
            return Err(Error::invalid_parameter(
                "placement rotation axis",
                format!("{axis:?}"),
                "must be finite and non-zero",
            ));
        }
        if !angle.is_finite() {
            return Err(Error::invalid_parameter(
                "placement rotation angle",
                angle,
                "must be finite (rad)",
            ));
        }
        let turn = Rotation3::from_axis_angle(&Unit::new_normalize(axis), angle);
        Ok(Placement {
            rotation: turn * self.rotation,
            ..self
        })
    }

    /// R·x + t (m).
    pub fn apply(&self, x: &Vector3<f64>) -> Vector3<f64> {
        self.rotation * x + self.translation
    }
}

/// Several bodies as one mesh: body b's nodes are [`node_range`](Self::node_range)(b) and its
/// tets [`tet_range`](Self::tet_range)(b), in the order the bodies were given; within a body,
/// nodes and tets keep its own mesh's order. A rotation preserves every tet's orientation, so
/// each body's tets stay as its mesh validated them.
#[derive(Debug, Clone)]
pub struct Bodies<C: CellType = Tet4> {
    mesh: TetMesh<C>,
    nodes: Vec<Range<usize>>,
    tets: Vec<Range<usize>>,
}

impl<C: CellType> Bodies<C> {
    /// The bodies `parts` (each a mesh and its placement) in one mesh. No body is
    /// [`Error::InvalidParameter`] naming `bodies`; a body's placed nodes are validated as any
    /// mesh's (a non-finite position names the node of the merged mesh).
    pub fn new(parts: Vec<(TetMesh<C>, Placement)>) -> Result<Self> {
        if parts.is_empty() {
            return Err(Error::invalid_parameter(
                "bodies",
                "none",
                "at least one body (a mesh and its placement)",
            ));
        }
        let mut nodes = Vec::new();
        let mut tets = Vec::new();
        let (mut node_ranges, mut tet_ranges) = (Vec::new(), Vec::new());
        for (mesh, placement) in &parts {
            let offset = nodes.len();
            nodes.extend(mesh.nodes().iter().map(|x| placement.apply(x)));
            node_ranges.push(offset..nodes.len());
            let first = tets.len();
            tets.extend(mesh.tets().iter().map(|cell| {
                let mut moved = *cell;
                moved.as_mut().iter_mut().for_each(|n| *n += offset);
                moved
            }));
            tet_ranges.push(first..tets.len());
        }
        Ok(Bodies {
            mesh: TetMesh::from_cells(nodes, tets)?,
            nodes: node_ranges,
            tets: tet_ranges,
        })
    }

    /// The bodies' mesh (rest positions placed), one DOF space.
    pub fn mesh(&self) -> &TetMesh<C> {
        &self.mesh
    }

    /// The number of bodies.
    pub fn count(&self) -> usize {
        self.nodes.len()
    }

    /// The mesh nodes of body `body`; [`Error::InvalidParameter`] naming it if there is no such
    /// body.
    pub fn node_range(&self, body: usize) -> Result<Range<usize>> {
        self.check_body(body)?;
        Ok(self.nodes[body].clone())
    }

    /// The mesh tets of body `body`; [`Error::InvalidParameter`] naming it if there is no such
    /// body.
    pub fn tet_range(&self, body: usize) -> Result<Range<usize>> {
        self.check_body(body)?;
        Ok(self.tets[body].clone())
    }

    /// The body of each tet of the mesh (the `.vtu` cell field of a per-body output).
    pub fn tet_bodies(&self) -> Vec<usize> {
        let mut of = vec![0; self.mesh.tet_count()];
        for (b, range) in self.tets.iter().enumerate() {
            of[range.clone()].fill(b);
        }
        of
    }

    /// The body of each node of the mesh.
    pub fn node_bodies(&self) -> Vec<usize> {
        let mut of = vec![0; self.mesh.node_count()];
        for (b, range) in self.nodes.iter().enumerate() {
            of[range.clone()].fill(b);
        }
        of
    }

    /// The full velocity field (m/s, 3 per mesh node) of every body moving rigidly at
    /// `velocities[b]` — the initial velocity of a scene of several bodies.
    /// [`Error::InvalidParameter`] if there is not one per body or one is not finite.
    pub fn velocity(&self, velocities: &[Vector3<f64>]) -> Result<Vec<f64>> {
        if velocities.len() != self.count() {
            return Err(Error::invalid_parameter(
                "body velocities",
                format!("{} given", velocities.len()),
                format!("one per body ({})", self.count()),
            ));
        }
        let mut v = vec![0.0; 3 * self.mesh.node_count()];
        for (b, (range, velocity)) in self.nodes.iter().zip(velocities).enumerate() {
            if !velocity.iter().all(|c| c.is_finite()) {
                return Err(Error::invalid_parameter(
                    format!("body {b} velocity"),
                    format!("{velocity:?}"),
                    "must be finite (m/s)",
                ));
            }
            for n in range.clone() {
                v[3 * n..3 * n + 3].copy_from_slice(velocity.as_slice());
            }
        }
        Ok(v)
    }

    fn check_body(&self, body: usize) -> Result<()> {
        match body < self.count() {
            true => Ok(()),
            false => Err(Error::invalid_parameter(
                "body",
                body,
                format!("must be below the number of bodies {}", self.count()),
            )),
        }
    }
}
