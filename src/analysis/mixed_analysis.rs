//! The mixed displacement–pressure static solve of either model it takes, chosen in one place:
//! the linear model by one saddle-point solve ([`MixedStaticSolver`]), the Neo-Hookean and the
//! corotational ones by Newton's load steps ([`solve_static_mixed_nonlinear_with`] and their
//! [`MixedLaw`]), after the library's rule of what the
//! mixed element may be combined with ([`Combination::check`]). Front ends (scenes, Python)
//! call this and decide nothing. Beside it, the checked entries of the linear mixed body's
//! implicit dynamics ([`mixed_transient_model`]) and modes ([`mixed_modes_model`]).

use crate::analysis::combination::{Analysis, Combination, Formulation};
use crate::analysis::dynamics::{Method, Rayleigh};
use crate::analysis::mixed_dynamics::MixedTransient;
use crate::analysis::mixed_modal::{MixedModes, lowest_mixed_modes};
use crate::analysis::mixed_nonlinear::{MixedLaw, solve_static_mixed_nonlinear_with};
use crate::analysis::mixed_nonlinear_dynamics::{MixedBody, MixedNonlinearEuler};
use crate::analysis::mixed_statics::{MixedStaticSolution, MixedStaticSolver};
use crate::analysis::nonlinear::NewtonOptions;
use crate::base::error::Result;
use crate::bc::constraints::Constraints;
use crate::bc::loads::Loads;
use crate::fe::element::{MixedElement, Tet4, Tet10};
use crate::fe::materials::TetMaterials;
use crate::mesh::TetMesh;
use crate::model::ModelKind;

/// What [`solve_static_mixed_model`] found and how.
#[derive(Debug, Clone, PartialEq)]
pub struct MixedOutcome {
    /// Displacement, pressure (Pa), reactions (force units) and relative residual.
    pub solution: MixedStaticSolution,
    /// Free displacement DOFs.
    pub free_dofs: usize,
    /// Entries of the LDLᵀ factor (the linear model's single factorization; 0 for Newton's,
    /// which factors each iteration).
    pub factor_len: usize,
    /// Newton iterations in all (`None` for the linear model's single solve).
    pub newton_iterations: Option<usize>,
}

/// A mixed element with its element order in [`Combination`].
pub trait MixedStaticElement: MixedElement {
    /// The element order: 1 (4-node, stabilized P1–P1) or 2 (10-node, Taylor–Hood).
    const ORDER: usize;
}

impl MixedStaticElement for Tet10 {
    const ORDER: usize = 2;
}

impl MixedStaticElement for Tet4 {
    const ORDER: usize = 1;
}

/// The mixed static solve of `model` on `mesh` (10-node tets: Taylor–Hood P2–P1; 4-node tets:
/// stabilized P1–P1; see the [module](self) docs); `options` are Newton's (load steps,
/// tolerance, iterations), unused by the linear model.
///
/// Errors: a combination the mixed element does not compute ([`Combination::check`], naming
/// the pair; `moving_supports` says whether a support follows a motion); those of
/// [`MixedStaticSolver`] and [`solve_static_mixed_nonlinear_with`].
pub fn solve_static_mixed_model<E: MixedStaticElement>(
    mesh: &TetMesh<E>,
    materials: &impl TetMaterials,
    model: ModelKind,
    (constraints, moving_supports): (&Constraints, bool),
    loads: &Loads,
    options: NewtonOptions,
) -> Result<MixedOutcome> {
    Combination {
        model,
        order: E::ORDER,
        analysis: Analysis::Static,
        moving_supports,
        formulation: Formulation::Mixed,
        ..Combination::default()
    }
    .check()?;
    let Some(law) = MixedLaw::of(model) else {
        let mut solver = MixedStaticSolver::new(mesh, materials, constraints)?;
        let solution = solver.solve(loads)?;
        return Ok(MixedOutcome {
            solution,
            free_dofs: solver.dofs().free_count(),
            factor_len: solver.factor_len(),
            newton_iterations: None,
        });
    };
    let report =
        solve_static_mixed_nonlinear_with(law, mesh, materials, constraints, loads, options)?;
    Ok(MixedOutcome {
        solution: MixedStaticSolution {
            displacement: report.displacement,
            pressure: report.pressure,
            relative_residual: report.relative_residual,
            reactions: report.reactions,
        },
        free_dofs: constraints.dof_count() - constraints.count(),
        factor_len: 0,
        newton_iterations: Some(report.iterations),
    })
}

/// The mixed element (10-node tets: Taylor–Hood P2–P1; 4-node tets: stabilized P1–P1) in an
/// implicit dynamic run of `model` (the linear one): the library's rule first
/// ([`Combination::check`] with [`Analysis::Transient`]`(method)`: the explicit method,
/// another model, moving supports and loads that follow amplitudes are refused by name), then
/// [`MixedTransient::new`] with `method`, `dt` and `damping`, at rest. The Neo-Hookean and
/// corotational models' run is [`mixed_nonlinear_euler_model`].
pub fn mixed_transient_model<E: MixedStaticElement>(
    mesh: &TetMesh<E>,
    materials: &impl TetMaterials,
    model: ModelKind,
    (constraints, loads): (&Constraints, &Loads),
    (method, dt, damping): (Method, f64, Rayleigh),
) -> Result<MixedTransient<E>> {
    Combination {
        model,
        order: E::ORDER,
        analysis: Analysis::Transient(method),
        formulation: Formulation::Mixed,
        ..Combination::default()
    }
    .check()?;
    if model != ModelKind::Linear {
        return Err(crate::base::error::Error::invalid_parameter(
            "model",
            model.name(),
            "the mixed transient of MixedTransient is the linear model's; the Neo-Hookean \
             and corotational ones are mixed_nonlinear_euler_model's",
        ));
    }
    MixedTransient::new(mesh, materials, constraints, loads, (method, dt, damping))
}

/// The mixed element with a hyperelastic `model` (Neo-Hookean or corotational) in backward
/// Euler (10-node tets: Taylor–Hood; 4-node tets: stabilized P1–P1): the library's rule first
/// ([`Combination::check`]), then [`MixedNonlinearEuler::new_with_law`] with the model's
/// [`MixedLaw`], `dt` and Newton's relative `tolerance`, at rest.
///
/// Errors: the combination's refusal (naming the model); `model` linear or St.
/// Venant–Kirchhoff (no mixed law: the linear model's run is [`mixed_transient_model`]); those
/// of [`MixedNonlinearEuler::new_with_law`].
pub fn mixed_nonlinear_euler_model<'a, E: MixedStaticElement + MixedBody>(
    mesh: &'a TetMesh<E>,
    materials: &impl TetMaterials,
    model: ModelKind,
    (constraints, loads): (&Constraints, &Loads),
    (dt, tolerance): (f64, f64),
) -> Result<MixedNonlinearEuler<'a, E>> {
    Combination {
        model,
        order: E::ORDER,
        analysis: Analysis::Transient(Method::BackwardEuler),
        formulation: Formulation::Mixed,
        ..Combination::default()
    }
    .check()?;
    let Some(law) = MixedLaw::of(model) else {
        return Err(crate::base::error::Error::invalid_parameter(
            "model",
            model.name(),
            "the mixed backward Euler of MixedNonlinearEuler takes the Neo-Hookean and the \
             corotational models; the linear one is mixed_transient_model's",
        ));
    };
    MixedNonlinearEuler::new_with_law(law, mesh, materials, constraints, loads, (dt, tolerance))
}

/// The `count` lowest modes of the mixed body (10-node tets: Taylor–Hood P2–P1; 4-node tets:
/// stabilized P1–P1) with `model` (the linear one; the library's rule [`Combination::check`]
/// with [`Analysis::Modal`] first), by [`lowest_mixed_modes`].
pub fn mixed_modes_model<E: MixedStaticElement>(
    mesh: &TetMesh<E>,
    materials: &impl TetMaterials,
    model: ModelKind,
    constraints: &Constraints,
    count: usize,
) -> Result<MixedModes> {
    Combination {
        model,
        order: E::ORDER,
        analysis: Analysis::Modal,
        formulation: Formulation::Mixed,
        ..Combination::default()
    }
    .check()?;
    lowest_mixed_modes(mesh, materials, constraints, count)
}
