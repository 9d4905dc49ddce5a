//! The cell type of a mesh: how many nodes a tet carries and how they are laid out.
//!
//! Every cell is a straight-sided tetrahedron: its first four nodes are the corners (ordered so
//! that det[x₁−x₀ x₂−x₀ x₃−x₀] > 0), which carry the geometry, the quality checks and the face
//! topology. Higher-order cells add nodes after the corners (the 10-node tet one per edge). The
//! mesh knows only this layout; what an element computes on it (shape functions, stiffness, mass,
//! consistent loads) is [`crate::fe::element::ElementType`], one layer up.

use std::fmt::Debug;

use nalgebra::Vector3;

use crate::base::error::{Error, Result};

/// The node indices of one cell, `[usize; N]`: the four corners first, then any higher-order
/// nodes. Implemented for node arrays of every length ≥ 4.
pub trait NodeList:
    Copy + Debug + PartialEq + Eq + Send + Sync + AsRef<[usize]> + AsMut<[usize]> + 'static
{
    /// The four corner nodes.
    fn corners(&self) -> [usize; 4];

    /// The cell of these node indices, if there are as many as the cell has (`None` otherwise).
    fn from_slice(nodes: &[usize]) -> Option<Self>;
}

impl<const N: usize> NodeList for [usize; N] {
    #[inline]
    fn corners(&self) -> [usize; 4] {
        const { assert!(N >= 4, "a tet cell has at least its four corners") };
        [self[0], self[1], self[2], self[3]]
    }

    fn from_slice(nodes: &[usize]) -> Option<Self> {
        nodes.try_into().ok()
    }
}

/// A tetrahedral cell type: the node layout of one cell (see the [module](self) docs).
///
/// A new element type implements this (its topology) and
/// [`ElementType`](crate::fe::element::ElementType) (its mechanics) in its own file; meshes,
/// assembly, constraints, loads and outputs are generic over it.
pub trait CellType: Copy + Debug + Default + PartialEq + Send + Sync + 'static {
    /// Node indices of one cell, `[usize; NODES]`.
    type Nodes: NodeList;
    /// Nodes per cell (4 for the linear tet, 10 for the quadratic one).
    const NODES: usize;
    /// Short name, as scenes and summaries write it (`"tet4"`, `"tet10"`).
    const NAME: &'static str;
    /// VTK cell type of the `.vtu` outputs (10 = `VTK_TETRA`, 24 = `VTK_QUADRATIC_TETRA`).
    const VTK_CELL_TYPE: u8;

    /// The cell's node carried by the edge between local corners `a` and `b` (`a ≠ b`, both
    /// < 4), or `None` for a cell with no edge nodes.
    fn edge_node(nodes: &Self::Nodes, a: usize, b: usize) -> Option<usize>;

    /// Reverses the orientation of a cell by swapping its corners 1 and 2 (and whatever
    /// higher-order nodes move with them), leaving the same cell.
    fn swap_corners_1_2(nodes: &mut Self::Nodes);

    /// Checks what [`TetMesh::from_cells`](super::TetMesh::from_cells) cannot know about the
    /// higher-order nodes of cell `tet` (e.g. that edge nodes sit where the element assumes);
    /// the corners are checked already. `nodes` are the mesh's node positions.
    fn check_cell(_tet: usize, _cell: &Self::Nodes, _nodes: &[Vector3<f64>]) -> Result<()> {
        Ok(())
    }
}

/// The linear 4-node tet: nodes = corners.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Tet4;

impl CellType for Tet4 {
    type Nodes = [usize; 4];
    const NODES: usize = 4;
    const NAME: &'static str = "tet4";
    const VTK_CELL_TYPE: u8 = 10;

    fn edge_node(_nodes: &[usize; 4], _a: usize, _b: usize) -> Option<usize> {
        None
    }

    fn swap_corners_1_2(nodes: &mut [usize; 4]) {
        nodes.swap(1, 2);
    }
}

/// The quadratic 10-node tet: corners 0–3, then the nodes of the edges in [`EDGES`] order
/// (VTK's `VTK_QUADRATIC_TETRA`), straight-sided. Its mechanics (shape functions, mass, loads)
/// are the element's ([`crate::fe::element::Tet10`] docs, `src/fe/element/tet10.rs`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Tet10;

/// The corners (i, j) of edge node 4 + k.
pub const EDGES: [(usize, usize); 6] = [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)];

/// Relative distance of an edge node from its edge's midpoint above which a mesh is rejected:
/// the element assumes straight edges, and a node this far off is a curved (isoparametric)
/// element it would silently get wrong. The bound is round-off of a midpoint, with room.
pub const MIDPOINT_TOLERANCE: f64 = 1e-9;

impl CellType for Tet10 {
    type Nodes = [usize; 10];
    const NODES: usize = 10;
    const NAME: &'static str = "tet10";
    const VTK_CELL_TYPE: u8 = 24;

    fn edge_node(nodes: &[usize; 10], a: usize, b: usize) -> Option<usize> {
        let key = (a.min(b), a.max(b));
        EDGES.iter().position(|&e| e == key).map(|k| nodes[4 + k])
    }

    /// Corners 1 ↔ 2 carry edges (0,1) ↔ (0,2) and (1,3) ↔ (2,3) with them; (1,2) stays.
    fn swap_corners_1_2(nodes: &mut [usize; 10]) {
        nodes.swap(1, 2);
        nodes.swap(4, 6);
        nodes.swap(8, 9);
    }

    fn check_cell(tet: usize, cell: &[usize; 10], nodes: &[Vector3<f64>]) -> Result<()> {
        for (k, &(i, j)) in EDGES.iter().enumerate() {
            let (a, b, m) = (nodes[cell[i]], nodes[cell[j]], nodes[cell[4 + k]]);
            let offset = (m - (a + b) * 0.5).norm() / (b - a).norm();
            // A NaN offset (coincident corners are rejected before, so only overflow) fails too.
            if offset.is_nan() || offset > MIDPOINT_TOLERANCE {
                return Err(Error::invalid_parameter(
                    format!("tet {tet}: edge node {} (local {})", cell[4 + k], 4 + k),
                    format!(
                        "{offset:e} edge lengths from the midpoint of nodes {} and {}",
                        cell[i], cell[j]
                    ),
                    format!("at most {MIDPOINT_TOLERANCE:e}: the 10-node tet is straight-sided"),
                ));
            }
        }
        Ok(())
    }
}
