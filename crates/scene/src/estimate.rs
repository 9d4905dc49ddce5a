//! The run's self-estimated discretization error, for the summaries and the `.vtu` files.

use tetfem::base::error::Result;
use tetfem::fe::materials::TetMaterials;
use tetfem::mesh::TetMesh;
use tetfem::model::ModelMap;
use tetfem::post::estimate::{PointwiseElement, Recovery, estimate_error, estimate_map_error};

/// What `estimated_error` in a summary means, written into the summary itself.
pub const ESTIMATED_ERROR_DEFINITION: &str = "ZZ estimate (patch-recovered stress) of the \
    relative energy-norm discretization error, eta / sqrt(u_h'K u_h + eta^2); eta^2 = sum over \
    tets of the integral of (s* - s_h):C^-1:(s* - s_h), the .vtu cell field error_indicator is \
    each tet's eta_K (J^1/2)";

/// [`ESTIMATED_ERROR_DEFINITION`] for a run with a nonlinear model.
pub const MODEL_ESTIMATED_ERROR_DEFINITION: &str = "ZZ estimate (patch-recovered second \
    Piola-Kirchhoff stress S of the run's model) of the relative error of the Green strain in the \
    energy norm, eta / sqrt(int S_h:C^-1:S_h + eta^2); eta^2 = sum over tets of the integral of \
    (S* - S_h):C^-1:(S* - S_h), C the rest elasticity, the .vtu cell field error_indicator is \
    each tet's eta_K (J^1/2)";

/// The ZZ error estimate of one displacement (see [`tetfem::post::estimate`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct EstimatedError {
    /// η / (‖u_h‖_E² + η²)^½: the estimated relative error in the energy norm (dimensionless).
    pub relative: f64,
    /// The global estimate η = (Σ η_K²)^½ (J^½).
    pub eta: f64,
    /// ‖u_h‖_E = (u_hᵀKu_h)^½ (J^½); for a nonlinear model (∫ S_h : C⁻¹ : S_h dV)^½.
    pub energy_norm: f64,
    /// [`ESTIMATED_ERROR_DEFINITION`] or [`MODEL_ESTIMATED_ERROR_DEFINITION`].
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

/// [`estimated_error_of`] for a run with the force models of `models`: the linear model's
/// estimate when every material takes the linear model, the estimate on the second
/// Piola–Kirchhoff stress otherwise (see [`tetfem::post::estimate::model`]).
pub fn model_estimated_error_of<E: PointwiseElement>(
    mesh: &TetMesh<E>,
    models: &ModelMap,
    displacement: &[f64],
) -> Result<(EstimatedError, Vec<f64>)> {
    if models.is_linear() {
        return estimated_error_of(mesh, models.materials(), displacement);
    }
    let estimate = estimate_map_error(mesh, models, displacement, Recovery::PatchRecovery)?;
    Ok((
        EstimatedError {
            relative: estimate.relative(),
            eta: estimate.estimate,
            energy_norm: estimate.energy_norm,
            definition: MODEL_ESTIMATED_ERROR_DEFINITION,
        },
        estimate.indicators,
    ))
}
