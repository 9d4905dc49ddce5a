//! The 3×3 node-block matrices of `tetfem::linalg::block_sparse` on real stiffness matrices:
//! products equal the scalar CSC ones, streams and threads change no bit, padded blocks of
//! partially constrained nodes. (Moved from the unit tests when the linear algebra became its
//! own crate: they need an assembled K, which the linear-algebra crate cannot build.)

mod node_blocks {
    use tetfem::linalg::block_sparse::*;
    use tetfem::linalg::sparse::CscMatrix;
    use tetfem::{Assembler, DofMap};
    use tetfem_fixtures::cantilever::Cantilever;

    /// K_ff of a small beam, with a roller on its free end when `roller` (padded blocks).
    fn stiffness(roller: bool) -> (CscMatrix, DofMap) {
        stiffness_of(&Cantilever::peer_benchmark([6, 2, 2]), roller)
    }

    /// K_ff of `problem`'s beam, with a roller on its free end when `roller`.
    fn stiffness_of(problem: &Cantilever, roller: bool) -> (CscMatrix, DofMap) {
        let mesh = problem.mesh().unwrap();
        let mut constraints = problem.constraints(&mesh).unwrap();
        if roller {
            // A roller on the free end's nodes: their z axis only is fixed.
            let far: Vec<usize> = (0..mesh.node_count())
                .filter(|&n| mesh.nodes()[n].x > problem.length - 1e-9)
                .collect();
            constraints.fix_axes(&far, [false, false, true]).unwrap();
        }
        let dofs = DofMap::new(&constraints);
        let k = Assembler::new(&mesh)
            .stiffness(&mesh, &problem.material)
            .unwrap();
        let k_ff = dofs.restriction(k.pattern()).unwrap().restrict(&k).unwrap();
        (k_ff, dofs)
    }

    /// [`check_kernel`] on the scalar kernel, then on the AVX2/FMA one where the CPU has it
    /// (elsewhere reported as skipped: that kernel is then not tested).
    fn check_products(roller: bool) {
        check_kernel(roller, false);
        if simd_available() {
            check_kernel(roller, true);
        } else {
            println!("skipped: no AVX2/FMA on this CPU, the SIMD kernel is not tested");
        }
    }

    fn check_kernel(roller: bool, simd: bool) {
        let (k, dofs) = stiffness(roller);
        let mut blocks = BlockMatrix3::from_free_matrix(&k, dofs.free_dofs()).unwrap();
        // The kernel asked for is the one that runs (`simd` only where the CPU has it).
        assert_eq!(blocks.set_simd(simd), simd);
        assert_eq!(blocks.simd(), simd);
        assert_eq!(blocks.is_padded(), roller);
        let n = k.dim();
        let xa: Vec<f64> = (0..n).map(|i| ((i * 7919) % 101) as f64 - 50.0).collect();
        let xb: Vec<f64> = (0..n).map(|i| ((i * 104_729) % 37) as f64 * 0.1).collect();
        let (reference_a, reference_b) = (k.mul(&xa).unwrap(), k.mul(&xb).unwrap());
        let mut work = blocks.workspace();
        let (mut ya, mut yb) = (vec![f64::NAN; n], vec![f64::NAN; n]);
        let dots = blocks.product2_into((&xa, &xb), (&mut ya, &mut yb), &mut work);
        let dot = |x: &[f64], y: &[f64]| x.iter().zip(y).map(|(p, q)| p * q).sum::<f64>();
        let (xkx_a, xkx_b) = (dot(&xa, &reference_a), dot(&xb, &reference_b));
        // Round-off of a sum of n terms in another order.
        assert!(
            (dots.0 - xkx_a).abs()
                <= 1e-12 * dot(&xa, &xa).sqrt() * dot(&reference_a, &reference_a).sqrt()
        );
        assert!(
            (dots.1 - xkx_b).abs()
                <= 1e-12 * dot(&xb, &xb).sqrt() * dot(&reference_b, &reference_b).sqrt()
        );
        assert_eq!(
            blocks
                .product_into(&xa, &mut vec![0.0; n], &mut work)
                .to_bits(),
            dots.0.to_bits()
        );
        let mut y = vec![f64::NAN; n];
        blocks.mul_vec(&xa, &mut y).unwrap();
        let scale = k.values().iter().fold(0.0f64, |m, v| m.max(v.abs())) * 50.0 * 100.0;
        for i in 0..n {
            // Same products summed in another order: round-off of ~100 terms of size `scale`.
            assert!((y[i] - reference_a[i]).abs() <= 1e-13 * scale, "row {i}");
            assert_eq!(
                y[i].to_bits(),
                ya[i].to_bits(),
                "one- and two-vector row {i}"
            );
            assert!((yb[i] - reference_b[i]).abs() <= 1e-13 * scale, "row {i}");
        }
        // Every stored entry of K is in a block: 9 values per block cover nnz.
        assert!(9 * blocks.stored_blocks() >= k.nnz());
    }

    #[test]
    fn block_products_equal_the_scalar_ones() {
        check_products(false);
    }

    #[test]
    fn padded_blocks_of_partially_constrained_nodes() {
        check_products(true);
    }

    /// `k`'s products with 1, 2, 4 and 8 streams on pools of one and two threads: y and the dot
    /// products xᵀy bit for bit those of the single-stream product on one thread (each y entry
    /// is the same sequential sum; the dots' order is fixed by the chunks and streams), and y
    /// the CSC product's up to round-off.
    fn check_streams(k: &CscMatrix, free_dofs: &[usize]) {
        let blocks = BlockMatrix3::from_free_matrix(k, free_dofs).unwrap();
        let n = k.dim();
        let xa: Vec<f64> = (0..n).map(|i| ((i * 7919) % 101) as f64 - 50.0).collect();
        let xb: Vec<f64> = (0..n).map(|i| ((i * 104_729) % 37) as f64 * 0.1).collect();
        let reference = k.mul(&xa).unwrap();
        let mut single = vec![f64::NAN; n];
        blocks.mul_vec_with_streams(&xa, &mut single, 1).unwrap();
        let scale = k.values().iter().fold(0.0f64, |m, v| m.max(v.abs())) * 50.0 * 100.0;
        for i in 0..n {
            // Same products summed in another order: round-off of ~100 terms of size `scale`.
            assert!((single[i] - reference[i]).abs() <= 1e-13 * scale, "row {i}");
        }
        let bits = |y: &[f64]| y.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        let mut expected_dots = None;
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                for streams in [1, 2, 4, 8] {
                    let mut y = vec![f64::NAN; n];
                    blocks.mul_vec_with_streams(&xa, &mut y, streams).unwrap();
                    assert_eq!(
                        bits(&y),
                        bits(&single),
                        "{streams} streams, {threads} threads"
                    );
                }
                let mut work = blocks.workspace();
                let (mut ya, mut yb) = (vec![f64::NAN; n], vec![f64::NAN; n]);
                let dots = blocks.product2_into((&xa, &xb), (&mut ya, &mut yb), &mut work);
                assert_eq!(bits(&ya), bits(&single), "{threads} threads");
                let dots = (dots.0.to_bits(), dots.1.to_bits());
                assert_eq!(
                    *expected_dots.get_or_insert(dots),
                    dots,
                    "{threads} threads"
                );
            });
        }
        assert!(blocks.mul_vec_with_streams(&xa, &mut single, 3).is_err());
    }

    #[test]
    fn streams_and_threads_change_no_bit_over_several_chunks() {
        for roller in [false, true] {
            let problem = Cantilever::peer_benchmark([50, 6, 6]);
            let (k, dofs) = stiffness_of(&problem, roller);
            let blocks = BlockMatrix3::from_free_matrix(&k, dofs.free_dofs()).unwrap();
            // Two chunks, the second partial: 2 450 block rows.
            assert!(
                blocks.block_rows() > CHUNK_ROWS && !blocks.block_rows().is_multiple_of(CHUNK_ROWS)
            );
            check_streams(&k, dofs.free_dofs());
        }
    }

    /// A dense SPD matrix of dimension `n` (full pattern).
    fn dense(n: usize) -> CscMatrix {
        let col_ptr = (0..=n).map(|j| j * n).collect();
        let rows = (0..n * n).map(|k| k % n).collect();
        let values = (0..n * n)
            .map(|k| {
                if k % n == k / n {
                    10.0
                } else {
                    1.0 / (1 + k % n + k / n) as f64
                }
            })
            .collect();
        let pattern = faer::sparse::SymbolicSparseColMat::new_checked(n, n, col_ptr, None, rows);
        CscMatrix::from_values(std::sync::Arc::new(pattern), values).unwrap()
    }

    #[test]
    fn tiny_matrices_with_fewer_block_rows_than_streams() {
        check_streams(&dense(0), &[]);
        check_streams(&dense(3), &[0, 1, 2]);
        // One node with two free axes (padded), then a complete one and a one-axis node.
        check_streams(&dense(2), &[3, 5]);
        check_streams(&dense(6), &[1, 2, 3, 4, 5, 8]);
    }

    #[test]
    fn streams_split_a_chunk_into_equal_work() {
        let (k, dofs) = stiffness_of(&Cantilever::peer_benchmark([50, 6, 6]), false);
        let blocks = BlockMatrix3::from_free_matrix(&k, dofs.free_dofs()).unwrap();
        let longest_row = (0..blocks.block_rows())
            .map(|b| blocks.row_ptr()[b + 1] - blocks.row_ptr()[b])
            .max()
            .unwrap();
        let (first, end) = (100, blocks.block_rows());
        let bounds = blocks.stream_bounds_for_tests::<4>(first, end);
        assert_eq!((bounds[0], bounds[4]), (first, end));
        let total = blocks.row_ptr()[end] - blocks.row_ptr()[first];
        for part in bounds.windows(2) {
            let stored = blocks.row_ptr()[part[1]] - blocks.row_ptr()[part[0]];
            // A cut falls at a row boundary: within one row of the ideal quarter.
            assert!(
                stored.abs_diff(total / 4) <= longest_row,
                "{part:?}: {stored} of {total}"
            );
        }
    }

    #[test]
    fn bad_free_dofs_are_errors() {
        let (k, dofs) = stiffness(false);
        let mut reversed = dofs.free_dofs().to_vec();
        reversed.swap(0, 1);
        assert!(BlockMatrix3::from_free_matrix(&k, &reversed).is_err());
        assert!(BlockMatrix3::from_free_matrix(&k, &dofs.free_dofs()[1..]).is_err());
        let blocks = BlockMatrix3::from_free_matrix(&k, dofs.free_dofs()).unwrap();
        assert!(blocks.mul_vec(&[1.0], &mut [0.0]).is_err());
    }
}

mod symmetric_blocks {
    use tetfem::linalg::block_sparse::*;
    use tetfem::linalg::sparse::CscMatrix;
    use tetfem::{Assembler, DofMap};
    use tetfem_fixtures::cantilever::Cantilever;

    /// K_ff of `problem`'s beam, with a roller (z fixed) on its free end when `roller`, so that
    /// those nodes have padded blocks.
    fn beam(problem: &Cantilever, roller: bool) -> (CscMatrix, Vec<usize>) {
        let mesh = problem.mesh().unwrap();
        let mut constraints = problem.constraints(&mesh).unwrap();
        if roller {
            let far: Vec<usize> = (0..mesh.node_count())
                .filter(|&n| mesh.nodes()[n].x > problem.length - 1e-9)
                .collect();
            constraints.fix_axes(&far, [false, false, true]).unwrap();
        }
        let dofs = DofMap::new(&constraints);
        let k = Assembler::new(&mesh)
            .stiffness(&mesh, &problem.material)
            .unwrap();
        let k_ff = dofs.restriction(k.pattern()).unwrap().restrict(&k).unwrap();
        (k_ff, dofs.free_dofs().to_vec())
    }

    /// Block-arrow matrix on `nodes` nodes, 3 DOFs each: node 0 couples with every node, every
    /// other node only with itself, so chunk 0's columns reach the last row.
    fn arrow(nodes: usize) -> (CscMatrix, Vec<usize>) {
        let n = 3 * nodes;
        let value = |i: usize, j: usize| {
            if i == j {
                10.0
            } else {
                1.0 / (1 + i + j) as f64
            }
        };
        let (mut col_ptr, mut rows, mut values) = (vec![0], Vec::new(), Vec::new());
        for j in 0..n {
            let column: Vec<usize> = if j < 3 {
                (0..n).collect()
            } else {
                let node = 3 * (j / 3);
                (0..3).chain(node..node + 3).collect()
            };
            values.extend(column.iter().map(|&i| value(i, j)));
            rows.extend(column);
            col_ptr.push(rows.len());
        }
        let pattern = faer::sparse::SymbolicSparseColMat::new_checked(n, n, col_ptr, None, rows);
        let k = CscMatrix::from_values(std::sync::Arc::new(pattern), values).unwrap();
        (k, (0..n).collect())
    }

    /// Products of `k` in upper blocks: equal to the CSC product up to round-off on either
    /// kernel; bit for bit the same on one and two threads, and between one- and two-vector
    /// products; xᵀy returned as summed from y. Returns the chunk count.
    fn check(k: &CscMatrix, free_dofs: &[usize]) -> usize {
        let mut upper = SymmetricBlockMatrix3::from_free_matrix(k, free_dofs).unwrap();
        let full = BlockMatrix3::from_free_matrix(k, free_dofs).unwrap();
        // The diagonal blocks and half of the others (plus any diagonal blocks the full format
        // lacks).
        assert!(2 * upper.stored_blocks() >= full.stored_blocks() + full.block_rows());
        assert!(2 * upper.stored_blocks() <= full.stored_blocks() + 2 * full.block_rows());
        let n = k.dim();
        let xa: Vec<f64> = (0..n).map(|i| ((i * 7919) % 101) as f64 - 50.0).collect();
        let xb: Vec<f64> = (0..n).map(|i| ((i * 104_729) % 37) as f64 * 0.1).collect();
        let (reference_a, reference_b) = (k.mul(&xa).unwrap(), k.mul(&xb).unwrap());
        let scale = k.values().iter().fold(0.0f64, |m, v| m.max(v.abs()))
            * 50.0
            * k.col_ptr().windows(2).map(|w| w[1] - w[0]).max().unwrap() as f64;
        let bits = |y: &[f64]| y.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        for simd in [false, true] {
            if upper.set_simd(simd) != simd {
                // Only `true` can be refused, and only on a CPU without AVX2/FMA.
                assert!(simd && !simd_available());
                println!("skipped: no AVX2/FMA on this CPU, the SIMD kernel is not tested");
                continue;
            }
            assert_eq!(upper.simd(), simd);
            let mut expected = None;
            for threads in [1, 2] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let (ya, yb, dots, dot) = pool.install(|| {
                    let mut work = upper.workspace();
                    let (mut ya, mut yb) = (vec![f64::NAN; n], vec![f64::NAN; n]);
                    let dots = upper.product2_into((&xa, &xb), (&mut ya, &mut yb), &mut work);
                    let mut y = vec![f64::NAN; n];
                    let dot = upper.mul_vec_with(&xa, &mut y, &mut work).unwrap();
                    assert_eq!(
                        bits(&y),
                        bits(&ya),
                        "one and two vectors, {threads} threads"
                    );
                    (ya, yb, dots, dot)
                });
                for i in 0..n {
                    // The same products summed in another order: round-off of at most
                    // (entries per row) terms of size `scale`.
                    assert!((ya[i] - reference_a[i]).abs() <= 1e-13 * scale, "row {i}");
                    assert!((yb[i] - reference_b[i]).abs() <= 1e-13 * scale, "row {i}");
                }
                let summed: f64 = xa.iter().zip(&ya).map(|(x, y)| x * y).sum();
                // xᵀy over chunks in order against one left-to-right sum: round-off.
                let norm = xa.iter().zip(&ya).map(|(x, y)| (x * y).abs()).sum::<f64>();
                assert!((dot - summed).abs() <= 1e-13 * norm);
                assert_eq!(dot.to_bits(), dots.0.to_bits());
                let run = (bits(&ya), bits(&yb), dots.0.to_bits(), dots.1.to_bits());
                assert!(
                    *expected.get_or_insert(run.clone()) == run,
                    "simd {simd}: bits differ on {threads} threads"
                );
            }
        }
        upper.chunk_count()
    }

    #[test]
    fn products_of_a_small_beam_with_and_without_padding() {
        let problem = Cantilever::peer_benchmark([6, 2, 2]);
        for roller in [false, true] {
            let (k, free) = beam(&problem, roller);
            assert_eq!(check(&k, &free), 1);
        }
    }

    #[test]
    fn chunks_write_their_successors_rows_without_a_race() {
        // 81·9·9 nodes, 72 of them clamped: four chunks of 2048 block rows, each coupled to
        // the next through the 81·9 nodes of a cross-section.
        let (k, free) = beam(&Cantilever::peer_benchmark([80, 8, 8]), true);
        assert_eq!(check(&k, &free), 4);
    }

    #[test]
    fn a_row_coupled_to_all_stretches_the_next_chunk_to_the_end() {
        let (k, free) = arrow(5000);
        // Chunk 0 (2048 rows) reaches the last row, so chunk 1 takes all the rest.
        assert_eq!(check(&k, &free), 2);
    }

    #[test]
    fn wrong_lengths_are_errors() {
        let (k, free) = arrow(4);
        let upper = SymmetricBlockMatrix3::from_free_matrix(&k, &free).unwrap();
        let mut work = upper.workspace();
        let (x, mut y) = (vec![1.0; 12], vec![0.0; 12]);
        assert!(upper.mul_vec_with(&x[..11], &mut y, &mut work).is_err());
        assert!(upper.mul_vec_with(&x, &mut y[..11], &mut work).is_err());
        let mut other =
            SymmetricBlockMatrix3::from_free_matrix(&arrow(5).0, &(0..15).collect::<Vec<_>>())
                .unwrap()
                .workspace();
        assert!(upper.mul_vec_with(&x, &mut y, &mut other).is_err());
        assert!(
            upper
                .mul_vec_with(&x, &mut y, &mut SymmetricWorkspace::default())
                .is_err()
        );
        let mut z = vec![0.0; 12];
        upper.mul_vec(&x, &mut z).unwrap();
        upper.mul_vec_with(&x, &mut y, &mut work).unwrap();
        assert_eq!(y, z);
    }
}
