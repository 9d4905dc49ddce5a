//! Whether a curved 10-node tet's map keeps a positive Jacobian determinant over the whole
//! element, not only at sample points.
//!
//! The quadratic map's Jacobian G = ∂x/∂ξ is affine in the barycentric coordinates λ, so
//! G(λ) = Σₘ λₘ·Gₘ with Gₘ its value at corner m, and det G is a cubic on the tet. In the
//! Bernstein basis of degree 3, det G(λ) = Σ_{|α|=3} b_α·B_α(λ) with B_α = 3!/α!·λ^α: det is
//! linear in each column, so b_α is the mean of det[G_a·e₁, G_b·e₂, G_c·e₃] over the orderings
//! (a, b, c) of the multi-index α. The B_α are ≥ 0 and sum to 1 on the tet, so
//! min b_α ≤ det G ≤ max b_α there, and the corner coefficients are exact values,
//! b_{3eₘ} = det Gₘ. All b_α above the floor prove det G above it on the whole tet; a corner's
//! at or below it is a point where the map folds. Between the two the tet is bisected and each
//! half tested the same way (its corner Jacobians are G at its corners), the bound tightening
//! as O(h²): the certificate of Johnen, Remacle and Geuzaine ("Geometrical validity of
//! curvilinear finite elements", J. Comput. Phys. 233, 2013), which Gmsh applies to its curved
//! meshes.

use nalgebra::{Matrix3, Vector3};

/// Pieces (the tet and its halves) examined before a tet whose determinant neither is shown
/// above the floor nor found at or below it is reported undecided: the bound's gap shrinks as
/// the square of a piece's size, so 1,024 pieces tighten it ~100× (a valid tet's determinant
/// would have to stay within ~1 % of its scale of the floor over a region to need more). A
/// piece costs 64 3×3 determinants.
const MAX_PIECES: usize = 1024;

/// What the certificate found about det G over the tet.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum JacobianSign {
    /// det G > floor everywhere on the closed tet.
    Positive,
    /// det G = `det` ≤ floor at the barycentric point `at` (NaN when G is not finite there).
    NotPositive { at: [f64; 4], det: f64 },
    /// Neither shown after [`MAX_PIECES`] pieces: the least Bernstein coefficient `bound` of
    /// the piece whose barycentric centre is `near`.
    Undecided { bound: f64, near: [f64; 4] },
}

/// The sign of det G over the tet whose Jacobian at corner m is `corners[m]`, against `floor`
/// (the module's docs say how).
pub(crate) fn jacobian_sign(corners: &[Matrix3<f64>; 4], floor: f64) -> JacobianSign {
    let whole: Piece = std::array::from_fn(|m| std::array::from_fn(|i| f64::from(i == m)));
    let mut stack = vec![whole];
    let mut examined = 0;
    while let Some(piece) = stack.pop() {
        examined += 1;
        let g: [Matrix3<f64>; 4] = std::array::from_fn(|m| jacobian_at(corners, &piece[m]));
        let coefficients = bernstein_coefficients(&g);
        for (m, &at) in piece.iter().enumerate() {
            let det = coefficients[CORNER_INDEX[m]];
            if det.is_nan() || det <= floor {
                return JacobianSign::NotPositive { at, det };
            }
        }
        // Written so that a NaN coefficient (an overflow) never proves the piece.
        if coefficients.iter().all(|&b| b > floor) {
            continue;
        }
        if examined >= MAX_PIECES {
            // The least coefficient, a NaN kept as the bound.
            let bound = (coefficients.iter().copied()).fold(f64::INFINITY, |m, b| {
                if b.is_nan() || b < m { b } else { m }
            });
            let near = std::array::from_fn(|i| piece.iter().map(|v| v[i]).sum::<f64>() / 4.0);
            return JacobianSign::Undecided { bound, near };
        }
        stack.extend(bisect(&piece));
    }
    JacobianSign::Positive
}

/// A sub-tet of the reference tet: its four corners' barycentric coordinates.
type Piece = [[f64; 4]; 4];

/// G(λ) = Σₘ λₘ·Gₘ, from the Jacobians Gₘ at the corners.
pub(super) fn jacobian_at(corners: &[Matrix3<f64>; 4], l: &[f64; 4]) -> Matrix3<f64> {
    corners
        .iter()
        .zip(l)
        .fold(Matrix3::zeros(), |sum, (g, &w)| sum + g * w)
}

/// The multi-indices α (|α| = 3) as sorted corner triples a ≤ b ≤ c, in a fixed order.
const TRIPLES: [[usize; 3]; 20] = {
    let mut out = [[0; 3]; 20];
    let mut k = 0;
    let mut a = 0;
    while a < 4 {
        let mut b = a;
        while b < 4 {
            let mut c = b;
            while c < 4 {
                out[k] = [a, b, c];
                k += 1;
                c += 1;
            }
            b += 1;
        }
        a += 1;
    }
    out
};

/// Where corner m's coefficient b_{3eₘ} sits in [`TRIPLES`].
const CORNER_INDEX: [usize; 4] = [0, 10, 16, 19];

/// The Bernstein coefficients b_α of det(Σₘ λₘ·gₘ), in [`TRIPLES`]' order: each the mean of the
/// mixed determinants det[g_a·e₁, g_b·e₂, g_c·e₃] over the six orderings of its triple (each
/// distinct ordering occurs equally often among them), a corner's its one determinant.
fn bernstein_coefficients(g: &[Matrix3<f64>; 4]) -> [f64; 20] {
    // det[u, v, w] = u·(v × w): 16 cross products serve the 64 ordered triples.
    let cross: [[Vector3<f64>; 4]; 4] =
        std::array::from_fn(|b| std::array::from_fn(|c| g[b].column(1).cross(&g[c].column(2))));
    let mixed = |a: usize, b: usize, c: usize| g[a].column(0).dot(&cross[b][c]);
    TRIPLES.map(|[a, b, c]| {
        if a == c {
            return mixed(a, a, a);
        }
        let sum = mixed(a, b, c)
            + mixed(a, c, b)
            + mixed(b, a, c)
            + mixed(b, c, a)
            + mixed(c, a, b)
            + mixed(c, b, a);
        sum / 6.0
    })
}

/// The two halves of `piece` split at the midpoint of its longest edge (in barycentric
/// coordinates), so that repeated bisection shrinks every edge.
fn bisect(piece: &Piece) -> [Piece; 2] {
    let length =
        |a: usize, b: usize| -> f64 { (0..4).map(|i| (piece[a][i] - piece[b][i]).powi(2)).sum() };
    let mut longest = (0, 1);
    for a in 0..4 {
        for b in a + 1..4 {
            if length(a, b) > length(longest.0, longest.1) {
                longest = (a, b);
            }
        }
    }
    let (a, b) = longest;
    let middle: [f64; 4] = std::array::from_fn(|i| 0.5 * (piece[a][i] + piece[b][i]));
    let (mut first, mut second) = (*piece, *piece);
    first[a] = middle;
    second[b] = middle;
    [first, second]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Corner Jacobians of a pseudo-random curved map (any four matrices are one: the quadratic
    /// map's G is affine in λ with free corner values), the identity perturbed by entries of up
    /// to 0.5–1.5 by seed, so that some maps stay positive and others fold.
    fn corners(seed: u64) -> [Matrix3<f64>; 4] {
        let amplitude = 1.0 + (seed % 5) as f64 * 0.5;
        let mut state = seed;
        let mut next = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        std::array::from_fn(|_| Matrix3::identity() + Matrix3::from_fn(|_, _| amplitude * next()))
    }

    /// The Bernstein form reproduces det G(λ) at points inside the tet: Σ b_α·3!/α!·λ^α against
    /// the determinant of G(λ) itself, to round-off (1e-13: products of three O(1) entries, 20
    /// terms).
    #[test]
    fn the_bernstein_form_is_the_determinant() {
        for seed in 1..20 {
            let g = corners(seed);
            let b = bernstein_coefficients(&g);
            for l in [[0.1, 0.2, 0.3, 0.4], [0.25; 4], [0.7, 0.1, 0.15, 0.05_f64]] {
                let form: f64 = TRIPLES
                    .iter()
                    .zip(&b)
                    .map(|(t, b)| {
                        let mut count = [0usize; 4];
                        t.iter().for_each(|&m| count[m] += 1);
                        let factorial = |n: usize| (1..=n).product::<usize>() as f64;
                        let multinomial =
                            6.0 / count.iter().map(|&n| factorial(n)).product::<f64>();
                        b * multinomial
                            * (0..4).map(|m| l[m].powi(count[m] as i32)).product::<f64>()
                    })
                    .sum();
                let direct = jacobian_at(&g, &l).determinant();
                assert!((form - direct).abs() < 1e-13, "{form} against {direct}");
            }
            for (m, &index) in CORNER_INDEX.iter().enumerate() {
                assert_eq!(TRIPLES[index], [m; 3]);
            }
        }
    }

    /// det G = (λ₀ − t)²·1 with t = 1/π: zero on a plane through the tet that no bisection
    /// point reaches, positive on both sides — a fold of zero thickness. Never called
    /// positive: undecided after the piece budget, the bound ≤ 0.
    #[test]
    fn a_determinant_vanishing_inside_is_never_called_positive() {
        let t = std::f64::consts::FRAC_1_PI;
        let corners: [Matrix3<f64>; 4] = std::array::from_fn(|m| {
            let f = f64::from(m == 0) - t;
            Matrix3::from_diagonal(&Vector3::new(f, f, 1.0))
        });
        match jacobian_sign(&corners, 0.0) {
            JacobianSign::Undecided { bound, near } => {
                assert!(bound <= 0.0, "{bound}");
                // The undecided piece straddles the plane λ₀ = t (within a piece's size).
                assert!((near[0] - t).abs() < 0.2, "{near:?}");
            }
            JacobianSign::NotPositive { det, .. } => assert!(det <= 0.0),
            JacobianSign::Positive => panic!("a vanishing determinant called positive"),
        }
    }

    /// Against sampling on a fine lattice (degree 30 in λ, 5,456 points): a map the certificate
    /// calls positive is positive at every sample, and one with a sample at or below zero is
    /// never called positive; a found point's value is the determinant there.
    #[test]
    fn the_verdict_agrees_with_dense_sampling() {
        let n = 30;
        let mut verdicts = [0; 3];
        for seed in 1..200 {
            let g = corners(seed);
            let mut least = f64::INFINITY;
            for i in 0..=n {
                for j in 0..=n - i {
                    for k in 0..=n - i - j {
                        let l = [i, j, k, n - i - j - k].map(|c| c as f64 / n as f64);
                        least = least.min(jacobian_at(&g, &l).determinant());
                    }
                }
            }
            match jacobian_sign(&g, 0.0) {
                JacobianSign::Positive => {
                    verdicts[0] += 1;
                    assert!(least > 0.0, "seed {seed}: sampled {least}");
                }
                JacobianSign::NotPositive { at, det } => {
                    verdicts[1] += 1;
                    // Two formulas of one 3×3 determinant: round-off of entries ≤ ~3.
                    let direct = jacobian_at(&g, &at).determinant();
                    assert!((det - direct).abs() < 1e-13, "{det} against {direct}");
                    assert!(det <= 0.0);
                }
                JacobianSign::Undecided { .. } => verdicts[2] += 1,
            }
        }
        // Both verdicts occur among these maps (the check would be vacuous otherwise).
        eprintln!("positive, not positive, undecided: {verdicts:?}");
        assert!(verdicts[0] > 10 && verdicts[1] > 10, "{verdicts:?}");
    }
}
