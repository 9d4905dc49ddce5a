//! What a static solution gives on demand, by the definition's model: the stresses of every
//! tet and the recovery estimate of the error. They live in `post` (a later room than
//! `analysis`) because they use the stress fields and the estimator.

use nalgebra::Matrix3;

use crate::analysis::static_analysis::Static;
use crate::base::error::{Error, Result};
use crate::model::ModelElement;
use crate::post::estimate::{ErrorEstimate, PointwiseElement, estimate_error};
use crate::post::output::fields::{cell_model_stress, cell_stress};

impl<C: ModelElement> Static<'_, C> {
    /// The Cauchy stress of every tet (Pa, at its centroid or mean over its quadrature
    /// points) of the definition's model at the displacement `u`: the linear model's σ = C:ε
    /// straight from u (the force-model route forms x = X + u and takes u = x − X back, which
    /// costs digits, ~1e-11 relative in σ_vM on a steel beam), a nonlinear model's own.
    pub fn stresses(&self, u: &[f64]) -> Result<Vec<Matrix3<f64>>> {
        let d = self.definition();
        match d.model.is_linear() {
            true => cell_stress(&d.mesh, &d.materials, u),
            false => cell_model_stress(&d.mesh, self.model(), u),
        }
    }

    /// The von Mises stress of every tet (Pa) of [`stresses`](Self::stresses).
    pub fn von_mises(&self, u: &[f64]) -> Result<Vec<f64>> {
        Ok(self
            .stresses(u)?
            .iter()
            .map(crate::fe::element::von_mises)
            .collect())
    }
}

impl<C: ModelElement + PointwiseElement> Static<'_, C> {
    /// The recovery (ZZ) estimate of the energy-norm error of the solution `u`
    /// ([`estimate_error`]). It recovers the linear model's stress σ = C:ε, so it applies to
    /// the linear model only: for a nonlinear model (whose stress is not linear in ε) it is
    /// [`Error::InvalidParameter`] naming the model.
    pub fn estimated_error(&self, u: &[f64]) -> Result<ErrorEstimate> {
        let d = self.definition();
        if !d.model.is_linear() {
            return Err(Error::invalid_parameter(
                "model with the estimated error",
                d.model.name(),
                "the recovery estimate recovers the linear model's stress σ = C:ε and its \
                 energy norm; a large-deformation model's stress is not linear in ε (estimate \
                 the linear model's solution on the same mesh)",
            ));
        }
        estimate_error(&d.mesh, &d.materials, u)
    }
}
