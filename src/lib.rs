//! # tetfem
//!
//! Elastic solids with the finite element method on 4-node (linear) and 10-node (quadratic)
//! tetrahedra: static equilibrium (linear, or Newton with corotational and hyperelastic force
//! models), time integration (explicit, backward Euler, Newmark), modes, contact with rigid
//! obstacles, error estimates and ParaView output.
//!
//! Where to start:
//! - the book in `docs/` (`mdbook build docs`): getting started, scenes, the library guide,
//!   Python, dynamics, contact, quadratic elements, outputs, theory;
//! - a problem is an [`analysis::Definition`] (mesh, materials, constraints, loads, gravity,
//!   contact) run by an analysis: [`analysis::Static`], [`analysis::Transient`] or
//!   [`analysis::Modal`];
//! - [`prelude`] imports the common path in one line (`use tetfem::prelude::*;`), and the
//!   runnable programs in `examples/` each teach one idea.
//!
//! Below the analyses: element stiffness from the linear (Cauchy) strain and Hooke's law (the
//! linear model; the corotational and hyperelastic models assemble their forces and tangents from
//! the deformation gradient F per quadrature point), one global sparse stiffness K, lumped and
//! consistent mass, Dirichlet constraints eliminated exactly, gravity, nodal and surface loads,
//! and sparse Cholesky solves through [`linalg`].
//!
//! The modules live in rooms, in layer order (a room uses only itself and the rooms before it):
//! [`base`] → [`mesh`] → [`fe`] → [`bc`] → [`model`], [`contact`] → [`analysis`] → [`post`].
//! Data flows one way: mesh → material → element → assembly → analysis (its linear solves
//! through [`linalg`]) → outputs.
//!
//! Conventions: f64 everywhere; DOF `3·node + axis`; units are the caller's but must be
//! consistent (SI in every shipped scene: m, kg, s, N, Pa).
//!
//! ```
//! use tetfem::nalgebra::Vector3;
//! use tetfem::{BoxSplit, Constraints, Loads, Material, TetMesh, solve_static};
//!
//! // A 1 m × 0.1 m × 0.1 m steel bar, clamped at x = 0, pulled by 1 kN at x = 1 m.
//! let mesh = TetMesh::box_grid(Vector3::zeros(), Vector3::new(1.0, 0.1, 0.1), [20, 2, 2], BoxSplit::Lecture6)?;
//! let steel = Material::new(200e9, 0.3, 7850.0)?;
//! let mut constraints = Constraints::new(&mesh);
//! constraints.fix_nodes(&mesh.nodes_on_plane(0, 0.0, 1e-9))?;
//! let end = mesh.faces_on_plane(&mesh.boundary_faces()?, 0, 1.0, 1e-9);
//! let mut loads = Loads::new(&mesh);
//! loads.add_total_force_on_faces(&mesh, &end, Vector3::new(1e3, 0.0, 0.0))?;
//! let solution = solve_static(&mesh, &steel, &constraints, &loads)?;
//! let stretch = solution.displacement[3 * mesh.nodes_on_plane(0, 1.0, 1e-9)[0]];
//! // F·L/(E·A) = 1e3 / (200e9 · 0.01) = 5e-7 m, up to the clamp's lateral restraint.
//! assert!((stretch - 5e-7).abs() < 0.05 * 5e-7);
//! # Ok::<(), tetfem::Error>(())
//! ```
#![warn(missing_docs)]

/// nalgebra, re-exported so that a user's crate needs only `tetfem` in its `Cargo.toml` for the
/// vectors and matrices of the API (`tetfem::nalgebra::Vector3`, or `Vector3` from the prelude).
pub use nalgebra;
pub use tetfem_linalg as linalg;
// The linear algebra under its own names inside this crate (`crate::sparse::CscMatrix`, ...):
// the analyses use it throughout, the public surface has it as `tetfem::linalg`.
pub(crate) use tetfem_linalg::{
    amg, block_sparse, iterative, linear_solver, linsolve, ordering, sparse,
};

pub mod analysis;
pub mod base;
pub mod bc;
pub mod contact;
pub mod fe;
pub mod mesh;
pub mod model;
pub mod post;
pub mod prelude;

pub use analysis::mixed_analysis::{MixedOutcome, solve_static_mixed_model};
pub use analysis::mixed_nonlinear::{MixedNewtonReport, solve_static_mixed_nonlinear};
pub use analysis::mixed_statics::{MixedStaticSolution, MixedStaticSolver, solve_static_mixed};
pub use analysis::problem::Problem;
pub use analysis::statics::{StaticSolution, StaticSolver, solve_static};
pub use base::error::{Error, Result};
pub use bc::constraints::{Constraints, DofMap};
pub use bc::loads::Loads;
pub use fe::assembly::{Assembler, lumped_mass};
pub use fe::element::{ElementType, Tet, Tet4, Tet10};
pub use fe::material::Material;
pub use fe::materials::{MaterialAssignment, MaterialMap, TetMaterials};
pub use linear_solver::{LinearMethod, LinearSolver, SolverOptions};
pub use linsolve::{CholeskyOptions, NumericFactorization, SparseCholesky, TriangularSolve};
pub use mesh::{BoxSplit, CellType, TetMesh};
pub use ordering::FillOrdering;
pub use sparse::CscMatrix;

/// The README's code blocks, compiled and run as doctests so that they stay true.
#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;

#[cfg(test)]
mod readme_tests {
    /// The README's Rust blocks compile as doctests, where tetfem's dev-dependencies are in
    /// scope too; a user's crate has only `tetfem` (the `Cargo.toml` lines the README shows).
    /// So each block may name `tetfem`, `std` and `core` paths only: a `nalgebra::…` path
    /// would compile here and fail in the reader's crate.
    #[test]
    fn readme_rust_blocks_name_no_crate_but_tetfem() {
        let readme = include_str!("../README.md");
        let mut offending = Vec::new();
        let mut in_rust = false;
        for (number, line) in readme.lines().enumerate() {
            let trimmed = line.trim();
            if trimmed.starts_with("```") {
                in_rust = !in_rust && trimmed == "```rust";
                continue;
            }
            let code = trimmed.trim_start_matches("# ");
            if !in_rust {
                continue;
            }
            let named = code
                .strip_prefix("use ")
                .or_else(|| code.strip_prefix("extern crate "))
                .map(|path| path.split([':', ';', ' ', '{']).next().unwrap_or(""));
            let bare_nalgebra = code.contains("nalgebra::") && !code.contains("tetfem::nalgebra::");
            if bare_nalgebra || named.is_some_and(|c| !["tetfem", "std", "core"].contains(&c)) {
                offending.push(format!("README.md:{}: {code}", number + 1));
            }
        }
        assert!(offending.is_empty(), "{offending:#?}");
    }
}
