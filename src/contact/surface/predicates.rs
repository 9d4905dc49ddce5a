//! Exact orientation predicates (Shewchuk, "Adaptive precision floating-point arithmetic and
//! fast robust geometric predicates", 1997): the sign of a determinant of point coordinates,
//! exact for every finite input whose products neither overflow nor underflow. A floating-
//! point evaluation with Shewchuk's error bound decides almost every call; the rest are summed
//! exactly as floating-point expansions (two-sum, two-product by fused multiply–add).

use nalgebra::Vector3;

/// The unit round-off 2⁻⁵³ of f64.
const EPSILON: f64 = 1.0 / 9_007_199_254_740_992.0;

/// The sign (−1, 0, 1) of det[a − d; b − d; c − d] = (a − d)·((b − d)×(c − d)): positive when
/// d lies on the side of the plane (a, b, c) opposite to its normal (b − a)×(c − a), zero when
/// the four points are coplanar. Exact (see the module docs).
pub fn orient3d(a: &Vector3<f64>, b: &Vector3<f64>, c: &Vector3<f64>, d: &Vector3<f64>) -> i8 {
    let (ad, bd, cd) = (a - d, b - d, c - d);
    let bc = bd.x * cd.y - cd.x * bd.y;
    let ca = cd.x * ad.y - ad.x * cd.y;
    let ab = ad.x * bd.y - bd.x * ad.y;
    let det = ad.z * bc + bd.z * ca + cd.z * ab;
    let permanent = ((bd.x * cd.y).abs() + (cd.x * bd.y).abs()) * ad.z.abs()
        + ((cd.x * ad.y).abs() + (ad.x * cd.y).abs()) * bd.z.abs()
        + ((ad.x * bd.y).abs() + (bd.x * ad.y).abs()) * cd.z.abs();
    // Shewchuk's bound o3derrboundA on the rounding error of `det`.
    let bound = (7.0 + 56.0 * EPSILON) * EPSILON * permanent;
    if det > bound {
        return 1;
    }
    if -det > bound {
        return -1;
    }
    orient3d_exact(a, b, c, d)
}

/// The sign of det[a − c; b − c] = (a − c)×(b − c) in the plane: positive when a, b, c turn
/// counter-clockwise, zero when they are collinear. Exact.
pub fn orient2d(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> i8 {
    let left = (a[0] - c[0]) * (b[1] - c[1]);
    let right = (a[1] - c[1]) * (b[0] - c[0]);
    let det = left - right;
    // Shewchuk's bound ccwerrboundA.
    let bound = (3.0 + 16.0 * EPSILON) * EPSILON * (left.abs() + right.abs());
    if det > bound {
        return 1;
    }
    if -det > bound {
        return -1;
    }
    // det[[aₓ, a_y, 1], [bₓ, b_y, 1], [cₓ, c_y, 1]], term by term.
    let mut terms = Vec::with_capacity(12);
    for (p, q, sign) in [
        (a[0], b[1], 1.0),
        (a[0], c[1], -1.0),
        (a[1], b[0], -1.0),
        (a[1], c[0], 1.0),
        (b[0], c[1], 1.0),
        (b[1], c[0], -1.0),
    ] {
        let (h, l) = two_product(p, q);
        terms.push(sign * h);
        terms.push(sign * l);
    }
    sign_of_sum(&terms)
}

/// det[[a, 1], [b, 1], [c, 1], [d, 1]] (which equals det[a − d; b − d; c − d]) by Leibniz's
/// formula: 24 products of three coordinates, each split exactly into four floats.
fn orient3d_exact(a: &Vector3<f64>, b: &Vector3<f64>, c: &Vector3<f64>, d: &Vector3<f64>) -> i8 {
    let rows = [a, b, c, d];
    let mut terms = Vec::with_capacity(96);
    for perm in permutations4() {
        let (sigma, parity) = perm;
        // The row whose column is the column of ones contributes 1.
        let mut factors = [0.0; 3];
        let mut k = 0;
        for (row, &col) in sigma.iter().enumerate() {
            if col < 3 {
                factors[k] = rows[row][col];
                k += 1;
            }
        }
        let (p, e) = two_product(factors[0], factors[1]);
        let (q1, q2) = two_product(p, factors[2]);
        let (q3, q4) = two_product(e, factors[2]);
        for q in [q1, q2, q3, q4] {
            terms.push(parity * q);
        }
    }
    sign_of_sum(&terms)
}

/// The 24 permutations of (0, 1, 2, 3) with their signs.
fn permutations4() -> Vec<([usize; 4], f64)> {
    let mut out = Vec::with_capacity(24);
    for i in 0..4 {
        for j in 0..4 {
            for k in 0..4 {
                for l in 0..4 {
                    let p = [i, j, k, l];
                    let distinct = (0..4).all(|x| (x + 1..4).all(|y| p[x] != p[y]));
                    if distinct {
                        let inversions = (0..4)
                            .flat_map(|x| (x + 1..4).map(move |y| (x, y)))
                            .filter(|&(x, y)| p[x] > p[y])
                            .count();
                        out.push((p, if inversions % 2 == 0 { 1.0 } else { -1.0 }));
                    }
                }
            }
        }
    }
    out
}

/// a + b = s + e exactly (Knuth's two-sum).
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bv = s - a;
    let av = s - bv;
    (s, (a - av) + (b - bv))
}

/// a·b = p + e exactly (the fused multiply–add rounds once).
fn two_product(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    (p, a.mul_add(b, -p))
}

/// The sign of the exact sum of `terms`: grown into a non-overlapping expansion (Shewchuk's
/// GROW-EXPANSION, zeros dropped), whose largest component carries the sign.
fn sign_of_sum(terms: &[f64]) -> i8 {
    let mut expansion: Vec<f64> = Vec::with_capacity(terms.len());
    for &t in terms {
        let mut q = t;
        for h in expansion.iter_mut() {
            let (s, e) = two_sum(q, *h);
            *h = e;
            q = s;
        }
        expansion.push(q);
        expansion.retain(|&h| h != 0.0);
    }
    match expansion.last() {
        Some(&h) if h > 0.0 => 1,
        Some(&h) if h < 0.0 => -1,
        _ => 0,
    }
}
