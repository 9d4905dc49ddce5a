//! Volumetric locking of the displacement elements as Poisson's ratio ν approaches 0.5: the
//! share of the displacement a 4-node or 10-node tet loses to it, measured once on Lamé's
//! tube, so that a run with a nearly incompressible material is told how much it stands to
//! lose and what does not lose it (the mixed displacement–pressure element).
//!
//! As ν → 0.5 the bulk modulus κ = E/(3(1−2ν)) grows without bound while the shear modulus
//! stays: the displacement must become divergence-free, and a tet's few displacement modes
//! cannot all satisfy div u = 0 tet by tet, so the element comes out too stiff. The loss is a
//! property of the element and the mesh, not of the load; the curve below is the measured
//! loss on one mesh that resolves the problem at ν = 0.3 (the tube of
//! `validation/src/bin/locking.rs`, 6 tets' cells through the wall), the way the linear model's
//! rotation error is measured once on the cantilever
//! ([`crate::post::adequacy::rotation::LINEAR_MODEL_ERROR_CURVE`]).

/// The locking loss against ν: (ν, 4-node loss, 10-node loss), ν ascending, each loss
/// 1 − r(ν)/r(0.3), r the radial displacement of the bore of Lamé's thick-walled tube (a = 1 m,
/// b = 2 m, plane strain, internal pressure; `tetfem_fixtures::tube::LameTube`) over the exact
/// value at that ν, on its 6 × 24 × 2 cells of the 6-tet split: the element's accuracy at ν
/// over its accuracy at ν = 0.3 on the same mesh (r = 0.98843 and 0.99933 there: the mesh's
/// own resolution error, which the ratio removes). Measured by `validation/src/bin/locking.rs` (`validation/report/locking.csv`);
/// `tests/core/locking_curve.rs` recomputes every point.
pub const VOLUMETRIC_LOCKING_CURVE: [(f64, f64, f64); 4] = [
    (0.45, 0.02151, 0.000199),
    (0.49, 0.10639, 0.000768),
    (0.499, 0.38049, 0.002385),
    (0.4999, 0.51600, 0.003513),
];

/// The expected share of the displacement (dimensionless, 0–1) a displacement element of
/// `order` (1: 4-node, 2: 10-node tets) loses to volumetric locking at Poisson's ratio
/// `poisson_ratio`, from [`VOLUMETRIC_LOCKING_CURVE`]: interpolated linearly in log(0.5 − ν)
/// (the curve's natural axis: κ/μ grows as 1/(0.5 − ν)), 0 at ν ≤ 0.3, proportional to
/// log((0.5 − 0.3)/(0.5 − ν)) between 0.3 and the first point, and the last point's loss beyond
/// it (a lower bound there: the loss only grows). `None` for another order or a NaN ν.
pub fn expected_locking_loss(poisson_ratio: f64, order: usize) -> Option<f64> {
    let loss = |point: (f64, f64, f64)| match order {
        1 => Some(point.1),
        2 => Some(point.2),
        _ => None,
    };
    let curve = &VOLUMETRIC_LOCKING_CURVE;
    let last = curve[curve.len() - 1];
    if poisson_ratio <= 0.3 {
        return loss(last).map(|_| 0.0);
    }
    if poisson_ratio >= last.0 {
        return loss(last);
    }
    // No loss at ν = 0.3 (the curve's reference), then the measured points.
    let points = std::iter::once((0.3, 0.0, 0.0)).chain(curve.iter().copied());
    let (below, above) = points
        .clone()
        .zip(points.skip(1))
        .find(|(_, above)| poisson_ratio <= above.0)?;
    let axis = |nu: f64| (0.5 - nu).ln();
    let s = (axis(poisson_ratio) - axis(below.0)) / (axis(above.0) - axis(below.0));
    Some(loss(below)? + s * (loss(above)? - loss(below)?))
}
