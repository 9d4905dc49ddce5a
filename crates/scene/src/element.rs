//! What the scene runners need of an element type beyond the library's seam: how a box mesh
//! becomes a mesh of it, and its explicit critical-step bound. Implemented for the 4-node tet
//! (order 1) and the 10-node tet (order 2).

use tetfem::analysis::dynamics::{
    ElementStepBound, element_step_bound_of, element_step_bound_of_type,
};
use tetfem::base::error::Result;
use tetfem::fe::element::{ElementType, Tet10};
use tetfem::fe::materials::TetMaterials;
use tetfem::mesh::{Tet4, TetMesh};

/// An element type a scene can run on (see the [module](self) docs); pointwise evaluation
/// (`PointwiseElement`) for the self-estimated error and the rotation check of every run.
pub trait SceneElement:
    ElementType + tetfem::post::estimate::PointwiseElement + tetfem::model::ModelElement
{
    /// The scene's `mesh.order` for this element (1 or 2).
    const ORDER: usize;

    /// The mesh of this element on the tets of a linear (box) mesh: the mesh itself for the
    /// 4-node tet, with a node added at each edge's midpoint for the 10-node tet.
    fn from_linear(linear: TetMesh) -> Result<TetMesh<Self>>;

    /// The element bound on the explicit critical step (see
    /// [`ElementStepBound`]).
    fn step_bound(mesh: &TetMesh<Self>, materials: &impl TetMaterials) -> Result<ElementStepBound>;
}

impl SceneElement for Tet4 {
    const ORDER: usize = 1;

    fn from_linear(linear: TetMesh) -> Result<TetMesh> {
        Ok(linear)
    }

    /// The linear tet's own bound, as before the seam (the same bits).
    fn step_bound(mesh: &TetMesh, materials: &impl TetMaterials) -> Result<ElementStepBound> {
        element_step_bound_of(mesh, materials)
    }
}

impl SceneElement for Tet10 {
    const ORDER: usize = 2;

    fn from_linear(linear: TetMesh) -> Result<TetMesh<Tet10>> {
        TetMesh::<Tet10>::from_linear(&linear)
    }

    fn step_bound(
        mesh: &TetMesh<Tet10>,
        materials: &impl TetMaterials,
    ) -> Result<ElementStepBound> {
        element_step_bound_of_type(mesh, materials)
    }
}
