//! Running a dynamic problem — a dynamic scene, or the default cantilever released from its
//! loaded shape — and writing its outputs: `.vtu` frames with a `.pvd` collection, a CSV series
//! of probes, energies and wall time per step, PNG frames, and a JSON summary.

// Without the `png` feature the frames' code is a stand-in that refuses.
mod accuracy;
mod adaptive;
mod mixed;
#[cfg_attr(not(feature = "png"), path = "png_look_off.rs")]
mod png_look;
mod run_loop;
pub use accuracy::DynamicAccuracy;
use adaptive::FrameClock;
pub use adaptive::TimeStepping;
use png_look::{PngFrame, PngLook, dynamic_look};
use run_loop::run_dynamic_locked;

use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use nalgebra::Vector3;

use super::dynamic_contact::{ContactForceHistory, contact_of};
use super::obstacles::obstacle_tile;
use super::restart::{self, ProbeRange, Restart};
use super::{Analysis, BuiltScene, DynamicSettings, OutputSettings, Probe, Scene, SceneElement};
use tetfem::analysis::dynamics::{
    Energy, IntegratorOptions, InternalForce, LinearSystem, MassKind, Method, NewtonStats,
    NonlinearSolve, Rayleigh, State, StepNewtonOptions,
};
use tetfem::analysis::transient::AdaptiveStep;
pub use tetfem::analysis::transient::{MAX_STEPS, RunLength, TimeStep};
use tetfem::base::error::{Error, Result};
use tetfem::bc::constraints::Constraints;
use tetfem::bc::loads::Loads;
use tetfem::fe::element::{ElementType, Tet10};
use tetfem::fe::material::Material;
use tetfem::linalg::linear_solver::LinearMethod;
use tetfem::mesh::{CellType, Tet4, TetMesh};
use tetfem::post::output::{
    ContactFields, CsvSeries, CsvValue, FrameExtras, OriginalIds, OutputLock, PvdCollection,
    write_atomically, write_obstacles_vtp,
};
use tetfem_fixtures::cantilever::Cantilever;

/// A dynamic problem ready to integrate: the mesh (of 4-node tets by default, or 10-node ones),
/// the assembled system and the initial state.
#[derive(Debug, Clone)]
pub struct DynamicSetup<C: CellType = Tet4> {
    /// The mesh.
    pub mesh: TetMesh<C>,
    /// The material (the scene's default; see `materials` for each tet's).
    pub material: Material,
    /// The material of every tet.
    pub materials: tetfem::fe::materials::MaterialMap,
    /// M·ü + C·u̇ + K·u = f on the free DOFs.
    pub system: Arc<LinearSystem>,
    /// The state at time 0.
    pub initial: State,
    /// Node sets whose mean displacement goes into the CSV series.
    pub probes: Vec<Probe>,
    /// Wall time to assemble the system and the initial state (s).
    pub setup_seconds: f64,
    /// How the implicit methods solve their step systems: direct as built by
    /// [`from_scene`](Self::from_scene) and [`released_cantilever`](Self::released_cantilever)
    /// (the integrators' default); [`run_dynamic_scene`] sets the scene's
    /// `analysis.linear_solver` (auto when unset).
    pub linear_method: LinearMethod,
    /// How the implicit methods' Newton iterations solve with a nonlinear model:
    /// [`NonlinearSolve::default`] unless the scene sets `analysis.nonlinear_solver`.
    pub nonlinear_solve: NonlinearSolve,
    /// Those iterations' tolerance and budget: [`StepNewtonOptions::default`], the tolerance
    /// the scene's `analysis.newton_tolerance` and the contact nodes' relaxation its
    /// `analysis.relax_contact_nodes` where [`run_dynamic_scene`] sets them.
    pub newton: StepNewtonOptions,
    /// Warnings about the scene's own entries (a load acting on fixed DOFs only, no free DOF),
    /// reported with the mesh's and the material's in the run summary.
    pub input_warnings: Vec<tetfem::base::warning::Warning>,
    /// The elastic force law: linear as built; [`with_model`](Self::with_model) (which
    /// [`run_dynamic_scene`] calls with the scene's `analysis.model`) sets a nonlinear one.
    /// Energies, stresses and `.vtu` fields of the run are the model's.
    pub force: InternalForce,
    /// For a mesh read from a file: the file's (node ids, element ids), written into every
    /// frame as `original_node_id` / `original_element_id`.
    pub original_ids: Option<(Vec<u64>, Vec<u64>)>,
    /// The support reactions per node and per constraint set, reported at every step.
    pub reactions: super::DynamicReactions,
    /// The explicit critical step once computed.
    critical: std::sync::OnceLock<(f64, &'static str)>,
    /// The bodies and their surface barrier, with `[[bodies]]` or `[self_contact]`: per-body
    /// CSV columns and the `.vtu` cell field `body_id`.
    pub bodies: Option<crate::bodies::BuiltBodies>,
}

impl<E: SceneElement> DynamicSetup<E> {
    /// The system of a built scene with its dynamic settings and the linear model, without its
    /// obstacles: [`of_scene`](Self::of_scene) with those left out.
    pub fn from_scene(built: BuiltScene<E>, settings: &DynamicSettings) -> Result<Self> {
        let clock = Instant::now();
        let definition = built.definition(tetfem::model::ModelKind::Linear, None)?;
        Self::of_definition(built, &definition, settings, clock)
    }

    /// The setup of a dynamic scene as it runs: the problem of `built` with the scene's model
    /// and its obstacles' contact ([`BuiltScene::definition`]), assembled by the library's
    /// transient set-up ([`Definition::transient_system`], [`Definition::transient_force`]:
    /// gravity tracked apart, the other loads constant or following their amplitudes, Rayleigh
    /// damping and mass kind as set; with obstacles the body may be held by contact alone and
    /// every model, the linear one too, steps through Newton with the barrier), starting at
    /// rest in the reference configuration with the scene's initial velocity on every free DOF.
    ///
    /// What may be combined is the library's rule ([`Scene::combination`]), checked when the
    /// scene was parsed. Errors: those of the system and of the contact (a body starting inside
    /// an obstacle).
    ///
    /// [`Definition::transient_system`]: tetfem::analysis::Definition::transient_system
    /// [`Definition::transient_force`]: tetfem::analysis::Definition::transient_force
    pub fn of_scene(
        scene: &Scene,
        built: BuiltScene<E>,
        settings: &DynamicSettings,
    ) -> Result<Self> {
        let clock = Instant::now();
        let contact = match scene.has_obstacles() {
            true => Some(super::dynamic_contact::scene_contact(scene, &built)?),
            false => None,
        };
        let definition = scene.definition_of(&built, contact)?;
        Self::of_definition(built, &definition, settings, clock)
    }

    /// [`of_scene`](Self::of_scene) on the scene's `definition`; `clock` started with the setup.
    fn of_definition(
        built: BuiltScene<E>,
        definition: &tetfem::analysis::Definition<E>,
        settings: &DynamicSettings,
        clock: Instant,
    ) -> Result<Self> {
        let damping = Rayleigh::new(settings.damping.mass, settings.damping.stiffness)?;
        let system = definition.transient_system(settings.mass, damping)?;
        let mut initial = State::at_rest(system.free_count());
        // Each body's own velocity on top of the scene's (several bodies).
        let body_velocity = |dof: usize| {
            built
                .bodies
                .as_ref()
                .map_or(0.0, |b| b.velocities[b.body_of_node[dof / 3]][dof % 3])
        };
        let velocity: Vec<f64> = (0..built.mesh.dof_count())
            .map(|dof| settings.initial_velocity[dof % 3] + body_velocity(dof))
            .collect();
        initial.velocity = system.dofs().restrict(&velocity)?;
        let force = definition.transient_force(&system)?;
        let reactions = super::DynamicReactions::of_scene(&built, &system)?;
        let mut setup = Self::of_built(built, system, initial, reactions, clock)?;
        setup.force = force;
        Ok(setup)
    }

    /// The setup of a built scene with its assembled system and initial state; `clock` started
    /// with the setup. [`Error::Diverged`] at step 0 if the initial state's energy is not finite
    /// (an initial velocity of 1e300 m/s), before any frame is written.
    pub(super) fn of_built(
        built: BuiltScene<E>,
        system: LinearSystem,
        initial: State,
        reactions: super::DynamicReactions,
        clock: Instant,
    ) -> Result<Self> {
        system
            .energy(&initial)?
            .check_start(initial.steps, initial.time)?;
        Ok(DynamicSetup {
            bodies: built.bodies,
            original_ids: built.imported.map(|i| (i.node_ids, i.tet_ids)),
            input_warnings: built.input_warnings,
            mesh: built.mesh,
            material: built.material,
            materials: built.materials,
            system: Arc::new(system),
            initial,
            probes: built.probes,
            setup_seconds: clock.elapsed().as_secs_f64(),
            linear_method: LinearMethod::Direct,
            nonlinear_solve: NonlinearSolve::default(),
            newton: StepNewtonOptions::default(),
            force: InternalForce::default(),
            reactions,
            critical: Default::default(),
        })
    }

    /// A built scene released from rest in its static shape under all its loads, with every
    /// load but gravity removed: it swings about its gravity-only shape. Lumped mass, no
    /// damping; the scene's probes. A cantilever scene gives the problem of
    /// [`released_cantilever`](Self::released_cantilever).
    pub fn released(built: BuiltScene<E>) -> Result<Self> {
        let clock = Instant::now();
        let (initial, system) = released_system(
            &built.mesh,
            &built.materials,
            &built.constraints,
            &built.other_loads,
            built.gravity,
        )?;
        let reactions = super::DynamicReactions::of_sets(
            released_reactions(&system, &built.mesh, &built.materials, built.gravity)?,
            &built,
        );
        Self::of_built(built, system, initial, reactions, clock)
    }

    /// The same setup with the force model `kind`, one model per material of
    /// [`materials`](Self::materials) (on a copy of the mesh; the linear model gives
    /// [`InternalForce::Linear`], the fast path). Errors: those of
    /// [`InternalForce::of_models`].
    pub fn with_model(mut self, kind: tetfem::model::ModelKind) -> Result<Self> {
        self.force = InternalForce::of_kind(kind, &self.mesh, &self.materials, &self.system)?;
        Ok(self)
    }

    /// The model's von Mises stress per tet (Pa) at full displacement `u`.
    // Only the PNG frames colour by it; the .vtu frames write the stress tensor.
    #[cfg_attr(not(feature = "png"), allow(dead_code))]
    pub(crate) fn von_mises(&self, u: &[f64]) -> Result<Vec<f64>> {
        self.force.cell_von_mises(&self.mesh, &self.materials, u)
    }

    /// The period 2π/ω₁ (time units) of the lowest natural mode of the constrained body, from
    /// [`lowest_modes_with_force`](tetfem::analysis::modal::lowest_modes_with_force) with the setup's
    /// force: modal analysis is linear only, so after [`with_model`](Self::with_model) with a
    /// nonlinear model it is [`Error::InvalidParameter`] naming the model.
    pub fn first_mode_period(&self) -> Result<f64> {
        let modes = tetfem::analysis::modal::lowest_modes_with_force(&self.system, &self.force, 1)?;
        match modes.omega.first() {
            Some(&omega) if omega.is_finite() && omega > 0.0 => {
                Ok(2.0 * std::f64::consts::PI / omega)
            }
            _ => Err(Error::Solver("no positive lowest natural frequency".into())),
        }
    }

    /// The explicit critical step and how it was found: the library's one policy
    /// ([`critical_step`](tetfem::analysis::transient::critical_step): Lanczos iteration or
    /// Gershgorin's bound for a lumped mass, the element bound for a consistent one). Computed
    /// once, then remembered.
    pub fn critical_step(&self) -> Result<(f64, &'static str)> {
        if let Some(c) = self.critical.get() {
            return Ok(*c);
        }
        let limit =
            tetfem::analysis::transient::critical_step(&self.system, &self.mesh, &self.materials)?;
        Ok(*self.critical.get_or_init(|| (limit.dt, limit.source)))
    }

    /// A time step in time units: `dt` itself, or its multiple of [`critical_step`](Self::critical_step).
    pub fn resolve(&self, dt: TimeStep) -> Result<f64> {
        dt.seconds(|| Ok(self.critical_step()?.0))
    }
}

impl DynamicSetup {
    /// The cantilever released from rest in its static shape under end load and gravity, with
    /// the end load removed and gravity kept: it swings about its (much smaller) gravity-only
    /// deflection. Lumped mass, no damping. The probe `tip` is the end face x = L.
    pub fn released_cantilever(cantilever: &Cantilever) -> Result<Self> {
        let clock = Instant::now();
        let mesh = cantilever.mesh()?;
        let material = cantilever.material;
        let constraints: Constraints = cantilever.constraints(&mesh)?;
        let gravity = Vector3::new(0.0, 0.0, -cantilever.gravity);
        let end_load_only = Cantilever {
            gravity: 0.0,
            ..*cantilever
        }
        .loads(&mesh)?;
        let (initial, system) =
            released_system(&mesh, &material, &constraints, &end_load_only, gravity)?;
        let probes = vec![Probe {
            name: "tip".into(),
            nodes: cantilever.tip_nodes(&mesh),
            point: None,
        }];
        let reactions = super::DynamicReactions::single(
            released_reactions(&system, &mesh, &material, gravity)?,
            "clamp",
        );
        Ok(DynamicSetup {
            reactions,
            original_ids: None,
            input_warnings: Vec::new(),
            materials: tetfem::fe::materials::MaterialMap::uniform(material, mesh.tet_count()),
            mesh,
            material,
            system: Arc::new(system),
            initial,
            probes,
            setup_seconds: clock.elapsed().as_secs_f64(),
            linear_method: LinearMethod::Direct,
            nonlinear_solve: NonlinearSolve::default(),
            newton: StepNewtonOptions::default(),
            force: InternalForce::default(),
            critical: Default::default(),
            bodies: None,
        })
    }
}

/// What to run on a [`DynamicSetup`].
#[derive(Debug, Clone, PartialEq)]
pub struct DynamicRun {
    /// Title (PNG frames, summary).
    pub title: String,
    /// Where the problem came from (a scene path, or `default`).
    pub source: String,
    /// The method.
    pub method: Method,
    /// The time step.
    pub dt: TimeStep,
    /// How long.
    pub length: RunLength,
}

/// Energies of a state, as written to the summary.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct EnergyTerms {
    /// ½vᵀMv.
    pub kinetic: f64,
    /// ½uᵀKu.
    pub elastic: f64,
    /// −f_g·u.
    pub gravity_potential: f64,
    /// −f·u of the other loads.
    pub load_potential: f64,
    /// The sum.
    pub total: f64,
}

impl From<Energy> for EnergyTerms {
    fn from(e: Energy) -> Self {
        EnergyTerms {
            kinetic: e.kinetic,
            elastic: e.elastic,
            gravity_potential: e.gravity_potential,
            load_potential: e.load_potential,
            total: e.total(),
        }
    }
}

/// What a dynamic run did, for printing or as one JSON object (`--json`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct DynamicSummary {
    /// The title.
    pub title: String,
    /// The scene file (or `default`).
    pub scene: String,
    /// `"dynamic"`.
    pub analysis: String,
    /// The method's name.
    pub method: String,
    /// Node count.
    pub nodes: usize,
    /// Tet count.
    pub tets: usize,
    /// Free DOFs.
    pub free_dofs: usize,
    /// The time step (time units).
    pub dt: f64,
    /// The explicit method's critical step (time units).
    pub critical_step: f64,
    /// How it was found: `"Lanczos iteration"`, `"Gershgorin bound"` or `"element bound"`.
    pub critical_step_source: String,
    /// dt / critical_step.
    pub dt_over_critical: f64,
    /// Steps taken.
    pub steps: usize,
    /// Simulated time at the end.
    pub end_time: f64,
    /// Wall time of setup: assembly, initial state, critical step, integrator (s).
    pub setup_seconds: f64,
    /// Wall time of the first step (s): for implicit methods it includes the factorization.
    pub first_step_seconds: f64,
    /// Mean wall time of the steps after the first (s); the first's when there is one step.
    pub mean_step_seconds: f64,
    /// Wall time of all steps (s).
    pub step_seconds: f64,
    /// Wall time spent on outputs, energies and probes (s).
    pub output_seconds: f64,
    /// Energies at time 0.
    pub initial_energy: EnergyTerms,
    /// Energies at the end.
    pub final_energy: EnergyTerms,
    /// Each probe's last value and range.
    pub probes: Vec<ProbeRange>,
    /// The support reactions at the last step, per `[[constraints]]` entry (the default run:
    /// its clamp): r = M·a + C·v − f_int − f_ext summed over the entry's DOFs (N) and its moment
    /// about the entry's `moment_about` (N·m); see [`tetfem::analysis::dynamics::SupportReactions`].
    pub reactions: Vec<super::ReactionRow>,
    /// Frames written (`.vtu`).
    pub frames: usize,
    /// Files written.
    pub files: Vec<PathBuf>,
    /// The force model (`linear`, `corotational`, `neo-hookean`, `st-venant-kirchhoff`).
    pub model: String,
    /// Newton iterations of an implicit method with a nonlinear model (total, most in one
    /// step); `None` for the linear model and the explicit method.
    pub newton: Option<NewtonStats>,
    /// Warnings about the mesh and the material (see [`tetfem::base::warning`]), as sentences.
    pub warnings: Vec<String>,
    /// The self-estimated relative energy-norm error of the last state (the last frame), with
    /// its definition; `None` for a nonlinear model.
    pub estimated_error: Option<super::EstimatedError>,
    /// Wall time of that one estimate (s), to compare with `mean_step_seconds`: each `.vtu`
    /// frame of a linear run costs one such estimate for its `error_indicator`.
    pub estimate_seconds: f64,
    /// The last state's largest element rotation and strain (`None` for a nonlinear model);
    /// past the measured threshold a warning names the model to use.
    pub deformation: Option<tetfem::post::adequacy::rotation::Deformation>,
    /// Backward Euler with the linear model on at most [`STEP_CHECK_DOFS`] free DOFs: how dt
    /// resolves the lowest mode the load excites, and the method's decay per period there
    /// (a warning past [`DECAY_WARNING`](tetfem::post::adequacy::time_step::DECAY_WARNING)).
    pub step_resolution: Option<tetfem::post::adequacy::time_step::StepResolution>,
    /// The step of the checkpoint a resumed run continued from (`None`: a run from the
    /// start). `steps`, `frames`, the probes' ranges, the contact forces' peaks and the Newton
    /// counts are the whole run's.
    pub resumed_from_step: Option<usize>,
    /// With `[[obstacles]]`: per obstacle the force the body exerts on it at the last step
    /// (N) and the peak magnitude over the run with its time (s); `None` without obstacles.
    pub contact_forces: Option<Vec<super::ContactForceHistory>>,
    /// With `[[obstacles]]`: the barrier's activation distance and stiffness, its largest and
    /// last gap error over the accepted steps and the smallest gap over every step and Newton
    /// iterate (see [`DynamicContactBarrier`](super::DynamicContactBarrier)); `None` without
    /// obstacles.
    pub contact_barrier: Option<super::DynamicContactBarrier>,
    /// With `[analysis] time_tolerance`: the error-controlled run's own error estimate, its
    /// accepted and rejected steps and its smallest and largest step (then `dt` is the first
    /// step, `steps` the accepted ones); absent (`None`, and not in the JSON) otherwise.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub time_stepping: Option<TimeStepping>,
    /// With `[analysis] accuracy`: the order, cells and time tolerance chosen for the target,
    /// and the run's estimates of its spatial and temporal error (see [`DynamicAccuracy`]);
    /// absent (`None`, and not in the JSON) otherwise.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub accuracy: Option<DynamicAccuracy>,
    /// A mixed Neo-Hookean run: the largest |∫J dV/V₀ − 1| over its states (the volume the
    /// nearly incompressible body lost or gained); absent (`None`, and not in the JSON)
    /// otherwise.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub volume_change: Option<f64>,
}

/// Free DOFs up to which a backward-Euler run checks its step against the lowest excited mode
/// (a subspace modal solve of [`STEP_CHECK_MODES`] modes; beyond, the check is skipped).
pub const STEP_CHECK_DOFS: usize = 30_000;
/// Modes searched for the lowest excited one.
pub const STEP_CHECK_MODES: usize = 6;

impl DynamicSummary {
    /// The summary as one line of JSON, with a `units` table (the unit of every field that
    /// carries a quantity, keyed by its path).
    pub fn to_json(&self) -> String {
        match self.accuracy {
            None => super::units::to_json_with_units(self, super::units::DYNAMIC),
            Some(_) => super::units::to_json_with_units(
                self,
                &[super::units::DYNAMIC, super::units::DYNAMIC_ACCURACY].concat(),
            ),
        }
    }
}

/// Where and what to write; `None` in [`run_dynamic`] writes nothing.
#[derive(Debug, Clone, PartialEq)]
pub struct DynamicOutputs {
    /// The scene's output settings (folder, stem, which files, frame interval, PNG look).
    pub settings: OutputSettings,
    /// Render PNG frames even if the settings do not ask for them.
    pub force_png: bool,
}

/// Integrates `setup` as `run` says, calling `progress(steps_done, steps_total)` once when the
/// set-up is done and the stepping begins (`steps_done` = the step it starts from: 0, or the
/// checkpoint's on a resume) and after each step; when it returns `ControlFlow::Break` before
/// the last step the run stops there with [`Error::Interrupted`] (how the command-line tool
/// handles Ctrl-C).
///
/// Outputs (when `outputs` is given) go to the settings' folder: `<stem>_<step>.vtu` every
/// `every` steps and at the last step, with `<stem>.pvd` listing them and their times (rewritten
/// after every frame, so it is valid at any moment);
/// `<stem>.csv` with one row per step, the initial state included (time, step, wall time of
/// the step, each probe's mean displacement, each energy term and their total);
/// `<stem>_<step>.png` frames (fixed colour range and magnification across frames); and
/// `<stem>_summary.json`.
///
/// The CSV is streamed: its rows are appended as the run goes, written out at every frame
/// (before the frame, so that the rows of every frame listed in the `.pvd` are in the file,
/// whole), when its buffer fills, and on every stop; memory does not grow with the step count.
///
/// Writing files, the run first takes the folder's [`OutputLock`]: another run writing there is
/// an [`Error::OutputLocked`]; a lock left by a killed run is taken over, with a warning in the
/// summary, and its temporary files are removed.
///
/// Errors: invalid dt or length (more than [`MAX_STEPS`] steps: see [`RunLength::steps`]), and
/// [`Error::Diverged`] when the run blows up — the frames and the CSV rows up to that point are
/// written first.
pub fn run_dynamic<E: SceneElement>(
    setup: &DynamicSetup<E>,
    run: &DynamicRun,
    outputs: Option<&DynamicOutputs>,
    progress: &mut dyn FnMut(usize, usize) -> ControlFlow<()>,
) -> Result<DynamicSummary> {
    if let TimeStep::Seconds(dt) = run.dt {
        run.length.steps(dt)?;
    }
    let lock = match outputs {
        Some(o) => Some(OutputLock::acquire(&o.settings.directory)?),
        None => None,
    };
    run_dynamic_locked(setup, run, outputs, (lock, None), None, progress)
}

/// The [`Error::Interrupted`] of a run stopped at the boundary after `step` (at `time`, s), once
/// the CSV rows up to there are written out: every frame written so far is complete and listed
/// in the `.pvd` (rewritten after each frame).
fn interrupted(writer: &mut Option<FrameWriter>, step: usize, time: f64) -> Result<Error> {
    let frames = writer.as_ref().map_or(0, |w| w.frames);
    if let Some(w) = writer {
        w.finish_partial()?;
    }
    Ok(Error::Interrupted { step, time, frames })
}

/// Writes the frames and the series of a run as it goes.
struct FrameWriter {
    settings: OutputSettings,
    png: Option<PngLook>,
    title: String,
    frames: usize,
    pvd: Option<PvdCollection>,
    /// With obstacles and `.vtu` frames: `<stem>_obstacles.pvd`, listing a
    /// `<stem>_obstacles_<step>.vtp` of the obstacles' surfaces per frame.
    obstacle_pvd: Option<PvdCollection>,
    csv: Option<CsvSeries>,
    files: Vec<PathBuf>,
    digits: usize,
    /// The states' times and which are frames.
    clock: FrameClock,
}

/// The time of `state`, t = t₀ + (n − n₀)·dt from the run's first state (t₀, n₀) and its
/// fixed step dt (a scene's dt never changes during a run): one rounding, where the
/// integrators' running sum t += dt drifts (1000 steps of 0.1 sum to 99.9999999999986).
/// Written to the CSV, the `.pvd` and the frames' `TimeValue`.
fn step_time(start: (f64, usize), dt: f64, state: &State) -> f64 {
    start.0 + state.steps.saturating_sub(start.1) as f64 * dt
}

impl FrameWriter {
    fn new<E: SceneElement>(
        setup: &DynamicSetup<E>,
        run: &DynamicRun,
        outputs: &DynamicOutputs,
        steps: usize,
        clock: FrameClock,
        resumed_at: Option<usize>,
    ) -> Result<Self> {
        let s = &outputs.settings;
        // A resume runs at a fixed step (an error-controlled run is refused one).
        let dt = match clock {
            FrameClock::Steps { dt, .. } => dt,
            FrameClock::Landings { interval, .. } => interval,
        };
        std::fs::create_dir_all(&s.directory).map_err(|source| Error::Io {
            path: s.directory.clone(),
            source,
        })?;
        let csv = if s.csv {
            let mut columns = csv_columns(&setup.probes, setup.reactions.columns());
            if let Some(contact) = contact_of(&setup.force) {
                columns.extend(super::dynamic_contact::csv_columns(contact));
            }
            if let Some(bodies) = &setup.bodies {
                columns.extend(crate::bodies::csv_columns(bodies));
            }
            let path = s.directory.join(format!("{}.csv", s.stem));
            Some(match resumed_at {
                // The rows of steps 0..=k, one per step.
                Some(k) => CsvSeries::reopen(path, columns, k + 1)?,
                None => CsvSeries::new(path, columns)?,
            })
        } else {
            None
        };
        let png = if s.png || outputs.force_png {
            Some(dynamic_look(setup, s, &clock.frame_times(steps))?)
        } else {
            None
        };
        let start = (setup.initial.time, setup.initial.steps);
        let pvd_path = s.directory.join(format!("{}.pvd", s.stem));
        let pvd = match (s.vtu, resumed_at) {
            (false, _) => None,
            (true, None) => Some(PvdCollection::new(pvd_path)),
            // The frames up to the checkpoint, at its time only where its step is on the grid.
            // The run wrote a frame at each step of [start, k] on the frame interval.
            (true, Some(k)) => Some(restart::truncate_frames(
                &pvd_path,
                start.0 + k.saturating_sub(start.1) as f64 * dt,
                k.is_multiple_of(s.every),
                (k / s.every + 1).saturating_sub(start.1.div_ceil(s.every)),
            )?),
        };
        let obstacle_pvd_path = s.directory.join(format!("{}_obstacles.pvd", s.stem));
        let obstacle_pvd = match (s.vtu && contact_of(&setup.force).is_some(), resumed_at) {
            (false, _) => None,
            (true, None) => Some(PvdCollection::new(obstacle_pvd_path)),
            // The obstacles' frames up to the checkpoint, one per body frame.
            (true, Some(k)) => Some(restart::truncate_frames(
                &obstacle_pvd_path,
                start.0 + k.saturating_sub(start.1) as f64 * dt,
                k.is_multiple_of(s.every),
                pvd.as_ref().map_or(0, |p| p.frames().len()),
            )?),
        };
        let files: Vec<PathBuf> = pvd
            .iter()
            .chain(&obstacle_pvd)
            .flat_map(|p| p.frames())
            .map(|(_, f)| s.directory.join(f))
            .collect();
        Ok(FrameWriter {
            settings: s.clone(),
            png,
            title: run.title.clone(),
            frames: pvd.as_ref().map_or(0, |p| p.frames().len()),
            pvd,
            obstacle_pvd,
            csv,
            files,
            digits: steps.to_string().len().max(4),
            clock,
        })
    }

    #[allow(clippy::too_many_arguments)]
    fn record<E: SceneElement>(
        &mut self,
        setup: &DynamicSetup<E>,
        state: &State,
        u: &[f64],
        wall: f64,
        probes: &[[f64; 3]],
        energy: &Energy,
        reactions: &super::ReactionsAt,
        contact_forces: Option<&[Vector3<f64>]>,
        last: bool,
    ) -> Result<()> {
        let time = self.clock.time(state);
        if let Some(csv) = &mut self.csv {
            let row = csv_row(
                setup,
                state,
                (time, state.steps, wall),
                u,
                probes,
                energy,
                reactions,
                contact_forces,
            )?;
            csv.push_values(&row)?;
        }
        if !(self.clock.is_frame(state) || last) {
            return Ok(());
        }
        // The rows up to this frame go to disk before the frame is listed in the .pvd.
        if let Some(csv) = &mut self.csv {
            csv.write()?;
        }
        let name = format!(
            "{}_{:0w$}",
            self.settings.stem,
            state.steps,
            w = self.digits
        );
        let dir = self.settings.directory.clone();
        if let Some(pvd) = &mut self.pvd {
            let vtu = dir.join(format!("{name}.vtu"));
            write_frame_vtu(
                setup,
                state,
                u,
                time,
                reactions,
                self.settings.vtu_format.format(),
                &vtu,
            )?;
            pvd.push(time, &vtu)?;
            self.files.push(vtu);
        }
        if let (Some(pvd), Some(contact)) = (&mut self.obstacle_pvd, contact_of(&setup.force)) {
            let vtp = dir.join(format!(
                "{}_obstacles_{:0w$}.vtp",
                self.settings.stem,
                state.steps,
                w = self.digits
            ));
            let (center, tile) = obstacle_tile(&setup.mesh);
            write_obstacles_vtp(&vtp, contact.obstacles(), time, center, tile)?;
            pvd.push(time, &vtp)?;
            self.files.push(vtp);
        }
        if let Some(look) = &mut self.png {
            let frame = PngFrame {
                time,
                step: state.steps,
                title: &self.title,
                size: self.settings.png_size,
                path: &dir.join(format!("{name}.png")),
            };
            self.files.push(look.draw(setup, u, &frame)?);
        }
        self.frames += 1;
        Ok(())
    }

    /// Writes out the CSV rows so far (on a stop before the end: a divergence, an interrupt).
    fn finish_partial(&mut self) -> Result<()> {
        match &mut self.csv {
            Some(csv) => csv.write(),
            None => Ok(()),
        }
    }

    /// Writes out and syncs the CSV, and lists every file written.
    fn finish(self) -> Result<Vec<PathBuf>> {
        let mut files = self.files;
        for pvd in self.pvd.iter().chain(&self.obstacle_pvd) {
            pvd.write()?;
            files.push(pvd.path().to_path_buf());
        }
        if let Some(csv) = self.csv {
            files.push(csv.path().to_path_buf());
            csv.finish()?;
        }
        Ok(files)
    }
}

/// Overrides of a scene's dynamic settings (from the command line).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DynamicOverrides {
    /// Another method.
    pub method: Option<Method>,
    /// Another time step.
    pub dt: Option<TimeStep>,
    /// Another length (steps or duration).
    pub length: Option<RunLength>,
}

/// Builds and runs a dynamic scene (see [`run_dynamic`] for the outputs); `write_files: false`
/// writes no files.
pub fn run_dynamic_scene(
    scene: &Scene,
    overrides: &DynamicOverrides,
    write_files: bool,
    force_png: bool,
    progress: &mut dyn FnMut(usize, usize) -> ControlFlow<()>,
) -> Result<DynamicSummary> {
    run_dynamic_scene_as(scene, overrides, write_files, false, force_png, progress)
}

/// Resumes a dynamic scene from the checkpoint its last run left in its output folder
/// (`[output] checkpoint_every`, see [`checkpoint_path`](super::checkpoint_path)) and runs it
/// to its end, `analysis.duration` (or the overrides' length), counted from time 0: the
/// outputs end as those of one uninterrupted run, with the same bits (the CSV's wall-time
/// column aside). The CSV keeps its rows and the `.pvd` its frames up to the checkpoint.
///
/// Errors, before the system is built: no checkpoint (naming the path looked for), a damaged
/// one, a scene that differs from the checkpoint's in any key but [`RESUMABLE_KEYS`]
/// (naming the first such key and its line); then a mesh that differs, another method or dt
/// (through the overrides), or a checkpoint at or past the run's end (naming the length key).
///
/// [`RESUMABLE_KEYS`]: super::RESUMABLE_KEYS
pub fn resume_dynamic_scene(
    scene: &Scene,
    overrides: &DynamicOverrides,
    force_png: bool,
    progress: &mut dyn FnMut(usize, usize) -> ControlFlow<()>,
) -> Result<DynamicSummary> {
    run_dynamic_scene_as(scene, overrides, true, true, force_png, progress)
}

/// [`run_dynamic_scene`], or with `resume` [`resume_dynamic_scene`].
fn run_dynamic_scene_as(
    scene: &Scene,
    overrides: &DynamicOverrides,
    write_files: bool,
    resume: bool,
    force_png: bool,
    progress: &mut dyn FnMut(usize, usize) -> ControlFlow<()>,
) -> Result<DynamicSummary> {
    scene.require_tetfem_engine()?;
    let Analysis::Dynamic(settings) = scene.analysis() else {
        return Err(Error::Scene {
            source_name: scene.source_name().to_string(),
            key: "analysis.type".into(),
            line: 0,
            message: "this scene is static; run_dynamic_scene runs dynamic scenes only".into(),
        });
    };
    let length = overrides
        .length
        .unwrap_or(RunLength::Duration(settings.duration));
    let dt = overrides.dt.unwrap_or(TimeStep::Seconds(settings.dt));
    let timed = accuracy::with_time_share(scene, resume)?;
    let scene = timed.as_ref().unwrap_or(scene);
    // Before the expensive work: what cannot combine with an error-controlled step, the step
    // count when dt is known without the system, and the output folder's lock.
    let adaptive = adaptive::scene_control(scene, settings, overrides, resume)?;
    if let TimeStep::Seconds(dt) = dt {
        length.steps(dt)?;
    }
    let lock = match write_files {
        true => Some(OutputLock::acquire(&scene.output().directory)?),
        false => None,
    };
    if scene.formulation() == super::Formulation::Mixed && !resume {
        return mixed::run_mixed_dynamic(scene, settings, overrides, lock, progress);
    }
    let resume = match resume {
        true => Some(restart::checkpoint_for_resume(scene)?),
        false => None,
    };
    // With `accuracy`, the run on the order and cells its static twin's search chose.
    let chosen = match scene.accuracy() {
        Some(target) => Some(accuracy::choose_mesh(scene, target)?),
        None => None,
    };
    let run_scene = chosen.as_ref().map_or(scene, |(chosen, _)| chosen);
    let mut summary = match run_scene.order() {
        2 => run_dynamic_scene_on::<Tet10>(
            run_scene,
            settings,
            overrides,
            (dt, length, adaptive),
            (lock, resume),
            force_png,
            progress,
        ),
        _ => run_dynamic_scene_on::<Tet4>(
            run_scene,
            settings,
            overrides,
            (dt, length, adaptive),
            (lock, resume),
            force_png,
            progress,
        ),
    }?;
    if let Some((_, space)) = chosen {
        accuracy::report(scene, &mut summary, space);
        accuracy::rewrite_summary(&summary)?;
    }
    Ok(summary)
}

/// [`run_dynamic_scene`] on the element of the scene's order, with the output lock (if any)
/// held (`lock` is `None` when no files are written); `adaptive` the error control of
/// `time_tolerance`, if set.
fn run_dynamic_scene_on<E: SceneElement>(
    scene: &Scene,
    settings: &DynamicSettings,
    overrides: &DynamicOverrides,
    (dt, length, adaptive): (TimeStep, RunLength, Option<AdaptiveStep>),
    (lock, resume): (
        Option<OutputLock>,
        Option<tetfem::analysis::dynamics::Checkpoint>,
    ),
    force_png: bool,
    progress: &mut dyn FnMut(usize, usize) -> ControlFlow<()>,
) -> Result<DynamicSummary> {
    let write_files = lock.is_some();
    let method = overrides.method.unwrap_or(settings.method);
    let mut setup = DynamicSetup::of_scene(scene, scene.build_as::<E>()?, settings)?;
    setup.linear_method = scene.spec().linear_method();
    setup.nonlinear_solve = scene.spec().nonlinear_solve();
    setup.newton.tolerance = settings.newton_tolerance;
    setup.newton.relax_contact_nodes = settings.relax_contact_nodes;
    let restart = match write_files {
        true => Some(Restart::new(scene, &setup.mesh, resume)?),
        false => None,
    };
    if let Some(r) = &restart {
        let output = scene.output();
        let csv = output.directory.join(format!("{}.csv", output.stem));
        r.check_clock(
            setup.initial.time,
            setup.initial.steps,
            output.csv.then_some(csv.as_path()),
        )?;
    }
    if let Some(at) = restart.as_ref().and_then(Restart::resumed_at) {
        let steps = length.steps(setup.resolve(dt)?)?;
        restart::check_remaining(scene, at, steps, overrides.length.is_some())?;
    }
    let run = DynamicRun {
        title: scene.title(),
        source: scene.source_name().to_string(),
        method,
        dt,
        length,
    };
    let outputs = write_files.then(|| DynamicOutputs {
        settings: scene.output().clone(),
        force_png,
    });
    // The frames' interval, landed on exactly: `every` steps of the first dt.
    let adaptive = match adaptive {
        Some(mut control) => {
            let every = scene.output().every as f64;
            control.output_interval = Some(every * setup.resolve(dt)?);
            Some(control)
        }
        None => None,
    };
    run_dynamic_locked(
        &setup,
        &run,
        outputs.as_ref(),
        (lock, restart),
        adaptive,
        progress,
    )
}

/// The support reactions of a [`released_system`]: gravity its only load.
fn released_reactions<E: ElementType>(
    system: &LinearSystem,
    mesh: &TetMesh<E>,
    materials: &impl tetfem::fe::materials::TetMaterials,
    gravity: Vector3<f64>,
) -> Result<tetfem::analysis::dynamics::SupportReactions> {
    tetfem::analysis::dynamics::SupportReactions::new(
        system,
        mesh,
        materials,
        &Loads::new(mesh),
        gravity,
        &tetfem::analysis::dynamics::TimeData::default(),
    )
}

/// The state at rest in the static shape under `loads` and `gravity`, and the system with the
/// loads removed and gravity kept (lumped mass, no damping), which it swings in.
fn released_system<E: ElementType>(
    mesh: &TetMesh<E>,
    material: &impl tetfem::fe::materials::TetMaterials,
    constraints: &Constraints,
    loads: &Loads,
    gravity: Vector3<f64>,
) -> Result<(State, LinearSystem)> {
    let system = |loads: &Loads| {
        LinearSystem::new(
            mesh,
            material,
            constraints,
            loads,
            gravity,
            MassKind::Lumped,
            Rayleigh::default(),
        )
    };
    let initial = State::released_from(system(loads)?.static_displacement()?);
    Ok((initial, system(&Loads::new(mesh))?))
}

/// A point probe's Cauchy stress at its point (Pa; XX, YY, ZZ, XY, YZ, XZ) from the full
/// displacement `u`: the linear model's with the tet's material, or the run's force model's,
/// as the static summary reports it.
fn point_stress<E: SceneElement>(
    setup: &DynamicSetup<E>,
    point: &super::PointProbe,
    u: &[f64],
) -> Result<[f64; 6]> {
    let s = setup
        .force
        .point_stress(&point.location, &setup.mesh, &setup.materials, u)?;
    Ok(tetfem::post::output::fields::symmetric_components(&s))
}

/// The columns of a dynamic run's CSV before the contact's: `time_s`, `step`,
/// `wall_seconds_per_step`, each probe's displacement (`<probe>_ux_m` …) and a point probe's
/// stress (`<probe>_sxx_pa` …), the energies (`kinetic_J`, `elastic_J`, `gravity_potential_J`,
/// `load_potential_J`, `total_J`) and `reactions` ([`DynamicReactions::columns`](super::DynamicReactions::columns)).
pub fn csv_columns(probes: &[super::Probe], reactions: Vec<String>) -> Vec<String> {
    let mut columns: Vec<String> = vec![
        "time_s".into(),
        "step".into(),
        "wall_seconds_per_step".into(),
    ];
    for p in probes {
        for c in ["ux", "uy", "uz"] {
            columns.push(format!("{}_{c}_m", p.name));
        }
        if p.point.is_some() {
            for c in super::build::STRESS_COLUMNS {
                columns.push(format!("{}_{c}_pa", p.name));
            }
        }
    }
    for e in [
        "kinetic",
        "elastic",
        "gravity_potential",
        "load_potential",
        "total",
    ] {
        columns.push(format!("{e}_J"));
    }
    columns.extend(reactions);
    columns
}

/// One CSV row of a dynamic run at `(time, step, wall seconds per step)`: the probes (a point
/// probe's stress after its displacement), the energies, the reactions and, with contact, the
/// obstacles' columns; in the order of the header `FrameWriter::new` writes.
#[allow(clippy::too_many_arguments)]
fn csv_row<E: SceneElement>(
    setup: &DynamicSetup<E>,
    state: &State,
    (time, step, wall): (f64, usize, f64),
    u: &[f64],
    probes: &[[f64; 3]],
    energy: &Energy,
    reactions: &super::ReactionsAt,
    contact_forces: Option<&[Vector3<f64>]>,
) -> Result<Vec<CsvValue>> {
    let mut row: Vec<CsvValue> = vec![time.into(), step.into(), wall.into()];
    for (probe, value) in setup.probes.iter().zip(probes) {
        row.extend(value.iter().map(|&v| CsvValue::Real(v)));
        if let Some(point) = &probe.point {
            row.extend(point_stress(setup, point, u)?.map(CsvValue::Real));
        }
    }
    row.extend(
        [
            energy.kinetic,
            energy.elastic,
            energy.gravity_potential,
            energy.load_potential,
            energy.total(),
        ]
        .map(CsvValue::Real),
    );
    row.extend(reactions.csv_values().map(CsvValue::Real));
    if let (Some(contact), Some(forces)) = (contact_of(&setup.force), contact_forces) {
        let values = super::dynamic_contact::csv_values(contact, u, time, forces)?;
        row.extend(values.into_iter().map(CsvValue::Real));
    }
    if let Some(bodies) = &setup.bodies {
        let values = crate::bodies::csv_values(&setup.system, &setup.force, bodies, state, u)?;
        row.extend(values.into_iter().map(CsvValue::Real));
    }
    Ok(row)
}

/// Writes the `.vtu` frame of `state` (full displacement `u`, at `time`) to `path`: velocity,
/// reactions, contact fields, stresses and, for the linear model, the error indicator; the
/// model's own stresses for a nonlinear one.
fn write_frame_vtu<E: SceneElement>(
    setup: &DynamicSetup<E>,
    state: &State,
    u: &[f64],
    time: f64,
    reactions: &super::ReactionsAt,
    format: tetfem::post::output::VtuFormat,
    path: &Path,
) -> Result<()> {
    let mut velocity = vec![0.0; u.len()];
    for (&dof, v) in setup.system.dofs().free_dofs().iter().zip(&state.velocity) {
        velocity[dof] = *v;
    }
    let contact_fields = match contact_of(&setup.force) {
        Some(c) => Some(super::dynamic_contact::node_fields(
            c,
            setup.mesh.nodes(),
            u,
            time,
        )?),
        None => None,
    };
    let extras = FrameExtras {
        contact: contact_fields
            .as_ref()
            .map(|(gap, pressure)| ContactFields { gap, pressure }),
        velocity: Some(&velocity),
        reactions: Some(&reactions.nodal),
        time: Some(time),
        format,
        original_ids: setup
            .original_ids
            .as_ref()
            .map(|(nodes, elements)| OriginalIds { nodes, elements }),
        ..FrameExtras::default()
    };
    let mut arrays = frame_arrays(&setup.mesh, &setup.materials, &setup.force, u, extras)?;
    crate::bodies::add_body_id(&mut arrays, setup.bodies.as_ref());
    arrays.writer(&setup.mesh)?.write(path)?;
    Ok(())
}

/// The arrays of a dynamic run's `.vtu` frame at the full displacement `u`: `extras` (velocity,
/// reactions, time, ids, contact, encoding) with the stress tensors and the error indicators
/// η_K of `u` (J^½; a nonlinear force's on its S); a nonlinear force's own stresses and energy.
pub fn frame_arrays<E: SceneElement>(
    mesh: &TetMesh<E>,
    materials: &tetfem::fe::materials::MaterialMap,
    force: &InternalForce,
    u: &[f64],
    extras: FrameExtras<'_>,
) -> Result<tetfem::post::output::FrameArrays> {
    let estimate = force.estimated_error(mesh, materials, u)?;
    let extras = FrameExtras {
        stress_tensors: true,
        error_indicator: Some(estimate.indicators.as_slice()),
        ..extras
    };
    force.result_frame_arrays(mesh, materials, u, extras)
}
