//! The explicit critical step, found one way for every front end: for a lumped mass 2/ω_max by
//! Lanczos iteration on the assembled system ([`critical_time_step`]: proven by an inertia check,
//! or Gershgorin's looser bound where the check's factor would not fit), for a consistent mass
//! the element bound ([`StepBoundElement::step_bound`], never above the system's step).
//!
//! Contact adds nothing to it: explicit steps enforce contact on the velocity
//! ([`crate::contact::velocity`]), which has no stiffness, so the body's critical step is the
//! run's and a step up to it lets no node through an obstacle. The barrier's stiffness
//! κ·Aᵢ·b″(d) — unbounded as d → 0, so no critical step could include it — acts only on a node
//! that starts inside its reach, and there a step it makes unstable is refused by name.
//!
//! Body–body and self-contact is different: its barrier acts between two moving surfaces as a
//! force of the explicit step, so its stiffness at the smallest distance the run may reach
//! enters the step ([`crate::analysis::dynamics::surface_step_bound`]); [`super::Transient`]
//! takes the smaller of the two for a step given as a multiple of the critical one (its
//! source then `"surface barrier bound"`).

use crate::analysis::dynamics::{LinearSystem, Mass, StepBoundElement, critical_time_step};
use crate::base::error::Result;
use crate::fe::materials::TetMaterials;
use crate::mesh::TetMesh;

/// The explicit method's critical step of a system and how it was found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepLimit {
    /// The critical step (time units, s in SI): the explicit method is stable below it.
    pub dt: f64,
    /// How it was found: `"Lanczos iteration"`, `"Gershgorin bound"`, `"element bound"` or
    /// (explicit with surface contact, [`super::Transient`]) `"surface barrier bound"`.
    pub source: &'static str,
}

/// The critical step of `system` assembled on `mesh` with `materials`: for a lumped mass
/// 2/ω_max by Lanczos iteration ([`critical_time_step`]), for a consistent mass the element bound
/// ([`StepBoundElement::step_bound`]): what a step given as a multiple of it (`"50crit"`) multiplies and what
/// run summaries report.
///
/// Errors: those of [`critical_time_step`] (a system without free DOF) and of the element
/// bound (`materials` do not cover the mesh).
pub fn critical_step<E: StepBoundElement>(
    system: &LinearSystem,
    mesh: &TetMesh<E>,
    materials: &impl TetMaterials,
) -> Result<StepLimit> {
    Ok(match system.mass() {
        Mass::Lumped(_) => {
            let step = critical_time_step(system)?;
            StepLimit {
                dt: step.dt,
                source: step.certificate.source(),
            }
        }
        Mass::Consistent(_) => StepLimit {
            dt: E::step_bound(mesh, materials)?.dt_element,
            source: "element bound",
        },
    })
}
