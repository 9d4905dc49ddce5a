//! The largest eigenvalue λ_max of A = M^(−1/2)·K·M^(−1/2) (M diagonal, the lumped mass)
//! bracketed by the Lanczos iteration: the estimate the explicit critical step
//! ([`super::stability::critical_time_step`]) proposes to its inertia check.
//!
//! For any unit vector y, θ = yᵀAy ≤ λ_max (Rayleigh), and some eigenvalue of A lies within
//! δ = ‖Ay − θy‖ of θ (not necessarily the largest: the inertia check that follows decides).
//! Power iteration, which gave y before, needs a number of products with K that grows as the
//! top of A's spectrum crowds: 425 products to a bracket of 1e-3 on a 9,720-DOF linear
//! cantilever, 575 on a 36,720-DOF quadratic one (1.8 s of a 2.8 s scene set-up). Lanczos
//! takes y from the Krylov space of all the products so far: its Ritz value converges to
//! λ_max at a rate set by the square root of the relative gap, not the gap itself.
//!
//! Each new vector is orthogonalized against the whole basis (one pass of classical
//! Gram–Schmidt): without it, copies of a converged Ritz vector appear in the basis. A second
//! pass bought nothing measurable (the same 90 products on a 69,360-DOF beam, 0.56 against
//! 0.41 s), and no guarantee rests on orthogonality: the stopping test uses Lanczos's residual
//! estimate β·|s_m|, but the bracket returned is always the Ritz vector's explicit residual,
//! one product more. To bound the memory the basis holds at most [`BASIS`] vectors; past it the
//! iteration restarts from its Ritz vector (explicit restart).

use nalgebra::{DMatrix, SymmetricEigen};

use crate::base::error::{Error, Result};
use crate::base::vector::dot;
use crate::sparse::CscMatrix;

/// The largest number of Lanczos vectors kept before a restart: 160·n bytes, below the sparse
/// factor of K's size that the inertia check allocates next (hundreds of entries a column).
/// 40 vectors took 47 / 67 / 82 products (36,720-DOF P2, 9,720- and 69,360-DOF P1 beams), 20
/// took 53 / 69 / 90, each product cheaper by its shorter orthogonalization.
const BASIS: usize = 20;

/// The Lanczos residual estimate is checked after the first product and every this many
/// products (a dense eigenproblem of the tridiagonal matrix, at most [`BASIS`]², each time).
const CHECK_EVERY: usize = 5;

/// A bracket [`lower`, `upper`] that holds an eigenvalue of A (rad²/time²): `lower` a Rayleigh
/// quotient (≤ λ_max), `upper` = `lower` + the residual's norm (capped by the caller's bound).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct TopBracket {
    pub lower: f64,
    pub upper: f64,
    /// Products with K made.
    pub products: usize,
}

/// The operator A/s: `out` = M^(−1/2)·K·M^(−1/2)·`z` / `scale` (`scale` a power of two, exact).
struct ScaledOperator<'a> {
    k: &'a CscMatrix,
    inverse_root: &'a [f64],
    scale: f64,
    x: Vec<f64>,
    kx: Vec<f64>,
    products: usize,
}

impl ScaledOperator<'_> {
    fn apply(&mut self, z: &[f64], out: &mut [f64]) {
        for ((x, z), s) in self.x.iter_mut().zip(z).zip(self.inverse_root) {
            *x = s * z;
        }
        self.k.product_into(&self.x, &mut self.kx);
        for ((o, kx), s) in out.iter_mut().zip(&self.kx).zip(self.inverse_root) {
            *o = s * kx / self.scale;
        }
        self.products += 1;
    }
}

/// The bracket on an eigenvalue of A = M^(−1/2)·K·M^(−1/2) (`inverse_root` = the entries of
/// M^(−1/2)) from the Lanczos iteration started at `start` (any nonzero vector, of entries of
/// order 1), stopped when the residual δ ≤ `tolerance`·θ or after about `max_products` products
/// with K. The iteration runs on A/`scale` (`scale` a power of two near λ_max, so that no square
/// overflows); the bracket is returned unscaled, its upper end at most `cap`.
///
/// Errors: [`Error::Solver`] naming the product at which a value stopped being finite.
pub(crate) fn top_eigenvalue_bracket(
    (k, inverse_root): (&CscMatrix, &[f64]),
    start: Vec<f64>,
    (scale, cap): (f64, f64),
    (tolerance, max_products): (f64, usize),
) -> Result<TopBracket> {
    let n = start.len();
    let mut operator = ScaledOperator {
        k,
        inverse_root,
        scale,
        x: vec![0.0; n],
        kx: vec![0.0; n],
        products: 0,
    };
    let (mut y, mut ay) = (start, vec![0.0; n]);
    normalize(&mut y);
    loop {
        y = lanczos_cycle(&mut operator, y, tolerance, max_products)?;
        operator.apply(&y, &mut ay);
        let theta = dot(&y, &ay);
        let delta = norm_of_difference(&ay, &y, theta);
        if !(theta.is_finite() && delta.is_finite() && theta > 0.0) {
            return Err(Error::Solver(format!(
                "Lanczos iteration for ω_max broke down at product {} (Rayleigh quotient {:e}, \
                 residual {:e})",
                operator.products,
                theta * scale,
                delta * scale
            )));
        }
        // Lanczos's estimate met the test but the explicit residual may not (round-off): the
        // next cycle starts from this Ritz vector.
        if delta <= tolerance * theta || operator.products >= max_products {
            return Ok(TopBracket {
                lower: theta * scale,
                upper: ((theta + delta) * scale).min(cap),
                products: operator.products,
            });
        }
    }
}

/// One cycle of at most [`BASIS`] Lanczos steps from the unit vector `q`: the unit Ritz vector
/// of the largest Ritz value once Lanczos's residual estimate β_m·|s_m| ≤ `tolerance`·θ, the
/// basis is full, the Krylov space is invariant (β_m ≈ 0) or `max_products` are made.
fn lanczos_cycle(
    operator: &mut ScaledOperator,
    q: Vec<f64>,
    tolerance: f64,
    max_products: usize,
) -> Result<Vec<f64>> {
    let n = q.len();
    let mut basis: Vec<Vec<f64>> = vec![q];
    let (mut alphas, mut betas): (Vec<f64>, Vec<f64>) = (Vec::new(), Vec::new());
    loop {
        let j = basis.len() - 1;
        let mut w = vec![0.0; n];
        operator.apply(&basis[j], &mut w);
        let alpha = dot(&basis[j], &w);
        for q in &basis {
            let c = dot(q, &w);
            w.iter_mut().zip(q).for_each(|(w, q)| *w -= c * q);
        }
        let beta = dot(&w, &w).sqrt();
        alphas.push(alpha);
        if !(alpha.is_finite() && beta.is_finite()) {
            return Err(Error::Solver(format!(
                "Lanczos iteration for ω_max broke down at product {} (α = {alpha:e}, β = \
                 {beta:e})",
                operator.products
            )));
        }
        let m = alphas.len();
        let invariant =
            beta <= f64::EPSILON * alpha.abs().max(betas.last().copied().unwrap_or(0.0));
        let last = invariant || m == BASIS || operator.products >= max_products;
        // Also after the first product: a start that is an eigenvector already (its residual
        // round-off) stops there, rather than let the normalized round-off steer the basis.
        if last || m == 1 || m % CHECK_EVERY == 0 {
            let (theta, s) = top_ritz_pair(&alphas, &betas);
            if last || beta * s[m - 1].abs() <= tolerance * theta {
                let mut y = vec![0.0; n];
                for (q, &c) in basis.iter().zip(&s) {
                    y.iter_mut().zip(q).for_each(|(y, q)| *y += c * q);
                }
                normalize(&mut y);
                return Ok(y);
            }
        }
        betas.push(beta);
        w.iter_mut().for_each(|w| *w /= beta);
        basis.push(w);
    }
}

/// The largest eigenvalue of the symmetric tridiagonal matrix of diagonal `alphas` and
/// off-diagonal `betas` (one fewer), with its unit eigenvector.
fn top_ritz_pair(alphas: &[f64], betas: &[f64]) -> (f64, Vec<f64>) {
    let m = alphas.len();
    let t = DMatrix::from_fn(m, m, |i, j| match i.abs_diff(j) {
        0 => alphas[i],
        1 => betas[i.min(j)],
        _ => 0.0,
    });
    let eigen = SymmetricEigen::new(t);
    let top = (0..m)
        .max_by(|&a, &b| eigen.eigenvalues[a].total_cmp(&eigen.eigenvalues[b]))
        .unwrap_or(0);
    (
        eigen.eigenvalues[top],
        eigen.eigenvectors.column(top).iter().copied().collect(),
    )
}

/// ‖a − θ·v‖.
fn norm_of_difference(a: &[f64], v: &[f64], theta: f64) -> f64 {
    a.iter()
        .zip(v)
        .map(|(a, v)| (a - theta * v).powi(2))
        .sum::<f64>()
        .sqrt()
}

fn normalize(v: &mut [f64]) {
    let length = dot(v, v).sqrt();
    v.iter_mut().for_each(|x| *x /= length);
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::sparse::SymbolicSparseColMat;
    use std::sync::Arc;

    /// The tridiagonal K with `diagonal` and −1 beside it (the 1-D Laplacian when the diagonal
    /// is 2): λ_max = 2 + 2·cos(π/(n + 1)) for that one.
    fn tridiagonal(diagonal: &[f64]) -> CscMatrix {
        let n = diagonal.len();
        let (mut col_ptr, mut row_idx, mut values) = (vec![0], Vec::new(), Vec::new());
        for j in 0..n {
            for i in j.saturating_sub(1)..(j + 2).min(n) {
                row_idx.push(i);
                values.push(if i == j { diagonal[j] } else { -1.0 });
            }
            col_ptr.push(row_idx.len());
        }
        let pattern = Arc::new(SymbolicSparseColMat::new_checked(
            n, n, col_ptr, None, row_idx,
        ));
        CscMatrix::from_values(pattern, values).unwrap()
    }

    fn alternating(n: usize) -> Vec<f64> {
        (0..n)
            .map(|i| if i % 2 == 0 { 1.0 } else { -0.7 })
            .collect()
    }

    /// The 1-D Laplacian of 2,000 unknowns: its top eigenvalues crowd (relative gap ~1e-6),
    /// where power iteration's error falls by 1 − 1e-6 a product and needs ~1e6 of them to a
    /// bracket of 1e-3. Lanczos's Ritz value is a Rayleigh quotient (never above λ_max) within
    /// the bracket's 1e-3 of it (the bracket holds *an* eigenvalue; this start has a component
    /// along the top one), in far fewer products than the limit.
    #[test]
    fn a_crowded_top_of_the_spectrum_is_bracketed_in_few_products() {
        let n = 2000;
        let k = tridiagonal(&vec![2.0; n]);
        let exact = 2.0 + 2.0 * (std::f64::consts::PI / (n as f64 + 1.0)).cos();
        let ones = vec![1.0; n];
        let found = top_eigenvalue_bracket((&k, &ones), alternating(n), (4.0, 4.0), (1e-3, 20_000))
            .unwrap();
        assert!(
            found.lower <= exact * (1.0 + 1e-14),
            "{found:?} against {exact}"
        );
        assert!(
            found.lower >= exact * (1.0 - 1e-3),
            "{found:?} against {exact}"
        );
        assert!(
            found.upper >= found.lower && found.upper <= 4.0,
            "{found:?}"
        );
        assert!(found.products < 2_000, "{found:?}");
    }

    /// Fewer unknowns than the basis holds: the Krylov space becomes invariant and the Ritz
    /// value is the top eigenvalue to round-off (5×5, diagonal 2 and the masses 1/s² scaled
    /// by M^(−1/2) = `inverse_root`: A = S·K·S with S = 0.5·I, λ_max = (2 + √3)/4).
    #[test]
    fn an_invariant_krylov_space_gives_the_top_eigenvalue_to_round_off() {
        let k = tridiagonal(&[2.0; 5]);
        let halves = vec![0.5; 5];
        let found =
            top_eigenvalue_bracket((&k, &halves), alternating(5), (1.0, 1.0), (1e-3, 20_000))
                .unwrap();
        let exact = (2.0 + 3f64.sqrt()) / 4.0;
        // Round-off of a 5×5 eigenproblem and of the explicit residual: a few ulps.
        assert!(
            (found.lower - exact).abs() <= 1e-14,
            "{found:?} against {exact}"
        );
        assert!(found.upper - found.lower <= 1e-13, "{found:?}");
        assert!(found.products <= 7, "{found:?}");
    }

    /// A value that stops being finite is an error naming the product, not a bracket.
    #[test]
    fn an_infinite_entry_is_an_error_naming_the_product() {
        let mut diagonal = vec![2.0; 10];
        diagonal[3] = f64::INFINITY;
        let k = tridiagonal(&diagonal);
        let ones = vec![1.0; 10];
        let error = top_eigenvalue_bracket((&k, &ones), alternating(10), (1.0, 1.0), (1e-3, 100))
            .unwrap_err();
        assert!(
            error.to_string().contains("broke down at product 1"),
            "{error}"
        );
    }
}
