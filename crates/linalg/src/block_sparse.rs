//! K in node blocks: a 3×3 block compressed-row copy of a free-DOF stiffness matrix, for the
//! matrix–vector products that dominate explicit steps.
//!
//! Why a second copy: a product with K reads every stored value once, so its cost is the bytes of
//! K over the memory bandwidth. The scalar CSC matrix stores an 8-byte value and an 8-byte row
//! index per entry (16 B). Elasticity couples nodes, not single DOFs, so K's entries come in
//! dense 3×3 blocks; storing one 4-byte block-column index per 9 values brings that to
//! 8 + 4/9 ≈ 8.44 B per entry — close to the 8 B of the values alone, the floor of any format
//! that stores both halves. [`SymmetricBlockMatrix3`] stores the upper half only and is what the
//! time steppers use; [`BlockMatrix3`] stays for comparison (`benches/explicit_product.rs`).

use rayon::prelude::*;

mod symmetric;
pub use symmetric::{SymmetricBlockMatrix3, SymmetricWorkspace};

use crate::error::{Error, Result};
use crate::sparse::CscMatrix;

/// A symmetric matrix on free DOFs stored as dense 3×3 blocks, one block row per node with a
/// free DOF.
///
/// Free DOFs of one node are consecutive (the free numbering is ascending in the full numbering
/// 3·node + axis). A node with one or two free DOFs gets a padded block row: its missing axes hold
/// zero rows and columns. When every block is complete the padded numbering *is* the free
/// numbering and products read and write the caller's vectors directly; otherwise they go through
/// a gather and a scatter.
#[derive(Debug, Clone)]
pub struct BlockMatrix3 {
    /// Start of each block row in `columns` (length blocks + 1).
    row_ptr: Vec<usize>,
    /// Block column of each stored block.
    columns: Vec<u32>,
    /// Nine values per stored block, row-major, then one 0.0: the SIMD kernel loads each block
    /// row as four lanes, and the last block's third row reaches one value past its block.
    values: Vec<f64>,
    /// Padded index 3·block + axis of each free DOF; `None` when every block is complete.
    padded_index: Option<Vec<u32>>,
    /// Free DOF count.
    dim: usize,
    /// Whether products run the AVX2/FMA kernel (detected on this CPU at construction).
    simd: bool,
}

/// Scratch vectors of the padded numbering (empty when the matrix needs no padding).
#[derive(Debug, Clone, Default)]
pub struct BlockWorkspace {
    x: [Vec<f64>; 2],
    y: [Vec<f64>; 2],
}

impl BlockMatrix3 {
    /// Copies `matrix` (on the free DOFs, symmetric, full pattern) into node blocks.
    /// `free_dofs[i]` is the full index 3·node + axis of free DOF i, ascending (as
    /// `tetfem::DofMap::free_dofs` gives them).
    ///
    /// Errors if the lengths disagree, `free_dofs` is not ascending, or there are more than 2³²
    /// blocks.
    pub fn from_free_matrix(matrix: &CscMatrix, free_dofs: &[usize]) -> Result<Self> {
        let dim = matrix.dim();
        Error::check_len("free_dofs", dim, free_dofs.len())?;
        if let Some(i) = free_dofs.windows(2).position(|w| w[0] >= w[1]) {
            return Err(Error::invalid_parameter(
                "free_dofs",
                format!("{} then {}", free_dofs[i], free_dofs[i + 1]),
                "must be strictly ascending",
            ));
        }
        // Block of each free DOF: a new block starts whenever the node changes.
        let mut block_of = Vec::with_capacity(dim);
        let mut nodes = 0usize;
        for (i, &dof) in free_dofs.iter().enumerate() {
            if i == 0 || dof / 3 != free_dofs[i - 1] / 3 {
                nodes += 1;
            }
            block_of.push(nodes - 1);
        }
        if nodes > u32::MAX as usize / 3 {
            return Err(Error::invalid_parameter(
                "free nodes",
                nodes,
                "must be below 2³²/3 for 4-byte block indices",
            ));
        }
        let padded: Vec<u32> = (0..dim)
            .map(|i| (3 * block_of[i] + free_dofs[i] % 3) as u32)
            .collect();
        let complete = padded.iter().enumerate().all(|(i, &p)| p as usize == i);
        // DOFs of each block, by padded slot (usize::MAX where the axis is constrained).
        let mut block_dofs = vec![[usize::MAX; 3]; nodes];
        for (i, &p) in padded.iter().enumerate() {
            block_dofs[p as usize / 3][p as usize % 3] = i;
        }
        let (col_ptr, row_idx, values) = (matrix.col_ptr(), matrix.row_idx(), matrix.values());
        // The matrix is symmetric, so column i read top to bottom is row i.
        let rows: Vec<(Vec<u32>, Vec<f64>)> = block_dofs
            .par_iter()
            .map(|dofs| {
                let mut columns: Vec<u32> = dofs
                    .iter()
                    .filter(|&&i| i != usize::MAX)
                    .flat_map(|&i| row_idx[col_ptr[i]..col_ptr[i + 1]].iter())
                    .map(|&j| block_of[j] as u32)
                    .collect();
                columns.sort_unstable();
                columns.dedup();
                let mut block_values = vec![0.0; 9 * columns.len()];
                for (r, &i) in dofs.iter().enumerate() {
                    if i == usize::MAX {
                        continue;
                    }
                    for k in col_ptr[i]..col_ptr[i + 1] {
                        let j = row_idx[k];
                        let slot = padded[j] as usize;
                        // Found: `columns` was built from these very entries.
                        let b = columns.partition_point(|&c| (c as usize) < slot / 3);
                        block_values[9 * b + 3 * r + slot % 3] = values[k];
                    }
                }
                (columns, block_values)
            })
            .collect();
        let mut row_ptr = Vec::with_capacity(nodes + 1);
        row_ptr.push(0);
        let total: usize = rows.iter().map(|(c, _)| c.len()).sum();
        let mut columns = Vec::with_capacity(total);
        let mut block_values = Vec::with_capacity(9 * total);
        for (c, v) in rows {
            columns.extend_from_slice(&c);
            block_values.extend_from_slice(&v);
            row_ptr.push(columns.len());
        }
        block_values.push(0.0);
        Ok(BlockMatrix3 {
            row_ptr,
            columns,
            values: block_values,
            padded_index: (!complete).then_some(padded),
            dim,
            simd: simd_available(),
        })
    }

    /// Free DOF count (the dimension of the vectors it multiplies).
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// Number of node blocks per side.
    pub fn block_rows(&self) -> usize {
        self.row_ptr.len() - 1
    }

    /// Stored 3×3 blocks.
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
    /// the CPU has both), for measuring one against the other, and returns whether the AVX2/FMA
    /// kernel now runs: `set_simd(true)` returns `false` on a CPU without AVX2 or FMA (the
    /// scalar kernel runs instead), so a caller that means to use the SIMD kernel can tell that
    /// it did not. Both give each entry as one fixed sequence of operations, so results are
    /// reproducible, but the two kernels' sums differ in order and so in the last bits.
    pub fn set_simd(&mut self, enabled: bool) -> bool {
        self.simd = enabled && simd_available();
        self.simd
    }

    /// Whether some node has only one or two free DOFs (products then gather and scatter).
    pub fn is_padded(&self) -> bool {
        self.padded_index.is_some()
    }

    /// Scratch for the products (vectors of the padded numbering; empty when there is no padding).
    pub fn workspace(&self) -> BlockWorkspace {
        let n = if self.is_padded() {
            3 * self.block_rows()
        } else {
            0
        };
        BlockWorkspace {
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

    /// y = A·x for vectors of length `dim()` by construction; `work` from
    /// [`workspace`](Self::workspace). Returns xᵀ·y, summed in a fixed order (the same bits
    /// whatever the thread count): the energy ½uᵀKu comes with the product for free.
    #[doc(hidden)]
    pub fn product_into(&self, x: &[f64], y: &mut [f64], work: &mut BlockWorkspace) -> f64 {
        match &self.padded_index {
            None => self.blocks_times([x, x], [y, &mut []]).0,
            Some(padded) => {
                let [xp, _] = &mut work.x;
                let [yp, _] = &mut work.y;
                gather(padded, x, xp);
                let dot = self.blocks_times([xp, xp], [yp, &mut []]).0;
                scatter(padded, yp, y);
                dot
            }
        }
    }

    /// ya = A·xa and yb = A·xb in one pass over the matrix (half the bytes of two products).
    /// Returns (xaᵀ·ya, xbᵀ·yb), summed in a fixed order. Only the tests call it since the time
    /// steppers moved to [`SymmetricBlockMatrix3`]; it keeps the two-vector kernel checked for
    /// comparisons with that format.
    #[cfg(feature = "kernel-internals")]
    #[doc(hidden)]
    pub fn product2_into(
        &self,
        (xa, xb): (&[f64], &[f64]),
        (ya, yb): (&mut [f64], &mut [f64]),
        work: &mut BlockWorkspace,
    ) -> (f64, f64) {
        match &self.padded_index {
            None => self.blocks_times([xa, xb], [ya, yb]),
            Some(padded) => {
                let [xpa, xpb] = &mut work.x;
                let [ypa, ypb] = &mut work.y;
                gather(padded, xa, xpa);
                gather(padded, xb, xpb);
                let dots = self.blocks_times([xpa, xpb], [ypa, ypb]);
                scatter(padded, ypa, ya);
                scatter(padded, ypb, yb);
                dots
            }
        }
    }

    /// y = A·x with a chosen number of concurrent streams per parallel task (1, 2, 4 or 8;
    /// [`Error::InvalidParameter`] otherwise), for measuring what the streams buy: the result
    /// is bit for bit that of [`mul_vec`](Self::mul_vec), which uses [`STREAMS`].
    pub fn mul_vec_with_streams(&self, x: &[f64], y: &mut [f64], streams: usize) -> Result<()> {
        Error::check_len("x", self.dim, x.len())?;
        Error::check_len("y", self.dim, y.len())?;
        let times = match streams {
            1 => Self::blocks_times_streams::<1>,
            2 => Self::blocks_times_streams::<2>,
            4 => Self::blocks_times_streams::<4>,
            8 => Self::blocks_times_streams::<8>,
            _ => {
                return Err(Error::invalid_parameter(
                    "streams",
                    streams,
                    "must be 1, 2, 4 or 8",
                ));
            }
        };
        match &self.padded_index {
            None => {
                times(self, [x, x], [y, &mut []]);
            }
            Some(padded) => {
                let mut work = self.workspace();
                let [xp, _] = &mut work.x;
                let [yp, _] = &mut work.y;
                gather(padded, x, xp);
                times(self, [xp, xp], [yp, &mut []]);
                scatter(padded, yp, y);
            }
        }
        Ok(())
    }

    /// y₀ = A·x₀ and, when y₁ is not empty, y₁ = A·x₁, in the padded numbering, with
    /// [`STREAMS`] streams per task.
    fn blocks_times(&self, x: [&[f64]; 2], y: [&mut [f64]; 2]) -> (f64, f64) {
        self.blocks_times_streams::<STREAMS>(x, y)
    }

    /// The products in parallel over fixed chunks of [`CHUNK_ROWS`] block rows, whose partial
    /// dot products xᵢᵀ·yᵢ are summed in chunk order. Each output entry is one sequential sum
    /// and the chunks and their streams do not depend on the thread count, so no bit does.
    fn blocks_times_streams<const S: usize>(
        &self,
        x: [&[f64]; 2],
        y: [&mut [f64]; 2],
    ) -> (f64, f64) {
        let [y0, y1] = y;
        let len = 3 * CHUNK_ROWS;
        let partial: Vec<(f64, f64)> = if y1.is_empty() {
            y0.par_chunks_mut(len)
                .enumerate()
                .map(|(c, y0)| self.chunk_times::<S, false>(c * CHUNK_ROWS, x, [y0, &mut []]))
                .collect()
        } else {
            y0.par_chunks_mut(len)
                .zip(y1.par_chunks_mut(len))
                .enumerate()
                .map(|(c, (y0, y1))| self.chunk_times::<S, true>(c * CHUNK_ROWS, x, [y0, y1]))
                .collect()
        };
        partial
            .iter()
            .fold((0.0, 0.0), |(a, b), (p, q)| (a + p, b + q))
    }

    /// One chunk of block rows from `first` (as many as `y[0]` holds), cut into `S` parts of
    /// about equal stored blocks that advance together, one block row of each per turn: the
    /// hardware prefetchers then follow S sequential streams, and one core reads memory
    /// faster than it does along a single stream (measured in benches/explicit_product.rs).
    /// Returns the chunk's (x₀ᵀ·y₀, x₁ᵀ·y₁), its parts' sums added in order.
    fn chunk_times<const S: usize, const TWO: bool>(
        &self,
        first: usize,
        x: [&[f64]; 2],
        y: [&mut [f64]; 2],
    ) -> (f64, f64) {
        #[cfg(target_arch = "x86_64")]
        if self.simd {
            // SAFETY: `simd` is set only where AVX2 and FMA were detected on this CPU.
            return unsafe { self.chunk_times_avx2::<S, TWO>(first, x, y) };
        }
        self.chunk_body::<S, TWO, false>(first, x, y)
    }

    /// [`chunk_times`](Self::chunk_times) compiled for AVX2 and FMA, with the SIMD row kernel.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn chunk_times_avx2<const S: usize, const TWO: bool>(
        &self,
        first: usize,
        x: [&[f64]; 2],
        y: [&mut [f64]; 2],
    ) -> (f64, f64) {
        self.chunk_body::<S, TWO, true>(first, x, y)
    }

    #[inline(always)]
    fn chunk_body<const S: usize, const TWO: bool, const SIMD: bool>(
        &self,
        first: usize,
        x: [&[f64]; 2],
        y: [&mut [f64]; 2],
    ) -> (f64, f64) {
        let bounds = self.stream_bounds::<S>(first, first + y[0].len() / 3);
        let [y0, y1] = y;
        let parts0 = split_rows::<S>(y0, &bounds);
        let parts1 = if TWO {
            split_rows::<S>(y1, &bounds)
        } else {
            std::array::from_fn(|_| &mut [][..])
        };
        let longest = (0..S).map(|s| bounds[s + 1] - bounds[s]).max().unwrap_or(0);
        let mut dots = [(0.0, 0.0); S];
        for local in 0..longest {
            for s in 0..S {
                let b = bounds[s] + local;
                if b >= bounds[s + 1] {
                    continue;
                }
                let (s0, s1) = if SIMD {
                    self.row_times_simd::<TWO>(b, x)
                } else {
                    self.row_times::<TWO>(b, x)
                };
                let rows = 3 * local..3 * local + 3;
                parts0[s][rows.clone()].copy_from_slice(&s0);
                dots[s].0 += dot3(&x[0][3 * b..3 * b + 3], &s0);
                if TWO {
                    parts1[s][rows].copy_from_slice(&s1);
                    dots[s].1 += dot3(&x[1][3 * b..3 * b + 3], &s1);
                }
            }
        }
        dots.iter()
            .fold((0.0, 0.0), |(a, b), (p, q)| (a + p, b + q))
    }

    /// Block-row bounds of the `S` parts of rows `first..end`: part s is
    /// `bounds[s]..bounds[s + 1]`, cut where the stored blocks reach s/S of the chunk's (parts
    /// may be empty when the chunk has fewer rows than parts). A `Vec` because arrays cannot
    /// have length S + 1 on stable Rust; one small allocation per chunk of thousands of rows.
    /// [`stream_bounds`](Self::stream_bounds) and the block-row starts, for tetfem's tests of
    /// the partitioning (feature `kernel-internals`; not a stable API).
    #[cfg(feature = "kernel-internals")]
    #[doc(hidden)]
    pub fn stream_bounds_for_tests<const S: usize>(&self, first: usize, end: usize) -> Vec<usize> {
        self.stream_bounds::<S>(first, end)
    }

    /// Start of each block row's stored blocks (feature `kernel-internals`; not a stable API).
    #[cfg(feature = "kernel-internals")]
    #[doc(hidden)]
    pub fn row_ptr(&self) -> &[usize] {
        &self.row_ptr
    }

    fn stream_bounds<const S: usize>(&self, first: usize, end: usize) -> Vec<usize> {
        let row_ptr = &self.row_ptr[first..=end];
        let (start, blocks) = (row_ptr[0], row_ptr[end - first] - row_ptr[0]);
        let cut = |s: usize| first + row_ptr.partition_point(|&p| p - start < blocks * s / S);
        // The last part ends at `end` even when the chunk's last rows store no block.
        (0..S).map(cut).chain([end]).collect()
    }

    /// (A·x₀, A·x₁) of block row `b` (the second only when `TWO`).
    #[inline(always)]
    fn row_times<const TWO: bool>(&self, b: usize, x: [&[f64]; 2]) -> ([f64; 3], [f64; 3]) {
        let (mut s0, mut s1) = ([0.0; 3], [0.0; 3]);
        let range = self.row_ptr[b]..self.row_ptr[b + 1];
        let blocks = self.values[9 * range.start..9 * range.end].chunks_exact(9);
        for (&j, a) in self.columns[range].iter().zip(blocks) {
            let j = 3 * j as usize;
            let p = &x[0][j..j + 3];
            for r in 0..3 {
                s0[r] += a[3 * r] * p[0] + a[3 * r + 1] * p[1] + a[3 * r + 2] * p[2];
            }
            if TWO {
                let q = &x[1][j..j + 3];
                for r in 0..3 {
                    s1[r] += a[3 * r] * q[0] + a[3 * r + 1] * q[1] + a[3 * r + 2] * q[2];
                }
            }
        }
        (s0, s1)
    }

    /// [`row_times`](Self::row_times) on AVX2: each block row is one 4-lane load (its fourth
    /// lane the next value, which meets x's masked-off fourth lane, 0), multiplied into an
    /// accumulator per block row; alternate blocks go to two sets of accumulators, so that
    /// consecutive FMAs do not wait on each other's latency. Lanes are summed once per row,
    /// (l₀ + l₁) + l₂: each entry is still one fixed sequence of operations, whatever the threads.
    /// On other targets (never called there) the scalar kernel.
    #[inline(always)]
    fn row_times_simd<const TWO: bool>(&self, b: usize, x: [&[f64]; 2]) -> ([f64; 3], [f64; 3]) {
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: only reached from `chunk_times_avx2`, i.e. with AVX2 and FMA.
            unsafe { self.row_times_avx2::<TWO>(b, x) }
        }
        #[cfg(not(target_arch = "x86_64"))]
        self.row_times::<TWO>(b, x)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    fn row_times_avx2<const TWO: bool>(&self, b: usize, x: [&[f64]; 2]) -> ([f64; 3], [f64; 3]) {
        use std::arch::x86_64::*;
        let range = self.row_ptr[b]..self.row_ptr[b + 1];
        let columns = &self.columns[range.clone()];
        // The row's blocks and the one value after them (the next block's first, or the pad).
        let values = &self.values[9 * range.start..9 * range.end + 1];
        let (x0, x1) = (x[0], x[1]);
        let mask = _mm256_setr_epi64x(-1, -1, -1, 0);
        let zero = _mm256_setzero_pd();
        let (mut a0, mut a1) = ([zero; 3], [zero; 3]);
        let (mut b0, mut b1) = ([zero; 3], [zero; 3]);
        let block = |k: usize, acc0: &mut [__m256d; 3], acc1: &mut [__m256d; 3]| {
            let j = 3 * columns[k] as usize;
            let v = &values[9 * k..9 * k + 10];
            // SAFETY: `v` holds 10 values, so the loads at 0, 3 and 6 read 4 in bounds; the
            // masked loads read only the 3 lanes of `x0[j..j + 3]`, bounds-checked here.
            unsafe {
                let rows = [0, 3, 6].map(|r| _mm256_loadu_pd(v[r..].as_ptr()));
                let p = _mm256_maskload_pd(x0[j..j + 3].as_ptr(), mask);
                for r in 0..3 {
                    acc0[r] = _mm256_fmadd_pd(rows[r], p, acc0[r]);
                }
                if TWO {
                    let q = _mm256_maskload_pd(x1[j..j + 3].as_ptr(), mask);
                    for r in 0..3 {
                        acc1[r] = _mm256_fmadd_pd(rows[r], q, acc1[r]);
                    }
                }
            }
        };
        let pairs = columns.len() / 2;
        for k in 0..pairs {
            block(2 * k, &mut a0, &mut a1);
            block(2 * k + 1, &mut b0, &mut b1);
        }
        if columns.len() % 2 == 1 {
            block(columns.len() - 1, &mut a0, &mut a1);
        }
        let s0 = std::array::from_fn(|r| sum3(_mm256_add_pd(a0[r], b0[r])));
        let s1 = if TWO {
            std::array::from_fn(|r| sum3(_mm256_add_pd(a1[r], b1[r])))
        } else {
            [0.0; 3]
        };
        (s0, s1)
    }
}

/// (l₀ + l₁) + l₂ of a 4-lane vector (its fourth lane ignored): a node's entry from the lanes
/// of a block row's accumulator.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
fn sum3(t: std::arch::x86_64::__m256d) -> f64 {
    use std::arch::x86_64::*;
    let low = _mm256_castpd256_pd128(t);
    let high = _mm256_extractf128_pd::<1>(t);
    _mm_cvtsd_f64(_mm_add_sd(_mm_add_sd(low, _mm_unpackhi_pd(low, low)), high))
}

/// Whether this CPU runs the AVX2/FMA product kernel (both features detected at run time):
/// where it does not, [`BlockMatrix3::set_simd`] and [`SymmetricBlockMatrix3::set_simd`] keep
/// the scalar kernel.
pub fn simd_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    false
}

/// Concurrent sequential streams each parallel task of a product follows (see
/// [`BlockMatrix3::mul_vec_with_streams`] to measure others). Two, as measured with
/// `benches/explicit_product.rs` on a shared 2-core EPYC (best of 20, interleaved): at 132k
/// and 435k DOFs two streams took 0.81–0.93× the time of one on one and two threads, while
/// four and eight took 1.2–2.1× *longer* than one, although a plain read of the values runs
/// 1.5–1.8× faster as four streams than as one. Presumably because each part of a product is
/// three streams (values, block columns, y) plus a window of x, and twelve or more outrun the
/// prefetchers; writing out one copy of the loads per stream did not help.
pub const STREAMS: usize = 2;

/// Block rows per parallel task of a product: fixed (not derived from the thread count), so
/// that the dot products' summation order is too.
pub const CHUNK_ROWS: usize = 2048;

/// `y` (the rows of one chunk) cut into the parts of `bounds` (block rows, 3 entries each).
fn split_rows<'a, const S: usize>(y: &'a mut [f64], bounds: &[usize]) -> [&'a mut [f64]; S] {
    let mut rest = y;
    std::array::from_fn(|s| {
        let rows = bounds[s + 1] - bounds[s];
        let (part, tail) = std::mem::take(&mut rest).split_at_mut(3 * rows);
        rest = tail;
        part
    })
}

fn dot3(x: &[f64], y: &[f64; 3]) -> f64 {
    x[0] * y[0] + x[1] * y[1] + x[2] * y[2]
}

fn gather(padded: &[u32], free: &[f64], out: &mut [f64]) {
    out.fill(0.0);
    for (&p, &v) in padded.iter().zip(free) {
        out[p as usize] = v;
    }
}

fn scatter(padded: &[u32], values: &[f64], free: &mut [f64]) {
    for (&p, out) in padded.iter().zip(free) {
        *out = values[p as usize];
    }
}
