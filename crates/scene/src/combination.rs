//! The scene's [`Combination`]: what it combines (model, order, analysis, amplitudes, moving
//! supports, obstacles, friction, regions), checked by the library's rule
//! ([`Combination::check`]) — the scene refuses nothing of its own; it only names the key and
//! line of the pair the library refuses.

use tetfem::analysis::{self, Combination};
use tetfem::base::error::{Error, Result};
use tetfem::base::warning::Warning;

use super::{Analysis, Scene};

impl Scene {
    /// What this scene combines.
    pub fn combination(&self) -> Combination {
        let spec = &self.spec;
        Combination {
            model: self.model,
            region_models: self.differing_region_models(),
            order: self.order,
            analysis: match &self.analysis {
                Analysis::Static => analysis::Analysis::Static,
                Analysis::Dynamic(d) => analysis::Analysis::Transient(d.method),
                Analysis::Modal(_) => analysis::Analysis::Modal,
            },
            time_varying_loads: spec.loads.iter().any(|l| l.get_ref().amplitude.is_some()),
            moving_supports: spec.constraints.iter().any(|c| {
                let c = c.get_ref();
                c.amplitude.is_some() || c.linear_field.is_some() || c.rigid_motion.is_some()
            }),
            obstacles: !spec.obstacles.is_empty(),
            friction: spec
                .obstacles
                .iter()
                .any(|o| o.get_ref().friction.is_some_and(|mu| mu > 0.0)),
            regions: !spec.materials.is_empty(),
            formulation: analysis::combination::Formulation::Displacement,
            surface_contact: self.has_surface_contact(),
            surface_friction: spec
                .self_contact
                .as_ref()
                .is_some_and(|s| s.get_ref().friction.is_some_and(|mu| mu > 0.0)),
        }
    }

    /// [`Combination::check`] of [`combination`](Self::combination): its warnings, or its
    /// error at the key and line of the pair it names (`analysis.model` for a model,
    /// `materials[i].model` for a region's,
    /// `obstacles[0].kind` for obstacles, `analysis` otherwise).
    pub(crate) fn check_combination(&self) -> Result<Vec<Warning>> {
        self.combination().check().map_err(|e| {
            let (name, message) = match &e {
                Error::InvalidParameter {
                    name,
                    value,
                    requirement,
                } => (name.clone(), format!("{value}: {requirement}")),
                other => (String::new(), other.to_string()),
            };
            let analysis = self.spec.analysis.as_ref().map(|a| a.span());
            let region = name
                .strip_prefix("model of materials[")
                .and_then(|rest| rest.split(']').next()?.parse::<usize>().ok())
                .and_then(|i| Some((i, self.spec.materials.get(i)?.span())));
            let region_key = region
                .as_ref()
                .map(|(i, _)| format!("materials[{i}].model"));
            let (key, span) = match (name.split(' ').next(), self.spec.obstacles.first()) {
                (Some("model"), _) if region.is_some() => (
                    region_key.as_deref().unwrap_or("materials"),
                    region.map(|(_, span)| span).unwrap_or_default(),
                ),
                (Some("model"), _) => ("analysis.model", analysis.unwrap_or_default()),
                (Some("obstacles"), Some(first)) => ("obstacles[0].kind", first.span()),
                (Some("surface_contact"), _) if name.contains("friction") => (
                    "self_contact.friction",
                    self.spec
                        .self_contact
                        .as_ref()
                        .map(|s| s.span())
                        .unwrap_or_default(),
                ),
                (Some("surface_contact"), _) => {
                    match (&self.spec.self_contact, self.spec.bodies.first()) {
                        (_, Some(first)) => ("bodies", first.span()),
                        (Some(given), None) => ("self_contact", given.span()),
                        (None, None) => ("analysis", analysis.unwrap_or_default()),
                    }
                }
                _ => ("analysis", analysis.unwrap_or_default()),
            };
            self.error(key, &span, message)
        })
    }
}
