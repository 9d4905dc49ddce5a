//! The limited-memory BFGS inverse Hessian of a minimization (Nocedal & Wright, "Numerical
//! Optimization", 2nd ed., Algorithm 7.4): the last few steps sᵢ and gradient changes yᵢ
//! correct an initial inverse Hessian H₀ (here the turned rest factor, as Liu, Bouaziz & Kavan,
//! "Quasi-Newton methods for real-time simulation of hyperelastic materials", 2017, use a
//! constant Laplacian), so a step needs no tangent.

use std::collections::VecDeque;

use crate::base::error::Result;
use crate::base::vector::{axpy, dot, norm};

/// One correction pair: s = x_{k+1} − x_k, y = g_{k+1} − g_k and ρ = 1/(yᵀs).
struct Pair {
    step: Vec<f64>,
    change: Vec<f64>,
    rho: f64,
}

/// The last `capacity` correction pairs of an L-BFGS iteration.
pub(crate) struct LbfgsMemory {
    pairs: VecDeque<Pair>,
    capacity: usize,
    alphas: Vec<f64>,
    /// Vectors of forgotten or refused pairs, handed out again by [`buffer`](Self::buffer):
    /// a fresh vector per pair would be zero-filled by the kernel page by page, every iteration.
    spare: Vec<Vec<f64>>,
}

impl LbfgsMemory {
    /// An empty memory keeping at most `capacity` pairs (0: H = H₀ always, a chord iteration).
    pub fn new(capacity: usize) -> Self {
        LbfgsMemory {
            pairs: VecDeque::with_capacity(capacity),
            capacity,
            alphas: Vec::with_capacity(capacity),
            spare: Vec::new(),
        }
    }

    /// Forgets every pair (a new minimization).
    pub fn clear(&mut self) {
        while let Some(pair) = self.pairs.pop_front() {
            self.spare.extend([pair.step, pair.change]);
        }
    }

    /// A vector of length `len` for the next pair's s or y (its values unspecified).
    pub fn buffer(&mut self, len: usize) -> Vec<f64> {
        let mut v = self.spare.pop().unwrap_or_default();
        v.resize(len, 0.0);
        v
    }

    /// Keeps the pair (s, y) when the curvature yᵀs is positive beyond round-off
    /// (yᵀs > 1e-12·|y|·|s|): only then is the updated H positive definite. Returns whether
    /// it was kept.
    pub fn push(&mut self, step: Vec<f64>, change: Vec<f64>) -> bool {
        if self.capacity == 0 {
            self.spare.extend([step, change]);
            return false;
        }
        let curvature = dot(&step, &change);
        if curvature.is_nan() || curvature <= 1e-12 * norm(&step) * norm(&change) {
            self.spare.extend([step, change]);
            return false;
        }
        if self.pairs.len() == self.capacity
            && let Some(oldest) = self.pairs.pop_front()
        {
            self.spare.extend([oldest.step, oldest.change]);
        }
        self.pairs.push_back(Pair {
            step,
            change,
            rho: 1.0 / curvature,
        });
        true
    }

    /// v ← H·v by the two-loop recursion, `initial(v)` applying H₀ in place.
    pub fn apply(
        &mut self,
        v: &mut [f64],
        initial: &mut dyn FnMut(&mut [f64]) -> Result<()>,
    ) -> Result<()> {
        self.alphas.clear();
        for pair in self.pairs.iter().rev() {
            let alpha = pair.rho * dot(&pair.step, v);
            axpy(-alpha, &pair.change, v);
            self.alphas.push(alpha);
        }
        initial(v)?;
        for (pair, alpha) in self.pairs.iter().zip(self.alphas.iter().rev()) {
            let beta = pair.rho * dot(&pair.change, v);
            axpy(alpha - beta, &pair.step, v);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// y = A·s for a symmetric positive definite A (a quadratic's gradient changes).
    fn product(a: &[[f64; 3]; 3], s: &[f64]) -> Vec<f64> {
        a.iter()
            .map(|row| row.iter().zip(s).map(|(x, y)| x * y).sum())
            .collect()
    }

    const A: [[f64; 3]; 3] = [[4.0, 1.0, 0.5], [1.0, 3.0, 0.2], [0.5, 0.2, 2.0]];

    /// BFGS's defining identity, the secant equation H·y = s for the newest pair, holds to
    /// round-off (1e-14 of |s|: a few ulps through two short loops) whatever H₀ is.
    #[test]
    fn the_newest_pair_satisfies_the_secant_equation() {
        let mut memory = LbfgsMemory::new(2);
        for s in [[1.0, 0.0, 0.3], [0.2, 1.0, -0.4], [-0.5, 0.3, 1.0]] {
            assert!(memory.push(s.to_vec(), product(&A, &s)));
        }
        let s = [-0.5, 0.3, 1.0];
        let mut v = product(&A, &s);
        memory
            .apply(&mut v, &mut |v: &mut [f64]| {
                v.iter_mut().for_each(|x| *x *= 0.7);
                Ok(())
            })
            .unwrap();
        for (h_y, s) in v.iter().zip(s) {
            assert!((h_y - s).abs() < 1e-14, "{v:?} against {s}");
        }
    }

    /// A pair of non-positive curvature (yᵀs ≤ 0, which would make H indefinite) is refused,
    /// and with no pairs (or no capacity) H is H₀.
    #[test]
    fn negative_curvature_is_refused_and_h0_stands_alone() {
        let mut memory = LbfgsMemory::new(3);
        assert!(!memory.push(vec![1.0, 0.0, 0.0], vec![-1.0, 0.5, 0.0]));
        let mut none = LbfgsMemory::new(0);
        assert!(!none.push(vec![1.0, 0.0, 0.0], vec![2.0, 0.0, 0.0]));
        for memory in [&mut memory, &mut none] {
            let mut v = vec![1.0, 2.0, 3.0];
            memory
                .apply(&mut v, &mut |v: &mut [f64]| {
                    v.iter_mut().for_each(|x| *x *= 0.5);
                    Ok(())
                })
                .unwrap();
            assert_eq!(v, vec![0.5, 1.0, 1.5]);
        }
    }
}
