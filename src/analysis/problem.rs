//! The problem set-up every analysis shares, written once: the mesh, the constraints' free-DOF
//! numbering (checked to hold every rigid-body mode), the assembly pattern and the restriction
//! of matrices on it to the free DOFs.
//!
//! The materials are not stored: the linear analyses pass them (one [`Material`](crate::Material)
//! or a [`MaterialMap`](crate::fe::materials::MaterialMap)) to the matrix builders, and the
//! nonlinear ones hold them inside their force models
//! ([`ModelMap`](crate::model::ModelMap)), so one set-up serves both.
//!
//! [`StaticSolver`](crate::analysis::statics::StaticSolver), [`solve_nonlinear_static`](crate::analysis::nonlinear::solve_nonlinear_static)
//! and [`LinearSystem::new`](crate::analysis::dynamics::LinearSystem::new) build from it; what they add is
//! their own analysis. The integrators' nonlinear force
//! ([`NonlinearForce`](crate::analysis::dynamics::NonlinearForce)) takes its pattern and restriction from
//! the same set-up (`Problem::with_dofs`) on the DOF map of the system it acts on.

use std::sync::Arc;
use std::time::{Duration, Instant};

use nalgebra::Vector3;

use crate::base::error::{Error, Result};
use crate::bc::constraints::{Constraints, DofMap, Restriction, ensure_held};
use crate::bc::loads::Loads;
use crate::fe::assembly::{Assembler, lumped_mass_of};
use crate::fe::element::{ElementType, Tet4};
use crate::fe::materials::TetMaterials;
use crate::mesh::{CellType, TetMesh};
use crate::sparse::CscMatrix;

/// Mesh, free DOFs, assembly pattern and free-DOF restriction of one problem.
///
/// Units: those of the mesh (length) and the materials passed in (stress, density); matrices
/// built from it are in force/length (K) and mass (M).
#[derive(Debug)]
pub struct Problem<'a, E: ElementType = Tet4> {
    mesh: &'a TetMesh<E>,
    dofs: DofMap,
    assembler: Assembler,
    restriction: Restriction,
    pattern_time: Duration,
    constraints_time: Duration,
}

impl<'a, E: ElementType> Problem<'a, E> {
    /// Checks that `constraints` are made for the mesh's DOFs, numbers the free DOFs, checks
    /// that the constraints hold every rigid-body mode of every connected part
    /// ([`Error::NotConstrained`] otherwise), and builds the assembly pattern and its
    /// restriction to the free DOFs.
    pub fn new(mesh: &'a TetMesh<E>, constraints: &Constraints) -> Result<Self> {
        ensure_mesh_dofs(mesh, "constraints", constraints.dof_count())?;
        let clock = Instant::now();
        let dofs = DofMap::new(constraints);
        ensure_held(mesh, &mesh.face_topology()?, &dofs)?;
        let checks = clock.elapsed();
        let mut problem = Self::with_dofs(mesh, dofs)?;
        problem.constraints_time += checks;
        Ok(problem)
    }

    /// The assembly pattern and its restriction to the free DOFs of `dofs`, a numbering made
    /// already (a [`LinearSystem`](crate::analysis::dynamics::LinearSystem)'s, whose rigid-mode check
    /// [`new`](Self::new) did when the system was built; not repeated here).
    ///
    /// Errors: `dofs` is not a numbering of this mesh's DOFs.
    pub(crate) fn with_dofs(mesh: &'a TetMesh<E>, dofs: DofMap) -> Result<Self> {
        ensure_mesh_dofs(mesh, "DOF map", dofs.full_count())?;
        let clock = Instant::now();
        let assembler = Assembler::new(mesh);
        let pattern_time = clock.elapsed();
        let clock = Instant::now();
        let restriction = dofs.restriction(assembler.pattern())?;
        Ok(Problem {
            mesh,
            dofs,
            assembler,
            restriction,
            pattern_time,
            constraints_time: clock.elapsed(),
        })
    }

    /// The mesh.
    pub fn mesh(&self) -> &'a TetMesh<E> {
        self.mesh
    }

    /// The free/constrained DOF numbering.
    pub fn dofs(&self) -> &DofMap {
        &self.dofs
    }

    /// The assembly pattern and scatter map.
    pub fn assembler(&self) -> &Assembler {
        &self.assembler
    }

    /// The restriction of matrices on the assembly pattern to the free DOFs.
    pub fn restriction(&self) -> &Restriction {
        &self.restriction
    }

    /// Wall time of the pattern build and of the constraint set-up (numbering, rigid-mode
    /// check, restriction).
    pub fn timings(&self) -> (Duration, Duration) {
        (self.pattern_time, self.constraints_time)
    }

    /// The full linear stiffness K (force/length), each tet with its own material.
    ///
    /// Errors (here and in the other builders): `materials` do not cover the mesh's tets.
    pub fn stiffness(&self, materials: &impl TetMaterials) -> Result<CscMatrix> {
        self.assembler.stiffness(self.mesh, materials)
    }

    /// A zero matrix on the full assembly pattern (for refilled tangents).
    pub fn zero_matrix(&self) -> Result<CscMatrix> {
        Ok(CscMatrix::zeros(Arc::clone(self.assembler.pattern()))?)
    }

    /// A zero matrix on the free-DOF pattern.
    pub fn zero_free_matrix(&self) -> Result<CscMatrix> {
        Ok(CscMatrix::zeros(Arc::clone(self.restriction.pattern()))?)
    }

    /// A_ff of a matrix on the full pattern.
    pub fn restrict(&self, full: &CscMatrix) -> Result<CscMatrix> {
        self.restriction.restrict(full)
    }

    /// The full consistent mass (mass units), every DOF.
    pub fn consistent_mass(&self, materials: &impl TetMaterials) -> Result<CscMatrix> {
        self.assembler.consistent_mass(self.mesh, materials)
    }

    /// The consistent mass restricted to the free DOFs (mass units), on the pattern of K_ff.
    pub fn free_consistent_mass(&self, materials: &impl TetMaterials) -> Result<CscMatrix> {
        self.restriction
            .restrict(&self.assembler.consistent_mass(self.mesh, materials)?)
    }

    /// The lumped mass of the free DOFs (mass units), ρₑVₑ/4 per node of each tet.
    pub fn free_lumped_mass(&self, materials: &impl TetMaterials) -> Result<Vec<f64>> {
        self.dofs.restrict(&lumped_mass_of(self.mesh, materials)?)
    }

    /// Gravity `gravity` (acceleration) as nodal loads ρₑ·g·Vₑ/4, all DOFs.
    pub fn gravity_loads(
        &self,
        materials: &impl TetMaterials,
        gravity: Vector3<f64>,
    ) -> Result<Loads> {
        let mut loads = Loads::new(self.mesh);
        loads.add_gravity(self.mesh, materials, gravity)?;
        Ok(loads)
    }

    /// The DOF numbering, consuming the problem.
    pub fn into_dofs(self) -> DofMap {
        self.dofs
    }

    /// The assembly pattern and the free-DOF restriction, consuming the problem: what a force
    /// law that outlives the mesh borrow keeps.
    pub(crate) fn into_assembly(self) -> (Assembler, Restriction) {
        (self.assembler, self.restriction)
    }
}

/// [`Error::InvalidParameter`] naming `what` (constraints, a DOF map) unless it has `count` =
/// the mesh's DOF count, 3 per node.
pub(crate) fn ensure_mesh_dofs<C: CellType>(
    mesh: &TetMesh<C>,
    what: &str,
    count: usize,
) -> Result<()> {
    if count != mesh.dof_count() {
        return Err(Error::invalid_parameter(
            what,
            format!("{count} DOFs"),
            format!("must be made for this mesh ({} DOFs)", mesh.dof_count()),
        ));
    }
    Ok(())
}
