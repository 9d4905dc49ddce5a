//! Triangular solves L·y = P·b, Lᵀ·z = y, x = Pᵀ·z on faer's supernodal Cholesky factor.
//!
//! A solve streams the whole factor twice and does two flops per value, so it is bound by memory
//! bandwidth. faer's own supernodal solve goes through its general dense kernels (a triangular
//! solve and a matrix product into a temporary per supernode), whose dispatch costs dominate the
//! many small supernodes of an elasticity factor. These kernels read eight (then four, then one)
//! columns of a supernode per pass, so that each pass over the dense accumulator serves eight
//! factor values and the memory system follows eight streams at once (one thread's bandwidth
//! grows with the number of concurrent streams: measured 17 GB/s for one, 25 GB/s for four;
//! eight columns per pass measured 3–14 % faster than four). The two subtrees below the top
//! separators of the nested dissection can run on two threads.

use faer::sparse::linalg::cholesky::SymbolicCholesky;
use faer::sparse::linalg::cholesky::SymbolicCholeskyRaw;

mod factor;
mod many;

pub(crate) use factor::{Columns, FactorPlan, FactorWorkspace};

/// A stored value of the factor, and the arithmetic of its solve: `f64`, or `f32` for a copy
/// kept in single precision. The f32 copy's solve computes in f32 too, eight values to an AVX2
/// register and none converted (computing in f64, each value widened on its load, it had been
/// no faster than the f64 factor where the factor sits in cache, 9,720 DOFs): a
/// backward-stable solve in f32, its relative backward error of order n·2⁻²⁴ over columns of
/// length n (against 2⁻²⁴ for the rounding of the values alone), what a preconditioner and an
/// initial inverse Hessian need.
pub(crate) trait FactorValue:
    Copy
    + Default
    + Send
    + Sync
    + std::ops::Add<Output = Self>
    + std::ops::Sub<Output = Self>
    + std::ops::Mul<Output = Self>
    + std::ops::Div<Output = Self>
    + std::ops::AddAssign
    + std::ops::SubAssign
    + std::iter::Sum
{
    /// A power of two by which to multiply the right-hand side `rhs` before the solve (and to
    /// divide the solution after it): exact, and its largest entry then near 1, so that f32
    /// holds the vectors' range (a residual near convergence could be 1e-40, below f32's
    /// smallest normal number, 1.2e-38); 1 for f64, without reading `rhs`.
    fn range_scale(rhs: &[f64]) -> f64;
    /// `v` rounded to this type.
    fn from_f64(v: f64) -> Self;
    /// The value as `f64` (exact).
    fn to_f64(self) -> f64;
    /// The workspace's buffers of this type.
    fn buffers(ws: &mut SupernodalWorkspace) -> &mut Buffers<Self>;
}

impl FactorValue for f64 {
    fn range_scale(_: &[f64]) -> f64 {
        1.0
    }
    #[inline(always)]
    fn from_f64(v: f64) -> Self {
        v
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self
    }
    fn buffers(ws: &mut SupernodalWorkspace) -> &mut Buffers<Self> {
        &mut ws.double
    }
}

impl FactorValue for f32 {
    fn range_scale(rhs: &[f64]) -> f64 {
        let largest = rhs.iter().fold(0.0, |m: f64, b| m.max(b.abs()));
        match largest.is_normal() {
            // 2^−⌊log₂ largest⌋: the largest entry lands in [0.5, 2).
            true => 2f64.powi(-(largest.log2().floor() as i32)),
            false => 1.0,
        }
    }
    #[inline(always)]
    fn from_f64(v: f64) -> Self {
        v as f32
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        f64::from(self)
    }
    fn buffers(ws: &mut SupernodalWorkspace) -> &mut Buffers<Self> {
        &mut ws.single
    }
}

/// One supernode: its columns `first..first + ncols` and the layout of its values (column-major,
/// `ncols + below` rows: the dense diagonal block, then the rows listed in the factor's row
/// indices from `row_start`).
#[derive(Debug, Clone, Copy)]
struct Supernode {
    first: usize,
    ncols: usize,
    below: usize,
    val_start: usize,
    row_start: usize,
}

/// The supernodes and their split across two threads, derived once from the symbolic analysis.
#[derive(Debug)]
pub(crate) struct SupernodalPlan {
    nodes: Vec<Supernode>,
    /// Row indices of the below-diagonal blocks (copied from faer's symbolic factor, which is
    /// small next to the values, so that the plan does not borrow it).
    row_idx: Vec<usize>,
    /// `fwd[i]`: the original index of permuted index `i` (empty: no permutation).
    fwd: Vec<usize>,
    /// `inv[j]`: the permuted index of original index `j` (empty: no permutation).
    inv: Vec<usize>,
    dim: usize,
    /// Longest below-diagonal block: the size of each thread's accumulator.
    max_below: usize,
    /// Supernodes (ascending) of each thread's independent subtrees, then of the top of the tree
    /// that both sets of subtrees update and that runs on one thread.
    parts: [Vec<usize>; 2],
    top: Vec<usize>,
    /// Every supernode, for the one-thread solve.
    all: Vec<usize>,
    /// Whether the CPU has AVX2 and FMA: the kernels have a second copy compiled for them,
    /// measured 10–20 % faster than the baseline SSE2 build when the factor is in cache, a few
    /// per cent when it streams from memory.
    avx2: bool,
    /// Column ranges owned by the second thread's subtrees and by the top.
    part1_cols: Vec<(usize, usize)>,
    top_cols: Vec<(usize, usize)>,
}

/// Buffers of a solve, allocated once.
#[derive(Debug, Default)]
pub(crate) struct SupernodalWorkspace {
    double: Buffers<f64>,
    single: Buffers<f32>,
}

/// The vectors of a solve in one arithmetic: the permuted right-hand side, the second thread's
/// copy, and each thread's accumulator.
#[derive(Debug, Default)]
pub(crate) struct Buffers<T> {
    x: Vec<T>,
    x1: Vec<T>,
    acc: [Vec<T>; 2],
}

impl SupernodalPlan {
    /// The plan of a supernodal factor, or `None` for a simplicial one.
    pub(crate) fn new(symbolic: &SymbolicCholesky<usize>) -> Option<Self> {
        let SymbolicCholeskyRaw::Supernodal(sn) = symbolic.raw() else {
            return None;
        };
        let dim = sn.nrows();
        let count = sn.n_supernodes();
        let begin = sn.supernode_begin();
        let end = sn.supernode_end();
        let col_ptr_val = sn.col_ptr_for_val();
        let col_ptr_row = sn.col_ptr_for_row_idx();
        let mut nodes = Vec::with_capacity(count);
        let mut row_idx = Vec::new();
        for s in 0..count {
            let ncols = end[s] - begin[s];
            let len = col_ptr_val[s + 1] - col_ptr_val[s];
            let below = len.checked_div(ncols).map_or(0, |rows| rows - ncols);
            let row_start = row_idx.len();
            row_idx.extend_from_slice(&sn.row_idx()[col_ptr_row[s]..][..below]);
            nodes.push(Supernode {
                first: begin[s],
                ncols,
                below,
                val_start: col_ptr_val[s],
                row_start,
            });
        }
        let (fwd, inv) = symbolic.perm().map_or_else(
            || (Vec::new(), Vec::new()),
            |p| (p.arrays().0.to_vec(), p.arrays().1.to_vec()),
        );
        let max_below = nodes.iter().map(|n| n.below).max().unwrap_or(0);
        let mut plan = SupernodalPlan {
            nodes,
            row_idx,
            fwd,
            inv,
            dim,
            max_below,
            parts: [Vec::new(), Vec::new()],
            top: Vec::new(),
            all: (0..count).collect(),
            #[cfg(target_arch = "x86_64")]
            avx2: is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma"),
            #[cfg(not(target_arch = "x86_64"))]
            avx2: false,
            part1_cols: Vec::new(),
            top_cols: Vec::new(),
        };
        plan.split_for_two_threads();
        Some(plan)
    }

    /// Splits the supernodal elimination tree for the solves: work ≈ values read, plus a
    /// constant for the per-supernode overhead.
    fn split_for_two_threads(&mut self) {
        let count = self.nodes.len();
        let work: Vec<f64> = self
            .nodes
            .iter()
            .map(|n| (n.ncols * (n.ncols + n.below)) as f64 + 64.0)
            .collect();
        let owner = self.two_thread_owner(&work);
        let ranges = |which: u8| -> Vec<(usize, usize)> {
            let mut ranges: Vec<(usize, usize)> = Vec::new();
            for (s, node) in self.nodes.iter().enumerate() {
                if owner[s] != which {
                    continue;
                }
                match ranges.last_mut() {
                    Some(last) if last.1 == node.first => last.1 += node.ncols,
                    _ => ranges.push((node.first, node.first + node.ncols)),
                }
            }
            ranges
        };
        self.part1_cols = ranges(1);
        self.top_cols = ranges(2);
        self.parts = [
            (0..count).filter(|&s| owner[s] == 0).collect(),
            (0..count).filter(|&s| owner[s] == 1).collect(),
        ];
        self.top = (0..count).filter(|&s| owner[s] == 2).collect();
    }

    /// Splits the supernodal elimination tree into a top (ancestor-closed, run on one thread
    /// or on both together) and two sets of independent subtrees of balanced `work`,
    /// minimising the estimated time top + max(part 0, part 1) over successive splits of the
    /// heaviest subtree. Returns each supernode's owner: 0 or 1 for a thread's subtrees, 2 for
    /// the top.
    pub(crate) fn two_thread_owner(&self, work: &[f64]) -> Vec<u8> {
        let count = self.nodes.len();
        let mut col_node = vec![0usize; self.dim];
        for (s, node) in self.nodes.iter().enumerate() {
            col_node[node.first..node.first + node.ncols].fill(s);
        }
        let mut parent = vec![usize::MAX; count];
        let mut children = vec![Vec::new(); count];
        let mut subtree = work.to_vec();
        let mut roots = Vec::new();
        for s in 0..count {
            let rows = &self.row_idx[self.nodes[s].row_start..][..self.nodes[s].below];
            match rows.iter().min() {
                // A supernode's parent holds its first off-diagonal row, which comes after it.
                Some(&r) if col_node[r] > s => {
                    let p = col_node[r];
                    parent[s] = p;
                    children[p].push(s);
                    subtree[p] += subtree[s];
                }
                _ => roots.push(s),
            }
        }
        let balance = |pool: &[usize]| -> (f64, Vec<bool>) {
            let mut order: Vec<usize> = (0..pool.len()).collect();
            order.sort_by(|&a, &b| subtree[pool[b]].total_cmp(&subtree[pool[a]]));
            let mut bins = [0.0f64; 2];
            let mut second = vec![false; pool.len()];
            for k in order {
                let bin = usize::from(bins[1] < bins[0]);
                bins[bin] += subtree[pool[k]];
                second[k] = bin == 1;
            }
            (bins[0].max(bins[1]), second)
        };
        let mut top: Vec<usize> = Vec::new();
        let mut top_work = 0.0;
        let mut pool = roots;
        let (mut best_cost, mut best_second) = balance(&pool);
        let mut best = (top.clone(), pool.clone());
        for _ in 0..256 {
            let Some((k, _)) = pool
                .iter()
                .enumerate()
                .filter(|(_, s)| !children[**s].is_empty())
                .max_by(|a, b| subtree[*a.1].total_cmp(&subtree[*b.1]))
            else {
                break;
            };
            let s = pool.swap_remove(k);
            top.push(s);
            top_work += work[s];
            pool.extend_from_slice(&children[s]);
            let (cost, second) = balance(&pool);
            if top_work + cost < best_cost {
                best_cost = top_work + cost;
                best_second = second;
                best = (top.clone(), pool.clone());
            }
            if top_work > best_cost {
                break;
            }
        }
        let (top, pool) = best;
        // Owner of each supernode: 2 = top, else the thread of the pool subtree it belongs to;
        // parents come after their children, so a descending sweep sees the parent first.
        let mut owner = vec![0u8; count];
        for &s in &top {
            owner[s] = 2;
        }
        let mut in_pool = vec![None; count];
        for (k, &s) in pool.iter().enumerate() {
            in_pool[s] = Some(u8::from(best_second[k]));
        }
        for s in (0..count).rev() {
            if owner[s] == 2 {
                continue;
            }
            owner[s] = match in_pool[s] {
                Some(bin) => bin,
                None if parent[s] != usize::MAX => owner[parent[s]],
                None => 0,
            };
        }
        owner
    }

    /// Fractions of the factor's values in the top and in each thread's subtrees.
    pub(crate) fn split_summary(&self) -> [f64; 3] {
        let values = |list: &[usize]| -> f64 {
            list.iter()
                .map(|&s| {
                    (self.nodes[s].ncols * (self.nodes[s].ncols + self.nodes[s].below)) as f64
                })
                .sum()
        };
        let total = values(&self.top) + values(&self.parts[0]) + values(&self.parts[1]);
        let total = total.max(1.0);
        [
            values(&self.top) / total,
            values(&self.parts[0]) / total,
            values(&self.parts[1]) / total,
        ]
    }

    /// Solves A·x = b in place. `factor` holds the factor's values and `rhs.len()` the dimension
    /// (both checked by the caller).
    pub(crate) fn solve_in_place<T: FactorValue>(
        &self,
        factor: &[T],
        rhs: &mut [f64],
        threads: usize,
        ws: &mut SupernodalWorkspace,
    ) {
        let n = self.dim;
        let ws = T::buffers(ws);
        let zero = T::default();
        ws.x.resize(n, zero);
        for acc in &mut ws.acc {
            acc.resize(self.max_below, zero);
        }
        let scale = T::range_scale(rhs);
        if self.fwd.is_empty() {
            for (x, &b) in ws.x.iter_mut().zip(rhs.iter()) {
                *x = T::from_f64(b * scale);
            }
        } else {
            for (x, &i) in ws.x.iter_mut().zip(&self.fwd) {
                *x = T::from_f64(rhs[i] * scale);
            }
        }
        let two = threads >= 2 && !self.parts[0].is_empty() && !self.parts[1].is_empty();
        let [acc0, acc1] = &mut ws.acc;
        if two {
            ws.x1.resize(n, zero);
            let x = &mut ws.x;
            let x1 = &mut ws.x1;
            for &(a, b) in &self.part1_cols {
                x1[a..b].copy_from_slice(&x[a..b]);
            }
            for &(a, b) in &self.top_cols {
                x1[a..b].fill(zero);
            }
            rayon::join(
                || self.forward(&self.parts[0], factor, x, acc0),
                || self.forward(&self.parts[1], factor, x1, acc1),
            );
            for &(a, b) in &self.part1_cols {
                x[a..b].copy_from_slice(&x1[a..b]);
            }
            for &(a, b) in &self.top_cols {
                for (y, d) in x[a..b].iter_mut().zip(&x1[a..b]) {
                    *y += *d;
                }
            }
            self.forward(&self.top, factor, x, acc0);
            self.backward(&self.top, factor, x, acc0);
            for &(a, b) in self.top_cols.iter().chain(&self.part1_cols) {
                x1[a..b].copy_from_slice(&x[a..b]);
            }
            rayon::join(
                || self.backward(&self.parts[0], factor, x, acc0),
                || self.backward(&self.parts[1], factor, x1, acc1),
            );
            for &(a, b) in &self.part1_cols {
                x[a..b].copy_from_slice(&x1[a..b]);
            }
        } else {
            self.forward(&self.all, factor, &mut ws.x, acc0);
            self.backward(&self.all, factor, &mut ws.x, acc0);
        }
        if self.fwd.is_empty() {
            for (b, &x) in rhs.iter_mut().zip(&ws.x) {
                *b = x.to_f64() / scale;
            }
        } else {
            for (&x, &i) in ws.x.iter().zip(&self.fwd) {
                rhs[i] = x.to_f64() / scale;
            }
        }
    }

    fn forward<T: FactorValue>(&self, list: &[usize], factor: &[T], x: &mut [T], acc: &mut [T]) {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `new` detected AVX2 and FMA on this CPU.
            unsafe { self.forward_avx2(list, factor, x, acc) };
            return;
        }
        for &s in list {
            self.forward_node(s, factor, x, acc);
        }
    }

    fn backward<T: FactorValue>(&self, list: &[usize], factor: &[T], x: &mut [T], acc: &mut [T]) {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `new` detected AVX2 and FMA on this CPU.
            unsafe { self.backward_avx2(list, factor, x, acc) };
            return;
        }
        for &s in list.iter().rev() {
            self.backward_node(s, factor, x, acc);
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn forward_avx2<T: FactorValue>(
        &self,
        list: &[usize],
        factor: &[T],
        x: &mut [T],
        acc: &mut [T],
    ) {
        for &s in list {
            self.forward_node(s, factor, x, acc);
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn backward_avx2<T: FactorValue>(
        &self,
        list: &[usize],
        factor: &[T],
        x: &mut [T],
        acc: &mut [T],
    ) {
        for &s in list.iter().rev() {
            self.backward_node(s, factor, x, acc);
        }
    }

    /// x_s ← L_ss⁻¹·x_s, then x[rows] −= L_below·x_s through a dense accumulator (so that the
    /// inner loops are contiguous and vectorize, and the scatter runs once per supernode).
    #[inline(always)]
    fn forward_node<T: FactorValue>(&self, s: usize, factor: &[T], x: &mut [T], acc: &mut [T]) {
        let node = self.nodes[s];
        let w = node.ncols;
        let ld = w + node.below;
        let block = &factor[node.val_start..][..w * ld];
        let xs = &mut x[node.first..][..w];
        // Zero here: x_s stays zero and adds nothing above. A right-hand side non-zero at a few
        // DOFs (a contact node's unit vector) reaches only their supernodes' ancestors.
        if xs.iter().all(|v| v.to_f64() == 0.0) {
            return;
        }
        let acc = &mut acc[..node.below];
        acc.fill(T::default());
        let wide = w / 8 * 8;
        for j in (0..wide).step_by(8) {
            let c: [&[T]; 8] = std::array::from_fn(|k| &block[(j + k) * ld..][..ld]);
            let mut a = [T::default(); 8];
            for k in 0..8 {
                let mut v = xs[j + k];
                for p in 0..k {
                    v -= c[p][j + k] * a[p];
                }
                a[k] = v / c[k][j + k];
                xs[j + k] = a[k];
            }
            axpy8(&mut xs[j + 8..], c.map(|c| &c[j + 8..w]), a);
            axpy8(acc, c.map(|c| &c[w..]), a);
        }
        let full = wide + (w - wide) / 4 * 4;
        for j in (wide..full).step_by(4) {
            let c0 = &block[j * ld..][..ld];
            let c1 = &block[(j + 1) * ld..][..ld];
            let c2 = &block[(j + 2) * ld..][..ld];
            let c3 = &block[(j + 3) * ld..][..ld];
            let x0 = xs[j] / c0[j];
            let x1 = (xs[j + 1] - c0[j + 1] * x0) / c1[j + 1];
            let x2 = (xs[j + 2] - c0[j + 2] * x0 - c1[j + 2] * x1) / c2[j + 2];
            let x3 = (xs[j + 3] - c0[j + 3] * x0 - c1[j + 3] * x1 - c2[j + 3] * x2) / c3[j + 3];
            xs[j] = x0;
            xs[j + 1] = x1;
            xs[j + 2] = x2;
            xs[j + 3] = x3;
            let r = j + 4..w;
            axpy4(
                &mut xs[r.clone()],
                [&c0[r.clone()], &c1[r.clone()], &c2[r.clone()], &c3[r]],
                [x0, x1, x2, x3],
            );
            axpy4(
                acc,
                [&c0[w..], &c1[w..], &c2[w..], &c3[w..]],
                [x0, x1, x2, x3],
            );
        }
        for j in full..w {
            let c = &block[j * ld..][..ld];
            let xj = xs[j] / c[j];
            xs[j] = xj;
            for (y, l) in xs[j + 1..].iter_mut().zip(&c[j + 1..w]) {
                *y -= *l * xj;
            }
            for (y, l) in acc.iter_mut().zip(&c[w..]) {
                *y -= *l * xj;
            }
        }
        let rows = &self.row_idx[node.row_start..][..node.below];
        for (&i, a) in rows.iter().zip(acc.iter()) {
            x[i] += *a;
        }
    }

    /// x_s ← L_ssᵀ⁻¹·(x_s − L_belowᵀ·x[rows]), the rows gathered into a dense vector first.
    #[inline(always)]
    fn backward_node<T: FactorValue>(&self, s: usize, factor: &[T], x: &mut [T], acc: &mut [T]) {
        let node = self.nodes[s];
        let w = node.ncols;
        let ld = w + node.below;
        let block = &factor[node.val_start..][..w * ld];
        let g = &mut acc[..node.below];
        let rows = &self.row_idx[node.row_start..][..node.below];
        for (g, &i) in g.iter_mut().zip(rows) {
            *g = x[i];
        }
        let g = &*g;
        let xs = &mut x[node.first..][..w];
        let wide = w / 8 * 8;
        let full = wide + (w - wide) / 4 * 4;
        for j in (full..w).rev() {
            let c = &block[j * ld..][..ld];
            let d = dot(&c[j + 1..w], &xs[j + 1..]) + dot(&c[w..], g);
            xs[j] = (xs[j] - d) / c[j];
        }
        for j in (wide..full).step_by(4).rev() {
            let c0 = &block[j * ld..][..ld];
            let c1 = &block[(j + 1) * ld..][..ld];
            let c2 = &block[(j + 2) * ld..][..ld];
            let c3 = &block[(j + 3) * ld..][..ld];
            let r = j + 4..w;
            let top = dot4(
                [&c0[r.clone()], &c1[r.clone()], &c2[r.clone()], &c3[r]],
                &xs[j + 4..],
            );
            let bot = dot4([&c0[w..], &c1[w..], &c2[w..], &c3[w..]], g);
            let x3 = (xs[j + 3] - top[3] - bot[3]) / c3[j + 3];
            let x2 = (xs[j + 2] - top[2] - bot[2] - c2[j + 3] * x3) / c2[j + 2];
            let x1 = (xs[j + 1] - top[1] - bot[1] - c1[j + 2] * x2 - c1[j + 3] * x3) / c1[j + 1];
            let x0 = (xs[j] - top[0] - bot[0] - c0[j + 1] * x1 - c0[j + 2] * x2 - c0[j + 3] * x3)
                / c0[j];
            xs[j] = x0;
            xs[j + 1] = x1;
            xs[j + 2] = x2;
            xs[j + 3] = x3;
        }
        for j in (0..wide).step_by(8).rev() {
            let c: [&[T]; 8] = std::array::from_fn(|k| &block[(j + k) * ld..][..ld]);
            let top = dot8(c.map(|c| &c[j + 8..w]), &xs[j + 8..]);
            let bot = dot8(c.map(|c| &c[w..]), g);
            for k in (0..8).rev() {
                let mut v = xs[j + k] - top[k] - bot[k];
                for p in k + 1..8 {
                    v -= c[k][j + p] * xs[j + p];
                }
                xs[j + k] = v / c[k][j + k];
            }
        }
    }
}

/// y −= Σₖ cₖ·aₖ over eight columns.
#[inline(always)]
fn axpy8<T: FactorValue>(y: &mut [T], c: [&[T]; 8], a: [T; 8]) {
    let n = y.len();
    let [c0, c1, c2, c3, c4, c5, c6, c7] = c.map(|c| &c[..n]);
    for i in 0..n {
        y[i] -= (c0[i] * a[0] + c1[i] * a[1] + c2[i] * a[2] + c3[i] * a[3])
            + (c4[i] * a[4] + c5[i] * a[5] + c6[i] * a[6] + c7[i] * a[7]);
    }
}

/// Eight dot products of columns with one vector in one pass over the vector.
#[inline(always)]
fn dot8<T: FactorValue>(c: [&[T]; 8], v: &[T]) -> [T; 8] {
    const L: usize = 4;
    let n = v.len();
    let c = c.map(|c| &c[..n]);
    let m = n / L * L;
    let mut s = [[T::default(); L]; 8];
    for (i, v) in v[..m].chunks_exact(L).enumerate() {
        let base = i * L;
        for (s, c) in s.iter_mut().zip(&c) {
            let c = &c[base..base + L];
            for k in 0..L {
                s[k] += c[k] * v[k];
            }
        }
    }
    let mut out = [T::default(); 8];
    for ((o, s), c) in out.iter_mut().zip(&s).zip(&c) {
        *o = s.iter().copied().sum::<T>()
            + c[m..].iter().zip(&v[m..]).map(|(&a, &b)| a * b).sum::<T>();
    }
    out
}

/// y −= Σₖ cₖ·aₖ over four columns (all slices of y's length).
#[inline(always)]
fn axpy4<T: FactorValue>(y: &mut [T], c: [&[T]; 4], a: [T; 4]) {
    let n = y.len();
    let (c0, c1, c2, c3) = (&c[0][..n], &c[1][..n], &c[2][..n], &c[3][..n]);
    for ((((y, l0), l1), l2), l3) in y.iter_mut().zip(c0).zip(c1).zip(c2).zip(c3) {
        *y -= *l0 * a[0] + *l1 * a[1] + *l2 * a[2] + *l3 * a[3];
    }
}

const LANES: usize = 8;

/// Dot product with `LANES` independent partial sums, so that it vectorizes (a single running
/// sum would serialise on the addition's latency and cannot be reordered by the compiler).
#[inline(always)]
fn dot<T: FactorValue>(a: &[T], b: &[T]) -> T {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut sum = [T::default(); LANES];
    let mut ac = a.chunks_exact(LANES);
    let mut bc = b.chunks_exact(LANES);
    for (a, b) in (&mut ac).zip(&mut bc) {
        for k in 0..LANES {
            sum[k] += a[k] * b[k];
        }
    }
    let tail: T = ac
        .remainder()
        .iter()
        .zip(bc.remainder())
        .map(|(&a, &b)| a * b)
        .sum();
    sum.iter().copied().sum::<T>() + tail
}

/// Four dot products of columns with one vector in one pass over the vector.
#[inline(always)]
fn dot4<T: FactorValue>(c: [&[T]; 4], v: &[T]) -> [T; 4] {
    let n = v.len();
    let (c0, c1, c2, c3) = (&c[0][..n], &c[1][..n], &c[2][..n], &c[3][..n]);
    let mut s = [[T::default(); LANES]; 4];
    let chunks = n / LANES * LANES;
    for ((((v, l0), l1), l2), l3) in v[..chunks]
        .chunks_exact(LANES)
        .zip(c0[..chunks].chunks_exact(LANES))
        .zip(c1[..chunks].chunks_exact(LANES))
        .zip(c2[..chunks].chunks_exact(LANES))
        .zip(c3[..chunks].chunks_exact(LANES))
    {
        for k in 0..LANES {
            s[0][k] += l0[k] * v[k];
            s[1][k] += l1[k] * v[k];
            s[2][k] += l2[k] * v[k];
            s[3][k] += l3[k] * v[k];
        }
    }
    let mut out = [T::default(); 4];
    for (o, s) in out.iter_mut().zip(&s) {
        *o = s.iter().copied().sum();
    }
    for i in chunks..n {
        out[0] += c0[i] * v[i];
        out[1] += c1[i] * v[i];
        out[2] += c2[i] * v[i];
        out[3] += c3[i] * v[i];
    }
    out
}

#[cfg(test)]
mod tests {
    use faer::dyn_stack::{MemBuffer, MemStack};
    use faer::mat::MatMut;
    use faer::sparse::linalg::SupernodalThreshold;
    use faer::sparse::linalg::cholesky::{
        CholeskySymbolicParams, LltRef, SymmetricOrdering, factorize_symbolic_cholesky,
    };
    use faer::sparse::{SparseColMat, Triplet};
    use faer::{Conj, Par, Side};

    use super::{Columns, FactorPlan, FactorWorkspace, SupernodalPlan, SupernodalWorkspace};

    /// tetfem's numeric factorization of `a` (both triangles) on `threads`, compared with
    /// faer's factor `reference` on and below each supernode's diagonal.
    fn check_factorization(
        plan: &SupernodalPlan,
        full: &SparseColMat<usize, f64>,
        reference: &[f64],
    ) {
        let columns = Columns {
            col_ptr: full.symbolic().col_ptr(),
            row_idx: full.symbolic().row_idx(),
            values: full.val(),
        };
        let scale = reference.iter().fold(1e-300f64, |m, v| m.max(v.abs()));
        for (threads, block_columns) in [(1, usize::MAX), (2, usize::MAX), (1, 2), (2, 3)] {
            let factor_plan = FactorPlan::new(plan).with_block_columns(block_columns);
            let mut ws = FactorWorkspace::default();
            let mut values = vec![f64::NAN; reference.len()];
            factor_plan
                .factorize(plan, columns, &mut values, threads, &mut ws)
                .unwrap();
            for node in &plan.nodes {
                let rows = node.ncols + node.below;
                for j in 0..node.ncols {
                    for i in j..rows {
                        let k = node.val_start + j * rows + i;
                        // Same operations in another order: round-off of a few ulps of the
                        // largest entry.
                        assert!(
                            (values[k] - reference[k]).abs() <= 1e-13 * scale,
                            "threads {threads}, blocks of {block_columns}: entry {k}: {} vs {}",
                            values[k],
                            reference[k]
                        );
                    }
                }
            }
        }
    }

    /// Factors an SPD matrix (lower triangle given) with a forced supernodal structure, so
    /// that the kernels run on small matrices too, and compares them with faer's solve.
    fn check(n: usize, entries: &[(usize, usize, f64)]) -> Option<[f64; 3]> {
        let triplets: Vec<_> = entries
            .iter()
            .map(|&(i, j, v)| Triplet::new(i, j, v))
            .collect();
        let a = SparseColMat::<usize, f64>::try_new_from_triplets(n, n, &triplets).unwrap();
        let mirrored: Vec<_> = entries
            .iter()
            .filter(|&&(i, j, _)| i != j)
            .map(|&(i, j, v)| Triplet::new(j, i, v))
            .chain(triplets.iter().copied())
            .collect();
        let full = SparseColMat::<usize, f64>::try_new_from_triplets(n, n, &mirrored).unwrap();
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
            ..Default::default()
        };
        let symbolic =
            factorize_symbolic_cholesky(a.symbolic(), Side::Lower, SymmetricOrdering::Amd, params)
                .unwrap();
        let mut values = vec![0.0; symbolic.len_val()];
        let mut buffer = MemBuffer::new(
            symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()),
        );
        symbolic
            .factorize_numeric_llt(
                &mut values,
                a.as_ref(),
                Side::Lower,
                Default::default(),
                Par::Seq,
                MemStack::new(&mut buffer),
                Default::default(),
            )
            .unwrap();
        let Some(plan) = SupernodalPlan::new(&symbolic) else {
            // faer keeps 0×0 and 1×1 matrices simplicial even when supernodal is forced.
            assert!(n <= 1, "n = {n}: forced supernodal");
            return None;
        };
        check_factorization(&plan, &full, &values);
        let b: Vec<f64> = (0..n).map(|i| ((i * 37) % 11) as f64 - 5.0).collect();
        let mut reference = b.clone();
        let mut buffer = MemBuffer::new(symbolic.solve_in_place_scratch::<f64>(1, Par::Seq));
        LltRef::new(&symbolic, &values).solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(&mut reference, n, 1),
            Par::Seq,
            MemStack::new(&mut buffer),
        );
        let mut ws = SupernodalWorkspace::default();
        for threads in [1, 2, 1] {
            let mut x = b.clone();
            plan.solve_in_place(&values, &mut x, threads, &mut ws);
            let scale = reference.iter().fold(1e-300f64, |m, v| m.max(v.abs()));
            for (x, r) in x.iter().zip(&reference) {
                assert!((x - r).abs() <= 1e-12 * scale, "n = {n}, threads {threads}");
            }
        }
        Some(plan.split_summary())
    }

    #[test]
    fn dense_matrices_of_every_width() {
        for n in 0..=13 {
            let mut entries = Vec::new();
            for j in 0..n {
                for i in j..n {
                    let v = if i == j {
                        n as f64 + 1.0
                    } else {
                        1.0 / (1.0 + (i - j) as f64)
                    };
                    entries.push((i, j, v));
                }
            }
            check(n, &entries);
        }
    }

    #[test]
    fn block_diagonal_and_arrow_matrices() {
        // Independent blocks joined by a last dense row and column: a tree with several
        // subtrees below one top supernode, so that the two-thread split has work on both sides.
        let (blocks, size) = (5, 9);
        let n = blocks * size + 3;
        let mut entries = Vec::new();
        for k in 0..blocks {
            for j in 0..size {
                for i in j..size {
                    let v = if i == j {
                        20.0
                    } else {
                        0.5 / (1.0 + (i + j + k) as f64)
                    };
                    entries.push((k * size + i, k * size + j, v));
                }
            }
        }
        for r in blocks * size..n {
            for j in 0..r {
                entries.push((r, j, 0.1 + (j % 3) as f64 * 0.05));
            }
            entries.push((r, r, 60.0));
        }
        let split = check(n, &entries).unwrap();
        assert!(
            split[1] > 0.0 && split[2] > 0.0,
            "both threads have work: {split:?}"
        );
    }
}
