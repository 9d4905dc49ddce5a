//! The two cell types every binding works on: a value of the 4-node tet's or of the 10-node
//! tet's ([`Cells`]), meshes of either ([`AnyMesh`]) and the one dispatch between them
//! ([`on_cells!`]).

use nalgebra::Vector3;
use tetfem::fe::element::Tet10;
use tetfem::mesh::io::ImportedMesh;
use tetfem::mesh::{NodeList, TetMesh};

/// A value of each cell type: of the 4-node tet (`P1`, order 1) or of the 10-node tet (`P2`,
/// order 2). [`on_cells!`] runs one generic expression on either.
#[derive(Debug)]
pub enum Cells<A, B> {
    /// Of the 4-node tet.
    P1(A),
    /// Of the 10-node tet.
    P2(B),
}

/// A validated mesh of either cell type.
pub type AnyMesh = Cells<TetMesh, TetMesh<Tet10>>;

/// A mesh read from a file, of either cell type.
pub type AnyImported = Cells<ImportedMesh, ImportedMesh<Tet10>>;

/// `on_cells!(value, m => body)`: `body` with `m` bound to the contents of a [`Cells`] value,
/// compiled once per cell type (the one dispatch of every call on a mesh of either order).
macro_rules! on_cells {
    ($value:expr, $m:ident => $body:expr) => {
        match $value {
            $crate::cells::Cells::P1($m) => $body,
            $crate::cells::Cells::P2($m) => $body,
        }
    };
}
pub(crate) use on_cells;

impl AnyMesh {
    /// The element order: 1 (4-node tets) or 2 (10-node tets).
    pub fn order(&self) -> usize {
        match self {
            Cells::P1(_) => 1,
            Cells::P2(_) => 2,
        }
    }

    /// Number of nodes (corners and, of order 2, edge nodes).
    pub fn node_count(&self) -> usize {
        on_cells!(self, m => m.node_count())
    }

    /// Number of tets.
    pub fn tet_count(&self) -> usize {
        on_cells!(self, m => m.tet_count())
    }

    /// Degrees of freedom: 3 per node.
    pub fn dof_count(&self) -> usize {
        on_cells!(self, m => m.dof_count())
    }

    /// Node coordinates (length units).
    pub fn nodes(&self) -> &[Vector3<f64>] {
        on_cells!(self, m => m.nodes())
    }

    /// The four corner nodes of every tet.
    pub fn corners(&self) -> Vec<[usize; 4]> {
        on_cells!(self, m => m.tets().iter().map(NodeList::corners).collect())
    }

    /// (min, max) corners of the bounding box (length units).
    pub fn bounding_box(&self) -> (Vector3<f64>, Vector3<f64>) {
        on_cells!(self, m => m.bounding_box())
    }
}
