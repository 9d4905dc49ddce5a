//! The ZZ estimate of a run with a nonlinear force model: the same recovery and the same
//! metric as the linear estimate ([`super`]), on the model's own stress.
//!
//! The stress measure is the second Piola–Kirchhoff stress S = F⁻¹·P(F) (stress units,
//! symmetric for every model here), the work conjugate of the Green strain
//! E = ½(FᵀF − I): both are unchanged by a rigid rotation of the deformed body, so a body that
//! turns far without straining has no error to estimate — unlike σ or P, whose rotation with
//! the body would read as an error wherever the recovered field lags it. Per tet K
//!
//! η_K² = ∫_K (S* − S_h) : C⁻¹ : (S* − S_h) dV,
//!
//! S* recovered at the nodes from the elements' S_h ([`super::Recovery`]), C the tet's linear
//! elasticity at rest. For the St Venant–Kirchhoff model S = C : E exactly, so η_K² is the
//! recovery estimate of ∫_K (E − E_h) : C : (E − E_h) dV, the error of the Green strain in the
//! energy norm; for the other models S = C : E + O(|E|²) and the same holds to that order. The
//! relative estimate divides by (∫ S_h : C⁻¹ : S_h dV + η²)^½.
//!
//! Measured (`tests/core/error_estimate_model.rs`: a manufactured deformation of the unit cube
//! with Green strains up to 8 %, its true error computed from the exact strain): effectivities
//! η / ‖E − E_h‖_C of 0.92 and 0.96–0.97 for P1 on 4³ and 8³ cells, 1.28–1.29 and 1.005–1.018
//! for P2 on 2³ and 4³ cells, for the Neo-Hookean, St Venant–Kirchhoff and corotational models;
//! the same estimate to 7 digits with the whole deformation turned 30° (the small-strain
//! estimate of the same runs moves by 7 %).

use nalgebra::Matrix3;

use super::recovery::{self, StressOf, hooke};
use super::{ErrorEstimate, Recovery, check_displacement, element_indicators, estimate_error_with};
use crate::base::error::{Error, Result};
use crate::fe::element::PointwiseElement;
use crate::fe::materials::TetMaterials;
use crate::mesh::TetMesh;
use crate::model::{ModelMap, TetModels};

/// The estimate of a run with the models of `models`: [`estimate_error_with`] when every
/// material takes the linear model, [`estimate_model_error`] otherwise (each tet's own model's
/// S; a linear region among nonlinear ones is estimated on its model's S = F⁻¹·σ(ε) too, so
/// the recovery across a region boundary compares one stress measure).
///
/// Errors: as those two.
pub fn estimate_map_error<E: PointwiseElement>(
    mesh: &TetMesh<E>,
    models: &ModelMap,
    displacement: &[f64],
    recovery: Recovery,
) -> Result<ErrorEstimate> {
    match models.is_linear() {
        true => estimate_error_with(mesh, models.materials(), displacement, recovery),
        false => estimate_model_error(mesh, models, models.materials(), displacement, recovery),
    }
}

/// The ZZ estimate of `displacement` (node-major, 3 values per node) under the force models of
/// `models` (one for every tet, or a [`ModelMap`]), with the metric of
/// each tet's material in `materials` (see the [module](self) docs). Meant for the nonlinear
/// models: the linear model's own estimate is [`estimate_error_with`] (σ and ε of small
/// strain), which [`estimate_map_error`] picks for it.
///
/// Errors: `displacement` does not hold 3 values per node or a value is not finite;
/// `models` or `materials` do not cover the tets; a tet has no finite S at a point where its
/// stress is sampled (F singular, or P not finite there): the error names the tet and its
/// det F. An inverted tet (det F < 0) has an S under every model here.
pub fn estimate_model_error<E: PointwiseElement>(
    mesh: &TetMesh<E>,
    models: &(impl TetModels + ?Sized),
    materials: &impl TetMaterials,
    displacement: &[f64],
    recovery: Recovery,
) -> Result<ErrorEstimate> {
    check_displacement(mesh, displacement)?;
    models.check_covers(mesh.tet_count())?;
    materials.check_tet_count(mesh)?;
    let inverted = std::cell::Cell::new(None);
    let stress = |t: usize, gradient: &Matrix3<f64>| {
        second_piola(models, t, gradient).unwrap_or_else(|det| {
            inverted.set(inverted.get().or(Some((t, det))));
            // Any finite value: the error below discards the estimate.
            hooke(materials.material_of(t), gradient)
        })
    };
    let recovered = recovered(mesh, displacement, &stress, recovery)?;
    let (indicators, stress_norm) =
        element_indicators(mesh, materials, displacement, &recovered, &stress);
    if let Some((t, det)) = inverted.get() {
        return Err(Error::invalid_parameter(
            format!("tet {t}"),
            format!("det F = {det:e}"),
            "must give a finite second Piola–Kirchhoff stress where the tet's stress is \
             sampled (F invertible, and P finite under the model) to estimate an error from",
        ));
    }
    let estimate = indicators.iter().map(|e| e * e).sum::<f64>().sqrt();
    Ok(ErrorEstimate {
        indicators,
        estimate,
        energy_norm: stress_norm.max(0.0).sqrt(),
    })
}

/// The recovered nodal field of `stress` by the chosen [`Recovery`].
fn recovered<E: PointwiseElement>(
    mesh: &TetMesh<E>,
    displacement: &[f64],
    stress: &StressOf,
    recovery: Recovery,
) -> Result<Vec<Matrix3<f64>>> {
    Ok(match recovery {
        Recovery::Averaging => recovery::averaged_nodal(mesh, displacement, stress),
        Recovery::PatchRecovery => recovery::spr_nodal(mesh, displacement, stress)?,
    })
}

/// S = F⁻¹·P(F) of tet `t`'s model at F = I + ∇u, symmetrized (its skew part is round-off);
/// `Err(det F)` where F is singular or S is not finite.
fn second_piola(
    models: &(impl TetModels + ?Sized),
    t: usize,
    gradient: &Matrix3<f64>,
) -> std::result::Result<Matrix3<f64>, f64> {
    let f = Matrix3::identity() + gradient;
    let det = f.determinant();
    let inverse = f.try_inverse().filter(|_| det != 0.0).ok_or(det)?;
    let s = inverse * models.model_of(t).first_piola(&f);
    match s.iter().all(|v| v.is_finite()) {
        true => Ok((s + s.transpose()) * 0.5),
        false => Err(det),
    }
}
