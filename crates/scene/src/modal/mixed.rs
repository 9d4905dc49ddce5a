//! The mixed formulation's modal scenes: `formulation = "mixed"` with `type = "modal"` and the
//! consistent mass, on 4-node tets (stabilized P1–P1) or 10-node tets (Taylor–Hood P2–P1,
//! `[mesh] order = 2`). The library computes
//! ([`mixed_modes_model`]); this file writes `<stem>_modes.pvd` with `mode_shape` and
//! `pressure` per mode, `<stem>_modes.csv` and the summary.

use std::path::PathBuf;
use std::time::Instant;

use tetfem::Problem;
use tetfem::analysis::mixed_analysis::{MixedStaticElement, mixed_modes_model};
use tetfem::analysis::modal::effective_mass_fractions;
use tetfem::base::error::Result;
use tetfem::fe::element::{Tet4, Tet10};
use tetfem::post::output::{OutputLock, PvdCollection, VtuWriter};

use super::ModalSummary;
use crate::mixed_dynamics::mixed_warnings;
use crate::{ModalSettings, Scene, SceneElement};

/// A mixed modal scene (see the [module](self) docs): the lowest modes of K_eff·φ = ω²·M·φ.
pub(crate) fn run_mixed_modal(
    scene: &Scene,
    settings: ModalSettings,
    lock: Option<OutputLock>,
) -> Result<ModalSummary> {
    if scene.order() == 1 {
        run_mixed_modal_on::<Tet4>(scene, settings, lock)
    } else {
        run_mixed_modal_on::<Tet10>(scene, settings, lock)
    }
}

/// [`run_mixed_modal`] on element `E`.
fn run_mixed_modal_on<E: SceneElement + MixedStaticElement>(
    scene: &Scene,
    settings: ModalSettings,
    lock: Option<OutputLock>,
) -> Result<ModalSummary> {
    let clock = Instant::now();
    let built = scene.build_as::<E>()?;
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
    let (rows, cumulative) = super::mode_rows(&mixed.modes, &fractions);
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

/// The mode files (see the [module](self) docs).
fn write_mixed_modes<E: SceneElement>(
    scene: &Scene,
    mesh: &tetfem::TetMesh<E>,
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
    super::write_modes_table_and_summary(scene, summary, files)
}
