//! The common path in one import: `use tetfem::prelude::*;`.
//!
//! A mesh, materials (one or per region), constraints and loads; a static solve (linear or
//! Newton with a force model); a dynamic system, an integrator and the explicit critical step.
//!
//! ```
//! use tetfem::prelude::*; // Vector3 too: no other crate is needed
//!
//! // A 1 m steel bar in 20 × 2 × 2 cells, clamped at x = 0, pulled by 1 kN at x = 1 m.
//! let mesh = TetMesh::box_grid(Vector3::zeros(), Vector3::new(1.0, 0.1, 0.1), [20, 2, 2], BoxSplit::default())?;
//! let mut constraints = Constraints::new(&mesh);
//! constraints.fix_nodes(&mesh.nodes_on_plane(0, 0.0, 1e-9))?;
//! let end = mesh.faces_on_plane(&mesh.boundary_faces()?, 0, 1.0, 1e-9);
//! let mut loads = Loads::new(&mesh);
//! loads.add_total_force_on_faces(&mesh, &end, Vector3::new(1e3, 0.0, 0.0))?;
//! let u = solve_static(&mesh, &Material::steel(), &constraints, &loads)?.displacement;
//! // F·L/(E·A) = 1e3 / (200e9 · 0.01) = 5e-7 m, up to the clamp's lateral restraint.
//! let stretch = u[3 * mesh.nodes_on_plane(0, 1.0, 1e-9)[0]];
//! assert!((stretch - 5e-7).abs() < 0.05 * 5e-7);
//! # Ok::<(), tetfem::Error>(())
//! ```

pub use crate::analysis::dynamics::{
    CriticalStep, Integrator, IntegratorOptions, LinearSystem, MassKind, Method, Rayleigh, State,
    critical_time_step,
};
pub use crate::analysis::nonlinear::{NewtonOptions, solve_nonlinear_static};
pub use crate::analysis::problem::Problem;
pub use crate::analysis::statics::{StaticSolution, StaticSolver, solve_static};
pub use crate::base::error::{Error, Result};
pub use crate::bc::constraints::{Constraints, DofMap};
pub use crate::bc::loads::Loads;
pub use crate::fe::material::Material;
pub use crate::fe::materials::{MaterialAssignment, MaterialMap};
pub use crate::mesh::{BoxSplit, TetMesh};
pub use crate::model::ModelKind;
pub use nalgebra::{Matrix3, Vector3};
