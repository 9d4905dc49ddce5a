//! The cell type of a mesh: how many nodes a tet carries and how they are laid out.
//!
//! Every cell is a tetrahedron whose first four nodes are the corners (ordered so that
//! det[x₁−x₀ x₂−x₀ x₃−x₀] > 0), which carry the quality checks and the face topology, and
//! the geometry of straight-sided cells (a 10-node cell with edge nodes off their midpoints is
//! curved: its geometry is the quadratic map of all ten nodes). Higher-order cells add nodes after the corners (the 10-node tet one per edge). The
//! mesh knows only this layout; what an element computes on it (shape functions, stiffness, mass,
//! consistent loads) is [`crate::fe::element::ElementType`], one layer up.

use std::fmt::Debug;

use nalgebra::Vector3;

use super::jacobian_sign::{JacobianSign, jacobian_at, jacobian_sign};
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
/// (VTK's `VTK_QUADRATIC_TETRA`); straight-sided when every edge node is at its edge's midpoint,
/// curved (isoparametric: the geometry mapped by the same quadratic shape functions) otherwise. Its mechanics (shape functions, mass, loads)
/// are the element's ([`crate::fe::element::Tet10`] docs, `src/fe/element/tet10.rs`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Tet10;

/// The corners (i, j) of edge node 4 + k.
pub const EDGES: [(usize, usize); 6] = [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)];

/// Relative distance of an edge node from its edge's midpoint (in edge lengths) up to which a
/// 10-node tet counts as straight-sided and takes the affine path (constant ∇Lᵢ, closed-form
/// mass and loads, bit for bit the straight element); farther, it is curved (isoparametric).
/// The bound is round-off of a midpoint, with room.
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

    /// A cell whose edge nodes all sit at their edges' midpoints (to [`MIDPOINT_TOLERANCE`]) is
    /// straight-sided and always valid (its corners were checked). Otherwise it is curved
    /// (isoparametric): the map x(ξ) = Σₐ Nₐ(ξ) xₐ must keep det(∂x/∂ξ) > 0 on the whole
    /// element, wherever a quadrature rule or a stress recovery may read it: checked at the ten
    /// nodes, then over the tet by the Bernstein certificate of Johnen, Remacle and Geuzaine
    /// (the crate's `mesh::jacobian_sign`: det ∂x/∂ξ is a cubic whose Bernstein coefficients
    /// bound it).
    /// An edge node moved so far that the element folds is an error naming the tet and the
    /// point (a node, or the barycentric coordinates of a point inside).
    fn check_cell(tet: usize, cell: &[usize; 10], nodes: &[Vector3<f64>]) -> Result<()> {
        let x: [Vector3<f64>; 10] = std::array::from_fn(|a| nodes[cell[a]]);
        for (k, &(i, j)) in EDGES.iter().enumerate() {
            let offset = (x[4 + k] - (x[i] + x[j]) * 0.5).norm() / (x[j] - x[i]).norm();
            // Only overflow makes a NaN here (coincident corners are rejected before).
            if !offset.is_finite() {
                return Err(Error::invalid_parameter(
                    format!("tet {tet}: edge node {} (local {})", cell[4 + k], 4 + k),
                    format!(
                        "{offset:e} edge lengths from the midpoint of nodes {} and {}",
                        cell[i], cell[j]
                    ),
                    "a finite position",
                ));
            }
        }
        if is_straight(&x) {
            return Ok(());
        }
        // The straight tet's det is 6V > 0: a relative 1e-12 of it is round-off, not a fold.
        let scale = (x[1] - x[0]).cross(&(x[2] - x[0])).dot(&(x[3] - x[0]));
        let floor = 1e-12 * scale;
        let fold = |at: String, det: f64, allowed: &str| {
            Error::invalid_parameter(
                format!("tet {tet}: curved 10-node tet (edge nodes off their midpoints) at {at}"),
                format!("Jacobian determinant {det:e} (straight tet's {scale:e})"),
                format!(
                    "{allowed}: an edge node is moved so far from its edge's midpoint that the \
                     isoparametric map folds (an inverted or too-curved element)"
                ),
            )
        };
        // G is affine in λ: its values at the corners give it everywhere (the nodes' too).
        let corners = std::array::from_fn(|m| {
            reference_jacobian(&x, &std::array::from_fn(|i| f64::from(i == m)))
        });
        for (name, l) in node_points() {
            let det = jacobian_at(&corners, &l).determinant();
            if det.is_nan() || det <= floor {
                return Err(fold(format!("{name} (barycentric {l:?})"), det, "> 0"));
            }
        }
        match jacobian_sign(&corners, floor) {
            JacobianSign::Positive => {}
            JacobianSign::NotPositive { at, det } => {
                return Err(fold(format!("barycentric {at:?}"), det, "> 0"));
            }
            JacobianSign::Undecided { bound, near } => {
                return Err(fold(
                    format!("barycentric {near:?}"),
                    bound,
                    "a lower bound > 0 (this is the bound of its Bernstein form near that \
                     point, which could not be shown positive)",
                ));
            }
        }
        Ok(())
    }
}

/// True when every edge node of the 10-node cell `x` (positions in local order) sits at its
/// edge's midpoint to [`MIDPOINT_TOLERANCE`] edge lengths: the straight-sided (affine) tet.
pub fn is_straight(x: &[Vector3<f64>; 10]) -> bool {
    EDGES.iter().enumerate().all(|(k, &(i, j))| {
        (x[4 + k] - (x[i] + x[j]) * 0.5).norm() <= MIDPOINT_TOLERANCE * (x[j] - x[i]).norm()
    })
}

/// The ten nodes' barycentric points, named as in an error.
fn node_points() -> impl Iterator<Item = (String, [f64; 4])> {
    let corners = (0..4).map(|c| {
        let l = std::array::from_fn(|i| if i == c { 1.0 } else { 0.0 });
        (format!("node {c}"), l)
    });
    let edges = EDGES.iter().enumerate().map(|(k, &(i, j))| {
        let l = std::array::from_fn(|m| if m == i || m == j { 0.5 } else { 0.0 });
        (format!("node {}", 4 + k), l)
    });
    corners.chain(edges)
}

/// ∂x/∂ξ of the quadratic map at barycentric `l`, ξ = (L₁, L₂, L₃) (so L₀ = 1 − ξ₁ − ξ₂ − ξ₃):
/// Σₐ xₐ ⊗ ∇_ξNₐ with ∇_ξNᵢ = (4Lᵢ − 1)∇_ξLᵢ and ∇_ξN₍ᵢⱼ₎ = 4(Lⱼ∇_ξLᵢ + Lᵢ∇_ξLⱼ).
fn reference_jacobian(x: &[Vector3<f64>; 10], l: &[f64; 4]) -> nalgebra::Matrix3<f64> {
    let dl = [
        Vector3::new(-1.0, -1.0, -1.0),
        Vector3::x(),
        Vector3::y(),
        Vector3::z(),
    ];
    let mut j = nalgebra::Matrix3::zeros();
    for i in 0..4 {
        j += x[i] * (dl[i] * (4.0 * l[i] - 1.0)).transpose();
    }
    for (k, &(a, b)) in EDGES.iter().enumerate() {
        j += x[4 + k] * ((dl[a] * l[b] + dl[b] * l[a]) * 4.0).transpose();
    }
    j
}
