//! The static analysis of a [`Definition`]: equilibrium Σₑ fₑ(u) + f = 0 under the static load,
//! by the library's one dispatch between the linear fast path (K_ff factored once, one solve:
//! [`StaticSolver`]), Newton over load steps (a nonlinear model) and Newton with the contact
//! barriers (obstacles, body–body and self-contact of the boundary surface, with any model,
//! the linear one too). Moving supports follow
//! [`Definition::motions`] through the load steps. The outcome carries the reactions of every
//! model and, on demand, the stresses and the estimated error.

use std::time::Duration;

use nalgebra::Vector3;

use crate::analysis::dynamics::TimeData;
use crate::analysis::nonlinear::{
    NewtonOptions, NewtonReport, nonlinear_reactions,
    solve_nonlinear_static_with_motion_and_contact, solve_nonlinear_static_with_surface_contact,
};
use crate::analysis::statics::{StaticSolver, StaticTimings};
use crate::base::error::Result;
use crate::base::warning::Warning;
use crate::bc::amplitude::STATIC_TIME;
use crate::bc::constraints::DofMap;
use crate::bc::loads::Loads;
use crate::contact::surface::SurfaceContact;
use crate::fe::element::{ElementType, Tet4};
use crate::fe::materials::MaterialMap;
use crate::linear_solver::{SolveInfo, SolverOptions};
use crate::mesh::TetMesh;
use crate::model::{ModelElement, ModelMap};

use super::combination::Analysis;
use super::definition::Definition;

/// The solvers' settings of a [`Static`] analysis.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StaticOptions {
    /// The linear fast path's solver (direct Cholesky, CG, or chosen by predicted time).
    pub linear: SolverOptions,
    /// Newton's load steps, tolerance and iteration budget (a nonlinear model or obstacles).
    pub newton: NewtonOptions,
}

/// How [`Static::solve`] solved: one linear solve, or Newton over load steps.
#[derive(Debug, Clone, PartialEq)]
pub enum StaticPath {
    /// The linear model without obstacles: K_ff factored (or CG) once, one solve.
    Linear {
        /// How the linear system was solved.
        info: SolveInfo,
        /// Wall time of each phase.
        timings: StaticTimings,
        /// Stored values of the Cholesky factor (0 on the iterative path).
        factor_len: usize,
    },
    /// A nonlinear model, or obstacles with any model: Newton's method over load steps.
    Newton {
        /// Residual norms ‖r_f‖ (force units) of each iteration, one list per load step (see
        /// [`NewtonReport::residuals`](crate::analysis::nonlinear::NewtonReport::residuals)).
        residuals: Vec<Vec<f64>>,
        /// Newton iterations over all load steps.
        iterations: usize,
    },
}

/// The result of [`Static::solve`].
#[derive(Debug, Clone, PartialEq)]
pub struct StaticOutcome {
    /// Displacement of every DOF (length units), prescribed values included.
    pub displacement: Vec<f64>,
    /// The support reactions of every DOF (force units): K·u − f for the linear model,
    /// −(Σₑ fₑ(u) + f) for the nonlinear ones ([`nonlinear_reactions`]); zero on free DOFs.
    /// With the load and the obstacles' forces they balance: Σ R + Σ f − Σ obstacle forces = 0
    /// up to the solve's residual.
    pub reactions: Vec<f64>,
    /// ‖r_f‖/‖f_f‖ at the solution (the linear solve's relative residual; Newton's last
    /// residual over the load norm, or the residual itself in force units without a load).
    pub relative_residual: f64,
    /// The free DOF count.
    pub free_dofs: usize,
    /// Per obstacle (in the contact's order) the whole force the body exerts on it (force
    /// units): the barrier's [`Contact::obstacle_forces`](crate::contact::Contact::obstacle_forces)
    /// plus friction; empty without contact.
    pub obstacle_forces: Vec<Vector3<f64>>,
    /// Per obstacle the friction part of `obstacle_forces` (force units; empty without
    /// contact, zero without friction).
    pub friction_forces: Vec<Vector3<f64>>,
    /// With contact: the barrier's scales the solution is in equilibrium under (the
    /// definition's contact's, or the smaller d̂ its continuation reached; see
    /// [`NewtonReport::contact_parameters`](crate::analysis::nonlinear::NewtonReport::contact_parameters)):
    /// evaluate gaps and pressures of the solution under these
    /// ([`Contact::with_parameters`](crate::contact::Contact::with_parameters)). `None`
    /// without contact.
    pub contact_parameters: Option<crate::contact::ContactParameters>,
    /// With contact: the solution's gap error (dimensionless; see
    /// [`NewtonReport::gap_error`](crate::analysis::nonlinear::NewtonReport::gap_error)).
    pub gap_error: Option<f64>,
    /// With contact: the smallest gap of any accepted Newton iterate (length; see
    /// [`NewtonReport::smallest_iterate_gap`](crate::analysis::nonlinear::NewtonReport::smallest_iterate_gap)).
    pub smallest_iterate_gap: Option<f64>,
    /// With body–body contact: the smallest surface distance of any accepted Newton iterate
    /// (m; see
    /// [`NewtonReport::smallest_surface_distance`](crate::analysis::nonlinear::NewtonReport::smallest_surface_distance)).
    pub smallest_surface_distance: Option<f64>,
    /// Which path ran, with its counts.
    pub path: StaticPath,
}

impl StaticOutcome {
    /// `contact` (the definition's) under the barrier this solution is in equilibrium under
    /// ([`contact_parameters`](Self::contact_parameters)): what to evaluate its gaps,
    /// pressures and contact forces with — the given d̂ would read the gaps a continuation
    /// closed as enormous forces. `None` without contact; `contact` as it is for a solve
    /// that did not go through the barrier (the linear path).
    pub fn solved_contact(
        &self,
        contact: Option<&crate::contact::Contact>,
    ) -> Result<Option<crate::contact::Contact>> {
        match (contact, self.contact_parameters) {
            (Some(c), Some(parameters)) => Ok(Some(c.with_parameters(parameters)?)),
            (c, _) => Ok(c.cloned()),
        }
    }

    /// The linear solve's phase timings (`None` for Newton).
    pub fn timings(&self) -> Option<StaticTimings> {
        match &self.path {
            StaticPath::Linear { timings, .. } => Some(*timings),
            StaticPath::Newton { .. } => None,
        }
    }

    /// Stored values of the Cholesky factor (0 for an iterative or a Newton solve).
    pub fn factor_len(&self) -> usize {
        match &self.path {
            StaticPath::Linear { factor_len, .. } => *factor_len,
            StaticPath::Newton { .. } => 0,
        }
    }

    /// Newton's load steps and iterations in all (`None` for the linear path).
    pub fn newton_counts(&self) -> Option<(usize, usize)> {
        match &self.path {
            StaticPath::Linear { .. } => None,
            StaticPath::Newton {
                residuals,
                iterations,
            } => Some((residuals.len(), *iterations)),
        }
    }

    /// The wall time of the linear solve's phases together (zero for Newton).
    pub fn linear_time(&self) -> Duration {
        self.timings().map_or(Duration::ZERO, |t| {
            t.pattern + t.assembly + t.constraints + t.symbolic + t.factorization + t.solve
        })
    }
}

/// The static analysis of one [`Definition`]: [`new`](Self::new) checks the combination,
/// [`solve`](Self::solve) runs the one dispatch.
///
/// ```
/// use tetfem::analysis::{Definition, Static};
/// use tetfem::nalgebra::Vector3;
/// use tetfem::{BoxSplit, Constraints, Loads, Material, MaterialMap, TetMesh};
/// # fn main() -> tetfem::Result<()> {
/// // A 1 m steel cantilever, 0.1 m square section, clamped at x = 0, 1 kN down at its end.
/// let size = Vector3::new(1.0, 0.1, 0.1);
/// let mesh = TetMesh::box_grid(Vector3::zeros(), size, [20, 2, 2], BoxSplit::Mirrored6)?;
/// let steel = MaterialMap::uniform(Material::new(200e9, 0.3, 7850.0)?, mesh.tet_count());
/// let mut constraints = Constraints::new(&mesh);
/// constraints.fix_nodes(&mesh.nodes_on_plane(0, 0.0, 1e-9))?;
/// let mut loads = Loads::new(&mesh);
/// let end = mesh.faces_on_plane(&mesh.boundary_faces()?, 0, 1.0, 1e-9);
/// loads.add_total_force_on_faces(&mesh, &end, Vector3::new(0.0, 0.0, -1e3))?; // N
/// let beam = Definition::builder(mesh, steel)
///     .constraints(constraints)?
///     .loads(loads)?
///     .build()?;
/// let outcome = Static::new(&beam, Default::default())?.solve()?;
/// // The clamp carries the load: Σ r_z = +1 kN (K's rows sum to zero along a translation).
/// let lift: f64 = outcome.reactions.iter().skip(2).step_by(3).sum();
/// assert!((lift - 1e3).abs() < 1e-6 * 1e3);
/// # Ok(()) }
/// ```
#[derive(Debug)]
pub struct Static<'a, C: ModelElement = Tet4> {
    definition: &'a Definition<C>,
    options: StaticOptions,
    model: ModelMap,
    warnings: Vec<Warning>,
}

impl<'a, C: ModelElement> Static<'a, C> {
    /// The analysis of `definition` with `options`:
    /// [`Error::InvalidParameter`](crate::Error::InvalidParameter) naming the pair the
    /// library's combination rule refuses ([`Definition::check`]), else the analysis with
    /// the rule's warnings ([`warnings`](Self::warnings)).
    pub fn new(definition: &'a Definition<C>, options: StaticOptions) -> Result<Self> {
        let warnings = definition.check(Analysis::Static)?;
        Ok(Static {
            model: definition.model_map()?,
            definition,
            options,
            warnings,
        })
    }

    /// The combination rule's warnings for this definition.
    pub fn warnings(&self) -> &[Warning] {
        &self.warnings
    }

    /// The force model that runs, one per material (whose stresses the outcome reports).
    pub fn model(&self) -> &ModelMap {
        &self.model
    }

    /// The definition this analysis runs.
    pub fn definition(&self) -> &'a Definition<C> {
        self.definition
    }

    /// Whether [`solve`](Self::solve) takes the linear fast path: the linear model (in every
    /// material) without
    /// obstacles or body–body contact (any other model, or contact with any model, is Newton).
    pub fn is_linear_path(&self) -> bool {
        let d = self.definition;
        d.is_linear() && d.contact.is_none() && d.surface_contact.is_none()
    }

    /// Static equilibrium under [`Definition::static_load`]: one linear solve on the linear
    /// fast path, else Newton over the load steps of the options (with the definition's moving
    /// supports and obstacles). Errors: those of the solve taken (a constraint set leaving a
    /// rigid mode, Newton not converging, a load step with no frictional equilibrium, …).
    pub fn solve(&self) -> Result<StaticOutcome> {
        let d = self.definition;
        let load = d.static_load()?;
        let free_dofs = DofMap::new(&d.constraints).free_count();
        if self.is_linear_path() {
            let mut solver = StaticSolver::with_options(
                &d.mesh,
                &d.materials,
                &d.constraints,
                self.options.linear,
            )?;
            let solution = solver.solve(&load)?;
            return Ok(StaticOutcome {
                displacement: solution.displacement,
                reactions: solution.reactions,
                relative_residual: solution.relative_residual,
                free_dofs,
                obstacle_forces: Vec::new(),
                friction_forces: Vec::new(),
                contact_parameters: None,
                gap_error: None,
                smallest_iterate_gap: None,
                smallest_surface_distance: None,
                path: StaticPath::Linear {
                    info: solution.info,
                    timings: solver.timings(),
                    factor_len: solver.factor_len(),
                },
            });
        }
        self.solve_by_newton(&load, free_dofs)
    }

    /// Newton over the load steps, and the reactions −(Σₑ fₑ(u) + f), with body–body
    /// contact −(Σₑ fₑ(u) + f_B(u) + f) (f_B the surface barrier's force on a supported node).
    fn solve_by_newton(&self, load: &Loads, free_dofs: usize) -> Result<StaticOutcome> {
        let d = self.definition;
        let surface = match &d.surface_contact {
            Some(data) => Some(SurfaceContact::new(
                &d.mesh,
                &data.body_of_node,
                data.barrier,
            )?),
            None => None,
        };
        let report = self.newton_report(load, surface.as_ref())?;
        let load_norm = norm(&DofMap::new(&d.constraints).restrict(load.as_slice())?);
        let last = report
            .residuals
            .last()
            .and_then(|r| r.last())
            .copied()
            .unwrap_or(0.0);
        let mut reactions = nonlinear_reactions(
            &d.mesh,
            &self.model,
            &d.constraints,
            load,
            &report.displacement,
        )?;
        if let Some(surface) = &surface {
            // The barrier's force on a supported node is carried by the support too.
            let mut pushed = vec![0.0; reactions.len()];
            surface.add_force(&report.displacement, &mut pushed)?;
            for (dof, (r, f)) in reactions.iter_mut().zip(&pushed).enumerate() {
                if d.constraints.get(dof).is_some() {
                    *r -= f;
                }
            }
        }
        // The solution is in equilibrium under the barrier its continuation ended with.
        let solved_contact = match &d.contact {
            Some(contact) => Some(report.solved_contact(contact)?),
            None => None,
        };
        let obstacle_forces = match &solved_contact {
            Some(contact) => contact
                .obstacle_forces(&report.displacement)?
                .iter()
                .enumerate()
                .map(|(o, f)| {
                    f + report
                        .obstacle_friction_forces
                        .get(o)
                        .copied()
                        .unwrap_or_default()
                })
                .collect(),
            None => Vec::new(),
        };
        Ok(StaticOutcome {
            // ‖r_f‖/‖f_f‖ at the end, as for the linear solve.
            relative_residual: if load_norm > 0.0 {
                last / load_norm
            } else {
                last
            },
            free_dofs,
            obstacle_forces,
            friction_forces: report.obstacle_friction_forces,
            contact_parameters: report.contact_parameters,
            gap_error: report.gap_error,
            smallest_iterate_gap: report.smallest_iterate_gap,
            smallest_surface_distance: report.smallest_surface_distance,
            reactions,
            displacement: report.displacement,
            path: StaticPath::Newton {
                residuals: report.residuals,
                iterations: report.iterations,
            },
        })
    }
}

impl<C: ModelElement> Static<'_, C> {
    /// Newton's report: the obstacles' solve, or with body–body contact (`surface`) the one
    /// that carries its barrier too (no surface: exactly the path of a run without it).
    fn newton_report(
        &self,
        load: &Loads,
        surface: Option<&SurfaceContact>,
    ) -> Result<NewtonReport> {
        let d = self.definition;
        match surface {
            None => solve_nonlinear_static_with_motion_and_contact(
                &d.mesh,
                &self.model,
                &d.constraints,
                load,
                &d.motions,
                d.contact.as_ref(),
                self.options.newton,
            ),
            Some(surface) => solve_nonlinear_static_with_surface_contact(
                &d.mesh,
                &self.model,
                &d.constraints,
                load,
                &d.motions,
                d.contact.as_ref(),
                surface,
                self.options.newton,
            ),
        }
    }
}

impl<C: ModelElement> Definition<C> {
    /// The static load (force units, every DOF): [`static_load_of`] this definition's mesh,
    /// materials, constant loads, gravity and time data. Every front end's static solve takes
    /// this one sum.
    pub fn static_load(&self) -> Result<Loads> {
        static_load_of(
            &self.mesh,
            &self.materials,
            &self.loads,
            self.gravity,
            &self.time_data,
        )
    }
}

/// The static load (force units, every DOF) on `mesh` with `materials`: the constant `loads`,
/// plus gravity's ρ·g (`gravity` in m/s², ρ of each tet's material, times gravity's amplitude
/// at [`STATIC_TIME`]), plus each amplitude load of `time_data` times its amplitude at
/// [`STATIC_TIME`], summed in that order. [`Definition::static_load`] is this of its own data;
/// a front end with a prefactored solver (Python's `StaticSolver`) calls it directly, so that
/// every static solve takes the same sum. Errors: a load not made for `mesh`
/// ([`crate::Error::DimensionMismatch`]).
pub fn static_load_of<C: ElementType>(
    mesh: &TetMesh<C>,
    materials: &MaterialMap,
    loads: &Loads,
    gravity: Vector3<f64>,
    time_data: &TimeData,
) -> Result<Loads> {
    let mut load = loads.clone();
    let factor = time_data.gravity.value(STATIC_TIME);
    if gravity != Vector3::zeros() && factor != 0.0 {
        load.add_gravity(mesh, materials, gravity * factor)?;
    }
    for (loads, amplitude) in &time_data.loads {
        load.add_scaled(loads, amplitude.value(STATIC_TIME))?;
    }
    Ok(load)
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}
