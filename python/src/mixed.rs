//! `tetfem.solve_static_mixed`: the mixed displacement–pressure static solve for nearly
//! incompressible materials, linear, Neo-Hookean or corotational (Taylor–Hood P2–P1 on 10-node tets, the
//! stabilized P1–P1 on 4-node tets).

use pyo3::prelude::*;
use pyo3::types::PyDict;
use tetfem::analysis::nonlinear::NewtonOptions;
use tetfem::solve_static_mixed_model;

use crate::arrays;
use crate::cells::on_cells;
use crate::constraints::PyConstraints;
use crate::interrupt::detach_interruptible;
use crate::loads::PyLoads;
use crate::material::materials_of;
use crate::mesh::PyMesh;
use crate::names;
use crate::statics::check_same_mesh;

/// Static equilibrium in the mixed displacement–pressure form with a continuous linear
/// pressure: no volumetric locking as Poisson's ratio → 0.5. ``mesh``: 10-node tets
/// (``order=2``: Taylor–Hood P2–P1, quadratic displacement) or 4-node tets (``order=1``: the
/// stabilized P1–P1 of Dohrmann–Bochev, linear displacement). ``material``: a ``Material`` or a ``MaterialMap``
/// (ν < 0.5). ``model``: ``"linear"`` (one LDLᵀ solve of the quasi-definite saddle system) or
/// ``"neo-hookean"`` (Simo–Taylor's mixed form at large deformation) or ``"corotational"``
/// (linear elasticity in each point's rotated frame), both by Newton in ``load_steps``
/// increments of at most ``max_iterations`` each, to a relative residual of 1e-10. What may
/// be combined with the mixed element is the library's rule (``Combination``): a moving
/// support with the Neo-Hookean model, for one, raises ``InvalidInputError``. Loads enter at
/// their value at the pseudo-time t = 1, as in ``solve_static``. Returns a dict with
/// ``displacement`` (n, 3) m, ``pressure`` (n,) Pa (p = −tr σ/3, positive in compression),
/// ``reactions`` (n, 3) N, ``relative_residual``, ``model`` and ``newton_iterations`` (0 for
/// the linear model). The work runs with the GIL released.
#[pyfunction]
#[pyo3(name = "solve_static_mixed", signature = (mesh, material, constraints, loads, model = "linear", load_steps = 10, max_iterations = 30))]
#[allow(clippy::too_many_arguments)]
pub fn solve_static_mixed_py<'py>(
    py: Python<'py>,
    mesh: &Bound<'py, PyMesh>,
    material: &Bound<'py, PyAny>,
    constraints: PyRef<'py, PyConstraints>,
    loads: PyRef<'py, PyLoads>,
    model: &str,
    load_steps: usize,
    max_iterations: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let data = &mesh.get().data;
    check_same_mesh(py, data, &constraints, Some(&loads))?;
    let materials = materials_of(py, material, data)?;
    let kind = names::model(py, model)?;
    let options = NewtonOptions {
        load_steps,
        max_iterations,
        ..NewtonOptions::default()
    };
    let moving = !constraints.motions.is_empty();
    let (fixed, all) = (&constraints.constraints, &loads.all);
    let outcome = detach_interruptible(py, || {
        on_cells!(&data.mesh, m => {
            solve_static_mixed_model(m, &materials, kind, (fixed, moving), all, options)
        })
    })?;
    let (solution, iterations) = (outcome.solution, outcome.newton_iterations.unwrap_or(0));
    let (displacement, pressure, reactions, residual) = (
        solution.displacement,
        solution.pressure,
        solution.reactions,
        solution.relative_residual,
    );
    let out = PyDict::new(py);
    out.set_item("displacement", arrays::rows3(py, displacement)?)?;
    out.set_item("pressure", arrays::vector(py, pressure))?;
    out.set_item("reactions", arrays::rows3(py, reactions)?)?;
    out.set_item("relative_residual", residual)?;
    out.set_item("model", kind.name())?;
    out.set_item("newton_iterations", iterations)?;
    Ok(out)
}
