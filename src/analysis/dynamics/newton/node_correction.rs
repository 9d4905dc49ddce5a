//! A kept factor of the Newton matrix, corrected at the nodes where J has moved away from it:
//! the preconditioner of CG on J in a contact run ([`super::direction`]).
//!
//! A rigid obstacle's barrier and friction act node by node: their Hessians are 3×3 blocks on
//! the diagonal of J, and between Newton iterations they change by orders of magnitude (b″(d)
//! grows as 1/d² when a gap closes; a node that sticks has friction's stiffness 2μλ/ε, ε a few
//! micrometres, one that slips almost none), while the elastic part moves little. The factor
//! B of J_k (the run's first iterate) knows the old blocks. With S the current diagonal blocks
//! of the nodes whose block changed, the preconditioner is the symmetric two-level one
//!
//! z₁ = S⁻¹r, z₂ = z₁ + B⁻¹(r − J·z₁), z = z₂ + S⁻¹(r − J·z₂)
//!
//! (block Jacobi on those nodes before and after the factor's solve): the changed nodes'
//! stiffness is solved locally, the rest of the body by the factor; one triangular solve pair
//! and one product with J an application, as before plus a product.

use nalgebra::Matrix3;

use crate::iterative::{CgOptions, CgReport, conjugate_gradient_with};
use crate::linear_solver::LinearSolver;
use crate::sparse::CscMatrix;

/// The free DOFs of one node: the first and how many (1 to 3), consecutive.
#[derive(Debug, Clone, Copy)]
pub(super) struct Group {
    pub first: usize,
    pub count: usize,
}

/// The groups of `free_dofs` (full DOF `3·node + axis` of each free DOF, increasing): one per
/// node with a free DOF.
pub(super) fn node_groups(free_dofs: &[usize]) -> Vec<Group> {
    let mut groups: Vec<Group> = Vec::new();
    for (i, &dof) in free_dofs.iter().enumerate() {
        match groups.last_mut() {
            Some(g) if free_dofs[g.first] / 3 == dof / 3 => g.count += 1,
            _ => groups.push(Group { first: i, count: 1 }),
        }
    }
    groups
}

/// The diagonal node blocks of the factored J and, at each solve, the nodes whose block has
/// changed with the inverse of their current block.
#[derive(Debug, Default)]
pub(crate) struct NodeCorrection {
    groups: Vec<Group>,
    /// The diagonal block of each group in the matrix last factored.
    factored: Vec<Matrix3<f64>>,
    /// The groups whose current block differs from the factored one, and the current block's
    /// inverse.
    changed: Vec<(Group, Matrix3<f64>)>,
}

impl NodeCorrection {
    /// The groups of `free_dofs` (full DOF `3·node + axis` of each free DOF, increasing).
    pub fn new(free_dofs: &[usize]) -> Self {
        NodeCorrection {
            groups: node_groups(free_dofs),
            factored: Vec::new(),
            changed: Vec::new(),
        }
    }

    /// Keeps the diagonal blocks of `matrix`, the matrix just factored.
    pub fn remember(&mut self, matrix: &CscMatrix) {
        self.factored = self.groups.iter().map(|&g| block(matrix, g)).collect();
        self.changed.clear();
    }

    /// Selects the nodes whose diagonal block of `matrix` differs from the factored one by
    /// more than `threshold` of it (Frobenius norms); returns how many.
    pub fn select(&mut self, matrix: &CscMatrix, threshold: f64) -> usize {
        self.changed.clear();
        if self.factored.len() != self.groups.len() {
            return 0;
        }
        for (&g, old) in self.groups.iter().zip(&self.factored) {
            let new = block(matrix, g);
            if (new - old).norm() > threshold * old.norm()
                && let Some(inverse) = new.try_inverse()
            {
                self.changed.push((g, inverse));
            }
        }
        self.changed.len()
    }

    /// z += S⁻¹·r on the changed nodes.
    fn add_local(&self, r: &[f64], z: &mut [f64]) {
        for (g, inverse) in &self.changed {
            for a in 0..g.count {
                let mut sum = 0.0;
                for b in 0..g.count {
                    sum += inverse[(a, b)] * r[g.first + b];
                }
                z[g.first + a] += sum;
            }
        }
    }

    /// t −= J·z for z zero outside the changed nodes (their columns of J only).
    fn subtract_local_product(&self, matrix: &CscMatrix, z: &[f64], t: &mut [f64]) {
        let (col_ptr, rows, values) = (matrix.col_ptr(), matrix.row_idx(), matrix.values());
        for (g, _) in &self.changed {
            for c in g.first..g.first + g.count {
                for k in col_ptr[c]..col_ptr[c + 1] {
                    t[rows[k]] -= values[k] * z[c];
                }
            }
        }
    }

    /// δ = J⁻¹·`rhs` in place by CG on `matrix` (J) to `options`, preconditioned by the
    /// solver's factor corrected at the selected nodes (see the module's docs); an
    /// [`Error::Solver`](tetfem_linalg::Error::Solver) as
    /// [`LinearSolver::solve_preconditioned`] gives it.
    pub fn solve(
        &self,
        solver: &mut LinearSolver,
        matrix: &CscMatrix,
        rhs: &mut [f64],
        options: CgOptions,
    ) -> tetfem_linalg::Result<CgReport> {
        let n = rhs.len();
        let (mut t, mut product, mut x) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        let report = conjugate_gradient_with(
            matrix,
            &mut |r, z| {
                z.fill(0.0);
                self.add_local(r, z);
                t.copy_from_slice(r);
                self.subtract_local_product(matrix, z, &mut t);
                solver.solve_approximate(matrix, &mut t)?;
                for (z, t) in z.iter_mut().zip(&t) {
                    *z += t;
                }
                matrix.product_into(z, &mut product);
                for ((t, r), p) in t.iter_mut().zip(r).zip(&product) {
                    *t = r - p;
                }
                self.add_local(&t, z);
                Ok(())
            },
            rhs,
            &mut x,
            options,
        )?;
        rhs.copy_from_slice(&x);
        Ok(report)
    }
}

/// The diagonal block of group `g` of `matrix` (identity where the node has fewer than three
/// free DOFs, so that it inverts).
pub(super) fn block(matrix: &CscMatrix, g: Group) -> Matrix3<f64> {
    let (col_ptr, rows, values) = (matrix.col_ptr(), matrix.row_idx(), matrix.values());
    let mut b = Matrix3::identity();
    for c in 0..g.count {
        let range = col_ptr[g.first + c]..col_ptr[g.first + c + 1];
        let column = &rows[range.clone()];
        let start = column.partition_point(|&r| r < g.first);
        for (k, &r) in column.iter().enumerate().skip(start) {
            if r >= g.first + g.count {
                break;
            }
            b[(r - g.first, c)] = values[range.start + k];
        }
    }
    b
}
