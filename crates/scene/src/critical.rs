//! The explicit critical step of a static or modal scene, for its summary.

use super::BuiltScene;
use tetfem::analysis::dynamics::{LinearSystem, MassKind, Rayleigh, critical_time_step};
use tetfem::base::error::Result;

/// The explicit critical step of a scene's body: the largest stable step of the explicit
/// method with a lumped mass, 2/ω_max, proven from above (see
/// [`tetfem::analysis::dynamics::critical_time_step`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct CriticalStepReport {
    /// The step (s).
    pub seconds: f64,
    /// How it was found: `"Lanczos iteration"` (proven by an inertia check) or `"Gershgorin
    /// bound"`.
    pub source: String,
}

/// [`CriticalStepReport`] of a built scene: its linear system with a lumped mass (the
/// scene's loads do not enter); `critical_step_of_body` with the supports held.
pub fn critical_step_of<C: tetfem::fe::element::ElementType>(
    built: &BuiltScene<C>,
) -> Result<CriticalStepReport> {
    critical_step_of_body(built, false)
}

/// [`CriticalStepReport`] of a built scene's linear system with a lumped mass: with
/// `free_body` the free body's ([`LinearSystem::new_free_body`], for a body that obstacles alone
/// may hold, e.g. a dropped ball: its rigid modes are not refused), else the supported one's
/// ([`LinearSystem::new`], which refuses a body its supports do not hold).
pub fn critical_step_of_body<C: tetfem::fe::element::ElementType>(
    built: &BuiltScene<C>,
    free_body: bool,
) -> Result<CriticalStepReport> {
    type Build<C> = fn(
        &tetfem::mesh::TetMesh<C>,
        &tetfem::fe::materials::MaterialMap,
        &tetfem::Constraints,
        &tetfem::Loads,
        nalgebra::Vector3<f64>,
        MassKind,
        Rayleigh,
    ) -> Result<LinearSystem>;
    let build: Build<C> = if free_body {
        LinearSystem::new_free_body
    } else {
        LinearSystem::new
    };
    let system = build(
        &built.mesh,
        &built.materials,
        &built.constraints,
        &built.other_loads,
        built.gravity,
        MassKind::Lumped,
        Rayleigh::default(),
    )?;
    let step = critical_time_step(&system)?;
    Ok(CriticalStepReport {
        seconds: step.dt,
        source: step.certificate.source().to_string(),
    })
}
