//! Names given as strings in Python (axis, box split, method, model, mass, linear solver),
//! parsed with an `InvalidInputError` that lists the allowed names.

use pyo3::prelude::*;
use tetfem::analysis::dynamics::{MassKind, Method};
use tetfem::linalg::linear_solver::LinearMethod;
use tetfem::mesh::BoxSplit;
use tetfem::model::ModelKind;

use crate::errors::{OrRaise, invalid};

/// An axis: 0, 1, 2 or `"x"`, `"y"`, `"z"`.
pub fn axis(py: Python<'_>, value: &Bound<'_, PyAny>) -> PyResult<usize> {
    if let Ok(i) = value.extract::<i64>() {
        if (0..3).contains(&i) {
            return Ok(i as usize);
        }
        return Err(invalid(py, "axis", i, "must be 0, 1, 2 or 'x', 'y', 'z'"));
    }
    match value.extract::<String>().as_deref() {
        Ok("x") | Ok("X") => Ok(0),
        Ok("y") | Ok("Y") => Ok(1),
        Ok("z") | Ok("Z") => Ok(2),
        _ => Err(invalid(
            py,
            "axis",
            value.repr().map(|r| r.to_string()).unwrap_or_default(),
            "must be 0, 1, 2 or 'x', 'y', 'z'",
        )),
    }
}

/// Which axes of `"xyz"`-style text (any subset, e.g. `"xz"`).
pub fn axes(py: Python<'_>, text: &str) -> PyResult<[bool; 3]> {
    let mut axes = [false; 3];
    for c in text.chars() {
        match c.to_ascii_lowercase() {
            'x' => axes[0] = true,
            'y' => axes[1] = true,
            'z' => axes[2] = true,
            _ => {
                return Err(invalid(
                    py,
                    "axes",
                    format!("'{text}'"),
                    "must be letters among 'x', 'y', 'z' (e.g. 'xyz', 'z')",
                ));
            }
        }
    }
    if axes == [false; 3] {
        return Err(invalid(py, "axes", "''", "must name at least one axis"));
    }
    Ok(axes)
}

/// A box split: `"mirrored6"`, `"lecture6"` or `"five"`.
pub fn split(py: Python<'_>, name: &str) -> PyResult<BoxSplit> {
    match name {
        "mirrored6" => Ok(BoxSplit::Mirrored6),
        "lecture6" => Ok(BoxSplit::Lecture6),
        "five" => Ok(BoxSplit::Five),
        other => Err(invalid(
            py,
            "split",
            format!("'{other}'"),
            "must be 'mirrored6', 'lecture6' or 'five'",
        )),
    }
}

/// A time-stepping method: `"backward-euler"`, `"newmark"` or `"explicit"` (underscores work
/// too, as in scene files).
pub fn method(py: Python<'_>, name: &str) -> PyResult<Method> {
    name.replace('_', "-").parse::<Method>().or_raise(py)
}

/// A force model: `"linear"`, `"corotational"`, `"neo-hookean"` or `"st-venant-kirchhoff"`.
pub fn model(py: Python<'_>, name: &str) -> PyResult<ModelKind> {
    name.replace('_', "-").parse::<ModelKind>().or_raise(py)
}

/// The `model` argument of a solve: one model name for every material, or a list of names, one
/// per material of the run's material map (in its order: a `MaterialMap`'s materials), e.g. a
/// linear body beside a Neo-Hookean one.
#[derive(Debug, Clone, FromPyObject)]
pub enum ModelArg {
    /// One name for every material.
    One(String),
    /// A name per material.
    PerMaterial(Vec<String>),
}

impl Default for ModelArg {
    /// `"linear"`, every material.
    fn default() -> Self {
        ModelArg::One("linear".into())
    }
}

/// The models of `arg` as the library's definition takes them: the first material's kind (the
/// run's model) and, for a list, the kind of each material. An empty list or an unknown name
/// raises `InvalidInputError` naming it; a list of another length than the materials is the
/// library's error (`Definition`'s region models, naming both counts).
pub fn models(py: Python<'_>, arg: &ModelArg) -> PyResult<(ModelKind, Option<Vec<ModelKind>>)> {
    match arg {
        ModelArg::One(name) => Ok((model(py, name)?, None)),
        ModelArg::PerMaterial(names) => {
            let kinds = names
                .iter()
                .map(|n| model(py, n))
                .collect::<PyResult<Vec<_>>>()?;
            match kinds.first() {
                Some(&first) => Ok((first, Some(kinds))),
                None => Err(invalid(
                    py,
                    "model",
                    "[]",
                    "must be a model name or a list of them, one per material",
                )),
            }
        }
    }
}

/// A mass matrix kind: `"lumped"` or `"consistent"`.
pub fn mass(py: Python<'_>, name: &str) -> PyResult<MassKind> {
    match name {
        "lumped" => Ok(MassKind::Lumped),
        "consistent" => Ok(MassKind::Consistent),
        other => Err(invalid(
            py,
            "mass",
            format!("'{other}'"),
            "must be 'lumped' or 'consistent'",
        )),
    }
}

/// How linear systems are solved: `"auto"`, `"direct"` or `"iterative"`.
pub fn linear_solver(py: Python<'_>, name: &str) -> PyResult<LinearMethod> {
    match name {
        "auto" => Ok(LinearMethod::Auto),
        "direct" => Ok(LinearMethod::Direct),
        "iterative" => Ok(LinearMethod::Iterative),
        other => Err(invalid(
            py,
            "linear_solver",
            format!("'{other}'"),
            "must be 'auto', 'direct' or 'iterative'",
        )),
    }
}

/// A time step: seconds, or a multiple of the explicit critical step (the library's).
pub use tetfem::analysis::transient::TimeStep;

/// A time step given as a float (s) or as text `"<factor>crit"` (e.g. `"0.9crit"`).
pub fn time_step(py: Python<'_>, value: &Bound<'_, PyAny>) -> PyResult<TimeStep> {
    if let Ok(dt) = value.extract::<f64>() {
        return Ok(TimeStep::Seconds(dt));
    }
    let allowed =
        "must be seconds (a float) or a positive multiple of the critical step ('0.9crit')";
    let text: String = value.extract().map_err(|_| {
        invalid(
            py,
            "dt",
            value.repr().map(|r| r.to_string()).unwrap_or_default(),
            allowed,
        )
    })?;
    // The library's parser (a float in text is refused here: seconds come as a float).
    match text.parse::<TimeStep>() {
        Ok(step @ TimeStep::CriticalMultiple(_)) => Ok(step),
        _ => Err(invalid(py, "dt", format!("'{text}'"), allowed)),
    }
}
