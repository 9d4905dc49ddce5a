//! Running a static scene and writing its outputs.

use std::path::PathBuf;
use std::time::Instant;

use super::{BuiltScene, Scene, SceneElement};
use crate::png_frames::{StaticLook, static_picture};
use tetfem::analysis::{Static, StaticOptions, StaticOutcome};
use tetfem::base::error::Result;
use tetfem::model::ModelMap;
use tetfem::post::output::fields::{cell_model_von_mises, displacement_magnitude};
use tetfem::post::output::{
    CsvSeries, OriginalIds, OutputLock, PvdCollection, model_result_frame_arrays,
    result_frame_arrays, write_atomically,
};

/// Choices a caller (the command line) makes on top of the scene.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RunOptions {
    /// Render PNGs even if the scene does not ask for them (`--png`).
    pub force_png: bool,
    /// Write no files at all (tests, dry runs).
    pub no_files: bool,
}

/// The mean displacement of one probe, or its displacement and stress at its point.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ProbeValue {
    /// The probe's name.
    pub name: String,
    /// Mean displacement (m) of its nodes; for a point probe the displacement at the point.
    pub displacement: [f64; 3],
    /// A point probe's Cauchy stress at the point (Pa; XX, YY, ZZ, XY, YZ, XZ), from the
    /// shape functions of the tet holding it and the model that ran (absent for a node set).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stress_pa: Option<[f64; 6]>,
}

/// The reaction resultant of one `[[constraints]]` entry (static runs, and each step of dynamic
/// ones).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ReactionRow {
    /// The scene entry, `constraints[i]`.
    pub constraint: String,
    /// Σ of the reactions on its DOFs (N): what the support exerts on the body.
    pub force_n: [f64; 3],
    /// The point the moment is about (m): the entry's `moment_about`, default the origin.
    pub moment_point_m: [f64; 3],
    /// Their moment Σ (xᵢ − p) × Rᵢ about that point p, xᵢ the nodes' reference positions
    /// (N·m).
    pub moment_nm: [f64; 3],
}

/// Wall time (s) of each phase of a linear static solve, from
/// [`StaticTimings`](tetfem::analysis::statics::StaticTimings).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct SolvePhases {
    /// Pattern and scatter map.
    pub pattern: f64,
    /// Element stiffness and scatter into K.
    pub assembly: f64,
    /// Constraint check and extraction of K_ff.
    pub constraints: f64,
    /// Symbolic analysis, or the choice of the iterative method.
    pub symbolic: f64,
    /// Numeric factorization, or the preconditioner's setup.
    pub factorization: f64,
    /// Right-hand side, triangular solves and residual.
    pub solve: f64,
}

impl From<tetfem::analysis::statics::StaticTimings> for SolvePhases {
    fn from(t: tetfem::analysis::statics::StaticTimings) -> Self {
        SolvePhases {
            pattern: t.pattern.as_secs_f64(),
            assembly: t.assembly.as_secs_f64(),
            constraints: t.constraints.as_secs_f64(),
            symbolic: t.symbolic.as_secs_f64(),
            factorization: t.factorization.as_secs_f64(),
            solve: t.solve.as_secs_f64(),
        }
    }
}

/// The total contact force on one `[[obstacles]]` entry.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ContactForceRow {
    /// The obstacle's name.
    pub obstacle: String,
    /// The force the body exerts on it (N): the barrier's Σᵢ κ·Aᵢ·b′(dᵢ)·∇d plus, with
    /// friction, the friction force along it (Σ μ·λᵢ·f₁(yᵢ)·ûᵢ over its nodes). A body held by
    /// contact alone puts the applied load's resultant on its obstacles.
    pub force_n: [f64; 3],
}

/// What a run did, for printing or as one JSON object (`--json`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RunSummary {
    /// The scene's title.
    pub title: String,
    /// The scene file.
    pub scene: String,
    /// `"static"`.
    pub analysis: String,
    /// Node count.
    pub nodes: usize,
    /// Tet count.
    pub tets: usize,
    /// Free DOFs.
    pub free_dofs: usize,
    /// Largest nodal displacement magnitude (m).
    pub max_displacement: f64,
    /// Largest per-tet von Mises stress (Pa) of the Cauchy stress of the model that ran.
    pub max_von_mises: f64,
    /// Relative residual of the linear solve.
    pub relative_residual: f64,
    /// Mean displacement of each probe.
    pub probes: Vec<ProbeValue>,
    /// Resultant of all applied loads (N), gravity included.
    pub applied_load_n: [f64; 3],
    /// The reaction resultant of each `[[constraints]]` entry (K·u − f for the linear model,
    /// −(Σₑ fₑ(u) + f) for the nonlinear ones, on its DOFs; moments about its `moment_about`
    /// point from the nodes' reference positions). With the applied load they balance: Σ reactions + applied
    /// = 0 up to the solve's residual (a DOF in two entries counts in both).
    pub reactions: Option<Vec<ReactionRow>>,
    /// Wall time to build the mesh, constraints and loads (s).
    pub build_seconds: f64,
    /// Wall time to assemble, factor and solve (s).
    pub solve_seconds: f64,
    /// Wall time to write the outputs (s).
    pub output_seconds: f64,
    /// Wall time of each phase of the linear solve (`None` for the nonlinear models).
    pub phases: Option<SolvePhases>,
    /// The explicit critical step, with `[output] critical_step = true` (else `None`).
    pub critical_step: Option<super::CriticalStepReport>,
    /// Stored values of the Cholesky factor (0 for an iterative or a nonlinear solve).
    pub factor_len: usize,
    /// Files written.
    pub files: Vec<PathBuf>,
    /// Warnings about the mesh and the material (see [`tetfem::base::warning`]), as sentences.
    pub warnings: Vec<String>,
    /// The self-estimated relative energy-norm error of the solution (linear model; `None` for
    /// the nonlinear ones), with its definition.
    pub estimated_error: Option<super::EstimatedError>,
    /// The linear solution's largest element rotation and strain (`None` for the nonlinear
    /// models); past the measured threshold a warning names the model to use.
    pub deformation: Option<tetfem::post::adequacy::rotation::Deformation>,
    /// With `[analysis] accuracy`: the meshes tried, the order and cells chosen and why, the
    /// estimate reached and whether it meets the target (else `None`).
    pub accuracy: Option<super::AccuracyReport>,
    /// With `[[obstacles]]`: the total contact force on each (`None` without obstacles).
    pub contact_forces: Option<Vec<ContactForceRow>>,
    /// With `[[obstacles]]`: the barrier the solution ended under and by how much its gaps
    /// miss an exact contact's (`None` without obstacles).
    pub contact_barrier: Option<ContactBarrier>,
    /// With a nonlinear model or obstacles (Newton): the load steps and the Newton iterations
    /// they took in all (`None` for one linear solve).
    pub newton: Option<StaticNewton>,
}

/// The barrier a static contact solution ended under: its activation distance (m; the
/// scene's `[contact] activation_distance`, or the smaller one the library's continuation
/// reached) and the gap error Σλd/Σλ/max|u| (dimensionless: the force-weighted gap of the
/// pushed nodes over the largest displacement), with the tolerance it was driven to
/// (`[contact] gap_tolerance`).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ContactBarrier {
    /// d̂ at the solution (m).
    pub activation_distance_m: f64,
    /// Σλᵢdᵢ/Σλᵢ/max|u| at the solution.
    pub gap_error: f64,
    /// The gap error asked for.
    pub gap_tolerance: f64,
}

/// What a static Newton solve took: `load_steps` increments (`analysis.load_steps`), and
/// `iterations` Newton iterations in all, to the relative residual `tolerance`
/// (`analysis.newton_tolerance`).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct StaticNewton {
    /// The load increments.
    pub load_steps: usize,
    /// Newton iterations over all load steps.
    pub iterations: usize,
    /// Each load step's tolerance on ‖r_f‖/‖f_f‖.
    pub tolerance: f64,
}

impl RunSummary {
    /// The summary as one line of JSON, with a `units` table (the unit of every field that
    /// carries a quantity, keyed by its path).
    pub fn to_json(&self) -> String {
        match self.accuracy {
            None => super::units::to_json_with_units(self, super::units::STATIC),
            Some(_) => super::units::to_json_with_units(
                self,
                &[super::units::STATIC, super::units::ACCURACY].concat(),
            ),
        }
    }
}

/// [`run_static_with`] on the element of the scene's order, with the output lock (if any) held.
pub(super) fn run_static_on<E: SceneElement>(
    scene: &Scene,
    options: &RunOptions,
    lock: Option<OutputLock>,
) -> Result<RunSummary> {
    let clock = Instant::now();
    let built = scene.build_as::<E>()?;
    let build_seconds = clock.elapsed().as_secs_f64();
    let clock = Instant::now();
    // With obstacles every model (the linear one too) goes through the contact Newton solve:
    // the library's one dispatch (tetfem::analysis::Static) decides.
    let contact = match scene.has_obstacles() {
        true => scene.contact(&built.mesh, built.materials.stiffest_youngs_modulus())?,
        false => None,
    };
    let definition = scene.definition_of(&built, contact)?;
    let solver_options = StaticOptions {
        linear: tetfem::linalg::linear_solver::SolverOptions {
            method: scene.spec().linear_method(),
            ..Default::default()
        },
        newton: scene.static_newton(),
    };
    let analysis = Static::new(&definition, solver_options)?;
    let outcome = analysis.solve()?;
    // Gaps, pressures and forces under the barrier the solution is in equilibrium under.
    let contact = outcome.solved_contact(definition.contact.as_ref())?;
    let solved = StaticSolve::of(outcome, solver_options.newton.tolerance);
    // The model that runs is the model whose stress and energy are reported.
    let model = analysis.model();
    let contact = contact.as_ref();
    let solve_seconds = clock.elapsed().as_secs_f64();
    let StaticReport {
        mut summary,
        von_mises,
        indicators,
    } = report_static(
        scene,
        &built,
        model,
        &solved,
        contact,
        [build_seconds, solve_seconds],
        lock.as_ref().and_then(OutputLock::warning),
    )?;
    let u = &solved.displacement;
    if !options.no_files {
        let clock = Instant::now();
        let contact_fields = match contact {
            Some(c) => Some(c.node_fields(built.mesh.nodes(), u)?),
            None => None,
        };
        summary.files = write_static_outputs(
            scene,
            &built,
            model,
            u,
            contact_fields
                .as_ref()
                .map(|(gap, pressure)| tetfem::post::output::ContactFields { gap, pressure }),
            Some(&solved.reactions),
            indicators.as_deref(),
            &von_mises,
            options,
            &summary,
        )?;
        summary.output_seconds = clock.elapsed().as_secs_f64();
    }
    Ok(summary)
}

/// A static solution's summary, with the per-tet fields its outputs reuse: von Mises (Pa) and,
/// for the linear model, the error indicators η_K (J^½).
#[derive(Debug, Clone, PartialEq)]
pub struct StaticReport {
    /// The summary (no files yet, `output_seconds` 0).
    pub summary: RunSummary,
    /// Each tet's von Mises stress (Pa) of the model that ran.
    pub von_mises: Vec<f64>,
    /// Each tet's ZZ error indicator η_K (J^½; the linear model only).
    pub indicators: Option<Vec<f64>>,
}

/// The report of the static solution `solved` of `scene` (built as `built`, run with `model`
/// and the obstacles' `contact`): what `tetfem run` prints and writes, from the displacement
/// and the reactions alone, so that a solve elsewhere (the PETSc engine) reports alike.
/// `seconds`: the wall time (s) of the build and of the solve; `lock_warning`: the output
/// lock's, if any.
pub fn report_static<E: SceneElement>(
    scene: &Scene,
    built: &BuiltScene<E>,
    model: &ModelMap,
    solved: &StaticSolve,
    contact: Option<&tetfem::contact::Contact>,
    seconds: [f64; 2],
    lock_warning: Option<String>,
) -> Result<StaticReport> {
    let u = &solved.displacement;
    // The linear model's fields come straight from u: the force-model route forms x = X + u and
    // takes u = x − X back, which costs digits (~1e-11 relative in σ_vM on a steel beam).
    let linear = model.is_linear();
    let von_mises = match linear {
        true => tetfem::post::output::fields::cell_von_mises(&built.mesh, &built.materials, u)?,
        false => cell_model_von_mises(&built.mesh, model, u)?,
    };
    let (estimated_error, indicators) = match linear {
        true => super::estimated_error_of(&built.mesh, &built.materials, u)?,
        false => super::model_estimated_error_of(&built.mesh, model, u)?,
    };
    let (estimated_error, indicators) = (Some(estimated_error), Some(indicators));
    let deformation = match linear {
        true => {
            Some(tetfem::post::adequacy::rotation::largest_rotation_and_strain(&built.mesh, u)?)
        }
        false => None,
    };
    let magnitude = displacement_magnitude(u);
    let reactions = reaction_rows(built, &solved.reactions)?;
    let contact_forces = match contact {
        Some(contact) => Some(
            contact
                .obstacle_forces(u)?
                .iter()
                .zip(contact.obstacles())
                .enumerate()
                .map(|(o, (force, obstacle))| ContactForceRow {
                    obstacle: obstacle.name().to_string(),
                    force_n: (force + solved.friction_forces.get(o).copied().unwrap_or_default())
                        .into(),
                })
                .collect(),
        ),
        None => None,
    };
    let contact_barrier = match (contact, solved.barrier) {
        (Some(contact), Some((parameters, gap_error))) => Some(ContactBarrier {
            activation_distance_m: parameters.activation_distance,
            gap_error,
            gap_tolerance: contact.gap_tolerance(),
        }),
        _ => None,
    };
    let summary = RunSummary {
        contact_forces,
        contact_barrier,
        newton: solved.newton,
        warnings: built
            .warnings()
            .iter()
            .map(ToString::to_string)
            .chain(deformation.and_then(|d| d.warning()).map(|w| w.to_string()))
            .chain(lock_warning)
            .collect(),
        title: scene.title(),
        scene: scene.source_name().to_string(),
        analysis: "static".into(),
        nodes: built.mesh.node_count(),
        tets: built.mesh.tet_count(),
        free_dofs: solved.free_dofs,
        max_displacement: magnitude.iter().fold(0.0, |a: f64, &b| a.max(b)),
        max_von_mises: von_mises.iter().fold(0.0, |a: f64, &b| a.max(b)),
        relative_residual: solved.relative_residual,
        probes: probe_values(built, model, linear, u)?,
        applied_load_n: built.loads.resultant().into(),
        reactions: Some(reactions),
        build_seconds: seconds[0],
        solve_seconds: seconds[1],
        output_seconds: 0.0,
        phases: solved.phases,
        critical_step: match scene.output().critical_step {
            true => Some(super::critical_step_of(built)?),
            false => None,
        },
        factor_len: solved.factor_len,
        files: Vec::new(),
        estimated_error,
        deformation,
        accuracy: None,
    };
    Ok(StaticReport {
        summary,
        von_mises,
        indicators,
    })
}

/// The reaction resultant of each `[[constraints]]` entry of `built` from the nodal reactions
/// `reactions` (N, every DOF).
pub fn reaction_rows<E: SceneElement>(
    built: &BuiltScene<E>,
    reactions: &[f64],
) -> Result<Vec<ReactionRow>> {
    built
        .constraint_dofs
        .iter()
        .enumerate()
        .zip(&built.moment_points)
        .map(|((i, dofs), point)| {
            let (force, moment) = tetfem::analysis::statics::reaction_resultant(
                &built.mesh,
                reactions,
                dofs,
                *point,
            )?;
            Ok(ReactionRow {
                constraint: format!("constraints[{i}]"),
                force_n: force.into(),
                moment_point_m: (*point).into(),
                moment_nm: moment.into(),
            })
        })
        .collect()
}

/// What a static solve gives its report ([`report_static`]).
#[derive(Debug, Clone, PartialEq)]
pub struct StaticSolve {
    /// The displacement of every DOF (m; node-major).
    pub displacement: Vec<f64>,
    /// ‖r_f‖/‖f_f‖ at the solution.
    pub relative_residual: f64,
    /// The free DOF count.
    pub free_dofs: usize,
    /// The linear solve's phases (`None` for Newton).
    pub phases: Option<SolvePhases>,
    /// Stored values of the Cholesky factor (0 for an iterative or a Newton solve).
    pub factor_len: usize,
    /// Per obstacle the friction force the body exerts on it (N; empty without friction).
    pub friction_forces: Vec<nalgebra::Vector3<f64>>,
    /// With obstacles: the barrier's scales the solution is in equilibrium under (see
    /// [`StaticOutcome::contact_parameters`]) and its gap error.
    pub barrier: Option<(tetfem::contact::ContactParameters, f64)>,
    /// Newton's counts (`None` for one linear solve).
    pub newton: Option<StaticNewton>,
    /// The reaction of every DOF (N; K·u − f for the linear model, −(Σₑ fₑ(u) + f) for the
    /// nonlinear ones; zero on the free DOFs).
    pub reactions: Vec<f64>,
}

impl StaticSolve {
    /// What the report takes of the library's static `outcome`; `tolerance`: Newton's
    /// (`analysis.newton_tolerance`), reported with its counts.
    pub fn of(outcome: StaticOutcome, tolerance: f64) -> Self {
        StaticSolve {
            relative_residual: outcome.relative_residual,
            free_dofs: outcome.free_dofs,
            phases: outcome.timings().map(SolvePhases::from),
            factor_len: outcome.factor_len(),
            newton: outcome
                .newton_counts()
                .map(|(load_steps, iterations)| StaticNewton {
                    load_steps,
                    iterations,
                    tolerance,
                }),
            friction_forces: outcome.friction_forces,
            barrier: outcome.contact_parameters.zip(outcome.gap_error),
            displacement: outcome.displacement,
            reactions: outcome.reactions,
        }
    }
}

/// Each probe's value at the solution `u`: a point probe's stress is the linear model's with
/// each tet's material when `linear`, else `model`'s own.
fn probe_values<E: SceneElement>(
    built: &BuiltScene<E>,
    model: &ModelMap,
    linear: bool,
    u: &[f64],
) -> Result<Vec<ProbeValue>> {
    built
        .probes
        .iter()
        .map(|p| {
            let stress = match &p.point {
                None => None,
                Some(point) => {
                    let s = match linear {
                        true => point.location.stress(&built.mesh, &built.materials, u)?,
                        false => point.location.model_stress(&built.mesh, model, u)?,
                    };
                    Some(tetfem::post::output::fields::symmetric_components(&s))
                }
            };
            Ok(ProbeValue {
                name: p.name.clone(),
                displacement: p.displacement(u).into(),
                stress_pa: stress,
            })
        })
        .collect()
}

#[allow(clippy::too_many_arguments)]
fn write_static_outputs<E: SceneElement>(
    scene: &Scene,
    built: &BuiltScene<E>,
    model: &ModelMap,
    u: &[f64],
    contact: Option<tetfem::post::output::ContactFields<'_>>,
    reactions: Option<&[f64]>,
    error_indicator: Option<&[f64]>,
    von_mises: &[f64],
    options: &RunOptions,
    summary: &RunSummary,
) -> Result<Vec<PathBuf>> {
    let out = scene.output();
    let dir = &out.directory;
    let magnitude = &displacement_magnitude(u);
    let mut files = Vec::new();
    if out.vtu {
        let vtu = dir.join(format!("{}.vtu", out.stem));
        static_frame_arrays(scene, built, model, u, contact, reactions, error_indicator)?
            .writer(&built.mesh)?
            .write(&vtu)?;
        let mut pvd = PvdCollection::new(dir.join(format!("{}.pvd", out.stem)));
        pvd.push(0.0, &vtu)?;
        files.push(vtu);
        files.push(pvd.path().to_path_buf());
        // The obstacles' surfaces beside the body, for ParaView: where the solution has them,
        // moving ones at the end of the static step's pseudo-time (TimeValue t = 1), fixed ones
        // at rest (t = 0, as before obstacles could move here).
        if !scene.obstacles.is_empty() {
            let vtp = dir.join(format!("{}_obstacles.vtp", out.stem));
            let (center, tile) = super::obstacles::obstacle_tile(&built.mesh);
            let time = match scene.obstacles.iter().any(|o| o.motion().is_some()) {
                true => tetfem::bc::amplitude::STATIC_TIME,
                false => 0.0,
            };
            tetfem::post::output::write_obstacles_vtp(&vtp, &scene.obstacles, time, center, tile)?;
            files.push(vtp);
        }
    }
    if out.csv && !built.probes.is_empty() {
        let path = dir.join(format!("{}_probes.csv", out.stem));
        files.push(write_static_probe_csv(path, built, summary)?);
    }
    if out.png || options.force_png {
        let path = dir.join(format!("{}.png", out.stem));
        let look = StaticLook {
            title: &summary.title,
            magnitude,
            von_mises,
            path: &path,
        };
        files.push(static_picture(scene, &built.mesh, u, &look)?);
    }
    finish_with_summary(dir, &out.stem, summary, files)
}

/// Writes a static run's `<stem>_summary.json` into `dir` — `summary` listing every file of
/// the run, itself included — and returns `files` with it, the run's file list.
pub(crate) fn finish_with_summary(
    dir: &std::path::Path,
    stem: &str,
    summary: &RunSummary,
    mut files: Vec<PathBuf>,
) -> Result<Vec<PathBuf>> {
    let json = dir.join(format!("{stem}_summary.json"));
    let mut with_files = summary.clone();
    with_files.files = files.clone();
    with_files.files.push(json.clone());
    write_atomically(&json, |w| writeln!(w, "{}", with_files.to_json()))?;
    files.push(json);
    Ok(files)
}

/// The arrays of a static result's `.vtu` (see [`tetfem::post::output::FrameArrays`]): the fields
/// of the model that ran at the displacement `u` (m, every DOF), with the nodal `reactions`
/// (N), the stress tensors, the error indicators η_K (J^½), the mesh file's ids and, with
/// contact, its gap and pressure; in the scene's `output.vtu_format`.
pub fn static_frame_arrays<E: SceneElement>(
    scene: &Scene,
    built: &BuiltScene<E>,
    model: &ModelMap,
    u: &[f64],
    contact: Option<tetfem::post::output::ContactFields<'_>>,
    reactions: Option<&[f64]>,
    error_indicator: Option<&[f64]>,
) -> Result<tetfem::post::output::FrameArrays> {
    let extras = tetfem::post::output::FrameExtras {
        reactions,
        stress_tensors: true,
        original_ids: built.imported.as_ref().map(OriginalIds::of),
        error_indicator,
        format: scene.output().vtu_format.format(),
        contact,
        ..Default::default()
    };
    let mut arrays = match model.is_linear() {
        true => result_frame_arrays(&built.mesh, &built.materials, u, extras),
        // A nonlinear model's stresses and energy are its own.
        false => model_result_frame_arrays(&built.mesh, model, &built.materials, u, extras),
    }?;
    crate::bodies::add_body_id(&mut arrays, built.bodies.as_ref());
    Ok(arrays)
}

/// Writes a static run's probe CSV to `path`: one row at time 0 with each probe's displacement
/// (`<probe>_ux_m` …) and a point probe's stress (`<probe>_sxx_pa` …) from `summary`'s probes.
/// Returns `path`.
pub fn write_static_probe_csv<E: SceneElement>(
    path: PathBuf,
    built: &BuiltScene<E>,
    summary: &RunSummary,
) -> Result<PathBuf> {
    let mut columns = vec!["time_s".to_string()];
    for p in &built.probes {
        for c in ["ux", "uy", "uz"] {
            columns.push(format!("{}_{c}_m", p.name));
        }
        if p.point.is_some() {
            for c in super::build::STRESS_COLUMNS {
                columns.push(format!("{}_{c}_pa", p.name));
            }
        }
    }
    let mut csv = CsvSeries::new(path, columns)?;
    let mut row = vec![0.0];
    for p in &summary.probes {
        row.extend(p.displacement);
        row.extend(p.stress_pa.iter().flatten());
    }
    csv.push(&row)?;
    let path = csv.path().to_path_buf();
    csv.finish()?;
    Ok(path)
}
