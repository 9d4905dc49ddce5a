//! `[analysis] accuracy = a` in a dynamic scene: tetfem chooses the element order, the cells
//! and the time steps so that the run's error stays within `a`, split evenly between space and
//! time (the errors of the two discretizations add, by the triangle inequality, so each gets
//! half):
//! - **space**: the accuracy search of a static scene ([`crate::accuracy`]) with target a/2, on
//!   the scene's static twin — the same mesh, material, model, supports and loads, solved for
//!   equilibrium. A body driven by its loads moves about that equilibrium, and its shape is
//!   what the mesh must resolve (the lowest modes a load excites look like its static
//!   deflection), so the twin's relative energy-norm error stands for the run's spatial error.
//!   A scene with no load (an initial velocity only) has no twin to estimate and is refused.
//! - **time**: the error-controlled stepping of `time_tolerance` ([`super::adaptive`]) at
//!   a/2: dt adapts so the run's own estimate of its relative trajectory error stays within it.
//!
//! The summary's `accuracy` reports both parts and their sum; each part's measure is the one its
//! estimator has (the energy norm of the twin, the trajectory's relative error), so the sum is
//! an estimate of the run's relative error, not a bound in one norm.

use super::DynamicSummary;
use crate::accuracy::{AccuracyReport, AccuracyTarget};
use crate::{Analysis, Scene};
use tetfem::base::error::{Error, Result};
use tetfem::post::output::write_atomically;

/// What `[analysis] accuracy` chose in a dynamic scene, and the run's estimates of its parts.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct DynamicAccuracy {
    /// The target relative error of the run (1).
    pub target: f64,
    /// The spatial half: the static twin's accuracy search at target a/2 (its trials, the order
    /// and cells chosen, its estimate).
    pub space: AccuracyReport,
    /// The temporal half: the time tolerance a/2 the steps were controlled to (1).
    pub time_tolerance: f64,
    /// The run's own estimate of its relative trajectory error (1).
    pub time_estimate: f64,
    /// `space.estimated_error + time_estimate` (1).
    pub estimated_error: f64,
    /// Whether each part met its half of the target.
    pub met: bool,
}

/// The scene with its accuracy's time share set: `time_tolerance` = a/2, the target the
/// adaptive stepping then controls (`None` without `accuracy`). Errors: `--resume`, which
/// counts in steps of a fixed dt (named at the accuracy key rather than the derived tolerance).
pub(super) fn with_time_share(scene: &Scene, resume: bool) -> Result<Option<Scene>> {
    let Some(target) = scene.accuracy() else {
        return Ok(None);
    };
    if resume {
        return Err(refusal(
            scene,
            "accuracy in a dynamic scene adapts dt, and a resumed run counts time in steps of \
             a fixed dt: run it from the start (without --resume)"
                .into(),
        ));
    }
    let mut timed = scene.clone();
    if let Some(analysis) = timed.spec.analysis.as_mut() {
        analysis.get_mut().time_tolerance = Some(0.5 * target.target);
    }
    Ok(Some(timed))
}

/// The space share: the static twin's accuracy search at a/2, and the scene on the order and
/// cells it chose (with `time_tolerance` already set by [`with_time_share`]). Runs the twin's
/// trials without writing files.
pub(super) fn choose_mesh(
    scene: &Scene,
    target: AccuracyTarget,
) -> Result<(Scene, AccuracyReport)> {
    let mut twin = scene.clone();
    twin.analysis = Analysis::Static;
    let space = AccuracyTarget {
        target: 0.5 * target.target,
        ..target
    };
    let (report, summary) =
        crate::accuracy::choose(&twin, space).map_err(|e| twin_error(scene, e))?;
    if !(report.estimated_error.is_finite() && summary.max_displacement > 0.0) {
        return Err(refusal(
            scene,
            "accuracy in a dynamic scene estimates the spatial error on the scene's static \
             equilibrium under its loads, and this scene's loads move nothing (give a load, \
             or choose the mesh yourself and set time_tolerance)"
                .into(),
        ));
    }
    let chosen = crate::accuracy::variant(scene, report.order, report.cells, scene.model());
    Ok((chosen, report))
}

/// Puts `space` and the run's time estimate into `summary`'s `accuracy` (and the search's
/// warnings into its warnings).
pub(super) fn report(scene: &Scene, summary: &mut DynamicSummary, space: AccuracyReport) {
    let target = scene.accuracy().map_or(f64::NAN, |t| t.target);
    let time_tolerance = 0.5 * target;
    let time_estimate = summary
        .time_stepping
        .as_ref()
        .map_or(f64::NAN, |t| t.estimated_error);
    summary
        .warnings
        .extend(crate::accuracy::warnings(scene, &space));
    // NaN (no estimate) is not within the share either.
    let time_met = time_estimate <= time_tolerance;
    if !time_met {
        summary.warnings.push(format!(
            "accuracy: the time error estimate {time_estimate:.3e} passes its share \
             {time_tolerance:.3e} of the target"
        ));
    }
    summary.accuracy = Some(DynamicAccuracy {
        target,
        met: space.met && time_met,
        estimated_error: space.estimated_error + time_estimate,
        space,
        time_tolerance,
        time_estimate,
    });
}

/// An error of the static twin's search, said as the dynamic scene's accuracy.
fn twin_error(scene: &Scene, error: Error) -> Error {
    refusal(
        scene,
        format!(
            "accuracy in a dynamic scene chooses the mesh on the scene's static equilibrium \
             under its loads, and that solve failed: {error}"
        ),
    )
}

/// An [`Error::Scene`] at the `analysis.accuracy` key.
fn refusal(scene: &Scene, message: String) -> Error {
    Error::Scene {
        source_name: scene.source_name().to_string(),
        key: "analysis.accuracy".into(),
        line: crate::restart::key_line(scene.text(), "analysis.accuracy").unwrap_or(0),
        message,
    }
}

/// Writes `summary` again over its `<stem>_summary.json` (if the run wrote one), now with its
/// `accuracy`.
pub(super) fn rewrite_summary(summary: &DynamicSummary) -> Result<()> {
    let json = summary
        .files
        .iter()
        .find(|f| f.to_string_lossy().ends_with("_summary.json"));
    match json {
        Some(json) => write_atomically(json, |w| writeln!(w, "{}", summary.to_json())),
        None => Ok(()),
    }
}
