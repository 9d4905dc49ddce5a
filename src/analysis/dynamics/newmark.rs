//! Implicit Newmark, average acceleration (β = ¼, γ = ½): second order, unconditionally stable,
//! and for linear undamped motion it conserves the total energy exactly (up to round-off).

use std::sync::Arc;

use super::newton::{NewtonSolver, StepEquation, contact_force_and_energy, solve_mass};
use super::{
    DivergenceGuard, Integrator, IntegratorHistory, IntegratorOptions, InternalForce, LinearSystem,
    Mass, NewtonStats, State, check_time_step,
};
use crate::base::error::Result;
use crate::block_sparse::SymmetricWorkspace;
use crate::linear_solver::LinearSolver;
use crate::linsolve::SparseCholesky;
use crate::sparse::CscMatrix;

/// Newmark's average-acceleration method:
///
/// K_eff·u⁺ = f + M·(4/dt²·u + 4/dt·v + a) + C·(2/dt·u + v),  K_eff = K + 2/dt·C + 4/dt²·M,
/// a⁺ = 4/dt²·(u⁺ − u) − 4/dt·v − a,  v⁺ = v + dt/2·(a + a⁺).
///
/// K_eff is factored once per dt value (symbolic analysis once). The acceleration is part of the
/// method's state: it is computed from the equation of motion on the first step, and again
/// whenever the [`State`] given is not the one this integrator left (its time or step count
/// changed).
///
/// With a nonlinear [`InternalForce`], K·u⁺ becomes −f_int(u⁺) and the step equation in u⁺,
///
/// 4/dt²·M·(u⁺ − u − dt·v − dt²/4·a) + C·(2/dt·(u⁺ − u) − v) − f_int(u⁺) − f = 0,
///
/// is solved by Newton's method ([`super::StepNewtonOptions`]; C's stiffness part the tangent
/// at u), then a⁺ and v⁺ follow from the same two formulas. Undamped, the method then conserves
/// kinetic + the model's elastic energy − the loads' work to the Newton tolerance (the
/// trapezoidal rule on the force, exact for the quadratic energy only).
///
/// With contact (the barrier force f_c = −∂E_c/∂u), the contact force is taken at the step's
/// end alone, the rest of the step unchanged (Kane, Repetto, Ortiz & Marsden 1999):
///
/// M·(v⁺ − v)/dt = ½·(F(u) + F(u⁺)) + f_c(u⁺),  u⁺ − u = dt/2·(v + v⁺),
///
/// F every other force. The trapezoid on the stiff, convex barrier over a step that enters or
/// leaves it gained energy (a block dropped on the ground diverged at 0.5, 1 and 10× the
/// explicit critical step); at the end point the step changes kinetic + elastic + barrier
/// energy by E_c(u⁺) − E_c(u) − ∇E_c(u⁺)·(u⁺ − u) ≤ 0 (E_c convex along the step: exact for
/// half-spaces, whose gaps are affine in u; elastic part exact for the linear model). The step
/// equation is the one above with a replaced by a_el = a − M⁻¹·f_c(u), the acceleration of the
/// other forces, and the barrier weighted by 2 (the gradient of Φ with 2·E_c: the line search
/// and its collision-free first fraction unchanged); a⁺ = 4/dt²·(u⁺ − u) − 4/dt·v − a_el −
/// M⁻¹·f_c(u⁺) is again the acceleration of all the forces at u⁺, so the stored acceleration
/// (and a checkpoint's) means what a fresh start computes. Friction (lagged at the step's
/// start) stays on the trapezoid.
///
/// Body–body and self-contact ([`NonlinearForce::with_surface_contact`](super::NonlinearForce::with_surface_contact))
/// is a contact potential of the same kind, B(u) = κ·Σₖ mₖ·b(dₖ(u)), and takes the same end
/// point: f_c above is the obstacles' and the surface barrier's force together, E_c their
/// energies, each weighted by 2 in Φ and J. The step then changes kinetic + elastic + E_c by
/// E_c(u⁺) − E_c(u) − ∇E_c(u⁺)·(u⁺ − u) = −∫₀¹ s·Δuᵀ∇²E_c(u + s·Δu)·Δu ds (Δu = u⁺ − u),
/// ≤ 0 wherever E_c is convex along the step: b is convex and decreasing in d, and a pair's
/// distance is affine along a step that moves it without turning it (a face meeting a face
/// head on), so the barrier cannot add energy there; the distance's own curvature (a pair
/// turning, edges sliding past each other) is what could, by −b′·Δuᵀ∇²d·Δu, second order in
/// the step. Every Newton iterate keeps the collision-free line search of the implicit
/// methods. Measured on two rubber blocks meeting head on: `tests/core/surface_dynamics.rs`.
#[derive(Debug)]
pub struct Newmark {
    system: Arc<LinearSystem>,
    dt: f64,
    matrix: CscMatrix,
    solver: LinearSolver,
    factored_for: Option<f64>,
    guard: Option<DivergenceGuard>,
    acceleration: Vec<f64>,
    /// (steps, time) of the state the stored acceleration belongs to.
    acceleration_of: Option<(usize, f64)>,
    /// M·a of the linear step's start ([`Newmark::incoming_energy`]).
    mass_acceleration: Vec<f64>,
    work: Vec<f64>,
    product: Vec<f64>,
    /// Scratch of the block copy of K's products ([`Newmark::guard_energy`]).
    blocks_work: SymmetricWorkspace,
    rhs: Vec<f64>,
    /// f(t) of time-varying data (empty for constant data: see [`LinearSystem::load_buffer`]).
    load: Vec<f64>,
    /// The Newton solver of a nonlinear force (`None`: the linear path).
    newton: Option<NewtonSolver>,
    /// With contact: the acceleration of the step's non-contact forces,
    /// a_el = a − M⁻¹·f_c(u), the predictor's and the update's a (see [`Newmark`]).
    elastic_acceleration: Vec<f64>,
    /// With contact: M⁻¹·f_c(u) at the state a contact step left, and (steps, time) of that
    /// state — the next step's start reuses it rather than evaluate the contact and solve
    /// with M again.
    contact_acceleration: (Vec<f64>, Option<(usize, f64)>),
    /// With contact and a consistent mass: M's factor for M⁻¹·f_c, made once.
    mass_factor: MassFactor,
}

/// A consistent mass's Cholesky factor, kept (`None` until needed).
#[derive(Default)]
struct MassFactor(Option<SparseCholesky>);

impl std::fmt::Debug for MassFactor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(if self.0.is_some() {
            "MassFactor(factored)"
        } else {
            "MassFactor(none)"
        })
    }
}

impl MassFactor {
    /// b ← M⁻¹·b.
    fn solve(&mut self, mass: &Mass, b: &mut [f64]) -> Result<()> {
        match mass {
            Mass::Lumped(m) => {
                b.iter_mut().zip(m).for_each(|(a, m)| *a /= m);
                Ok(())
            }
            Mass::Consistent(m) => {
                if self.0.is_none() {
                    let mut cholesky = SparseCholesky::analyze(m)?;
                    cholesky.factorize(m)?;
                    self.0 = Some(cholesky);
                }
                match &mut self.0 {
                    Some(cholesky) => Ok(cholesky.solve_in_place(b)?),
                    None => Ok(()),
                }
            }
        }
    }
}

impl Newmark {
    /// An integrator with time step `dt` and default [`IntegratorOptions`].
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
        let blocks_work = system.stiffness_blocks().workspace();
        Ok(Newmark {
            load,
            system,
            dt,
            matrix,
            solver,
            factored_for: None,
            guard: None,
            acceleration: vec![0.0; n],
            acceleration_of: None,
            mass_acceleration: vec![0.0; n],
            work: vec![0.0; n],
            product: vec![0.0; n],
            blocks_work,
            rhs: vec![0.0; n],
            newton,
            elastic_acceleration: Vec::new(),
            contact_acceleration: (Vec::new(), None),
            mass_factor: MassFactor::default(),
        })
    }

    /// The energies of the state a linear step with stiffness damping reached, for the
    /// divergence guard (without it, [`incoming_energy`](Self::incoming_energy)): those of
    /// [`LinearSystem::energy_with`] (uᵀK·u from K's block copy, vᵀM·v from the mass's
    /// compact copy) on this integrator's scratch.
    fn guard_energy(&mut self, state: &State) -> Result<super::Energy> {
        self.system
            .energy_into(state, &mut self.product, &mut self.blocks_work)
    }

    /// The energies of the state a linear step starts from, for the divergence guard, without a
    /// product of their own: undamped or with mass damping alone (C = α·M) the state satisfies
    /// the equation of motion M·a + α·M·v + K·u = f (Newmark's a⁺ does by construction, the
    /// first step's a by its solve), so uᵀK·u = uᵀf − uᵀ(M·a) − α·uᵀ(M·v), with M·v and M·a
    /// taken in the right-hand side's read of M and f the
    /// step's load (constant data: f(t + dt) = f(t); with data that follow time the guard
    /// checks only that the energies are finite). The energies of [`energy_of`](Self::energy_of)
    /// up to rounding: ε·(|uᵀf| + |uᵀM·a|), far below the guard's bound (10× the start's energy
    /// plus the loads' work).
    fn incoming_energy(
        alpha: f64,
        state: &State,
        f: &[f64],
        (mass_velocity, mass_acceleration): (&[f64], &[f64]),
    ) -> super::Energy {
        let (u, v) = (&state.displacement, &state.velocity);
        let (mut twice_kinetic, mut twice_elastic, mut potential) = (0.0, 0.0, 0.0);
        for i in 0..u.len() {
            let (mv, ma) = (mass_velocity[i], mass_acceleration[i]);
            twice_kinetic += v[i] * mv;
            twice_elastic += u[i] * (f[i] - ma - alpha * mv);
            potential -= f[i] * u[i];
        }
        super::Energy::for_guard(twice_kinetic, twice_elastic, potential)
    }

    /// The energies of `state` under this integrator's force law.
    fn energy_of(&mut self, state: &State) -> Result<super::Energy> {
        match &mut self.newton {
            Some(newton) => newton.elastic_energy_of(&self.system, state),
            None => self.guard_energy(state),
        }
    }

    /// A step with the nonlinear force: a = M⁻¹·(f + f_int(u) − C·v) when needed, Newton on
    /// the step equation in u⁺, then the linear method's update of a and v.
    fn nonlinear_step(&mut self, state: &mut State) -> Result<()> {
        let n = self.system.free_count();
        state.check_len(n)?;
        if let Some(newton) = &self.newton {
            newton.force().set_time(&self.system, state.time)?;
            // Moving obstacles where they are at the step's start (a rejected step may have
            // left them staged part-way): f_c(u) below is taken there.
            if let Some(contact) = newton.force().contact().filter(|c| c.is_moving()) {
                contact.set_time(state.time);
            }
            newton
                .force()
                .begin_impact_step(&self.system, state, self.dt)?;
        }
        let Some(newton) = self.newton.as_ref() else {
            return Ok(());
        };
        if self.guard.is_none() {
            let finite_only = newton.force().does_work_off_the_potentials(&self.system);
            let start = self.energy_of(state)?;
            self.guard = Some(match finite_only {
                true => DivergenceGuard::finite_only(start),
                false => DivergenceGuard::new(start),
            });
        }
        let Some(newton) = self.newton.as_mut() else {
            return Ok(());
        };
        let dt = self.dt;
        if self.acceleration_of != Some((state.steps, state.time)) {
            let load = self
                .system
                .model_load_at(state.time, true, &mut self.load)?;
            newton.net_force(
                &self.system,
                (&state.displacement, &state.velocity),
                load,
                &mut self.acceleration,
            )?;
            solve_mass(self.system.mass(), &mut self.acceleration)?;
            self.acceleration_of = Some((state.steps, state.time));
        }
        // With contact the contact force is taken at the step's end alone (see [`Newmark`]):
        // the predictor and the update use the acceleration of the other forces.
        let end_point = newton.force().has_contact();
        if end_point {
            if self.contact_acceleration.1 != Some((state.steps, state.time)) {
                let mut contact = contact_force_and_energy(newton.force(), &state.displacement)?.0;
                self.mass_factor.solve(self.system.mass(), &mut contact)?;
                self.contact_acceleration = (contact, None);
            }
            let contact = &self.contact_acceleration.0;
            self.elastic_acceleration = (0..n).map(|i| self.acceleration[i] - contact[i]).collect();
        }
        let (u, v) = (&state.displacement, &state.velocity);
        let a = match end_point {
            true => &self.elastic_acceleration,
            false => &self.acceleration,
        };
        for i in 0..n {
            self.work[i] = u[i] + dt * v[i] + 0.25 * dt * dt * a[i];
        }
        // u⁺ = ũ + dt²/4·a⁺: with a⁺ ≈ a, the first guess.
        let guess: Vec<f64> = (0..n)
            .map(|i| self.work[i] + 0.25 * dt * dt * a[i])
            .collect();
        // The equation of motion at t + dt, with the load and the supports of that time.
        newton.force().set_time(&self.system, state.time + dt)?;
        let load = self
            .system
            .model_load_at(state.time + dt, true, &mut self.load)?;
        let equation = StepEquation {
            mass_scale: 4.0 / (dt * dt),
            damping_scale: 2.0 / dt,
            predictor: &self.work,
            start: u,
            damping_velocity: Some(v),
            duration: dt,
            first_iterate: Some(&guess),
            contact_weight: match end_point {
                true => 2.0,
                false => 1.0,
            },
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
        match end_point {
            true => self.advance_end_point(state)?,
            false => self.advance(state),
        }
        let energy = self.energy_of(state)?;
        match &self.guard {
            Some(guard) => guard.check(state, &energy),
            None => Ok(()),
        }
    }

    /// The update of a contact step, from a_el (`elastic_acceleration`):
    /// ã = 4/dt²·(u⁺ − u) − 4/dt·v − a_el (= a_el⁺ + 2·M⁻¹·f_c(u⁺)), v⁺ = v + dt/2·(a_el + ã),
    /// u ← u⁺, and the state's acceleration a⁺ = ã − M⁻¹·f_c(u⁺) (its forces at u⁺, the
    /// contact's once: what [`net_force`](NewtonSolver::net_force) gives on a fresh start).
    fn advance_end_point(&mut self, state: &mut State) -> Result<()> {
        std::mem::swap(&mut self.acceleration, &mut self.elastic_acceleration);
        self.advance(state);
        let Some(newton) = &self.newton else {
            return Ok(());
        };
        let mut contact = contact_force_and_energy(newton.force(), &state.displacement)?.0;
        self.mass_factor.solve(self.system.mass(), &mut contact)?;
        for (a, c) in self.acceleration.iter_mut().zip(&contact) {
            *a -= c;
        }
        self.contact_acceleration = (contact, Some((state.steps, state.time)));
        Ok(())
    }

    /// a⁺ = 4/dt²·(u⁺ − u) − 4/dt·v − a,  v⁺ = v + dt/2·(a + a⁺),  u ← u⁺ (u⁺ in `rhs`).
    fn advance(&mut self, state: &mut State) {
        let dt = self.dt;
        for i in 0..self.rhs.len() {
            let u_new = self.rhs[i];
            let a_new = 4.0 / (dt * dt) * (u_new - state.displacement[i])
                - 4.0 / dt * state.velocity[i]
                - self.acceleration[i];
            state.velocity[i] += 0.5 * dt * (self.acceleration[i] + a_new);
            state.displacement[i] = u_new;
            self.acceleration[i] = a_new;
        }
        state.time += dt;
        state.steps += 1;
        self.acceleration_of = Some((state.steps, state.time));
    }

    fn factor(&mut self) -> Result<()> {
        let (dt, damping) = (self.dt, self.system.damping());
        // K_eff = (1 + 2β/dt)·K + (4/dt² + 2α/dt)·M
        let (stiffness_scale, mass_scale) = (
            1.0 + 2.0 * damping.beta / dt,
            4.0 / (dt * dt) + 2.0 * damping.alpha / dt,
        );
        self.system
            .combine_into(stiffness_scale, mass_scale, &mut self.matrix)?;
        super::check_step_matrix(&self.matrix, dt, "(1 + 2β/dt)·K + (4/dt² + 2α/dt)·M")?;
        self.solver.factorize(&self.matrix)?;
        self.factored_for = Some(dt);
        Ok(())
    }

    /// a = M⁻¹·(f − K·u − C·v).
    fn initial_acceleration(&mut self, state: &State) -> Result<()> {
        let damping = self.system.damping();
        let n = self.system.free_count();
        for i in 0..n {
            self.work[i] = state.displacement[i] + damping.beta * state.velocity[i];
        }
        self.system
            .stiffness()
            .product_into(&self.work, &mut self.product);
        self.system
            .mass_product_into(&state.velocity, &mut self.work);
        let f = self.system.external_load_at(state.time, &mut self.load)?;
        for i in 0..n {
            self.acceleration[i] = f[i] - self.product[i] - damping.alpha * self.work[i];
        }
        match self.system.mass() {
            Mass::Lumped(m) => self
                .acceleration
                .iter_mut()
                .zip(m)
                .for_each(|(a, m)| *a /= m),
            Mass::Consistent(m) => {
                let mut cholesky = SparseCholesky::analyze(m)?;
                cholesky.factorize(m)?;
                cholesky.solve_in_place(&mut self.acceleration)?;
            }
        }
        self.acceleration_of = Some((state.steps, state.time));
        Ok(())
    }
}

impl Newmark {
    /// [`Integrator::step`] in this thread.
    fn step_here(&mut self, state: &mut State) -> Result<()> {
        if self.newton.is_some() {
            return self.nonlinear_step(state);
        }
        let n = self.system.free_count();
        state.check_len(n)?;
        if self.factored_for != Some(self.dt) {
            self.factor()?;
        }
        if self.acceleration_of != Some((state.steps, state.time)) {
            self.initial_acceleration(state)?;
        }
        if self.guard.is_none() {
            let start = self.guard_energy(state)?;
            self.guard = Some(
                self.system
                    .divergence_guard(start, (state.steps, state.time))?,
            );
        }
        let (dt, damping) = (self.dt, self.system.damping());
        let (u, v, a) = (&state.displacement, &state.velocity, &self.acceleration);
        // M·(4/dt²·u + 4/dt·v + a + α·(2/dt·u + v)) + β·K·(2/dt·u + v) + f
        for i in 0..n {
            self.work[i] = 4.0 / (dt * dt) * u[i]
                + 4.0 / dt * v[i]
                + a[i]
                + damping.alpha * (2.0 / dt * u[i] + v[i]);
        }
        let incoming_guard = damping.beta == 0.0;
        if incoming_guard {
            // M·v and M·a in the same read of M: the incoming state's energies (below).
            self.system.mass_product3_into(
                [&self.work, v, a],
                [
                    &mut self.rhs,
                    &mut self.product,
                    &mut self.mass_acceleration,
                ],
            );
        } else {
            self.system.mass_product_into(&self.work, &mut self.rhs);
            for i in 0..n {
                self.work[i] = 2.0 / dt * u[i] + v[i];
            }
            self.system
                .stiffness()
                .product_into(&self.work, &mut self.product);
            for i in 0..n {
                self.rhs[i] += damping.beta * self.product[i];
            }
        }
        // The equation of motion at t + dt, with the load and moving supports of that time.
        let f = self
            .system
            .external_load_at(state.time + dt, &mut self.load)?;
        for i in 0..n {
            self.rhs[i] += f[i];
        }
        if incoming_guard {
            let products = (self.product.as_slice(), self.mass_acceleration.as_slice());
            let energy = Self::incoming_energy(damping.alpha, state, f, products);
            if let Some(guard) = &self.guard {
                guard.check_energy(state.steps, state.time, &energy)?;
            }
        }
        self.solver.solve(&self.matrix, &mut self.rhs)?;
        self.advance(state);
        if incoming_guard {
            // The energy of this state is checked when the next step starts from it; its
            // values must be finite now (the divergence is named at the step that made it).
            return state.ensure_finite("");
        }
        let energy = self.guard_energy(state)?;
        match &self.guard {
            Some(guard) => guard.check(state, &energy),
            None => Ok(()),
        }
    }
}

impl Integrator for Newmark {
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
        Ok(())
    }

    fn factor_len(&self) -> Option<usize> {
        Some(self.solver.factor_len())
    }

    fn linear_solver(&self) -> Option<&LinearSolver> {
        Some(&self.solver)
    }

    fn name(&self) -> &'static str {
        "newmark"
    }

    fn linear_acceleration(&self, state: &State) -> Option<std::borrow::Cow<'_, [f64]>> {
        let left = self.acceleration_of == Some((state.steps, state.time));
        (self.newton.is_none() && left).then_some(std::borrow::Cow::Borrowed(&self.acceleration))
    }

    fn newton_stats(&self) -> Option<NewtonStats> {
        self.newton.as_ref().map(NewtonSolver::stats)
    }

    /// The guard, Newton's counts, and the acceleration when it belongs to the state the
    /// integrator left (after a step; before the first one it is computed from the equation
    /// of motion, as on a fresh start).
    fn history(&self) -> Result<IntegratorHistory> {
        Ok(IntegratorHistory {
            method: self.name().into(),
            guard: self.guard,
            acceleration: self
                .acceleration_of
                .is_some()
                .then(|| self.acceleration.clone()),
            previous_acceleration: None,
            newton: self.newton_stats(),
        })
    }

    fn restore(&mut self, state: &State, history: &IntegratorHistory) -> Result<()> {
        history.check(self.name(), self.system.free_count(), state)?;
        self.guard = history.guard;
        match &history.acceleration {
            Some(a) => {
                self.acceleration.copy_from_slice(a);
                self.acceleration_of = Some((state.steps, state.time));
            }
            None => self.acceleration_of = None,
        }
        if let (Some(newton), Some(stats)) = (self.newton.as_mut(), history.newton) {
            newton.set_stats(stats);
        }
        Ok(())
    }
}
