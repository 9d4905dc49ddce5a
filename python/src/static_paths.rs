//! The static solve's dispatch with what `tetfem::nonlinear::solve_static_model` does not take
//! yet: obstacles on 10-node meshes and obstacles together with moving supports. Both run as
//! the scene runner runs them (`solve_nonlinear_static_with_motion_and_contact`, generic over
//! the element); every other case is the library's one dispatch.

use tetfem::boundary_motion::BoundaryMotion;
use tetfem::constraints::{Constraints, DofMap};
use tetfem::contact::Contact;
use tetfem::linalg::linear_solver::SolverOptions;
use tetfem::loads::Loads;
use tetfem::mesh::TetMesh;
use tetfem::model::{ModelElement, ModelMap};
use tetfem::nonlinear::{
    NewtonOptions, StaticModelSolution, StaticPath, nonlinear_reactions,
    solve_nonlinear_static_with_motion_and_contact, solve_static_model,
};

/// Static equilibrium of `models` on `mesh` (the arguments of `solve_static_model`):
/// `solve_static_model` itself, except with `contact` on a mesh of other cells than 4-node
/// tets or with moving supports `motion`, which it refuses: those are Newton with the contact
/// barrier and the motion through the load steps, as the scene runner solves them, with the
/// same reactions −(Σₑ fₑ(u) + f), relative residual ‖r_f‖/‖f_f‖ and obstacle forces (barrier
/// plus friction) that `solve_static_model` reports.
#[allow(clippy::too_many_arguments)]
pub fn solve_model<E: ModelElement>(
    mesh: &TetMesh<E>,
    models: &ModelMap,
    constraints: &Constraints,
    loads: &Loads,
    motion: &BoundaryMotion,
    contact: Option<&Contact>,
    linear: SolverOptions,
    newton: NewtonOptions,
) -> tetfem::Result<StaticModelSolution> {
    let Some(contact) = contact.filter(|_| E::NODES != 4 || !motion.is_empty()) else {
        return solve_static_model(
            mesh,
            models,
            constraints,
            loads,
            motion,
            contact,
            linear,
            newton,
        );
    };
    let report = solve_nonlinear_static_with_motion_and_contact(
        mesh,
        models,
        constraints,
        loads,
        motion,
        Some(contact),
        newton,
    )?;
    let dofs = DofMap::new(constraints);
    let load = dofs
        .restrict(loads.as_slice())?
        .iter()
        .map(|f| f * f)
        .sum::<f64>()
        .sqrt();
    let last = report
        .residuals
        .last()
        .and_then(|r| r.last())
        .copied()
        .unwrap_or(0.0);
    let reactions = nonlinear_reactions(mesh, models, constraints, loads, &report.displacement)?;
    let friction = &report.obstacle_friction_forces;
    let obstacle_forces = contact
        .obstacle_forces(&report.displacement)?
        .iter()
        .enumerate()
        .map(|(o, f)| f + friction.get(o).copied().unwrap_or_default())
        .collect();
    Ok(StaticModelSolution {
        relative_residual: if load > 0.0 { last / load } else { last },
        free_dofs: dofs.free_count(),
        obstacle_forces,
        reactions,
        displacement: report.displacement,
        path: StaticPath::Newton {
            residuals: report.residuals,
            iterations: report.iterations,
        },
    })
}
