//! Running a dynamic simulation end to end: build the linear system, step, and write a `.pvd`
//! series of `.vtu` frames, a CSV time series and optional PNG frames as it goes. Used by the
//! command-line tool for the default scene and for dynamic scene files.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use nalgebra::Vector3;

use crate::constraints::Constraints;
use crate::dynamics::{LinearSystem, MassKind, Method, Rayleigh, State, critical_time_step};
use crate::error::{Error, Result};
use crate::loads::Loads;
use crate::material::Material;
use crate::mesh::TetMesh;
use crate::output::{CsvSeries, PvdCollection, fields::displacement_magnitude, write_result_vtu};
use crate::render::{Field, RenderOptions, auto_deformation_scale, render};

/// What to run and what to write.
#[derive(Debug, Clone, PartialEq)]
pub struct SimulationSettings {
    /// Integrator.
    pub method: Method,
    /// Time step (s).
    pub dt: f64,
    /// Steps to take.
    pub steps: usize,
    /// Rayleigh damping.
    pub damping: Rayleigh,
    /// Mass kind.
    pub mass: MassKind,
    /// Constant gravitational acceleration (m/s²), tracked as its own potential.
    pub gravity: Vector3<f64>,
    /// Write a frame (and a CSV row) every this many steps (≥ 1).
    pub every: usize,
    /// Output folder.
    pub directory: PathBuf,
    /// File stem: `<stem>.pvd`, `<stem>_NNNNN.vtu`, `<stem>.csv`, `<stem>_NNNNN.png`.
    pub stem: String,
    /// Write `.vtu` frames and the `.pvd`.
    pub vtu: bool,
    /// Write the CSV series.
    pub csv: bool,
    /// Render PNG frames.
    pub png: bool,
}

/// A named set of nodes whose mean displacement is recorded.
#[derive(Debug, Clone, PartialEq)]
pub struct ProbeSet {
    /// Column name prefix.
    pub name: String,
    /// The nodes.
    pub nodes: Vec<usize>,
}

/// What a run did.
#[derive(Debug, Clone, PartialEq)]
pub struct SimulationSummary {
    /// Steps completed.
    pub steps: usize,
    /// Simulated time reached (s).
    pub time: f64,
    /// The explicit critical step of this system (lumped mass), for comparison.
    pub critical_step: Option<f64>,
    /// Wall time of the whole stepping loop (s), outputs excluded.
    pub stepping_seconds: f64,
    /// Wall time per step (s), outputs excluded.
    pub seconds_per_step: f64,
    /// Files written.
    pub files: Vec<PathBuf>,
    /// Mean displacement of each probe at the end.
    pub probes: Vec<(String, Vector3<f64>)>,
    /// Total energy at the start and at the end (J).
    pub energy: (f64, f64),
}

/// Runs `settings.steps` steps from `initial` (free-DOF state; `None`: at rest) and writes the
/// outputs. On divergence the frames written so far stay valid (the `.pvd` is rewritten after
/// each frame) and the [`Error::Diverged`] is returned.
#[allow(clippy::too_many_arguments)]
pub fn simulate(
    mesh: &TetMesh,
    material: &Material,
    constraints: &Constraints,
    loads: &Loads,
    probes: &[ProbeSet],
    initial_velocity: Vector3<f64>,
    initial_displacement: Option<Vec<f64>>,
    settings: &SimulationSettings,
    mut progress: impl FnMut(usize, usize),
) -> Result<SimulationSummary> {
    if settings.every == 0 || settings.steps == 0 {
        return Err(Error::invalid_parameter(
            "steps/every",
            format!("{}/{}", settings.steps, settings.every),
            "must both be ≥ 1",
        ));
    }
    let system = Arc::new(LinearSystem::new(
        mesh,
        material,
        constraints,
        loads,
        settings.gravity,
        settings.mass,
        settings.damping,
    )?);
    let critical_step = match settings.mass {
        MassKind::Lumped => Some(critical_time_step(&system)?.dt),
        MassKind::Consistent => None,
    };
    let mut integrator = settings
        .method
        .integrator(Arc::clone(&system), settings.dt)?;
    let mut state = match initial_displacement {
        Some(u) => {
            if u.len() != system.free_count() {
                return Err(Error::invalid_parameter(
                    "initial displacement",
                    u.len(),
                    format!("needs {} free DOFs", system.free_count()),
                ));
            }
            State::released_from(u)
        }
        None => State::at_rest(system.free_count()),
    };
    for (i, &dof) in system.dofs().free_dofs().iter().enumerate() {
        state.velocity[i] = initial_velocity[dof % 3];
    }
    let dir = &settings.directory;
    let mut pvd = PvdCollection::new(dir.join(format!("{}.pvd", settings.stem)));
    let mut columns = vec!["time".to_string()];
    for p in probes {
        for axis in ["x", "y", "z"] {
            columns.push(format!("{}_u{axis}", p.name));
        }
    }
    columns.extend(
        [
            "kinetic",
            "elastic",
            "gravity_potential",
            "load_potential",
            "total",
            "wall_seconds_per_step",
        ]
        .map(String::from),
    );
    let mut csv = CsvSeries::new(dir.join(format!("{}.csv", settings.stem)), columns)?;
    let mut files = Vec::new();
    let e0 = system.energy(&state).total();
    let mut scale = None;
    let mut frame = |state: &State,
                     wall: f64,
                     files: &mut Vec<PathBuf>,
                     pvd: &mut PvdCollection,
                     csv: &mut CsvSeries|
     -> Result<()> {
        let u = system.dofs().expand(&state.displacement);
        let mut v = vec![0.0; u.len()];
        for (&dof, value) in system.dofs().free_dofs().iter().zip(&state.velocity) {
            v[dof] = *value;
        }
        let index = state.steps / settings.every;
        if settings.vtu {
            let path = dir.join(format!("{}_{index:05}.vtu", settings.stem));
            write_result_vtu(&path, mesh, material, &u, Some(&v))?;
            pvd.push(state.time, &path)?;
            files.push(path);
        }
        if settings.csv {
            let energy = system.energy(state);
            let mut row = vec![state.time];
            for p in probes {
                let m = p
                    .nodes
                    .iter()
                    .map(|&n| Vector3::new(u[3 * n], u[3 * n + 1], u[3 * n + 2]))
                    .sum::<Vector3<f64>>()
                    / p.nodes.len().max(1) as f64;
                row.extend([m.x, m.y, m.z]);
            }
            row.extend([
                energy.kinetic,
                energy.elastic,
                energy.gravity_potential,
                energy.load_potential,
                energy.total(),
                wall,
            ]);
            csv.push(&row)?;
            csv.write()?;
        }
        if settings.png {
            let deformation_scale =
                *scale.get_or_insert_with(|| auto_deformation_scale(mesh, &u).max(1.0));
            let magnitude = displacement_magnitude(&u);
            let image = render(
                mesh,
                &u,
                &Field::Nodes {
                    name: "|u| (m)",
                    values: &magnitude,
                },
                &RenderOptions {
                    title: format!("{} ({})", settings.stem, integrator_name(settings.method)),
                    subtitle: format!(
                        "t = {:.4e} s, displacement ×{deformation_scale:.0}",
                        state.time
                    ),
                    deformation_scale,
                    ..RenderOptions::default()
                },
            )?;
            let path = dir.join(format!("{}_{index:05}.png", settings.stem));
            image.write_png(&path)?;
            files.push(path);
        }
        Ok(())
    };
    frame(&state, 0.0, &mut files, &mut pvd, &mut csv)?;
    let clock = Instant::now();
    let mut since_frame = Instant::now();
    let mut output_seconds = 0.0;
    let mut outcome = Ok(());
    for step in 1..=settings.steps {
        if let Err(e) = integrator.step(&mut state) {
            outcome = Err(e);
            break;
        }
        progress(step, settings.steps);
        if step % settings.every == 0 || step == settings.steps {
            let wall = since_frame.elapsed().as_secs_f64() / settings.every as f64;
            let writing = Instant::now();
            frame(&state, wall, &mut files, &mut pvd, &mut csv)?;
            output_seconds += writing.elapsed().as_secs_f64();
            since_frame = Instant::now();
        }
    }
    let stepping_seconds = clock.elapsed().as_secs_f64() - output_seconds;
    if settings.csv {
        files.push(csv.path().to_path_buf());
    }
    if settings.vtu {
        files.push(pvd.path().to_path_buf());
    }
    outcome?;
    let u = system.dofs().expand(&state.displacement);
    Ok(SimulationSummary {
        steps: state.steps,
        time: state.time,
        critical_step,
        stepping_seconds,
        seconds_per_step: stepping_seconds / state.steps.max(1) as f64,
        files,
        probes: probes
            .iter()
            .map(|p| {
                (
                    p.name.clone(),
                    p.nodes
                        .iter()
                        .map(|&n| Vector3::new(u[3 * n], u[3 * n + 1], u[3 * n + 2]))
                        .sum::<Vector3<f64>>()
                        / p.nodes.len().max(1) as f64,
                )
            })
            .collect(),
        energy: (e0, system.energy(&state).total()),
    })
}

fn integrator_name(method: Method) -> &'static str {
    match method {
        Method::BackwardEuler => "backward Euler",
        Method::Newmark => "Newmark",
        Method::Explicit => "explicit",
    }
}
