//! Writing results: VTK XML unstructured grids for ParaView, written atomically.

mod atomic;
mod vtu;

pub use atomic::write_atomically;
pub use vtu::VtuWriter;
