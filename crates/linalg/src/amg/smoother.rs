//! The node-block diagonal D of a level, the largest eigenvalue of D⁻¹A by Lanczos, and the
//! Chebyshev smoother on D⁻¹A.

use nalgebra::{DMatrix, SymmetricEigen};
use rayon::prelude::*;

use super::rows::RowMatrix;
use crate::error::{Error, Result};
use crate::sparse::CscMatrix;

/// Vectors shorter than this are updated sequentially: fork-join would cost more than the work.
const PARALLEL_LEN: usize = 4096;

/// The inverses of the node-block diagonal D of a matrix (blocks of 1–6 DOFs).
#[derive(Debug, Clone)]
pub(crate) struct BlockDiagonal {
    starts: Vec<usize>,
    block_of: Vec<u32>,
    offsets: Vec<usize>,
    /// Row-major D_b⁻¹ of every block, concatenated.
    inverse: Vec<f64>,
    /// Row-major D_b, for the D-inner product of the Lanczos estimate.
    blocks: Vec<f64>,
}

impl BlockDiagonal {
    /// Extracts and inverts the diagonal blocks; one that is not symmetric positive definite
    /// (a zero, negative or non-finite diagonal) is an error naming its first DOF.
    pub fn new(matrix: &CscMatrix, starts: &[usize]) -> Result<Self> {
        let count = starts.len().saturating_sub(1);
        let mut block_of = vec![0u32; matrix.dim()];
        let mut offsets = Vec::with_capacity(count + 1);
        offsets.push(0);
        for b in 0..count {
            let size = starts[b + 1] - starts[b];
            block_of[starts[b]..starts[b + 1]].fill(b as u32);
            offsets.push(offsets[b] + size * size);
        }
        let total = offsets[count];
        let mut inverse = vec![0.0; total];
        let mut blocks = vec![0.0; total];
        for b in 0..count {
            let (lo, size) = (starts[b], starts[b + 1] - starts[b]);
            let block =
                DMatrix::from_fn(size, size, |r, c| matrix.get(lo + r, lo + c).unwrap_or(0.0));
            let bad = || {
                Error::Solver(format!(
                    "smoothed aggregation: the diagonal block at DOF {lo} is not positive definite \
                     (zero, negative or non-finite diagonal)"
                ))
            };
            if block.iter().any(|v| !v.is_finite()) {
                return Err(bad());
            }
            let inv = block.clone().cholesky().ok_or_else(bad)?.inverse();
            for r in 0..size {
                for c in 0..size {
                    inverse[offsets[b] + r * size + c] = inv[(r, c)];
                    blocks[offsets[b] + r * size + c] = block[(r, c)];
                }
            }
        }
        Ok(BlockDiagonal {
            starts: starts.to_vec(),
            block_of,
            offsets,
            inverse,
            blocks,
        })
    }

    /// (D⁻¹·r)ᵢ, or (D·r)ᵢ with `forward`.
    #[inline]
    fn row(&self, i: usize, r: &[f64], forward: bool) -> f64 {
        let b = self.block_of[i] as usize;
        let (lo, hi) = (self.starts[b], self.starts[b + 1]);
        let size = hi - lo;
        let at = self.offsets[b] + (i - lo) * size;
        let entries = if forward {
            &self.blocks[at..at + size]
        } else {
            &self.inverse[at..at + size]
        };
        entries.iter().zip(&r[lo..hi]).map(|(a, x)| a * x).sum()
    }

    /// D⁻¹ as a sparse matrix (its blocks), for the prolongator smoothing D⁻¹·(A·P_tent).
    pub fn inverse_rows(&self) -> Result<RowMatrix> {
        let n = self.block_of.len();
        let mut row_ptr = Vec::with_capacity(n + 1);
        row_ptr.push(0);
        let mut col_idx = Vec::with_capacity(self.inverse.len());
        let mut values = Vec::with_capacity(self.inverse.len());
        for i in 0..n {
            let b = self.block_of[i] as usize;
            let (lo, hi) = (self.starts[b], self.starts[b + 1]);
            let at = self.offsets[b] + (i - lo) * (hi - lo);
            // n ≤ MAX_COLUMNS (checked before the setup), so these cannot truncate.
            col_idx.extend((lo..hi).map(|c| c as u32));
            values.extend_from_slice(&self.inverse[at..at + hi - lo]);
            row_ptr.push(col_idx.len());
        }
        RowMatrix::new(n, row_ptr, col_idx, values)
    }
}

/// A deterministic pseudo-random vector in [−1, 1]ⁿ (xorshift64*), so that setups are
/// reproducible.
pub(crate) fn pseudo_random(n: usize, seed: u64) -> Vec<f64> {
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    (0..n)
        .map(|_| {
            state ^= state >> 12;
            state ^= state << 25;
            state ^= state >> 27;
            let bits = state.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11;
            2.0 * (bits as f64 / (1u64 << 53) as f64) - 1.0
        })
        .collect()
}

/// The largest eigenvalue of D⁻¹A (self-adjoint in the D-inner product) by `steps` Lanczos
/// steps: the largest Ritz value, a lower bound that converges fast at the spectrum's top end.
pub(crate) fn largest_eigenvalue(
    matrix: &CscMatrix,
    diagonal: &BlockDiagonal,
    steps: usize,
) -> Result<f64> {
    let n = matrix.dim();
    if n == 0 {
        return Ok(1.0);
    }
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let d_norm = |v: &[f64]| {
        let dv: Vec<f64> = (0..n).map(|i| diagonal.row(i, v, true)).collect();
        dot(v, &dv).sqrt()
    };
    let mut v = pseudo_random(n, 7);
    let norm = d_norm(&v);
    v.iter_mut().for_each(|x| *x /= norm);
    let mut previous = vec![0.0; n];
    let mut u = vec![0.0; n];
    let (mut alphas, mut betas) = (Vec::new(), Vec::new());
    let mut beta = 0.0;
    for _ in 0..steps.min(n) {
        matrix.product_into(&v, &mut u);
        let alpha = dot(&v, &u);
        let w: Vec<f64> = (0..n)
            .map(|i| diagonal.row(i, &u, false) - alpha * v[i] - beta * previous[i])
            .collect();
        alphas.push(alpha);
        beta = d_norm(&w);
        if !(alpha.is_finite() && beta.is_finite()) {
            return Err(Error::Solver(
                "smoothed aggregation: the matrix has non-finite entries".into(),
            ));
        }
        if beta <= 1e-12 * alpha.abs() {
            break;
        }
        betas.push(beta);
        previous = std::mem::replace(&mut v, w.iter().map(|x| x / beta).collect());
    }
    let k = alphas.len();
    let tridiagonal = DMatrix::from_fn(k, k, |r, c| {
        if r == c {
            alphas[r]
        } else if r + 1 == c {
            betas[r]
        } else if c + 1 == r {
            betas[c]
        } else {
            0.0
        }
    });
    Ok(SymmetricEigen::new(tridiagonal)
        .eigenvalues
        .iter()
        .copied()
        .fold(f64::MIN_POSITIVE, f64::max))
}

/// Chebyshev smoothing on D⁻¹A over the interval [λ_lo, λ_hi]: x ← x + p(D⁻¹A)·D⁻¹·(b − A·x)
/// with p of degree `degree − 1` chosen so that the error factor 1 − λ·p(λ) is the scaled
/// Chebyshev polynomial T_k((θ − λ)/δ)/T_k(θ/δ), θ = (λ_hi + λ_lo)/2, δ = (λ_hi − λ_lo)/2
/// (Saad, Iterative Methods, Alg. 12.1). p(D⁻¹A)·D⁻¹ is symmetric, so the same sweep before and
/// after the coarse correction keeps the V-cycle symmetric.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Chebyshev {
    pub centre: f64,
    pub half_width: f64,
    pub degree: usize,
}

/// Scratch vectors of one smoothing sweep.
pub(crate) struct Scratch<'a> {
    pub residual: &'a mut [f64],
    pub direction: &'a mut [f64],
    pub product: &'a mut [f64],
}

impl Chebyshev {
    /// One sweep; `zero_start` means x is taken as zero on entry (saves the product A·x).
    pub fn smooth(
        &self,
        matrix: &CscMatrix,
        diagonal: &BlockDiagonal,
        b: &[f64],
        x: &mut [f64],
        zero_start: bool,
        scratch: Scratch<'_>,
    ) {
        let Scratch {
            residual: r,
            direction: d,
            product: w,
        } = scratch;
        if zero_start {
            r.copy_from_slice(b);
        } else {
            matrix.product_into(x, w);
            zip_apply(r, |i, ri| *ri = b[i] - w[i]);
        }
        let (theta, delta) = (self.centre, self.half_width);
        let r_ro: &[f64] = r;
        zip_apply(d, |i, di| *di = diagonal.row(i, r_ro, false) / theta);
        let mut rho_old = delta / theta;
        for k in 0..self.degree {
            let d_ro: &[f64] = d;
            if zero_start && k == 0 {
                zip_apply(x, |i, xi| *xi = d_ro[i]);
            } else {
                zip_apply(x, |i, xi| *xi += d_ro[i]);
            }
            if k + 1 == self.degree {
                break;
            }
            matrix.product_into(d_ro, w);
            let w_ro: &[f64] = w;
            zip_apply(r, |i, ri| *ri -= w_ro[i]);
            let rho = 1.0 / (2.0 * theta / delta - rho_old);
            let (keep, step) = (rho * rho_old, 2.0 * rho / delta);
            let r_ro: &[f64] = r;
            zip_apply(d, |i, di| {
                *di = keep * *di + step * diagonal.row(i, r_ro, false)
            });
            rho_old = rho;
        }
    }
}

/// Applies `f(i, &mut v[i])` to every entry, in parallel for long vectors.
pub(crate) fn zip_apply(v: &mut [f64], f: impl Fn(usize, &mut f64) + Sync + Send) {
    if v.len() < PARALLEL_LEN {
        v.iter_mut().enumerate().for_each(|(i, x)| f(i, x));
    } else {
        v.par_iter_mut()
            .enumerate()
            .with_min_len(PARALLEL_LEN)
            .for_each(|(i, x)| f(i, x));
    }
}
