//! The mixed (Taylor–Hood P2–P1) formulation's dynamic and modal scenes: `formulation =
//! "mixed"` with `type = "dynamic"` (backward Euler or Newmark, the linear model, the
//! consistent mass) or `type = "modal"`. The library computes
//! ([`mixed_transient_model`], [`mixed_modes_model`]); this file reads the scene's keys, steps,
//! and writes what a user opens: `<stem>.pvd` with a `.vtu` per frame (point fields
//! `displacement`, m, and `pressure`, Pa), `<stem>.csv` (time, energies, pressure range, each
//! probe's mean displacement) and
//! `<stem>_summary.json`; for modes `<stem>_modes.pvd` with `mode_shape` and `pressure` per mode,
//! `<stem>_modes.csv` and the summary.

use std::ops::ControlFlow;
use std::path::PathBuf;
use std::time::Instant;

use tetfem::analysis::dynamics::Rayleigh;
use tetfem::analysis::mixed_analysis::{mixed_modes_model, mixed_transient_model};
use tetfem::analysis::mixed_dynamics::MixedTransient;
use tetfem::analysis::modal::effective_mass_fractions;
use tetfem::analysis::transient::{RunLength, TimeStep};
use tetfem::base::error::{Error, Result};
use tetfem::fe::element::Tet10;
use tetfem::post::output::{OutputLock, PvdCollection, VtuWriter, write_atomically};
use tetfem::{Loads, Problem};

use super::dynamic::{DynamicOverrides, DynamicSummary, EnergyTerms};
use super::modal::{ModalSummary, ModeRow};
use super::{DynamicSettings, ModalSettings, ProbeRange, Scene};

/// A mixed modal scene (see the [module](self) docs): the lowest modes of K_eff·φ = ω²·M·φ.
pub(crate) fn run_mixed_modal(
    scene: &Scene,
    settings: ModalSettings,
    lock: Option<OutputLock>,
) -> Result<ModalSummary> {
    let clock = Instant::now();
    let built = scene.build_as::<Tet10>()?;
    let build_seconds = clock.elapsed().as_secs_f64();
    let clock = Instant::now();
    let mixed = mixed_modes_model(
        &built.mesh,
        &built.materials,
        scene.model(),
        &built.constraints,
        settings.modes,
    )?;
    // Base-excitation participation from the consistent mass's row sums (every DOF).
    let problem = Problem::new(&built.mesh, &built.constraints)?;
    let full_mass = problem.consistent_mass(&built.materials)?;
    let row_sums = full_mass.mul(&vec![1.0; full_mass.dim()])?;
    let fractions = effective_mass_fractions(&mixed.modes, problem.dofs(), &row_sums)?;
    let solve_seconds = clock.elapsed().as_secs_f64();
    let rows: Vec<ModeRow> = (mixed.modes.omega.iter().zip(&fractions))
        .zip(&mixed.modes.residuals)
        .enumerate()
        .map(|(i, ((&omega, &fraction), &residual))| {
            let frequency_hz = omega / (2.0 * std::f64::consts::PI);
            ModeRow {
                mode: i + 1,
                frequency_hz,
                period_s: 1.0 / frequency_hz,
                omega_rad_per_s: omega,
                effective_mass_fraction: fraction,
                residual,
            }
        })
        .collect();
    let mut cumulative = [0.0; 3];
    for row in &rows {
        for (sum, f) in cumulative.iter_mut().zip(row.effective_mass_fraction) {
            *sum += f;
        }
    }
    let mut summary = ModalSummary {
        title: scene.title(),
        scene: scene.source_name().to_string(),
        analysis: "modal (mixed)".into(),
        mass: "consistent".into(),
        nodes: built.mesh.node_count(),
        tets: built.mesh.tet_count(),
        free_dofs: mixed.free_dofs,
        modes: rows,
        cumulative_mass_fraction: cumulative,
        iterations: mixed.modes.iterations,
        critical_step: None,
        build_seconds,
        solve_seconds,
        output_seconds: 0.0,
        files: Vec::new(),
        warnings: mixed_warnings(scene, &built)?
            .into_iter()
            .chain(lock.as_ref().and_then(OutputLock::warning))
            .collect(),
    };
    if lock.is_some() {
        let clock = Instant::now();
        summary.files = write_mixed_modes(scene, &built.mesh, problem.dofs(), &mixed, &summary)?;
        summary.output_seconds = clock.elapsed().as_secs_f64();
    }
    Ok(summary)
}

/// The mesh's and materials' warnings without the displacement element's locking warning
/// (the mixed element does not lock).
fn mixed_warnings(scene: &Scene, built: &super::BuiltScene<Tet10>) -> Result<Vec<String>> {
    let _ = scene;
    Ok(built
        .warnings()
        .iter()
        .filter(|w| {
            !matches!(
                w,
                tetfem::base::warning::Warning::NearlyIncompressible { .. }
            )
        })
        .map(ToString::to_string)
        .collect())
}

/// The mode files (see the [module](self) docs).
fn write_mixed_modes(
    scene: &Scene,
    mesh: &tetfem::TetMesh<Tet10>,
    dofs: &tetfem::DofMap,
    mixed: &tetfem::analysis::mixed_modal::MixedModes,
    summary: &ModalSummary,
) -> Result<Vec<PathBuf>> {
    let out = scene.output();
    let dir = &out.directory;
    let mut files = Vec::new();
    if out.vtu {
        let mut pvd = PvdCollection::new(dir.join(format!("{}_modes.pvd", out.stem)));
        for ((row, shape), pressure) in summary
            .modes
            .iter()
            .zip(&mixed.modes.shapes)
            .zip(&mixed.pressure)
        {
            // Zero on the supports, scaled to a largest nodal amplitude of 1 (the pressure
            // with it, Pa per unit amplitude).
            let mut full = vec![0.0; dofs.full_count()];
            for (value, &dof) in shape.iter().zip(dofs.free_dofs()) {
                full[dof] = *value;
            }
            let largest = full
                .chunks_exact(3)
                .map(|v| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt())
                .fold(0.0, f64::max);
            let scale = if largest > 0.0 { 1.0 / largest } else { 1.0 };
            full.iter_mut().for_each(|v| *v *= scale);
            let pressure: Vec<f64> = pressure.iter().map(|p| p * scale).collect();
            let vtu = dir.join(format!(
                "{}_mode_{:02}_{:.4}Hz.vtu",
                out.stem, row.mode, row.frequency_hz
            ));
            VtuWriter::new(mesh)
                .format(out.vtu_format.format())
                .field_data("mode", row.mode as f64)?
                .field_data("frequency_hz", row.frequency_hz)?
                .field_data("period_s", row.period_s)?
                .point_field("mode_shape", 3, &full)?
                .point_field("pressure", 1, &pressure)?
                .write(&vtu)?;
            pvd.push(row.mode as f64, &vtu)?;
            files.push(vtu);
        }
        files.push(pvd.path().to_path_buf());
    }
    super::modal::write_modes_table_and_summary(scene, summary, files)
}

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
    let method = overrides.method.unwrap_or(settings.method);
    let dt = seconds_step(overrides, settings)?;
    let steps = overrides
        .length
        .unwrap_or(RunLength::Duration(settings.duration))
        .steps(dt)?;
    let clock = Instant::now();
    let built = scene.build_as::<Tet10>()?;
    let mesh = &built.mesh;
    let mut gravity = Loads::new(mesh);
    gravity.add_gravity(mesh, &built.materials, built.gravity)?;
    let mut loads = built.other_loads.clone();
    loads.add_scaled(&gravity, 1.0)?;
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
    let critical = super::critical_step_of(&built)?;
    let setup_seconds = clock.elapsed().as_secs_f64();
    let energy = |run: &MixedTransient| energy_terms(run, &gravity);
    let initial_energy = energy(&run)?;
    let out = scene.output();
    let mut writer = lock.as_ref().map(|_| FrameFiles::new(scene));
    let (mut rows, mut probes) = csv_start(&built.probes);
    let (mut step_seconds, mut first_step_seconds, mut output_seconds) = (0.0, 0.0, 0.0);
    for step in 0..=steps {
        if step > 0 {
            let clock = Instant::now();
            run.step()?;
            let seconds = clock.elapsed().as_secs_f64();
            if step == 1 {
                first_step_seconds = seconds;
            }
            step_seconds += seconds;
        }
        let clock = Instant::now();
        let e = energy(&run)?;
        let pressure = run.pressure();
        let (low, high) = pressure
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &p| {
                (a.min(p), b.max(p))
            });
        let u = run.displacement()?;
        csv_row(
            (&mut rows, &mut probes),
            &built.probes,
            (run.time(), &e, (low, high)),
            &u,
        );
        if let Some(w) = &mut writer
            && (step % out.every == 0 || step == steps)
        {
            w.frame(mesh, run.time(), &u, &pressure)?;
        }
        output_seconds += clock.elapsed().as_secs_f64();
        if step > 0 && progress(step, steps).is_break() {
            return Err(Error::Interrupted {
                step,
                time: run.time(),
                frames: writer.as_ref().map_or(0, |w| w.frames.len()),
            });
        }
    }
    let final_energy = energy(&run)?;
    let mut summary = DynamicSummary {
        warnings: mixed_warnings(scene, &built)?
            .into_iter()
            .chain(lock.as_ref().and_then(OutputLock::warning))
            .collect(),
        title: scene.title(),
        scene: scene.source_name().to_string(),
        analysis: "dynamic (mixed)".into(),
        method: match method {
            tetfem::analysis::dynamics::Method::Newmark => "newmark",
            _ => "backward-euler",
        }
        .into(),
        nodes: mesh.node_count(),
        tets: mesh.tet_count(),
        free_dofs: dofs.free_count(),
        dt,
        critical_step: critical.seconds,
        critical_step_source: critical.source.clone(),
        dt_over_critical: dt / critical.seconds,
        steps,
        end_time: run.time(),
        setup_seconds,
        first_step_seconds,
        mean_step_seconds: step_seconds / steps as f64,
        step_seconds,
        output_seconds,
        initial_energy,
        final_energy,
        probes,
        reactions: Vec::new(),
        frames: writer.as_ref().map_or(0, |w| w.frames.len()),
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
    };
    if let Some(w) = writer {
        let clock = Instant::now();
        let mut files = w.finish()?;
        if out.csv {
            let csv = out.directory.join(format!("{}.csv", out.stem));
            write_atomically(&csv, |f| f.write_all(rows.as_bytes()))?;
            files.push(csv);
        }
        let json = out.directory.join(format!("{}_summary.json", out.stem));
        summary.files = files.clone();
        summary.files.push(json.clone());
        write_atomically(&json, |f| writeln!(f, "{}", summary.to_json()))?;
        summary.output_seconds += clock.elapsed().as_secs_f64();
    }
    Ok(summary)
}

/// The run's dt (s): the override's or the scene's; a multiple of the critical step is
/// refused (the mixed run is implicit, its dt given in seconds).
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
fn energy_terms(run: &MixedTransient, gravity: &Loads) -> Result<EnergyTerms> {
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
fn csv_start(probes: &[super::Probe]) -> (String, Vec<ProbeRange>) {
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
    probes: &[super::Probe],
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
    fn frame(
        &mut self,
        mesh: &tetfem::TetMesh<Tet10>,
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

impl Scene {
    /// What a mixed dynamic or modal scene asks that this front end does not run, named for
    /// the error of `analysis.formulation` (`None` for a static scene or a runnable one): a
    /// lumped mass (the mixed element's inertia is the consistent mass), and in a dynamic run
    /// a model other than the linear one, an error-controlled step and checkpoints.
    pub(crate) fn mixed_dynamics_refusal(&self) -> Option<String> {
        let mass = match self.analysis() {
            super::Analysis::Static => return None,
            super::Analysis::Modal(m) => m.mass,
            super::Analysis::Dynamic(d) => d.mass,
        };
        if mass == tetfem::analysis::dynamics::MassKind::Lumped {
            return Some(
                "mass = \"lumped\" (the mixed element's inertia is the consistent mass: set \
                 mass = \"consistent\")"
                    .into(),
            );
        }
        if !matches!(self.analysis(), super::Analysis::Dynamic(_)) {
            return None;
        }
        let tolerance = (self.spec.analysis.as_ref()).and_then(|a| a.get_ref().time_tolerance);
        if self.model() != tetfem::model::ModelKind::Linear {
            // The library's MixedNeoHookeanEuler; this front end runs the linear model.
            Some(format!(
                "model = \"{}\" in a dynamic scene (the linear model only here)",
                self.model().name()
            ))
        } else if tolerance.is_some() {
            Some("analysis.time_tolerance (the mixed run takes a fixed dt)".into())
        } else if self.output().checkpoint_every > 0 {
            Some("[output] checkpoint_every".into())
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::{DynamicOverrides, run_dynamic_scene, run_modal_scene};

    /// A rubber cantilever 1 × 0.2 × 0.2 m (E = 1e7 Pa), clamped at x = 0, under gravity.
    const BEAM: &str = r#"
[mesh]
order = 2
[mesh.box]
max = [1.0, 0.2, 0.2]
cells = [6, 2, 2]
split = "lecture6"
[material]
youngs_modulus = 1e7
poisson_ratio = 0.4999
density = 1000.0
[[constraints]]
where = { plane = { axis = "x", at = 0.0 } }
[[loads]]
gravity = [0.0, 0.0, -9.81]
[[probes]]
name = "tip"
where = { plane = { axis = "x", at = 1.0 } }
[analysis]
type = "dynamic"
formulation = "mixed"
method = "newmark"
mass = "consistent"
dt = 0.005
duration = 0.4
[output]
every = 20
vtu_format = "ascii"
"#;

    fn parse(text: &str) -> Result<Scene> {
        Scene::parse(text, "beam.toml", Path::new("."))
    }

    #[test]
    fn a_mixed_newmark_scene_conserves_energy_and_writes_the_pressure() {
        let directory =
            std::env::temp_dir().join(format!("tetfem_mixed_swing_{}", std::process::id()));
        let mut scene = parse(BEAM).unwrap();
        scene.set_output_directory(directory.clone());
        let summary = run_dynamic_scene(
            &scene,
            &DynamicOverrides::default(),
            true,
            false,
            &mut |_, _| ControlFlow::Continue(()),
        )
        .unwrap();
        let end = &summary.final_energy;
        println!(
            "mixed swing: {} steps, end energies kinetic {:.4e}, elastic {:.4e}, gravity {:.4e}, \
             total {:.2e} J; tip u_z in [{:.4e}, {:.4e}] m",
            summary.steps,
            end.kinetic,
            end.elastic,
            end.gravity_potential,
            end.total,
            summary.probes[0].min[2],
            summary.probes[0].max[2]
        );
        assert_eq!(summary.steps, 80);
        // Average acceleration conserves kinetic + elastic − fᵀu of the linear undamped body
        // from its start at 0: round-off of the solves against the energies exchanged.
        assert!(end.total.abs() < 1e-9 * end.gravity_potential.abs());
        assert!(end.kinetic > 0.0 && end.elastic > 0.0);
        // The tip falls (gravity along −z) and stays below its start but for the swing's
        // small overshoot.
        assert!(summary.probes[0].min[2] < 0.0);
        let vtu = summary
            .files
            .iter()
            .find(|f| f.extension().is_some_and(|e| e == "vtu"))
            .unwrap();
        let text = std::fs::read_to_string(vtu).unwrap();
        assert!(text.contains("Name=\"pressure\""), "{vtu:?}");
        let csv = summary
            .files
            .iter()
            .find(|f| f.extension().is_some_and(|e| e == "csv"))
            .unwrap();
        let header = std::fs::read_to_string(csv).unwrap();
        assert!(header.starts_with("time_s,kinetic_J") && header.contains("tip_uz_m"));
        let _ = std::fs::remove_dir_all(directory);
    }

    #[test]
    fn a_mixed_modal_scene_matches_the_displacement_one_where_neither_locks() {
        // ν = 0.3: the displacement P2 modes are accurate, so the mixed ones must agree with
        // them to the discretisation difference (measured 0.4 % on the library's beam test).
        let modal = BEAM
            .replace("poisson_ratio = 0.4999", "poisson_ratio = 0.3")
            .replace("type = \"dynamic\"", "type = \"modal\"\nmodes = 4")
            .replace("method = \"newmark\"\n", "")
            .replace("dt = 0.005\nduration = 0.4\n", "")
            .replace("[[loads]]\ngravity = [0.0, 0.0, -9.81]\n", "")
            .replace(
                "[[probes]]\nname = \"tip\"\nwhere = { plane = { axis = \"x\", at = 1.0 } }\n",
                "",
            );
        let mixed = run_modal_scene(&parse(&modal).unwrap(), true).unwrap();
        let plain = run_modal_scene(
            &parse(&modal.replace("formulation = \"mixed\"", "formulation = \"displacement\""))
                .unwrap(),
            true,
        )
        .unwrap();
        assert_eq!(mixed.analysis, "modal (mixed)");
        for (m, d) in mixed.modes.iter().zip(&plain.modes) {
            println!(
                "mode {}: mixed {:.5} Hz, displacement P2 {:.5} Hz",
                m.mode, m.frequency_hz, d.frequency_hz
            );
            assert!((m.frequency_hz / d.frequency_hz - 1.0).abs() < 0.01);
        }
    }

    #[test]
    fn mixed_dynamics_refuses_what_it_does_not_run_naming_the_key() {
        for (from, to, culprit) in [
            (
                "mass = \"consistent\"",
                "mass = \"lumped\"",
                "mass = \"lumped\"",
            ),
            (
                "method = \"newmark\"",
                "method = \"explicit\"",
                "method = \"explicit\"",
            ),
            (
                "duration = 0.4",
                "duration = 0.4\ntime_tolerance = 1e-3",
                "time_tolerance",
            ),
            (
                "model = \"linear\"",
                "model = \"neo-hookean\"",
                "model = \"neo-hookean\"",
            ),
        ] {
            let text = BEAM.replace(
                "mass = \"consistent\"",
                "mass = \"consistent\"\nmodel = \"linear\"",
            );
            let message = parse(&text.replace(from, to)).unwrap_err().to_string();
            assert!(
                message.contains("analysis.formulation") && message.contains(culprit),
                "{culprit}: {message}"
            );
        }
    }
}
