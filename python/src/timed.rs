//! What a `Simulation` follows in time: the loads with an amplitude (`Loads.add_*(...,
//! amplitude=...)`) and the supports that move (`Constraints.prescribe*(..., amplitude=...)`,
//! `prescribe_rigid`), as the library's `TimeData`, and the system built with it.

use nalgebra::Vector3;
use tetfem::analysis::dynamics::{LinearSystem, MassKind, Rayleigh, TimeData};
use tetfem::bc::loads::Loads;
use tetfem::fe::element::ElementType;
use tetfem::fe::materials::MaterialMap;
use tetfem::mesh::TetMesh;

use crate::constraints::PyConstraints;
use crate::loads::PyLoads;

/// The time data of `loads` (none without) and `constraints`: each load with its amplitude,
/// gravity's own amplitude constant 1 (gravity with an amplitude is one of the loads), and the
/// motions that change in time.
pub fn time_data(loads: Option<&PyLoads>, constraints: &PyConstraints) -> TimeData {
    TimeData {
        loads: loads.map(|l| l.timed.clone()).unwrap_or_default(),
        motion: constraints.moving.clone(),
        ..TimeData::default()
    }
}

/// The system of a run, as the scene runner builds it: with `data` (its loads scaled by a(t)
/// each step, its moving DOFs following their motion), without the rigid-mode check when
/// `free_body` (a body that obstacles may hold). With constant `data` it is
/// `LinearSystem::new` (or `new_free_body`) bit for bit.
#[allow(clippy::too_many_arguments)]
pub fn system<E: ElementType>(
    mesh: &TetMesh<E>,
    materials: &MaterialMap,
    constraints: &tetfem::bc::constraints::Constraints,
    loads: &Loads,
    gravity: Vector3<f64>,
    mass: MassKind,
    damping: Rayleigh,
    data: &TimeData,
    free_body: bool,
) -> tetfem::Result<LinearSystem> {
    match free_body {
        true => LinearSystem::new_free_body_with_time_data(
            mesh,
            materials,
            constraints,
            loads,
            gravity,
            mass,
            damping,
            data,
        ),
        false => LinearSystem::with_time_data(
            mesh,
            materials,
            constraints,
            loads,
            gravity,
            mass,
            damping,
            data,
        ),
    }
}
