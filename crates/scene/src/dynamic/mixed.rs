//! The mixed formulation's dynamic scenes: `formulation = "mixed"` with `type = "dynamic"`
//! (backward Euler or Newmark, the linear model, the consistent mass, on 4-node tets with the
//! stabilized P1–P1 element or on 10-node tets with Taylor–Hood P2–P1; the Neo-Hookean and
//! corotational models in backward Euler, with obstacles, are [`hyperelastic`]'s). The
//! library computes ([`mixed_transient_model`]); this file reads the scene's keys, steps, and
//! writes what a user opens: `<stem>.pvd` with a `.vtu` per frame (point fields
//! `displacement`, m, and `pressure`, Pa), `<stem>.csv` (time, energies, pressure range, each
//! probe's mean displacement) and `<stem>_summary.json`.

use std::ops::ControlFlow;
use std::path::PathBuf;
use std::time::Instant;

use tetfem::Loads;
use tetfem::analysis::dynamics::Rayleigh;
use tetfem::analysis::mixed_analysis::{MixedStaticElement, mixed_transient_model};
use tetfem::analysis::mixed_dynamics::MixedTransient;
use tetfem::analysis::transient::{RunLength, TimeStep};
use tetfem::base::error::{Error, Result};
use tetfem::fe::element::{Tet4, Tet10};
use tetfem::mesh::CellType;
use tetfem::post::output::{OutputLock, PvdCollection, VtuWriter, write_atomically};

use super::{DynamicOverrides, DynamicSummary, EnergyTerms};

mod hyperelastic;
use crate::mixed_dynamics::mixed_warnings;
use crate::{DynamicSettings, ProbeRange, Scene, SceneElement};

/// A mixed dynamic scene (see the [module](self) docs): from rest in the undeformed state (with
/// `initial_velocity` on the free DOFs), constant loads and gravity, `overrides` of the
/// method, dt (in seconds) and length; `progress(step, steps)` after each step may stop the
/// run ([`Error::Interrupted`]).
pub(crate) fn run_mixed_dynamic(
    scene: &Scene,
    settings: &DynamicSettings,
    overrides: &DynamicOverrides,
    lock: Option<OutputLock>,
    progress: &mut dyn FnMut(usize, usize) -> ControlFlow<()>,
) -> Result<DynamicSummary> {
    if matches!(
        scene.model(),
        tetfem::model::ModelKind::NeoHookean | tetfem::model::ModelKind::Corotational
    ) {
        return hyperelastic::run_mixed_hyperelastic(scene, settings, overrides, lock, progress);
    }
    if scene.order() == 1 {
        run_linear::<Tet4>(scene, settings, overrides, lock, progress)
    } else {
        run_linear::<Tet10>(scene, settings, overrides, lock, progress)
    }
}

/// The linear model's run of [`run_mixed_dynamic`] on element `E` (4-node stabilized P1–P1 or
/// 10-node Taylor–Hood).
fn run_linear<E: SceneElement + MixedStaticElement>(
    scene: &Scene,
    settings: &DynamicSettings,
    overrides: &DynamicOverrides,
    lock: Option<OutputLock>,
    progress: &mut dyn FnMut(usize, usize) -> ControlFlow<()>,
) -> Result<DynamicSummary> {
    let method = overrides.method.unwrap_or(settings.method);
    let (dt, steps) = step_and_count(overrides, settings)?;
    let clock = Instant::now();
    let built = scene.build_as::<E>()?;
    let mesh = &built.mesh;
    let (gravity, loads) = gravity_and_loads(&built)?;
    let damping = Rayleigh::new(settings.damping.mass, settings.damping.stiffness)?;
    let mut run = mixed_transient_model(
        mesh,
        &built.materials,
        scene.model(),
        (&built.constraints, &loads),
        (method, dt, damping),
    )?;
    let dofs = run.operator().dofs().clone();
    let v0: Vec<f64> = dofs
        .free_dofs()
        .iter()
        .map(|&dof| settings.initial_velocity[dof % 3])
        .collect();
    run.start(vec![0.0; dofs.free_count()], v0)?;
    let critical = crate::critical_step_of(&built)?;
    let setup_seconds = clock.elapsed().as_secs_f64();
    let energy = |run: &MixedTransient<E>| energy_terms(run, &gravity);
    let initial_energy = energy(&run)?;
    let mut outputs = LoopOutputs::new(scene, lock.is_some(), steps);
    let (mut rows, mut probes) = csv_start(&built.probes);
    for step in 0..=steps {
        if step > 0 {
            outputs.timed_step(step, || run.step())?;
        }
        let clock = Instant::now();
        let e = energy(&run)?;
        let pressure = run.pressure();
        let u = run.displacement()?;
        csv_row(
            (&mut rows, &mut probes),
            &built.probes,
            (run.time(), &e, pressure_range(&pressure)),
            &u,
        );
        outputs.after_step(step, clock, (mesh, run.time(), &u, &pressure), progress)?;
    }
    let final_energy = energy(&run)?;
    let mut summary = DynamicSummary {
        method: match method {
            tetfem::analysis::dynamics::Method::Newmark => "newmark",
            _ => "backward-euler",
        }
        .into(),
        free_dofs: dofs.free_count(),
        dt,
        critical_step: critical.seconds,
        critical_step_source: critical.source.clone(),
        dt_over_critical: dt / critical.seconds,
        steps,
        end_time: run.time(),
        setup_seconds,
        initial_energy,
        final_energy,
        probes,
        ..outputs.timings(summary_base(scene, &built, lock.as_ref())?)
    };
    if let Some(w) = outputs.writer {
        write_outputs(scene, w, &rows, &mut summary)?;
    }
    Ok(summary)
}

/// The summary fields every mixed dynamic run fills alike (the scene's, the mesh's, the
/// warnings, none of the displacement runs' estimates); each runner sets its own measurements
/// over it.
fn summary_base<C: CellType>(
    scene: &Scene,
    built: &crate::BuiltScene<C>,
    lock: Option<&OutputLock>,
) -> Result<DynamicSummary> {
    Ok(DynamicSummary {
        warnings: mixed_warnings(scene, built)?
            .into_iter()
            .chain(lock.and_then(OutputLock::warning))
            .collect(),
        title: scene.title(),
        scene: scene.source_name().to_string(),
        analysis: "dynamic (mixed)".into(),
        method: String::new(),
        nodes: built.mesh.node_count(),
        tets: built.mesh.tet_count(),
        free_dofs: 0,
        dt: 0.0,
        critical_step: 0.0,
        critical_step_source: String::new(),
        dt_over_critical: 0.0,
        steps: 0,
        end_time: 0.0,
        setup_seconds: 0.0,
        first_step_seconds: 0.0,
        mean_step_seconds: 0.0,
        step_seconds: 0.0,
        output_seconds: 0.0,
        initial_energy: EnergyTerms::default(),
        final_energy: EnergyTerms::default(),
        probes: Vec::new(),
        reactions: Vec::new(),
        frames: 0,
        files: Vec::new(),
        model: scene.model().name().into(),
        newton: None,
        estimated_error: None,
        estimate_seconds: 0.0,
        deformation: None,
        step_resolution: None,
        resumed_from_step: None,
        contact_forces: None,
        contact_barrier: None,
        time_stepping: None,
        accuracy: None,
        volume_change: None,
    })
}

/// Writes the frames' `.pvd`, the CSV `rows` and the summary's JSON, listing them in
/// `summary.files`.
fn write_outputs(
    scene: &Scene,
    writer: FrameFiles,
    rows: &str,
    summary: &mut DynamicSummary,
) -> Result<()> {
    let out = scene.output();
    let clock = Instant::now();
    let mut files = writer.finish()?;
    if out.csv {
        let csv = out.directory.join(format!("{}.csv", out.stem));
        write_atomically(&csv, |f| f.write_all(rows.as_bytes()))?;
        files.push(csv);
    }
    let json = out.directory.join(format!("{}_summary.json", out.stem));
    summary.files = files;
    summary.files.push(json.clone());
    write_atomically(&json, |f| writeln!(f, "{}", summary.to_json()))?;
    summary.output_seconds += clock.elapsed().as_secs_f64();
    Ok(())
}

/// The run's dt (s): the override's or the scene's; a multiple of the critical step is
/// refused (the mixed run is implicit, its dt given in seconds).
/// The run's step dt (s, [`seconds_step`]) and its number of steps (the overridden run length,
/// else the scene's duration).
fn step_and_count(
    overrides: &DynamicOverrides,
    settings: &DynamicSettings,
) -> Result<(f64, usize)> {
    let dt = seconds_step(overrides, settings)?;
    let steps = overrides
        .length
        .unwrap_or(RunLength::Duration(settings.duration))
        .steps(dt)?;
    Ok((dt, steps))
}

/// Gravity's nodal loads (N) on the built scene, and all its loads: the other loads plus
/// gravity's.
fn gravity_and_loads<E: SceneElement>(built: &crate::BuiltScene<E>) -> Result<(Loads, Loads)> {
    let mut gravity = Loads::new(&built.mesh);
    gravity.add_gravity(&built.mesh, &built.materials, built.gravity)?;
    let mut loads = built.other_loads.clone();
    loads.add_scaled(&gravity, 1.0)?;
    Ok((gravity, loads))
}

fn seconds_step(overrides: &DynamicOverrides, settings: &DynamicSettings) -> Result<f64> {
    match overrides.dt.unwrap_or(TimeStep::Seconds(settings.dt)) {
        TimeStep::Seconds(dt) => Ok(dt),
        TimeStep::CriticalMultiple(m) => Err(Error::invalid_parameter(
            "formulation mixed with dt",
            format!("{m}crit"),
            "the mixed element's implicit run takes dt in seconds",
        )),
    }
}

/// The energies of `run`'s state, gravity's potential −f_gᵀu apart (`gravity` its nodal
/// loads).
fn energy_terms<E: MixedStaticElement>(
    run: &MixedTransient<E>,
    gravity: &Loads,
) -> Result<EnergyTerms> {
    let e = run.energy()?;
    let u = run.displacement()?;
    let g: f64 = -(gravity.as_slice().iter().zip(&u))
        .map(|(f, x)| f * x)
        .sum::<f64>();
    Ok(EnergyTerms {
        kinetic: e.kinetic,
        elastic: e.elastic,
        gravity_potential: g,
        load_potential: e.load_potential - g,
        total: e.total(),
    })
}

/// The CSV's header (with three columns per probe) and the probes' ranges, empty.
fn csv_start(probes: &[crate::Probe]) -> (String, Vec<ProbeRange>) {
    let mut header = String::from(
        "time_s,kinetic_J,elastic_J,gravity_potential_J,load_potential_J,total_J,\
         pressure_min_Pa,pressure_max_Pa",
    );
    for probe in probes {
        for axis in ["x", "y", "z"] {
            header.push_str(&format!(",{}_u{axis}_m", probe.name));
        }
    }
    header.push('\n');
    let ranges = (probes.iter())
        .map(|p| ProbeRange {
            name: p.name.clone(),
            last: [0.0; 3],
            min: [f64::INFINITY; 3],
            max: [f64::NEG_INFINITY; 3],
        })
        .collect();
    (header, ranges)
}

/// One CSV row at `time` (s): the energies, the pressure range (Pa) and each node-set probe's
/// mean displacement of the full `u` (m), which also updates the probes' ranges. (Point
/// probes are refused for the mixed formulation when the scene is read.)
fn csv_row(
    (rows, ranges): (&mut String, &mut [ProbeRange]),
    probes: &[crate::Probe],
    (time, e, (low, high)): (f64, &EnergyTerms, (f64, f64)),
    u: &[f64],
) {
    rows.push_str(&format!(
        "{time:e},{:e},{:e},{:e},{:e},{:e},{low:e},{high:e}",
        e.kinetic, e.elastic, e.gravity_potential, e.load_potential, e.total
    ));
    for (range, probe) in ranges.iter_mut().zip(probes) {
        for a in 0..3 {
            let mean =
                probe.nodes.iter().map(|&n| u[3 * n + a]).sum::<f64>() / probe.nodes.len() as f64;
            range.last[a] = mean;
            range.min[a] = range.min[a].min(mean);
            range.max[a] = range.max[a].max(mean);
            rows.push_str(&format!(",{mean:e}"));
        }
    }
    rows.push('\n');
}

/// The smallest and largest pressure (Pa) of a state, for the CSV's pressure range.
fn pressure_range(pressure: &[f64]) -> (f64, f64) {
    pressure
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &p| {
            (a.min(p), b.max(p))
        })
}

/// What a mixed run's time loop keeps besides its CSV rows: the frames (when the run writes
/// files), the step and output times (s) for the summary, and when to stop.
struct LoopOutputs {
    writer: Option<FrameFiles>,
    every: usize,
    steps: usize,
    step_seconds: f64,
    first_step_seconds: f64,
    output_seconds: f64,
}

impl LoopOutputs {
    /// For a run of `steps` steps writing frames every `[output] every` steps when `writes`.
    fn new(scene: &Scene, writes: bool, steps: usize) -> Self {
        LoopOutputs {
            writer: writes.then(|| FrameFiles::new(scene)),
            every: scene.output().every,
            steps,
            step_seconds: 0.0,
            first_step_seconds: 0.0,
            output_seconds: 0.0,
        }
    }

    /// Step number `step` (from 1) made by `advance`, timed into the step times.
    fn timed_step<T>(&mut self, step: usize, advance: impl FnOnce() -> Result<T>) -> Result<T> {
        let clock = Instant::now();
        let result = advance()?;
        let seconds = clock.elapsed().as_secs_f64();
        if step == 1 {
            self.first_step_seconds = seconds;
        }
        self.step_seconds += seconds;
        Ok(result)
    }

    /// After step `step` (0: the start) has written its row from `clock` on: its frame of
    /// `time` (s), displacement `u` (m) and `pressure` (Pa) on `mesh` when due (every
    /// `every` steps and the last), the output time, then `progress`, whose break stops the
    /// run as [`Error::Interrupted`] with the whole frames written so far.
    fn after_step<C: CellType>(
        &mut self,
        step: usize,
        clock: Instant,
        (mesh, time, u, pressure): (&tetfem::TetMesh<C>, f64, &[f64], &[f64]),
        progress: &mut dyn FnMut(usize, usize) -> ControlFlow<()>,
    ) -> Result<()> {
        if let Some(w) = &mut self.writer
            && (step.is_multiple_of(self.every) || step == self.steps)
        {
            w.frame(mesh, time, u, pressure)?;
        }
        self.output_seconds += clock.elapsed().as_secs_f64();
        if step > 0 && progress(step, self.steps).is_break() {
            return Err(Error::Interrupted {
                step,
                time,
                frames: self.frames(),
            });
        }
        Ok(())
    }

    /// Frames written so far.
    fn frames(&self) -> usize {
        self.writer.as_ref().map_or(0, |w| w.frames.len())
    }

    /// `summary` with this loop's times and frame count.
    fn timings(&self, summary: DynamicSummary) -> DynamicSummary {
        DynamicSummary {
            first_step_seconds: self.first_step_seconds,
            mean_step_seconds: self.step_seconds / self.steps as f64,
            step_seconds: self.step_seconds,
            output_seconds: self.output_seconds,
            frames: self.frames(),
            ..summary
        }
    }
}

/// The frames of a mixed dynamic run: a `.vtu` each and the `.pvd` listing them.
struct FrameFiles {
    vtu: bool,
    stem: String,
    directory: PathBuf,
    format: tetfem::post::output::VtuFormat,
    pvd: PvdCollection,
    frames: Vec<PathBuf>,
}

impl FrameFiles {
    fn new(scene: &Scene) -> Self {
        let out = scene.output();
        FrameFiles {
            vtu: out.vtu,
            stem: out.stem.clone(),
            directory: out.directory.clone(),
            format: out.vtu_format.format(),
            pvd: PvdCollection::new(out.directory.join(format!("{}.pvd", out.stem))),
            frames: Vec::new(),
        }
    }

    /// One frame at `time` (s): displacement (m) and pressure (Pa) at every node.
    fn frame<C: CellType>(
        &mut self,
        mesh: &tetfem::TetMesh<C>,
        time: f64,
        u: &[f64],
        pressure: &[f64],
    ) -> Result<()> {
        if !self.vtu {
            return Ok(());
        }
        let path = self
            .directory
            .join(format!("{}_{:05}.vtu", self.stem, self.frames.len()));
        VtuWriter::new(mesh)
            .format(self.format)
            .field_data("time", time)?
            .point_field("displacement", 3, u)?
            .point_field("pressure", 1, pressure)?
            .write(&path)?;
        self.pvd.push(time, &path)?;
        self.frames.push(path);
        Ok(())
    }

    /// The files written.
    fn finish(self) -> Result<Vec<PathBuf>> {
        let mut files = self.frames;
        if self.vtu {
            files.push(self.pvd.path().to_path_buf());
        }
        Ok(files)
    }
}
