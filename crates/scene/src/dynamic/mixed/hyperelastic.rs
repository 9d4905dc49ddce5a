//! The mixed formulation's hyperelastic dynamic scenes: `formulation = "mixed"`, `type =
//! "dynamic"`, `model = "neo_hookean"` or `"corotational"`, `method = "backward_euler"`, on
//! 10-node tets
//! (Taylor–Hood P2–P1) or 4-node ones (`[mesh] order = 1`: the stabilized P1–P1), with or without
//! still `[[obstacles]]`, with or without friction (the library's
//! [`MixedNonlinearEuler`](tetfem::analysis::mixed_nonlinear_dynamics::MixedNonlinearEuler);
//! what combines is the library's [`Combination`](tetfem::analysis::combination::Combination),
//! checked when the scene was read). Writes what the linear mixed run writes (frames with the
//! point field `pressure`, the CSV, the summary), and per state the volume change
//! ∫J dV/V₀ − 1, the smallest gap to an obstacle and the barrier's energy; the summary's
//! `volume_change` is the largest |∫J dV/V₀ − 1| of the run.

use std::ops::ControlFlow;
use std::time::Instant;

use tetfem::Loads;
use tetfem::analysis::mixed_analysis::{MixedStaticElement, mixed_nonlinear_euler_model};
use tetfem::analysis::mixed_nonlinear_dynamics::{MixedBody, MixedNonlinearEuler};
use tetfem::base::error::Result;
use tetfem::fe::element::{Tet4, Tet10};
use tetfem::post::output::OutputLock;

use super::super::{DynamicOverrides, DynamicSummary, EnergyTerms};
use super::{
    LoopOutputs, csv_row, csv_start, gravity_and_loads, pressure_range, step_and_count,
    summary_base, write_outputs,
};
use crate::dynamic_contact::ContactForceHistory;
use crate::{DynamicSettings, Scene, SceneElement};

/// The hyperelastic (Neo-Hookean or corotational) mixed dynamic scene (see the [module](self)
/// docs): as [`run_mixed_dynamic`](super::run_mixed_dynamic), from the undeformed state with
/// `initial_velocity`.
pub(super) fn run_mixed_hyperelastic(
    scene: &Scene,
    settings: &DynamicSettings,
    overrides: &DynamicOverrides,
    lock: Option<OutputLock>,
    progress: &mut dyn FnMut(usize, usize) -> ControlFlow<()>,
) -> Result<DynamicSummary> {
    if scene.order() == 1 {
        run_on::<Tet4>(scene, settings, overrides, lock, progress)
    } else {
        run_on::<Tet10>(scene, settings, overrides, lock, progress)
    }
}

/// [`run_mixed_hyperelastic`] on element `E`.
fn run_on<E: SceneElement + MixedStaticElement + MixedBody>(
    scene: &Scene,
    settings: &DynamicSettings,
    overrides: &DynamicOverrides,
    lock: Option<OutputLock>,
    progress: &mut dyn FnMut(usize, usize) -> ControlFlow<()>,
) -> Result<DynamicSummary> {
    let (dt, steps) = step_and_count(overrides, settings)?;
    let clock = Instant::now();
    let built = scene.build_as::<E>()?;
    let mesh = &built.mesh;
    let (gravity, loads) = gravity_and_loads(&built)?;
    let mut run = mixed_nonlinear_euler_model(
        mesh,
        &built.materials,
        scene.model(),
        (&built.constraints, &loads),
        (dt, settings.newton_tolerance),
    )?;
    if scene.has_obstacles() {
        run = run.with_contact(crate::dynamic_contact::scene_contact(scene, &built)?)?;
    }
    let v0: Vec<f64> = (0..mesh.dof_count())
        .map(|dof| settings.initial_velocity[dof % 3])
        .collect();
    run = run.with_velocity(&v0)?;
    // A body with obstacles may be held by them alone (a dropped ball): the free body's step.
    let critical = crate::critical::critical_step_of_body(&built, scene.has_obstacles())?;
    let (critical, critical_source) = (critical.seconds, critical.source);
    let setup_seconds = clock.elapsed().as_secs_f64();
    let rest_volume = run.deformed_volume();
    let energy = |run: &MixedNonlinearEuler<E>| energy_terms(run, &gravity, &built.other_loads);
    let initial_energy = energy(&run)?;
    let mut outputs = LoopOutputs::new(scene, lock.is_some(), steps);
    let (header, mut probes) = csv_start(&built.probes);
    let mut rows = format!(
        "{},volume_change_1,smallest_gap_m,contact_energy_J\n",
        header.trim_end()
    );
    let mut forces = run.contact().map(ContactForceHistory::start);
    let (mut volume_change, mut most_iterations, mut last_step): (f64, usize, usize) = (0.0, 0, 0);
    for step in 0..=steps {
        if step > 0 {
            last_step = outputs.timed_step(step, || run.step())?;
            most_iterations = most_iterations.max(last_step);
        }
        let clock = Instant::now();
        let e = energy(&run)?;
        let pressure = run.pressure();
        let u = run.displacement().to_vec();
        let change = run.deformed_volume() / rest_volume - 1.0;
        volume_change = volume_change.max(change.abs());
        let mut row = String::new();
        csv_row(
            (&mut row, &mut probes),
            &built.probes,
            (run.time(), &e, pressure_range(&pressure)),
            &u,
        );
        let (gap, barrier) = contact_columns(&run, forces.as_deref_mut(), &u)?;
        rows.push_str(row.trim_end());
        rows.push_str(&format!(",{change:e},{gap:e},{barrier:e}\n"));
        outputs.after_step(step, clock, (mesh, run.time(), &u, &pressure), progress)?;
    }
    let final_energy = energy(&run)?;
    let mut summary = DynamicSummary {
        method: "backward-euler".into(),
        free_dofs: built.constraints.dof_count() - built.constraints.count(),
        dt,
        critical_step: critical,
        critical_step_source: critical_source,
        dt_over_critical: dt / critical,
        steps,
        end_time: run.time(),
        setup_seconds,
        initial_energy,
        final_energy,
        probes,
        newton: Some(tetfem::analysis::dynamics::NewtonStats {
            steps,
            total_iterations: run.iterations(),
            max_per_step: most_iterations,
            last_step,
            // Each iteration factors the saddle-point tangent once.
            factorizations: run.iterations(),
            ..Default::default()
        }),
        contact_forces: forces,
        volume_change: Some(volume_change),
        ..outputs.timings(summary_base(scene, &built, lock.as_ref())?)
    };
    if let Some(w) = outputs.writer {
        write_outputs(scene, w, &rows, &mut summary)?;
    }
    Ok(summary)
}

/// The CSV's smallest gap to an obstacle (m; ∞ without obstacles) and barrier energy (J) at
/// the full displacement `u`, recording the obstacles' forces in `forces`.
fn contact_columns<E: MixedBody>(
    run: &MixedNonlinearEuler<E>,
    forces: Option<&mut [ContactForceHistory]>,
    u: &[f64],
) -> Result<(f64, f64)> {
    let Some(contact) = run.contact() else {
        return Ok((f64::INFINITY, 0.0));
    };
    if let Some(f) = forces {
        ContactForceHistory::record(f, &contact.obstacle_forces(u)?, run.time());
    }
    Ok((contact.smallest_gap(u)?, contact.energy(u)?))
}

/// The energies of `run`'s state: ½vᵀMv, the stored energy
/// ([`MixedNonlinearEuler::elastic_energy`]), gravity's −f_g·u (`gravity` its nodal loads)
/// and the other loads' −f·u; the barrier's energy is the CSV's own column, as in the
/// displacement runs.
fn energy_terms<E: MixedBody>(
    run: &MixedNonlinearEuler<E>,
    gravity: &Loads,
    other: &Loads,
) -> Result<EnergyTerms> {
    let u = run.displacement();
    let work = |loads: &Loads| -> f64 {
        -(loads.as_slice().iter().zip(u))
            .map(|(f, x)| f * x)
            .sum::<f64>()
    };
    let (kinetic, elastic) = (run.kinetic_energy()?, run.elastic_energy());
    let (gravity_potential, load_potential) = (work(gravity), work(other));
    Ok(EnergyTerms {
        kinetic,
        elastic,
        gravity_potential,
        load_potential,
        total: kinetic + elastic + gravity_potential + load_potential,
    })
}
