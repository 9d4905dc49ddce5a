//! The static Newton step with the surface barrier's off-pattern Hessian entries: the factored
//! tangent P holds each as |v| on its row's diagonal (PSD, above the exact J); the step solves
//! the exact J·δ = r by conjugate gradients preconditioned by P's factor, as the implicit
//! dynamic step does (the lumped P alone converged linearly: 5.7e-6 of the reference after 200
//! iterations of one load step of a block resting on another). [`solve_with_lumped`] is that
//! solve for both.

use std::sync::Arc;

use faer::sparse::SymbolicSparseColMat;

use crate::base::error::Result;
use crate::bc::constraints::DofMap;
use crate::contact::surface::SurfaceContact;
use crate::linear_solver::LinearSolver;
use crate::linsolve::SparseCholesky;
use crate::sparse::CscMatrix;

/// Most CG iterations: a few low modes (the bodies' common motion that the lumped coupling
/// resists) hold the preconditioned spectrum's spread.
const LUMPED_CG_ITERATIONS: usize = 100;

/// The last tangent's lumped entries of `surface` ([`SurfaceContact::lumped_entries`]) on the
/// free DOFs of `dofs`: (row, column or `None` where the column is supported, v); rows on
/// supported DOFs are dropped.
pub(super) fn free_lumped_entries(
    surface: &SurfaceContact,
    dofs: &DofMap,
) -> Vec<(usize, Option<usize>, f64)> {
    surface
        .lumped_entries()
        .into_iter()
        .filter_map(|(r, c, v)| Some((dofs.free_index(r)?, dofs.free_index(c), v)))
        .collect()
}

/// Solves J·δ = b (`delta` holding b on entry) for J = P + Σ (v at (r, c) − |v| at (r, r))
/// over `lumped`, P the factored `matrix`: conjugate gradients preconditioned by P's factor.
/// P − J is PSD, so P⁻¹J has its spectrum in (0, 1]. Stops at 1e-12 of ‖b‖ in the
/// preconditioned norm, or at non-positive curvature (keeping the iterate reached, which
/// started from P⁻¹b: a descent direction either way); a non-finite or zero iterate falls
/// back to P⁻¹b.
pub(crate) fn solve_with_lumped(
    solver: &mut LinearSolver,
    matrix: &CscMatrix,
    lumped: &[(usize, Option<usize>, f64)],
    delta: &mut [f64],
) -> Result<()> {
    let n = delta.len();
    let b = delta.to_vec();
    let apply = |x: &[f64], out: &mut [f64]| {
        matrix.product_into(x, out);
        for &(r, c, v) in lumped {
            out[r] -= v.abs() * x[r];
            if let Some(c) = c {
                out[r] += v * x[c];
            }
        }
    };
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let mut x = vec![0.0; n];
    let mut r = b.clone();
    let mut z = r.clone();
    solver.solve(matrix, &mut z)?;
    let mut p = z.clone();
    let mut rz = dot(&r, &z);
    let stop = 1e-24 * rz;
    let mut ap = vec![0.0; n];
    for _ in 0..LUMPED_CG_ITERATIONS {
        apply(&p, &mut ap);
        let curvature = dot(&p, &ap);
        if curvature.is_nan() || curvature <= 0.0 {
            break;
        }
        let alpha = rz / curvature;
        x.iter_mut().zip(&p).for_each(|(x, p)| *x += alpha * p);
        r.iter_mut().zip(&ap).for_each(|(r, a)| *r -= alpha * a);
        z.copy_from_slice(&r);
        solver.solve(matrix, &mut z)?;
        let next = dot(&r, &z);
        if next <= stop {
            break;
        }
        let beta = next / rz;
        rz = next;
        p.iter_mut().zip(&z).for_each(|(p, z)| *p = z + beta * *p);
    }
    if x.iter().all(|v| v.is_finite()) && x.iter().any(|&v| v != 0.0) {
        delta.copy_from_slice(&x);
    } else {
        delta.copy_from_slice(&b);
        solver.solve(matrix, delta)?;
    }
    Ok(())
}

/// The exact J = P + Σ (v at (r, c) − |v| at (r, r)) factored on its own pattern: P's pattern
/// (the stiffness pattern on the free DOFs) with the lumped entries' positions added, so the
/// Newton direction is J⁻¹·b by one factorization and a pair of triangular solves, not CG on
/// P's factor (which converges linearly in the bodies' common motion that the contact couples:
/// the 8-block stack's step 2 stalled at 2.4e-6 of its residual after 25 Newton iterations of
/// 100 CG iterations each, see `validation/block_stack.md`).
///
/// The added positions only grow: a pattern that holds every pair met so far holds a settling
/// stack's pairs after its first contacts, so the symbolic analysis (the fill-reducing ordering,
/// about a numeric factorization's cost) is redone only when a pair couples two DOFs for the
/// first time. Entries of pairs no longer active are stored zeros.
#[derive(Default)]
pub(crate) struct CoupledFactor {
    /// The base pattern the coupled one extends (the Newton matrix's).
    base: Option<Arc<SymbolicSparseColMat<usize>>>,
    /// The added positions (column, row), sorted: both triangles, never on the base pattern.
    added: Vec<(usize, usize)>,
    /// J on the coupled pattern.
    matrix: Option<CscMatrix>,
    /// The coupled index of each base entry.
    base_to_coupled: Vec<usize>,
    /// The factor of `matrix` (its symbolic analysis made when the pattern was built).
    cholesky: Option<SparseCholesky>,
}

impl CoupledFactor {
    /// Forms the exact J from `matrix` (P, lumped entries on its diagonal) and `lumped` (free
    /// (row, column or `None`, v), see [`solve_with_lumped`]) on the coupled pattern (grown
    /// when an entry's position is new) and factors it. `Ok(false)`: J is not positive
    /// definite (the caller projects or falls back to [`solve_with_lumped`]).
    pub(crate) fn factor(
        &mut self,
        matrix: &CscMatrix,
        lumped: &[(usize, Option<usize>, f64)],
    ) -> Result<bool> {
        let same_base = self
            .base
            .as_ref()
            .is_some_and(|b| Arc::ptr_eq(b, matrix.pattern()));
        // A new position shows as a lumped entry the coupled pattern lacks (its mirror was
        // added with it: the pattern holds both triangles of every position added). Found while
        // filling, so a step whose pairs are all known pays no pass of its own; sorting the
        // wanted positions at every iteration, as before, took 5 % of an 8-block stack's run.
        let known = same_base && self.cholesky.is_some() && self.fill(matrix, lumped);
        if !known {
            // Both triangles: the factorization's analysis reads one, its numeric phase the
            // other, and a pair's mirror entry may be missing from the list (its row supported,
            // or the Hessian's triplets one-sided at round-off zeros).
            let mut wanted: Vec<(usize, usize)> = lumped
                .iter()
                .filter_map(|&(r, c, _)| c.map(|c| [(c, r), (r, c)]))
                .flatten()
                .collect();
            if same_base {
                wanted.extend_from_slice(&self.added);
            }
            wanted.sort_unstable();
            wanted.dedup();
            self.build(matrix, wanted)?;
            if !self.fill(matrix, lumped) {
                return Err(unbuilt());
            }
        }
        let (Some(coupled), Some(cholesky)) = (self.matrix.as_mut(), self.cholesky.as_mut()) else {
            return Err(unbuilt());
        };
        match cholesky.factorize(coupled) {
            Ok(()) => Ok(true),
            Err(tetfem_linalg::Error::NotPositiveDefinite { .. }) => Ok(false),
            Err(other) => Err(other.into()),
        }
    }

    /// J's values on the coupled pattern: `matrix`'s (P) through the base map, less each
    /// lumped |v| on its row's diagonal, plus v at its position. `false` when the pattern
    /// lacks a lumped entry's position (or there is no pattern yet).
    fn fill(&mut self, matrix: &CscMatrix, lumped: &[(usize, Option<usize>, f64)]) -> bool {
        let Some(coupled) = self.matrix.as_mut() else {
            return false;
        };
        let values = coupled.values_mut();
        values.iter_mut().for_each(|v| *v = 0.0);
        for (&k, &v) in self.base_to_coupled.iter().zip(matrix.values()) {
            values[k] += v;
        }
        for &(r, c, v) in lumped {
            let Some(diagonal) = position(coupled, r, r) else {
                return false;
            };
            coupled.values_mut()[diagonal] -= v.abs();
            if let Some(c) = c {
                let Some(k) = position(coupled, r, c) else {
                    return false;
                };
                coupled.values_mut()[k] += v;
            }
        }
        true
    }

    /// J⁻¹·b in place, J the last one [`factor`](Self::factor) factored.
    pub(crate) fn solve(&mut self, rhs: &mut [f64]) -> Result<()> {
        match self.cholesky.as_mut() {
            Some(cholesky) => Ok(cholesky.solve_in_place(rhs)?),
            None => Err(unbuilt()),
        }
    }

    /// The union of `matrix`'s pattern and `added` (column, row), its map and its analysis.
    fn build(&mut self, matrix: &CscMatrix, added: Vec<(usize, usize)>) -> Result<()> {
        let n = matrix.dim();
        let (col_ptr, rows) = (matrix.col_ptr(), matrix.row_idx());
        let mut new_ptr = Vec::with_capacity(n + 1);
        let mut new_rows = Vec::with_capacity(rows.len() + added.len());
        let mut map = Vec::with_capacity(rows.len());
        let mut next = 0;
        new_ptr.push(0);
        for c in 0..n {
            let start = next;
            while next < added.len() && added[next].0 == c {
                next += 1;
            }
            let extra = &added[start..next];
            let (mut i, mut j) = (col_ptr[c], 0);
            while i < col_ptr[c + 1] || j < extra.len() {
                if j == extra.len() || (i < col_ptr[c + 1] && rows[i] < extra[j].1) {
                    map.push(new_rows.len());
                    new_rows.push(rows[i]);
                    i += 1;
                } else {
                    new_rows.push(extra[j].1);
                    j += 1;
                }
            }
            new_ptr.push(new_rows.len());
        }
        let pattern = SymbolicSparseColMat::new_checked(n, n, new_ptr, None, new_rows);
        let coupled = CscMatrix::zeros(Arc::new(pattern))?;
        self.cholesky = Some(SparseCholesky::analyze(&coupled)?);
        self.matrix = Some(coupled);
        self.base_to_coupled = map;
        self.base = Some(Arc::clone(matrix.pattern()));
        self.added = added;
        Ok(())
    }
}

/// The index in `matrix`'s values of entry (row, col), `None` where the pattern has none.
fn position(matrix: &CscMatrix, row: usize, col: usize) -> Option<usize> {
    let range = matrix.col_ptr()[col]..matrix.col_ptr()[col + 1];
    matrix.row_idx()[range.clone()]
        .binary_search(&row)
        .ok()
        .map(|k| range.start + k)
}

/// The error of a coupled factor used before [`CoupledFactor::factor`] built it, or of a base
/// pattern without a diagonal entry (the stiffness pattern stores every one).
fn unbuilt() -> crate::base::error::Error {
    crate::base::error::Error::invalid_parameter(
        "coupled factor",
        "no pattern entry",
        "factor on a pattern with every diagonal entry before solving",
    )
}
