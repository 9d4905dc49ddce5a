//! Writing results: VTK XML unstructured grids for ParaView, `.pvd` collections of frames, CSV
//! time series and derived fields, all written atomically.

mod atomic;
mod csv;
pub mod fields;
mod frame;
mod pvd;
mod vtu;

pub use atomic::write_atomically;
pub use csv::CsvSeries;
pub use frame::{write_model_result_vtu, write_result_vtu};
pub use pvd::PvdCollection;
pub use vtu::VtuWriter;
