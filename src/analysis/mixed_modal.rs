//! Modal analysis of the linear mixed body, on either mixed element ([`MixedElement`]:
//! Taylor–Hood P2–P1 on 10-node tets, the stabilized P1–P1 on 4-node tets): K_eff·φ = ω²·M·φ
//! with the pressure eliminated exactly, K_eff = K_dev + BᵀC⁻¹B ([`MixedOperator`]; C the
//! element's pressure block, M_p/κ for Taylor–Hood, M_p/κ + (1/μ)(M_p − M_Π) for P1–P1).
//!
//! The subspace iteration of [`modal`](crate::analysis::modal) runs unchanged on a stiffness
//! operator (`modal::StiffnessOperator`) whose solve x = K_eff⁻¹·b is one LDLᵀ solve of the
//! saddle point
//!
//! ```text
//!   ⎡ K_dev,ff   −B_fᵀ ⎤ ⎡x⎤   ⎡b⎤
//!   ⎣ −B_f       −C    ⎦ ⎣p⎦ = ⎣0⎦
//! ```
//!
//! (factored once; quasi-definite for ν < 0.5 once the supports hold every rigid motion), and
//! whose product K_eff·x is K_dev,ff·x − B_fᵀ·p with p = −C⁻¹·B_f·x (a Cholesky solve with the
//! small pressure block). Each mode's pressure is the one its shape implies.

use crate::analysis::dynamics::Mass;
use crate::analysis::mixed_operator::MixedOperator;
use crate::analysis::modal::{Modes, StiffnessOperator, subspace_modes};
use crate::base::error::{Error, Result};
use crate::bc::constraints::Constraints;
use crate::fe::element::MixedElement;
use crate::fe::materials::TetMaterials;
use crate::linalg::QuasiDefiniteLdlt;
use crate::mesh::TetMesh;
use crate::ordering::FillOrdering;
use crate::sparse::CscMatrix;

/// Scaled residual every mixed mode meets (see [`MixedModes::modes`]): ten times the
/// displacement modes' [`RESIDUAL_TOLERANCE`](crate::analysis::modal::RESIDUAL_TOLERANCE),
/// since the product K_eff·φ goes through a solve with C whose error (ε times M_p's
/// condition, a few tens for a P1 mass) the magnitude bound does not contain: measured, the
/// residuals of a ν = 0.4999 beam stall at 1.0–1.3e-13.
pub const MIXED_RESIDUAL_TOLERANCE: f64 = 1e-12;

/// The lowest modes of a mixed body.
#[derive(Debug, Clone, PartialEq)]
pub struct MixedModes {
    /// Frequencies, M-orthonormal shapes on the free DOFs, iterations and the scaled residuals
    /// ‖K_eff·φ − ω²·M·φ‖ / ‖(|K_dev| + |Bᵀ|·|C⁻¹B| + ω²·M)·|φ|‖.
    pub modes: Modes,
    /// Each mode's pressure at every node (Pa per unit of modal amplitude), linear along edges.
    pub pressure: Vec<Vec<f64>>,
    /// Free displacement DOFs.
    pub free_dofs: usize,
}

/// K_eff through the saddle point (see the [module](self) docs).
struct SaddleStiffness<E: MixedElement> {
    operator: MixedOperator<E>,
    system: CscMatrix,
    ldlt: Option<QuasiDefiniteLdlt>,
}

impl<E: MixedElement> StiffnessOperator for SaddleStiffness<E> {
    fn dim(&self) -> usize {
        self.operator.dofs().free_count()
    }

    fn factor(&mut self) -> Result<()> {
        let mut ldlt =
            QuasiDefiniteLdlt::analyze(&self.system, self.dim(), FillOrdering::NestedDissection)?;
        ldlt.factorize(&self.system)?;
        self.ldlt = Some(ldlt);
        Ok(())
    }

    fn solve_in_place(&mut self, b: &mut [f64]) -> Result<()> {
        let n = self.dim();
        let mut x = b.to_vec();
        x.resize(self.system.dim(), 0.0);
        match &mut self.ldlt {
            Some(ldlt) => ldlt.solve_in_place(&mut x)?,
            None => {
                return Err(Error::Solver(
                    "mixed modal analysis: solved before the factorization".into(),
                ));
            }
        }
        b.copy_from_slice(&x[..n]);
        Ok(())
    }

    fn product(&mut self, x: &[f64]) -> Result<Vec<f64>> {
        Ok(self.operator.condensed_product(x)?.0)
    }

    fn product_and_bound(&mut self, x: &[f64]) -> Result<(Vec<f64>, Vec<f64>)> {
        self.operator.condensed_product(x)
    }
}

/// The `count` lowest modes of the mixed body of `mesh` (10-node tets: Taylor–Hood P2–P1;
/// 4-node tets: stabilized P1–P1) with `materials` (ν < 0.5), held by
/// `constraints` (every rigid motion: [`Error::NotConstrained`]), converged as
/// [`lowest_modes`](crate::analysis::modal::lowest_modes) converges, each scaled residual at
/// most [`MIXED_RESIDUAL_TOLERANCE`].
///
/// Errors: `count` not between 1 and the free DOF count; those of the assembly and the LDLᵀ.
pub fn lowest_mixed_modes<E: MixedElement>(
    mesh: &TetMesh<E>,
    materials: &impl TetMaterials,
    constraints: &Constraints,
    count: usize,
) -> Result<MixedModes> {
    // The count is checked before the assembly (the free DOFs are those not constrained).
    let free_dofs = constraints.dof_count().saturating_sub(constraints.count());
    if count == 0 || count > free_dofs {
        return Err(Error::invalid_parameter(
            "mode count",
            count,
            format!("must be between 1 and the free DOF count {free_dofs}"),
        ));
    }
    let operator = MixedOperator::new(mesh, materials, constraints, true)?;
    let mass = Mass::Consistent(operator.mass().clone());
    let mut stiffness = SaddleStiffness {
        system: operator.shifted(0.0),
        operator,
        ldlt: None,
    };
    let modes = subspace_modes(&mut stiffness, &mass, count, MIXED_RESIDUAL_TOLERANCE)?;
    let operator = &mut stiffness.operator;
    let pressure = modes
        .shapes
        .iter()
        .map(|shape| {
            let mut full = vec![0.0; operator.dofs().full_count()];
            for (value, &dof) in shape.iter().zip(operator.dofs().free_dofs()) {
                full[dof] = *value;
            }
            let corner = operator.implied_pressure(&full)?;
            Ok(operator.nodal_pressure(&corner))
        })
        .collect::<Result<_>>()?;
    Ok(MixedModes {
        modes,
        pressure,
        free_dofs,
    })
}
