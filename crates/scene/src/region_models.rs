//! A force model per material region (`[[materials]] model`, default `analysis.model`): the
//! scene's part — reading the keys, the kind of each material of a built scene, the problem
//! definition with them. What may be combined with a mix of models is the library's rule
//! ([`tetfem::analysis::Combination`]'s `region_models`).

use tetfem::CellType;
use tetfem::analysis::Definition;
use tetfem::base::error::Result;
use tetfem::contact::Contact;
use tetfem::fe::materials::MaterialMap;
use tetfem::model::ModelKind;

use super::{BuiltScene, Scene};

impl Scene {
    /// Each `[[materials]]` entry's own model (`materials[i].model`), `None` where it takes
    /// `analysis.model`: an unknown name is an error at that key and line, listing the models.
    pub(crate) fn check_region_models(&self) -> Result<Vec<Option<ModelKind>>> {
        self.spec()
            .materials
            .iter()
            .enumerate()
            .map(|(i, entry)| {
                let Some(name) = &entry.get_ref().model else {
                    return Ok(None);
                };
                name.parse().map(Some).map_err(|_| {
                    self.error(
                        &format!("materials[{i}].model"),
                        &entry.span(),
                        format!(
                            "unknown model '{name}': use one of {}",
                            ModelKind::listed_names()
                        ),
                    )
                })
            })
            .collect()
    }

    /// The `[[materials]]` entries (by key, `materials[i]`) whose model differs from
    /// `analysis.model`, with theirs: what the combination rule names.
    pub(crate) fn differing_region_models(&self) -> Vec<(String, ModelKind)> {
        self.region_models
            .iter()
            .enumerate()
            .filter_map(|(i, kind)| kind.filter(|&k| k != self.model).map(|k| (i, k)))
            .map(|(i, kind)| (format!("materials[{i}]"), kind))
            .collect()
    }

    /// Whether every region of the scene takes the linear model (`analysis.model` and each
    /// `[[materials]]` entry's): the linear fast paths' question.
    pub fn is_linear(&self) -> bool {
        self.model.is_linear() && self.region_models.iter().flatten().all(|k| k.is_linear())
    }

    /// The model of each material of `materials`, a map this scene built (its `[[materials]]`
    /// entries in order, then `[material]` for the tets none claims): `None` when no entry
    /// names a model (every material takes `analysis.model`).
    pub fn model_kinds(&self, materials: &MaterialMap) -> Option<Vec<ModelKind>> {
        if self.region_models.iter().all(Option::is_none) {
            return None;
        }
        let count = materials.materials().len();
        Some(
            (0..count)
                .map(|i| self.region_models.get(i).copied().flatten())
                .map(|kind| kind.unwrap_or(self.model))
                .collect(),
        )
    }

    /// The problem definition a run of this scene solves: [`BuiltScene::definition`] with the
    /// scene's model, each region's own where `[[materials]]` names one, and `contact`.
    ///
    /// Errors: those of [`BuiltScene::definition`].
    pub fn definition_of<C: CellType>(
        &self,
        built: &BuiltScene<C>,
        contact: Option<Contact>,
    ) -> Result<Definition<C>> {
        let mut definition = built.definition(self.model, contact)?;
        // One kind per material of the built map, by construction.
        definition.region_models = self.model_kinds(&built.materials);
        Ok(definition)
    }
}
