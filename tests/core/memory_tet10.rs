//! The memory estimate of 10-node tets: K's stored size against the assembled matrix, the box
//! node count against the generated mesh, and a too-large order-2 box refused before meshing.

use nalgebra::Vector3;
use tetfem::base::memory::{
    MemoryBound, MemoryLimits, RunPath, SolverMemory, StaticEstimate, box_node_count,
    box_static_estimate, check_box_run,
};
use tetfem::{BoxSplit, Material, Tet10, TetMesh, fe::assembly::stiffness_matrix};

/// Bytes of a CSC matrix as stored: column starts and row indices (usize) and values (f64).
fn csc_bytes(col_starts: usize, entries: usize) -> u128 {
    8 * col_starts as u128 + 16 * entries as u128
}

#[test]
fn tet10_stiffness_estimate_covers_the_assembled_matrix_within_twice() {
    let material = Material::new(1e3, 0.3, 1.0).unwrap();
    for split in [BoxSplit::Lecture6, BoxSplit::Five] {
        for n in [3usize, 6, 10] {
            let linear =
                TetMesh::box_grid(Vector3::zeros(), Vector3::repeat(1.0), [n; 3], split).unwrap();
            let mesh = TetMesh::<Tet10>::from_linear(&linear).unwrap();
            // Euler's formula gives the edge count of any conforming box split exactly.
            assert_eq!(
                box_node_count([n; 3], split.tets_per_cell(), 10),
                mesh.node_count() as u128,
                "{split:?} {n}³"
            );
            let k = stiffness_matrix(&mesh, &material).unwrap();
            let measured = csc_bytes(k.col_ptr().len(), k.nnz());
            let estimate = StaticEstimate::for_element(
                mesh.node_count(),
                mesh.tet_count(),
                10,
                SolverMemory::Iterative,
            );
            let estimated =
                csc_bytes(3 * mesh.node_count() + 1, 0) + 16 * estimate.stiffness_entries;
            let linear_formula =
                StaticEstimate::new(mesh.node_count(), mesh.tet_count(), SolverMemory::Iterative);
            println!(
                "{split:?} {n}³: N = {}, T = {}, K {} bytes (nnz {}), estimate {} bytes (×{:.3}), \
                 linear-tet formula nnz {} (×{:.3})",
                mesh.node_count(),
                mesh.tet_count(),
                measured,
                k.nnz(),
                estimated,
                estimated as f64 / measured as f64,
                linear_formula.stiffness_entries,
                linear_formula.stiffness_entries as f64 / k.nnz() as f64
            );
            // An estimate that refuses runs must not undercount (else the allocator aborts
            // them); the bound 2× is the issue's: the formula counts the pattern's blocks, and
            // only boundary nodes (fewer neighbours than interior ones) make it exceed them.
            assert!(
                estimated >= measured,
                "{split:?} {n}³: {estimated} < {measured}"
            );
            assert!(
                estimated <= 2 * measured,
                "{split:?} {n}³: {estimated} > 2 × {measured}"
            );
            // The linear tet's formula undercounts the quadratic pattern (what this replaces).
            assert!(linear_formula.stiffness_entries < k.nnz() as u128);
        }
    }
}

#[test]
fn an_order_two_box_too_large_is_refused_before_meshing() {
    // Order 2 needs more than order 1 on the same cells: a bound between the two estimates
    // accepts the linear box and refuses the quadratic one, naming the size.
    let cells = [40, 40, 40];
    let p1 = box_static_estimate(cells, 6, 4, SolverMemory::Iterative);
    let p2 = box_static_estimate(cells, 6, 10, SolverMemory::Iterative);
    println!(
        "40³ box: order 1 {} , order 2 {}",
        p1.describe(),
        p2.describe()
    );
    // Order 2 on 40³ cells has 7.7× the nodes (531 441 vs 68 921) and about twice the blocks per
    // node: measured 14× the peak. Under 4× would mean the element's counts were ignored.
    assert!(p2.peak() > 4 * p1.peak(), "{} vs {}", p2.peak(), p1.peak());
    let limits = MemoryLimits {
        bounds: vec![MemoryBound {
            source: "test bound",
            bytes: u64::try_from(2 * p1.peak()).unwrap(),
            address_space: false,
        }],
        dense_kernels: 0,
    };
    p1.ensure_fits("order 1", &limits).unwrap();
    let err = p2.ensure_fits("order 2", &limits).unwrap_err().to_string();
    assert!(err.contains("test bound") && err.contains("nodes"), "{err}");
    // A box beyond any machine at order 2: refused at once from the counts, with the box's
    // size and the element named.
    let err = check_box_run([5000, 5000, 5000], 6, 10, false, RunPath::Iterative)
        .unwrap_err()
        .to_string();
    println!("{err}");
    assert!(
        err.contains("5000×5000×5000") && err.contains("10-node"),
        "{err}"
    );
}
