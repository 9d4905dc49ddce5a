//! K in node blocks, upper half only: each product reads half the bytes of [`BlockMatrix3`].
//!
//! K is symmetric, so the blocks K_ij with j > i determine those below the diagonal
//! (K_ji = K_ijᵀ). A product then visits each stored off-diagonal block once and uses it twice,
//! y_i += K_ij·x_j and y_j += K_ijᵀ·x_i: about half the bytes of the full format for the same
//! arithmetic, which matters because a product is bound by memory traffic (see the module
//! docs of [`block_sparse`](super)).
//!
//! The price is the scattered update of y_j, which rows of other parallel tasks also update.
//! Tasks own fixed chunks of block rows, each chunk at least as long as the reach of the previous
//! chunk's columns, so a chunk's updates stay within it and the next one; even chunks run
//! concurrently, then odd ones, and no two running chunks write one entry. The chunks depend only
//! on the matrix, so every entry of y is one fixed sequence of operations whatever the thread
//! count. The chunks are as short as the node numbering's bandwidth allows (at least 2048 block
//! rows): on a mesh numbered with a narrow band, such as the generated boxes, there are many; a
//! numbering whose first nodes couple to its last leaves few chunks and so little parallelism,
//! never a wrong result.

use crate::parallel::one_thread;
use rayon::prelude::*;

#[cfg(target_arch = "x86_64")]
use super::sum3;
use super::{BlockMatrix3, CHUNK_ROWS, simd_available};
use crate::error::{Error, Result};
use crate::sparse::CscMatrix;

/// A symmetric matrix on free DOFs stored as the dense 3×3 blocks on and above the block
/// diagonal, one block row per node with a free DOF (padded as in [`BlockMatrix3`]).
///
/// Products go through vectors with four slots per node (the fourth unused) so that a block row
/// and a node's entries each load as one 4-lane vector.
#[derive(Debug, Clone)]
pub struct SymmetricBlockMatrix3 {
    /// Start of each block row in `columns` (length blocks + 1); each row's first block is its
    /// diagonal block.
    row_ptr: Vec<usize>,
    /// Block column (≥ the row) of each stored block, ascending within a row.
    columns: Vec<u32>,
    /// Nine values per stored block, row-major, then one 0.0 for the last block's 4-lane load.
    values: Vec<f64>,
    /// Chunk bounds in block rows (0 first, block rows last): chunk c's columns are below the
    /// start of chunk c + 2.
    chunks: Vec<usize>,
    /// Slot 4·block + axis of each free DOF.
    slots: Vec<u32>,
    /// Free DOF count.
    dim: usize,
    /// Whether products run the AVX2/FMA kernel.
    simd: bool,
}

/// Values ahead of the current block that the AVX2 kernel asks the cache for: 4 KiB. The
/// product reads a single stream, which the hardware prefetchers alone follow at about 9–10 GB/s
/// on one core of this EPYC; with the hint at 256–2048 values ahead a product took 0.80–0.87×
/// the time without it (132k and 435k DOFs, one and two threads, best of 40 interleaved).
const PREFETCH_AHEAD: usize = 512;

/// Vectors with four slots per node for [`SymmetricBlockMatrix3`]'s products.
#[derive(Debug, Clone, Default)]
pub struct SymmetricWorkspace {
    x: [Vec<f64>; 2],
    y: [Vec<f64>; 2],
}

impl SymmetricBlockMatrix3 {
    /// Number of parallel chunks of a product (feature `kernel-internals`, for tetfem's tests;
    /// not a stable API).
    #[cfg(feature = "kernel-internals")]
    #[doc(hidden)]
    pub fn chunk_count(&self) -> usize {
        self.chunks.len() - 1
    }

    /// Copies `matrix` (on the free DOFs, symmetric, full pattern) into upper node blocks;
    /// `free_dofs` as for [`BlockMatrix3::from_free_matrix`], with its errors.
    pub fn from_free_matrix(matrix: &CscMatrix, free_dofs: &[usize]) -> Result<Self> {
        Ok(Self::from_blocks(&BlockMatrix3::from_free_matrix(
            matrix, free_dofs,
        )?))
    }

    /// The blocks of `full` on and above its block diagonal.
    pub fn from_blocks(full: &BlockMatrix3) -> Self {
        let blocks = full.block_rows();
        let mut row_ptr = Vec::with_capacity(blocks + 1);
        row_ptr.push(0);
        let mut columns = Vec::with_capacity(full.stored_blocks() / 2 + blocks);
        let mut values = Vec::with_capacity(9 * columns.capacity() + 1);
        for i in 0..blocks {
            let range = full.row_ptr[i]..full.row_ptr[i + 1];
            let first =
                range.start + full.columns[range.clone()].partition_point(|&j| (j as usize) < i);
            // The diagonal block leads each row even where K's is all zero (a padded node's
            // constrained axes), so the kernel can take it as the first without a test.
            if full.columns.get(first).is_none_or(|&j| j as usize != i) {
                columns.push(i as u32);
                values.extend_from_slice(&[0.0; 9]);
            }
            columns.extend_from_slice(&full.columns[first..range.end]);
            values.extend_from_slice(&full.values[9 * first..9 * range.end]);
            row_ptr.push(columns.len());
        }
        values.push(0.0);
        let reach = |rows: std::ops::Range<usize>| {
            rows.map(|i| columns[row_ptr[i + 1] - 1] as usize + 1)
                .max()
                .unwrap_or(0)
        };
        // Chunk c + 1 ends no earlier than chunk c's reach, so chunk c writes only itself and
        // chunk c + 1.
        let mut chunks = vec![0];
        while chunks[chunks.len() - 1] < blocks {
            let start = chunks[chunks.len() - 1];
            let previous = chunks
                .len()
                .checked_sub(2)
                .map_or(0, |c| reach(chunks[c]..start));
            chunks.push(blocks.min((start + CHUNK_ROWS).max(previous)));
        }
        let slots = (0..full.dim)
            .map(|i| {
                let padded = full.padded_index.as_ref().map_or(i, |p| p[i] as usize);
                (4 * (padded / 3) + padded % 3) as u32
            })
            .collect();
        SymmetricBlockMatrix3 {
            row_ptr,
            columns,
            values,
            chunks,
            slots,
            dim: full.dim,
            simd: full.simd,
        }
    }

    /// Free DOF count (the dimension of the vectors it multiplies).
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// Number of node blocks per side.
    pub fn block_rows(&self) -> usize {
        self.row_ptr.len() - 1
    }

    /// Whether some node has only one or two free DOFs (a padded block row).
    pub fn is_padded(&self) -> bool {
        self.dim != 3 * self.block_rows()
    }

    /// Stored 3×3 blocks (the diagonal ones and those above).
    pub fn stored_blocks(&self) -> usize {
        self.columns.len()
    }

    /// Bytes a product reads of the matrix: 72 per block of values, 4 per block index, 8 per
    /// block row pointer.
    pub fn matrix_bytes(&self) -> usize {
        self.columns.len() * (72 + 4) + self.row_ptr.len() * 8
    }

    /// Whether products run the AVX2/FMA kernel: by default wherever the CPU has both.
    pub fn simd(&self) -> bool {
        self.simd
    }

    /// Chooses the scalar kernel (`false`) or the AVX2/FMA kernel (`true`, honoured only where
    /// the CPU has both); returns whether the AVX2/FMA kernel now runs (`false` after
    /// `set_simd(true)` on a CPU without it). As [`BlockMatrix3::set_simd`].
    pub fn set_simd(&mut self, enabled: bool) -> bool {
        self.simd = enabled && simd_available();
        self.simd
    }

    /// Scratch for the products: four vectors of four slots per node.
    pub fn workspace(&self) -> SymmetricWorkspace {
        let n = 4 * self.block_rows();
        SymmetricWorkspace {
            x: [vec![0.0; n], vec![0.0; n]],
            y: [vec![0.0; n], vec![0.0; n]],
        }
    }

    /// y = A·x ([`Error::DimensionMismatch`] unless both have length [`dim`](Self::dim)).
    pub fn mul_vec(&self, x: &[f64], y: &mut [f64]) -> Result<()> {
        Error::check_len("x", self.dim, x.len())?;
        Error::check_len("y", self.dim, y.len())?;
        self.product_into(x, y, &mut self.workspace());
        Ok(())
    }

    /// y = A·x reusing `work` (from [`workspace`](Self::workspace)), so that repeated products
    /// allocate nothing; returns xᵀ·y. [`Error::DimensionMismatch`] unless `x` and `y` have
    /// length [`dim`](Self::dim) and `work` is this matrix's size.
    pub fn mul_vec_with(
        &self,
        x: &[f64],
        y: &mut [f64],
        work: &mut SymmetricWorkspace,
    ) -> Result<f64> {
        Error::check_len("x", self.dim, x.len())?;
        Error::check_len("y", self.dim, y.len())?;
        let slots = 4 * self.block_rows();
        for (name, v) in [("workspace x", &work.x[0]), ("workspace y", &work.y[0])] {
            Error::check_len(name, slots, v.len())?;
        }
        Ok(self.product_into(x, y, work))
    }

    /// y = A·x for vectors of length `dim()` by construction; `work` from
    /// [`workspace`](Self::workspace). Returns xᵀ·y, summed in a fixed order.
    #[doc(hidden)]
    pub fn product_into(&self, x: &[f64], y: &mut [f64], work: &mut SymmetricWorkspace) -> f64 {
        let [x4, _] = &mut work.x;
        let [y4, _] = &mut work.y;
        self.gather(x, x4);
        self.blocks_times::<false>([x4, &[]], [y4, &mut []]);
        self.scatter(y4, y, x)
    }

    /// ya = A·xa and yb = A·xb in one pass over the matrix. Returns (xaᵀ·ya, xbᵀ·yb), summed
    /// in a fixed order.
    #[doc(hidden)]
    pub fn product2_into(
        &self,
        (xa, xb): (&[f64], &[f64]),
        (ya, yb): (&mut [f64], &mut [f64]),
        work: &mut SymmetricWorkspace,
    ) -> (f64, f64) {
        let [x4a, x4b] = &mut work.x;
        let [y4a, y4b] = &mut work.y;
        self.gather(xa, x4a);
        self.gather(xb, x4b);
        self.blocks_times::<true>([x4a, x4b], [y4a, y4b]);
        (self.scatter(y4a, ya, xa), self.scatter(y4b, yb, xb))
    }

    /// Free-numbered `x` into four slots per node (unused slots stay 0 from the workspace).
    fn gather(&self, x: &[f64], x4: &mut [f64]) {
        for (&slot, &value) in self.slots.iter().zip(x) {
            x4[slot as usize] = value;
        }
    }

    /// y from the slots of `y4`, returning xᵀ·y summed over fixed chunks in order.
    fn scatter(&self, y4: &[f64], y: &mut [f64], x: &[f64]) -> f64 {
        const CHUNK: usize = 3 * CHUNK_ROWS;
        let chunk = |((y, slots), x): ((&mut [f64], &[u32]), &[f64])| {
            let mut dot = 0.0;
            for ((y, &slot), &x) in y.iter_mut().zip(slots).zip(x) {
                *y = y4[slot as usize];
                dot += x * *y;
            }
            dot
        };
        let partial: Vec<f64> = match one_thread() {
            true => (y.chunks_mut(CHUNK))
                .zip(self.slots.chunks(CHUNK))
                .zip(x.chunks(CHUNK))
                .map(chunk)
                .collect(),
            false => (y.par_chunks_mut(CHUNK))
                .zip(self.slots.par_chunks(CHUNK))
                .zip(x.par_chunks(CHUNK))
                .map(chunk)
                .collect(),
        };
        partial.iter().sum()
    }

    /// y₀ = A·x₀ (and y₁ = A·x₁ when `TWO`) in four-slot vectors: even chunks concurrently,
    /// then odd ones, each writing its own rows and the next chunk's.
    fn blocks_times<const TWO: bool>(&self, x: [&[f64]; 2], y: [&mut [f64]; 2]) {
        let [y0, y1] = y;
        let serial = one_thread();
        let zero = |y: &mut [f64]| match serial {
            true => y.fill(0.0),
            false => y.par_chunks_mut(4 * CHUNK_ROWS).for_each(|y| y.fill(0.0)),
        };
        zero(y0);
        if TWO {
            zero(y1);
        }
        let count = self.chunks.len() - 1;
        for parity in 0..2 {
            let owned: Vec<usize> = (parity..count).step_by(2).collect();
            let windows0 = self.windows(y0, &owned);
            let windows1 = if TWO {
                self.windows(y1, &owned)
            } else {
                owned.iter().map(|_| &mut [][..]).collect()
            };
            // The same phases in this thread with one thread in the pool: the same sums in the
            // same order.
            let times = |((c, w0), w1): ((usize, &mut [f64]), &mut [f64])| {
                self.chunk_times::<TWO>(c, x, [w0, w1])
            };
            match serial {
                true => (owned.into_iter().zip(windows0).zip(windows1)).for_each(times),
                false => (owned.into_par_iter().zip(windows0).zip(windows1)).for_each(times),
            }
        }
    }

    /// Disjoint windows of `y` for chunks `owned` (every other chunk): chunk c's window runs
    /// from its first row to the end of chunk c + 1.
    fn windows<'a>(&self, y: &'a mut [f64], owned: &[usize]) -> Vec<&'a mut [f64]> {
        let count = self.chunks.len() - 1;
        let Some(&first) = owned.first() else {
            return Vec::new();
        };
        let mut rest = &mut y[4 * self.chunks[first]..];
        owned
            .iter()
            .map(|&c| {
                let rows = self.chunks[(c + 2).min(count)] - self.chunks[c];
                let (window, tail) = std::mem::take(&mut rest).split_at_mut(4 * rows);
                rest = tail;
                window
            })
            .collect()
    }

    /// The block rows of chunk `c`, writing `y` windows that start at the chunk's first row.
    fn chunk_times<const TWO: bool>(&self, c: usize, x: [&[f64]; 2], y: [&mut [f64]; 2]) {
        #[cfg(target_arch = "x86_64")]
        if self.simd {
            // SAFETY: `simd` is set only where AVX2 and FMA were detected on this CPU.
            unsafe { self.chunk_times_avx2::<TWO>(c, x, y) };
            return;
        }
        let base = self.chunks[c];
        let [y0, y1] = y;
        for i in base..self.chunks[c + 1] {
            self.row_scalar(i, x[0], y0, base);
            if TWO {
                self.row_scalar(i, x[1], y1, base);
            }
        }
    }

    /// Block row i: y_i += Σ_j K_ij·x_j over its stored blocks, and y_j += K_ijᵀ·x_i for those
    /// right of the diagonal; `y` is a window starting at block row `base`.
    fn row_scalar(&self, i: usize, x: &[f64], y: &mut [f64], base: usize) {
        let range = self.row_ptr[i]..self.row_ptr[i + 1];
        let xi = &x[4 * i..4 * i + 3];
        let mut sum = [0.0; 3];
        for (&j, a) in self.columns[range.clone()]
            .iter()
            .zip(self.values[9 * range.start..9 * range.end].chunks_exact(9))
        {
            let j = j as usize;
            let xj = &x[4 * j..4 * j + 3];
            for r in 0..3 {
                sum[r] += a[3 * r] * xj[0] + a[3 * r + 1] * xj[1] + a[3 * r + 2] * xj[2];
            }
            if j != i {
                let yj = &mut y[4 * (j - base)..4 * (j - base) + 3];
                for (col, yj) in yj.iter_mut().enumerate() {
                    *yj += a[col] * xi[0] + a[3 + col] * xi[1] + a[6 + col] * xi[2];
                }
            }
        }
        for (yi, s) in y[4 * (i - base)..4 * (i - base) + 3].iter_mut().zip(sum) {
            *yi += s;
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn chunk_times_avx2<const TWO: bool>(&self, c: usize, x: [&[f64]; 2], y: [&mut [f64]; 2]) {
        let base = self.chunks[c];
        let [y0, y1] = y;
        for i in base..self.chunks[c + 1] {
            self.row_avx2(i, x[0], y0, base);
            if TWO {
                self.row_avx2(i, x[1], y1, base);
            }
        }
    }

    /// [`row_scalar`](Self::row_scalar) on AVX2: the diagonal block first, then per block the
    /// three block rows as 4-lane loads (their fourth lanes meet x's unused slot, 0), FMAs into
    /// alternating accumulators for y_i, and y_j += Σ_r row_r·x_i[r] as one 4-lane
    /// read–modify–write (the fourth slot gains row 2's spill times x_i[2] and is never read).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    fn row_avx2(&self, i: usize, x: &[f64], y: &mut [f64], base: usize) {
        use std::arch::x86_64::*;
        let range = self.row_ptr[i]..self.row_ptr[i + 1];
        let columns = &self.columns[range.clone()];
        let values = &self.values[9 * range.start..9 * range.end + 1];
        let xi = &x[4 * i..4 * i + 4];
        // SAFETY (all loads and stores below): each pointer comes from a bounds-checked slice
        // of at least 4 values (a block's 10, a node's 4 slots).
        unsafe {
            let load_rows = |k: usize| {
                let v = &values[9 * k..9 * k + 10];
                [0, 3, 6].map(|r| _mm256_loadu_pd(v[r..].as_ptr()))
            };
            let spread = [0, 1, 2].map(|r| _mm256_broadcast_sd(&xi[r]));
            let mut acc = [_mm256_setzero_pd(); 3];
            let mut odd = [_mm256_setzero_pd(); 3];
            let diagonal = load_rows(0);
            let xv = _mm256_loadu_pd(xi.as_ptr());
            for r in 0..3 {
                acc[r] = _mm256_mul_pd(diagonal[r], xv);
            }
            let mut block = |k: usize, acc: &mut [__m256d; 3]| {
                // A hint only: an address past the end is never dereferenced.
                _mm_prefetch::<_MM_HINT_T0>(
                    values.as_ptr().wrapping_add(9 * k + PREFETCH_AHEAD).cast(),
                );
                let j = columns[k] as usize;
                let rows = load_rows(k);
                let xj = _mm256_loadu_pd(x[4 * j..4 * j + 4].as_ptr());
                for r in 0..3 {
                    acc[r] = _mm256_fmadd_pd(rows[r], xj, acc[r]);
                }
                let yj = &mut y[4 * (j - base)..4 * (j - base) + 4];
                let mut t = _mm256_loadu_pd(yj.as_ptr());
                for r in 0..3 {
                    t = _mm256_fmadd_pd(rows[r], spread[r], t);
                }
                _mm256_storeu_pd(yj.as_mut_ptr(), t);
            };
            let mut k = 1;
            while k + 1 < columns.len() {
                block(k, &mut odd);
                block(k + 1, &mut acc);
                k += 2;
            }
            if k < columns.len() {
                block(k, &mut odd);
            }
            let yi = &mut y[4 * (i - base)..4 * (i - base) + 3];
            for r in 0..3 {
                yi[r] += sum3(_mm256_add_pd(acc[r], odd[r]));
            }
        }
    }
}
