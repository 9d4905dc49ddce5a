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
    /// How it was found: `"power iteration"` (proven by an inertia check) or `"Gershgorin
    /// bound"`.
    pub source: String,
}

/// [`CriticalStepReport`] of a built scene: its linear system with a lumped mass (the
/// scene's loads do not enter).
pub fn critical_step_of<C: tetfem::fe::element::ElementType>(
    built: &BuiltScene<C>,
) -> Result<CriticalStepReport> {
    let system = LinearSystem::new(
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
