//! Tests of the symbolic tuning ([`SparseCholesky::analyze_tuned`]): the factor counts against
//! faer's simplicial (unpadded) analysis, solutions under every setting, and the refusals.

use std::sync::Arc;

use faer::Side;
use faer::perm::PermRef;
use faer::sparse::SymbolicSparseColMat;
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymmetricOrdering, factorize_symbolic_cholesky,
};

use super::{CholeskyOptions, DEFAULT_RELAXATION, SparseCholesky};
use crate::ordering::{NestedDissectionOptions, inverse_permutation, nested_dissection_with};
use crate::sparse::CscMatrix;
use crate::{Error, Result};

/// A 3-DOF-per-node matrix on an n×n×n grid of nodes, each coupled to its 26 neighbours (the
/// pattern of a hexahedral or tetrahedral elasticity mesh), diagonally dominant hence SPD.
fn grid(n: usize) -> CscMatrix {
    let node = |x: usize, y: usize, z: usize| (z * n + y) * n + x;
    let dofs = 3 * n * n * n;
    let (mut col_ptr, mut rows, mut values) = (vec![0], Vec::new(), Vec::new());
    for j in 0..dofs {
        let (p, c) = (j / 3, j % 3);
        let (x, y, z) = (p % n, (p / n) % n, p / (n * n));
        let mut column = Vec::new();
        for dz in [-1i64, 0, 1] {
            for dy in [-1i64, 0, 1] {
                for dx in [-1i64, 0, 1] {
                    let (a, b, e) = (x as i64 + dx, y as i64 + dy, z as i64 + dz);
                    if [a, b, e].iter().all(|&v| (0..n as i64).contains(&v)) {
                        let q = node(a as usize, b as usize, e as usize);
                        column.extend((0..3).map(|d| 3 * q + d));
                    }
                }
            }
        }
        column.sort_unstable();
        let diagonal = column.len() as f64 + 1.0;
        for &i in &column {
            rows.push(i);
            // Off-diagonal −1 + 0.1·(component coupling): symmetric, since it depends on the
            // unordered pair of components only.
            let off = -1.0 + 0.1 * ((i % 3) + c) as f64;
            values.push(if i == j { diagonal } else { off });
        }
        col_ptr.push(rows.len());
    }
    let pattern = SymbolicSparseColMat::new_checked(dofs, dofs, col_ptr, None, rows);
    CscMatrix::from_values(Arc::new(pattern), values).expect("a valid pattern")
}

/// nnz(L) (lower triangle with diagonal) of faer's simplicial analysis on the same METIS
/// ordering: the factor's true nonzero count, computed from the elimination tree's column
/// counts, with no supernodes at all.
fn simplicial_nnz(matrix: &CscMatrix, dissection: NestedDissectionOptions) -> Result<usize> {
    let forward = nested_dissection_with(matrix.pattern(), dissection)?;
    let inverse = inverse_permutation(&forward)?;
    let perm = PermRef::new_checked(&forward, &inverse, matrix.dim());
    let params = CholeskySymbolicParams {
        supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SIMPLICIAL,
        ..Default::default()
    };
    let symbolic = factorize_symbolic_cholesky(
        SymbolicSparseColMat::as_ref(matrix.pattern()),
        Side::Lower,
        SymmetricOrdering::Custom(perm),
        params,
    )
    .map_err(|e| Error::Solver(format!("{e:?}")))?;
    Ok(symbolic.len_val())
}

#[test]
fn the_empty_relaxation_stores_exactly_the_simplicial_nonzeros() -> Result<()> {
    let a = grid(8);
    let metis = NestedDissectionOptions::default();
    let exact = SparseCholesky::analyze_tuned(&a, CholeskyOptions::default(), metis, &[])?;
    assert!(exact.is_supernodal(), "the test needs a supernodal factor");
    // Integer counts of the same structure: exact equality.
    assert_eq!(exact.factor_nnz_lower(), simplicial_nnz(&a, metis)?);
    // The default table pads with zeros: at least the exact count, and faer's stored length
    // adds the upper triangles of the diagonal blocks on top.
    let padded = SparseCholesky::analyze(&a)?;
    assert!(padded.factor_nnz_lower() >= exact.factor_nnz_lower());
    assert!(padded.factor_len() > padded.factor_nnz_lower());
    Ok(())
}

#[test]
fn every_setting_solves_the_same_system() -> Result<()> {
    let a = grid(7);
    let x_true: Vec<f64> = (0..a.dim()).map(|i| ((i * 37) % 11) as f64 - 5.0).collect();
    let b = a.mul(&x_true)?;
    let settings = [
        (NestedDissectionOptions::default(), DEFAULT_RELAXATION),
        (NestedDissectionOptions::default(), &[][..]),
        (
            NestedDissectionOptions {
                separators: Some(3),
                refinement_iterations: Some(20),
                imbalance: Some(30),
                pruning: Some(0),
                connected_components: Some(true),
                compress: Some(false),
            },
            &[(usize::MAX, 1.0)][..],
        ),
    ];
    for (dissection, relaxation) in settings {
        let mut solver =
            SparseCholesky::analyze_tuned(&a, CholeskyOptions::default(), dissection, relaxation)?;
        solver.factorize(&a)?;
        let mut x = b.clone();
        solver.solve_in_place(&mut x)?;
        let error = x
            .iter()
            .zip(&x_true)
            .fold(0.0f64, |m, (u, v)| m.max((u - v).abs()));
        // A diagonally dominant matrix (condition number ≲ 100) solved by a backward-stable
        // Cholesky: the error is a few hundred ulps of the unit-sized solution at most.
        assert!(
            error < 1e-12,
            "{dissection:?} {relaxation:?}: error {error:e}"
        );
    }
    Ok(())
}

#[test]
fn settings_out_of_range_are_refused_by_name() {
    let a = grid(3);
    let options = CholeskyOptions::default();
    let metis = NestedDissectionOptions::default();
    let message = |r: Result<SparseCholesky>| r.expect_err("must be refused").to_string();
    let bad_fraction = message(SparseCholesky::analyze_tuned(
        &a,
        options,
        metis,
        &[(4, 1.0), (16, 1.5)],
    ));
    assert!(bad_fraction.contains("relaxation[1].1"), "{bad_fraction}");
    let nan = message(SparseCholesky::analyze_tuned(
        &a,
        options,
        metis,
        &[(4, f64::NAN)],
    ));
    assert!(nan.contains("relaxation[0].1"), "{nan}");
    for (dissection, name) in [
        (
            NestedDissectionOptions {
                separators: Some(0),
                ..metis
            },
            "separators",
        ),
        (
            NestedDissectionOptions {
                refinement_iterations: Some(0),
                ..metis
            },
            "refinement_iterations",
        ),
        (
            NestedDissectionOptions {
                imbalance: Some(0),
                ..metis
            },
            "imbalance",
        ),
        (
            NestedDissectionOptions {
                pruning: Some(-1),
                ..metis
            },
            "pruning",
        ),
    ] {
        let text = message(SparseCholesky::analyze_tuned(
            &a,
            options,
            dissection,
            DEFAULT_RELAXATION,
        ));
        assert!(text.contains(name), "{text}");
    }
}
