//! Sparse matrices out to Python: SciPy CSR when SciPy is importable, else the plain
//! `(indptr, indices, data, shape)` tuple of numpy arrays.

use numpy::PyArray1;
use pyo3::prelude::*;
use tetfem::CscMatrix;

/// `matrix` as a `scipy.sparse.csr_matrix`, or `(indptr, indices, data, (n, n))` without
/// SciPy. tetfem's matrices are symmetric with both triangles stored, so the CSC arrays are
/// also the CSR arrays of the same matrix.
pub fn csr<'py>(py: Python<'py>, matrix: &CscMatrix) -> PyResult<Bound<'py, PyAny>> {
    let n = matrix.dim();
    let indptr: Vec<i64> = matrix.col_ptr().iter().map(|&i| i as i64).collect();
    let indices: Vec<i64> = matrix.row_idx().iter().map(|&i| i as i64).collect();
    let parts = (
        PyArray1::from_vec(py, indptr),
        PyArray1::from_vec(py, indices),
        PyArray1::from_vec(py, matrix.values().to_vec()),
    );
    match py.import("scipy.sparse") {
        Ok(scipy) => scipy.call_method1("csr_matrix", ((parts.2, parts.1, parts.0), (n, n))),
        Err(_) => Ok((parts.0, parts.1, parts.2, (n, n))
            .into_pyobject(py)?
            .into_any()),
    }
}

/// A diagonal matrix (a lumped mass) in the form of [`csr`].
pub fn diagonal<'py>(py: Python<'py>, values: &[f64]) -> PyResult<Bound<'py, PyAny>> {
    let n = values.len();
    let indptr: Vec<i64> = (0..=n as i64).collect();
    let indices: Vec<i64> = (0..n as i64).collect();
    let parts = (
        PyArray1::from_vec(py, indptr),
        PyArray1::from_vec(py, indices),
        PyArray1::from_vec(py, values.to_vec()),
    );
    match py.import("scipy.sparse") {
        Ok(scipy) => scipy.call_method1("csr_matrix", ((parts.2, parts.1, parts.0), (n, n))),
        Err(_) => Ok((parts.0, parts.1, parts.2, (n, n))
            .into_pyobject(py)?
            .into_any()),
    }
}
