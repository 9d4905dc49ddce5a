//! Smoothed-aggregation algebraic multigrid (SA-AMG; Vaněk, Mandel & Brezina 1996) as a
//! preconditioner for conjugate gradients on elasticity stiffness matrices.
//!
//! Each level l has a matrix A_l (A₀ = A), a prolongator P_l from level l + 1, and the Galerkin
//! coarse operator A_{l+1} = P_lᵀ·A_l·P_l:
//! - the free DOFs are grouped by node (by aggregate below the finest level); nodes strongly
//!   connected, ‖A_ij‖_F ≥ θ·√(‖A_ii‖_F·‖A_jj‖_F), are aggregated greedily;
//! - the tentative prolongator P_tent holds, per aggregate, the Q of a thin QR of the
//!   near-null space B (the rigid-body modes), so that P_tent·B_c = B: the coarse space
//!   represents rigid motions exactly, which is what makes the iteration count nearly independent
//!   of the mesh for slender bodies whose low-energy modes are near-rigid;
//! - the prolongator is P = (I − ω·D⁻¹A)·P_tent, ω = 4/(3·λ_max(D⁻¹A)), D the node-block diagonal;
//! - the coarsest level (≤ [`AmgOptions::coarse_size`] DOFs) is factored by sparse Cholesky.
//!
//! One application of the preconditioner is a V(1,1) cycle with Chebyshev smoothing on D⁻¹A,
//! the same sweep before and after the coarse correction, so that the preconditioner is
//! symmetric positive definite as CG requires.

mod aggregation;
mod near_null;
mod rows;
mod smoother;

use std::sync::Mutex;

pub use near_null::{DofGeometry, NearNullSpace};
pub use rows::{MAX_COLUMNS, RowMatrix};

use self::rows::{Rows, TransposePlan, TransposeScratch};
use self::smoother::{BlockDiagonal, Chebyshev, Scratch};
use crate::error::{Error, Result};
use crate::linsolve::SparseCholesky;
use crate::preconditioner::Preconditioner;
use crate::sparse::CscMatrix;

/// Settings of [`SmoothedAggregation`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AmgOptions {
    /// Strength threshold θ: nodes i, j are connected when ‖A_ij‖_F ≥ θ·√(‖A_ii‖_F·‖A_jj‖_F)
    /// (dimensionless, default 0.04). Measured on the 5k×k×k beams: 0 gives huge aggregates on
    /// the coarse levels (51 CG iterations at k = 24 against 30 with 0.04); 0.12 splits the
    /// fine level's aggregates (operator complexity 12.9 at k = 16 against 1.4).
    pub strength_threshold: f64,
    /// Degree of the Chebyshev smoother, products with A per sweep (default 2).
    pub smoother_degree: usize,
    /// Lower end of the Chebyshev interval as a fraction of its upper end 1.1·λ_max(D⁻¹A)
    /// (default 1/30): the part of the spectrum the smoother damps, the rest is left to the
    /// coarse levels.
    pub smoother_range: f64,
    /// Coarsening stops at or below this many DOFs; that level is factored by Cholesky
    /// (default 2 000: a coarser level of a few hundred DOFs, aggregated on the nearly dense
    /// graph of its parent, costs iterations, 39 against 29 on the 40×8×8 beam).
    pub coarse_size: usize,
    /// At most this many levels, the coarsest included (default 12).
    pub max_levels: usize,
    /// Lanczos steps of the λ_max(D⁻¹A) estimate (default 15).
    pub lanczos_steps: usize,
}

impl Default for AmgOptions {
    fn default() -> Self {
        AmgOptions {
            strength_threshold: 0.04,
            smoother_degree: 2,
            smoother_range: 1.0 / 30.0,
            coarse_size: 2_000,
            max_levels: 12,
            lanczos_steps: 15,
        }
    }
}

impl AmgOptions {
    fn validate(&self) -> Result<()> {
        let bad = |name: &str, value: String, requirement: &str| {
            Err(Error::invalid_parameter(name, value, requirement))
        };
        if !(self.strength_threshold >= 0.0 && self.strength_threshold < 1.0) {
            return bad(
                "strength_threshold",
                self.strength_threshold.to_string(),
                "must be in [0, 1)",
            );
        }
        if self.smoother_degree == 0 || self.smoother_degree > 10 {
            return bad(
                "smoother_degree",
                self.smoother_degree.to_string(),
                "must be 1 to 10",
            );
        }
        if !(self.smoother_range > 0.0 && self.smoother_range < 1.0) {
            return bad(
                "smoother_range",
                self.smoother_range.to_string(),
                "must be in (0, 1)",
            );
        }
        if self.max_levels == 0 || self.lanczos_steps == 0 {
            return bad(
                "max_levels/lanczos_steps",
                format!("{}/{}", self.max_levels, self.lanczos_steps),
                "must be at least 1",
            );
        }
        Ok(())
    }
}

/// One coarsening step A → Pᵀ·A·P, exposed so that its properties can be checked.
#[derive(Debug, Clone)]
pub struct Coarsening {
    /// P_tent (n × n_c): orthonormal columns, P_tent·B_c = B.
    pub tentative: RowMatrix,
    /// P = (I − ω·D⁻¹A)·P_tent.
    pub prolongator: RowMatrix,
    /// Pᵀ·A·P, symmetric (averaged with its transpose to the last bit).
    pub coarse_matrix: CscMatrix,
    /// B_c, the near-null space of the coarse level (blocks: the aggregates).
    pub coarse_near_null_space: NearNullSpace,
    /// The Lanczos estimate of λ_max(D⁻¹A).
    pub lambda_max: f64,
}

/// One coarsening step of `matrix` (symmetric, both triangles stored) with near-null space
/// `near_null` (same dimension): aggregation, P_tent, P, and Pᵀ·A·P.
pub fn coarsen(
    matrix: &CscMatrix,
    near_null: &NearNullSpace,
    options: &AmgOptions,
) -> Result<Coarsening> {
    options.validate()?;
    rows::check_columns("matrix dimension", matrix.dim())?;
    Error::check_len("near-null space rows", matrix.dim(), near_null.dim())?;
    Ok(coarsen_level(matrix, near_null, options, true)?.0)
}

/// One coarsening step; without `keep_tentative` P_tent is freed as soon as P is built (the
/// returned one is then empty), which lowers the peak memory of the Galerkin product.
fn coarsen_level(
    matrix: &CscMatrix,
    near_null: &NearNullSpace,
    options: &AmgOptions,
    keep_tentative: bool,
) -> Result<(Coarsening, BlockDiagonal)> {
    let starts = near_null.starts();
    let diagonal = BlockDiagonal::new(matrix, starts)?;
    let lambda_max = smoother::largest_eigenvalue(matrix, &diagonal, options.lanczos_steps)?;
    let a = Rows::of_symmetric(matrix);
    let n = matrix.dim();
    let mut block_of = vec![0usize; n];
    for b in 0..starts.len().saturating_sub(1) {
        block_of[starts[b]..starts[b + 1]].fill(b);
    }
    let graph = aggregation::strength_graph(a, starts, &block_of, options.strength_threshold);
    drop(block_of);
    let (aggregate_of, aggregates) = aggregation::aggregate(&graph);
    drop(graph);
    let (mut tentative, coarse_near_null_space) =
        aggregation::tentative_prolongator(near_null, &aggregate_of, aggregates)?;
    drop(aggregate_of);
    let omega = 4.0 / (3.0 * lambda_max);
    // P = P_tent − ω·(D⁻¹·A)·P_tent, fused: neither A·P_tent nor D⁻¹·A·P_tent is stored whole.
    let prolongator = rows::triple_product(
        Some((1.0, &tentative)),
        -omega,
        diagonal.inverse_rows()?.rows(),
        a,
        n,
        &tentative,
    );
    if !keep_tentative {
        tentative = RowMatrix::empty(n, tentative.ncols());
    }
    // Pᵀ·A·P as (Pᵀ·A)·P by chunks of coarse rows: A·P, several times P's size, is never stored;
    // Pᵀ lives only for this product (the V-cycle restricts with P's transpose product).
    let mut coarse = {
        let restriction = prolongator.transpose()?;
        rows::triple_product(None, 1.0, restriction.rows(), a, n, &prolongator)
    };
    coarse.symmetrize()?;
    let coarse_matrix = coarse.into_symmetric_csc()?;
    Ok((
        Coarsening {
            tentative,
            prolongator,
            coarse_matrix,
            coarse_near_null_space,
            lambda_max,
        },
        diagonal,
    ))
}

/// A level above the coarsest: its matrix, smoother, and the transfers to the next level.
#[derive(Debug)]
struct Level {
    matrix: CscMatrix,
    diagonal: BlockDiagonal,
    smoother: Chebyshev,
    /// P (n_l × n_{l+1}); the restriction is its transpose product (Pᵀ is not stored).
    prolongator: RowMatrix,
    /// The fixed partition of P's rows for the transpose product.
    restriction: TransposePlan,
}

/// Vectors of one level, allocated once.
#[derive(Debug)]
struct LevelWork {
    residual: Vec<f64>,
    direction: Vec<f64>,
    product: Vec<f64>,
    coarse_rhs: Vec<f64>,
    coarse_solution: Vec<f64>,
    /// Buffers of the restriction Pᵀ·r.
    restriction: TransposeScratch,
}

#[derive(Debug)]
struct Workspace {
    levels: Vec<LevelWork>,
    coarsest: SparseCholesky,
}

/// Smoothed-aggregation AMG preconditioner: z = M⁻¹·r is one V(1,1) cycle (see the
/// [module docs](self)); symmetric positive definite for SPD A.
#[derive(Debug)]
pub struct SmoothedAggregation {
    dim: usize,
    levels: Vec<Level>,
    coarsest_dim: usize,
    coarsest_nnz: usize,
    /// The cycle's vectors and the coarsest factor, whose solve needs `&mut`.
    work: Mutex<Workspace>,
}

/// Dimension and stored entries of one level's matrix.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LevelSize {
    /// Rows (= columns).
    pub dim: usize,
    /// Stored entries (both triangles).
    pub nnz: usize,
}

impl SmoothedAggregation {
    /// The hierarchy for `matrix` (symmetric positive definite, both triangles stored) with the
    /// rigid-body modes from `geometry`, or without it the three translations; default
    /// [`AmgOptions`].
    pub fn new(matrix: &CscMatrix, geometry: Option<&DofGeometry>) -> Result<Self> {
        let near_null = match geometry {
            Some(geometry) => {
                Error::check_len("DofGeometry DOFs", matrix.dim(), geometry.len())?;
                NearNullSpace::rigid_body(geometry)?
            }
            None => NearNullSpace::translations(matrix),
        };
        SmoothedAggregation::with_options(matrix, near_null, AmgOptions::default())
    }

    /// The hierarchy for `matrix` with a given near-null space and options. The finest matrix
    /// is copied (the smoother needs it and the trait's `apply` does not receive it).
    pub fn with_options(
        matrix: &CscMatrix,
        near_null: NearNullSpace,
        options: AmgOptions,
    ) -> Result<Self> {
        options.validate()?;
        let dim = matrix.dim();
        rows::check_columns("matrix dimension", dim)?;
        Error::check_len("near-null space rows", dim, near_null.dim())?;
        if dim <= options.coarse_size {
            // No level above the Cholesky-factored one: still name a bad diagonal block as the
            // multigrid levels would.
            BlockDiagonal::new(matrix, near_null.starts())?;
        }
        let mut levels = Vec::new();
        let mut scratches = Vec::new();
        let mut current = matrix.clone();
        let mut modes = near_null;
        while current.dim() > options.coarse_size && levels.len() + 1 < options.max_levels {
            let (coarsening, diagonal) = coarsen_level(&current, &modes, &options, false)?;
            let coarse_dim = coarsening.coarse_matrix.dim();
            // Aggregation that no longer reduces the size would only add cost.
            if coarse_dim == 0 || 10 * coarse_dim > 9 * current.dim() {
                break;
            }
            let (restriction, scratch) = TransposePlan::new(&coarsening.prolongator);
            let upper = 1.1 * coarsening.lambda_max;
            let lower = options.smoother_range * upper;
            levels.push(Level {
                matrix: current,
                diagonal,
                smoother: Chebyshev {
                    centre: 0.5 * (upper + lower),
                    half_width: 0.5 * (upper - lower),
                    degree: options.smoother_degree,
                },
                prolongator: coarsening.prolongator,
                restriction,
            });
            scratches.push(scratch);
            current = coarsening.coarse_matrix;
            modes = coarsening.coarse_near_null_space;
        }
        let mut coarsest = SparseCholesky::analyze(&current)?;
        coarsest.factorize(&current)?;
        let work = levels
            .iter()
            .zip(scratches)
            .map(|(level, restriction)| {
                let (n, nc) = (level.matrix.dim(), level.prolongator.ncols());
                LevelWork {
                    residual: vec![0.0; n],
                    direction: vec![0.0; n],
                    product: vec![0.0; n],
                    coarse_rhs: vec![0.0; nc],
                    coarse_solution: vec![0.0; nc],
                    restriction,
                }
            })
            .collect();
        Ok(SmoothedAggregation {
            dim,
            levels,
            coarsest_dim: current.dim(),
            coarsest_nnz: current.nnz(),
            work: Mutex::new(Workspace {
                levels: work,
                coarsest,
            }),
        })
    }

    /// Dimension and nnz of every level, finest first, the Cholesky-factored coarsest last.
    pub fn level_sizes(&self) -> Vec<LevelSize> {
        self.levels
            .iter()
            .map(|l| LevelSize {
                dim: l.matrix.dim(),
                nnz: l.matrix.nnz(),
            })
            .chain(std::iter::once(LevelSize {
                dim: self.coarsest_dim,
                nnz: self.coarsest_nnz,
            }))
            .collect()
    }

    /// Operator complexity Σ_l nnz(A_l) / nnz(A₀): the memory and per-cycle cost of the
    /// hierarchy relative to the matrix alone.
    pub fn operator_complexity(&self) -> f64 {
        let sizes = self.level_sizes();
        let total: usize = sizes.iter().map(|s| s.nnz).sum();
        total as f64 / sizes[0].nnz.max(1) as f64
    }
}

/// x = V-cycle(b) from level `levels[0]` down: pre-smoothing from x = 0, restriction of the
/// residual, the coarse correction (recursively; Cholesky at the bottom), post-smoothing.
fn cycle(
    levels: &[Level],
    work: &mut [LevelWork],
    coarsest: &mut SparseCholesky,
    b: &[f64],
    x: &mut [f64],
) -> Result<()> {
    let (Some((level, deeper)), [this, deeper_work @ ..]) = (levels.split_first(), work) else {
        x.copy_from_slice(b);
        return coarsest.solve_in_place(x);
    };
    let LevelWork {
        residual,
        direction,
        product,
        coarse_rhs,
        coarse_solution,
        restriction,
    } = this;
    let (a, d) = (&level.matrix, &level.diagonal);
    level.smoother.smooth(
        a,
        d,
        b,
        x,
        true,
        Scratch {
            residual,
            direction,
            product,
        },
    );
    a.product_into(x, product);
    let product_ro: &[f64] = product;
    smoother::zip_apply(residual, |i, r| *r = b[i] - product_ro[i]);
    level
        .prolongator
        .transpose_product_into(&level.restriction, restriction, residual, coarse_rhs);
    cycle(deeper, deeper_work, coarsest, coarse_rhs, coarse_solution)?;
    level.prolongator.product_into(coarse_solution, x, true);
    level.smoother.smooth(
        a,
        d,
        b,
        x,
        false,
        Scratch {
            residual,
            direction,
            product,
        },
    );
    Ok(())
}

impl Preconditioner for SmoothedAggregation {
    fn dim(&self) -> usize {
        self.dim
    }

    fn apply(&self, r: &[f64], z: &mut [f64]) -> Result<()> {
        Error::check_len("r", self.dim, r.len())?;
        Error::check_len("z", self.dim, z.len())?;
        let mut work = self
            .work
            .lock()
            .map_err(|_| Error::Solver("smoothed aggregation: a previous apply panicked".into()))?;
        let Workspace { levels, coarsest } = &mut *work;
        cycle(&self.levels, levels, coarsest, r, z)
    }
}
