//! Writing results: VTK XML unstructured grids for ParaView, `.pvd` collections of frames and
//! derived fields, all written atomically; CSV time series, streamed row by row; and the lock
//! that gives one run at a time an output folder.

mod csv;
pub mod fields;
mod frame;
mod lock;
mod obstacles;
pub mod probe;
mod pvd;
mod vtu;

pub use crate::base::atomic_file::write_atomically;
pub use csv::{CSV_BUFFER_BYTES, CsvSeries, CsvValue};
pub use frame::{
    ContactFields, FrameArrays, FrameExtras, OriginalIds, model_result_frame_arrays,
    result_frame_arrays, write_model_result_vtu, write_result_frame, write_result_vtu,
    write_static_result_vtu,
};
pub use lock::{LOCK_FILE_NAME, OutputLock, remove_held_lock_files};
pub use obstacles::{ObstacleSurface, obstacle_surface, write_obstacles_vtp};
pub use probe::{PointLocation, evaluate_at_point};
pub use pvd::PvdCollection;
pub use vtu::{VtuFormat, VtuWriter};
