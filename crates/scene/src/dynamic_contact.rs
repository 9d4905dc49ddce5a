//! Contact in dynamic scenes: the set-up of a run with `[[obstacles]]` (the system of a body that
//! may be held by contact alone, every force model — the linear one too — through the Newton
//! step with the barrier), and what the outputs add: the CSV columns of the contact energy and
//! the force on each obstacle, the `.vtu` fields `contact_gap` and `contact_pressure`, and a
//! camera box that holds the body's way to the obstacles.

use std::sync::Arc;
use std::time::Instant;

use nalgebra::Vector3;
use tetfem::analysis::dynamics::{InternalForce, LinearSystem, NonlinearForce, Rayleigh, State};
use tetfem::base::error::Result;
use tetfem::contact::Contact;

use super::{BuiltScene, DynamicSettings, DynamicSetup, Scene, SceneElement};

impl<E: SceneElement> DynamicSetup<E> {
    /// The setup of a dynamic scene with `[[obstacles]]` (what
    /// [`from_scene`](Self::from_scene) and [`with_model`](Self::with_model) are without them):
    /// the system without the rigid-mode check (a body held by contact alone is well posed in
    /// time: the mass holds its rigid modes), and the scene's model — the linear one included,
    /// since the barrier makes every step nonlinear — with the contact
    /// ([`NonlinearForce::with_contact`]).
    ///
    /// Every method, element order, amplitude and moving support: what may be combined is the
    /// library's rule ([`Scene::combination`]), checked when the scene was parsed.
    ///
    /// Errors: those of the contact (a body starting inside an obstacle).
    pub fn with_contact(
        scene: &Scene,
        built: BuiltScene<E>,
        settings: &DynamicSettings,
    ) -> Result<Self> {
        let clock = Instant::now();
        let span = scene
            .spec()
            .obstacles
            .first()
            .map(|o| o.span())
            .unwrap_or_default();
        let damping = Rayleigh::new(settings.damping.mass, settings.damping.stiffness)?;
        let system = LinearSystem::new_free_body_with_time_data(
            &built.mesh,
            &built.materials,
            &built.constraints,
            &built.other_loads,
            built.gravity,
            settings.mass,
            damping,
            &built.time_data,
        )?;
        let mut initial = State::at_rest(system.free_count());
        let velocity: Vec<f64> = (0..built.mesh.dof_count())
            .map(|dof| settings.initial_velocity[dof % 3])
            .collect();
        initial.velocity = system.dofs().restrict(&velocity)?;
        let contact = scene
            .contact(&built.mesh, super::obstacles::stiffest(&built.materials))?
            .ok_or_else(|| scene.error("obstacles", &span, "no obstacle".to_string()))?;
        let models = scene.model().build_map(&built.materials);
        let force = NonlinearForce::with_models(Arc::new(built.mesh.clone()), models, &system)?
            .with_contact(contact)?;
        let reactions = super::DynamicReactions::of_scene(&built, &system)?;
        let mut setup = Self::of_built(built, system, initial, reactions, clock)?;
        setup.force = InternalForce::Nonlinear(Arc::new(force));
        Ok(setup)
    }
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
