//! Force models per region: one [`ForceModel`] per material of a
//! [`MaterialMap`](crate::fe::materials::MaterialMap), chosen per tet by its material index,
//! each material its own [`ModelKind`] (one kind for all: [`ModelMap::new`]; a kind per
//! material: [`ModelMap::with_kinds`], e.g. a linear body beside a Neo-Hookean one).

use super::{ForceModel, ModelKind};
use crate::base::error::{Error, Result};
use crate::fe::materials::{MaterialMap, TetMaterials};
use crate::mesh::{CellType, TetMesh};

/// The force model of each tet: one model for all (any [`ForceModel`], `dyn` included), or a
/// [`ModelMap`].
pub trait TetModels: Sync {
    /// The model of tet `tet` (which the caller checked is a tet of the mesh: see
    /// [`check_tet_count`](Self::check_tet_count)).
    fn model_of(&self, tet: usize) -> &dyn ForceModel;
    /// An error unless these models cover exactly `tets` tets (always `Ok` for one model).
    fn check_covers(&self, tets: usize) -> Result<()>;

    /// An error unless these models cover exactly the tets of `mesh`, of any element type
    /// (always `Ok` for one model).
    fn check_tet_count<C: CellType>(&self, mesh: &TetMesh<C>) -> Result<()>
    where
        Self: Sized,
    {
        self.check_covers(mesh.tet_count())
    }
}

impl<T: ForceModel> TetModels for T {
    #[inline(always)]
    fn model_of(&self, _tet: usize) -> &dyn ForceModel {
        self
    }

    fn check_covers(&self, _tets: usize) -> Result<()> {
        Ok(())
    }
}

impl TetModels for dyn ForceModel + '_ {
    #[inline(always)]
    fn model_of(&self, _tet: usize) -> &dyn ForceModel {
        self
    }

    fn check_covers(&self, _tets: usize) -> Result<()> {
        Ok(())
    }
}

/// A boxed model (what [`ModelKind::build`] returns) as one model for every tet, so that
/// `&Box<dyn ForceModel>` arguments keep working where `&dyn ForceModel` was taken before.
impl TetModels for Box<dyn ForceModel + '_> {
    #[inline(always)]
    fn model_of(&self, _tet: usize) -> &dyn ForceModel {
        self.as_ref()
    }

    fn check_covers(&self, _tets: usize) -> Result<()> {
        Ok(())
    }
}

/// One force model per material, and the materials' tet map.
pub struct ModelMap {
    /// The kind of each material's model.
    kinds: Vec<ModelKind>,
    models: Vec<Box<dyn ForceModel>>,
    materials: MaterialMap,
}

impl std::fmt::Debug for ModelMap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ModelMap")
            .field("kinds", &self.kinds)
            .field(
                "models",
                &self.models.iter().map(|m| m.name()).collect::<Vec<_>>(),
            )
            .field("materials", &self.materials)
            .finish()
    }
}

impl ModelMap {
    /// The model `kind` for each material of `materials`.
    pub fn new(kind: ModelKind, materials: &MaterialMap) -> Self {
        ModelMap {
            kinds: vec![kind; materials.materials().len()],
            models: materials
                .materials()
                .iter()
                .map(|m| kind.build(m))
                .collect(),
            materials: materials.clone(),
        }
    }

    /// The model `kinds[i]` for material `i` of `materials` (its tets take that model).
    ///
    /// Errors ([`Error::InvalidParameter`]): not one kind per material, naming both counts.
    pub fn with_kinds(kinds: Vec<ModelKind>, materials: &MaterialMap) -> Result<Self> {
        let count = materials.materials().len();
        if kinds.len() != count {
            return Err(Error::invalid_parameter(
                "model kinds",
                format!("{} kinds", kinds.len()),
                format!("must give one per material ({count} materials)"),
            ));
        }
        Ok(ModelMap {
            models: materials
                .materials()
                .iter()
                .zip(&kinds)
                .map(|(m, kind)| kind.build(m))
                .collect(),
            kinds,
            materials: materials.clone(),
        })
    }

    /// The kind of each material's model, in the materials' order.
    pub fn kinds(&self) -> &[ModelKind] {
        &self.kinds
    }

    /// Whether every material takes the linear model: what the linear fast paths (one
    /// factorization, the small-strain error estimate) need.
    pub fn is_linear(&self) -> bool {
        self.kinds.iter().all(|k| k.is_linear())
    }

    /// The kind every material shares, `None` for a map of several kinds.
    pub fn uniform_kind(&self) -> Option<ModelKind> {
        let first = *self.kinds.first()?;
        self.kinds.iter().all(|&k| k == first).then_some(first)
    }

    /// The name summaries use: the shared kind's ([`ModelKind::name`]), or `per-material` for
    /// a map of several kinds.
    pub fn name(&self) -> &'static str {
        self.uniform_kind().map_or(PER_MATERIAL, ModelKind::name)
    }

    /// The models, one per material of [`materials`](Self::materials).
    pub fn models(&self) -> &[Box<dyn ForceModel>] {
        &self.models
    }

    /// The material map the models follow.
    pub fn materials(&self) -> &MaterialMap {
        &self.materials
    }
}

/// The name of a [`ModelMap`] whose materials take different kinds.
const PER_MATERIAL: &str = "per-material";

impl TetModels for ModelMap {
    #[inline(always)]
    fn model_of(&self, tet: usize) -> &dyn ForceModel {
        self.models[self.materials.index_of(tet)].as_ref()
    }

    fn check_covers(&self, tets: usize) -> Result<()> {
        self.materials.check_covers(tets)
    }
}
