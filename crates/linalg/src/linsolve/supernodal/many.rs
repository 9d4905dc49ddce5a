//! Triangular solves for many right-hand sides at once: A·X = B for the columns of B, each
//! supernode's values read once for [`BATCH`] of them.
//!
//! One solve is bound by reading the factor (about two flops per value loaded); with a batch the
//! value is broadcast against `BATCH` entries of the right-hand sides held side by side (a row
//! of the batch is one `[T; BATCH]`), and updates are blocked four columns of the supernode at a
//! time, so the arithmetic runs from registers. Each column's operations are the same whatever
//! else is in its batch (the lanes never mix): a column's bits do not depend on its neighbours,
//! only on the arithmetic `T`. They differ from [`SupernodalPlan::solve_in_place`]'s in the
//! order of the additions (round-off).

use super::{FactorValue, SupernodalPlan, Supernode};

/// Right-hand sides solved together: 16 lanes, two AVX2 registers of f32 (four of f64).
pub(crate) const BATCH: usize = 16;

/// A row of a batch: one entry of each of its right-hand sides.
type Row<T> = [T; BATCH];

impl SupernodalPlan {
    /// Solves A·X = B in place for the `rhs.len() / dim` columns of `rhs` (column-major), on
    /// `threads` (1 or 2: the batches split between them). The caller checks the lengths.
    pub(crate) fn solve_many_in_place<T: FactorValue>(
        &self,
        factor: &[T],
        rhs: &mut [f64],
        threads: usize,
    ) {
        let n = self.dim;
        if n == 0 {
            return;
        }
        let batches: Vec<&mut [f64]> = rhs.chunks_mut(n * BATCH).collect();
        if threads >= 2 && batches.len() >= 2 {
            let mut batches = batches;
            let second = batches.split_off(batches.len() / 2);
            rayon::join(
                || self.solve_batches(factor, batches),
                || self.solve_batches(factor, second),
            );
        } else {
            self.solve_batches(factor, batches);
        }
    }

    /// Solves each batch (up to [`BATCH`] columns) in turn on this thread.
    fn solve_batches<T: FactorValue>(&self, factor: &[T], batches: Vec<&mut [f64]>) {
        let n = self.dim;
        let zero = [T::default(); BATCH];
        let mut x = vec![zero; n];
        let longest = (self.nodes.iter())
            .map(|node| node.ncols + node.below)
            .max()
            .unwrap_or(0);
        let mut local = vec![zero; longest];
        for batch in batches {
            let columns = batch.len() / n;
            let scales: Vec<f64> = (batch.chunks(n))
                .map(|column| T::range_scale(column))
                .collect();
            for (p, row) in x.iter_mut().enumerate() {
                let i = self.fwd.get(p).copied().unwrap_or(p);
                *row = zero;
                for c in 0..columns {
                    row[c] = T::from_f64(batch[c * n + i] * scales[c]);
                }
            }
            self.run(factor, &mut x, &mut local);
            for (p, row) in x.iter().enumerate() {
                let i = self.fwd.get(p).copied().unwrap_or(p);
                for c in 0..columns {
                    batch[c * n + i] = row[c].to_f64() / scales[c];
                }
            }
        }
    }

    /// Forward then backward substitution over every supernode on the batch `x`.
    fn run<T: FactorValue>(&self, factor: &[T], x: &mut [Row<T>], local: &mut [Row<T>]) {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `new` detected AVX2 and FMA on this CPU.
            unsafe { self.run_avx2(factor, x, local) };
            return;
        }
        self.run_any(factor, x, local);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn run_avx2<T: FactorValue>(&self, factor: &[T], x: &mut [Row<T>], local: &mut [Row<T>]) {
        self.run_any(factor, x, local);
    }

    #[inline(always)]
    fn run_any<T: FactorValue>(&self, factor: &[T], x: &mut [Row<T>], local: &mut [Row<T>]) {
        for &s in &self.all {
            self.forward_many(s, factor, x, local);
        }
        for &s in self.all.iter().rev() {
            self.backward_many(s, factor, x, local);
        }
    }

    /// Supernode `s` and its values (column-major, `ncols + below` rows).
    #[inline(always)]
    fn supernode<'f, T>(&self, s: usize, factor: &'f [T]) -> (Supernode, &'f [T]) {
        let node = self.nodes[s];
        let len = node.ncols * (node.ncols + node.below);
        (node, &factor[node.val_start..][..len])
    }

    /// x_s ← L_ss⁻¹·x_s, then x[rows] −= L_below·x_s, on a local copy [x_s; 0] of the
    /// supernode's rows, so that a column's update is one contiguous range.
    #[inline(always)]
    fn forward_many<T: FactorValue>(
        &self,
        s: usize,
        factor: &[T],
        x: &mut [Row<T>],
        local: &mut [Row<T>],
    ) {
        let (node, block) = self.supernode(s, factor);
        let (w, ld) = (node.ncols, node.ncols + node.below);
        // Zero in every column here: x_s stays zero and adds nothing above (unit vectors reach
        // only their supernodes' ancestors: the contact DOFs' columns of `benches/
        // interactive_contact.rs`'s drop, 675 at 10,125 DOFs, 98 → 67 ms).
        if x[node.first..][..w]
            .iter()
            .flatten()
            .all(|v| v.to_f64() == 0.0)
        {
            return;
        }
        let y = &mut local[..ld];
        y[..w].copy_from_slice(&x[node.first..][..w]);
        y[w..].fill([T::default(); BATCH]);
        let column = |j: usize| &block[j * ld..][..ld];
        let full = w / 4 * 4;
        for j in (0..full).step_by(4) {
            for t in 0..4 {
                let c = column(j + t);
                divide(&mut y[j + t], c[j + t]);
                let pivot = y[j + t];
                for u in t + 1..4 {
                    subtract(&mut y[j + u], c[j + u], &pivot);
                }
            }
            let [c0, c1, c2, c3] = [0, 1, 2, 3].map(|t| &column(j + t)[j + 4..]);
            let (a0, a1, a2, a3) = (y[j], y[j + 1], y[j + 2], y[j + 3]);
            let below = &mut y[j + 4..];
            for i in 0..below.len() {
                let (l0, l1, l2, l3) = (c0[i], c1[i], c2[i], c3[i]);
                let row = &mut below[i];
                for r in 0..BATCH {
                    row[r] -= (l0 * a0[r] + l1 * a1[r]) + (l2 * a2[r] + l3 * a3[r]);
                }
            }
        }
        for j in full..w {
            let c = column(j);
            divide(&mut y[j], c[j]);
            let pivot = y[j];
            for (row, &l) in y.iter_mut().zip(c).skip(j + 1) {
                subtract(row, l, &pivot);
            }
        }
        x[node.first..][..w].copy_from_slice(&y[..w]);
        let rows = &self.row_idx[node.row_start..][..node.below];
        for (&i, update) in rows.iter().zip(&y[w..]) {
            for r in 0..BATCH {
                x[i][r] += update[r];
            }
        }
    }

    /// x_s ← L_ssᵀ⁻¹·(x_s − L_belowᵀ·x[rows]), on a local copy [x_s; x[rows]].
    #[inline(always)]
    fn backward_many<T: FactorValue>(
        &self,
        s: usize,
        factor: &[T],
        x: &mut [Row<T>],
        local: &mut [Row<T>],
    ) {
        let (node, block) = self.supernode(s, factor);
        let (w, ld) = (node.ncols, node.ncols + node.below);
        let y = &mut local[..ld];
        y[..w].copy_from_slice(&x[node.first..][..w]);
        let rows = &self.row_idx[node.row_start..][..node.below];
        for (row, &i) in y[w..].iter_mut().zip(rows) {
            *row = x[i];
        }
        let column = |j: usize| &block[j * ld..][..ld];
        let full = w / 4 * 4;
        for j in (full..w).rev() {
            let c = column(j);
            let mut v = y[j];
            for (row, &l) in y.iter().zip(c).skip(j + 1) {
                subtract(&mut v, l, row);
            }
            divide(&mut v, c[j]);
            y[j] = v;
        }
        for j in (0..full).step_by(4).rev() {
            let c = [column(j), column(j + 1), column(j + 2), column(j + 3)];
            let [c0, c1, c2, c3] = c.map(|c| &c[j + 4..]);
            let below = &y[j + 4..];
            let zero = [T::default(); BATCH];
            let (mut s0, mut s1, mut s2, mut s3) = (zero, zero, zero, zero);
            for i in 0..below.len() {
                let (l0, l1, l2, l3, row) = (c0[i], c1[i], c2[i], c3[i], &below[i]);
                for r in 0..BATCH {
                    s0[r] += l0 * row[r];
                    s1[r] += l1 * row[r];
                    s2[r] += l2 * row[r];
                    s3[r] += l3 * row[r];
                }
            }
            let sums = [s0, s1, s2, s3];
            for t in (0..4).rev() {
                let mut v = y[j + t];
                for r in 0..BATCH {
                    v[r] -= sums[t][r];
                }
                for u in t + 1..4 {
                    subtract(&mut v, c[t][j + u], &y[j + u]);
                }
                divide(&mut v, c[t][j + t]);
                y[j + t] = v;
            }
        }
        x[node.first..][..w].copy_from_slice(&y[..w]);
    }
}

/// row ← row / d, lane by lane.
#[inline(always)]
fn divide<T: FactorValue>(row: &mut Row<T>, d: T) {
    for v in row.iter_mut() {
        *v = *v / d;
    }
}

/// row −= l·pivot, lane by lane.
#[inline(always)]
fn subtract<T: FactorValue>(row: &mut Row<T>, l: T, pivot: &Row<T>) {
    for (v, p) in row.iter_mut().zip(pivot) {
        *v -= l * *p;
    }
}
