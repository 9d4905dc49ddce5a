//! `tetfem.Amplitude`: the library's time functions a(t) (`tetfem::bc::amplitude::Amplitude`) for
//! loads and moving supports, and the `amplitude=` keyword every load and prescribed motion
//! takes (an `Amplitude`, a number, or a table of (t, a) pairs as an (k, 2) array).

use numpy::{PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use tetfem::bc::amplitude::Amplitude;

use crate::arrays;
use crate::errors::{OrRaise, invalid};

/// A dimensionless factor of time a(t) (t in s), with its rate ȧ (1/s) and acceleration ä
/// (1/s²): what a load or a prescribed displacement is multiplied by at time t. Static solves
/// take every amplitude at the pseudo-time t = ``STATIC_TIME`` = 1 (a ramp from 0 to 1 s is at
/// its full value there); a ``Simulation`` at each step's time from t = 0.
#[pyclass(name = "Amplitude", module = "tetfem", frozen)]
#[derive(Clone)]
pub struct PyAmplitude {
    /// The library's amplitude.
    pub amplitude: Amplitude,
}

/// `f(t)` of a number or an array of times: a float, or a float64 array of the same shape.
fn map_times<'py>(
    py: Python<'py>,
    times: &Bound<'py, PyAny>,
    f: impl Fn(f64) -> f64,
) -> PyResult<Bound<'py, PyAny>> {
    if let Ok(t) = times.extract::<f64>() {
        return Ok(f(t).into_pyobject(py)?.into_any());
    }
    let array = numpy_asarray(py, times)?;
    let array = array.cast::<PyArrayDyn<f64>>()?;
    let shape = array.shape().to_vec();
    let values: Vec<f64> = array.readonly().as_array().iter().map(|&t| f(t)).collect();
    Ok(numpy::PyArray1::from_vec(py, values)
        .reshape(shape)?
        .into_any())
}

/// `numpy.asarray(value, dtype=float64)`.
fn numpy_asarray<'py>(py: Python<'py>, value: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    let numpy = py.import("numpy")?;
    let kwargs = pyo3::types::PyDict::new(py);
    kwargs.set_item("dtype", "float64")?;
    numpy.getattr("asarray")?.call((value,), Some(&kwargs))
}

#[pymethods]
impl PyAmplitude {
    /// a(t) = ``value`` at all times.
    #[staticmethod]
    fn constant(py: Python<'_>, value: f64) -> PyResult<Self> {
        if !value.is_finite() {
            return Err(invalid(py, "value", value, "must be finite"));
        }
        Ok(PyAmplitude {
            amplitude: Amplitude::Constant(value),
        })
    }

    /// Tabulated points: ``points`` an (k, 2) array of (t, a) rows (times in s, strictly
    /// increasing), or ``points`` the times and ``values`` the values (both (k,)). Linear
    /// between points, constant beyond the ends.
    #[staticmethod]
    #[pyo3(signature = (points, values = None))]
    fn table(
        py: Python<'_>,
        points: &Bound<'_, PyAny>,
        values: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let (times, values) = match values {
            Some(values) => (
                arrays::floats(py, points, "times", None, false)?.0,
                arrays::floats(py, values, "values", None, false)?.0,
            ),
            None => {
                let (flat, _) = arrays::floats(py, points, "points", Some(2), false)?;
                flat.chunks(2).map(|p| (p[0], p[1])).unzip()
            }
        };
        Ok(PyAmplitude {
            amplitude: Amplitude::table(times, values).or_raise(py)?,
        })
    }

    /// 0 before ``start``, (t − start)/(end − start) between, 1 after (s).
    #[staticmethod]
    #[pyo3(signature = (start = 0.0, end = 1.0))]
    fn ramp(py: Python<'_>, start: f64, end: f64) -> PyResult<Self> {
        Ok(PyAmplitude {
            amplitude: Amplitude::ramp(start, end).or_raise(py)?,
        })
    }

    /// The quintic smooth step 10s³ − 15s⁴ + 6s⁵ of s = (t − start)/(end − start) clamped to
    /// [0, 1]: from 0 to 1 with zero rate and acceleration at both ends (s).
    #[staticmethod]
    #[pyo3(signature = (start = 0.0, end = 1.0))]
    fn smooth_step(py: Python<'_>, start: f64, end: f64) -> PyResult<Self> {
        Ok(PyAmplitude {
            amplitude: Amplitude::smooth_step(start, end).or_raise(py)?,
        })
    }

    /// A·sin(2π·f·(t − start) + φ) from ``start`` on, A·sin(φ) before: ``amplitude`` A
    /// (dimensionless), ``frequency`` f (Hz, ≥ 0), ``phase`` φ (rad), ``start`` (s).
    #[staticmethod]
    #[pyo3(signature = (amplitude, frequency, phase = 0.0, start = 0.0))]
    fn sine(
        py: Python<'_>,
        amplitude: f64,
        frequency: f64,
        phase: f64,
        start: f64,
    ) -> PyResult<Self> {
        Ok(PyAmplitude {
            amplitude: Amplitude::sine(amplitude, frequency, phase, start).or_raise(py)?,
        })
    }

    /// a(t) of a time (s) or an array of times (then an array of the same shape).
    fn value<'py>(&self, py: Python<'py>, t: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        map_times(py, t, |t| self.amplitude.value(t))
    }

    /// ȧ(t) (1/s) of a time or an array of times.
    fn rate<'py>(&self, py: Python<'py>, t: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        map_times(py, t, |t| self.amplitude.rate(t))
    }

    /// ä(t) (1/s²) of a time or an array of times.
    fn acceleration<'py>(
        &self,
        py: Python<'py>,
        t: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        map_times(py, t, |t| self.amplitude.acceleration(t))
    }

    /// Whether a(t) is the same at all times.
    #[getter]
    fn is_constant(&self) -> bool {
        self.amplitude.is_constant()
    }

    fn __repr__(&self) -> String {
        format!("Amplitude({:?})", self.amplitude)
    }
}

/// The amplitude of an `amplitude=` keyword: `None` (the default: constant 1, data without an
/// amplitude), an `Amplitude`, a number c (constant c) or an (k, 2) array of (t, a) pairs (a
/// table).
pub fn amplitude_of(py: Python<'_>, value: Option<&Bound<'_, PyAny>>) -> PyResult<Amplitude> {
    let Some(value) = value.filter(|v| !v.is_none()) else {
        return Ok(Amplitude::default());
    };
    if let Ok(a) = value.cast::<PyAmplitude>() {
        return Ok(a.get().amplitude.clone());
    }
    if let Ok(c) = value.extract::<f64>() {
        return Ok(PyAmplitude::constant(py, c)?.amplitude);
    }
    let (flat, _) = arrays::floats(py, value, "amplitude", Some(2), false)?;
    let (times, values) = flat.chunks(2).map(|p| (p[0], p[1])).unzip();
    Amplitude::table(times, values).or_raise(py)
}
