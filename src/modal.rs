//! Modal analysis: the lowest natural frequencies and mode shapes of the constrained body,
//! K·φ = ω²·M·φ, by shift-invert (shift 0) subspace iteration on the sparse Cholesky of K.

use nalgebra::{DMatrix, SymmetricEigen};

use crate::dynamics::{LinearSystem, Mass};
use crate::error::{Error, Result};
use crate::linsolve::SparseCholesky;

/// The lowest modes of a [`LinearSystem`].
#[derive(Debug, Clone, PartialEq)]
pub struct Modes {
    /// Angular frequencies ω (rad/time), ascending.
    pub omega: Vec<f64>,
    /// Mode shapes on the free DOFs, M-orthonormal (φᵢᵀ·M·φⱼ = δᵢⱼ), in the order of `omega`.
    pub shapes: Vec<Vec<f64>>,
    /// Subspace iterations used.
    pub iterations: usize,
}

impl Modes {
    /// Frequencies f = ω/2π (cycles per time unit, Hz in SI).
    pub fn frequencies(&self) -> Vec<f64> {
        self.omega
            .iter()
            .map(|w| w / (2.0 * std::f64::consts::PI))
            .collect()
    }
}

/// The `count` lowest modes, converged until each eigenvalue ω² changes by less than 1e-12
/// relative between iterations (at most 500 iterations).
///
/// Subspace iteration with a block of p = min(n, max(2·count, count + 8)) vectors: Y = K⁻¹·M·X,
/// then Rayleigh–Ritz on span(Y) (a p×p generalized eigenproblem). The extra vectors make the
/// convergence rate (ω_count/ω_{p+1})² per iteration.
pub fn lowest_modes(system: &LinearSystem, count: usize) -> Result<Modes> {
    let n = system.free_count();
    if count == 0 || count > n {
        return Err(Error::invalid_parameter(
            "mode count",
            count,
            format!("must be between 1 and the free DOF count {n}"),
        ));
    }
    let p = n.min((2 * count).max(count + 8));
    let k = system.stiffness();
    let mass = system.mass();
    let mut cholesky = SparseCholesky::analyze(k)?;
    cholesky.factorize(k)?;
    // Start block: smooth-ish deterministic vectors of varied shape.
    let mut x: Vec<Vec<f64>> = (0..p)
        .map(|j| {
            (0..n)
                .map(|i| {
                    ((i * (j + 1)) as f64 * 0.7548776662 + j as f64 * 0.569840291).fract() - 0.5
                })
                .collect()
        })
        .collect();
    let mut previous = vec![f64::INFINITY; count];
    let mut work = vec![0.0; n];
    for iteration in 1..=500 {
        // Y = K⁻¹ M X
        let mut y = Vec::with_capacity(p);
        for column in &x {
            mass.product_into(column, &mut work);
            let mut solved = work.clone();
            cholesky.solve_in_place(&mut solved)?;
            y.push(solved);
        }
        // Reduced matrices Kr = Yᵀ K Y, Mr = Yᵀ M Y.
        let ky: Vec<Vec<f64>> = y.iter().map(|c| k.mul(c)).collect::<Result<_>>()?;
        let my: Vec<Vec<f64>> = y
            .iter()
            .map(|c| {
                let mut out = vec![0.0; n];
                mass.product_into(c, &mut out);
                out
            })
            .collect();
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
        let kr = DMatrix::from_fn(p, p, |i, j| 0.5 * (dot(&y[i], &ky[j]) + dot(&y[j], &ky[i])));
        let mr = DMatrix::from_fn(p, p, |i, j| 0.5 * (dot(&y[i], &my[j]) + dot(&y[j], &my[i])));
        // Kr z = λ Mr z via Mr = L Lᵀ: (L⁻¹ Kr L⁻ᵀ) w = λ w, z = L⁻ᵀ w.
        let l = mr
            .cholesky()
            .ok_or_else(|| {
                Error::Solver(
                    "modal analysis: the subspace lost rank (Mr not positive definite)".into(),
                )
            })?
            .l();
        let l_inv = l
            .clone()
            .try_inverse()
            .ok_or_else(|| Error::Solver("modal analysis: singular subspace".into()))?;
        let reduced = &l_inv * &kr * l_inv.transpose();
        let reduced = (&reduced + reduced.transpose()) * 0.5;
        let eigen = SymmetricEigen::new(reduced);
        let mut order: Vec<usize> = (0..p).collect();
        order.sort_by(|&a, &b| eigen.eigenvalues[a].total_cmp(&eigen.eigenvalues[b]));
        let z = l_inv.transpose() * &eigen.eigenvectors;
        // X = Y Z, columns in ascending eigenvalue order (M-orthonormal by construction).
        x = order
            .iter()
            .map(|&c| {
                let mut column = vec![0.0; n];
                for (j, yj) in y.iter().enumerate() {
                    let coefficient = z[(j, c)];
                    for (out, v) in column.iter_mut().zip(yj) {
                        *out += coefficient * v;
                    }
                }
                column
            })
            .collect();
        let lambda: Vec<f64> = order
            .iter()
            .take(count)
            .map(|&c| eigen.eigenvalues[c])
            .collect();
        if lambda.iter().any(|l| !(l.is_finite() && *l > 0.0)) {
            return Err(Error::Solver(format!(
                "modal analysis: non-positive eigenvalue estimate {lambda:?}"
            )));
        }
        let converged = lambda
            .iter()
            .zip(&previous)
            .all(|(l, p)| (l - p).abs() <= 1e-12 * l);
        previous = lambda;
        if converged {
            let omega = previous.iter().map(|l| l.sqrt()).collect();
            x.truncate(count);
            return Ok(Modes {
                omega,
                shapes: x,
                iterations: iteration,
            });
        }
    }
    Err(Error::Solver(
        "modal analysis did not converge in 500 subspace iterations".into(),
    ))
}

/// The mass inner product φᵀ·M·ψ ([`Error::DimensionMismatch`] unless both vectors have the
/// mass matrix's dimension).
pub fn mass_inner_product(mass: &Mass, a: &[f64], b: &[f64]) -> Result<f64> {
    Error::check_len("a", mass.dim(), a.len())?;
    let mut mb = vec![0.0; b.len()];
    mass.mul_vec(b, &mut mb)?;
    Ok(a.iter().zip(&mb).map(|(x, y)| x * y).sum())
}
