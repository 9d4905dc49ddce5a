//! What a `Simulation` follows in time: the loads with an amplitude (`Loads.add_*(...,
//! amplitude=...)`) and the supports that move (`Constraints.prescribe*(..., amplitude=...)`,
//! `prescribe_rigid`), as the library's `TimeData` (which the library's transient set-up
//! assembles the system with).

use tetfem::analysis::dynamics::TimeData;

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
