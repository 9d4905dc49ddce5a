//! Nonlinear static equilibrium with a [`ForceModel`](crate::model::ForceModel): Newton's method with a backtracking line
//! search and load stepping, one symbolic factorization for all iterations.

mod continuation;
pub(crate) mod lumped;

use nalgebra::Vector3;

use crate::analysis::dynamics::internal_force::coordinate_scale;
use crate::analysis::newton::factor_exact_or_projected;
use crate::analysis::newton::iteration::{self, NewtonSystem, Stall};
use crate::analysis::newton::line_search::{Backtracking, LineFunction, NEAR_SOLUTION};
use crate::analysis::problem::Problem;
use crate::base::error::{Error, Result};
use crate::bc::amplitude::STATIC_TIME;
use crate::bc::boundary_motion::BoundaryMotion;
use crate::bc::constraints::{Constraints, DofMap, Restriction};
use crate::bc::loads::Loads;
use crate::contact::surface::SurfaceContact;
use crate::contact::{Contact, FrictionLag, MAX_MOTION_STAGES, MotionStage, STEP_FRACTION};
use crate::fe::assembly::Assembler;
use crate::linear_solver::{LinearMethod, LinearSolver, SolverOptions};
use crate::mesh::TetMesh;
use crate::model::assemble::{energy, internal_force, refill_tangent};
use crate::model::{ModelElement, TetModels};
use crate::sparse::CscMatrix;

/// Settings of [`solve_nonlinear_static`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewtonOptions {
    /// Load steps: the loads and prescribed displacements are applied in this many equal
    /// increments (default 10).
    pub load_steps: usize,
    /// Converged when ‖r_f‖ ≤ tolerance·‖f_f‖ (default 1e-10; ‖f_f‖ the full load).
    pub tolerance: f64,
    /// Newton iterations allowed per load step (default 30).
    pub max_iterations: usize,
    /// The linear solver for the Newton systems (always direct here: the tangent changes every
    /// iteration, and the symbolic analysis is reused).
    pub solver: SolverOptions,
}

impl Default for NewtonOptions {
    fn default() -> Self {
        NewtonOptions {
            load_steps: 10,
            tolerance: 1e-10,
            max_iterations: 30,
            solver: SolverOptions {
                method: LinearMethod::Direct,
                ..SolverOptions::default()
            },
        }
    }
}

impl NewtonOptions {
    /// [`Error::InvalidParameter`] unless there is at least one load step and the tolerance is
    /// finite and > 0.
    pub fn check(&self) -> Result<()> {
        if self.load_steps == 0 || !(self.tolerance > 0.0 && self.tolerance.is_finite()) {
            return Err(Error::invalid_parameter(
                "Newton options",
                format!(
                    "{} load steps, tolerance {}",
                    self.load_steps, self.tolerance
                ),
                "need at least one load step and a finite tolerance > 0",
            ));
        }
        Ok(())
    }
}

/// The result of a nonlinear static solve.
#[derive(Debug, Clone, PartialEq)]
pub struct NewtonReport {
    /// Displacement of every DOF (prescribed values included).
    pub displacement: Vec<f64>,
    /// Residual norms ‖r_f‖ of each Newton iteration (first entry: before the first update),
    /// one list per load step.
    pub residuals: Vec<Vec<f64>>,
    /// Newton iterations in total.
    pub iterations: usize,
    /// With contact: per obstacle (in their order) the friction force the body exerts on it,
    /// μ·λ·(f₁(y)/y)·P·(x − x⁰) summed over its nodes at the solution under the last load
    /// step's lag (N; zero without friction; empty without contact). Its sum with
    /// [`Contact::obstacle_forces`] is the whole force on the obstacle.
    pub obstacle_friction_forces: Vec<nalgebra::Vector3<f64>>,
    /// With contact: the barrier's scales the solution is in equilibrium under — the given
    /// contact's, or a smaller d̂ its continuation reached in the last load step (see
    /// [`solve_nonlinear_static_with_contact`]). Evaluate the solution's contact forces, gaps
    /// and pressures under these ([`Contact::with_parameters`]); `None` without contact.
    pub contact_parameters: Option<crate::contact::ContactParameters>,
    /// With contact: the gap error of the solution, Σλᵢdᵢ/Σλᵢ over the nodes the barrier
    /// pushes divided by the largest displacement (dimensionless; 0 when nothing touches) —
    /// by how much, relative to the motion, the barrier's gaps miss an exact contact's
    /// ([`Contact::complementarity`]). At most [`Contact::gap_tolerance`] unless the
    /// continuation ran out of stages or the contact has friction (whose solve keeps the
    /// given d̂).
    pub gap_error: Option<f64>,
    /// With contact: the smallest signed distance of any boundary node to any obstacle over
    /// every accepted Newton iterate of every load step and continuation stage (length;
    /// [`Contact::smallest_gap`]). Positive by the barrier's argument (a state with a node
    /// inside has infinite energy, and the line search accepts only a decrease from a finite
    /// start); this measures it. `None` without contact.
    pub smallest_iterate_gap: Option<f64>,
    /// With body–body and self-contact ([`solve_nonlinear_static_with_surface_contact`]): the
    /// smallest distance between two non-adjacent surface primitives over every accepted
    /// Newton iterate (m; [`SurfaceContact::smallest_distance`], +∞ when no pair came within
    /// d̂). Positive: every step is bounded by [`SurfaceContact::max_step`], and the line
    /// search accepts only a decrease of the potential from a finite start. `None` without
    /// surface contact.
    pub smallest_surface_distance: Option<f64>,
}

impl NewtonReport {
    /// `contact` (the one the solve was given) under the barrier the solution is in
    /// equilibrium under ([`contact_parameters`](Self::contact_parameters)): what to evaluate
    /// the solution's contact forces, gaps and pressures with. The given contact's own d̂ would
    /// read the gaps its continuation closed to ~1e-13 m as enormous forces. Without contact
    /// in the solve, `contact` as it is.
    pub fn solved_contact(&self, contact: &Contact) -> Result<Contact> {
        match self.contact_parameters {
            Some(parameters) => contact.with_parameters(parameters),
            None => Ok(contact.clone()),
        }
    }
}

/// Most friction passes (re-lags of the normal forces) per load step; more is
/// [`Error::Solver`] naming the load step.
const MAX_FRICTION_PASSES: usize = 30;

/// The error of a load step with friction whose Newton failed (`cause`), naming the load
/// step and what the lag (`lag`) lets friction carry. Three cases:
/// - no node within d̂ (`d_hat`, length) of a frictional obstacle at the lag, on a body without
///   constraints (`constrained` false): neither the barrier nor friction holds it at the step's
///   start, so it is free to move rigidly (the tangent is singular) — the message says so,
///   whatever the load's direction;
/// - the load along the obstacles' surfaces (the applied resultant, `free_load` on the free
///   DOFs `free_dofs` times `factor`, projected with the first lagged contact's tangent
///   projector) within μ·Σλ: friction is not the limit, and the message says that;
/// - a load along the surfaces above μ·Σλ: no frictional equilibrium exists (the body slides).
#[allow(clippy::too_many_arguments)]
fn no_frictional_equilibrium(
    cause: Error,
    (step, steps): (usize, usize),
    lag: &FrictionLag,
    free_load: &[f64],
    free_dofs: &[usize],
    factor: f64,
    constrained: bool,
    d_hat: f64,
) -> Error {
    let mut resultant = nalgebra::Vector3::zeros();
    for (&dof, f) in free_dofs.iter().zip(free_load) {
        resultant[dof % 3] += factor * f;
    }
    let (limit, [x, y, z]) = (
        lag.friction_limit(),
        [resultant.x, resultant.y, resultant.z],
    );
    if lag.is_empty() && !constrained {
        return Error::Solver(format!(
            "no static equilibrium at load step {step}/{steps}: {cause}. The body is \
             unconstrained: it has no constraints, and at this load step's start no node is \
             within the activation distance d̂ = {d_hat:.3e} of an obstacle, so neither the \
             barrier (along the obstacles' normals) nor friction (along their surfaces) holds \
             it: it is free to move as a rigid body under the load ({x:.4e}, {y:.4e}, {z:.4e}) \
             N. Constrain it ([[constraints]] on a face or a point) or start it within d̂ of \
             the obstacle it rests on"
        ));
    }
    let along = lag
        .points
        .first()
        .map_or(resultant.norm(), |p| (p.projector * resultant).norm());
    if along <= limit {
        return Error::Solver(format!(
            "no static equilibrium at load step {step}/{steps}: {cause}. Friction is not the \
             limit: the load along the obstacles' surfaces ({along:.4e} N of the applied \
             ({x:.4e}, {y:.4e}, {z:.4e}) N) is within what friction can carry (μ·Σλ = \
             {limit:.4e} N at this load step's lag); the body is free in a direction nothing \
             holds{}",
            match constrained {
                true => "",
                false =>
                    " (it has no constraints: friction and the obstacles' normals alone hold it)",
            }
        ));
    }
    Error::Solver(format!(
        "no static equilibrium with friction at load step {step}/{steps}: {cause}. Friction can \
         carry at most μ·Σλ = {limit:.4e} N along the obstacles (normal forces lagged at this \
         load step), against an applied load of ({x:.4e}, {y:.4e}, {z:.4e}) N ({along:.4e} N \
         along the surface): a load along the surface above μ·N has no equilibrium (the body \
         would slide away){}",
        match lag.is_empty() {
            true =>
                "; no node was within the activation distance d̂ of a frictional obstacle at \
                     the lag: a body that friction must hold should start within d̂ of it",
            false => "",
        }
    ))
}

/// Solves Σ fₑ(u) + f = 0 on the free DOFs for a nonlinear `model`.
///
/// Per load step λ = s/N: Newton iterations K_t·Δu = r with the exact tangent, or — where that
/// is not positive definite — with every element tangent projected onto the PSD cone (then K_t
/// is SPD with the constraints), and a backtracking line search that accepts
/// a step when the residual norm or the total potential Π = E − λ·fᵀu decreases. The symbolic
/// Cholesky analysis of the tangent's pattern is done once.
///
/// `model`: one force model for every tet, or a [`ModelMap`](crate::model::ModelMap) with one
/// model per material (each tet takes its material's). `mesh`: 4-node tets, or 10-node ones
/// (the models at their quadrature points, see [`ModelElement`]).
///
/// Errors: [`Error::NotConverged`] (method "Newton's method") when a load step does not reach
/// ‖r_f‖ ≤ tolerance·‖f_f‖ in `max_iterations` or its line search finds no decrease, naming
/// the load step and the residual reached; [`Error::Stopped`] when the caller's interrupt
/// test ([`crate::linalg::interrupt`]) says stop between two iterations.
pub fn solve_nonlinear_static<E: ModelElement>(
    mesh: &TetMesh<E>,
    model: &(impl TetModels + ?Sized),
    constraints: &Constraints,
    loads: &Loads,
    options: NewtonOptions,
) -> Result<NewtonReport> {
    solve(
        mesh,
        model,
        constraints,
        loads,
        &BoundaryMotion::new(),
        (None, None),
        options,
    )
}

/// [`solve_nonlinear_static`] with moving supports: at load step λ = s/N the DOFs of `motion`
/// take its values at [`STATIC_TIME`] with the amplitudes scaled by λ
/// ([`BoundaryMotion::evaluate_scaled`]) instead of λ times their final value, so a clamp under
/// a [`RigidMotion`](crate::bc::boundary_motion::RigidMotion) turns through exact rotations by λ·θ
/// (a chord λ·u would shrink the clamped section on the way: by cos(θ/2) halfway through a
/// rotation by θ). `constraints` must hold the motion's DOFs at their values at
/// [`STATIC_TIME`] (see [`BoundaryMotion::prescribe_at`]).
pub fn solve_nonlinear_static_with_motion<E: ModelElement>(
    mesh: &TetMesh<E>,
    model: &(impl TetModels + ?Sized),
    constraints: &Constraints,
    loads: &Loads,
    motion: &BoundaryMotion,
    options: NewtonOptions,
) -> Result<NewtonReport> {
    solve(
        mesh,
        model,
        constraints,
        loads,
        motion,
        (None, None),
        options,
    )
}

/// [`solve_nonlinear_static`] with contact against rigid obstacles (see [`crate::contact`]):
/// the barrier's force and Hessian join the model's, each line search starts at 0.8 of the
/// collision-free step ([`Contact::max_step`]) and accepts only a decrease of the potential
/// Π = E + E_c − λ·fᵀu (up to its round-off), so no iterate penetrates an obstacle.
///
/// The constraints need not hold every rigid mode (the obstacles may hold the body): a
/// direction held by neither makes the tangent singular, reported as
/// [`Error::NotPositiveDefinite`](crate::linalg::Error) from the factorization. The body must
/// start outside every obstacle; a contact that Newton cannot resolve in its budget is an
/// [`Error::NotConverged`] naming the load step, never a penetrated state.
///
/// Friction (obstacles with μ > 0), quasi-static as IPC does it: per load step the normal forces
/// λ and tangent planes are lagged and the step adds the potential μ·λ·f₀(|P·(x − x⁰)|) of each
/// contact node's slip from the load step's start x⁰, smoothed below the stick distance ε_d
/// ([`Contact::slip_distance`], default d̂/10: a sticking node creeps less than ε_d per load
/// step). The first pass lags λ at the step's start scaled by s/(s − 1) (proportional loads);
/// each further pass re-lags λ and the planes at the last solution, until it is in equilibrium
/// under its own lag (at most 30 passes; a failed pass is retried once with λ from where it
/// stopped). A load along the obstacles above μ·N has no equilibrium: the solve ends with an
/// [`Error::Solver`] naming the load step, μ·Σλ and the applied load, never with a slid-away
/// state. The report's [`obstacle_friction_forces`](NewtonReport::obstacle_friction_forces)
/// is the friction force on each obstacle. A body that friction must hold should start within
/// d̂ of its obstacle (the first load step's lag is the rest state's).
///
/// Moving obstacles ([`Obstacle::with_motion`](crate::contact::Obstacle::with_motion)) follow
/// their motion c(t) over the static step's pseudo-time t ∈ [0, 1] (dimensionless, as in
/// Abaqus's static step of time period 1; it is also the time an
/// [`Amplitude`](crate::bc::amplitude::Amplitude) is evaluated at): the solve starts with them at
/// c(0) ([`Contact::set_time`]`(0)`), and load step k of N places them at c(t_k), t_k = k/N,
/// together with the load factor λ_k = k/N — an
/// [`ObstacleMotion::Amplitude`](crate::contact::ObstacleMotion) with a ramp from 0 to 1
/// reaches its displacement at the last load step, a
/// [`Velocity`](crate::contact::ObstacleMotion::Velocity) v has moved by v·1 there. Within a
/// load step they are moved in stages as an implicit dynamic step moves them
/// ([`Contact::advance_stage`]): each stage as far as the body leaves free (×0.8), the body
/// solved there, so no Newton iterate has a node inside an obstacle; each move raises the
/// step's reference to its new residual and to the obstacles' force, and a Newton step below
/// 10⁻⁹·d̂ on every DOF ends the iterations. Friction's slip is then relative to the obstacle
/// (a node the obstacle carries along does not slip; [`Contact::friction_lag_moving`]). On
/// return the obstacles are at c(1), where the solution is in equilibrium with them (so
/// [`Contact::obstacle_forces`] and [`Contact::node_fields`] of the solution see them there).
/// A load step whose obstacles do not reach their placement in
/// [`MAX_MOTION_STAGES`] stages (a gap held in
/// equilibrium is a fraction of d̂, and each stage advances them by about that), or whose
/// obstacle touches a node a support holds in its path, is an [`Error::NotConverged`] naming
/// the load step, the obstacle and what to do (more load steps move them less per step).
///
/// Any element type: on 10-node tets the contact points are the boundary's corner and
/// mid-edge nodes ([`Contact::new`]).
pub fn solve_nonlinear_static_with_contact<E: ModelElement>(
    mesh: &TetMesh<E>,
    model: &(impl TetModels + ?Sized),
    constraints: &Constraints,
    loads: &Loads,
    contact: &Contact,
    options: NewtonOptions,
) -> Result<NewtonReport> {
    solve(
        mesh,
        model,
        constraints,
        loads,
        &BoundaryMotion::new(),
        (Some(contact), None),
        options,
    )
}

/// The static solve of every combination: [`solve_nonlinear_static_with_motion`]'s moving
/// supports (taken through the load steps) and, when `contact` is given,
/// [`solve_nonlinear_static_with_contact`]'s obstacles, together; their errors.
pub fn solve_nonlinear_static_with_motion_and_contact<E: ModelElement>(
    mesh: &TetMesh<E>,
    model: &(impl TetModels + ?Sized),
    constraints: &Constraints,
    loads: &Loads,
    motion: &BoundaryMotion,
    contact: Option<&Contact>,
    options: NewtonOptions,
) -> Result<NewtonReport> {
    solve(
        mesh,
        model,
        constraints,
        loads,
        motion,
        (contact, None),
        options,
    )
}

/// [`solve_nonlinear_static_with_motion_and_contact`] with body–body and self-contact of the
/// mesh's boundary surface (`surface`, [`crate::contact::surface::term`]): the surface
/// barrier's energy B(X + u) (J) joins the potential Π = E + E_c + B − λ·fᵀu, its force
/// −∂B/∂u (N) the residual, and its PSD-projected Hessian (N/m) the tangent. The pairs' entries
/// outside the stiffness pattern ([`SurfaceContact::add_tangent`]) are factored with it on the
/// pattern grown by their couplings (`lumped::CoupledFactor`, as the implicit dynamic step
/// does), so each Newton direction is the exact tangent's; where that tangent is not positive
/// definite they are lumped onto the diagonal: a PSD tangent that bounds the exact one from
/// above, whose factor preconditions CG on the exact Hessian (`lumped.rs`: 25 iterations over
/// 4 load steps of a block resting on another, where the lumped tangent alone stalled). Every
/// line search starts at most at
/// [`crate::contact::first_step_fraction`] of the collision-free step
/// ([`SurfaceContact::max_step`]) and accepts only a decrease of Π, so no iterate has two
/// surface triangles meeting ([`NewtonReport::smallest_surface_distance`] measures it).
///
/// The constraints need not hold every rigid mode of every body: the barrier may hold a body
/// against another, but only where its pairs are within d̂ already at the start of a load step
/// — a body held by nothing there makes the tangent singular,
/// [`Error::NotPositiveDefinite`](crate::linalg::Error) from the factorization.
///
/// Errors: those of [`solve_nonlinear_static_with_motion_and_contact`]; `surface` made for
/// another mesh ([`Error::DimensionMismatch`] naming the surface contact's node count); a
/// surface pair touching at the start (+∞ energy, [`Error::InvalidParameter`] from the
/// barrier).
#[allow(clippy::too_many_arguments)]
pub fn solve_nonlinear_static_with_surface_contact<E: ModelElement>(
    mesh: &TetMesh<E>,
    model: &(impl TetModels + ?Sized),
    constraints: &Constraints,
    loads: &Loads,
    motion: &BoundaryMotion,
    contact: Option<&Contact>,
    surface: &SurfaceContact,
    options: NewtonOptions,
) -> Result<NewtonReport> {
    Error::check_len(
        "surface contact nodes (3 DOFs each)",
        mesh.dof_count(),
        3 * surface.node_count(),
    )?;
    solve(
        mesh,
        model,
        constraints,
        loads,
        motion,
        (contact, Some(surface)),
        options,
    )
}

fn solve<E: ModelElement, M: TetModels + ?Sized>(
    mesh: &TetMesh<E>,
    model: &M,
    constraints: &Constraints,
    loads: &Loads,
    motion: &BoundaryMotion,
    (contact, surface): (Option<&Contact>, Option<&SurfaceContact>),
    options: NewtonOptions,
) -> Result<NewtonReport> {
    options.check()?;
    if constraints.dof_count() != mesh.dof_count() || loads.as_slice().len() != mesh.dof_count() {
        return Err(Error::invalid_parameter(
            "constraints/loads",
            "another mesh",
            "must be made for this mesh",
        ));
    }
    model.check_covers(mesh.tet_count())?;
    if let Some(surface) = surface {
        // The start's energy: +∞ (a pair touching) is refused here, before any factorization.
        surface.energy(&vec![0.0; mesh.dof_count()])?;
    }
    let problem = match contact {
        // The surface barrier, as the obstacles, may hold a body the constraints leave free.
        None if surface.is_some() => Problem::with_dofs(mesh, DofMap::new(constraints))?,
        None => Problem::new(mesh, constraints)?,
        Some(contact) => {
            // Moving obstacles start at their placement at the pseudo-time t = 0.
            if contact.is_moving() {
                contact.set_time(0.0);
            }
            contact.check_state(&vec![0.0; mesh.dof_count()])?;
            Problem::with_dofs(mesh, DofMap::new(constraints))?
        }
    };
    let dofs = problem.dofs();
    let tangent = problem.zero_matrix()?;
    let free_tangent = problem.zero_free_matrix()?;
    let geometry = dofs.geometry_for_method(options.solver.method, mesh)?;
    let solver = LinearSolver::analyze_with_geometry(&free_tangent, options.solver, geometry)?;
    let ladder = std::cell::OnceCell::new();
    let mut newton = StaticNewton {
        mesh,
        model,
        contact,
        surface,
        dofs,
        assembler: problem.assembler(),
        restriction: problem.restriction(),
        f_full: loads.as_slice(),
        options,
        tangent,
        free_tangent,
        solver,
        iterations: 0,
        ladder: &ladder,
        barrier: None,
        smallest_iterate_gap: f64::INFINITY,
        smallest_surface_distance: f64::INFINITY,
        coupled: lumped::CoupledFactor::default(),
    };
    let load_norm = norm(&dofs.restrict(loads.as_slice())?);
    let mut u = vec![0.0; mesh.dof_count()];
    let mut residuals = Vec::new();
    let mut final_lag = None;
    for step in 1..=options.load_steps {
        let factor = step as f64 / options.load_steps as f64;
        for (dof, value) in dofs.prescribed().iter().enumerate() {
            if dofs.free_index(dof).is_none() {
                u[dof] = factor * value;
            }
        }
        if !motion.is_empty() {
            let values = motion.evaluate_scaled(mesh.nodes(), STATIC_TIME, factor)?;
            for (dof, [value, _, _]) in motion.dofs().into_iter().zip(values) {
                u[dof] = value;
            }
        }
        let (history, lag) = newton.load_step(&mut u, step, load_norm)?;
        final_lag = lag;
        residuals.push(history);
    }
    if u.iter().any(|v| !v.is_finite()) {
        return Err(Error::NotConverged {
            method: "Newton's method".into(),
            message: "the solution is not finite".into(),
        });
    }
    let obstacle_friction_forces = match (contact, &final_lag) {
        (Some(contact), Some(lag)) => contact.obstacle_friction_forces(lag, &u)?,
        (Some(contact), None) => vec![nalgebra::Vector3::zeros(); contact.obstacles().len()],
        (None, _) => Vec::new(),
    };
    Ok(NewtonReport {
        displacement: u,
        residuals,
        iterations: newton.iterations,
        obstacle_friction_forces,
        contact_parameters: newton.barrier.map(|b| b.parameters),
        gap_error: newton.barrier.map(|b| b.gap_error),
        smallest_iterate_gap: contact.map(|_| newton.smallest_iterate_gap),
        smallest_surface_distance: surface.map(|_| newton.smallest_surface_distance),
    })
}

/// What the Newton iterations of one load step need to know about it: its number `step`
/// (1-based), its load factor λ = `factor` (= its pseudo-time t), and the reference ‖·‖ its
/// residual converges relative to (force).
#[derive(Debug, Clone, Copy)]
struct LoadStep {
    step: usize,
    factor: f64,
    reference: f64,
}

/// The moving obstacles of one load step: their offsets at its start (`from`) and at its
/// pseudo-time (`to`; length, one per obstacle).
struct StepMotion {
    from: Vec<Vector3<f64>>,
    to: Vec<Vector3<f64>>,
}

/// What a load step's passes and continuation stages share: the state it started from (the
/// origin of friction's slip), its obstacles' move, and friction's current lag.
struct StepState<'s> {
    start: &'s [f64],
    moving: &'s Option<StepMotion>,
    /// The load step's pseudo-time Δt = 1/n (a spinning obstacle turns by |ω|·Δt).
    duration: f64,
    lag: Option<FrictionLag>,
}

/// A static solve's parts that every load step uses: the mesh, model, loads and contact, the
/// DOF map and assembly, the tangent's storage and its factorization (one symbolic analysis),
/// and the Newton iterations taken so far.
struct StaticNewton<'a, E: ModelElement, M: TetModels + ?Sized> {
    mesh: &'a TetMesh<E>,
    model: &'a M,
    contact: Option<&'a Contact>,
    /// Body–body and self-contact of the boundary surface, if any.
    surface: Option<&'a SurfaceContact>,
    dofs: &'a DofMap,
    assembler: &'a Assembler,
    restriction: &'a Restriction,
    f_full: &'a [f64],
    options: NewtonOptions,
    tangent: CscMatrix,
    free_tangent: CscMatrix,
    solver: LinearSolver,
    iterations: usize,
    /// The contact under ever smaller d̂ ([`continuation`]): the stages a load step may take
    /// after it converged under the given contact, built when the first stage is taken.
    ladder: &'a std::cell::OnceCell<Vec<Contact>>,
    /// The barrier the last load step ended under, and its gap error.
    barrier: Option<continuation::BarrierEnd>,
    /// The smallest gap of any accepted iterate so far (length; ∞ without contact).
    smallest_iterate_gap: f64,
    /// The smallest surface distance of any accepted iterate so far (m; ∞ without surface
    /// contact or while no pair is within d̂).
    smallest_surface_distance: f64,
    /// The exact tangent with surface contact factored on the pairs' grown pattern
    /// ([`coupled_direction`](Self::coupled_direction)); its symbolic analysis is redone only
    /// when a pair couples two DOFs for the first time.
    coupled: lumped::CoupledFactor,
}

impl<E: ModelElement, M: TetModels + ?Sized> StaticNewton<'_, E, M> {
    /// The free residual r_f of Σ fₑ(u) + contact (+ friction under `lag`) + surface + λ·f at full
    /// displacement `u`, λ = `factor`.
    fn residual(&self, u: &[f64], lag: Option<&FrictionLag>, factor: f64) -> Result<Vec<f64>> {
        let mut fi = internal_force(self.mesh, self.model, u)?;
        if let Some(contact) = self.contact {
            contact.add_force(u, &mut fi)?;
            if let Some(lag) = lag {
                contact.add_friction_force(lag, u, &mut fi)?;
            }
        }
        if let Some(surface) = self.surface {
            surface.add_force(u, &mut fi)?;
        }
        self.dofs.restrict(
            &fi.iter()
                .zip(self.f_full)
                .map(|(a, b)| a + factor * b)
                .collect::<Vec<_>>(),
        )
    }

    /// The total potential Π = E + E_c (+ friction's under `lag`) + B − λ·fᵀu at `u` (energy;
    /// B the surface barrier's, when given).
    fn potential(&self, u: &[f64], lag: Option<&FrictionLag>, factor: f64) -> Result<f64> {
        let mut barrier = 0.0;
        if let Some(contact) = self.contact {
            barrier += contact.energy(u)?;
            if let Some(lag) = lag {
                barrier += contact.friction_energy(lag, u)?;
            }
        }
        if let Some(surface) = self.surface {
            barrier += surface.energy(u)?;
        }
        Ok(energy(self.mesh, self.model, u)? + barrier
            - factor * self.f_full.iter().zip(u).map(|(f, u)| f * u).sum::<f64>())
    }

    /// Load step `step` from the state `u` (its prescribed values set already): the obstacles
    /// moved to their placement at its pseudo-time, friction's passes (see
    /// [`solve_nonlinear_static_with_contact`]), each pass's Newton iterations, then the
    /// barrier's continuation ([`continuation`]). Returns the residual norms it saw and the
    /// friction lag it ended under.
    fn load_step(
        &mut self,
        u: &mut Vec<f64>,
        step: usize,
        load_norm: f64,
    ) -> Result<(Vec<f64>, Option<FrictionLag>)> {
        let factor = step as f64 / self.options.load_steps as f64;
        // Moving obstacles go from where the last load step left them to their placement at
        // this load step's pseudo-time t = λ.
        let moving = self.contact.filter(|c| c.is_moving()).map(|c| StepMotion {
            from: c.offsets(),
            to: c.offsets_at(factor),
        });
        // Friction (quasi-static, as IPC does it): the normal forces λ and tangent planes are
        // lagged, the slip measured from this load step's start (carried along by a moving
        // obstacle: the slip is relative to it). A pass solves with one lag; the next re-lags λ
        // and the planes at its solution (the slip origin stays), until the solution is in
        // equilibrium under the lag it makes. The first pass lags λ at the step's start scaled
        // by s/(s − 1): the loads grow in proportion, and so does the normal force they need
        // (λ of the step before would hold only (s − 1)/s of the load).
        let start = u.clone();
        // A spinning obstacle turns by |ω|·Δt over the load step's pseudo-time Δt = 1/n.
        let duration = 1.0 / self.options.load_steps as f64;
        let lag = match self.contact.filter(|c| c.has_friction()) {
            Some(c) => {
                let mut lag = match &moving {
                    Some(m) => c.friction_lag_toward(u, c.slip_distance(), &m.to, duration)?,
                    None => c.friction_lag(u, c.slip_distance())?,
                };
                if step > 1 {
                    lag.scale_limits(step as f64 / (step - 1) as f64);
                }
                Some(lag)
            }
            None => None,
        };
        let mut r = self.residual(u, lag.as_ref(), factor)?;
        // The reference scale: the full load, or for displacement-driven problems the first
        // residual of the step (moving obstacles raise it, see `solve_placed`).
        let mut at = LoadStep {
            step,
            factor,
            reference: if load_norm > 0.0 {
                load_norm
            } else {
                norm(&r).max(f64::MIN_POSITIVE)
            },
        };
        let mut history = vec![norm(&r)];
        let mut step_state = StepState {
            start: &start,
            moving: &moving,
            duration,
            lag,
        };
        self.settle(u, &mut r, &mut history, &mut step_state, &mut at)?;
        // The solution the solve returns is the last load step's; the ones before are its
        // path, solved under the given d̂ (the next load step's obstacles may move, which is
        // what that d̂ is sized for; from gaps a continuation closed to 1e-13 m, the given
        // barrier's first forces are ~1e11 N and swamp the step's reference).
        if step == self.options.load_steps {
            self.continue_barrier(u, &mut history, &mut step_state, &mut at)?;
        }
        Ok((history, step_state.lag))
    }

    /// Friction's lag of this load step's solution at `normal_at`, the slip measured from
    /// the step's start (relative to the obstacles' move over the step when they move).
    fn relag(contact: &Contact, normal_at: &[f64], state: &StepState<'_>) -> Result<FrictionLag> {
        match state.moving {
            Some(m) => contact.friction_lag_moving(
                normal_at,
                state.start,
                (&m.from, &m.to),
                contact.slip_distance(),
                state.duration,
            ),
            None => contact.friction_lag_from(normal_at, state.start, contact.slip_distance()),
        }
    }

    /// The load step solved from `u` (residual `r` under `state.lag`) with the obstacles
    /// placed or moved ([`solve_placed`](Self::solve_placed)), friction re-lagged at each
    /// pass's solution until the solution is in equilibrium under the lag it makes.
    fn settle(
        &mut self,
        u: &mut Vec<f64>,
        r: &mut Vec<f64>,
        history: &mut Vec<f64>,
        state: &mut StepState<'_>,
        at: &mut LoadStep,
    ) -> Result<()> {
        let (step, factor) = (at.step, at.factor);
        let friction = self.contact.filter(|c| c.has_friction());
        let mut retried = false;
        for pass in 1..=MAX_FRICTION_PASSES {
            let outcome = self.solve_placed(u, r, history, state.lag.as_ref(), at, state.moving);
            let (Some(contact), Some(solved_with)) = (friction, state.lag.as_ref()) else {
                return outcome;
            };
            if let Err(e) = outcome {
                // The caller's interrupt is no weak lag: stop.
                if matches!(e, Error::Stopped { .. }) {
                    return Err(e);
                }
                // Once, a lag too weak for this step's load (its normal forces from a state that
                // carried less) may be what failed: re-lag where the failed pass stopped, whose
                // normal forces carry this step's load, and solve again from the step's start
                // (moving obstacles back where they were then, to be moved again).
                if !retried && contact.check_state(u).is_ok() {
                    retried = true;
                    let relagged = Self::relag(contact, u, state)?;
                    *u = state.start.to_vec();
                    if let Some(m) = state.moving {
                        contact.set_offsets(m.from.clone())?;
                    }
                    *r = self.residual(u, Some(&relagged), factor)?;
                    state.lag = Some(relagged);
                    history.push(norm(r));
                    continue;
                }
                let error = no_frictional_equilibrium(
                    e,
                    (step, self.options.load_steps),
                    solved_with,
                    &self.dofs.restrict(self.f_full)?,
                    self.dofs.free_dofs(),
                    factor,
                    self.dofs.free_dofs().len() < self.f_full.len(),
                    contact.parameters().activation_distance,
                );
                return Err(match state.moving {
                    Some(m) => self.with_sliding_hint(error, contact, solved_with, m),
                    None => error,
                });
            }
            // Re-lag at this pass's solution: settled when the equilibrium holds under the new
            // lag to Newton's tolerance (or within twice the floor this pass reached).
            let floor = history.last().copied().unwrap_or(0.0);
            let relagged = Self::relag(contact, u, state)?;
            *r = self.residual(u, Some(&relagged), factor)?;
            state.lag = Some(relagged);
            let now = norm(r);
            history.push(now);
            if now <= self.options.tolerance * at.reference || now <= 2.0 * floor {
                return Ok(());
            }
            if pass == MAX_FRICTION_PASSES {
                return Err(Error::Solver(format!(
                    "friction's lagged normal forces did not settle in {MAX_FRICTION_PASSES} passes at load step {step}/{} (residual {now:.3e} of {:.3e} under the last lag)",
                    self.options.load_steps, at.reference
                )));
            }
        }
        Ok(())
    }

    /// `error` (a load step's failed friction solve) with, when a frictional obstacle moved
    /// along its surface by more than the stick distance ε_d in the load step (`motion`, at
    /// the lagged contacts of `lag`), why that may be the cause and what helps: its nodes start
    /// the step sliding relative to it, where friction's potential is linear in the slip (no
    /// stiffness along it), so a body held along the surface by that friction alone is free
    /// there and the tangent singular.
    fn with_sliding_hint(
        &self,
        error: Error,
        contact: &Contact,
        lag: &FrictionLag,
        motion: &StepMotion,
    ) -> Error {
        let (slide, obstacle) = lag
            .points
            .iter()
            .map(|p| {
                let o = p.obstacle;
                ((p.projector * (motion.to[o] - motion.from[o])).norm(), o)
            })
            .fold((0.0, 0), |a, b| if b.0 > a.0 { b } else { a });
        let epsilon = contact.slip_distance();
        let Error::Solver(message) = error else {
            return error;
        };
        if slide <= epsilon {
            return Error::Solver(message);
        }
        let n = self.options.load_steps;
        let needed = (n as f64 * slide / epsilon).ceil();
        Error::Solver(format!(
            "{message}. Obstacle {obstacle} ('{}') moved along its surface by {slide:.3e} in \
             this load step, more than friction's stick distance ε_d = {epsilon:.3e}: the nodes \
             it carries start the load step sliding on it, where friction has no stiffness along \
             the slip, so a body held along the surface by that friction alone is free there. \
             At least {needed} load steps (load_steps, now {n}) or a slip_distance above \
             {slide:.3e} let them start within ε_d",
            contact.obstacles()[obstacle].name()
        ))
    }

    /// One pass's solve of load step `at`: with fixed obstacles (`moving` `None`) Newton from
    /// `u`; with moving ones, the obstacles go from where they are to `moving.to` in stages
    /// ([`Contact::advance_stage`]), Newton solving the body at each, so every iterate stays
    /// outside them. After each move the residual `r` is taken anew and the step's reference
    /// raised to it and to the obstacles' force on the free DOFs (a displacement-driven step's
    /// first residual, before the move, is only the last step's round-off).
    ///
    /// Errors (naming the load step): an obstacle that touches a node it cannot push away, the
    /// obstacles still short of their placement after [`MAX_MOTION_STAGES`] stages; Newton's.
    fn solve_placed(
        &mut self,
        u: &mut Vec<f64>,
        r: &mut Vec<f64>,
        history: &mut Vec<f64>,
        lag: Option<&FrictionLag>,
        at: &mut LoadStep,
        moving: &Option<StepMotion>,
    ) -> Result<()> {
        let (Some(contact), Some(motion)) = (self.contact, moving) else {
            return self.newton(u, r, history, lag, *at);
        };
        if self.solve_carried(contact, u, r, history, lag, at, &motion.to)? {
            return Ok(());
        }
        for _ in 0..MAX_MOTION_STAGES {
            let stage = contact.advance_stage(u, &motion.to)?;
            if stage == MotionStage::Blocked {
                return Err(self.staging_error(contact, u, &motion.to, at, true));
            }
            *r = self.residual(u, lag, at.factor)?;
            let mut pushed = vec![0.0; u.len()];
            contact.add_force(u, &mut pushed)?;
            at.reference = at
                .reference
                .max(norm(r))
                .max(norm(&self.dofs.restrict(&pushed)?));
            history.push(norm(r));
            self.newton(u, r, history, lag, *at)?;
            if stage == MotionStage::Last {
                return Ok(());
            }
        }
        Err(self.staging_error(contact, u, &motion.to, at, false))
    }

    /// Load step `at` with the obstacles moved to `target` at once and the body carried with
    /// them ([`Contact::carried_start`]), Newton from there: `true` when it converged (`u` and
    /// `r` its solution); `false` when no carried start exists or Newton did not converge from
    /// it, with `u`, `r` and the obstacles as they were (the caller stages the move instead).
    #[allow(clippy::too_many_arguments)]
    fn solve_carried(
        &mut self,
        contact: &Contact,
        u: &mut Vec<f64>,
        r: &mut Vec<f64>,
        history: &mut Vec<f64>,
        lag: Option<&FrictionLag>,
        at: &mut LoadStep,
        target: &[Vector3<f64>],
    ) -> Result<bool> {
        let mut free = vec![false; u.len()];
        for &d in self.dofs.free_dofs() {
            free[d] = true;
        }
        let Some(start) = contact.carried_start(self.mesh.nodes(), u, target, &free)? else {
            return Ok(false);
        };
        let (before, offsets, reference) = (u.clone(), contact.offsets(), at.reference);
        contact.set_offsets(target.to_vec())?;
        let mut carried = start;
        let mut residual = self.residual(&carried, lag, at.factor)?;
        let mut pushed = vec![0.0; carried.len()];
        contact.add_force(&carried, &mut pushed)?;
        at.reference = reference
            .max(norm(&residual))
            .max(norm(&self.dofs.restrict(&pushed)?));
        let mut tried = history.clone();
        tried.push(norm(&residual));
        match self.newton(&mut carried, &mut residual, &mut tried, lag, *at) {
            Ok(()) => {
                (*u, *r, *history) = (carried, residual, tried);
                Ok(true)
            }
            Err(Error::NotConverged { .. } | Error::Solver(_)) => {
                contact.set_offsets(offsets)?;
                (*u, at.reference) = (before, reference);
                Ok(false)
            }
            Err(e) => Err(e),
        }
    }

    /// The error of load step `at` whose obstacles could not be moved to `target` for the body
    /// at `u`: `blocked` (a node touches one that cannot push it away) or out of stages. It
    /// names the obstacle that limits the move (the one whose own move alone is the shortest
    /// collision-free one) and what to do.
    fn staging_error(
        &self,
        contact: &Contact,
        u: &[f64],
        target: &[Vector3<f64>],
        at: &LoadStep,
        blocked: bool,
    ) -> Error {
        let offsets = contact.offsets();
        let limiting = (0..target.len())
            .filter(|&o| target[o] != offsets[o])
            .map(|o| {
                let mut alone = offsets.clone();
                alone[o] = target[o];
                (o, contact.motion_step_limit(u, &alone).unwrap_or(f64::NAN))
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map_or_else(String::new, |(o, _)| {
                format!(
                    " (obstacle {o}, '{}', limits it)",
                    contact.obstacles()[o].name()
                )
            });
        let n = self.options.load_steps;
        let (step, t) = (at.step, at.factor);
        Error::NotConverged {
            method: "static solve with moving obstacles".into(),
            message: match blocked {
                true => format!(
                    "at load step {step}/{n} (pseudo-time t = {t}) a moving obstacle touches a \
                     node it cannot push away{limiting}: a support holds the node in its path. \
                     More load steps do not help; move the obstacle's path or free the node"
                ),
                false => format!(
                    "at load step {step}/{n} the moving obstacles did not reach their placement \
                     at pseudo-time t = {t} in {MAX_MOTION_STAGES} stages{limiting}: each stage \
                     moves them {STEP_FRACTION} of the way the body leaves free and solves the \
                     body there, and a gap held in equilibrium is a fraction of the activation \
                     distance d̂ = {:.3e}. More load steps (load_steps, now {n}; a scene's \
                     analysis.load_steps) move them less per load step",
                    contact.parameters().activation_distance
                ),
            },
        }
    }

    /// Newton's iterations of load step `at` from `u` (residual `r` there), friction lagged by
    /// `lag`, until ‖r_f‖ ≤ tolerance·reference or the round-off floor: the one Newton
    /// loop ([`iteration::iterate`]) on this load step's equation ([`LoadStepSystem`]).
    /// Appends each residual norm to `history`.
    fn newton(
        &mut self,
        u: &mut Vec<f64>,
        r: &mut Vec<f64>,
        history: &mut Vec<f64>,
        lag: Option<&FrictionLag>,
        at: LoadStep,
    ) -> Result<()> {
        let (
            options,
            LoadStep {
                step, reference, ..
            },
        ) = (self.options, at);
        // A Newton step below the positions' resolution 4ε·max|X| changes no force (the test
        // that holds at zero load, where r is the forces' round-off and no step lowers it);
        // with moving obstacles one below 1e-9·d̂ changes nothing the barrier resolves.
        let resolution = 4.0 * f64::EPSILON * coordinate_scale(self.mesh.nodes());
        let smallest = self
            .contact
            .filter(|c| c.is_moving())
            .map_or(resolution, |c| {
                resolution.max(1e-9 * c.parameters().activation_distance)
            });
        let r_norm = norm(r);
        let mut system = LoadStepSystem {
            newton: self,
            u,
            r,
            history,
            lag,
            at,
            smallest,
            delta: Vec::new(),
            trial: None,
        };
        let limits = (options.tolerance, options.max_iterations);
        let stall = match iteration::iterate(&mut system, (r_norm, reference), limits)? {
            Ok(_) => return Ok(()),
            Err(stall) => stall,
        };
        let n = options.load_steps;
        Err(Error::NotConverged {
            method: "Newton's method".into(),
            message: match stall {
                Stall::OutOfIterations { residual, .. } => format!(
                    "no convergence in {} iterations at load step {step}/{n}: residual \
                     ‖r_f‖ = {residual:.3e}, {:.3e} of the reference {reference:.3e} \
                     (tolerance {:e}); more load steps or iterations may help",
                    options.max_iterations,
                    residual / reference,
                    options.tolerance
                ),
                Stall::NoDecrease { residual } => format!(
                    "the line search found no decrease at load step {step}/{n} (residual \
                     ‖r_f‖ = {residual:.3e}, {:.3e} of the reference {reference:.3e}; \
                     tolerance {:e})",
                    residual / reference,
                    options.tolerance
                ),
                Stall::NotFinite => {
                    format!("the residual is no longer finite at load step {step}/{n}")
                }
            },
        })
    }

    /// The Newton step Δu on the free DOFs at `u` (free residual `r`): K_t·Δu = r with the
    /// exact tangent first (quadratic convergence); if it is not positive definite, the one
    /// with every element tangent projected onto the PSD cone (a descent direction, at the
    /// price of linear convergence while it is needed). Friction's Hessian is PSD as it stands.
    fn direction(&mut self, u: &[f64], r: &[f64], lag: Option<&FrictionLag>) -> Result<Vec<f64>> {
        if self.surface.is_some()
            && self.solver.is_direct()
            && let Some(delta) = self.coupled_direction(u, r, lag)?
        {
            return Ok(delta);
        }
        let (mesh, assembler, model, contact, surface) = (
            self.mesh,
            self.assembler,
            self.model,
            self.contact,
            self.surface,
        );
        let (tangent, restriction) = (&mut self.tangent, self.restriction);
        factor_exact_or_projected(&mut self.solver, &mut self.free_tangent, |project, free| {
            refill_tangent(mesh, assembler, model, u, project, tangent)?;
            if let Some(contact) = contact {
                contact.add_tangent(u, project, tangent)?;
                if let Some(lag) = lag {
                    contact.add_friction_tangent(lag, u, tangent)?;
                }
            }
            if let Some(surface) = surface {
                surface.add_tangent(u, project, tangent)?;
            }
            restriction.restrict_into(tangent, free)
        })?;
        let mut delta = r.to_vec();
        let lumped = self
            .surface
            .map_or_else(Vec::new, |s| lumped::free_lumped_entries(s, self.dofs));
        if lumped.is_empty() {
            self.solver.solve(&self.free_tangent, &mut delta)?;
        } else {
            lumped::solve_with_lumped(&mut self.solver, &self.free_tangent, &lumped, &mut delta)?;
        }
        Ok(delta)
    }

    /// The Newton step with surface contact whose exact tangent J has pair entries off the
    /// stiffness pattern: J factored on the pattern grown by the pairs' couplings
    /// ([`lumped::CoupledFactor`]), so δ = J⁻¹·r exactly, as the implicit dynamic step takes it.
    /// `None` (the caller's exact-then-projected path, CG on the lumped factor) where nothing is
    /// lumped or J is not positive definite there.
    ///
    /// Why: CG on the lumped factor stops at 1e-12 of the preconditioned residual or at its
    /// iteration cap, an inexact direction that converges linearly in the bodies' common motion
    /// the contact couples (the dynamic 8-block stack stalled so, `validation/block_stack.md`);
    /// the factored exact J gives Newton's own direction in one solve.
    fn coupled_direction(
        &mut self,
        u: &[f64],
        r: &[f64],
        lag: Option<&FrictionLag>,
    ) -> Result<Option<Vec<f64>>> {
        let Some(surface) = self.surface else {
            return Ok(None);
        };
        refill_tangent(
            self.mesh,
            self.assembler,
            self.model,
            u,
            false,
            &mut self.tangent,
        )?;
        if let Some(contact) = self.contact {
            contact.add_tangent(u, false, &mut self.tangent)?;
            if let Some(lag) = lag {
                contact.add_friction_tangent(lag, u, &mut self.tangent)?;
            }
        }
        surface.add_tangent(u, false, &mut self.tangent)?;
        self.restriction
            .restrict_into(&self.tangent, &mut self.free_tangent)?;
        let lumped = lumped::free_lumped_entries(surface, self.dofs);
        if lumped.is_empty() || !self.coupled.factor(&self.free_tangent, &lumped)? {
            return Ok(None);
        }
        let mut delta = r.to_vec();
        self.coupled.solve(&mut delta)?;
        Ok(Some(delta))
    }

    /// The backtracking line search along the free step `delta` from `u` (residual `r`):
    /// from 1, or with contact from [`crate::contact::first_step_fraction`] of the collision-free step, halved up to
    /// 30 times until the residual norm or Π decreases — with contact only a decrease of Π (up
    /// to its round-off), so the barrier keeps the gaps open. It is every Newton's search
    /// ([`Backtracking`]) on this problem's line. Returns the accepted state and its free
    /// residual (`None`: no decrease found).
    fn line_search(
        &self,
        u: &[f64],
        delta: &[f64],
        r: &[f64],
        lag: Option<&FrictionLag>,
        at: LoadStep,
    ) -> Result<Option<(Vec<f64>, Vec<f64>)>> {
        let mut line = StaticLine {
            newton: self,
            u,
            delta,
            lag,
            factor: at.factor,
            start: None,
            trial: Vec::new(),
            r_trial: Vec::new(),
        };
        // Π at the start first, as before the search was shared (its errors come first).
        line.start_potential()?;
        let mut first_alpha = 1.0;
        if self.contact.is_some() || self.surface.is_some() {
            let mut step = vec![0.0; u.len()];
            for (&dof, d) in self.dofs.free_dofs().iter().zip(delta) {
                step[dof] = *d;
            }
            let mut limit = match self.contact {
                Some(contact) => contact.max_step(u, &step)?,
                None => 1.0,
            };
            // The surface's bound last: its broad phase is kept for the trials that follow.
            if let Some(surface) = self.surface {
                limit = limit.min(surface.max_step(u, &step)?);
            }
            first_alpha = crate::contact::first_step_fraction(limit);
        }
        // |r·δ|, the first-order change of Π along the step (the relaxed search's slack).
        let slope = r.iter().zip(delta).map(|(a, b)| a * b).sum::<f64>().abs();
        let search = Backtracking::for_contact(self.contact.is_some() || self.surface.is_some());
        let near_level = NEAR_SOLUTION * at.reference;
        let (accepted, _) = search.search(&mut line, first_alpha, (norm(r), near_level), slope)?;
        Ok(accepted.then_some((line.trial, line.r_trial)))
    }
}

/// A load step's equation at the iterate `u` (residual `r`) as the Newton loop drives it
/// ([`iteration::NewtonSystem`]): the exact-then-projected tangent's direction, the line search
/// of [`StaticNewton::line_search`], the iterate moved to the accepted trial and its residual
/// norm appended to `history`.
struct LoadStepSystem<'s, 'a, E: ModelElement, M: TetModels + ?Sized> {
    newton: &'s mut StaticNewton<'a, E, M>,
    u: &'s mut Vec<f64>,
    r: &'s mut Vec<f64>,
    history: &'s mut Vec<f64>,
    lag: Option<&'s FrictionLag>,
    at: LoadStep,
    /// The smallest Newton step that changes a force (length).
    smallest: f64,
    /// The free Newton step δ of the iteration.
    delta: Vec<f64>,
    /// The accepted trial state (full) and its free residual.
    trial: Option<(Vec<f64>, Vec<f64>)>,
}

impl<E: ModelElement, M: TetModels + ?Sized> NewtonSystem for LoadStepSystem<'_, '_, E, M> {
    fn direction(&mut self, _first: bool) -> Result<()> {
        self.delta = self.newton.direction(self.u, self.r, self.lag)?;
        Ok(())
    }

    fn step_is_unresolved(&self) -> bool {
        self.delta.iter().all(|d| d.abs() <= self.smallest)
    }

    fn search(&mut self, _r_norm: f64, _reference: f64) -> Result<(bool, f64)> {
        self.trial = self
            .newton
            .line_search(self.u, &self.delta, self.r, self.lag, self.at)?;
        Ok((self.trial.is_some(), 1.0))
    }

    fn accept(&mut self, _alpha: f64) -> f64 {
        if let Some((trial, r_trial)) = self.trial.take() {
            *self.u = trial;
            *self.r = r_trial;
        }
        if let Some(contact) = self.newton.contact {
            // Measured, not needed by the solve: a length mismatch cannot occur here (the
            // contact was checked against this mesh) and would only leave the record as it was.
            let gap = contact.smallest_gap(self.u).unwrap_or(f64::INFINITY);
            self.newton.smallest_iterate_gap = self.newton.smallest_iterate_gap.min(gap);
        }
        if let Some(surface) = self.newton.surface {
            // Measured as the gap above; an error (none can occur on an accepted finite-energy
            // iterate) would only leave the record as it was.
            let d = surface.smallest_distance(self.u).unwrap_or(f64::INFINITY);
            self.newton.smallest_surface_distance = self.newton.smallest_surface_distance.min(d);
            surface.note_accepted_iterate(self.u);
        }
        self.newton.iterations += 1;
        let now = norm(self.r);
        self.history.push(now);
        now
    }

    fn describe(&self, iteration: usize) -> String {
        format!(
            "Newton iteration {iteration} of load step {}/{}",
            self.at.step, self.newton.options.load_steps
        )
    }
}

/// A static Newton step's line u + α·δ (free step δ scattered onto the full displacement)
/// for [`Backtracking`]: the free residual and Π at its trial points.
struct StaticLine<'s, 'a, E: ModelElement, M: TetModels + ?Sized> {
    newton: &'s StaticNewton<'a, E, M>,
    u: &'s [f64],
    delta: &'s [f64],
    lag: Option<&'s FrictionLag>,
    /// The load factor λ of the load step.
    factor: f64,
    /// Π at `u`, once computed.
    start: Option<f64>,
    /// The last trial state (full) and its free residual.
    trial: Vec<f64>,
    r_trial: Vec<f64>,
}

impl<E: ModelElement, M: TetModels + ?Sized> LineFunction for StaticLine<'_, '_, E, M> {
    fn trial(&mut self, alpha: f64) -> Result<f64> {
        let mut trial = self.u.to_vec();
        for (&dof, d) in self.newton.dofs.free_dofs().iter().zip(self.delta) {
            trial[dof] += alpha * d;
        }
        self.r_trial = self.newton.residual(&trial, self.lag, self.factor)?;
        self.trial = trial;
        Ok(norm(&self.r_trial))
    }

    fn start_potential(&mut self) -> Result<f64> {
        if let Some(pi) = self.start {
            return Ok(pi);
        }
        let pi = self.newton.potential(self.u, self.lag, self.factor)?;
        self.start = Some(pi);
        Ok(pi)
    }

    fn trial_potential(&mut self) -> Result<f64> {
        self.newton.potential(&self.trial, self.lag, self.factor)
    }
}

/// The support reactions of a nonlinear static solution: Rᵢ = −(Σₑ fₑ(u) + f)ᵢ on every
/// constrained DOF i, zero on the free ones (full length, force units). The element forces
/// fₑ are those the model exerts on the nodes (−K·u for the linear model, so R = K·u − f as in
/// [`StaticSolution::reactions`](crate::analysis::statics::StaticSolution::reactions)). R is what the
/// supports exert on the body: Σ R + Σ f equals, per axis, the sum of the free residual
/// components (at most √n_f·‖r_f‖, what Newton left), as Σₑ fₑ sums to zero exactly up to
/// round-off (each element's forces balance).
///
/// Errors: `u`, `constraints` or `loads` not made for `mesh`, or `model` not one per tet.
pub fn nonlinear_reactions<E: ModelElement>(
    mesh: &TetMesh<E>,
    model: &(impl TetModels + ?Sized),
    constraints: &Constraints,
    loads: &Loads,
    u: &[f64],
) -> Result<Vec<f64>> {
    if constraints.dof_count() != mesh.dof_count() || loads.as_slice().len() != mesh.dof_count() {
        return Err(Error::invalid_parameter(
            "constraints/loads",
            "another mesh",
            "must be made for this mesh",
        ));
    }
    let force = internal_force(mesh, model, u)?;
    Ok(force
        .iter()
        .zip(loads.as_slice())
        .enumerate()
        .map(|(dof, (fi, f))| match constraints.get(dof) {
            Some(_) => -(fi + f),
            None => 0.0,
        })
        .collect())
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}
