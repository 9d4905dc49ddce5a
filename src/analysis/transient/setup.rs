//! What a transient analysis assembles from a [`Definition`]: the system M·ü + C·u̇ + K·u =
//! f(t) on the free DOFs and the elastic force law. Said once here for scenes, Python and Rust
//! callers, so that the same definition steps with the same bits everywhere.

use std::sync::Arc;

use crate::analysis::Definition;
use crate::analysis::dynamics::{InternalForce, LinearSystem, MassKind, NonlinearForce, Rayleigh};
use crate::base::error::Result;
use crate::contact::surface::SurfaceContact;
use crate::model::{ModelElement, ModelKind};

impl<C: ModelElement> Definition<C> {
    /// The system of a transient run with `mass` and Rayleigh `damping`: the loads other than
    /// gravity constant or scaled by their amplitudes a(t), gravity tracked apart (its own
    /// potential), the supports following `time_data`'s motions.
    ///
    /// With obstacles the body may be held by contact alone, which is well posed in time (the
    /// mass holds its rigid modes): the rigid-mode check of the stiffness is then skipped
    /// ([`LinearSystem::new_free_body_with_time_data`]); without, a body free to move rigidly is
    /// the error of [`LinearSystem::with_time_data`].
    pub fn transient_system(&self, mass: MassKind, damping: Rayleigh) -> Result<LinearSystem> {
        let build = match self.contact.is_some() || self.surface_contact.is_some() {
            true => LinearSystem::new_free_body_with_time_data::<C>,
            false => LinearSystem::with_time_data::<C>,
        };
        build(
            &self.mesh,
            &self.materials,
            &self.constraints,
            &self.loads,
            self.gravity,
            mass,
            damping,
            &self.time_data,
        )
    }

    /// The elastic force law of a transient run on `system` (built by
    /// [`transient_system`](Self::transient_system)): the linear fast path
    /// ([`InternalForce::Linear`]) for the linear model (in every material region) without
    /// obstacles; otherwise the definition's model, one per material, each region its own with
    /// [`Definition::region_models`] (on a copy of the mesh), with the contact barrier
    /// of the obstacles if any (the linear model too: the barrier makes every step nonlinear).
    ///
    /// Errors: those of [`InternalForce::of_models`] and of the contact (a body starting inside
    /// an obstacle, [`NonlinearForce::with_contact`]).
    ///
    /// With body–body and self-contact ([`Definition::surface_contact`]) the surface barrier
    /// joins the force ([`NonlinearForce::with_surface_contact`]); its errors are those of
    /// [`SurfaceContact::new`] (bodies overlapping at the start, naming them and a triangle
    /// pair).
    pub fn transient_force(&self, system: &LinearSystem) -> Result<InternalForce> {
        if self.contact.is_none() && self.surface_contact.is_none() {
            return match &self.region_models {
                None => InternalForce::of_kind(self.model, &self.mesh, &self.materials, system),
                // Every region linear: the fast path, as for one linear model.
                Some(_) if self.is_linear() => {
                    InternalForce::of_kind(ModelKind::Linear, &self.mesh, &self.materials, system)
                }
                Some(_) => {
                    InternalForce::of_models(Arc::new(self.mesh.clone()), self.model_map()?, system)
                }
            };
        }
        let models = self.model_map()?;
        let mut force = NonlinearForce::with_models(Arc::new(self.mesh.clone()), models, system)?;
        if let Some(contact) = &self.contact {
            force = force.with_contact(contact.clone())?;
        }
        if let Some(data) = &self.surface_contact {
            let surface = SurfaceContact::new(&self.mesh, &data.body_of_node, data.barrier)?;
            force = force.with_surface_contact(surface)?;
        }
        Ok(InternalForce::Nonlinear(Arc::new(force)))
    }
}
