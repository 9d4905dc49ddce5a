//! tetfem's numeric supernodal Cholesky factorization on faer's symbolic structure, writing
//! faer's layout of the factor (so that faer's and tetfem's solves both read it).
//!
//! Why not faer's `factorize_numeric_llt`: it forms each update L_d,mid·L_d,midᵀ of a supernode
//! by its descendants with the right-hand factor as a transposed (row-major) view, a layout in
//! which faer's matrix product runs at 13–25 GFLOP/s once the inner dimension reaches a few
//! hundred, against 31–35 GFLOP/s for a contiguous column-major right-hand side (measured here,
//! one thread, m = 1000–2048, k = 300–2048); the big separators of nested dissection spend most
//! of the factorization's flops in exactly those products. It also has no tree parallelism: its
//! threads only split dense kernels, which the many small supernodes below the top separators
//! cannot use.
//!
//! The algorithm is left-looking, as in CHOLMOD: for each supernode s in order, gather A's
//! columns, subtract the update of every descendant d whose rows meet s's columns (a dense
//! product into a buffer, then a scatter through relative indices), factor the diagonal block
//! and solve for the rows below it. Updates are cut into blocks of at most [`UPDATE_COLUMNS`]
//! target columns so that the buffer stays small and the product skips the strictly upper part
//! of each update, block by block.
//!
//! Two threads: the two independent halves of the elimination tree below its top separators
//! (balanced by flops) are factored concurrently, each thread owning its supernodes' values;
//! then each top supernode is factored with both threads, which split its target columns for
//! the updates and share the dense kernels.
//!
//! Measured side by side with faer's kernel (`benches/factorization.rs`, 139k DOFs, quiet
//! machine): 0.88× its time on one thread, 0.63× on two; against CHOLMOD with METIS in one run
//! (`validation/SIDE_BY_SIDE.md`): 0.64–0.82× on one thread, 0.76–0.79× on two at 140k–266k DOFs.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::{LltError, cholesky_in_place, cholesky_in_place_scratch};
use faer::linalg::matmul::matmul;
use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::mat::{MatMut, MatRef};
use faer::{Accum, Par};
use std::ops::Range;

use super::{SupernodalPlan, Supernode};

/// Largest number of target columns per block of an update: the buffer holds at most
/// `rows × UPDATE_COLUMNS` values, and a block this wide keeps the product's efficiency (the
/// product's inner dimension is the descendant's width, not this).
const UPDATE_COLUMNS: usize = 512;

/// The matrix to factor, in compressed columns with both triangles (as [`crate::CscMatrix`]).
#[derive(Clone, Copy)]
pub(crate) struct Columns<'a> {
    pub col_ptr: &'a [usize],
    pub row_idx: &'a [usize],
    pub values: &'a [f64],
}

/// Who updates whom, and the flop-balanced two-thread split, derived once per pattern.
#[derive(Debug)]
pub(crate) struct FactorPlan {
    /// `updates[update_ptr[s]..update_ptr[s + 1]]`: the supernodes d < s with a row in s's
    /// columns, ascending.
    update_ptr: Vec<usize>,
    updates: Vec<usize>,
    /// Supernodes of each thread's independent subtrees, and of the top (both threads).
    parts: [Vec<usize>; 2],
    top: Vec<usize>,
    all: Vec<usize>,
    max_ncols: usize,
    max_rows: usize,
    /// Target columns per block of an update ([`UPDATE_COLUMNS`]; tests use fewer, so that
    /// small matrices cross block boundaries).
    block_columns: usize,
}

/// One thread's buffers.
#[derive(Debug, Default)]
struct ThreadBuffers {
    /// Local row of each global row in the current supernode's below-diagonal block.
    local_row: Vec<usize>,
    scratch: UpdateBuffers,
}

/// Buffers of one update: the relative indices of the descendant's rows in the target, its
/// transposed right factor and the product.
#[derive(Debug, Default)]
struct UpdateBuffers {
    relative: Vec<usize>,
    transposed: Vec<f64>,
    product: Vec<f64>,
}

/// Buffers of a factorization, allocated on first use and reused.
#[derive(Default)]
pub(crate) struct FactorWorkspace {
    threads: [ThreadBuffers; 2],
    /// Workspaces of the dense Cholesky kernel, one per thread.
    dense: [Option<MemBuffer>; 2],
}

impl std::fmt::Debug for FactorWorkspace {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FactorWorkspace").finish_non_exhaustive()
    }
}

impl std::fmt::Debug for Columns<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Columns")
            .field("ncols", &(self.col_ptr.len().saturating_sub(1)))
            .finish_non_exhaustive()
    }
}

/// Flops of factoring supernode `node` and of its updates to the ancestors:
/// c³/3 (diagonal block) + b·c² (rows below) + b²·c (updates), with c columns and b rows below.
fn flops(node: &Supernode) -> f64 {
    let (c, b) = (node.ncols as f64, node.below as f64);
    c * c * c / 3.0 + b * c * c + b * b * c
}

impl FactorPlan {
    /// The update lists (from the supernodes' row patterns) and the two-thread split of
    /// `plan`'s elimination tree, balanced by [`flops`].
    pub(crate) fn new(plan: &SupernodalPlan) -> Self {
        let count = plan.nodes.len();
        let mut col_node = vec![0usize; plan.dim];
        for (s, node) in plan.nodes.iter().enumerate() {
            col_node[node.first..node.first + node.ncols].fill(s);
        }
        let col_node = &col_node;
        let targets = |d: usize| {
            let node = plan.nodes[d];
            let rows = &plan.row_idx[node.row_start..][..node.below];
            let mut last = usize::MAX;
            rows.iter().filter_map(move |&r| {
                let s = col_node[r];
                (s != last).then(|| {
                    last = s;
                    s
                })
            })
        };
        let mut update_ptr = vec![0usize; count + 1];
        for d in 0..count {
            for s in targets(d) {
                update_ptr[s + 1] += 1;
            }
        }
        for s in 0..count {
            update_ptr[s + 1] += update_ptr[s];
        }
        let mut next = update_ptr.clone();
        let mut updates = vec![0usize; update_ptr[count]];
        for d in 0..count {
            for s in targets(d) {
                updates[next[s]] = d;
                next[s] += 1;
            }
        }
        let work: Vec<f64> = plan.nodes.iter().map(|n| flops(n) + 1e4).collect();
        let owner = plan.two_thread_owner(&work);
        FactorPlan {
            update_ptr,
            updates,
            parts: [
                (0..count).filter(|&s| owner[s] == 0).collect(),
                (0..count).filter(|&s| owner[s] == 1).collect(),
            ],
            top: (0..count).filter(|&s| owner[s] == 2).collect(),
            all: (0..count).collect(),
            max_ncols: plan.nodes.iter().map(|n| n.ncols).max().unwrap_or(0),
            max_rows: plan
                .nodes
                .iter()
                .map(|n| n.ncols + n.below)
                .max()
                .unwrap_or(0),
            block_columns: UPDATE_COLUMNS,
        }
    }

    /// Bytes of the workspace of [`factorize`](Self::factorize) on two threads (one thread
    /// uses about half): per thread the row map (8 B per row of the matrix), the relative
    /// indices, the update buffers and the dense Cholesky kernel's scratch.
    pub(crate) fn workspace_bytes(&self, plan: &SupernodalPlan) -> usize {
        let block = self.block_columns.min(self.max_ncols);
        let update = self.max_rows + (self.max_ncols + self.max_rows) * block;
        let dense =
            cholesky_in_place_scratch::<f64>(self.max_ncols, Par::rayon(2), Default::default())
                .size_bytes();
        2 * (8 * (plan.dim + update) + dense)
    }

    /// The same plan with at most `block_columns` target columns per update block.
    #[cfg(test)]
    pub(crate) fn with_block_columns(mut self, block_columns: usize) -> Self {
        self.block_columns = block_columns.max(1);
        self
    }

    /// Factors `matrix` (the analysed pattern, both triangles) into `values` (faer's layout).
    /// Returns the permuted index of the first non-positive pivot met on failure.
    pub(crate) fn factorize(
        &self,
        plan: &SupernodalPlan,
        matrix: Columns<'_>,
        values: &mut [f64],
        threads: usize,
        ws: &mut FactorWorkspace,
    ) -> Result<(), usize> {
        let two = threads >= 2 && !self.parts[0].is_empty() && !self.parts[1].is_empty();
        let par = if two { Par::rayon(2) } else { Par::Seq };
        for buffers in &mut ws.threads {
            buffers.local_row.resize(plan.dim, 0);
            let scratch = &mut buffers.scratch;
            scratch.relative.resize(self.max_rows, 0);
            let block = self.block_columns.min(self.max_ncols);
            scratch.transposed.resize(self.max_ncols * block, 0.0);
            scratch.product.resize(self.max_rows * block, 0.0);
        }
        let scratch = || {
            MemBuffer::new(cholesky_in_place_scratch::<f64>(
                self.max_ncols,
                Par::rayon(2),
                Default::default(),
            ))
        };
        let [dense0, dense1] = &mut ws.dense;
        let dense0 = dense0.get_or_insert_with(scratch);
        let mut slices: Vec<Option<&mut [f64]>> = Vec::with_capacity(plan.nodes.len());
        let mut rest = values;
        for node in &plan.nodes {
            let len = node.ncols * (node.ncols + node.below);
            let (block, tail) = std::mem::take(&mut rest).split_at_mut(len);
            slices.push(Some(block));
            rest = tail;
        }
        let [ws0, ws1] = &mut ws.threads;
        if !two {
            let stack = MemStack::new(dense0);
            return self.factor_list(plan, &self.all, matrix, &mut slices, ws0, stack);
        }
        // Each thread owns its subtrees' values; the top's stay behind for the second phase.
        let dense1 = dense1.get_or_insert_with(scratch);
        let mut own1: Vec<Option<&mut [f64]>> = (0..slices.len()).map(|_| None).collect();
        for &s in &self.parts[1] {
            own1[s] = slices[s].take();
        }
        let (r0, r1) = rayon::join(
            || {
                let stack = MemStack::new(dense0);
                self.factor_list(plan, &self.parts[0], matrix, &mut slices, ws0, stack)
            },
            || {
                let stack = MemStack::new(dense1);
                self.factor_list(plan, &self.parts[1], matrix, &mut own1, ws1, stack)
            },
        );
        match (r0, r1) {
            (Err(a), Err(b)) => return Err(a.min(b)),
            (Err(a), _) | (_, Err(a)) => return Err(a),
            _ => {}
        }
        for &s in &self.parts[1] {
            slices[s] = own1[s].take();
        }
        for &s in &self.top {
            let block = slices[s].take().expect("each supernode is factored once");
            let stack = MemStack::new(dense0);
            let result = self.factor_node_two(
                plan,
                s,
                matrix,
                block,
                &slices,
                [&mut *ws0, &mut *ws1],
                stack,
                par,
            );
            slices[s] = Some(block);
            result?;
        }
        Ok(())
    }

    /// Factors the supernodes of `list` in order on this thread.
    fn factor_list(
        &self,
        plan: &SupernodalPlan,
        list: &[usize],
        matrix: Columns<'_>,
        slices: &mut [Option<&mut [f64]>],
        ws: &mut ThreadBuffers,
        stack: &mut MemStack,
    ) -> Result<(), usize> {
        for &s in list {
            let block = slices[s].take().expect("each supernode is factored once");
            let node = plan.nodes[s];
            let nrows = node.ncols + node.below;
            mark_rows(plan, s, &mut ws.local_row);
            gather(plan, s, matrix, block, &ws.local_row);
            for &d in &self.updates[self.update_ptr[s]..self.update_ptr[s + 1]] {
                let source = slices[d]
                    .as_deref()
                    .expect("descendants are factored first");
                let target = Target {
                    columns: 0..node.ncols,
                    nrows,
                    block_columns: self.block_columns,
                };
                update(
                    plan,
                    s,
                    d,
                    source,
                    block,
                    target,
                    &ws.local_row,
                    &mut ws.scratch,
                );
            }
            let result = factor_diagonal(block, node, stack, Par::Seq);
            slices[s] = Some(block);
            result?;
        }
        Ok(())
    }

    /// Factors one top supernode with two threads: each applies the updates to its own range
    /// of target columns (balanced by the entries on and below the diagonal), then the dense
    /// kernels run on both.
    #[allow(clippy::too_many_arguments)]
    fn factor_node_two(
        &self,
        plan: &SupernodalPlan,
        s: usize,
        matrix: Columns<'_>,
        block: &mut [f64],
        slices: &[Option<&mut [f64]>],
        threads: [&mut ThreadBuffers; 2],
        stack: &mut MemStack,
        par: Par,
    ) -> Result<(), usize> {
        let node = plan.nodes[s];
        let nrows = node.ncols + node.below;
        let [ws0, ws1] = threads;
        mark_rows(plan, s, &mut ws0.local_row);
        gather(plan, s, matrix, block, &ws0.local_row);
        let local_row = &ws0.local_row;
        // Column t holds nrows − t entries on and below the diagonal.
        let total = node.ncols * nrows - node.ncols * node.ncols.saturating_sub(1) / 2;
        let mut split = 0;
        let mut acc = 0;
        while split < node.ncols && 2 * acc < total {
            acc += nrows - split;
            split += 1;
        }
        let (left, right) = block.split_at_mut(split * nrows);
        let updates = &self.updates[self.update_ptr[s]..self.update_ptr[s + 1]];
        let apply = |part: &mut [f64], columns: Range<usize>, scratch: &mut UpdateBuffers| {
            for &d in updates {
                let source = slices[d]
                    .as_deref()
                    .expect("descendants are factored first");
                let target = Target {
                    columns: columns.clone(),
                    nrows,
                    block_columns: self.block_columns,
                };
                update(plan, s, d, source, part, target, local_row, scratch);
            }
        };
        rayon::join(
            || apply(left, 0..split, &mut ws0.scratch),
            || apply(right, split..node.ncols, &mut ws1.scratch),
        );
        factor_diagonal(block, node, stack, par)
    }
}

/// Records, for each row below supernode `s`'s diagonal block, its local row in the block.
fn mark_rows(plan: &SupernodalPlan, s: usize, local_row: &mut [usize]) {
    let node = plan.nodes[s];
    let rows = &plan.row_idx[node.row_start..][..node.below];
    for (i, &r) in rows.iter().enumerate() {
        local_row[r] = node.ncols + i;
    }
}

/// Zeroes supernode `s`'s block and adds the matrix's entries on and below the diagonal of
/// the permuted matrix.
fn gather(
    plan: &SupernodalPlan,
    s: usize,
    matrix: Columns<'_>,
    block: &mut [f64],
    local_row: &[usize],
) {
    let node = plan.nodes[s];
    let nrows = node.ncols + node.below;
    let end = node.first + node.ncols;
    block.fill(0.0);
    for jj in 0..node.ncols {
        let j = node.first + jj;
        let col = if plan.fwd.is_empty() { j } else { plan.fwd[j] };
        let range = matrix.col_ptr[col]..matrix.col_ptr[col + 1];
        let column = &mut block[jj * nrows..][..nrows];
        for (&i, &v) in matrix.row_idx[range.clone()]
            .iter()
            .zip(&matrix.values[range])
        {
            let pi = if plan.inv.is_empty() { i } else { plan.inv[i] };
            if pi < j {
                continue;
            }
            let local = if pi < end {
                pi - node.first
            } else {
                local_row[pi]
            };
            column[local] += v;
        }
    }
}

/// The columns of a supernode's block that an update writes: `columns` (local column
/// indices), stored from column `columns.start` on, `nrows` rows each.
struct Target {
    columns: Range<usize>,
    nrows: usize,
    block_columns: usize,
}

/// Subtracts descendant `d`'s update L_d,rows·L_d,colsᵀ from the target columns of supernode
/// `s`, whose block (those columns only) is `block`.
#[allow(clippy::too_many_arguments)]
fn update(
    plan: &SupernodalPlan,
    s: usize,
    d: usize,
    source: &[f64],
    block: &mut [f64],
    target: Target,
    local_row: &[usize],
    ws: &mut UpdateBuffers,
) {
    let Target {
        columns,
        nrows,
        block_columns,
    } = target;
    let node = plan.nodes[s];
    let dn = plan.nodes[d];
    let end = node.first + node.ncols;
    let d_rows = &plan.row_idx[dn.row_start..][..dn.below];
    let lo = node.first + columns.start;
    let hi = node.first + columns.end;
    let p0 = d_rows.partition_point(|&r| r < lo);
    let p1 = p0 + d_rows[p0..].partition_point(|&r| r < hi);
    if p0 == p1 {
        return;
    }
    let m = dn.below - p0;
    let cd = dn.ncols;
    let d_nrows = cd + dn.below;
    for (rel, &r) in ws.relative[..m].iter_mut().zip(&d_rows[p0..]) {
        *rel = if r < end {
            r - node.first
        } else {
            local_row[r]
        };
    }
    let mut jb = 0;
    while jb < p1 - p0 {
        let kk = block_columns.min(p1 - p0 - jb);
        let rows = m - jb;
        // The update's left factor: rows p0 + jb.. of d's below-diagonal block.
        let first = cd + p0 + jb;
        let lhs = MatRef::from_column_major_slice_with_stride(&source[first..], rows, cd, d_nrows);
        // Its right factor, transposed into a contiguous column-major buffer.
        let transposed = &mut ws.transposed[..cd * kk];
        for jj in 0..kk {
            for t in 0..cd {
                transposed[jj * cd + t] = source[t * d_nrows + first + jj];
            }
        }
        let rhs = MatRef::from_column_major_slice(transposed, cd, kk);
        let product = &mut ws.product[..rows * kk];
        let (diagonal, below) =
            MatMut::from_column_major_slice_mut(product, rows, kk).split_at_row_mut(kk);
        let (lhs_diagonal, lhs_below) = lhs.split_at_row(kk);
        // The block's top kk×kk part is needed on and below its diagonal only.
        triangular::matmul(
            diagonal,
            BlockStructure::TriangularLower,
            Accum::Replace,
            lhs_diagonal,
            BlockStructure::Rectangular,
            rhs,
            BlockStructure::Rectangular,
            1.0,
            Par::Seq,
        );
        matmul(below, Accum::Replace, lhs_below, rhs, 1.0, Par::Seq);
        let rel = &ws.relative[jb..m];
        for jj in 0..kk {
            let column = &mut block[(rel[jj] - columns.start) * nrows..][..nrows];
            let values = &product[jj * rows..][..rows];
            for (&r, &v) in rel[jj..].iter().zip(&values[jj..]) {
                column[r] -= v;
            }
        }
        jb += kk;
    }
}

/// Factors the diagonal block of a supernode whose updates are applied, and solves for the
/// rows below it: L_bot ← L_bot·L_top⁻ᵀ.
fn factor_diagonal(
    block: &mut [f64],
    node: Supernode,
    stack: &mut MemStack,
    par: Par,
) -> Result<(), usize> {
    let nrows = node.ncols + node.below;
    let matrix = MatMut::from_column_major_slice_mut(block, nrows, node.ncols);
    let (mut top, bottom) = matrix.split_at_row_mut(node.ncols);
    match cholesky_in_place(
        top.as_mut(),
        Default::default(),
        par,
        stack,
        Default::default(),
    ) {
        Ok(_) => {}
        Err(LltError::NonPositivePivot { index }) => return Err(node.first + index),
    }
    solve_lower_triangular_in_place(top.as_ref(), bottom.transpose_mut(), par);
    Ok(())
}
