//! The `tetfem` Python package's native module (`tetfem._tetfem`): meshes, materials,
//! constraints, loads, static, dynamic and modal analyses and scenes of the tetfem library,
//! with numpy arrays in and out. The Python package (`python/tetfem/`) re-exports it and adds
//! the exception classes (`tetfem.errors`).
#![warn(missing_docs)]

use pyo3::prelude::*;

mod amplitude;
mod arrays;
mod bodies;
mod cells;
mod constraints;
mod contact;
mod errors;
mod interrupt;
mod loads;
mod material;
mod matrices;
mod mesh;
mod mixed;
mod mixed_dynamics;
mod mixed_neo_hookean;
mod modal;
mod names;
mod post;
mod scene;
mod sim_reactions;
mod simulation;
mod sparse;
mod statics;
mod timed;

/// The native module: every class and function of the `tetfem` package.
#[pymodule]
fn _tetfem(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<mesh::PyMesh>()?;
    m.add_class::<material::PyMaterial>()?;
    m.add_class::<material::PyMaterialMap>()?;
    m.add_class::<constraints::PyConstraints>()?;
    m.add_class::<loads::PyLoads>()?;
    m.add_class::<statics::StaticResult>()?;
    m.add_class::<contact::PyObstacle>()?;
    m.add_class::<amplitude::PyAmplitude>()?;
    m.add_class::<statics::PyStaticSolver>()?;
    m.add_class::<simulation::PySimulation>()?;
    m.add_class::<modal::ModalResult>()?;
    m.add_function(wrap_pyfunction!(statics::solve_static, m)?)?;
    m.add_function(wrap_pyfunction!(mixed::solve_static_mixed_py, m)?)?;
    m.add_function(wrap_pyfunction!(
        mixed_dynamics::mixed_modal_analysis_py,
        m
    )?)?;
    m.add_function(wrap_pyfunction!(mixed_dynamics::mixed_transient_py, m)?)?;
    m.add_function(wrap_pyfunction!(
        mixed_neo_hookean::mixed_neo_hookean_transient_py,
        m
    )?)?;
    m.add_function(wrap_pyfunction!(modal::modal_analysis, m)?)?;
    m.add_function(wrap_pyfunction!(scene::run_scene, m)?)?;
    m.add_function(wrap_pyfunction!(post::estimate_error, m)?)?;
    m.add_function(wrap_pyfunction!(post::model_advice, m)?)?;
    m.add_function(wrap_pyfunction!(matrices::stiffness_matrix, m)?)?;
    m.add_function(wrap_pyfunction!(matrices::mass_matrix, m)?)?;
    m.add("STATIC_TIME", tetfem::bc::amplitude::STATIC_TIME)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
