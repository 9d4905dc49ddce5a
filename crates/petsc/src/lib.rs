//! # tetfem-petsc: PETSc as tetfem's distributed engine
//!
//! Run as `mpirun -n N tetfem-petsc SCENE.toml`: every rank builds the scene (reading the mesh
//! file, or generating the box), METIS splits the tets into N parts ([`partition`]), each rank
//! assembles the stiffness of its own tets into one PETSc `MatMPIAIJ` of block size 3 (no rank
//! holds the global matrix), the constraints are applied per rank by zeroing rows and columns,
//! and PETSc solves with CG + GAMG (the rigid-body near-null space from the owned node
//! coordinates), CG + hypre BoomerAMG or MUMPS's Cholesky (module `engine`, with the feature);
//! a dynamic scene is integrated by backward Euler or Newmark (lumped mass), its system matrix and
//! preconditioner built once. Each rank writes its piece of the parallel `.pvtu` output
//! ([`pvtu`]).
//!
//! The PETSc parts need the cargo feature `petsc` (off by default) and a system PETSc 3.18 with
//! 32-bit `PetscInt`, real double scalars and Open MPI (`build.rs` checks and fails with a
//! message naming what differs). Without the feature the crate holds the partition and the
//! `.vtu` writer only.
//!
//! FFI: the few dozen PETSc and MPI functions used are declared by hand in one module (`ffi`,
//! the crate's only `unsafe` besides the METIS call in [`partition`]), wrapped in types that
//! destroy their PETSc object on drop and cannot outlive the PETSc session.

#![warn(missing_docs)]

#[cfg(feature = "petsc")]
pub mod engine;
pub mod error;
#[cfg(feature = "petsc")]
pub mod ffi;
pub mod partition;
pub mod pvtu;
#[cfg(feature = "petsc")]
pub mod record;

pub use error::{Error, Result};
pub use partition::Partition;
