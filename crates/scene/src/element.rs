//! What the scene runners need of an element type beyond the library's seam: how a box mesh
//! becomes a mesh of it (its explicit critical-step bound is the library's
//! [`StepBoundElement`]). Implemented for the 4-node tet (order 1) and the 10-node tet (order 2).

use tetfem::analysis::dynamics::StepBoundElement;
use tetfem::base::error::Result;
use tetfem::fe::element::{ElementType, Tet10};
use tetfem::mesh::{Tet4, TetMesh};

/// An element type a scene can run on (4- or 10-node tet), with how a box mesh becomes a mesh of
/// it; pointwise evaluation
/// (`PointwiseElement`) for the self-estimated error and the rotation check of every run.
pub trait SceneElement:
    ElementType
    + tetfem::post::estimate::PointwiseElement
    + tetfem::model::ModelElement
    + StepBoundElement
{
    /// The scene's `mesh.order` for this element (1 or 2).
    const ORDER: usize;

    /// The mesh of this element on the tets of a linear (box) mesh: the mesh itself for the
    /// 4-node tet, with a node added at each edge's midpoint for the 10-node tet.
    fn from_linear(linear: TetMesh) -> Result<TetMesh<Self>>;
}

impl SceneElement for Tet4 {
    const ORDER: usize = 1;

    fn from_linear(linear: TetMesh) -> Result<TetMesh> {
        Ok(linear)
    }
}

impl SceneElement for Tet10 {
    const ORDER: usize = 2;

    fn from_linear(linear: TetMesh) -> Result<TetMesh<Tet10>> {
        TetMesh::<Tet10>::from_linear(&linear)
    }
}
