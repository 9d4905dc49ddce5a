//! The tetfem application on top of the library: TOML scenes ([`scene`]: parsed, built into the
//! library's objects, run, written), PNG rendering of deformed meshes ([`render`]) and the
//! `tetfem info` report ([`info`]), and the hand-off of a scene to the PETSc engine
//! ([`handoff`]). The `tetfem` command (`src/main.rs`) adds the command line,
//! progress bars and signal handling.

pub mod handoff;
pub mod info;
pub mod render;
pub mod scene;

pub use scene::{Scene, run_static};
