//! The largest element rotation and strain of a displacement, and the linear model's expected
//! error at that rotation.
//!
//! The linear (Cauchy) strain ε = ½(∇u + ∇uᵀ) is not invariant under rotation: a rotation by θ
//! reads as a strain of order θ²/2 and the model misses the geometric stiffening and the
//! swing of a bent tip back toward its support. The error this causes was measured once on
//! the cantilever (below) as a function of the largest element rotation the *linear* solution
//! shows; a run looks up its own largest rotation there.

use nalgebra::Matrix3;

use crate::base::error::{Error, Result};
use crate::mesh::TetMesh;
use crate::model::rotation;
use crate::post::estimate::PointwiseElement;

/// The linear model's relative error in the tip displacement vector against the corotational
/// model, ‖u_lin − u_corot‖ / ‖u_corot‖ at the tip, as a function of the largest element
/// rotation (degrees) of the linear solution: (rotation°, error) pairs, rotation ascending.
///
/// Measured on the peer cantilever (L = 10, W = H = 1, E = 1e5, ν = 0.3, 20×2×2 cells of the
/// lecture's split, clamped at x = 0, uniform end traction) by
/// `model_choice_curve` in `tests/core/model_adequacy.rs`, which prints the whole table (run it
/// with `--ignored --nocapture`); `curve_points_are_reproduced` there recomputes two points
/// and checks them against this table. The error grows about linearly with the rotation
/// (≈ (2/5)·θ in radians: the tip's missing swing), so between points it is interpolated
/// linearly, below the first point proportionally to the rotation, and beyond the last point
/// it is extrapolated along the last segment.
pub const LINEAR_MODEL_ERROR_CURVE: [(f64, f64); 8] = [
    (1.00, 0.0069),
    (2.00, 0.0137),
    (5.00, 0.0343),
    (10.00, 0.0691),
    (15.00, 0.1053),
    (20.00, 0.1442),
    (25.01, 0.1868),
    (30.01, 0.2347),
];

/// Expected error of the linear model above which a run is warned (5 %): past it the model's
/// error is larger than a typical mesh's discretization error.
pub const LINEAR_MODEL_ERROR_THRESHOLD: f64 = 0.05;

/// Largest strain (the largest |principal value| of the Biot strain U − I) above which the suggested model is
/// Neo-Hookean rather than corotational (5 %): beyond it Hooke's law on a small strain is no
/// longer the material law, only rotations are handled by the corotational model.
pub const LARGE_STRAIN: f64 = 0.05;

/// The linear model's expected relative error at the largest element rotation `degrees`
/// (dimensionless), from [`LINEAR_MODEL_ERROR_CURVE`]; NaN for a NaN rotation.
pub fn linear_model_error(degrees: f64) -> f64 {
    let curve = &LINEAR_MODEL_ERROR_CURVE;
    let (first, last) = (curve[0], curve[curve.len() - 1]);
    if degrees.is_nan() {
        return f64::NAN;
    }
    if degrees <= first.0 {
        return first.1 * degrees.max(0.0) / first.0;
    }
    let segment = curve
        .windows(2)
        .find(|w| degrees <= w[1].0)
        .map_or([curve[curve.len() - 2], last], |w| [w[0], w[1]]);
    let [(x0, y0), (x1, y1)] = segment;
    y0 + (y1 - y0) * (degrees - x0) / (x1 - x0)
}

/// The largest rotation and strain of a displacement over the tets of a mesh.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Deformation {
    /// The largest element rotation (degrees): the angle of R in the polar decomposition
    /// F = R·U of F = I + ∇u at the tet's centroid.
    pub max_rotation_deg: f64,
    /// The tet where it occurs.
    pub rotation_tet: usize,
    /// The largest |principal value| of the Biot strain U − I at a tet's centroid
    /// (dimensionless): the stretch with the rotation taken out, so that a rigid rotation
    /// reads as zero (the linear strain would read 1 − cos θ).
    pub max_strain: f64,
    /// The tet where it occurs.
    pub strain_tet: usize,
}

impl Deformation {
    /// The linear model's expected error at this rotation ([`linear_model_error`]).
    pub fn linear_model_error(&self) -> f64 {
        linear_model_error(self.max_rotation_deg)
    }

    /// [`Warning::LinearModelRotation`](crate::base::warning::Warning::LinearModelRotation) when
    /// [`suggested_model`](Self::suggested_model) names one.
    pub fn warning(&self) -> Option<crate::base::warning::Warning> {
        self.suggested_model()
            .map(|model| crate::base::warning::Warning::LinearModelRotation {
                max_rotation_deg: self.max_rotation_deg,
                tet: self.rotation_tet,
                expected_error: self.linear_model_error(),
                suggested_model: model,
            })
    }

    /// The model a scene should use when the linear model's expected error passes
    /// [`LINEAR_MODEL_ERROR_THRESHOLD`] (`"corotational"`, or `"neo-hookean"` when the strain
    /// itself passes [`LARGE_STRAIN`]); `None` when the linear model is enough.
    pub fn suggested_model(&self) -> Option<&'static str> {
        let error = self.linear_model_error();
        if error.is_nan() || error > LINEAR_MODEL_ERROR_THRESHOLD {
            Some(if self.max_strain > LARGE_STRAIN {
                "neo-hookean"
            } else {
                "corotational"
            })
        } else {
            None
        }
    }
}

/// The rotation angle (degrees) of a rotation matrix: acos((tr R − 1)/2).
fn angle_deg(r: &Matrix3<f64>) -> f64 {
    ((r.trace() - 1.0) * 0.5)
        .clamp(-1.0, 1.0)
        .acos()
        .to_degrees()
}

/// The largest element rotation and strain of `displacement` (node-major, 3 per node) on
/// `mesh`, each tet evaluated at its centroid. O(tets).
///
/// Errors: `displacement` does not hold 3 values per node; the mesh has no tets.
pub fn largest_rotation_and_strain<E: PointwiseElement>(
    mesh: &TetMesh<E>,
    displacement: &[f64],
) -> Result<Deformation> {
    Error::check_len("displacement", mesh.dof_count(), displacement.len())?;
    let mut result = Deformation {
        max_rotation_deg: 0.0,
        rotation_tet: 0,
        max_strain: 0.0,
        strain_tet: 0,
    };
    let mut element = vec![0.0; 3 * E::NODES];
    let centroid = [0.25; 4];
    for t in 0..mesh.tet_count() {
        crate::post::estimate::recovery::gather(mesh, t, displacement, &mut element);
        let corners = crate::post::estimate::recovery::corners_of(mesh, t);
        let gradient = E::displacement_gradient_at(&corners, &centroid, &element);
        let f = Matrix3::identity() + gradient;
        let r = rotation(&f);
        let theta = angle_deg(&r);
        // NaN compares false with everything: taken explicitly, so that a NaN displacement
        // shows as a NaN rotation, never as a silent zero.
        if theta.is_nan() || theta > result.max_rotation_deg {
            result.max_rotation_deg = theta;
            result.rotation_tet = t;
        }
        let stretch = r.transpose() * f;
        let strain = (stretch + stretch.transpose()) * 0.5 - Matrix3::identity();
        let largest = strain
            .symmetric_eigenvalues()
            .iter()
            .fold(0.0, |a: f64, v| a.max(v.abs()));
        if largest.is_nan() || largest > result.max_strain {
            result.max_strain = largest;
            result.strain_tet = t;
        }
    }
    Ok(result)
}
