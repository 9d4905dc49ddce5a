//! Modal analysis: the lowest natural frequencies and mode shapes of the constrained body,
//! K·φ = ω²·M·φ, by shift-invert (shift 0) subspace iteration on the sparse Cholesky of K.
//!
//! Convergence is judged on each mode's eigen-residual r = K·φ − ω²·M·φ, scaled by the size of
//! the terms it is computed from (see [`Modes::residuals`]): that scale is what round-off in
//! evaluating r can reach, whatever the conditioning of K. (The change of ω² between
//! iterations, the test used before, stalls near ε·λ_max/λ₁ relative — about 1e-8 on a slender
//! beam — and never met a 1e-12 tolerance.)
//!
//! Modal analysis is linear only: its K is the linear model's (every model's tangent at rest).
//! [`lowest_modes_with_force`] is the entry that takes the force model every other analysis
//! takes, and refuses a nonlinear one with an error naming it.

use nalgebra::{DMatrix, SymmetricEigen};

use crate::analysis::dynamics::{InternalForce, LinearSystem, Mass};
use crate::base::error::{Error, Result};
use crate::base::vector::dot;
use crate::bc::constraints::DofMap;
use crate::linsolve::SparseCholesky;
use crate::sparse::CscMatrix;

/// Scaled residual every returned mode meets (see [`Modes::residuals`]). Round-off alone leaves
/// about 1e-16–1e-15; 1e-13 keeps a margin of ~100 above that while making the eigenvalue
/// error, of order (residual·λ_max)²/λ, negligible (measured ≤ 1e-12 relative against a dense
/// solve on the test meshes).
pub const RESIDUAL_TOLERANCE: f64 = 1e-13;

/// Iterations without the worst scaled residual halving after which the iteration is declared
/// stalled (it then fails, reporting the residuals, instead of running to the limit).
const STALL_ITERATIONS: usize = 40;

/// Iteration limit.
const MAX_ITERATIONS: usize = 1000;

/// The lowest modes of a [`LinearSystem`].
#[derive(Debug, Clone, PartialEq)]
pub struct Modes {
    /// Angular frequencies ω (rad/time), ascending.
    pub omega: Vec<f64>,
    /// Mode shapes on the free DOFs, M-orthonormal (φᵢᵀ·M·φⱼ = δᵢⱼ), in the order of `omega`.
    pub shapes: Vec<Vec<f64>>,
    /// Subspace iterations used.
    pub iterations: usize,
    /// Scaled eigen-residual of each mode (dimensionless), in the order of `omega`:
    /// ‖K·φ − ω²·M·φ‖₂ / ‖(|K| + ω²·|M|)·|φ|‖₂, |·| taken entry-wise. The denominator bounds the
    /// terms summed to form the residual, so floating-point evaluation alone leaves a residual of
    /// order ε (≈ 1e-16) times it; every value is at most [`RESIDUAL_TOLERANCE`].
    pub residuals: Vec<f64>,
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

/// [`lowest_modes`] of `system` with the elastic force law `force`, which must be
/// [`InternalForce::Linear`]: the modes solve K·φ = ω²·M·φ with the constant K_ff, a property of
/// the linear model. A nonlinear model (corotational, Neo-Hookean) has a tangent that changes
/// with the deformation and no such eigenproblem; it is [`Error::InvalidParameter`] naming the
/// model, checked before any work. (Its tangent at rest is the linear K_ff, so the linear
/// model gives the small-vibration modes of the undeformed body.)
pub fn lowest_modes_with_force(
    system: &LinearSystem,
    force: &InternalForce,
    count: usize,
) -> Result<Modes> {
    if force.is_nonlinear() {
        return Err(Error::invalid_parameter(
            "model",
            force.name(),
            "modal analysis is linear only (K·φ = ω²·M·φ with the constant stiffness of the \
             linear model); use the linear model, whose K is every model's tangent at rest",
        ));
    }
    lowest_modes(system, count)
}

/// The `count` lowest modes, converged until each mode's scaled eigen-residual
/// ([`Modes::residuals`]) is at most [`RESIDUAL_TOLERANCE`] (at most 1000 iterations; an
/// [`Error::Solver`] reporting the residuals if they stall above it for 40 iterations).
///
/// Subspace iteration with a block of p = min(n, max(2·count, count + 8)) vectors: Y = K⁻¹·M·X,
/// then Rayleigh–Ritz on span(Y) (a p×p generalized eigenproblem). The extra vectors make the
/// convergence rate (ω_count/ω_{p+1})² per iteration.
pub fn lowest_modes(system: &LinearSystem, count: usize) -> Result<Modes> {
    let mut stiffness = MatrixStiffness {
        k: system.stiffness(),
        cholesky: None,
    };
    subspace_modes(&mut stiffness, system.mass(), count, RESIDUAL_TOLERANCE)
}

/// The stiffness side of K·φ = ω²·M·φ as the subspace iteration uses it: solves with K (or,
/// for the mixed element, with the saddle point whose condensed stiffness is K) and products
/// by K. [`lowest_modes`]'s is the assembled K_ff and its sparse Cholesky factor.
pub(crate) trait StiffnessOperator {
    /// n, the free DOF count.
    fn dim(&self) -> usize;
    /// Factors K (once; before the first [`solve_in_place`](Self::solve_in_place)).
    fn factor(&mut self) -> Result<()>;
    /// b ← K⁻¹·b.
    fn solve_in_place(&mut self, b: &mut [f64]) -> Result<()>;
    /// K·x.
    fn product(&mut self, x: &[f64]) -> Result<Vec<f64>>;
    /// K·x and the magnitude |K|·|x| of the terms summed to form it (entry-wise), the scale of
    /// its round-off in [`Modes::residuals`].
    fn product_and_bound(&mut self, x: &[f64]) -> Result<(Vec<f64>, Vec<f64>)>;
}

/// An assembled K_ff with its Cholesky factor (made by [`StiffnessOperator::factor`]).
struct MatrixStiffness<'a> {
    k: &'a CscMatrix,
    cholesky: Option<SparseCholesky>,
}

impl StiffnessOperator for MatrixStiffness<'_> {
    fn dim(&self) -> usize {
        self.k.dim()
    }

    fn factor(&mut self) -> Result<()> {
        let mut cholesky = SparseCholesky::analyze(self.k)?;
        cholesky.factorize(self.k)?;
        self.cholesky = Some(cholesky);
        Ok(())
    }

    fn solve_in_place(&mut self, b: &mut [f64]) -> Result<()> {
        match &mut self.cholesky {
            Some(cholesky) => Ok(cholesky.solve_in_place(b)?),
            None => Err(Error::Solver(
                "modal analysis: K solved before its factorization".into(),
            )),
        }
    }

    fn product(&mut self, x: &[f64]) -> Result<Vec<f64>> {
        Ok(self.k.mul(x)?)
    }

    fn product_and_bound(&mut self, x: &[f64]) -> Result<(Vec<f64>, Vec<f64>)> {
        let k = self.k;
        let n = x.len();
        let mut kx = vec![0.0; n];
        k.product_into(x, &mut kx);
        // |K|·|x| by columns (K is symmetric).
        let (col_ptr, row_idx, values) = (k.col_ptr(), k.row_idx(), k.values());
        let bound = (0..n)
            .map(|j| {
                let mut abs_kx = 0.0;
                for e in col_ptr[j]..col_ptr[j + 1] {
                    abs_kx += values[e].abs() * x[row_idx[e]].abs();
                }
                abs_kx
            })
            .collect();
        Ok((kx, bound))
    }
}

/// [`lowest_modes`] on any [`StiffnessOperator`] `k` with mass `mass`, converged until every
/// scaled residual is at most `tolerance`.
pub(crate) fn subspace_modes(
    k: &mut dyn StiffnessOperator,
    mass: &Mass,
    count: usize,
    tolerance: f64,
) -> Result<Modes> {
    let n = k.dim();
    if count == 0 || count > n {
        return Err(Error::invalid_parameter(
            "mode count",
            count,
            format!("must be between 1 and the free DOF count {n}"),
        ));
    }
    let p = n.min((2 * count).max(count + 8));
    if p == n {
        return all_modes(k, mass, count, tolerance);
    }
    k.factor()?;
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
    let mut work = vec![0.0; n];
    let mut best = f64::INFINITY;
    let mut best_iteration = 0;
    let mut residuals = Vec::new();
    for iteration in 1..=MAX_ITERATIONS {
        // A caller's Ctrl-C between iterations.
        crate::linalg::interrupt::poll(|| format!("modal subspace iteration {iteration}"))?;
        // Y = K⁻¹ M X
        let mut y = Vec::with_capacity(p);
        for column in &x {
            mass.product_into(column, &mut work);
            let mut solved = work.clone();
            k.solve_in_place(&mut solved)?;
            y.push(solved);
        }
        let (lambda, ritz) = rayleigh_ritz(k, mass, &y)?;
        x = ritz;
        if lambda
            .iter()
            .take(count)
            .any(|l| !(l.is_finite() && *l > 0.0))
        {
            return Err(Error::Solver(format!(
                "modal analysis: non-positive eigenvalue estimate {:?}",
                &lambda[..count]
            )));
        }
        residuals = (0..count)
            .map(|i| scaled_residual(k, mass, lambda[i], &x[i]))
            .collect::<Result<_>>()?;
        let worst = residuals.iter().fold(0.0f64, |a, &b| a.max(b));
        if worst <= tolerance {
            x.truncate(count);
            return Ok(Modes {
                omega: lambda[..count].iter().map(|l| l.sqrt()).collect(),
                shapes: x,
                iterations: iteration,
                residuals,
            });
        }
        if worst <= 0.5 * best {
            best = worst;
            best_iteration = iteration;
        } else if iteration - best_iteration >= STALL_ITERATIONS {
            return Err(Error::Solver(format!(
                "modal analysis stalled after {iteration} subspace iterations: scaled residuals \
                 [{}] of the {count} lowest modes, tolerance {tolerance:.0e}",
                list(&residuals)
            )));
        }
    }
    Err(Error::Solver(format!(
        "modal analysis did not converge in {MAX_ITERATIONS} subspace iterations: scaled \
         residuals [{}] of the {count} lowest modes, tolerance {tolerance:.0e}",
        list(&residuals)
    )))
}

/// Free DOF counts up to which a block as wide as the whole space is solved densely.
pub const DENSE_MODES_LIMIT: usize = 2000;

/// The `count` lowest modes when the block would span the whole space (`count` ≥ n/2, or
/// n ≤ count + 8): Rayleigh–Ritz on the unit vectors, i.e. the dense generalized eigenproblem,
/// exact in one step. (Subspace iteration there would start from n vectors that K⁻¹·M makes
/// nearly dependent, and lose rank.) Up to [`DENSE_MODES_LIMIT`] free DOFs.
fn all_modes(
    k: &mut dyn StiffnessOperator,
    mass: &Mass,
    count: usize,
    tolerance: f64,
) -> Result<Modes> {
    let n = k.dim();
    if n > DENSE_MODES_LIMIT {
        return Err(Error::invalid_parameter(
            "mode count",
            count,
            format!(
                "at most {} of the {n} free DOFs (half of them, less one): more needs the \
                 dense eigenproblem of all {n}, which is done up to {DENSE_MODES_LIMIT} DOFs",
                n.div_ceil(2) - 1
            ),
        ));
    }
    let units: Vec<Vec<f64>> = (0..n)
        .map(|j| (0..n).map(|i| if i == j { 1.0 } else { 0.0 }).collect())
        .collect();
    let (lambda, mut shapes) = rayleigh_ritz(k, mass, &units)?;
    if let Some(bad) = lambda
        .iter()
        .take(count)
        .find(|l| !(l.is_finite() && **l > 0.0))
    {
        return Err(Error::Solver(format!(
            "modal analysis: non-positive eigenvalue {bad:e}"
        )));
    }
    let residuals: Vec<f64> = (0..count)
        .map(|i| scaled_residual(k, mass, lambda[i], &shapes[i]))
        .collect::<Result<_>>()?;
    if residuals.iter().any(|r| r.is_nan() || *r > tolerance) {
        return Err(Error::Solver(format!(
            "modal analysis: the dense eigensolve left scaled residuals [{}] above \
             {tolerance:.0e}",
            list(&residuals)
        )));
    }
    shapes.truncate(count);
    Ok(Modes {
        omega: lambda[..count].iter().map(|l| l.sqrt()).collect(),
        shapes,
        iterations: 1,
        residuals,
    })
}

/// "1.2e-13, 3.4e-14, …" for an error message.
fn list(values: &[f64]) -> String {
    values
        .iter()
        .map(|v| format!("{v:.1e}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Rayleigh–Ritz on span(Y): the eigenvalues of Yᵀ·K·Y·z = λ·Yᵀ·M·Y·z, ascending, and the Ritz
/// vectors Y·z (M-orthonormal by construction).
fn rayleigh_ritz(
    k: &mut dyn StiffnessOperator,
    mass: &Mass,
    y: &[Vec<f64>],
) -> Result<(Vec<f64>, Vec<Vec<f64>>)> {
    let (n, p) = (k.dim(), y.len());
    let ky: Vec<Vec<f64>> = y.iter().map(|c| k.product(c)).collect::<Result<_>>()?;
    let my: Vec<Vec<f64>> = y
        .iter()
        .map(|c| {
            let mut out = vec![0.0; n];
            mass.product_into(c, &mut out);
            out
        })
        .collect();
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
        .try_inverse()
        .ok_or_else(|| Error::Solver("modal analysis: singular subspace".into()))?;
    let reduced = &l_inv * &kr * l_inv.transpose();
    let reduced = (&reduced + reduced.transpose()) * 0.5;
    let eigen = SymmetricEigen::new(reduced);
    let mut order: Vec<usize> = (0..p).collect();
    order.sort_by(|&a, &b| eigen.eigenvalues[a].total_cmp(&eigen.eigenvalues[b]));
    let z = l_inv.transpose() * &eigen.eigenvectors;
    let vectors = order
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
    Ok((
        order.iter().map(|&c| eigen.eigenvalues[c]).collect(),
        vectors,
    ))
}

/// ‖K·x − λ·M·x‖₂ / ‖(|K| + λ·|M|)·|x|‖₂ (see [`Modes::residuals`]).
fn scaled_residual(
    k: &mut dyn StiffnessOperator,
    mass: &Mass,
    lambda: f64,
    x: &[f64],
) -> Result<f64> {
    let n = x.len();
    let mut mx = vec![0.0; n];
    let (kx, abs_kx) = k.product_and_bound(x)?;
    mass.product_into(x, &mut mx);
    let magnitude: Vec<f64> = x.iter().map(|v| v.abs()).collect();
    // The mass matrices have no negative entries, so |M|·|x| = M·|x|.
    let mut scale = vec![0.0; n];
    mass.product_into(&magnitude, &mut scale);
    let (mut residual, mut bound) = (0.0, 0.0);
    for j in 0..n {
        let r = kx[j] - lambda * mx[j];
        let s = abs_kx[j] + lambda * scale[j];
        residual += r * r;
        bound += s * s;
    }
    Ok(if bound > 0.0 {
        (residual / bound).sqrt()
    } else {
        0.0
    })
}

/// The mass inner product φᵀ·M·ψ ([`Error::DimensionMismatch`] unless both vectors have the
/// mass matrix's dimension).
pub fn mass_inner_product(mass: &Mass, a: &[f64], b: &[f64]) -> Result<f64> {
    Error::check_len("a", mass.dim(), a.len())?;
    let mut mb = vec![0.0; b.len()];
    mass.mul_vec(b, &mut mb)?;
    Ok(a.iter().zip(&mb).map(|(x, y)| x * y).sum())
}

/// Effective modal mass fractions of each mode in the directions x, y, z (dimensionless), for
/// a base excitation: the supports and the body move together along d, so the influence vector
/// r_d is 1 on every DOF along d (constrained ones included). With φ M-orthonormal on the free
/// DOFs (zero on the constrained), the participation factor is Γ_d = φᵀ·M·r_d = Σᵢ φᵢ·(row sum
/// of M)ᵢ over the free DOFs along d, the effective mass Γ_d², and the fraction Γ_d² over the
/// total mass r_dᵀ·M·r_d. Engineering practice asks the retained modes to reach 0.9; all modes
/// together reach less than 1 by the mass the supports hold (with a lumped mass exactly the free
/// mass over the total).
///
/// `row_sums` (full length, 3 per node) are the row sums of the mass matrix, Σⱼ Mᵢⱼ: for the
/// linear tet the lumped mass ρV/4 per node for either mass kind
/// ([`lumped_mass_of`](crate::fe::assembly::lumped_mass_of)).
///
/// Errors: `row_sums` or a shape of the wrong length, or a direction with no mass.
pub fn effective_mass_fractions(
    modes: &Modes,
    dofs: &DofMap,
    row_sums: &[f64],
) -> Result<Vec<[f64; 3]>> {
    Error::check_len("mass row sums", dofs.full_count(), row_sums.len())?;
    let mut totals = [0.0; 3];
    for (dof, m) in row_sums.iter().enumerate() {
        totals[dof % 3] += m;
    }
    for d in 0..3 {
        if totals[d].is_nan() || totals[d] <= 0.0 {
            return Err(Error::invalid_parameter(
                "mass row sums",
                format!("total {:e} along {}", totals[d], ["x", "y", "z"][d]),
                "must be > 0: the body has mass in every direction",
            ));
        }
    }
    let free = dofs.free_dofs();
    modes
        .shapes
        .iter()
        .map(|shape| {
            Error::check_len("mode shape", free.len(), shape.len())?;
            let mut gamma = [0.0; 3];
            for (value, &dof) in shape.iter().zip(free) {
                gamma[dof % 3] += value * row_sums[dof];
            }
            Ok([0, 1, 2].map(|d| gamma[d] * gamma[d] / totals[d]))
        })
        .collect()
}
