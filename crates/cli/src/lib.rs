//! The tetfem application on top of the library: the `tetfem info` report ([`info`]) and the
//! hand-off of a scene to the PETSc engine ([`handoff`]); scenes ([`scene`]) and PNG rendering
//! ([`render`]) are the `tetfem-scene` crate's, re-exported here under the names the command
//! has always used. The `tetfem` command (`src/main.rs`) adds the command line, progress bars
//! and signal handling.
#![warn(missing_docs)]

pub mod handoff;
pub mod info;

pub use tetfem_scene as scene;
pub use tetfem_scene::render;
pub use tetfem_scene::{Scene, run_static};
