//! Tetrahedral meshes: validated storage, generators, topology and node/face selection.

pub mod bodies;
pub mod cell;
mod generate;
pub mod geometry;
pub mod io;
mod jacobian_sign;
mod select;
mod topology;

pub use bodies::{Bodies, Placement};
pub use cell::{CellType, NodeList, Tet4, Tet10};
pub use generate::{BoxSplit, box_node_index};
pub use topology::{BoundaryFace, FaceTopology};

use nalgebra::Vector3;

use crate::base::error::{Error, Result};
use crate::mesh::geometry::{shape_quality, signed_volume};

/// Tets whose [`shape_quality`] 6√2·|V|/l_max³ falls below this are rejected as degenerate.
///
/// A regular tet has quality 1. A tet at 1e-10 is flat to about ten significant digits of its
/// longest edge; its stiffness would be dominated by round-off, so it is an input error rather
/// than a poor element.
pub const DEGENERATE_QUALITY: f64 = 1e-10;

/// A mesh of tetrahedra: node positions and, per tet, its node indices — four corners for the
/// default linear cell [`Tet4`], plus edge nodes for higher-order cell types (see [`cell`]).
///
/// Invariants, established by [`TetMesh::new`] (and [`TetMesh::from_cells`] for any cell type):
/// at least one tet; every coordinate finite; every index in range; no tet repeats a node; no tet
/// degenerate (see [`DEGENERATE_QUALITY`]); every tet positively oriented,
/// det[x₁−x₀ x₂−x₀ x₃−x₀] > 0 on its corners.
#[derive(Debug, Clone)]
pub struct TetMesh<C: CellType = Tet4> {
    nodes: Vec<Vector3<f64>>,
    tets: Vec<C::Nodes>,
    reoriented: usize,
}

/// Two meshes are equal when their nodes and (stored, positively oriented) tets are; how the
/// tets were oriented on input does not matter.
impl<C: CellType> PartialEq for TetMesh<C> {
    fn eq(&self, other: &Self) -> bool {
        self.nodes == other.nodes && self.tets == other.tets
    }
}

impl TetMesh {
    /// Validates nodes and linear tets (four corner nodes each) and builds the mesh.
    ///
    /// A negatively oriented tet is reoriented by swapping its second and third nodes
    /// (`[a, b, c, d]` → `[a, c, b, d]`), so that every stored tet has positive volume; the
    /// element set is unchanged. Errors name the first offending tet or node.
    pub fn new(nodes: Vec<Vector3<f64>>, tets: Vec<[usize; 4]>) -> Result<Self> {
        Self::from_cells(nodes, tets)
    }

    /// Rest positions of tet `t`'s four nodes; [`Error::UnknownTet`] if `t >= tet_count()`.
    pub fn tet_positions(&self, t: usize) -> Result<[Vector3<f64>; 4]> {
        self.check_tet("TetMesh::tet_positions", t)?;
        Ok(self.positions_of(t))
    }

    /// Rest positions of tet `t`, for loops over `0..tet_count()` (panics on a bad index).
    #[inline(always)]
    pub(crate) fn positions_of(&self, t: usize) -> [Vector3<f64>; 4] {
        // A plain loop, not `array::map`: its generic helpers are not always inlined into a
        // force pass, where the calls for four corners cost as much as a tet's arithmetic.
        let nodes = &self.tets[t];
        let mut out = [Vector3::zeros(); 4];
        for (out, &n) in out.iter_mut().zip(nodes) {
            *out = self.nodes[n];
        }
        out
    }

    /// The same mesh with new node positions (e.g. a perturbed or deformed copy),
    /// validated again.
    pub fn with_nodes(&self, nodes: Vec<Vector3<f64>>) -> Result<Self> {
        if nodes.len() != self.nodes.len() {
            return Err(Error::invalid_parameter(
                "nodes.len()",
                nodes.len(),
                format!("must equal the mesh's node count {}", self.nodes.len()),
            ));
        }
        TetMesh::new(nodes, self.tets.clone())
    }
}

impl<C: CellType> TetMesh<C> {
    /// Validates nodes and cells of type `C` and builds the mesh; the checks of
    /// [`TetMesh::new`], with the corners' orientation fixed by [`CellType::swap_corners_1_2`].
    pub fn from_cells(nodes: Vec<Vector3<f64>>, mut tets: Vec<C::Nodes>) -> Result<Self> {
        // Fewer than 4 nodes with a tet means that tet repeats a node or names one out of
        // range: the checks below name it (a reader that drops unused nodes turns a single tet
        // with a repeated node into 3 nodes, which "empty mesh" would misreport).
        if tets.is_empty() {
            return Err(Error::EmptyMesh {
                nodes: nodes.len(),
                tets: tets.len(),
            });
        }
        for (node, p) in nodes.iter().enumerate() {
            for axis in 0..3 {
                if !p[axis].is_finite() {
                    return Err(Error::NonFiniteCoordinate {
                        node,
                        axis,
                        value: p[axis],
                    });
                }
            }
        }
        let mut reoriented = 0;
        for (tet, t) in tets.iter_mut().enumerate() {
            let all = t.as_ref();
            for (k, &node) in all.iter().enumerate() {
                if node >= nodes.len() {
                    return Err(Error::NodeIndexOutOfRange {
                        tet,
                        node,
                        node_count: nodes.len(),
                    });
                }
                if all[..k].contains(&node) {
                    return Err(Error::RepeatedNode {
                        tet,
                        node,
                        nodes: all.to_vec(),
                    });
                }
            }
            let x = t.corners().map(|n| nodes[n]);
            let quality = shape_quality(&x);
            if quality.is_nan() || quality < DEGENERATE_QUALITY {
                return Err(Error::DegenerateTet {
                    tet,
                    nodes: t.corners(),
                    quality,
                    threshold: DEGENERATE_QUALITY,
                });
            }
            C::check_cell(tet, t, &nodes)?;
            if signed_volume(&x) < 0.0 {
                C::swap_corners_1_2(t);
                reoriented += 1;
            }
        }
        Ok(TetMesh {
            nodes,
            tets,
            reoriented,
        })
    }

    /// Node positions.
    pub fn nodes(&self) -> &[Vector3<f64>] {
        &self.nodes
    }

    /// Tets as node-index arrays (corners first), each positively oriented.
    pub fn tets(&self) -> &[C::Nodes] {
        &self.tets
    }

    /// Number of nodes.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Number of tets.
    pub fn tet_count(&self) -> usize {
        self.tets.len()
    }

    /// Number of degrees of freedom, 3 per node; DOF `3·node + axis`.
    pub fn dof_count(&self) -> usize {
        3 * self.nodes.len()
    }

    /// Total rest volume Σ Vₑ (of the straight-sided tets spanned by the corners).
    pub fn volume(&self) -> f64 {
        (0..self.tets.len())
            .map(|t| signed_volume(&self.corner_positions_of(t)))
            .sum()
    }

    /// Rest positions of tet `t`'s four corners, for loops over `0..tet_count()` (panics on a
    /// bad index).
    #[inline]
    pub(crate) fn corner_positions_of(&self, t: usize) -> [Vector3<f64>; 4] {
        self.tets[t].corners().map(|n| self.nodes[n])
    }

    /// Nodes that no tet uses, ascending (they carry no stiffness and no mass).
    pub fn unused_nodes(&self) -> Vec<usize> {
        let mut used = vec![false; self.nodes.len()];
        for tet in &self.tets {
            for &n in tet.as_ref() {
                used[n] = true;
            }
        }
        (0..used.len()).filter(|&n| !used[n]).collect()
    }

    /// Number of tets that [`TetMesh::new`] found negatively oriented and reoriented.
    pub fn reoriented_count(&self) -> usize {
        self.reoriented
    }

    /// [`Error::UnknownTet`] unless `t` is a tet of this mesh.
    pub(crate) fn check_tet(&self, context: &'static str, t: usize) -> Result<()> {
        if t < self.tets.len() {
            Ok(())
        } else {
            Err(Error::UnknownTet {
                context,
                tet: t,
                tet_count: self.tets.len(),
            })
        }
    }

    /// Axis-aligned bounding box (min corner, max corner).
    pub fn bounding_box(&self) -> (Vector3<f64>, Vector3<f64>) {
        let mut lo = self.nodes[0];
        let mut hi = self.nodes[0];
        for p in &self.nodes {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        (lo, hi)
    }
}
