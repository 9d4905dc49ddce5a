//! Explicit symplectic (semi-implicit) Euler with lumped mass.

use std::sync::Arc;

use rayon::prelude::*;

use super::newton::NewtonSolver;
use super::{
    DivergenceGuard, Energy, Integrator, IntegratorHistory, InternalForce, LinearSystem, Mass,
    State, StepNewtonOptions, check_time_step, sum_in_order,
};
use crate::base::error::{Error, Result};
use crate::block_sparse::SymmetricWorkspace;

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
/// With frictional contact ([`NonlinearForce::apply_friction_impulses`](super::NonlinearForce::apply_friction_impulses)), friction acts on v⁺ before
/// u⁺ is formed, node by node and implicitly: it shrinks each contact node's tangential
/// velocity relative to the obstacle (by at most dt·μ·λ/m, smoothed below ε_v) and never
/// reverses it, so it leaves the stable step as it is.
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
        let n = system.free_count();
        let load = system.model_load_buffer(forces.is_some());
        Ok(SymplecticEuler {
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
        DivergenceGuard::check_or_start(
            &mut self.guard,
            (state.steps, state.time),
            energy,
            forces.force().contact().is_some_and(|c| c.is_moving())
                || self.system.is_time_varying(),
        )?;
        let dt = self.dt;
        for i in 0..n {
            state.velocity[i] += dt * self.product[i] * self.inverse_mass[i];
        }
        // Friction acts on the new velocity implicitly, node by node (lumped mass): it shrinks
        // the tangential speed relative to the obstacle, never reverses it, so it needs no
        // smaller step (an explicit friction force would be a damper of rate μ·λ/(m·ε_v)).
        forces.force().apply_friction_impulses(
            &state.displacement,
            &mut state.velocity,
            &self.inverse_mass,
            state.time,
            dt,
        )?;
        for i in 0..n {
            state.displacement[i] += dt * state.velocity[i];
        }
        state.time += dt;
        state.steps += 1;
        state.ensure_finite("; is dt above the critical step?")?;
        // The barrier is as stiff as κ·Aᵢ·b″(d) ≈ κ·Aᵢ·d̂²/d² at a node of gap d: stable only
        // while dt < 2·√(mᵢ/(κ·Aᵢ·b″(d))), so a step that lets a node cross an obstacle was
        // too large for the contact — a divergence, never a penetrated state.
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
                    "nodes crossed into obstacle {}: {inside}. The step dt = {dt:e} is above the \
                     contact barrier's stable step: near an obstacle the barrier stiffens as \
                     κ·A·d̂²/d² at a node of gap d, so a step stable for the body alone lets a \
                     node jump through the barrier. Choose a smaller dt, a larger activation \
                     distance, or the backward_euler method (stable at any step)",
                    inside.obstacle
                ),
            });
        }
        Ok(())
    }
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
            Some(guard) => guard.check_energy(before_steps, before_time, &energy)?,
            None => {
                self.guard = Some(
                    self.system
                        .divergence_guard(energy, (before_steps, before_time))?,
                )
            }
        }
        if !sums[2].is_finite() {
            state.ensure_finite("; is dt above the critical step?")?;
        }
        Ok(())
    }

    fn time_step(&self) -> f64 {
        self.dt
    }

    fn set_time_step(&mut self, dt: f64) -> Result<()> {
        self.dt = check_time_step(dt)?;
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
