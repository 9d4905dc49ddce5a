//! numpy arrays in and out: arguments are taken through `numpy.asarray` (so lists work too) and
//! checked for shape, dtype and finiteness with an `InvalidInputError` naming the argument;
//! results are handed out as numpy arrays that own the Rust vectors (no copy).

use nalgebra::Vector3;
use numpy::{PyArray1, PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;

use crate::errors::invalid;

/// The shape of `array` as text, e.g. `(4, 2)`.
fn shape_text(shape: &[usize]) -> String {
    match shape {
        [n] => format!("({n},)"),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// `numpy.asarray(value)` (any dtype), or an `InvalidInputError` naming `name`.
fn as_array<'py>(
    py: Python<'py>,
    value: &Bound<'py, PyAny>,
    name: &str,
) -> PyResult<Bound<'py, PyAny>> {
    py.import("numpy")?
        .call_method1("asarray", (value,))
        .map_err(|e| {
            invalid(
                py,
                name,
                value_text(value),
                &format!("must be an array of numbers ({e})"),
            )
        })
}

/// A short text of a Python value for messages (its `repr`, cut at 80 characters).
fn value_text(value: &Bound<'_, PyAny>) -> String {
    let text = value
        .repr()
        .map(|r| r.to_string())
        .unwrap_or_else(|_| "<unprintable>".into());
    match text.char_indices().nth(80) {
        Some((cut, _)) => format!("{}…", &text[..cut]),
        None => text,
    }
}

/// The numpy dtype kind of an array (`'f'`, `'i'`, `'u'`, `'b'`, ...).
fn dtype_kind(array: &Bound<'_, PyAny>) -> PyResult<String> {
    array.getattr("dtype")?.getattr("kind")?.extract()
}

/// A float array of `name` with `columns` columns (`None`: a 1-D array) in row-major order, and
/// its row count. Integer and boolean arrays are converted; every value must be finite unless
/// `allow_non_finite` (a mesh's points, whose check names the node in the library's message).
pub fn floats(
    py: Python<'_>,
    value: &Bound<'_, PyAny>,
    name: &str,
    columns: Option<usize>,
    allow_non_finite: bool,
) -> PyResult<(Vec<f64>, usize)> {
    let array = as_array(py, value, name)?;
    let kind = dtype_kind(&array)?;
    if !matches!(kind.as_str(), "f" | "i" | "u" | "b") {
        return Err(invalid(
            py,
            name,
            value_text(value),
            &format!("must hold real numbers (got dtype kind '{kind}')"),
        ));
    }
    let array = array.call_method1("astype", ("float64",))?;
    let array = array.cast::<PyArrayDyn<f64>>()?;
    let shape = array.shape().to_vec();
    let rows = match (columns, shape.as_slice()) {
        (None, [n]) => *n,
        (Some(c), [n, m]) if *m == c => *n,
        _ => {
            let wanted = match columns {
                None => "a 1-D array (n,)".to_string(),
                Some(c) => format!("a 2-D array of shape (n, {c})"),
            };
            return Err(invalid(
                py,
                &format!("{name}.shape"),
                shape_text(&shape),
                &format!("must be {wanted}"),
            ));
        }
    };
    let values: Vec<f64> = array.readonly().as_array().iter().copied().collect();
    if !allow_non_finite && let Some(i) = values.iter().position(|v| !v.is_finite()) {
        let width = columns.unwrap_or(1);
        return Err(invalid(
            py,
            &format!("{name}[{}]", index_text(i, width, columns.is_some())),
            values[i],
            "must be finite",
        ));
    }
    Ok((values, rows))
}

/// `i` of a flat row-major array of `width` columns as `row` or `row, column`.
fn index_text(i: usize, width: usize, two_d: bool) -> String {
    match two_d {
        true => format!("{}, {}", i / width, i % width),
        false => i.to_string(),
    }
}

/// An integer array of `name` (`columns` as in [`floats`]) as non-negative indices. Floats are
/// refused (a silently truncated index is a wrong node), and so are negative values.
pub fn indices(
    py: Python<'_>,
    value: &Bound<'_, PyAny>,
    name: &str,
    columns: Option<usize>,
) -> PyResult<(Vec<usize>, usize)> {
    let array = as_array(py, value, name)?;
    let kind = dtype_kind(&array)?;
    let size: usize = array.getattr("size")?.extract()?;
    // An empty list comes in as float64: it is an empty index list all the same.
    let integers = matches!(kind.as_str(), "i" | "u");
    let empty_list = size == 0 && kind == "f";
    if !(integers || empty_list) {
        return Err(invalid(
            py,
            name,
            value_text(value),
            &format!(
                "must hold integer indices (got dtype kind '{kind}'; a boolean mask goes to a *_where method)"
            ),
        ));
    }
    let array = array.call_method1("astype", ("int64",))?;
    let array = array.cast::<PyArrayDyn<i64>>()?;
    let shape = array.shape().to_vec();
    let rows = match (columns, shape.as_slice()) {
        (None, [n]) => *n,
        (Some(c), [n, m]) if *m == c => *n,
        (Some(_), [0]) => 0,
        _ => {
            let wanted = match columns {
                None => "a 1-D array (n,)".to_string(),
                Some(c) => format!("a 2-D array of shape (n, {c})"),
            };
            return Err(invalid(
                py,
                &format!("{name}.shape"),
                shape_text(&shape),
                &format!("must be {wanted}"),
            ));
        }
    };
    let raw: Vec<i64> = array.readonly().as_array().iter().copied().collect();
    let mut out = Vec::with_capacity(raw.len());
    for (i, &v) in raw.iter().enumerate() {
        match usize::try_from(v) {
            Ok(u) => out.push(u),
            Err(_) => {
                return Err(invalid(
                    py,
                    &format!(
                        "{name}[{}]",
                        index_text(i, columns.unwrap_or(1), columns.is_some())
                    ),
                    v,
                    "must be a non-negative index",
                ));
            }
        }
    }
    Ok((out, rows))
}

/// A boolean mask of `name` with exactly `len` entries.
pub fn mask(
    py: Python<'_>,
    value: &Bound<'_, PyAny>,
    name: &str,
    len: usize,
) -> PyResult<Vec<bool>> {
    let array = as_array(py, value, name)?;
    let kind = dtype_kind(&array)?;
    if kind != "b" {
        return Err(invalid(
            py,
            name,
            value_text(value),
            &format!("must be a boolean mask (got dtype kind '{kind}')"),
        ));
    }
    let array = array.cast::<PyArrayDyn<bool>>()?;
    let shape = array.shape().to_vec();
    if shape != [len] {
        return Err(invalid(
            py,
            &format!("{name}.shape"),
            shape_text(&shape),
            &format!("must be ({len},): one entry per item"),
        ));
    }
    Ok(array.readonly().as_array().iter().copied().collect())
}

/// A 3-vector of `name` (a sequence or array of three finite numbers).
pub fn vector3(py: Python<'_>, value: &Bound<'_, PyAny>, name: &str) -> PyResult<Vector3<f64>> {
    let (v, n) = floats(py, value, name, None, false)?;
    if n != 3 {
        return Err(invalid(
            py,
            &format!("{name}.shape"),
            format!("({n},)"),
            "must be three numbers (x, y, z)",
        ));
    }
    Ok(Vector3::new(v[0], v[1], v[2]))
}

/// Three integers of `name` (e.g. cell counts), each ≥ 1.
pub fn counts3(py: Python<'_>, value: &Bound<'_, PyAny>, name: &str) -> PyResult<[usize; 3]> {
    let (v, n) = indices(py, value, name, None)?;
    if n != 3 {
        return Err(invalid(
            py,
            &format!("{name}.shape"),
            format!("({n},)"),
            "must be three integers (x, y, z)",
        ));
    }
    Ok([v[0], v[1], v[2]])
}

/// A numpy array of shape (len/3, 3) that owns `values` (no copy).
pub fn rows3<'py>(py: Python<'py>, values: Vec<f64>) -> PyResult<Bound<'py, PyAny>> {
    let rows = values.len() / 3;
    Ok(PyArray1::from_vec(py, values)
        .reshape([rows, 3])?
        .into_any())
}

/// A 1-D numpy array that owns `values` (no copy).
pub fn vector<'py, T: numpy::Element>(py: Python<'py>, values: Vec<T>) -> Bound<'py, PyAny> {
    PyArray1::from_vec(py, values).into_any()
}

/// A 1-D int64 numpy array of indices.
pub fn index_vector<'py>(py: Python<'py>, values: &[usize]) -> Bound<'py, PyAny> {
    vector(py, values.iter().map(|&i| i as i64).collect::<Vec<i64>>())
}

/// An int64 numpy array of shape (len, width) from rows of indices.
pub fn index_rows<'py, const W: usize>(
    py: Python<'py>,
    rows: &[[usize; W]],
) -> PyResult<Bound<'py, PyAny>> {
    let flat: Vec<i64> = rows.iter().flatten().map(|&i| i as i64).collect();
    Ok(PyArray1::from_vec(py, flat)
        .reshape([rows.len(), W])?
        .into_any())
}

/// Three values per item for `count` items from `name`: shape (3,) (the same for every item)
/// or (count, 3) (one row per item), row-major.
pub fn rows_per_item(
    py: Python<'_>,
    value: &Bound<'_, PyAny>,
    name: &str,
    count: usize,
) -> PyResult<Vec<f64>> {
    let ndim: usize = as_array(py, value, name)?.getattr("ndim")?.extract()?;
    if ndim == 1 {
        let v = vector3(py, value, name)?;
        return Ok((0..count).flat_map(|_| [v.x, v.y, v.z]).collect());
    }
    let (values, rows) = floats(py, value, name, Some(3), false)?;
    if rows != count {
        return Err(invalid(
            py,
            &format!("{name}.shape"),
            format!("({rows}, 3)"),
            &format!("must be (3,) or ({count}, 3): one row per node"),
        ));
    }
    Ok(values)
}
