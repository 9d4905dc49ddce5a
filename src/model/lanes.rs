//! Arithmetic on four tets side by side, one tet per lane of each operation: the lane types
//! and the 3×3 algebra the force models' four-tet kernels ([`super::corotational_lanes`],
//! [`super::neo_hookean_lanes`]) are written in, and a batch's gathering and force tail.
//!
//! Each operation is the scalar nalgebra one's, in the same order and rounding (no fused
//! multiply-add: Rust never contracts a·b + c), so every lane's result is that tet's scalar
//! result to the bit; compiled inside an AVX2 function, the four lanes of an operation are one
//! instruction.

use nalgebra::Vector3;

use crate::fe::element::{Tet, Vector12};

/// Tets per batch.
pub(crate) const LANES: usize = 4;

/// One value per lane.
pub(crate) type L = [f64; LANES];

/// A 3×3 matrix of lanes, `m[row][column]`.
pub(crate) type M = [[L; 3]; 3];

// Plain loops, not `std::array::from_fn`: its generic helpers are not always inlined into
// the AVX2 copy, and a call per value undoes the lanes.
/// The lanes [f(0), …, f(3)].
#[inline(always)]
pub(crate) fn lanes(f: impl Fn(usize) -> f64) -> L {
    let mut out = [0.0; LANES];
    for (l, out) in out.iter_mut().enumerate() {
        *out = f(l);
    }
    out
}

/// a + b, lane by lane.
#[inline(always)]
pub(crate) fn add(a: L, b: L) -> L {
    lanes(|l| a[l] + b[l])
}

/// a − b, lane by lane.
#[inline(always)]
pub(crate) fn sub(a: L, b: L) -> L {
    lanes(|l| a[l] - b[l])
}

/// a·b, lane by lane.
#[inline(always)]
pub(crate) fn mul(a: L, b: L) -> L {
    lanes(|l| a[l] * b[l])
}

/// a·s, lane by lane (s the same in every lane).
#[inline(always)]
pub(crate) fn scale(a: L, s: f64) -> L {
    lanes(|l| a[l] * s)
}

/// (a₀b₀ + a₁b₁) + a₂b₂: nalgebra's order for a 3-vector's dot product and for each entry of
/// a 3×3 product (its gemm adds the columns' terms in turn).
#[inline(always)]
pub(crate) fn dot3(a: [L; 3], b: [L; 3]) -> L {
    add(add(mul(a[0], b[0]), mul(a[1], b[1])), mul(a[2], b[2]))
}

/// Row i of M.
#[inline(always)]
pub(crate) fn row(m: &M, i: usize) -> [L; 3] {
    m[i]
}

/// Column j of M.
#[inline(always)]
pub(crate) fn column(m: &M, j: usize) -> [L; 3] {
    [m[0][j], m[1][j], m[2][j]]
}

/// A·B.
#[inline(always)]
pub(crate) fn product(a: &M, b: &M) -> M {
    let mut out = [[[0.0; LANES]; 3]; 3];
    for (i, out) in out.iter_mut().enumerate() {
        for (j, out) in out.iter_mut().enumerate() {
            *out = dot3(row(a, i), column(b, j));
        }
    }
    out
}

/// Aᵀ·B (nalgebra's `tr_mul`: each entry the dot product of a column of A and one of B).
#[inline(always)]
pub(crate) fn tr_product(a: &M, b: &M) -> M {
    let mut out = [[[0.0; LANES]; 3]; 3];
    for (i, out) in out.iter_mut().enumerate() {
        for (j, out) in out.iter_mut().enumerate() {
            *out = dot3(column(a, i), column(b, j));
        }
    }
    out
}

/// ‖M‖²_F in nalgebra's order: column by column, ((0 + ‖c₀‖²) + ‖c₁‖²) + ‖c₂‖².
#[inline(always)]
pub(crate) fn norm_squared(m: &M) -> L {
    let mut sum = [0.0; LANES];
    for j in 0..3 {
        sum = add(sum, dot3(column(m, j), column(m, j)));
    }
    sum
}

/// det M by nalgebra's cofactor expansion along the first row.
#[inline(always)]
pub(crate) fn determinant(m: &M) -> L {
    let minor_12_23 = sub(mul(m[1][1], m[2][2]), mul(m[2][1], m[1][2]));
    let minor_11_23 = sub(mul(m[1][0], m[2][2]), mul(m[2][0], m[1][2]));
    let minor_11_22 = sub(mul(m[1][0], m[2][1]), mul(m[2][0], m[1][1]));
    add(
        sub(mul(m[0][0], minor_12_23), mul(m[0][1], minor_11_23)),
        mul(m[0][2], minor_11_22),
    )
}

/// The matrix of lanes whose entry (i, j) in lane l is f(i, j, l).
#[inline(always)]
pub(crate) fn build(f: impl Fn(usize, usize, usize) -> f64) -> M {
    let mut out = [[[0.0; LANES]; 3]; 3];
    for (i, out) in out.iter_mut().enumerate() {
        for (j, out) in out.iter_mut().enumerate() {
            *out = lanes(|l| f(i, j, l));
        }
    }
    out
}

/// The lanes' tets: each one's rest inverse Dm⁻¹ and volume, and its deformed corners.
pub(crate) struct Tets<'a> {
    /// The rest elements.
    pub elements: [&'a Tet; LANES],
    /// The deformed corners x₀…x₃ of each.
    pub corners: &'a [[Vector3<f64>; 4]; LANES],
}

/// The lanes' deformation gradients F = Ds·Dm⁻¹ (Ds = [x₁ − x₀, x₂ − x₀, x₃ − x₀]), their
/// rest inverses Dm⁻¹ and their volumes V, as nalgebra forms F (`rest_shape_matrix(x) *
/// tet.rest_inverse()`).
#[inline(always)]
pub(crate) fn deformation_gradients(tets: &Tets) -> (M, M, L) {
    let x = tets.corners;
    let ds: M = build(|a, i, l| x[l][i + 1][a] - x[l][0][a]);
    let rest_inverse: M = build(|i, j, l| tets.elements[l].rest_inverse()[(i, j)]);
    let volume = lanes(|l| tets.elements[l].volume());
    (product(&ds, &rest_inverse), rest_inverse, volume)
}

/// Each lane's nodal forces from its first Piola–Kirchhoff stress P, as
/// [`super::piola_to_force`] makes them (h = (−P)·Dm⁻ᵀ·V; f₁…₃ the columns of h, f₀ minus
/// their sum), with its energy, into `out`.
#[inline(always)]
pub(crate) fn forces_into(
    piola: &M,
    (rest_inverse, volume): (&M, L),
    energy: L,
    out: &mut [(Vector12, f64); LANES],
) {
    let negated = build(|i, j, l| -piola[i][j][l]);
    let transposed = build(|i, j, l| rest_inverse[j][i][l]);
    let h = product(&negated, &transposed);
    let h = build(|i, j, l| h[i][j][l] * volume[l]);
    for (l, (force, e)) in out.iter_mut().enumerate() {
        *force = Vector12::zeros();
        for i in 0..3 {
            for a in 0..3 {
                force[3 * (i + 1) + a] = h[a][i][l];
                force[a] -= h[a][i][l];
            }
        }
        *e = energy[l];
    }
}

/// Test tets for the four-tet kernels' bit-for-bit tests.
#[cfg(test)]
pub(crate) mod test_tets {
    use nalgebra::{Matrix3, Rotation3, Unit, Vector3};

    use super::LANES;
    use crate::fe::element::{Tet, Vector12};
    use crate::model::ForceModel;

    /// A tet's four corners.
    type Corners = [Vector3<f64>; 4];

    /// A deterministic spread in [−1, 1].
    pub fn wave(k: f64) -> f64 {
        (k * 12.9898).sin() * 0.5 + (k * 78.233).cos() * 0.5
    }

    /// Four tets of batch `batch`: rest elements of many shapes, their rest corners and their
    /// corners deformed by rotations up to 3 rad, stretches up to ±30 % and shifts up to 3;
    /// by (4·batch + lane) mod 9 one tet in nine inverted, one flat and one stretched 6× along
    /// an axis, and batch 7's lane 3 not finite (a NaN corner).
    pub fn batch(batch: usize) -> (Vec<Tet>, [Corners; LANES], [Corners; LANES]) {
        let mut elements = Vec::new();
        let mut rests = [[Vector3::zeros(); 4]; LANES];
        let mut corners = [[Vector3::zeros(); 4]; LANES];
        for lane in 0..LANES {
            let k = (batch * LANES + lane) as f64;
            let rest = [
                Vector3::new(wave(k), wave(k + 0.1), wave(k + 0.2)) * 0.1,
                Vector3::new(
                    1.0 + 0.3 * wave(k + 0.3),
                    0.2 * wave(k + 0.4),
                    0.1 * wave(k + 0.5),
                ),
                Vector3::new(
                    0.2 * wave(k + 0.6),
                    1.0 + 0.3 * wave(k + 0.7),
                    0.1 * wave(k + 0.8),
                ),
                Vector3::new(
                    0.1 * wave(k + 0.9),
                    0.2 * wave(k + 1.0),
                    1.0 + 0.3 * wave(k + 1.1),
                ),
            ];
            let turn = Rotation3::from_axis_angle(
                &Unit::new_normalize(Vector3::new(wave(k + 2.0), wave(k + 2.1), 0.5)),
                3.0 * wave(k + 2.2),
            );
            let mut stretch = Matrix3::identity()
                + Matrix3::from_fn(|i, j| 0.3 * wave(k + 3.0 + (3 * i + j) as f64 * 0.1));
            match (batch * LANES + lane) % 9 {
                0 => stretch[(0, 0)] = -stretch[(0, 0)],       // inverted
                1 => stretch.set_column(2, &Vector3::zeros()), // flat
                2 => stretch[(0, 0)] = 6.0,                    // stretches far apart
                _ => {}
            }
            let shift = Vector3::new(wave(k + 4.0), wave(k + 4.1), wave(k + 4.2)) * 3.0;
            corners[lane] = rest.map(|p| turn * stretch * p + shift);
            if batch == 7 && lane == 3 {
                corners[lane][2].y = f64::NAN;
            }
            rests[lane] = rest;
            elements.push(Tet::new(&rest).unwrap());
        }
        (elements, rests, corners)
    }

    /// Asserts that `model`'s [`ForceModel::force_and_energy_4`] gives each tet of `batch`
    /// the bits of its own [`ForceModel::force_and_energy`] (compared as bit patterns, NaNs
    /// included).
    pub fn assert_four_match_one_by_one(model: &dyn ForceModel, batch: usize) {
        let (elements, rests, corners) = self::batch(batch);
        let tets = std::array::from_fn(|l| &elements[l]);
        let mut together = [(Vector12::zeros(), 0.0); LANES];
        model.force_and_energy_4(tets, &rests, &corners, &mut together);
        for lane in 0..LANES {
            let (force, energy) = model.force_and_energy(tets[lane], &rests[lane], &corners[lane]);
            let (f4, e4) = together[lane];
            let bits = |f: &Vector12| f.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&f4), bits(&force), "batch {batch} lane {lane}");
            assert_eq!(e4.to_bits(), energy.to_bits(), "batch {batch} lane {lane}");
        }
    }
}
