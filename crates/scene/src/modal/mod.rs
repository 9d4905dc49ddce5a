//! Running a modal scene: the lowest natural frequencies and mode shapes K·φ = ω²·M·φ of the
//! constrained body, their effective modal masses, and the files a user opens.

mod mixed;

use std::path::PathBuf;
use std::time::Instant;

use super::{Analysis, ModalSettings, Scene, SceneElement};
use tetfem::analysis::Modal;
use tetfem::analysis::dynamics::LinearSystem;
use tetfem::base::error::{Error, Result};
use tetfem::fe::element::{ElementType, Tet10};
use tetfem::mesh::Tet4;
use tetfem::post::output::{OutputLock, PvdCollection, VtuWriter, write_atomically};

/// One mode of a modal run.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ModeRow {
    /// 1 for the lowest.
    pub mode: usize,
    /// Frequency f = ω/2π (Hz).
    pub frequency_hz: f64,
    /// Period 1/f (s).
    pub period_s: f64,
    /// Angular frequency ω (rad/s).
    pub omega_rad_per_s: f64,
    /// Effective modal mass fraction in x, y, z (dimensionless, see
    /// [`tetfem::analysis::modal::effective_mass_fractions`]).
    pub effective_mass_fraction: [f64; 3],
    /// The eigen-residual the mode was converged to (dimensionless, see
    /// [`tetfem::analysis::modal::Modes::residuals`]).
    pub residual: f64,
}

/// What a modal run did, for printing or as one JSON object (`--json`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ModalSummary {
    /// The scene's title.
    pub title: String,
    /// The scene file.
    pub scene: String,
    /// `"modal"`.
    pub analysis: String,
    /// `"lumped"` or `"consistent"`.
    pub mass: String,
    /// Node count.
    pub nodes: usize,
    /// Tet count.
    pub tets: usize,
    /// Free DOFs.
    pub free_dofs: usize,
    /// The modes, lowest first.
    pub modes: Vec<ModeRow>,
    /// Sum of the modes' effective mass fractions in x, y, z: how much of the body's mass the
    /// retained modes set in motion under a base excitation (engineering practice asks for 0.9;
    /// the mass the supports hold is never reached).
    pub cumulative_mass_fraction: [f64; 3],
    /// Subspace iterations used.
    pub iterations: usize,
    /// The explicit critical step, with `[output] critical_step = true` (else `None`).
    pub critical_step: Option<super::CriticalStepReport>,
    /// Wall time to build the mesh and constraints (s).
    pub build_seconds: f64,
    /// Wall time to assemble K and M and find the modes (s).
    pub solve_seconds: f64,
    /// Wall time to write the outputs (s).
    pub output_seconds: f64,
    /// Files written.
    pub files: Vec<PathBuf>,
    /// Warnings about the mesh and the material, as sentences.
    pub warnings: Vec<String>,
}

impl ModalSummary {
    /// The summary as one line of JSON, with a `units` table (the unit of every field that
    /// carries a quantity, keyed by its path).
    pub fn to_json(&self) -> String {
        super::units::to_json_with_units(self, super::units::MODAL)
    }
}

/// Builds a modal scene, finds its lowest modes, and (unless `no_files`) writes into its output
/// folder: `<stem>_modes.pvd` with one `.vtu` per mode (`<stem>_mode_01_12.345Hz.vtu`: the
/// shape as the point field `mode_shape`, scaled to a largest nodal amplitude of 1, and
/// `frequency_hz`, `period_s` and `mode` as field data; the `.pvd` numbers the modes 1, 2, … as
/// its time steps), `<stem>_modes.csv` and `<stem>_summary.json`.
///
/// Errors: the scene is not modal; `analysis.modes` above the free DOF count (naming the key
/// and its line, before the eigensolve); the output folder is locked by another run.
pub fn run_modal_scene(scene: &Scene, no_files: bool) -> Result<ModalSummary> {
    scene.require_tetfem_engine()?;
    let Analysis::Modal(settings) = *scene.analysis() else {
        return Err(Error::Scene {
            source_name: scene.source_name().to_string(),
            key: "analysis.type".into(),
            line: 0,
            message: "this scene is not modal; run_modal_scene solves modal scenes only".into(),
        });
    };
    let lock = match no_files {
        true => None,
        false => Some(OutputLock::acquire(&scene.output().directory)?),
    };
    if scene.formulation() == super::Formulation::Mixed {
        return mixed::run_mixed_modal(scene, settings, lock);
    }
    match scene.order() {
        2 => run_modal_on::<Tet10>(scene, settings, lock),
        _ => run_modal_on::<Tet4>(scene, settings, lock),
    }
}

/// [`run_modal_scene`] on the element of the scene's order, with the output lock (if any) held
/// (`None`: no files).
fn run_modal_on<E: SceneElement>(
    scene: &Scene,
    settings: ModalSettings,
    lock: Option<OutputLock>,
) -> Result<ModalSummary> {
    let no_files = lock.is_none();
    let clock = Instant::now();
    let built = scene.build_as::<E>()?;
    let build_seconds = clock.elapsed().as_secs_f64();
    let clock = Instant::now();
    // Obstacles never reach here (the combination rule refuses them with a modal analysis
    // when the scene is read); a nonlinear model is the library's named error.
    let definition = built.definition(scene.model(), None)?;
    let analysis = Modal::new(&definition, settings.mass)?;
    let system = analysis.system();
    let free = system.free_count();
    if settings.modes > free {
        let span = scene
            .spec()
            .analysis
            .as_ref()
            .map(|a| a.span())
            .unwrap_or_default();
        return Err(scene.error(
            "analysis.modes",
            &span,
            format!(
                "modes = {} is more than the {free} free DOFs of this mesh and its constraints",
                settings.modes
            ),
        ));
    }
    let outcome = analysis.solve(settings.modes)?;
    let fractions = analysis.effective_mass_fractions(&outcome)?;
    let modes = outcome.modes;
    let solve_seconds = clock.elapsed().as_secs_f64();
    let (rows, cumulative) = mode_rows(&modes, &fractions);
    let mut summary = ModalSummary {
        title: scene.title(),
        scene: scene.source_name().to_string(),
        analysis: "modal".into(),
        mass: format!("{:?}", settings.mass).to_lowercase(),
        nodes: built.mesh.node_count(),
        tets: built.mesh.tet_count(),
        free_dofs: free,
        modes: rows,
        cumulative_mass_fraction: cumulative,
        iterations: modes.iterations,
        critical_step: match scene.output().critical_step {
            true => Some(super::critical_step_of(&built)?),
            false => None,
        },
        build_seconds,
        solve_seconds,
        output_seconds: 0.0,
        files: Vec::new(),
        warnings: built
            .warnings()
            .iter()
            .map(ToString::to_string)
            .chain(lock.as_ref().and_then(OutputLock::warning))
            .collect(),
    };
    if !no_files {
        let clock = Instant::now();
        summary.files = write_modal_outputs(
            scene,
            &built.mesh,
            built.imported.as_ref(),
            system,
            &modes,
            &summary,
        )?;
        summary.output_seconds = clock.elapsed().as_secs_f64();
    }
    Ok(summary)
}

/// A mode shape on every node (zero on constrained DOFs), scaled so that its largest nodal
/// amplitude |φ_node| is 1 (the sign is the solver's).
pub fn normalized_shape(system: &LinearSystem, shape: &[f64]) -> Result<Vec<f64>> {
    let mut full = system.dofs().expand(shape)?;
    // expand() puts the prescribed values on constrained DOFs; a mode moves none of them.
    for (dof, value) in full.iter_mut().enumerate() {
        if system.dofs().free_index(dof).is_none() {
            *value = 0.0;
        }
    }
    let largest = full
        .chunks_exact(3)
        .map(|v| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt())
        .fold(0.0, f64::max);
    if largest > 0.0 {
        for value in &mut full {
            *value /= largest;
        }
    }
    Ok(full)
}

fn write_modal_outputs<E: ElementType>(
    scene: &Scene,
    mesh: &tetfem::TetMesh<E>,
    imported: Option<&tetfem::mesh::io::ImportedMesh<E>>,
    system: &LinearSystem,
    modes: &tetfem::analysis::modal::Modes,
    summary: &ModalSummary,
) -> Result<Vec<PathBuf>> {
    let out = scene.output();
    let dir = &out.directory;
    let mut files = Vec::new();
    if out.vtu {
        let mut pvd = PvdCollection::new(dir.join(format!("{}_modes.pvd", out.stem)));
        for (row, shape) in summary.modes.iter().zip(&modes.shapes) {
            let full = normalized_shape(system, shape)?;
            let vtu = dir.join(format!(
                "{}_mode_{:02}_{:.4}Hz.vtu",
                out.stem, row.mode, row.frequency_hz
            ));
            let mut writer = VtuWriter::new(mesh)
                .format(out.vtu_format.format())
                .field_data("mode", row.mode as f64)?
                .field_data("frequency_hz", row.frequency_hz)?
                .field_data("period_s", row.period_s)?
                .point_field("mode_shape", 3, &full)?;
            if let Some(imported) = imported {
                writer = writer
                    .point_id_field("original_node_id", &imported.node_ids)?
                    .cell_id_field("original_element_id", &imported.tet_ids)?;
            }
            writer.write(&vtu)?;
            pvd.push(row.mode as f64, &vtu)?;
            files.push(vtu);
        }
        files.push(pvd.path().to_path_buf());
    }
    write_modes_table_and_summary(scene, summary, files)
}

/// A modal run's `<stem>_modes.csv` (if the scene asks for CSV) and `<stem>_summary.json`
/// after the `files` already written (the mode shapes), all of them listed in the summary:
/// shared by the displacement and the mixed modal runs.
pub(crate) fn write_modes_table_and_summary(
    scene: &Scene,
    summary: &ModalSummary,
    mut files: Vec<PathBuf>,
) -> Result<Vec<PathBuf>> {
    let out = scene.output();
    let dir = &out.directory;
    if out.csv {
        // Written whole (the run is over): integers as integers, each unit in its header.
        let mut text = String::from(
            "mode,frequency_Hz,period_s,omega_rad_per_s,effective_mass_fraction_x,\
             effective_mass_fraction_y,effective_mass_fraction_z\n",
        );
        for row in &summary.modes {
            let [x, y, z] = row.effective_mass_fraction;
            text.push_str(&format!(
                "{},{:e},{:e},{:e},{x:e},{y:e},{z:e}\n",
                row.mode, row.frequency_hz, row.period_s, row.omega_rad_per_s
            ));
        }
        let csv = dir.join(format!("{}_modes.csv", out.stem));
        write_atomically(&csv, |w| w.write_all(text.as_bytes()))?;
        files.push(csv);
    }
    let json = dir.join(format!("{}_summary.json", out.stem));
    let mut with_files = summary.clone();
    with_files.files = files.clone();
    with_files.files.push(json.clone());
    write_atomically(&json, |w| writeln!(w, "{}", with_files.to_json()))?;
    files.push(json);
    Ok(files)
}

/// The summary's row of each mode (frequency, period, ω, effective mass fractions, residual)
/// and the fractions' sums over the modes in x, y, z: shared by the displacement and the mixed
/// modal runs.
pub(crate) fn mode_rows(
    modes: &tetfem::analysis::modal::Modes,
    fractions: &[[f64; 3]],
) -> (Vec<ModeRow>, [f64; 3]) {
    let rows: Vec<ModeRow> = (modes.omega.iter().zip(fractions))
        .zip(&modes.residuals)
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
    (rows, cumulative)
}
