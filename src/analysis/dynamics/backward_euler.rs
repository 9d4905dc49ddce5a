//! Backward (implicit) Euler: first order, unconditionally stable, numerically dissipative.

use std::sync::Arc;

use rayon::prelude::*;

use super::newton::{NewtonSolver, StepEquation};
use super::{
    DivergenceGuard, Energy, Integrator, IntegratorHistory, IntegratorOptions, InternalForce,
    LinearSystem, Mass, NewtonStats, State, check_time_step, sum_in_order,
};
use crate::base::error::Result;
use crate::block_sparse::SymmetricWorkspace;
use crate::linear_solver::LinearSolver;
use crate::sparse::CscMatrix;

/// Backward Euler on the velocity, as in Baraff–Witkin:
///
/// (M + dt·C + dt²·K)·Δv = dt·(f − K·(u + dt·v) − C·v),  v ← v + Δv,  u ← u + dt·v.
///
/// With C = αM + βK the system matrix is (1 + dt·α)·M + (dt·β + dt²)·K, formed entry-wise on
/// K's pattern and factored once per time step value: the symbolic analysis is done once, a
/// change of dt only refactors numerically. A step is one pass over K (the node-block copy,
/// multiplying u and v together), one product with M, and two triangular solves (or, on the
/// iterative path of [`IntegratorOptions::linear_method`], one preconditioned CG solve); on the
/// direct path it allocates nothing. The divergence guard checks the energy of the state each step starts from (that
/// costs no extra product), so a runaway is caught one step after it happens.
///
/// With a nonlinear [`InternalForce`] the step is the same implicit equation in the new
/// displacement u⁺ = u + dt·v⁺,
///
/// M·(u⁺ − u − dt·v)/dt² + C·(u⁺ − u)/dt − f_int(u⁺) − f = 0,  v⁺ = (u⁺ − u)/dt,
///
/// solved by Newton's method ([`super::StepNewtonOptions`]; the tangent refilled and
/// refactored numerically each iteration on K_ff's symbolic analysis; C's stiffness part the
/// tangent at u). Its first iteration from u⁺ = u is the linearized step of Baraff & Witkin.
#[derive(Debug)]
pub struct BackwardEuler {
    system: Arc<LinearSystem>,
    dt: f64,
    matrix: CscMatrix,
    solver: LinearSolver,
    factored_for: Option<f64>,
    guard: Option<DivergenceGuard>,
    work: Vec<f64>,
    product: Vec<f64>,
    rhs: Vec<f64>,
    blocks_work: SymmetricWorkspace,
    /// f(t) of time-varying data (empty for constant data: see [`LinearSystem::load_buffer`]).
    load: Vec<f64>,
    /// The Newton solver of a nonlinear force (`None`: the linear path).
    newton: Option<NewtonSolver>,
    /// The nonlinear path's last acceleration a = (v⁺ − v)/dt (length/time², free DOFs) and
    /// the (steps, time) of the state it ends at: the next step's first Newton iterate is
    /// u + dt·v + dt²·a (a quadratic extrapolation of the last three positions), for that
    /// state only, or with `previous_acceleration` u + dt·v + dt²·(2a − a₋₁). Both are kept in
    /// checkpoints, so a resumed run takes the same iterations.
    acceleration: Option<(Vec<f64>, (usize, f64))>,
    /// The acceleration of the step before `acceleration`'s, when the two steps followed each
    /// other (the state was not set in between).
    previous_acceleration: Option<Vec<f64>>,
    /// The linear path's last step: (steps, time) of the state it left, whose Δv `rhs` holds.
    velocity_change_of: Option<(usize, f64)>,
}

impl BackwardEuler {
    /// An integrator with time step `dt` and default [`IntegratorOptions`] (analysis now, factorization on the first step).
    pub fn new(system: Arc<LinearSystem>, dt: f64) -> Result<Self> {
        Self::with_options(system, dt, IntegratorOptions::default())
    }

    /// An integrator with time step `dt` whose factorization and solves use
    /// `options` (direct or iterative, ordering and threads).
    pub fn with_options(
        system: Arc<LinearSystem>,
        dt: f64,
        options: IntegratorOptions,
    ) -> Result<Self> {
        Self::with_force(system, InternalForce::Linear, dt, options)
    }

    /// An integrator with the elastic force `force` (the linear one is
    /// [`with_options`](Self::with_options)), time step `dt` and `options`.
    pub fn with_force(
        system: Arc<LinearSystem>,
        force: InternalForce,
        dt: f64,
        options: IntegratorOptions,
    ) -> Result<Self> {
        let super::ImplicitParts {
            dt,
            matrix,
            solver,
            newton,
        } = super::ImplicitParts::new(&system, force, dt, &options)?;
        let n = system.free_count();
        let load = system.model_load_buffer(newton.is_some());
        Ok(BackwardEuler {
            dt,
            matrix,
            solver,
            factored_for: None,
            guard: None,
            work: vec![0.0; n],
            product: vec![0.0; n],
            rhs: vec![0.0; n],
            blocks_work: system.stiffness_blocks().workspace(),
            load,
            newton,
            acceleration: None,
            previous_acceleration: None,
            velocity_change_of: None,
            system,
        })
    }

    /// A step with the nonlinear force: Newton on the implicit equation in u⁺.
    fn nonlinear_step(&mut self, state: &mut State) -> Result<()> {
        let n = self.system.free_count();
        state.check_len(n)?;
        let Some(newton) = self.newton.as_mut() else {
            return Ok(());
        };
        let dt = self.dt;
        newton.force().set_time(&self.system, state.time)?;
        newton.force().begin_impact_step(&self.system, state, dt)?;
        let energy = newton.elastic_energy_of(&self.system, state)?;
        DivergenceGuard::check_or_start(
            &mut self.guard,
            (state.steps, state.time),
            energy,
            newton.force().does_work_off_the_potentials(&self.system),
        )?;
        // The predictor ũ = u + dt·v: where the body would go with no force.
        for ((p, u), v) in self
            .work
            .iter_mut()
            .zip(&state.displacement)
            .zip(&state.velocity)
        {
            *p = u + dt * v;
        }
        // The first iterate extrapolates the acceleration linearly where the last two steps'
        // are known: u + dt·v + dt²·(2a − a₋₁), a cubic through the last four positions. On
        // the swinging beam of `benches/corotational_step.rs` (132k DOFs, 20 steps) it took
        // L-BFGS from 48 to 41 iterations at a step tolerance of 1e-2 against u + dt·v + dt²·a,
        // the trajectory staying within 5.5e-5 of a converged one. Newton takes it only when
        // its residual or Φ is below u's.
        let continues =
            matches!(&self.acceleration, Some((_, of)) if *of == (state.steps, state.time));
        let guess: Option<Vec<f64>> = match (&self.acceleration, &self.previous_acceleration) {
            (Some((a, _)), Some(before)) if continues => Some(
                (self.work.iter().zip(a).zip(before))
                    .map(|((p, a), before)| p + dt * dt * (2.0 * a - before))
                    .collect(),
            ),
            (Some((a, _)), None) if continues => Some(
                (self.work.iter().zip(a))
                    .map(|(p, a)| p + dt * dt * a)
                    .collect(),
            ),
            _ => None,
        };
        // The load and the supports at the step's end, t + dt: the method is implicit in both.
        newton.force().set_time(&self.system, state.time + dt)?;
        let load = self
            .system
            .model_load_at(state.time + dt, true, &mut self.load)?;
        let equation = StepEquation {
            mass_scale: 1.0 / (dt * dt),
            damping_scale: 1.0 / dt,
            predictor: &self.work,
            start: &state.displacement,
            damping_velocity: None,
            duration: dt,
            first_iterate: guess.as_deref(),
            // Friction stays lagged at the step's start (IPC's single lag): on the conveyor the
            // block slides at μg to 1e-4 and rides at the belt's speed to 1e-5 either way (its
            // bounce is damped), while the passes took 3.1× and 1.9× the Newton iterations on
            // the shipped soft_block_drop and rubber_beam_floor (max 73 and 34 per step
            // against 12 and 11) and moved their outputs (the soft block's slide −22 %).
            // The implicit end-point rule is already dissipative for the barrier.
            contact_weight: 1.0,
            load,
        };
        newton.solve(
            &self.system,
            &equation,
            &mut self.matrix,
            &mut self.solver,
            &mut self.rhs,
            state.steps,
            state.time,
        )?;
        // This step's acceleration goes into the buffer of the one before last.
        let last = self.acceleration.take().map(|(a, _)| a);
        let mut acceleration = self.previous_acceleration.take().unwrap_or_default();
        acceleration.resize(n, 0.0);
        self.previous_acceleration = last.filter(|_| continues);
        for (((u, v), a), u_new) in state
            .displacement
            .iter_mut()
            .zip(state.velocity.iter_mut())
            .zip(acceleration.iter_mut())
            .zip(&self.rhs)
        {
            let v_new = (u_new - *u) / dt;
            *a = (v_new - *v) / dt;
            *v = v_new;
            *u = *u_new;
        }
        state.time += dt;
        state.steps += 1;
        self.acceleration = Some((acceleration, (state.steps, state.time)));
        state.ensure_finite("")
    }

    /// Forms (1 + dt·α)·M + (dt·β + dt²)·K and factors it.
    fn factor(&mut self) -> Result<()> {
        let (dt, damping) = (self.dt, self.system.damping());
        let (mass_scale, stiffness_scale) = (1.0 + dt * damping.alpha, dt * damping.beta + dt * dt);
        self.system
            .combine_into(stiffness_scale, mass_scale, &mut self.matrix)?;
        super::check_step_matrix(&self.matrix, dt, "(1 + dt·α)·M + (dt·β + dt²)·K")?;
        self.solver.factorize(&self.matrix)?;
        self.factored_for = Some(dt);
        Ok(())
    }
}

impl BackwardEuler {
    /// [`Integrator::step`] in this thread.
    fn step_here(&mut self, state: &mut State) -> Result<()> {
        if self.newton.is_some() {
            return self.nonlinear_step(state);
        }
        let n = self.system.free_count();
        state.check_len(n)?;
        // `rhs` is overwritten below: it holds no state's Δv until this step succeeds.
        self.velocity_change_of = None;
        if self.factored_for != Some(self.dt) {
            self.factor()?;
        }
        let (dt, damping) = (self.dt, self.system.damping());
        let (u, v) = (&state.displacement, &state.velocity);
        // K·u and K·v in one pass over K: uᵀK·u is the incoming state's elastic energy for the
        // guard, and K·(u + (dt + β)·v) = K·u + (dt + β)·K·v goes into the right-hand side.
        let (twice_elastic, _) = self.system.stiffness_blocks().product2_into(
            (u, v),
            (&mut self.product, &mut self.work),
            &mut self.blocks_work,
        );
        let lumped = match self.system.mass() {
            Mass::Lumped(m) => Some(m.as_slice()),
            Mass::Consistent(_) => {
                self.system.mass_product_into(v, &mut self.rhs);
                None
            }
        };
        // rhs = dt·(f − K·u − (dt + β)·K·v − α·M·v), in the same pass as the kinetic energy and
        // the potentials; `rhs` holds M·v on entry when the mass is consistent.
        // The load (and the moving supports' terms) at the step's end, t + dt: the method is
        // implicit in all of them.
        let f = self
            .system
            .external_load_at(state.time + dt, &mut self.load)?;
        let (ku, kv, stiffness_factor) = (&self.product, &self.work, dt + damping.beta);
        const CHUNK: usize = 4096;
        let chunk = |(c, rhs): (usize, &mut [f64])| {
            let offset = c * CHUNK;
            let mut sums = [0.0; 2];
            for (i, rhs) in rhs.iter_mut().enumerate() {
                let k = offset + i;
                let mv = lumped.map_or(*rhs, |m| m[k] * v[k]);
                sums[0] += v[k] * mv;
                sums[1] -= f[k] * u[k];
                *rhs = dt * (f[k] - ku[k] - stiffness_factor * kv[k] - damping.alpha * mv);
            }
            sums
        };
        // One thread in rayon's pool: the chunks in this thread (`linalg::parallel::one_thread`
        // says why); the same sums.
        let serial = crate::linalg::parallel::one_thread();
        let partial: Vec<[f64; 2]> = match serial {
            true => self.rhs.chunks_mut(CHUNK).enumerate().map(chunk).collect(),
            false => self
                .rhs
                .par_chunks_mut(CHUNK)
                .enumerate()
                .map(chunk)
                .collect(),
        };
        let sums = sum_in_order(&partial);
        let energy = Energy::for_guard(sums[0], twice_elastic, sums[1]);
        match &self.guard {
            Some(guard) => guard.check_energy(state.steps, state.time, &energy)?,
            None => {
                self.guard = Some(
                    self.system
                        .divergence_guard(energy, (state.steps, state.time))?,
                )
            }
        }
        self.solver.solve(&self.matrix, &mut self.rhs)?;
        let advance = |((v, u), dv): ((&mut f64, &mut f64), &f64)| {
            *v += dv;
            *u += dt * *v;
            u.is_finite() && v.is_finite()
        };
        // In this thread every DOF is advanced, whether or not one is not finite (no short
        // circuit: the failed step's values are then all in the state).
        let finite = match serial {
            true => {
                let mut all = true;
                let dofs = (state.velocity.iter_mut()).zip(state.displacement.iter_mut());
                for dof in dofs.zip(self.rhs.iter()) {
                    all &= advance(dof);
                }
                all
            }
            false => (state.velocity.par_iter_mut())
                .zip(state.displacement.par_iter_mut())
                .zip(self.rhs.par_iter())
                .with_min_len(CHUNK)
                .all(advance),
        };
        state.time += dt;
        state.steps += 1;
        if !finite {
            state.ensure_finite("")?;
        }
        self.velocity_change_of = Some((state.steps, state.time));
        Ok(())
    }
}

impl Integrator for BackwardEuler {
    /// A step runs on one of rayon's pool threads ([`crate::linalg::parallel::in_pool`]): its
    /// parallel regions (force passes, block products, the solves' halves) are then handed
    /// over within the pool, each in a few µs instead of two futex wake-ups from this thread.
    fn step(&mut self, state: &mut State) -> Result<()> {
        crate::linalg::parallel::in_pool(|| self.step_here(state))
    }

    fn time_step(&self) -> f64 {
        self.dt
    }

    fn set_time_step(&mut self, dt: f64) -> Result<()> {
        self.dt = check_time_step(dt)?;
        // The last Δv was taken over the old dt: a = Δv/dt no longer follows from it.
        self.velocity_change_of = None;
        Ok(())
    }

    fn factor_len(&self) -> Option<usize> {
        Some(self.solver.factor_len())
    }

    fn linear_solver(&self) -> Option<&LinearSolver> {
        Some(&self.solver)
    }

    fn name(&self) -> &'static str {
        "backward-euler"
    }

    fn linear_acceleration(&self, state: &State) -> Option<std::borrow::Cow<'_, [f64]>> {
        let left = self.velocity_change_of == Some((state.steps, state.time));
        (self.newton.is_none() && left)
            .then(|| std::borrow::Cow::Owned(self.rhs.iter().map(|dv| dv / self.dt).collect()))
    }

    fn newton_stats(&self) -> Option<NewtonStats> {
        self.newton.as_ref().map(NewtonSolver::stats)
    }

    /// The guard and Newton's counts: the step itself reads only u and v.
    fn history(&self) -> Result<IntegratorHistory> {
        Ok(IntegratorHistory {
            method: self.name().into(),
            guard: self.guard,
            acceleration: self.acceleration.as_ref().map(|(a, _)| a.clone()),
            previous_acceleration: self.previous_acceleration.clone(),
            newton: self.newton_stats(),
        })
    }

    fn restore(&mut self, state: &State, history: &IntegratorHistory) -> Result<()> {
        history.check(self.name(), self.system.free_count(), state)?;
        self.guard = history.guard;
        self.velocity_change_of = None;
        self.acceleration = (history.acceleration.clone()).map(|a| (a, (state.steps, state.time)));
        self.previous_acceleration = history.previous_acceleration.clone();
        if let (Some(newton), Some(stats)) = (self.newton.as_mut(), history.newton) {
            newton.set_stats(stats);
        }
        Ok(())
    }
}
