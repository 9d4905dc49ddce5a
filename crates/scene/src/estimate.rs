//! The run's self-estimated discretization error, for the summaries and the `.vtu` files.

use tetfem::base::error::Result;
use tetfem::fe::materials::TetMaterials;
use tetfem::mesh::TetMesh;
use tetfem::post::estimate::{PointwiseElement, estimate_error};

/// What `estimated_error` in a summary means, written into the summary itself.
pub const ESTIMATED_ERROR_DEFINITION: &str = "ZZ estimate (patch-recovered stress) of the \
    relative energy-norm discretization error, eta / sqrt(u_h'K u_h + eta^2); eta^2 = sum over \
    tets of the integral of (s* - s_h):C^-1:(s* - s_h), the .vtu cell field error_indicator is \
    each tet's eta_K (J^1/2)";

/// The ZZ error estimate of one displacement (see [`tetfem::post::estimate`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct EstimatedError {
    /// η / (‖u_h‖_E² + η²)^½: the estimated relative error in the energy norm (dimensionless).
    pub relative: f64,
    /// The global estimate η = (Σ η_K²)^½ (J^½).
    pub eta: f64,
    /// ‖u_h‖_E = (u_hᵀKu_h)^½ (J^½).
    pub energy_norm: f64,
    /// [`ESTIMATED_ERROR_DEFINITION`].
    pub definition: &'static str,
}

/// The estimate of `displacement` (full, node-major) and the per-tet indicators η_K (J^½).
pub fn estimated_error_of<E: PointwiseElement>(
    mesh: &TetMesh<E>,
    materials: &impl TetMaterials,
    displacement: &[f64],
) -> Result<(EstimatedError, Vec<f64>)> {
    let estimate = estimate_error(mesh, materials, displacement)?;
    Ok((
        EstimatedError {
            relative: estimate.relative(),
            eta: estimate.estimate,
            energy_norm: estimate.energy_norm,
            definition: ESTIMATED_ERROR_DEFINITION,
        },
        estimate.indicators,
    ))
}
