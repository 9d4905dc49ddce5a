//! `Simulation.reactions()`: the support reactions of a dynamic state, the library's
//! `SupportReactions` (r_c = M·a + C·v − f_int − f_ext on the constrained rows, moving supports
//! and loads with amplitudes at the state's time), as the scene runner reports them each step.

use std::sync::Mutex;

use nalgebra::Vector3;
use tetfem::analysis::dynamics::{InternalForce, LinearSystem, State, SupportReactions, TimeData};
use tetfem::bc::loads::Loads;
use tetfem::fe::materials::MaterialMap;

use crate::mesh::{MeshData, on_cells};

/// What the reactions of a run need beyond its system: the loads it was built with (gravity
/// apart) and its time data; the library's bookkeeping made on the first call, then kept.
pub struct Reactions {
    loads: Loads,
    gravity: Vector3<f64>,
    data: TimeData,
    /// Built on first use (it assembles K's and M's constrained rows once).
    supports: Mutex<Option<SupportReactions>>,
}

impl Reactions {
    /// The reactions of a system built from `loads` (gravity apart), `gravity` (acceleration)
    /// and `data`, exactly as given to `LinearSystem::with_time_data`.
    pub fn new(loads: Loads, gravity: Vector3<f64>, data: TimeData) -> Self {
        Reactions {
            loads,
            gravity,
            data,
            supports: Mutex::new(None),
        }
    }

    /// r on every DOF (force units) at `state` of `system` under `force`, on the mesh of
    /// `mesh` with `materials`: non-zero on the constrained DOFs only.
    pub fn at(
        &self,
        mesh: &MeshData,
        materials: &MaterialMap,
        system: &LinearSystem,
        force: &InternalForce,
        state: &State,
    ) -> tetfem::Result<Vec<f64>> {
        // Held for one evaluation only, by the caller that also holds the run's state lock.
        let mut guard = self
            .supports
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let supports = match guard.take() {
            Some(s) => s,
            None => on_cells!(&mesh.mesh, m => SupportReactions::new(
                system, m, materials, &self.loads, self.gravity, &self.data,
            ))?,
        };
        let supports = guard.insert(supports);
        supports.at(system, force, state)
    }
}
