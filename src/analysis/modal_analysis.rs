//! The modal analysis of a [`Definition`]: the lowest natural modes K·φ = ω²·M·φ of the
//! constrained body about its rest state (the linear model's K, every model's tangent at rest),
//! by subspace iteration ([`lowest_modes`]).

use crate::analysis::dynamics::{LinearSystem, MassKind, Rayleigh};
use crate::analysis::modal::{Modes, effective_mass_fractions, lowest_modes};
use crate::base::error::Result;
use crate::base::warning::Warning;
use crate::fe::assembly::lumped_mass_of;
use crate::fe::element::ElementType;
use crate::fe::element::Tet4;

use super::combination::Analysis;
use super::definition::Definition;

/// The result of [`Modal::solve`].
#[derive(Debug, Clone, PartialEq)]
pub struct ModalOutcome {
    /// The modes, lowest first (ω in rad/s, shapes on the free DOFs, mass-orthonormal).
    pub modes: Modes,
}

/// The modal analysis of one [`Definition`]: [`new`](Self::new) checks the combination (a
/// nonlinear model or obstacles are the library's named errors) and assembles K and M,
/// [`solve`](Self::solve) finds the modes.
///
/// ```
/// use tetfem::analysis::{Definition, Modal, dynamics::MassKind};
/// use tetfem::nalgebra::Vector3;
/// use tetfem::{BoxSplit, Constraints, Material, MaterialMap, TetMesh};
/// # fn main() -> tetfem::Result<()> {
/// // A 1 m steel cantilever, 0.1 m square section, clamped at x = 0.
/// let size = Vector3::new(1.0, 0.1, 0.1);
/// let mesh = TetMesh::box_grid(Vector3::zeros(), size, [20, 2, 2], BoxSplit::Mirrored6)?;
/// let steel = MaterialMap::uniform(Material::new(200e9, 0.3, 7850.0)?, mesh.tet_count());
/// let mut constraints = Constraints::new(&mesh);
/// constraints.fix_nodes(&mesh.nodes_on_plane(0, 0.0, 1e-9))?;
/// let beam = Definition::builder(mesh, steel).constraints(constraints)?.build()?;
/// let modes = Modal::new(&beam, MassKind::Lumped)?.solve(2)?.modes;
/// // Euler–Bernoulli's first bending frequency, 1.875²/(2π)·√(EI/(ρAL⁴)) = 81.5 Hz: linear
/// // tets on this coarse mesh are stiffer (shear locking), never softer by more than the
/// // beam's shear deformation (~1 %).
/// let f1 = modes.omega[0] / (2.0 * std::f64::consts::PI);
/// let euler_bernoulli = 1.875f64.powi(2) / (2.0 * std::f64::consts::PI)
///     * (200e9 * 0.1f64.powi(4) / 12.0 / (7850.0 * 0.01)).sqrt();
/// assert!(f1 > 0.98 * euler_bernoulli && f1 < 2.0 * euler_bernoulli, "{f1} Hz");
/// # Ok(()) }
/// ```
#[derive(Debug)]
pub struct Modal<'a, C: ElementType = Tet4> {
    definition: &'a Definition<C>,
    system: LinearSystem,
    warnings: Vec<Warning>,
}

impl<'a, C: ElementType> Modal<'a, C> {
    /// The analysis of `definition` with the mass matrix `mass` (lumped or consistent).
    ///
    /// Errors: [`Error::InvalidParameter`](crate::Error::InvalidParameter) naming the pair the
    /// combination rule refuses (a nonlinear model, obstacles: [`Definition::check`]); those of
    /// the assembly (constraints leaving a rigid mode, parts of another mesh).
    pub fn new(definition: &'a Definition<C>, mass: MassKind) -> Result<Self> {
        let warnings = definition.check(Analysis::Modal)?;
        // The loads do not enter the eigenproblem; the system carries them as every
        // LinearSystem does.
        let system = LinearSystem::new(
            &definition.mesh,
            &definition.materials,
            &definition.constraints,
            &definition.loads,
            definition.gravity,
            mass,
            Rayleigh::default(),
        )?;
        Ok(Modal {
            definition,
            system,
            warnings,
        })
    }

    /// The combination rule's warnings for this definition.
    pub fn warnings(&self) -> &[Warning] {
        &self.warnings
    }

    /// The assembled system: K_ff, M_ff and the DOF map the mode shapes live on.
    pub fn system(&self) -> &LinearSystem {
        &self.system
    }

    /// The free DOF count: the most modes [`solve`](Self::solve) can find.
    pub fn free_count(&self) -> usize {
        self.system.free_count()
    }

    /// The `count` lowest modes. Errors: those of [`lowest_modes`] (`count` 0 or above the
    /// free DOF count, no convergence).
    pub fn solve(&self, count: usize) -> Result<ModalOutcome> {
        Ok(ModalOutcome {
            modes: lowest_modes(&self.system, count)?,
        })
    }

    /// Each mode's effective modal mass fraction in x, y, z (dimensionless; see
    /// [`effective_mass_fractions`]), from the lumped mass's row sums.
    pub fn effective_mass_fractions(&self, outcome: &ModalOutcome) -> Result<Vec<[f64; 3]>> {
        let row_sums = lumped_mass_of(&self.definition.mesh, &self.definition.materials)?;
        effective_mass_fractions(&outcome.modes, self.system.dofs(), &row_sums)
    }
}
