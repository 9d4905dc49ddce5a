//! The time loop of a dynamic scene: the core's one loop ([`Transient::run`]) steps, and a
//! [`StepWatcher`] (the scene's [`Observer`]) has a [`StepRecorder`] keep each step's probes,
//! contact forces, reactions and outputs, writes checkpoints when due, and lets `progress`
//! stop the run at a step boundary; the summary closes the run.

use super::*;
use tetfem::analysis::dynamics::{EnergyWorkspace, Integrator};
use tetfem::analysis::transient::{AdaptiveStep, Flow, Observer, RunEnd, StepView, Transient};

/// [`run_dynamic`] once the output folder's lock (if any) is held; with `adaptive`
/// (`time_tolerance`, its output interval set) the library's error-controlled run, `run.dt` its
/// first step.
pub(super) fn run_dynamic_locked<E: SceneElement>(
    setup: &DynamicSetup<E>,
    run: &DynamicRun,
    outputs: Option<&DynamicOutputs>,
    (lock, restart): (Option<OutputLock>, Option<Restart>),
    adaptive: Option<AdaptiveStep>,
    progress: &mut dyn FnMut(usize, usize) -> ControlFlow<()>,
) -> Result<DynamicSummary> {
    let clock = Instant::now();
    let (critical, critical_source) = setup.critical_step()?;
    let dt = setup.resolve(run.dt)?;
    let steps = run.length.steps(dt)?;
    let frame_clock = frame_clock(setup, run, outputs, dt, adaptive.as_ref());
    let mut transient = start_transient(setup, run, dt)?;
    let setup_seconds = setup.setup_seconds + clock.elapsed().as_secs_f64();
    let initial_energy = transient.energy()?;
    let resumed_at = restart.as_ref().and_then(Restart::resumed_at);
    let mut recorder = StepRecorder::new(setup, run, outputs, steps, frame_clock, resumed_at)?;
    // A resume continues from the checkpoint's state, integrator history, probe extremes and
    // contact force peaks.
    let first = resumed_at.unwrap_or(0);
    if let Some(r) = restart.as_ref() {
        let (integrator, state) = transient.parts_mut();
        if let Some(restored) = recorder.restore(r, integrator)? {
            *state = restored;
        }
    }
    let start_energy = match resumed_at {
        None => recorder.record((transient.state(), None), 0.0, false)?,
        Some(_) => transient.energy()?,
    };
    // The stepping begins: `progress` learns it before the first step (the command-line tool
    // lets the first signal stop the run at a step boundary only from here on; during the
    // set-up above it exits at once) and may stop the run here already.
    if progress(first, steps).is_break() && first < steps {
        let time = frame_clock.time(transient.state());
        return Err(interrupted(&mut recorder.writer, first, time)?);
    }
    let mut watcher = StepWatcher {
        recorder: &mut recorder,
        restart: restart.as_ref(),
        progress,
        first,
        clocks: StepClocks::default(),
    };
    let (end, time_stepping) = match &adaptive {
        None => (transient.run((first, steps), &mut watcher)?, None),
        Some(control) => {
            let end_time = match frame_clock {
                FrameClock::Landings { end, .. } => end,
                FrameClock::Steps { .. } => steps as f64 * dt,
            };
            let report = transient.run_adaptive(end_time, control, &mut watcher)?;
            (report.end, Some(TimeStepping::of(&report, control)))
        }
    };
    let clocks = watcher.clocks;
    if let RunEnd::Stopped { step } = end {
        let time = frame_clock.time(transient.state());
        return Err(interrupted(&mut recorder.writer, step, time)?);
    }
    let tally = RunTally {
        critical: (critical, critical_source),
        dt,
        steps: match time_stepping {
            Some(_) => transient.state().steps,
            None => steps,
        },
        first,
        setup_seconds,
        clocks,
        energies: (initial_energy, clocks.final_energy.unwrap_or(start_energy)),
        resumed_at,
        frame_clock,
        time_stepping,
    };
    let summary = close_run(
        setup,
        run,
        transient.integrator(),
        transient.state(),
        recorder,
        &tally,
    )?;
    write_summary(summary, outputs, lock, restart.as_ref())
}

/// The library's transient run of `setup` with `run`'s method at `dt` (s) and the setup's
/// solvers.
fn start_transient<E: SceneElement>(
    setup: &DynamicSetup<E>,
    run: &DynamicRun,
    dt: f64,
) -> Result<Transient> {
    let options = IntegratorOptions {
        linear_method: setup.linear_method,
        nonlinear_solve: setup.nonlinear_solve,
        newton: setup.newton,
        ..IntegratorOptions::default()
    };
    Transient::from_parts(
        Arc::clone(&setup.system),
        setup.force.clone(),
        setup.initial.clone(),
        run.method,
        dt,
        options,
    )
}

/// The times of a run's states and its frames: steps of `dt` with a frame every
/// `[output] every` steps, or with `adaptive` the landings on its output interval to the end
/// of `run.length` (a step count there counts steps of `dt`).
fn frame_clock<E: SceneElement>(
    setup: &DynamicSetup<E>,
    run: &DynamicRun,
    outputs: Option<&DynamicOutputs>,
    dt: f64,
    adaptive: Option<&AdaptiveStep>,
) -> FrameClock {
    let every = outputs.map_or(1, |o| o.settings.every);
    let start = setup.initial.time;
    match adaptive {
        None => FrameClock::Steps {
            start: (start, setup.initial.steps),
            dt,
            every,
        },
        Some(control) => FrameClock::Landings {
            start,
            interval: control.output_interval.unwrap_or(every as f64 * dt),
            end: start
                + match run.length {
                    RunLength::Duration(d) => d,
                    RunLength::Steps(n) => n as f64 * dt,
                },
        },
    }
}

/// The summary of a finished run with the lock's warning and the checkpoint's path, written
/// to `<stem>_summary.json` when the run writes files; then the folder's lock is released.
fn write_summary(
    mut summary: DynamicSummary,
    outputs: Option<&DynamicOutputs>,
    lock: Option<OutputLock>,
    restart: Option<&Restart>,
) -> Result<DynamicSummary> {
    summary
        .warnings
        .extend(lock.as_ref().and_then(OutputLock::warning));
    if let Some(path) = restart.and_then(Restart::written) {
        summary.files.push(path);
    }
    if let Some(o) = outputs {
        let json = o
            .settings
            .directory
            .join(format!("{}_summary.json", o.settings.stem));
        summary.files.push(json.clone());
        write_atomically(&json, |w| writeln!(w, "{}", summary.to_json()))?;
    }
    drop(lock);
    Ok(summary)
}

/// Wall times of the stepping (s) and the energy after the last step taken.
#[derive(Debug, Clone, Copy, Default)]
struct StepClocks {
    first_step: f64,
    step_total: f64,
    final_energy: Option<Energy>,
}

/// The scene's observer of the time loop: each step recorded, a checkpoint written when due
/// (or when `progress` stops the run and checkpoints are on), a failed step leaving whole rows
/// and frames behind.
struct StepWatcher<'r, 's, E: SceneElement> {
    recorder: &'r mut StepRecorder<'s, E>,
    restart: Option<&'r Restart>,
    progress: &'r mut dyn FnMut(usize, usize) -> ControlFlow<()>,
    /// The step the run started from.
    first: usize,
    clocks: StepClocks,
}

impl<E: SceneElement> Observer for StepWatcher<'_, '_, E> {
    fn observe(&mut self, view: &StepView<'_>) -> Result<Flow> {
        let (step, steps) = (view.step, view.last);
        if step == self.first + 1 {
            self.clocks.first_step = view.wall;
        }
        self.clocks.step_total += view.wall;
        let acceleration = view.integrator.linear_acceleration(view.state);
        let energy = (self.recorder).record(
            (view.state, acceleration.as_deref()),
            view.wall,
            step == steps,
        )?;
        self.clocks.final_energy = Some(energy);
        let stop = (self.progress)(step, steps).is_break() && step < steps;
        // The checkpoint after the CSV rows up to it are written out (a resume keeps them).
        if let Some(r) = self
            .restart
            .filter(|r| r.due(step) || (stop && r.enabled()))
        {
            if let Some(w) = &mut self.recorder.writer {
                w.finish_partial()?;
            }
            r.write(
                view.integrator,
                view.state,
                &self.recorder.probes,
                (
                    self.recorder.contact_forces.as_deref().unwrap_or_default(),
                    view.force.barrier_record(),
                    view.force.node_stiffnesses(),
                ),
            )?;
        }
        Ok(if stop { Flow::Stop } else { Flow::Continue })
    }

    fn step_failed(&mut self, _error: &Error) -> Result<()> {
        match &mut self.recorder.writer {
            Some(w) => w.finish_partial(),
            None => Ok(()),
        }
    }
}

/// What a run keeps of each step: the probes' last values and extremes, the obstacles' force
/// history, the support reactions and the writer's rows and frames.
struct StepRecorder<'s, E: SceneElement> {
    setup: &'s DynamicSetup<E>,
    clock: FrameClock,
    writer: Option<FrameWriter>,
    probes: Vec<ProbeRange>,
    contact_forces: Option<Vec<ContactForceHistory>>,
    reactions: super::super::DynamicReactions,
    /// Scratch of the energies taken every step (the library's
    /// [`InternalForce::energy_with`]), kept so that a step's record allocates none for them.
    energy_work: EnergyWorkspace,
    /// Wall time spent recording (s).
    output_seconds: f64,
}

impl<'s, E: SceneElement> StepRecorder<'s, E> {
    /// The recorder of a run of `steps` steps (an error-controlled one: about as many) on
    /// `clock`, with its writer if `outputs`.
    fn new(
        setup: &'s DynamicSetup<E>,
        run: &DynamicRun,
        outputs: Option<&DynamicOutputs>,
        steps: usize,
        clock: FrameClock,
        resumed_at: Option<usize>,
    ) -> Result<Self> {
        let writer = match outputs {
            Some(o) => Some(FrameWriter::new(setup, run, o, steps, clock, resumed_at)?),
            None => None,
        };
        let probes = setup
            .probes
            .iter()
            .map(|p| ProbeRange {
                name: p.name.clone(),
                last: [0.0; 3],
                min: [f64::INFINITY; 3],
                max: [f64::NEG_INFINITY; 3],
            })
            .collect();
        Ok(StepRecorder {
            setup,
            clock,
            writer,
            probes,
            contact_forces: contact_of(&setup.force).map(ContactForceHistory::start),
            reactions: setup.reactions.clone(),
            energy_work: setup.system.energy_workspace(),
            output_seconds: 0.0,
        })
    }

    /// Restores the integrator's history, the probe extremes and the contact force peaks from
    /// `restart`'s checkpoint; the checkpoint's state if it resumes one.
    fn restore(
        &mut self,
        restart: &Restart,
        integrator: &mut dyn Integrator,
    ) -> Result<Option<State>> {
        restart.restore(
            (integrator, &self.setup.force),
            &mut self.probes,
            self.contact_forces.as_deref_mut().unwrap_or_default(),
        )
    }

    /// Records `state` (taken in `wall` s; `last` for the run's last step): its energy, the
    /// probes' means, the obstacles' forces and, with a writer, its CSV row and frame.
    fn record(
        &mut self,
        (state, acceleration): (&State, Option<&[f64]>),
        wall: f64,
        last: bool,
    ) -> Result<Energy> {
        let clock = Instant::now();
        let setup = self.setup;
        let system = &setup.system;
        let energy = (setup.force).energy_with(system, state, &mut self.energy_work)?;
        // The constrained DOFs at their values of this time (moving supports: u_c(t)).
        let u = system.expand_at(state.time, &state.displacement)?;
        let mut means = Vec::with_capacity(setup.probes.len());
        for (probe, range) in setup.probes.iter().zip(self.probes.iter_mut()) {
            let mean: [f64; 3] = probe.displacement(&u).into();
            range.last = mean;
            for a in 0..3 {
                range.min[a] = range.min[a].min(mean[a]);
                range.max[a] = range.max[a].max(mean[a]);
            }
            means.push(mean);
        }
        let time = self.clock.time(state);
        let forces = super::super::dynamic_contact::obstacle_forces(&setup.force, &u, time)?;
        if let (Some(histories), Some(f)) = (self.contact_forces.as_mut(), forces.as_ref()) {
            ContactForceHistory::record(histories, f, time);
        }
        if let Some(w) = &mut self.writer {
            let at =
                self.reactions
                    .at_with(&setup.mesh, system, &setup.force, (state, acceleration))?;
            w.record(
                setup,
                state,
                &u,
                wall,
                &means,
                &energy,
                &at,
                forces.as_deref(),
                last,
            )?;
        }
        self.output_seconds += clock.elapsed().as_secs_f64();
        Ok(energy)
    }
}

/// The figures of a finished stepping that its summary reports.
struct RunTally {
    /// The critical step (s) and where it comes from.
    critical: (f64, &'static str),
    dt: f64,
    steps: usize,
    /// The step the run started from (0, or a checkpoint's).
    first: usize,
    setup_seconds: f64,
    clocks: StepClocks,
    /// The energies at the start and at the end.
    energies: (Energy, Energy),
    /// The checkpoint's step the run resumed from, if it did.
    resumed_at: Option<usize>,
    /// The states' times.
    frame_clock: FrameClock,
    /// What an error-controlled run did.
    time_stepping: Option<TimeStepping>,
}

/// The summary of a finished run: the final reactions, the estimated error, the deformation
/// and step-resolution checks (their warnings with the mesh's, the materials' and the
/// scene's), the files written.
fn close_run<E: SceneElement>(
    setup: &DynamicSetup<E>,
    run: &DynamicRun,
    integrator: &dyn Integrator,
    state: &State,
    mut recorder: StepRecorder<'_, E>,
    tally: &RunTally,
) -> Result<DynamicSummary> {
    let (mesh, system) = (&setup.mesh, &setup.system);
    let clock = Instant::now();
    let final_reactions = recorder
        .reactions
        .at_with(
            mesh,
            system,
            &setup.force,
            (state, integrator.linear_acceleration(state).as_deref()),
        )?
        .rows;
    recorder.output_seconds += clock.elapsed().as_secs_f64();
    let clock = Instant::now();
    let u = system.dofs().expand(&state.displacement)?;
    let e = setup.force.estimated_error(mesh, &setup.materials, &u)?;
    // A linear model with obstacles runs as a nonlinear force, and keeps the linear estimate.
    let nonlinear = setup.force.name() != tetfem::model::ModelKind::Linear.name();
    let estimated_error = Some(super::super::EstimatedError {
        relative: e.relative(),
        eta: e.estimate,
        energy_norm: e.energy_norm,
        definition: match nonlinear {
            true => super::super::MODEL_ESTIMATED_ERROR_DEFINITION,
            false => super::super::ESTIMATED_ERROR_DEFINITION,
        },
    });
    let estimate_seconds = clock.elapsed().as_secs_f64();
    let deformation = setup.force.deformation(mesh, &u)?;
    let step_resolution = match system.free_count() <= STEP_CHECK_DOFS {
        true => setup.force.step_resolution(
            run.method,
            system,
            &setup.initial.displacement,
            STEP_CHECK_MODES,
            // An error-controlled run: its largest step, where the mode is resolved worst.
            tally.time_stepping.as_ref().map_or(tally.dt, |t| t.dt_max),
        )?,
        false => None,
    };
    let (mut files, mut frames) = (Vec::new(), 0);
    if let Some(w) = recorder.writer {
        (frames, files) = (w.frames, w.finish()?);
    }
    let (first, steps, clocks) = (tally.first, tally.steps, tally.clocks);
    let barrier = setup.force.barrier_record();
    // The run's own checks: deformation, step resolution, the barrier's reach.
    let checks = [
        deformation.and_then(|d| d.warning()),
        step_resolution.and_then(|r| r.warning()),
        barrier.and_then(|b| b.warning()),
    ];
    Ok(DynamicSummary {
        warnings: (mesh.warnings().iter())
            .chain(&setup.materials.warnings())
            .chain(&setup.input_warnings)
            .chain(checks.iter().flatten())
            .map(ToString::to_string)
            .collect(),
        title: run.title.clone(),
        scene: run.source.clone(),
        analysis: "dynamic".into(),
        method: integrator.name().into(),
        nodes: mesh.node_count(),
        tets: mesh.tet_count(),
        free_dofs: system.free_count(),
        dt: tally.dt,
        critical_step: tally.critical.0,
        critical_step_source: tally.critical.1.into(),
        dt_over_critical: tally.dt / tally.critical.0,
        steps,
        end_time: tally.frame_clock.time(state),
        setup_seconds: tally.setup_seconds,
        first_step_seconds: clocks.first_step,
        mean_step_seconds: if steps - first > 1 {
            (clocks.step_total - clocks.first_step) / (steps - first - 1) as f64
        } else {
            clocks.first_step
        },
        step_seconds: clocks.step_total,
        output_seconds: recorder.output_seconds,
        initial_energy: tally.energies.0.into(),
        final_energy: tally.energies.1.into(),
        probes: recorder.probes,
        reactions: final_reactions,
        frames,
        files,
        model: setup.force.name().into(),
        newton: integrator.newton_stats(),
        estimated_error,
        estimate_seconds,
        deformation,
        step_resolution,
        resumed_from_step: tally.resumed_at,
        contact_forces: recorder.contact_forces,
        contact_barrier: barrier
            .as_ref()
            .map(super::super::DynamicContactBarrier::of),
        time_stepping: tally.time_stepping.clone(),
        accuracy: None,
        volume_change: None,
    })
}

#[cfg(test)]
mod tests;
