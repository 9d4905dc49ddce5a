//! Explicit symplectic (semi-implicit) Euler with lumped mass.

use std::sync::Arc;

use rayon::prelude::*;

use super::NonlinearForce;
use super::explicit_surface::{SurfaceStepBound, check_surface_step, surface_step_bound};
use super::newton::NewtonSolver;
use super::{
    DivergenceGuard, Energy, Integrator, IntegratorHistory, InternalForce, LinearSystem, Mass,
    State, StepNewtonOptions, check_time_step, sum_in_order,
};
use crate::base::error::{Error, Result};
use crate::block_sparse::SymmetricWorkspace;
use crate::contact::velocity::ImpulseStep;

/// The remedy an explicit run's divergence names (appended to [`Error::Diverged`]'s reason by
/// [`SymplecticEuler`] when its divergence guard or its finite check stops it): the method is
/// stable only for dt below the critical step 2/ω_max, so a smaller step or an unconditionally
/// stable method removes the growth. Not appended to errors of the starting state or of
/// contact, which name their own cause.
pub const EXPLICIT_REMEDY: &str = "the explicit method is stable only below its critical step: \
     choose a dt below the critical step (e.g. 0.9 of it) or an implicit method";

/// `error` with [`EXPLICIT_REMEDY`] appended to its reason if it is an [`Error::Diverged`].
fn with_remedy(error: Error) -> Error {
    match error {
        Error::Diverged { step, time, reason } => Error::Diverged {
            step,
            time,
            reason: format!("{reason}; {EXPLICIT_REMEDY}"),
        },
        other => other,
    }
}

/// Symplectic Euler, M·(v⁺ − v)/dt = f − K·u − C·v, then u⁺ = u + dt·v⁺: the velocity form of
/// central differences. No linear solve (the mass is lumped), one product with K per step; stable
/// only for dt < 2/ω_max without damping, (2/ω_max)(√(1 + ξ²) − ξ) with Rayleigh damping of
/// ratio ξ at ω_max ([`super::critical_time_step`], [`super::damped_critical_step`]). An explicit run above the critical
/// step is allowed — the [`DivergenceGuard`] stops it with [`Error::Diverged`] once it blows up.
///
/// As in every leapfrog scheme the velocity it stores lives half a step behind the displacement
/// (v⁺ is the mean velocity over the step that produced u⁺); the velocity at the displacement's
/// time is v − dt/2·M⁻¹(K·u − f) to second order.
///
/// With a nonlinear [`InternalForce`], −K·u becomes f_int(u) and the stiffness damping β·K·v
/// becomes β·K_T(u)·v (the tangent, PSD-projected, assembled each step only when β > 0); still
/// no solve. The critical step is then the one of the tangent at rest (K_ff), which large
/// stretches can lower: leave a margin.
///
/// With contact, the contact acts on v⁺ before u⁺ is formed, at the velocity level and node by
/// node ([`Contact::apply_contact_impulses`](crate::contact::Contact::apply_contact_impulses), why in [`crate::contact::velocity`]): each contact
/// node's velocity relative to each obstacle is limited so that u + dt·v⁺ keeps a positive gap
/// (the barrier's reach d̂) to the obstacle's placement at t + dt — an inelastic impulse, its
/// reaction the force reported on the obstacle — and friction shrinks the tangential relative
/// velocity by at most μ times the normal impulse, never reversing it. Neither touches the
/// stable step: the critical step of the body is the critical step of the run, and no node
/// passes through an obstacle at any dt.
///
/// With body–body and self-contact the surface barrier's force is part of f_int, and its
/// stiffness enters the stable step: dt above the bound of [`super::surface_step_bound`]
/// (the barrier at a tenth of d̂) is refused when the integrator is made or its step changed,
/// and a step that brings a surface pair below that distance, or whose motion the CCD cannot
/// clear whole, stops the run with [`Error::Diverged`] naming it (`explicit_surface.rs`).
#[derive(Debug)]
pub struct SymplecticEuler {
    system: Arc<LinearSystem>,
    dt: f64,
    inverse_mass: Vec<f64>,
    guard: Option<DivergenceGuard>,
    work: Vec<f64>,
    product: Vec<f64>,
    blocks_work: SymmetricWorkspace,
    /// f(t) of time-varying data (empty for constant data: see [`LinearSystem::load_buffer`]).
    load: Vec<f64>,
    /// The evaluator of a nonlinear force (`None`: the linear path).
    forces: Option<NewtonSolver>,
    /// With surface contact: the step bound its barrier sets ([`SurfaceStepBound`]).
    surface_bound: Option<SurfaceStepBound>,
}

impl SymplecticEuler {
    /// An integrator with time step `dt`; the system must have lumped mass.
    pub fn new(system: Arc<LinearSystem>, dt: f64) -> Result<Self> {
        Self::with_force(system, InternalForce::Linear, dt)
    }

    /// An integrator with the elastic force `force` (the linear one is [`new`](Self::new)) and
    /// time step `dt`; the system must have lumped mass.
    pub fn with_force(system: Arc<LinearSystem>, force: InternalForce, dt: f64) -> Result<Self> {
        let dt = check_time_step(dt)?;
        super::check_damping(&system)?;
        let inverse_mass = match system.mass() {
            Mass::Lumped(m) => m.iter().map(|m| 1.0 / m).collect(),
            Mass::Consistent(_) => {
                return Err(Error::invalid_parameter(
                    "mass",
                    "consistent",
                    "the explicit method needs lumped mass (a consistent mass would need a solve per step)",
                ));
            }
        };
        let forces = match force {
            InternalForce::Linear => None,
            InternalForce::Nonlinear(f) => Some(NewtonSolver::new(
                f,
                &system,
                StepNewtonOptions::default(),
                super::NonlinearSolve::Refactor,
            )?),
        };
        // With surface contact the barrier's stiffness at the smallest distance the run may
        // reach enters the stable step: a dt above it is refused before any step.
        let surface_bound = match forces.as_ref().and_then(|f| f.force().surface_contact()) {
            Some(surface) => {
                let body = super::critical_time_step(&system)?.dt;
                let bound = surface_step_bound(&system, surface, body)?;
                bound.check(dt)?;
                Some(bound)
            }
            None => None,
        };
        let n = system.free_count();
        let load = system.model_load_buffer(forces.is_some());
        Ok(SymplecticEuler {
            surface_bound,
            forces,
            dt,
            inverse_mass,
            guard: None,
            work: vec![0.0; n],
            product: vec![0.0; n],
            blocks_work: system.stiffness_blocks().workspace(),
            load,
            system,
        })
    }
}

impl SymplecticEuler {
    /// A step with the nonlinear force: v⁺ = v + dt·M⁻¹·(f + f_int(u) − C(u)·v), u⁺ = u + dt·v⁺;
    /// the guard checks the energies of the state the step starts from.
    fn nonlinear_step(&mut self, state: &mut State) -> Result<()> {
        let n = self.system.free_count();
        state.check_len(n)?;
        let Some(forces) = self.forces.as_mut() else {
            return Ok(());
        };
        // Moving obstacles: the force is evaluated with them at the step's start, t.
        if let Some(contact) = forces.force().contact() {
            contact.set_time(state.time);
        }
        // So are the load and the supports.
        forces.force().set_time(&self.system, state.time)?;
        let load = self
            .system
            .model_load_at(state.time, true, &mut self.load)?;
        forces.net_force(
            &self.system,
            (&state.displacement, &state.velocity),
            load,
            &mut self.product,
        )?;
        // The guard's energies come out of the force's pass (a second pass over the tets
        // for the energy alone took as long again).
        let energy = forces.energy_at_net_force(&self.system, state)?;
        DivergenceGuard::check_or_start_with(
            &mut self.guard,
            (state.steps, state.time),
            energy,
            forces.force().contact().is_some_and(|c| c.is_moving())
                || self.system.is_time_varying(),
            with_remedy,
        )?;
        let dt = self.dt;
        for i in 0..n {
            state.velocity[i] += dt * self.product[i] * self.inverse_mass[i];
        }
        // Contact acts on the new velocity, node by node (lumped mass): no node ends the step
        // inside an obstacle, and friction follows from the normal impulse. Neither needs a
        // smaller step (a barrier or friction force would: its stiffness grows without bound).
        contact_impulses(&self.system, &self.inverse_mass, forces.force(), state, dt)?;
        let surface_motion = surface_motion(&self.system, forces.force(), state, dt)?;
        for i in 0..n {
            state.displacement[i] += dt * state.velocity[i];
        }
        state.time += dt;
        state.steps += 1;
        state.ensure_finite("").map_err(with_remedy)?;
        if let (Some(surface), Some((start, step, end))) =
            (forces.force().surface_contact(), &surface_motion)
        {
            check_surface_step(surface, (start, step, end), (state.steps, state.time))?;
        }
        // The impulses hold every free node outside; one that crossed all the same (pushed by
        // one obstacle into another, or with a support that moves it) is a divergence, never a
        // penetrated state.
        let force = forces.force();
        if let Some(contact) = force.contact() {
            contact.set_time(state.time);
        }
        if let Some(contact) = force.contact()
            && let Some(inside) =
                contact.nodes_inside(&force.full_displacement(&state.displacement)?)?
        {
            return Err(Error::Diverged {
                step: state.steps,
                time: state.time,
                reason: format!(
                    "nodes crossed into obstacle {}: {inside}. The explicit method's contact \
                     limits each free node's velocity so that it ends the step outside every \
                     obstacle; these were carried in by their supports or pushed by one \
                     obstacle into another at dt = {dt:e}. Choose a smaller dt, or the \
                     backward_euler method",
                    inside.obstacle
                ),
            });
        }
        Ok(())
    }
}

/// With surface contact, the step's motion over every DOF: the full displacement at its start
/// (the force's supports at the step's start), the motion dt·v⁺ (the supports' own over the
/// step) and the end; `None` without surface contact.
type SurfaceMotion = Option<(Vec<f64>, Vec<f64>, Vec<f64>)>;

fn surface_motion(
    system: &LinearSystem,
    force: &NonlinearForce,
    state: &State,
    dt: f64,
) -> Result<SurfaceMotion> {
    if force.surface_contact().is_none() {
        return Ok(None);
    }
    let start = force.full_displacement(&state.displacement)?;
    let mut end = match system.has_moving_supports() {
        true => system.prescribed_at(state.time + dt)?,
        false => start.clone(),
    };
    for (k, &d) in system.dofs().free_dofs().iter().enumerate() {
        end[d] = state.displacement[k] + dt * state.velocity[k];
    }
    let step = end.iter().zip(&start).map(|(e, s)| e - s).collect();
    Ok(Some((start, step, end)))
}

/// Contact in an explicit step ([`Contact::apply_contact_impulses`](crate::contact::Contact::apply_contact_impulses), see
/// [`crate::contact::velocity`]): limits the new free velocity `state.velocity` so that every
/// contact node ends the step (at `state.displacement` + dt·v) outside every obstacle placed at
/// t + dt, with friction from the normal impulse, and keeps the impulses' reaction on each
/// obstacle ([`NonlinearForce::keep_impulse_forces`]). The constrained DOFs move at their
/// prescribed velocity over the step. Does nothing without contact.
fn contact_impulses(
    system: &LinearSystem,
    inverse_mass: &[f64],
    force: &NonlinearForce,
    state: &mut State,
    dt: f64,
) -> Result<()> {
    let Some(contact) = force.contact() else {
        return Ok(());
    };
    // The force's supports are at the step's start (set for its evaluation).
    let start = force.full_displacement(&state.displacement)?;
    let mut velocity = vec![0.0; start.len()];
    if system.has_moving_supports() {
        let end = system.prescribed_at(state.time + dt)?;
        for (v, (e, s)) in velocity.iter_mut().zip(end.iter().zip(&start)) {
            *v = (e - s) / dt;
        }
    }
    let mut inverse = vec![0.0; start.len()];
    let free = system.dofs().free_dofs();
    for (k, &d) in free.iter().enumerate() {
        velocity[d] = state.velocity[k];
        inverse[d] = inverse_mass[k];
    }
    let step = ImpulseStep {
        step: state.steps + 1,
        time: state.time,
        dt,
    };
    let forces = contact.apply_contact_impulses(&start, &mut velocity, &inverse, step)?;
    force.keep_impulse_forces(forces);
    for (v, &d) in state.velocity.iter_mut().zip(free) {
        *v = velocity[d];
    }
    Ok(())
}

impl Integrator for SymplecticEuler {
    fn step(&mut self, state: &mut State) -> Result<()> {
        if self.forces.is_some() {
            return self.nonlinear_step(state);
        }
        let n = self.system.free_count();
        state.check_len(n)?;
        let (dt, damping) = (self.dt, self.system.damping());
        // A step is bound by memory traffic, so it makes one pass over K (K·u, and K·v with
        // stiffness damping; uᵀK·u comes with it) and one pass over the vectors, which both
        // takes this state's energies for the guard and advances it.
        let blocks = self.system.stiffness_blocks();
        let twice_elastic = if damping.beta != 0.0 {
            let (u, v) = (&state.displacement, &state.velocity);
            let (twice_elastic, _) = blocks.product2_into(
                (u, v),
                (&mut self.product, &mut self.work),
                &mut self.blocks_work,
            );
            for (p, kv) in self.product.iter_mut().zip(&self.work) {
                *p += damping.beta * kv;
            }
            twice_elastic
        } else {
            blocks.product_into(
                &state.displacement,
                &mut self.product,
                &mut self.blocks_work,
            )
        };
        let (before_steps, before_time) = (state.steps, state.time);
        // The force is evaluated at the step's start, t: the load and moving supports too.
        let f = self.system.external_load_at(state.time, &mut self.load)?;
        let (inverse_mass, product, alpha) = (&self.inverse_mass, &self.product, damping.alpha);
        // Per chunk: 2·kinetic, potential of all loads −f·u, Σ|u⁺| + |v⁺| (non-finite iff
        // some new value is); partial sums added in order, so the bits do not depend on threads.
        const CHUNK: usize = 4096;
        let partial: Vec<[f64; 3]> = state
            .velocity
            .par_chunks_mut(CHUNK)
            .zip(state.displacement.par_chunks_mut(CHUNK))
            .enumerate()
            .map(|(c, (v, u))| {
                let offset = c * CHUNK;
                let mut sums = [0.0; 3];
                for (i, (v, u)) in v.iter_mut().zip(u.iter_mut()).enumerate() {
                    let k = offset + i;
                    sums[0] += *v * *v / inverse_mass[k];
                    sums[1] -= f[k] * *u;
                    let acceleration = (f[k] - product[k]) * inverse_mass[k] - alpha * *v;
                    *v += dt * acceleration;
                    *u += dt * *v;
                    sums[2] += v.abs() + u.abs();
                }
                sums
            })
            .collect();
        let sums = sum_in_order(&partial);
        let energy = Energy::for_guard(sums[0], twice_elastic, sums[1]);
        // The state has advanced whatever the guard finds: it holds the failed step's values.
        state.time += dt;
        state.steps += 1;
        match &self.guard {
            Some(guard) => guard
                .check_energy(before_steps, before_time, &energy)
                .map_err(with_remedy)?,
            None => {
                self.guard = Some(
                    self.system
                        .divergence_guard(energy, (before_steps, before_time))?,
                )
            }
        }
        if !sums[2].is_finite() {
            state.ensure_finite("").map_err(with_remedy)?;
        }
        Ok(())
    }

    fn time_step(&self) -> f64 {
        self.dt
    }

    fn set_time_step(&mut self, dt: f64) -> Result<()> {
        let dt = check_time_step(dt)?;
        if let Some(bound) = &self.surface_bound {
            bound.check(dt)?;
        }
        self.dt = dt;
        Ok(())
    }

    fn name(&self) -> &'static str {
        "explicit"
    }

    /// The guard: the step reads only u and v (v the mean velocity of the last step).
    fn history(&self) -> Result<IntegratorHistory> {
        Ok(IntegratorHistory {
            method: self.name().into(),
            guard: self.guard,
            acceleration: None,
            previous_acceleration: None,
            newton: None,
        })
    }

    fn restore(&mut self, state: &State, history: &IntegratorHistory) -> Result<()> {
        history.check(self.name(), self.system.free_count(), state)?;
        self.guard = history.guard;
        Ok(())
    }
}
