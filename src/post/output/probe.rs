//! Point probes: the displacement and the stress of a solution at a point inside the mesh,
//! from the shape functions of the tet that holds it (not from the nodes around it).
//!
//! A point is located once ([`PointLocation::find`]: the tet and the point's barycentric
//! coordinates in it), then evaluated at any displacement: u(x) = Σᵢ Nᵢ(x) uᵢ over the tet's
//! nodes, σ(x) from ∇u(x) = Σᵢ uᵢ ⊗ ∇Nᵢ(x). The stress is that tet's own (constant in a 4-node
//! tet, linear in a 10-node one); on a face shared by two tets it is the one of the tet the point
//! lies deepest in (the first such tet on a tie), as finite element stress jumps there.

use nalgebra::{Matrix3, Vector3};

use crate::base::error::{Error, Result};
use crate::fe::materials::TetMaterials;
use crate::mesh::{CellType, TetMesh};
use crate::model::TetModels;
use crate::post::estimate::PointwiseElement;
use crate::post::estimate::recovery::{corners_of, gather, hooke};

/// How far outside a tet (in barycentric coordinates, a fraction of the tet's size) a point may
/// lie and still count as in it: points on a face, an edge or a node computed in floating point
/// land a few ulps outside every tet that holds them, and a coordinate written with 9 or more
/// significant digits should still find its tet.
pub const LOCATION_TOLERANCE: f64 = 1e-9;

/// Where a point lies in a mesh: its tet and its barycentric coordinates L₀…L₃ there (each in
/// [−[`LOCATION_TOLERANCE`], 1 + tolerance], summing to 1; Lᵢ is the weight of corner i).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointLocation {
    /// The index of the tet that holds the point.
    pub tet: usize,
    /// The point's barycentric coordinates in that tet (dimensionless).
    pub barycentric: [f64; 4],
}

impl PointLocation {
    /// Locates `point` (length units) in `mesh`: the tet it lies deepest in (largest smallest
    /// barycentric coordinate). The search visits every tet whose bounding box holds the point
    /// (O(tets): locate once, evaluate many times).
    ///
    /// Errors: `point` is not finite, or lies in no tet (outside the mesh, or in a hole), naming
    /// the point and the mesh's bounding box.
    pub fn find<C: CellType>(mesh: &TetMesh<C>, point: &Vector3<f64>) -> Result<Self> {
        if !point.iter().all(|v| v.is_finite()) {
            return Err(Error::invalid_parameter(
                "point",
                format!("({}, {}, {})", point.x, point.y, point.z),
                "must be finite",
            ));
        }
        let mut best: Option<PointLocation> = None;
        let mut depth = f64::NEG_INFINITY;
        for t in 0..mesh.tet_count() {
            let Some(l) = barycentric_in(&mesh.corner_positions_of(t), point) else {
                continue;
            };
            let smallest = l.iter().copied().fold(f64::INFINITY, f64::min);
            if smallest >= -LOCATION_TOLERANCE && smallest > depth {
                depth = smallest;
                best = Some(PointLocation {
                    tet: t,
                    barycentric: l,
                });
            }
        }
        best.ok_or_else(|| {
            let (lo, hi) = mesh.bounding_box();
            Error::invalid_parameter(
                "point",
                format!("({}, {}, {})", point.x, point.y, point.z),
                format!(
                    "must lie inside the mesh, but no tet holds it (the mesh spans ({}, {}, {}) to ({}, {}, {}))",
                    lo.x, lo.y, lo.z, hi.x, hi.y, hi.z
                ),
            )
        })
    }

    /// The displacement u(x) = Σᵢ Nᵢ(x) uᵢ at the point (length units) for the node-major
    /// `displacement` of `mesh` (the mesh it was located in).
    ///
    /// Errors: `displacement` does not hold 3 values per node, or the location's tet is not
    /// one of `mesh`'s.
    pub fn displacement<E: PointwiseElement>(
        &self,
        mesh: &TetMesh<E>,
        displacement: &[f64],
    ) -> Result<Vector3<f64>> {
        let element = self.element(mesh, displacement)?;
        let mut n = vec![0.0; E::NODES];
        E::shape_values_at(&self.barycentric, &mut n);
        Ok((0..E::NODES)
            .map(|i| Vector3::new(element[3 * i], element[3 * i + 1], element[3 * i + 2]) * n[i])
            .sum())
    }

    /// The linear-elastic Cauchy stress σ = λ tr(ε) I + 2με at the point (stress units), from
    /// the tet's material and ε = ½(∇u + ∇uᵀ) of its shape functions there.
    ///
    /// Errors: as [`displacement`](Self::displacement), or `materials` does not cover the tets.
    pub fn stress<E: PointwiseElement>(
        &self,
        mesh: &TetMesh<E>,
        materials: &impl TetMaterials,
        displacement: &[f64],
    ) -> Result<Matrix3<f64>> {
        materials.check_tet_count(mesh)?;
        let gradient = self.gradient(mesh, displacement)?;
        Ok(hooke(materials.material_of(self.tet), &gradient))
    }

    /// `model`'s Cauchy stress σ(F) at the point (stress units), F = I + ∇u of the tet's shape
    /// functions there ([`ConstitutiveLaw::cauchy`](crate::model::ConstitutiveLaw::cauchy)).
    ///
    /// Errors: as [`displacement`](Self::displacement), or `model` does not cover the tets.
    pub fn model_stress<E: PointwiseElement>(
        &self,
        mesh: &TetMesh<E>,
        model: &(impl TetModels + ?Sized),
        displacement: &[f64],
    ) -> Result<Matrix3<f64>> {
        model.check_covers(mesh.tet_count())?;
        let gradient = self.gradient(mesh, displacement)?;
        Ok(model
            .model_of(self.tet)
            .cauchy(&(Matrix3::identity() + gradient)))
    }

    /// The displacement gradient ∇u at the point (dimensionless).
    fn gradient<E: PointwiseElement>(
        &self,
        mesh: &TetMesh<E>,
        displacement: &[f64],
    ) -> Result<Matrix3<f64>> {
        let element = self.element(mesh, displacement)?;
        Ok(E::displacement_gradient_at(
            &corners_of(mesh, self.tet),
            &self.barycentric,
            &element,
        ))
    }

    /// The tet's node-major element displacement, after checking the lengths and the tet.
    fn element<E: PointwiseElement>(
        &self,
        mesh: &TetMesh<E>,
        displacement: &[f64],
    ) -> Result<Vec<f64>> {
        Error::check_len("displacement", mesh.dof_count(), displacement.len())?;
        if self.tet >= mesh.tet_count() {
            return Err(Error::invalid_parameter(
                "PointLocation.tet",
                self.tet,
                format!(
                    "must be a tet of the mesh (it has {}): locate the point in this mesh",
                    mesh.tet_count()
                ),
            ));
        }
        let mut element = vec![0.0; 3 * E::NODES];
        gather(mesh, self.tet, displacement, &mut element);
        Ok(element)
    }
}

/// The barycentric coordinates of `point` in the straight-sided tet of `corners`, or `None`
/// when the point is outside the tet's bounding box (so cannot be in it) or the tet is
/// degenerate.
fn barycentric_in(corners: &[Vector3<f64>; 4], point: &Vector3<f64>) -> Option<[f64; 4]> {
    let (mut lo, mut hi) = (corners[0], corners[0]);
    for c in &corners[1..] {
        lo = lo.inf(c);
        hi = hi.sup(c);
    }
    // The box grown by the location tolerance (relative to its size), as the test below.
    let margin = (hi - lo) * LOCATION_TOLERANCE;
    if (0..3).any(|a| point[a] < lo[a] - margin[a] || point[a] > hi[a] + margin[a]) {
        return None;
    }
    let shape = Matrix3::from_columns(&[
        corners[1] - corners[0],
        corners[2] - corners[0],
        corners[3] - corners[0],
    ]);
    let b = shape.try_inverse()? * (point - corners[0]);
    Some([1.0 - b.x - b.y - b.z, b.x, b.y, b.z])
}

/// The displacement (length units) and the linear-elastic Cauchy stress (stress units) of the
/// node-major `displacement` at `point` (length units), from the shape functions of the tet
/// that holds it ([`PointLocation`]): exact for any field the element represents (linear for
/// 4-node tets, quadratic with linear stress for 10-node ones).
///
/// Errors: `point` is outside the mesh or not finite; `displacement` or `materials` do not
/// match the mesh.
pub fn evaluate_at_point<E: PointwiseElement>(
    mesh: &TetMesh<E>,
    displacement: &[f64],
    materials: &impl TetMaterials,
    point: &Vector3<f64>,
) -> Result<(Vector3<f64>, Matrix3<f64>)> {
    Error::check_len("displacement", mesh.dof_count(), displacement.len())?;
    materials.check_tet_count(mesh)?;
    let location = PointLocation::find(mesh, point)?;
    Ok((
        location.displacement(mesh, displacement)?,
        location.stress(mesh, materials, displacement)?,
    ))
}
