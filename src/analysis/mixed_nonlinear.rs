//! Static equilibrium of nearly incompressible bodies at large deformation in the mixed
//! displacement–pressure form, on either mixed element ([`MixedElement`]) and with either
//! hyperelastic law ([`MixedLaw`]): Neo-Hookean rubber on Taylor–Hood P2–P1 10-node tets
//! ([`taylor_hood_neo_hookean`](crate::fe::element::taylor_hood_neo_hookean)) or the
//! stabilized P1–P1 on 4-node tets
//! ([`stabilized_p1_neo_hookean`](crate::fe::element::stabilized_p1_neo_hookean), whose −C
//! block also holds the projection stabilization where M_p/κ stands below), or corotational
//! elasticity on the same two
//! ([`taylor_hood_corotational`](crate::fe::element::taylor_hood_corotational),
//! [`stabilized_p1_corotational`](crate::fe::element::stabilized_p1_corotational)): no
//! volumetric locking as Poisson's ratio approaches 0.5. The two laws differ only in the
//! element state Newton asks for; the loop, the merit and the factorization are one.
//!
//! On the free displacement DOFs and the corner pressures, per load step λ = s/N (loads and
//! prescribed displacements scaled by λ, as [`solve_nonlinear_static`](crate::analysis::nonlinear::solve_nonlinear_static)
//! does), Newton's iterations solve
//!
//! ```text
//!   ⎡ K_uu   −Gᵀ   ⎤ ⎡δu⎤     ⎡ R_u = f_int(u, p) − λ·f ⎤
//!   ⎣ −G   −M_p/κ  ⎦ ⎣δp⎦ = − ⎣ R_p(u, p)               ⎦
//! ```
//!
//! with the one Newton loop of tetfem and its backtracking line search. The merit is the
//! residual norm ‖(R_u, (μ/ℓ)·R_p)‖, not the energy: the mixed energy is a saddle (a maximum
//! in p), so its decrease is no test of progress. The weight μ/ℓ (ℓ the cube root of the mean
//! tet volume, μ the largest shear modulus) is that of the saddle's natural norm: the Schur
//! complement B·K⁻¹·Bᵀ + M_p/κ that maps R_p (a volume) to a pressure scales as V/μ, and K as
//! μ·ℓ, so R_p·μ/ℓ is a force comparable with R_u. (κ/ℓ, the weight of the pressure's own
//! block, would make the merit of a nearly incompressible body its J − 1 alone: measured on
//! Cook's membrane, the line search then cut every Newton step to below 1 % and stalled.) Converged when that norm is ≤ `tolerance` times the full load's
//! norm (or, with no load, the step's first residual).
//!
//! The tangent is symmetric; it is quasi-definite (K_uu positive definite on the free DOFs,
//! −M_p/κ negative definite) near the rest state, so the LDLᵀ without pivoting of the linear
//! mixed solve ([`QuasiDefiniteLdlt`]) factors it, its symbolic analysis done once. At large
//! compressive pressure (−p·∂cof F/∂F in K_uu, −p·dR for the corotational law) or near a buckling load K_uu can stop being
//! positive definite: the factorization then fails and the solve returns its error (the row
//! and pivot), naming the load step — more load steps do not help a true instability, but they
//! do help a step that overshoots into it.

use nalgebra::Vector3;

use crate::analysis::mixed_statics::{nodal_pressure, saddle_point_matrix};
use crate::analysis::newton::iteration::{self, NewtonSystem, Stall};
use crate::analysis::newton::line_search::{Backtracking, LineFunction, NEAR_SOLUTION};
use crate::analysis::nonlinear::NewtonOptions;
use crate::analysis::problem::Problem;
use crate::base::error::{Error, Result};
use crate::bc::constraints::{Constraints, DofMap};
use crate::bc::loads::Loads;
use crate::fe::element::MixedElement;
use crate::fe::element::taylor_hood::{PRESSURE_NODES, PressureNodes};
use crate::fe::materials::TetMaterials;
use crate::linalg::QuasiDefiniteLdlt;
use crate::mesh::TetMesh;
use crate::model::ModelKind;
use crate::ordering::FillOrdering;
use crate::sparse::CscMatrix;

/// The hyperelastic law of the mixed Newton: which state of the [`MixedElement`] it asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum MixedLaw {
    /// Simo–Taylor's Neo-Hookean W = μ/2·(Ī₁ − 3) − p·(J − 1) − p²/(2κ)
    /// ([`MixedElement::neo_hookean`]).
    #[default]
    NeoHookean,
    /// Corotated linear W = μ‖dev ε‖² − p·tr ε − p²/(2κ), ε = sym(RᵀF) − I, R the polar
    /// rotation of F from [`crate::model::rotation`] ([`MixedElement::corotational`]).
    Corotational,
}

impl MixedLaw {
    /// The law of the force model `model`; `None` for a model without a mixed law (the linear
    /// one is solved in one saddle solve, St. Venant–Kirchhoff has none).
    pub fn of(model: ModelKind) -> Option<Self> {
        match model {
            ModelKind::NeoHookean => Some(MixedLaw::NeoHookean),
            ModelKind::Corotational => Some(MixedLaw::Corotational),
            ModelKind::Linear | ModelKind::StVenantKirchhoff => None,
        }
    }

    /// The law's name in messages (`"Neo-Hookean"`, `"corotational"`).
    pub fn name(self) -> &'static str {
        match self {
            MixedLaw::NeoHookean => "Neo-Hookean",
            MixedLaw::Corotational => "corotational",
        }
    }

    /// The element state of `E` at `u` (length), corner pressures `p` (Pa) and (μ, 1/κ)
    /// `moduli` (Pa, 1/Pa); `None` where the law has no state (an inverted Neo-Hookean tet,
    /// a non-finite F). The one seam of both mixed Newtons: the static one and the backward
    /// Euler ([`crate::analysis::mixed_nonlinear_dynamics`]).
    pub(crate) fn state<E: MixedElement>(
        self,
        rest: &E::Rest,
        u: &[f64],
        p: &[f64; PRESSURE_NODES],
        moduli: (f64, f64),
    ) -> Option<E::State> {
        match self {
            MixedLaw::NeoHookean => E::neo_hookean(rest, u, p, moduli.0, moduli.1),
            MixedLaw::Corotational => E::corotational(rest, u, p, moduli, crate::model::rotation),
        }
    }
}

/// The result of [`solve_static_mixed_nonlinear`].
#[derive(Debug, Clone, PartialEq)]
pub struct MixedNewtonReport {
    /// Displacement of every DOF (length), prescribed values included.
    pub displacement: Vec<f64>,
    /// Pressure p = −tr σ/3 at every node (Pa, positive in compression): the solved value at
    /// tet corners, the mean of its edge's corners at an edge node, 0 at nodes of no tet.
    pub pressure: Vec<f64>,
    /// The merit ‖(R_u, (μ/ℓ)·R_p)‖ (force) of each Newton iterate (first entry: before the
    /// first update), one list per load step.
    pub residuals: Vec<Vec<f64>>,
    /// Newton iterations in total.
    pub iterations: usize,
    /// The last load step's final merit over its reference (the full load's norm, or with no
    /// load its first residual): at most the tolerance, or the round-off floor.
    pub relative_residual: f64,
    /// Reaction forces f_int(u, p) − f: non-zero only on constrained DOFs (force units).
    pub reactions: Vec<f64>,
}

/// Solves the static equilibrium of the mixed Neo-Hookean model (see the [module](self) docs)
/// on the 10-node `mesh` with `materials` (μ and κ of each; ν < 0.5), `constraints` (holding
/// every rigid motion) and `loads`, in `options.load_steps` equal load steps:
/// [`solve_static_mixed_nonlinear_with`] and [`MixedLaw::NeoHookean`].
///
/// Errors: those of [`solve_static_mixed_nonlinear_with`].
pub fn solve_static_mixed_nonlinear<E: MixedElement>(
    mesh: &TetMesh<E>,
    materials: &impl TetMaterials,
    constraints: &Constraints,
    loads: &Loads,
    options: NewtonOptions,
) -> Result<MixedNewtonReport> {
    solve_static_mixed_nonlinear_with(
        MixedLaw::NeoHookean,
        mesh,
        materials,
        constraints,
        loads,
        options,
    )
}

/// Solves the static equilibrium of the mixed form of `law` (see the [module](self) docs) on
/// `mesh` (10-node tets: Taylor–Hood; 4-node: stabilized P1–P1) with `materials` (μ and κ of
/// each; ν < 0.5), `constraints` (holding every rigid motion) and `loads`, in
/// `options.load_steps` equal load steps.
///
/// Errors: [`Error::InvalidParameter`] for options, constraints or loads not made for this
/// mesh, or from the LDLᵀ when the tangent is not quasi-definite (a support that does not hold
/// a rigid motion, an instability); [`Error::NotConverged`] naming the load step and residual
/// when Newton's iterations stall or a tet inverts at every fraction of the step;
/// [`Error::Stopped`] on the caller's interrupt.
pub fn solve_static_mixed_nonlinear_with<E: MixedElement>(
    law: MixedLaw,
    mesh: &TetMesh<E>,
    materials: &impl TetMaterials,
    constraints: &Constraints,
    loads: &Loads,
    options: NewtonOptions,
) -> Result<MixedNewtonReport> {
    options.check()?;
    crate::analysis::problem::ensure_mesh_dofs(mesh, "constraints", constraints.dof_count())?;
    Error::check_len("loads", mesh.dof_count(), loads.as_slice().len())?;
    // Before any allocation, the estimate of the linear mixed solve (its saddle point and LDLᵀ
    // are what each Newton step rebuilds).
    crate::analysis::mixed_statics::ensure_mixed_fits(mesh, "the mixed Newton solve", None)?;
    materials.check_tet_count(mesh)?;
    let mut system = MixedSystem::new(law, mesh, materials, constraints)?;
    let dofs = system.problem.dofs();
    let load_norm = norm(&dofs.restrict(loads.as_slice())?);
    let mut residuals = Vec::new();
    let mut relative_residual = 0.0;
    for step in 1..=options.load_steps {
        let factor = step as f64 / options.load_steps as f64;
        let dofs = system.problem.dofs();
        for (dof, value) in dofs.prescribed().iter().enumerate() {
            if dofs.free_index(dof).is_none() {
                system.u[dof] = factor * value;
            }
        }
        system.load = loads.as_slice().iter().map(|f| factor * f).collect();
        system.step = step;
        let (u, p) = (system.u.clone(), system.p.clone());
        let r_norm = match system.evaluate(&u, &p, false)? {
            Some((residual, _)) => {
                system.residual = residual;
                system.merit(&system.residual)
            }
            None => {
                return Err(Error::NotConverged {
                    method: "Newton's method (mixed)".into(),
                    message: format!(
                        "the prescribed displacements of load step {step}/{} invert a tet; \
                         use more load steps",
                        options.load_steps
                    ),
                });
            }
        };
        let reference = if load_norm > 0.0 {
            load_norm
        } else {
            r_norm.max(f64::MIN_POSITIVE)
        };
        system.history = vec![r_norm];
        let limits = (options.tolerance, options.max_iterations);
        let stall = iteration::iterate(&mut system, (r_norm, reference), limits)?.err();
        if let Some(stall) = stall {
            let reached = match stall {
                Stall::OutOfIterations { residual, .. } | Stall::NoDecrease { residual } => {
                    format!("{residual:.3e}")
                }
                Stall::NotFinite => "not finite".into(),
            };
            return Err(Error::NotConverged {
                method: "Newton's method (mixed)".into(),
                message: format!(
                    "load step {step}/{} stalled ({stall:?}) at residual {reached}, reference \
                     {reference:.3e}; use more load steps",
                    options.load_steps
                ),
            });
        }
        relative_residual = system.history.last().copied().unwrap_or(0.0) / reference;
        residuals.push(std::mem::take(&mut system.history));
    }
    let dofs = system.problem.dofs();
    let reactions = system
        .unbalanced(&system.u, &system.p)?
        .map(|(forces, _)| {
            forces
                .iter()
                .enumerate()
                .map(|(dof, r)| match dofs.free_index(dof) {
                    Some(_) => 0.0,
                    None => *r,
                })
                .collect()
        })
        .unwrap_or_default();
    Ok(MixedNewtonReport {
        relative_residual,
        reactions,
        pressure: nodal_pressure::<E>(
            mesh.tets(),
            &system.pressure_nodes,
            mesh.node_count(),
            &system.p,
        ),
        displacement: system.u,
        residuals,
        iterations: system.iterations,
    })
}

/// f_int(u, p) − λ·f on every DOF, R_p per pressure unknown, and the element states.
type Unbalanced<E> = (Vec<f64>, Vec<f64>, Vec<<E as MixedElement>::State>);

/// The mixed problem at its current iterate, as the Newton loop drives it.
struct MixedSystem<'a, E: MixedElement> {
    law: MixedLaw,
    mesh: &'a TetMesh<E>,
    problem: Problem<'a, E>,
    rests: Vec<E::Rest>,
    /// μ and 1/κ of each tet (Pa, 1/Pa).
    moduli: Vec<(f64, f64)>,
    pressure_nodes: PressureNodes,
    /// The LDLᵀ of the tangent's pattern (analysed once, in [`MixedSystem::new`]).
    ldlt: Option<QuasiDefiniteLdlt>,
    /// μ/ℓ (Pa/length): the pressure residual's weight in the merit.
    pressure_weight: f64,
    /// The largest κ (Pa).
    largest_bulk: f64,
    /// The change of a coordinate below which no force changes (length).
    resolution: f64,
    u: Vec<f64>,
    p: Vec<f64>,
    load: Vec<f64>,
    /// R at the iterate: free displacement DOFs, then pressures.
    residual: Vec<f64>,
    delta: Vec<f64>,
    trial: Option<(Vec<f64>, Vec<f64>, Vec<f64>)>,
    history: Vec<f64>,
    iterations: usize,
    step: usize,
}

impl<'a, E: MixedElement> MixedSystem<'a, E> {
    fn new(
        law: MixedLaw,
        mesh: &'a TetMesh<E>,
        materials: &impl TetMaterials,
        constraints: &Constraints,
    ) -> Result<Self> {
        let problem = Problem::new(mesh, constraints)?;
        let rests: Vec<E::Rest> = (0..mesh.tet_count()).map(|t| E::rest(mesh, t)).collect();
        let moduli: Vec<(f64, f64)> = (0..mesh.tet_count())
            .map(|t| {
                let m = materials.material_of(t);
                (m.shear_modulus(), 1.0 / m.bulk_modulus())
            })
            .collect();
        let pressure_nodes = PressureNodes::new(mesh);
        let volume: f64 = rests.iter().map(E::volume).sum();
        let length = (volume / mesh.tet_count().max(1) as f64).cbrt();
        let bulk = materials
            .material_list()
            .iter()
            .map(|m| m.bulk_modulus())
            .fold(0.0, f64::max);
        let shear = materials
            .material_list()
            .iter()
            .map(|m| m.shear_modulus())
            .fold(0.0, f64::max);
        let scale = mesh
            .nodes()
            .iter()
            .map(|x: &Vector3<f64>| x.amax())
            .fold(0.0, f64::max);
        let u = vec![0.0; mesh.dof_count()];
        let p = vec![0.0; pressure_nodes.count()];
        let mut system = MixedSystem {
            law,
            mesh,
            problem,
            rests,
            moduli,
            pressure_nodes,
            ldlt: None,
            pressure_weight: shear / length,
            largest_bulk: bulk,
            resolution: 4.0 * f64::EPSILON * scale,
            load: vec![0.0; u.len()],
            u,
            p,
            residual: Vec::new(),
            delta: Vec::new(),
            trial: None,
            history: Vec::new(),
            iterations: 0,
            step: 0,
        };
        let (u, p) = (system.u.clone(), system.p.clone());
        let tangent = match system.evaluate(&u, &p, true)? {
            Some((_, Some(tangent))) => tangent,
            // The rest state has J = 1 at every point and its tangent is formed.
            _ => return Err(Error::Solver("no tangent at the rest state".into())),
        };
        let free = system.problem.dofs().free_count();
        system.ldlt = Some(QuasiDefiniteLdlt::analyze(
            &tangent,
            free,
            FillOrdering::NestedDissection,
        )?);
        Ok(system)
    }

    /// R (free displacement DOFs, then pressures) and, when `tangent`, the saddle matrix at
    /// (`u`, `p`); `None` when a tet is inverted at a quadrature point.
    fn evaluate(
        &self,
        u: &[f64],
        p: &[f64],
        tangent: bool,
    ) -> Result<Option<(Vec<f64>, Option<crate::sparse::CscMatrix>)>> {
        let Some((internal, pressure_residual, states)) = self.unbalanced_states(u, p) else {
            return Ok(None);
        };
        let mut residual = self.problem.dofs().restrict(&internal)?;
        residual.extend(pressure_residual);
        if !tangent {
            return Ok(Some((residual, None)));
        }
        let mut stiffness = self.problem.zero_matrix()?;
        self.problem.assembler().reassemble_elements(
            self.mesh,
            |t| E::state_stiffness(&states[t]),
            &mut stiffness,
        )?;
        let free_stiffness = self.problem.restrict(&stiffness)?;
        let matrix = state_saddle_point(
            self.mesh,
            &free_stiffness,
            (self.problem.dofs(), &self.pressure_nodes),
            &states,
            (&self.rests, &self.moduli),
        )?;
        Ok(Some((residual, Some(matrix))))
    }

    /// f_int(u, p) − λ·f on every DOF and R_p, with the element states; `None` when a tet
    /// is inverted at a quadrature point.
    fn unbalanced_states(&self, u: &[f64], p: &[f64]) -> Option<Unbalanced<E>> {
        let mut states: Vec<E::State> = Vec::with_capacity(self.mesh.tet_count());
        // The element's node-major displacement (3·NODES ≤ 30 values).
        let mut buffer = [0.0; 30];
        for (t, tet) in self.mesh.tets().iter().enumerate() {
            let tet = tet.as_ref();
            let u_e = &mut buffer[..3 * E::NODES];
            for (k, value) in u_e.iter_mut().enumerate() {
                *value = u[3 * tet[k / 3] + k % 3];
            }
            let corners = self.pressure_nodes.of_tet(tet);
            let p_e: [f64; PRESSURE_NODES] = std::array::from_fn(|k| p[corners[k]]);
            states.push(
                self.law
                    .state::<E>(&self.rests[t], u_e, &p_e, self.moduli[t])?,
            );
        }
        let mut internal: Vec<f64> = self.load.iter().map(|f| -f).collect();
        let mut pressure_residual = vec![0.0; self.pressure_nodes.count()];
        for (tet, state) in self.mesh.tets().iter().zip(&states) {
            let force = E::state_force(state);
            for (k, &n) in tet.as_ref().iter().enumerate() {
                for a in 0..3 {
                    internal[3 * n + a] += force[3 * k + a];
                }
            }
            for (&c, r) in self
                .pressure_nodes
                .of_tet(tet.as_ref())
                .iter()
                .zip(E::state_pressure_residual(state))
            {
                pressure_residual[c] += r;
            }
        }
        Some((internal, pressure_residual, states))
    }

    /// f_int(u, p) − λ·f on every DOF and R_p (see [`Self::unbalanced_states`]).
    fn unbalanced(&self, u: &[f64], p: &[f64]) -> Result<Option<(Vec<f64>, Vec<f64>)>> {
        Ok(self.unbalanced_states(u, p).map(|(f, r, _)| (f, r)))
    }

    /// ‖(R_u, (μ/ℓ)·R_p)‖ (force).
    fn merit(&self, residual: &[f64]) -> f64 {
        let free = self.problem.dofs().free_count();
        let (r_u, r_p) = residual.split_at(free);
        let w = self.pressure_weight;
        (r_u.iter().map(|r| r * r).sum::<f64>() + r_p.iter().map(|r| (w * r).powi(2)).sum::<f64>())
            .sqrt()
    }

    /// The first of α = 1, ½, ¼, ⅛ that passes Deuflhard's restricted natural monotonicity
    /// test ‖δ̄(α)‖ ≤ (1 − α/4)·‖δ‖, δ̄(α) = −J⁻¹·R((u, p) + α·δ) the simplified Newton
    /// correction (one more solve with the iterate's factor), ‖·‖ the norm of
    /// [`Self::correction_norm`]; its trial point is kept. `None`: the residual search decides.
    ///
    /// Why not the residual alone: the Newton step of a rotating, nearly incompressible body
    /// leaves a volume residual of second order in the rotation (tr ε of a linearised turn θ is
    /// θ²), which the merit weights as a force: measured on a slender cantilever (L/H = 20) at
    /// ν = 0.4999, the residual search stalled in the first of 10 load steps (tip turn 4°; 30
    /// iterations, the merit still 96 % of the step's start) with either law, and with this
    /// test the corotational one converged. The correction's size, affine invariant, sees
    /// that step as the quadratically convergent one it is (Deuflhard, *Newton Methods for Nonlinear Problems*,
    /// 2004, §3.3).
    fn natural_step(&mut self) -> Result<Option<f64>> {
        let size = self.correction_norm(&self.delta);
        let mut alpha = 1.0;
        while alpha >= 0.125 {
            let (u, p) = self.stepped(alpha);
            if let Some((residual, _)) = self.evaluate(&u, &p, false)? {
                let mut simplified: Vec<f64> = residual.iter().map(|r| -r).collect();
                let Some(ldlt) = self.ldlt.as_mut() else {
                    return Ok(None);
                };
                ldlt.solve_in_place(&mut simplified)?;
                if self.correction_norm(&simplified) <= (1.0 - alpha / 4.0) * size {
                    self.trial = Some((u, p, residual));
                    return Ok(Some(alpha));
                }
            }
            alpha *= 0.5;
        }
        Ok(None)
    }

    /// [`correction_norm`] of this system.
    fn correction_norm(&self, correction: &[f64]) -> f64 {
        correction_norm(
            correction,
            self.problem.dofs().free_count(),
            self.pressure_weight,
        )
    }

    /// (u, p) + α·δ.
    fn stepped(&self, alpha: f64) -> (Vec<f64>, Vec<f64>) {
        let dofs = self.problem.dofs();
        let free = dofs.free_count();
        let mut u = self.u.clone();
        for (k, &dof) in dofs.free_dofs().iter().enumerate() {
            u[dof] += alpha * self.delta[k];
        }
        let p = self
            .p
            .iter()
            .zip(&self.delta[free..])
            .map(|(p, d)| p + alpha * d)
            .collect();
        (u, p)
    }
}

impl<E: MixedElement> NewtonSystem for MixedSystem<'_, E> {
    fn direction(&mut self, _first: bool) -> Result<()> {
        let (u, p) = (self.u.clone(), self.p.clone());
        let Some((_, Some(tangent))) = self.evaluate(&u, &p, true)? else {
            return Err(Error::Solver(
                "the accepted iterate has an inverted tet".into(),
            ));
        };
        let Some(ldlt) = self.ldlt.as_mut() else {
            return Err(Error::Solver("the mixed tangent was not analysed".into()));
        };
        ldlt.factorize(&tangent).map_err(|e| {
            Error::Solver(format!(
                "the mixed {} tangent at load step {} is not quasi-definite (an \
                 instability, a compressed tet, or supports that do not hold a rigid motion): \
                 {e}",
                self.law.name(),
                self.step
            ))
        })?;
        self.delta = self.residual.iter().map(|r| -r).collect();
        Ok(ldlt.solve_in_place(&mut self.delta)?)
    }

    /// δu below the positions' resolution 4ε·max|X| and δp below the pressure's, 4ε·κ (the
    /// round-off of κ·(J − 1) near J = 1) or 4ε·max|p|: the iterate then stands.
    fn step_is_unresolved(&self) -> bool {
        let free = self.problem.dofs().free_count();
        let pressure_scale = self.p.iter().fold(self.largest_bulk, |m, p| m.max(p.abs()));
        self.delta[..free]
            .iter()
            .all(|d| d.abs() <= self.resolution)
            && self.delta[free..]
                .iter()
                .all(|d| d.abs() <= 4.0 * f64::EPSILON * pressure_scale)
    }

    fn search(&mut self, r_norm: f64, reference: f64) -> Result<(bool, f64)> {
        if self.law == MixedLaw::Corotational
            && let Some(alpha) = self.natural_step()?
        {
            return Ok((true, alpha));
        }
        // Without contact the search accepts a decrease of the residual norm (the potential
        // here is constant: see the module docs on the saddle).
        Backtracking::for_contact(false).search(self, 1.0, (r_norm, NEAR_SOLUTION * reference), 0.0)
    }

    fn accept(&mut self, _alpha: f64) -> f64 {
        if let Some((u, p, residual)) = self.trial.take() {
            (self.u, self.p, self.residual) = (u, p, residual);
        }
        self.iterations += 1;
        let now = self.merit(&self.residual);
        self.history.push(now);
        now
    }

    fn describe(&self, iteration: usize) -> String {
        format!(
            "mixed {} Newton iteration {iteration} of load step {}",
            self.law.name(),
            self.step
        )
    }
}

impl<E: MixedElement> LineFunction for MixedSystem<'_, E> {
    fn trial(&mut self, alpha: f64) -> Result<f64> {
        let (u, p) = self.stepped(alpha);
        match self.evaluate(&u, &p, false)? {
            Some((residual, _)) => {
                let merit = self.merit(&residual);
                self.trial = Some((u, p, residual));
                Ok(merit)
            }
            // An inverted tet: never accepted.
            None => {
                self.trial = None;
                Ok(f64::INFINITY)
            }
        }
    }

    /// The mixed energy is a saddle, no merit: constant, so only the residual decides.
    fn start_potential(&mut self) -> Result<f64> {
        Ok(0.0)
    }

    fn trial_potential(&mut self) -> Result<f64> {
        Ok(0.0)
    }
}

/// ‖(δu, δp·ℓ/μ)‖ (length) of a correction whose first `free` entries are δu (length) and the
/// rest δp (Pa), `pressure_weight` = μ/ℓ (Pa/length): the pressure weighted as in the merit, so
/// that δp of a strain's stress counts as the displacement of that strain. The norm of
/// Deuflhard's test in both mixed Newtons, the static one and the backward Euler
/// ([`crate::analysis::mixed_nonlinear_dynamics`]).
pub(crate) fn correction_norm(correction: &[f64], free: usize, pressure_weight: f64) -> f64 {
    let (du, dp) = correction.split_at(free);
    let w = 1.0 / pressure_weight;
    (du.iter().map(|d| d * d).sum::<f64>() + dp.iter().map(|d| (w * d).powi(2)).sum::<f64>()).sqrt()
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// The saddle-point matrix of the mixed tangent at the element `states` (one per tet, with
/// their `rests` and (μ, 1/κ) `moduli`, Pa and 1/Pa): the free deviatoric block
/// `free_stiffness` (K_ff, plus what the caller added to it, as backward Euler's M/dt²), the
/// states' couplings and each element's pressure block C; shared by the static and the
/// backward-Euler Newton.
pub(crate) fn state_saddle_point<E: MixedElement>(
    mesh: &TetMesh<E>,
    free_stiffness: &CscMatrix,
    (dofs, pressure_nodes): (&DofMap, &PressureNodes),
    states: &[E::State],
    (rests, moduli): (&[E::Rest], &[(f64, f64)]),
) -> Result<CscMatrix> {
    saddle_point_matrix(
        mesh,
        free_stiffness,
        dofs,
        pressure_nodes,
        |t, k, i, a| E::coupling_entry(E::state_coupling(&states[t]), k, i, a),
        |t, k, l| {
            let (mu, inverse_bulk) = moduli[t];
            E::pressure_block(&rests[t], mu, inverse_bulk, k, l)
        },
    )
}
