//! Convergence studies: run a problem family over refinements (of the mesh or the time step),
//! collect (h, DOFs, error, wall time), compute observed orders, fit a rate, and
//! Richardson-extrapolate a quantity when no exact answer exists.
//!
//! ```
//! use tetfem::post::convergence::{Level, Study};
//! // Errors of a second-order method at h = 1/4, 1/8, 1/16:
//! let study = Study::new(vec![
//!     Level { h: 0.25, dofs: 375, error: 0.0625, seconds: 0.01 },
//!     Level { h: 0.125, dofs: 2187, error: 0.015625, seconds: 0.05 },
//!     Level { h: 0.0625, dofs: 14739, error: 0.00390625, seconds: 0.4 },
//! ])?;
//! assert!((study.fitted_order()? - 2.0).abs() < 1e-12);
//! # Ok::<(), tetfem::Error>(())
//! ```

use std::time::Instant;

use crate::base::error::{Error, Result};

/// One refinement level: the size parameter (mesh size or time step), the problem size, the
/// error (in whatever norm the study uses) and the wall time it took.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Level {
    /// Mesh size or time step (> 0).
    pub h: f64,
    /// Degrees of freedom.
    pub dofs: usize,
    /// Error at this level (≥ 0; NaN when unknown).
    pub error: f64,
    /// Wall time of the solve, in seconds.
    pub seconds: f64,
}

/// Levels ordered from coarse to fine, with rates computed from them.
#[derive(Debug, Clone, PartialEq)]
pub struct Study {
    /// The levels, coarse to fine.
    pub levels: Vec<Level>,
}

impl Study {
    /// Wraps measured levels; they must have distinct positive h.
    pub fn new(mut levels: Vec<Level>) -> Result<Self> {
        if let Some(bad) = levels.iter().find(|l| !(l.h.is_finite() && l.h > 0.0)) {
            return Err(Error::invalid_parameter(
                "h",
                bad.h,
                "every level needs a finite h > 0",
            ));
        }
        levels.sort_by(|a, b| b.h.total_cmp(&a.h));
        if levels.windows(2).any(|w| w[0].h == w[1].h) {
            return Err(Error::invalid_parameter(
                "h",
                "a repeated value",
                "levels need distinct h",
            ));
        }
        Ok(Study { levels })
    }

    /// Runs `solve` on each parameter, timing it. `solve` returns (h, DOFs, error).
    pub fn run<P>(
        parameters: impl IntoIterator<Item = P>,
        mut solve: impl FnMut(P) -> Result<(f64, usize, f64)>,
    ) -> Result<Self> {
        let mut levels = Vec::new();
        for p in parameters {
            let clock = Instant::now();
            let (h, dofs, error) = solve(p)?;
            levels.push(Level {
                h,
                dofs,
                error,
                seconds: clock.elapsed().as_secs_f64(),
            });
        }
        Study::new(levels)
    }

    /// Observed order between consecutive levels, ln(e₁/e₂)/ln(h₁/h₂).
    pub fn observed_orders(&self) -> Vec<f64> {
        self.levels
            .windows(2)
            .map(|w| (w[0].error / w[1].error).ln() / (w[0].h / w[1].h).ln())
            .collect()
    }

    /// Least-squares slope of ln(error) against ln(h) over all levels: the fitted order p in
    /// error ≈ C·hᵖ. Needs at least two levels with positive, finite errors.
    pub fn fitted_order(&self) -> Result<f64> {
        fit_slope(self.levels.iter().map(|l| (l.h, l.error)))
    }
}

/// Least-squares slope of ln(y) against ln(x) over the points with positive, finite coordinates.
pub fn fit_slope(points: impl IntoIterator<Item = (f64, f64)>) -> Result<f64> {
    let logs: Vec<(f64, f64)> = points
        .into_iter()
        .filter(|(x, y)| x.is_finite() && y.is_finite() && *x > 0.0 && *y > 0.0)
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    if logs.len() < 2 {
        return Err(Error::invalid_parameter(
            "levels",
            logs.len(),
            "a fit needs at least two levels with positive, finite h and error",
        ));
    }
    let n = logs.len() as f64;
    let mx = logs.iter().map(|p| p.0).sum::<f64>() / n;
    let my = logs.iter().map(|p| p.1).sum::<f64>() / n;
    let sxy: f64 = logs.iter().map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = logs.iter().map(|(x, _)| (x - mx) * (x - mx)).sum();
    Ok(sxy / sxx)
}

/// A Richardson extrapolation from three levels with a constant refinement ratio.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Richardson {
    /// The extrapolated value (the estimate of the converged answer).
    pub value: f64,
    /// The observed order p = ln((q₁ − q₂)/(q₂ − q₃)) / ln(r).
    pub order: f64,
}

/// Richardson extrapolation of a quantity q computed at sizes h, h/r, h/r² (`coarse`, `medium`,
/// `fine`): observed order p from the three values, then q_fine + (q_fine − q_medium)/(rᵖ − 1).
/// Errors if the differences do not shrink monotonically (no asymptotic range).
pub fn richardson(coarse: f64, medium: f64, fine: f64, ratio: f64) -> Result<Richardson> {
    let (d1, d2) = (medium - coarse, fine - medium);
    if !(ratio > 1.0 && d1 != 0.0 && d2 != 0.0 && d1.signum() == d2.signum() && d2.abs() < d1.abs())
    {
        return Err(Error::invalid_parameter(
            "Richardson levels",
            format!("{coarse}, {medium}, {fine} (ratio {ratio})"),
            "need monotone, shrinking differences and a ratio > 1",
        ));
    }
    let order = (d1 / d2).ln() / ratio.ln();
    Ok(Richardson {
        value: fine + d2 / (ratio.powf(order) - 1.0),
        order,
    })
}
