//! Contact in dynamic scenes: the contact of a run with `[[obstacles]]` (the library's transient
//! set-up makes every force model — the linear one too — step through Newton with its barrier),
//! and what the outputs add: the CSV columns of the contact energy and
//! the force on each obstacle, the `.vtu` fields `contact_gap` and `contact_pressure`, and a
//! camera box that holds the body's way to the obstacles.

use nalgebra::Vector3;
use tetfem::analysis::dynamics::InternalForce;
use tetfem::base::error::Result;
use tetfem::contact::Contact;

use super::{BuiltScene, Scene, SceneElement};

/// The contact of a dynamic scene's `[[obstacles]]` on the body of `built` (the barrier's
/// stiffness scaled by its stiffest material).
///
/// Errors: those of the obstacles' placement; a scene without obstacle names the key.
pub(super) fn scene_contact<E: SceneElement>(
    scene: &Scene,
    built: &BuiltScene<E>,
) -> Result<Contact> {
    let span = scene
        .spec()
        .obstacles
        .first()
        .map(|o| o.span())
        .unwrap_or_default();
    scene
        .contact(&built.mesh, built.materials.stiffest_youngs_modulus())?
        .ok_or_else(|| scene.error("obstacles", &span, "no obstacle".to_string()))
}

/// The contact of a run's force law, if any.
pub(super) fn contact_of(force: &InternalForce) -> Option<&Contact> {
    force.contact()
}

/// The CSV columns a run with `contact` adds: `contact_energy_J` (the barrier's energy E_c,
/// which `total_J` leaves out) and per obstacle `contact_<name>_fx_N`, `_fy_N`, `_fz_N`: the
/// force the body exerts on it, normal and friction (N; its weight, for a body resting on the
/// ground; see [`obstacle_forces`]).
pub(super) fn csv_columns(contact: &Contact) -> Vec<String> {
    let mut columns = vec!["contact_energy_J".to_string()];
    for o in contact.obstacles() {
        for c in ["fx", "fy", "fz"] {
            columns.push(format!("contact_{}_{c}_N", o.name()));
        }
    }
    columns
}

/// The values of [`csv_columns`] at full displacement `u` and time `time` (the obstacles placed
/// there), with `forces` the obstacles' forces there ([`obstacle_forces`]).
pub(super) fn csv_values(
    contact: &Contact,
    u: &[f64],
    time: f64,
    forces: &[Vector3<f64>],
) -> Result<Vec<f64>> {
    contact.set_time(time);
    let mut values = vec![contact.energy(u)?];
    for f in forces {
        values.extend(f.iter());
    }
    Ok(values)
}

/// The force the body exerts on each obstacle (N) at full displacement `u` and time `time`
/// (the obstacles placed there), or `None` without contact: the barrier's normal force
/// Σᵢ κ·Aᵢ·b′(dᵢ)·∇dᵢ over the boundary nodes ([`Contact::obstacle_forces`]) plus, with
/// friction, the friction force of the step that reached `u`
/// ([`NonlinearForce::friction_forces`](tetfem::analysis::dynamics::NonlinearForce::friction_forces);
/// none at the initial state).
pub(super) fn obstacle_forces(
    force: &InternalForce,
    u: &[f64],
    time: f64,
) -> Result<Option<Vec<Vector3<f64>>>> {
    let InternalForce::Nonlinear(nonlinear) = force else {
        return Ok(None);
    };
    let Some(contact) = nonlinear.contact() else {
        return Ok(None);
    };
    contact.set_time(time);
    let mut forces = contact.obstacle_forces(u)?;
    if let Some(friction) = nonlinear.friction_forces() {
        for (total, f) in forces.iter_mut().zip(friction) {
            *total += f;
        }
    }
    Ok(Some(forces))
}

/// The force on one `[[obstacles]]` entry over a dynamic run (the summary's `contact_forces`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ContactForceHistory {
    /// The obstacle's name.
    pub obstacle: String,
    /// The force the body exerts on it at the last step (N): the same numbers as the CSV's
    /// last `contact_<name>_fx_N`, `_fy_N`, `_fz_N`. At rest under gravity alone it balances
    /// the load the obstacle carries (a block resting on the ground: its weight).
    pub force_n: [f64; 3],
    /// The largest magnitude |F| = (F_x² + F_y² + F_z²)^½ over every state of the run, the
    /// initial one included (N).
    pub peak_n: f64,
    /// The time of the first state where |F| reached `peak_n` (s).
    pub peak_time_s: f64,
}

impl ContactForceHistory {
    /// One history per obstacle of `contact`, before any state (zero force, peak 0 at t = 0).
    pub(super) fn start(contact: &Contact) -> Vec<ContactForceHistory> {
        contact
            .obstacles()
            .iter()
            .map(|o| ContactForceHistory {
                obstacle: o.name().to_string(),
                force_n: [0.0; 3],
                peak_n: 0.0,
                peak_time_s: 0.0,
            })
            .collect()
    }

    /// Takes the forces `forces` (N, one per obstacle in order) of the state at `time` (s).
    pub(super) fn record(
        histories: &mut [ContactForceHistory],
        forces: &[Vector3<f64>],
        time: f64,
    ) {
        for (h, f) in histories.iter_mut().zip(forces) {
            h.force_n = (*f).into();
            let magnitude = f.norm();
            if magnitude > h.peak_n {
                h.peak_n = magnitude;
                h.peak_time_s = time;
            }
        }
    }
}

/// Per mesh node of `nodes` (rest positions) the gap (m) and contact pressure (Pa) at full
/// displacement `u` and time `time` ([`Contact::node_fields`]).
pub(super) fn node_fields(
    contact: &Contact,
    nodes: &[Vector3<f64>],
    u: &[f64],
    time: f64,
) -> Result<(Vec<f64>, Vec<f64>)> {
    contact.set_time(time);
    contact.node_fields(nodes, u)
}

/// The barrier of a dynamic run with `[[obstacles]]` (the summary's `contact_barrier`): a
/// dynamic run keeps the scene's activation distance (a moving body has no equilibrium to
/// continue d̂ to, as a static solve does), so its contact forces carry the barrier's gap error
/// Σλd/Σλ/max|u|, measured by the library at every accepted step
/// ([`BarrierRecord`](tetfem::analysis::dynamics::BarrierRecord)); past
/// [`GAP_ERROR_WARNING`](tetfem::contact::GAP_ERROR_WARNING) the summary warns that the forces
/// may be off the exact contact by more than 1 %.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct DynamicContactBarrier {
    /// The barrier's activation distance d̂ (m; the scene's `[contact] activation_distance` or
    /// its default).
    pub activation_distance_m: f64,
    /// The barrier's stiffness κ (Pa/m).
    pub stiffness: f64,
    /// The largest gap error over the accepted steps.
    pub gap_error_max: f64,
    /// The gap error of the last step.
    pub gap_error_final: f64,
    /// The smallest gap of a contact node to an obstacle over every accepted step and every
    /// accepted Newton iterate inside the steps (m; `None` before the first step).
    pub smallest_gap_m: Option<f64>,
}

impl DynamicContactBarrier {
    /// The summary's view of the library's record.
    pub(super) fn of(record: &tetfem::analysis::dynamics::BarrierRecord) -> Self {
        let smallest = record.smallest_gap();
        DynamicContactBarrier {
            activation_distance_m: record.parameters.activation_distance,
            stiffness: record.parameters.stiffness,
            gap_error_max: record.gap_error_max,
            gap_error_final: record.gap_error_final,
            smallest_gap_m: smallest.is_finite().then_some(smallest),
        }
    }
}
