//! Backward Euler for hyperelastic rubber in the mixed displacement–pressure form, with either
//! law of [`MixedLaw`] (Neo-Hookean, or corotational) on either mixed element
//! ([`MixedElement`]): Taylor–Hood P2–P1 on 10-node tets
//! ([`taylor_hood_neo_hookean`](crate::fe::element::taylor_hood_neo_hookean),
//! [`taylor_hood_corotational`](crate::fe::element::taylor_hood_corotational)) or the
//! stabilized P1–P1 on 4-node tets
//! ([`stabilized_p1_neo_hookean`](crate::fe::element::stabilized_p1_neo_hookean),
//! [`stabilized_p1_corotational`](crate::fe::element::stabilized_p1_corotational)): large
//! deformation of nearly incompressible bodies in time, without volumetric locking. One
//! stepper over two laws: the law only chooses the element state ([`MixedLaw`], the seam the
//! static mixed Newton asks too) and, for the corotational law, the step length's test (below).
//!
//! Each step solves, for u⁺ on the free DOFs and the corner pressures p⁺,
//!
//! ```text
//!   R_u = M·(u⁺ − u − dt·v)/dt² + f_int(u⁺, p⁺) − f = 0,      R_p(u⁺, p⁺) = 0,
//! ```
//!
//! then v⁺ = (u⁺ − u)/dt, by Newton's method on the tangent [M/dt² + K_uu, −Gᵀ; −G, −C]
//! (C the element's pressure block: M_p/κ for Taylor–Hood, M_p/κ plus the projection
//! stabilization for P1–P1; the static mixed Newton's tangent with the inertia added: M/dt²
//! keeps its first block definite, so it is quasi-definite and the LDLᵀ needs no pivoting; its
//! symbolic analysis is done once) with a backtracking line search on the static solve's merit ‖(R_u, (μ/ℓ)·R_p)‖
//! (see [`mixed_nonlinear`](crate::analysis::mixed_nonlinear): the mixed energy is a saddle,
//! no merit). Constant loads and fixed supports; the consistent mass.
//!
//! The corotational law first tries, as its static Newton does, Deuflhard's restricted natural
//! monotonicity test: the first of α = 1, ½, ¼, ⅛ (times the contact cut below) whose
//! simplified correction −J⁻¹·R(x + α·δ), one more solve with the iteration's factor, is at
//! most (1 − α/4) times the correction δ in the norm ‖(δu, δp·ℓ/μ)‖; only when none passes
//! does the residual search decide. The reason is the static one: a rotating, nearly
//! incompressible body's Newton step leaves a volume residual of second order in the turn,
//! which the residual merit weights as a force and so cuts a good step.
//!
//! Rigid obstacles ([`with_contact`](MixedNonlinearEuler::with_contact)): the IPC barrier
//! E_c(u) of [`crate::contact`] is added to the step's potential in the displacement unknowns
//! only, so R_u gains ∂E_c/∂u and the first block of the tangent its Hessian projected PSD
//! (the displacement dynamics' own [`Contact::add_force`] and [`Contact::add_tangent`]); the
//! pressure block is unchanged, and the tangent stays quasi-definite (M/dt² + K_uu + H_c with
//! H_c ⪰ 0). Every iterate stays outside every obstacle: the predictor and each Newton step are
//! cut to [`first_step_fraction`] of the first time of impact ([`Contact::max_step`]) before the
//! line search halves them, so no accepted iterate crosses (the merit cannot tell a crossing
//! apart, the energy being a saddle). Coulomb friction
//! ([`Obstacle::friction`](crate::contact::Obstacle::friction)) is the displacement dynamics'
//! lagged smoothed friction: at each step's start the normal force and the tangent plane of
//! every node within d̂ of an obstacle with μ > 0 are frozen ([`Contact::friction_lag`],
//! smoothing distance ε_v·dt), and R_u gains the friction force's negative, the first block its
//! Hessian (PSD, so the tangent stays quasi-definite). Still obstacles: obstacle motion is
//! refused by name.

use crate::analysis::mixed_nonlinear::state_saddle_point;
use crate::analysis::mixed_nonlinear::{MixedLaw, correction_norm};
use crate::analysis::mixed_statics::nodal_pressure;
use crate::analysis::problem::Problem;
use crate::base::error::{Error, Result};
use crate::bc::constraints::{Constraints, DofMap};
use crate::bc::loads::Loads;
use crate::contact::{Contact, FrictionLag, first_step_fraction};
use crate::fe::element::stabilized_p1_corotational::stabilized_corotational_energy;
use crate::fe::element::taylor_hood::{PRESSURE_NODES, PressureNodes};
use crate::fe::element::taylor_hood_corotational::mixed_corotational_energy;
use crate::fe::element::tet10::Tet10Rest;
use crate::fe::element::{MixedElement, Tet, Tet4, Tet10};
use crate::fe::materials::TetMaterials;
use crate::linalg::QuasiDefiniteLdlt;
use crate::mesh::TetMesh;
use crate::model::rotation;
use crate::ordering::FillOrdering;
use crate::sparse::CscMatrix;

/// A Newton iterate: full displacement, corner pressures and the element states there.
type Iterate<E> = (Vec<f64>, Vec<f64>, Vec<<E as MixedElement>::State>);

/// Newton iterations per step before the step is declared not converged.
const MAX_ITERATIONS: usize = 30;

/// Halvings of the line search before a step is declared stalled.
const MAX_HALVINGS: usize = 30;

/// A hyperelastic mixed body (Neo-Hookean or corotational, [`MixedLaw`]) stepped by backward
/// Euler (see the [module](self) docs), on 10-node tets (Taylor–Hood, the default `E`) or
/// 4-node ones (stabilized P1–P1).
pub struct MixedNonlinearEuler<'a, E: MixedBody = Tet10> {
    law: MixedLaw,
    mesh: &'a TetMesh<E>,
    problem: Problem<'a, E>,
    rests: Vec<E::Rest>,
    /// μ and 1/κ per tet (Pa, 1/Pa).
    moduli: Vec<(f64, f64)>,
    pressure_nodes: PressureNodes,
    /// M_ff, consistent, on the pattern of the free stiffness (mass units).
    mass: CscMatrix,
    ldlt: Option<QuasiDefiniteLdlt>,
    dt: f64,
    tolerance: f64,
    /// μ/ℓ: the pressure residual's weight in the merit (Pa/length).
    pressure_weight: f64,
    /// The largest κ (Pa).
    largest_bulk: f64,
    /// 4ε·max|X|: the change of a coordinate below which no force changes (length).
    resolution: f64,
    load: Vec<f64>,
    /// Full displacement, free velocity, corner pressures.
    u: Vec<f64>,
    v: Vec<f64>,
    p: Vec<f64>,
    time: f64,
    iterations: usize,
    /// Rigid obstacles the boundary nodes meet (none by default).
    contact: Option<Contact>,
    /// The current step's lagged friction (with obstacles of μ > 0).
    friction: Option<FrictionLag>,
}

impl<E: MixedBody> std::fmt::Debug for MixedNonlinearEuler<'_, E> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MixedNonlinearEuler")
            .field("law", &self.law.name())
            .field("element", &E::MIXED_NAME)
            .field("dt", &self.dt)
            .field("time", &self.time)
            .field("iterations", &self.iterations)
            .finish()
    }
}

impl<'a, E: MixedBody> MixedNonlinearEuler<'a, E> {
    /// The Neo-Hookean body: [`Self::new_with_law`] with [`MixedLaw::NeoHookean`].
    ///
    /// Errors: those of [`Self::new_with_law`].
    pub fn new(
        mesh: &'a TetMesh<E>,
        materials: &impl TetMaterials,
        constraints: &Constraints,
        loads: &Loads,
        (dt, tolerance): (f64, f64),
    ) -> Result<Self> {
        Self::new_with_law(
            MixedLaw::NeoHookean,
            mesh,
            materials,
            constraints,
            loads,
            (dt, tolerance),
        )
    }

    /// The body of `law` on `mesh` (10-node tets: Taylor–Hood; 4-node tets: stabilized P1–P1)
    /// with `materials` (ν < 0.5), fixed `constraints` (prescribed values held from the
    /// start), constant `loads`, time step `dt` and Newton `tolerance` (relative to the step's
    /// first merit, in (0, 1)); at rest, the pressure 0.
    ///
    /// Errors: `dt` or `tolerance` out of range, `constraints`, `loads` or `materials` not made
    /// for this mesh (named); prescribed displacements that invert a tet (Neo-Hookean).
    pub fn new_with_law(
        law: MixedLaw,
        mesh: &'a TetMesh<E>,
        materials: &impl TetMaterials,
        constraints: &Constraints,
        loads: &Loads,
        (dt, tolerance): (f64, f64),
    ) -> Result<Self> {
        let dt = crate::analysis::dynamics::check_time_step(dt)?;
        if !(tolerance > 0.0 && tolerance < 1.0) {
            return Err(Error::invalid_parameter(
                "newton tolerance",
                tolerance,
                "must be in (0, 1)",
            ));
        }
        crate::analysis::problem::ensure_mesh_dofs(mesh, "constraints", constraints.dof_count())?;
        Error::check_len("loads", mesh.dof_count(), loads.as_slice().len())?;
        materials.check_tet_count(mesh)?;
        let problem = Problem::with_dofs(mesh, DofMap::new(constraints))?;
        let mass = problem.free_consistent_mass(materials)?;
        let rests: Vec<E::Rest> = (0..mesh.tet_count()).map(|t| E::rest(mesh, t)).collect();
        let moduli: Vec<(f64, f64)> = (0..mesh.tet_count())
            .map(|t| {
                let m = materials.material_of(t);
                (m.shear_modulus(), 1.0 / m.bulk_modulus())
            })
            .collect();
        let volume: f64 = rests.iter().map(E::volume).sum();
        let length = (volume / mesh.tet_count().max(1) as f64).cbrt();
        let shear = moduli.iter().map(|m| m.0).fold(0.0, f64::max);
        let moduli_bulk = moduli.iter().map(|m| 1.0 / m.1).fold(0.0, f64::max);
        let scale = mesh.nodes().iter().map(|x| x.amax()).fold(0.0, f64::max);
        let pressure_nodes = PressureNodes::new(mesh);
        let u = problem
            .dofs()
            .expand(&vec![0.0; problem.dofs().free_count()])?;
        let mut stepper = MixedNonlinearEuler {
            law,
            v: vec![0.0; problem.dofs().free_count()],
            p: vec![0.0; pressure_nodes.count()],
            mesh,
            problem,
            rests,
            moduli,
            pressure_nodes,
            mass,
            ldlt: None,
            dt,
            tolerance,
            pressure_weight: shear / length,
            largest_bulk: moduli_bulk,
            resolution: 4.0 * f64::EPSILON * scale,
            load: loads.as_slice().to_vec(),
            u,
            time: 0.0,
            iterations: 0,
            contact: None,
            friction: None,
        };
        let (u, p) = (stepper.u.clone(), stepper.p.clone());
        let Some(states) = stepper.states(&u, &p) else {
            return Err(Error::invalid_parameter(
                "constraints",
                "prescribed displacements",
                format!("invert a tet of the mixed {} body at the start", law.name()),
            ));
        };
        let tangent = stepper.tangent(&u, &states)?;
        let free = stepper.problem.dofs().free_count();
        stepper.ldlt = Some(QuasiDefiniteLdlt::analyze(
            &tangent,
            free,
            FillOrdering::NestedDissection,
        )?);
        Ok(stepper)
    }

    /// The element states at (`u`, `p`); `None` when a tet is inverted at a quadrature point.
    fn states(&self, u: &[f64], p: &[f64]) -> Option<Vec<E::State>> {
        // The element's node-major displacement (3·NODES ≤ 30 values).
        let mut buffer = [0.0; 30];
        self.mesh
            .tets()
            .iter()
            .enumerate()
            .map(|(t, tet)| {
                let u_e = element_displacement(tet.as_ref(), u, &mut buffer[..3 * E::NODES]);
                let corners = self.pressure_nodes.of_tet(tet.as_ref());
                let p_e: [f64; PRESSURE_NODES] = std::array::from_fn(|k| p[corners[k]]);
                self.law
                    .state::<E>(&self.rests[t], u_e, &p_e, self.moduli[t])
            })
            .collect()
    }

    /// R (free displacement DOFs, then pressures) of the step from (`u0`, `v0`) at `u`, with
    /// the element states.
    fn residual(&self, u: &[f64], states: &[E::State]) -> Result<Vec<f64>> {
        let mut internal: Vec<f64> = self.load.iter().map(|f| -f).collect();
        let mut pressure_residual = vec![0.0; self.pressure_nodes.count()];
        for (tet, state) in self.mesh.tets().iter().zip(states) {
            let force = E::state_force(state);
            for (k, &n) in tet.as_ref().iter().enumerate() {
                for a in 0..3 {
                    internal[3 * n + a] += force[3 * k + a];
                }
            }
            let corners = self.pressure_nodes.of_tet(tet.as_ref());
            for (&c, r) in corners.iter().zip(E::state_pressure_residual(state)) {
                pressure_residual[c] += r;
            }
        }
        if let Some(contact) = &self.contact {
            // R_u gains ∂E_c/∂u = −(the contact force).
            let mut push = vec![0.0; internal.len()];
            contact.add_force(u, &mut push)?;
            if let Some(lag) = &self.friction {
                contact.add_friction_force(lag, u, &mut push)?;
            }
            for (r, f) in internal.iter_mut().zip(&push) {
                *r -= f;
            }
        }
        let dofs = self.problem.dofs();
        let mut r = dofs.restrict(&internal)?;
        // Inertia: M·(u⁺ − u − dt·v)/dt².
        let free_u = dofs.restrict(u)?;
        let start = dofs.restrict(&self.u)?;
        let lag: Vec<f64> = (0..free_u.len())
            .map(|i| (free_u[i] - start[i] - self.dt * self.v[i]) / (self.dt * self.dt))
            .collect();
        for (r, m) in r.iter_mut().zip(self.mass.mul(&lag)?) {
            *r += m;
        }
        r.extend(pressure_residual);
        Ok(r)
    }

    /// The step's tangent [M/dt² + K_uu + H_c, −Gᵀ; −G, −C] at the full displacement `u`
    /// and its element states (H_c: the obstacles' barrier Hessian, projected PSD; C the
    /// element's pressure block).
    fn tangent(&self, u: &[f64], states: &[E::State]) -> Result<CscMatrix> {
        let mut stiffness = self.problem.zero_matrix()?;
        self.problem.assembler().reassemble_elements(
            self.mesh,
            |t| E::state_stiffness(&states[t]),
            &mut stiffness,
        )?;
        if let Some(contact) = &self.contact {
            contact.add_tangent(u, true, &mut stiffness)?;
            if let Some(lag) = &self.friction {
                contact.add_friction_tangent(lag, u, &mut stiffness)?;
            }
        }
        let mut free = self.problem.restrict(&stiffness)?;
        let c = 1.0 / (self.dt * self.dt);
        // M_ff is on the pattern of K_ff (both restricted from the assembly pattern).
        if free.col_ptr() != self.mass.col_ptr() || free.row_idx() != self.mass.row_idx() {
            return Err(Error::Solver(
                "mixed backward Euler step: mass and stiffness patterns differ".into(),
            ));
        }
        for (k, m) in free.values_mut().iter_mut().zip(self.mass.values()) {
            *k += c * m;
        }
        state_saddle_point(
            self.mesh,
            &free,
            (self.problem.dofs(), &self.pressure_nodes),
            states,
            (&self.rests, &self.moduli),
        )
    }

    /// ‖(R_u, (μ/ℓ)·R_p)‖ (force).
    fn merit(&self, r: &[f64]) -> f64 {
        let free = self.problem.dofs().free_count();
        let w = self.pressure_weight;
        r.iter()
            .enumerate()
            .map(|(i, x)| if i < free { x * x } else { (w * x).powi(2) })
            .sum::<f64>()
            .sqrt()
    }

    /// Advances one step of dt; returns the Newton iterations it took.
    pub fn step(&mut self) -> Result<usize> {
        let dofs = self.problem.dofs().clone();
        let free = dofs.free_count();
        // Friction lagged at the step's start (normal forces and tangent planes frozen).
        self.friction = match self.contact.as_ref().filter(|c| c.has_friction()) {
            Some(contact) => {
                Some(contact.friction_lag(&self.u, contact.slip_velocity() * self.dt)?)
            }
            None => None,
        };
        // Predictor: the step's start moved on by dt·v (the pressure kept).
        let mut u = self.u.clone();
        // With obstacles, the predictor stops short of the first impact along dt·v.
        let reach = match &self.contact {
            Some(contact) => first_step_fraction(contact.max_step(&self.u, &self.full(&self.v))?),
            None => 1.0,
        };
        for (k, &dof) in dofs.free_dofs().iter().enumerate() {
            u[dof] += reach * self.dt * self.v[k];
        }
        let mut p = self.p.clone();
        let mut states = match self.states(&u, &p) {
            Some(s) => s,
            None => {
                u.clone_from(&self.u);
                self.states(&u, &p)
                    .ok_or_else(|| Error::Solver("the accepted state has an inverted tet".into()))?
            }
        };
        let mut r = self.residual(&u, &states)?;
        let first = self.merit(&r);
        let target = self.tolerance * first.max(f64::MIN_POSITIVE);
        let mut merit = first;
        let mut iterations = 0;
        while merit > target {
            if iterations == MAX_ITERATIONS {
                return Err(self.not_converged(format!(
                    "{MAX_ITERATIONS} Newton iterations left the merit at {merit:.3e} (first \
                     {first:.3e})"
                )));
            }
            iterations += 1;
            let tangent = self.tangent(&u, &states)?;
            let Some(ldlt) = self.ldlt.as_mut() else {
                return Err(Error::Solver(
                    "the mixed step's tangent was not analysed".into(),
                ));
            };
            ldlt.factorize(&tangent)?;
            let mut delta: Vec<f64> = r.iter().map(|x| -x).collect();
            ldlt.solve_in_place(&mut delta)?;
            // A correction below the positions' and the pressures' resolution: the iterate
            // is as converged as round-off lets it be (the static mixed Newton's rule).
            let pressure_scale = p.iter().fold(self.largest_bulk, |m, p| m.max(p.abs()));
            if delta[..free].iter().all(|d| d.abs() <= self.resolution)
                && (delta[free..].iter()).all(|d| d.abs() <= 4.0 * f64::EPSILON * pressure_scale)
            {
                break;
            }
            // No trial crosses an obstacle: the step starts at 0.8 of the first impact.
            let mut alpha = match &self.contact {
                Some(contact) => first_step_fraction(contact.max_step(&u, &self.full(&delta))?),
                None => 1.0,
            };
            if self.law == MixedLaw::Corotational
                && let Some((trial_u, trial_p, trial_states)) =
                    self.natural_step((&u, &p), &delta, alpha)?
            {
                r = self.residual(&trial_u, &trial_states)?;
                merit = self.merit(&r);
                (u, p, states) = (trial_u, trial_p, trial_states);
                continue;
            }
            let mut accepted = false;
            for _ in 0..=MAX_HALVINGS {
                let mut trial_u = u.clone();
                for (k, &dof) in dofs.free_dofs().iter().enumerate() {
                    trial_u[dof] += alpha * delta[k];
                }
                let trial_p: Vec<f64> = (p.iter().zip(&delta[free..]))
                    .map(|(p, d)| p + alpha * d)
                    .collect();
                if let Some(trial_states) = self.states(&trial_u, &trial_p) {
                    let trial_r = self.residual(&trial_u, &trial_states)?;
                    let trial_merit = self.merit(&trial_r);
                    if trial_merit < merit {
                        (u, p, states, r, merit) =
                            (trial_u, trial_p, trial_states, trial_r, trial_merit);
                        accepted = true;
                        break;
                    }
                }
                alpha *= 0.5;
            }
            if !accepted {
                return Err(self.not_converged(format!(
                    "the line search found no decrease of the merit {merit:.3e} (first \
                     {first:.3e})"
                )));
            }
        }
        let start = dofs.restrict(&self.u)?;
        let end = dofs.restrict(&u)?;
        self.v = (0..free).map(|i| (end[i] - start[i]) / self.dt).collect();
        (self.u, self.p) = (u, p);
        self.time += self.dt;
        self.iterations += iterations;
        Ok(iterations)
    }

    /// The first of α = `start`·(1, ½, ¼, ⅛) that passes Deuflhard's restricted natural
    /// monotonicity test ‖δ̄(α)‖ ≤ (1 − α/4)·‖δ‖ at the iterate (`u`, `p`) with Newton
    /// correction `delta`, δ̄(α) = −J⁻¹·R((u, p) + α·δ) the simplified correction (one more
    /// solve with the iteration's factor), ‖·‖ [`Self::correction_norm`]; its trial point and
    /// states. `None`: the residual search decides. The static corotational Newton's test
    /// ([`crate::analysis::mixed_nonlinear`]), `start` < 1 only to stop short of an obstacle.
    fn natural_step(
        &mut self,
        (u, p): (&[f64], &[f64]),
        delta: &[f64],
        start: f64,
    ) -> Result<Option<Iterate<E>>> {
        let free = self.problem.dofs().free_count();
        let size = self.correction_norm(delta);
        let mut alpha = start;
        while alpha >= start * 0.125 {
            let mut trial_u = u.to_vec();
            for (k, &dof) in self.problem.dofs().free_dofs().iter().enumerate() {
                trial_u[dof] += alpha * delta[k];
            }
            let trial_p: Vec<f64> = (p.iter().zip(&delta[free..]))
                .map(|(p, d)| p + alpha * d)
                .collect();
            if let Some(states) = self.states(&trial_u, &trial_p) {
                let mut simplified: Vec<f64> = self
                    .residual(&trial_u, &states)?
                    .iter()
                    .map(|r| -r)
                    .collect();
                let Some(ldlt) = self.ldlt.as_mut() else {
                    return Ok(None);
                };
                ldlt.solve_in_place(&mut simplified)?;
                if self.correction_norm(&simplified) <= (1.0 - alpha / 4.0) * size {
                    return Ok(Some((trial_u, trial_p, states)));
                }
            }
            alpha *= 0.5;
        }
        Ok(None)
    }

    /// [`correction_norm`] of this body (the static mixed Newton's norm).
    fn correction_norm(&self, correction: &[f64]) -> f64 {
        let free = self.problem.dofs().free_count();
        correction_norm(correction, free, self.pressure_weight)
    }

    /// The full-length vector of the free entries `free[..free_count]` (0 on the constrained
    /// DOFs: a step or a velocity, not a displacement).
    fn full(&self, free: &[f64]) -> Vec<f64> {
        let mut full = vec![0.0; self.u.len()];
        for (&dof, x) in self.problem.dofs().free_dofs().iter().zip(free) {
            full[dof] = *x;
        }
        full
    }

    fn not_converged(&self, message: String) -> Error {
        Error::NotConverged {
            method: format!("Newton's method (mixed {} backward Euler)", self.law.name()),
            message: format!(
                "the step to t = {:e}: {message}; use a smaller dt",
                self.time + self.dt
            ),
        }
    }

    /// The body meeting the rigid obstacles of `contact` (built on this mesh; see the
    /// [module](self) docs), still, with or without friction.
    ///
    /// Errors, before any step: an obstacle with a motion (named); the body at its current
    /// state on or inside an obstacle ([`Contact::check_state`]).
    pub fn with_contact(mut self, contact: Contact) -> Result<Self> {
        if let Some(o) = contact
            .obstacles()
            .iter()
            .find(|o| o.motion().is_some() || o.spin().is_some())
        {
            return Err(Error::invalid_parameter(
                format!("obstacle {} motion", o.name()),
                "moving",
                format!(
                    "the mixed {} backward Euler takes still obstacles only",
                    self.law.name()
                ),
            ));
        }
        contact.check_state(&self.u)?;
        self.contact = Some(contact);
        Ok(self)
    }

    /// The body starting with the velocity `velocity` (length/time, every DOF: the entries of
    /// the constrained DOFs are ignored, they are held).
    ///
    /// Errors: `velocity` not of the mesh's DOF count or not finite (naming the DOF).
    pub fn with_velocity(mut self, velocity: &[f64]) -> Result<Self> {
        Error::check_len("velocity", self.u.len(), velocity.len())?;
        if let Some(dof) = velocity.iter().position(|v| !v.is_finite()) {
            return Err(Error::invalid_parameter(
                format!("velocity[{dof}]"),
                velocity[dof],
                "must be finite",
            ));
        }
        self.v = self.problem.dofs().restrict(velocity)?;
        Ok(self)
    }

    /// The obstacles the body meets, if any.
    pub fn contact(&self) -> Option<&Contact> {
        self.contact.as_ref()
    }

    /// The deformed volume ∫ det F dV (length³) at the current displacement
    /// ([`MixedBody::deformed_volume`]: exact on a 4-node tet, the degree-2 rule's estimate on
    /// a 10-node one).
    pub fn deformed_volume(&self) -> f64 {
        self.sum_over_tets(|_, rest, u_e, _| E::deformed_volume(rest, u_e))
    }

    /// The stored energy of the mixed body (energy units) at the current state:
    /// ∫ ψ − p·v − p²/(2κ) dV − ½·pᵀ·S·p (S the P1–P1 stabilization, 0 for Taylor–Hood; ψ, v
    /// the law's shear energy density and volume measure: μ/2·(Ī₁ − 3) and J − 1 for the
    /// Neo-Hookean law, μ‖dev ε‖² and tr ε for the corotational one), which at a converged
    /// state, where R_p = 0 gives ∫ p·v dV = −pᵀ·C·p (C = M_p/κ + S, the element's pressure
    /// block), is ∫ ψ dV + ½·pᵀ·C·p ([`MixedBody::shear_energy`] or
    /// [`MixedBody::corotated_shear_energy`], and [`MixedBody::pressure_energy`]). Not the
    /// pointwise κ/2·v², which counts the parts of v the pressure space does not see at the
    /// bulk modulus and overstates the energy.
    pub fn elastic_energy(&self) -> f64 {
        let shear = self.sum_over_tets(|t, rest, u_e, _| {
            let mu = self.moduli[t].0;
            match self.law {
                MixedLaw::NeoHookean => E::shear_energy(rest, u_e, mu),
                MixedLaw::Corotational => E::corotated_shear_energy(rest, u_e, mu),
            }
        });
        let volumetric = self.sum_over_tets(|t, rest, _, p_e| {
            let (mu, inverse_bulk) = self.moduli[t];
            E::pressure_energy(rest, p_e, mu, inverse_bulk)
        });
        shear + volumetric
    }

    /// Σ over tets t, in tet order, of `term(t, rest, u_e, p_e)` at the current state (u_e the
    /// tet's node-major displacement, p_e its corner pressures).
    fn sum_over_tets(
        &self,
        term: impl Fn(usize, &E::Rest, &[f64], &[f64; PRESSURE_NODES]) -> f64,
    ) -> f64 {
        let mut buffer = [0.0; 30];
        (self.mesh.tets().iter().zip(&self.rests))
            .enumerate()
            .map(|(t, (tet, rest))| {
                let u_e = element_displacement(tet.as_ref(), &self.u, &mut buffer[..3 * E::NODES]);
                let p_e = self.pressure_nodes.of_tet(tet.as_ref()).map(|c| self.p[c]);
                term(t, rest, u_e, &p_e)
            })
            .sum()
    }

    /// The kinetic energy ½·vᵀ·M·v of the free DOFs (energy units).
    pub fn kinetic_energy(&self) -> Result<f64> {
        let mv = self.mass.mul(&self.v)?;
        Ok(0.5 * self.v.iter().zip(&mv).map(|(a, b)| a * b).sum::<f64>())
    }

    /// Displacement of every DOF (length).
    pub fn displacement(&self) -> &[f64] {
        &self.u
    }

    /// Velocity of the free DOFs (length/time).
    pub fn velocity(&self) -> &[f64] {
        &self.v
    }

    /// The pressure at every node (Pa), linear along edges.
    pub fn pressure(&self) -> Vec<f64> {
        nodal_pressure::<E>(
            self.mesh.tets(),
            &self.pressure_nodes,
            self.mesh.node_count(),
            &self.p,
        )
    }

    /// Time reached.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Newton iterations in all.
    pub fn iterations(&self) -> usize {
        self.iterations
    }

    /// The hyperelastic law stepped.
    pub fn law(&self) -> MixedLaw {
        self.law
    }
}

/// The node-major displacement of the tet `nodes` out of the full `u`, written into `buffer`
/// (3 values per node).
fn element_displacement<'b>(nodes: &[usize], u: &[f64], buffer: &'b mut [f64]) -> &'b [f64] {
    for (k, value) in buffer.iter_mut().enumerate() {
        *value = u[3 * nodes[k / 3] + k % 3];
    }
    buffer
}

/// A mixed element whose state [`MixedNonlinearEuler`] reports: the deformed volume and the
/// stored energy of one tet (either law's), each summed over the tets in tet order.
pub trait MixedBody: MixedElement {
    /// ∫ det F dV over the tet (length³) at node-major displacement `u` (3·NODES values).
    fn deformed_volume(rest: &Self::Rest, u: &[f64]) -> f64;

    /// ∫ μ/2·(Ī₁ − 3) dV over the tet (energy units), Ī₁ = J^(−2/3)·tr(FᵀF), for shear modulus
    /// `shear_modulus` (Pa) at node-major displacement `u`.
    fn shear_energy(rest: &Self::Rest, u: &[f64], shear_modulus: f64) -> f64;

    /// ∫ μ‖dev ε‖² dV over the tet (energy units), ε = sym(RᵀF) − I with R the polar rotation
    /// of F ([`crate::model::rotation`]), for shear modulus `shear_modulus` (Pa) at node-major
    /// displacement `u`: the corotational mixed energy at p = 0, whose gradient in `u` is the
    /// force of [`MixedElement::corotational`] at p = 0 (the same quadrature).
    fn corotated_shear_energy(rest: &Self::Rest, u: &[f64], shear_modulus: f64) -> f64;

    /// ½·pᵀ·C·p (energy units): the element's pressure block C (length³/Pa,
    /// [`MixedElement::pressure_block`]) on the corner pressures `p` (Pa).
    fn pressure_energy(
        rest: &Self::Rest,
        p: &[f64; PRESSURE_NODES],
        shear_modulus: f64,
        inverse_bulk: f64,
    ) -> f64;
}

/// Taylor–Hood: the degree-2 rule (four points of weight V/4: det F is cubic on a 10-node tet,
/// so the volume is the rule's estimate, exact for an affine motion); C = M_p/κ in closed form,
/// V/20·(Σpᵢ² + (Σpᵢ)²)/κ.
impl MixedBody for Tet10 {
    fn deformed_volume(rest: &Tet10Rest, u: &[f64]) -> f64 {
        at_points(rest, u, |f| f.determinant())
    }

    fn shear_energy(rest: &Tet10Rest, u: &[f64], shear_modulus: f64) -> f64 {
        at_points(rest, u, |f| {
            let j = f.determinant();
            let i1 = j.powf(-2.0 / 3.0) * (f.transpose() * f).trace();
            0.5 * shear_modulus * (i1 - 3.0)
        })
    }

    /// [`mixed_corotational_energy`] at p = 0 (NaN for a `u` of other than 30 values).
    fn corotated_shear_energy(rest: &Tet10Rest, u: &[f64], shear_modulus: f64) -> f64 {
        let Ok(u) = u.try_into() else {
            return f64::NAN;
        };
        let moduli = (shear_modulus, 0.0);
        mixed_corotational_energy(rest, u, &[0.0; PRESSURE_NODES], moduli, rotation)
    }

    fn pressure_energy(
        rest: &Tet10Rest,
        p: &[f64; PRESSURE_NODES],
        _: f64,
        inverse_bulk: f64,
    ) -> f64 {
        let (sum, squares) = (p.iter().sum::<f64>(), p.iter().map(|x| x * x).sum::<f64>());
        rest.volume() / 20.0 * (squares + sum * sum) * 0.5 * inverse_bulk
    }
}

/// Σ over the degree-2 rule's four points of V/4·`density(F)` on a 10-node tet.
fn at_points(rest: &Tet10Rest, u: &[f64], density: impl Fn(&nalgebra::Matrix3<f64>) -> f64) -> f64 {
    rest.gradients()
        .iter()
        .map(|gradients| {
            let mut f = nalgebra::Matrix3::identity();
            for (i, g) in gradients.iter().enumerate() {
                f += nalgebra::Vector3::new(u[3 * i], u[3 * i + 1], u[3 * i + 2]) * g.transpose();
            }
            density(&f) * rest.volume() / 4.0
        })
        .sum::<f64>()
}

/// Stabilized P1–P1: F constant on the tet, so both integrals are V times the point value,
/// exact; C the element's whole pressure block (pressure mass over κ and stabilization).
impl MixedBody for Tet4 {
    fn deformed_volume(rest: &Tet, u: &[f64]) -> f64 {
        rest.volume() * linear_gradient(rest, u).determinant()
    }

    fn shear_energy(rest: &Tet, u: &[f64], shear_modulus: f64) -> f64 {
        let f = linear_gradient(rest, u);
        let j = f.determinant();
        let i1 = j.powf(-2.0 / 3.0) * (f.transpose() * f).trace();
        rest.volume() * 0.5 * shear_modulus * (i1 - 3.0)
    }

    /// [`stabilized_corotational_energy`] at p = 0.
    fn corotated_shear_energy(rest: &Tet, u: &[f64], shear_modulus: f64) -> f64 {
        let moduli = (shear_modulus, 0.0);
        stabilized_corotational_energy(rest, u, &[0.0; PRESSURE_NODES], moduli, rotation)
    }

    fn pressure_energy(
        rest: &Tet,
        p: &[f64; PRESSURE_NODES],
        shear_modulus: f64,
        inverse_bulk: f64,
    ) -> f64 {
        let mut sum = 0.0;
        for (k, pk) in p.iter().enumerate() {
            for (l, pl) in p.iter().enumerate() {
                sum += pk * Tet4::pressure_block(rest, shear_modulus, inverse_bulk, k, l) * pl;
            }
        }
        0.5 * sum
    }
}

/// F = I + Σᵢ uᵢ ⊗ ∇Nᵢ of a 4-node tet at node-major displacement `u` (12 values).
fn linear_gradient(rest: &Tet, u: &[f64]) -> nalgebra::Matrix3<f64> {
    let mut f = nalgebra::Matrix3::identity();
    for (i, g) in rest.shape_gradients().iter().enumerate() {
        f += nalgebra::Vector3::new(u[3 * i], u[3 * i + 1], u[3 * i + 2]) * g.transpose();
    }
    f
}
