//! `analysis.formulation`: the plain displacement element, or the mixed displacement–pressure
//! one ([`tetfem::MixedStaticSolver`]: Taylor–Hood P2–P1 on 10-node tets, stabilized P1–P1 on
//! 4-node tets) for nearly incompressible materials,
//! checked once when the scene is read, and the mixed static run with its outputs (the
//! pressure as a point field, the stress tensors' mean part from the solved pressure).

use std::path::PathBuf;
use std::time::Instant;

use tetfem::analysis::Combination;
use tetfem::analysis::mixed_analysis::MixedStaticElement;
use tetfem::base::error::{Error, Result};
use tetfem::base::warning::Warning;
use tetfem::fe::element::{Tet4, Tet10};
use tetfem::mesh::NodeList;
use tetfem::model::ModelMap;
use tetfem::post::output::fields::displacement_magnitude;
use tetfem::post::output::{FrameArrays, OutputLock, PvdCollection};
use tetfem::{MixedStaticSolution, TetMaterials, solve_static_mixed_model};

use super::run::{
    RunOptions, RunSummary, StaticNewton, StaticReport, StaticSolve, report_static,
    static_frame_arrays, write_static_probe_csv,
};
use super::{BuiltScene, Scene, SceneElement};
use crate::png_frames::{StaticLook, static_picture};

pub use tetfem::analysis::combination::Formulation;

/// What a mixed scene needs, said in the error of a scene that lacks it.
const MIXED_NEEDS: &str = "formulation = \"mixed\" is for static scenes with the linear, the \
                           Neo-Hookean or the corotational model (4-node or 10-node tets), and \
                           dynamic \
                           (backward_euler, newmark) and modal scenes with the linear model and \
                           mass = \"consistent\" (4-node or 10-node tets; fixed supports, \
                           constant loads, no probes, time_tolerance or checkpoints), dynamic \
                           ones also with the Neo-Hookean or the corotational model in \
                           backward_euler (4-node or \
                           10-node tets; undamped; still [[obstacles]] allowed, with friction \
                           too), on tetfem's own engine, without other obstacles, accuracy or \
                           point probes";

impl Scene {
    /// The scene's formulation (checked when the scene was read).
    pub fn formulation(&self) -> Formulation {
        self.check_formulation().unwrap_or_default()
    }

    /// `analysis.formulation`: its value, and for `"mixed"` the rest of the scene it needs;
    /// an error naming the key, the value and what is allowed otherwise.
    pub(crate) fn check_formulation(&self) -> Result<Formulation> {
        let Some(spanned) = &self.spec.analysis else {
            return Ok(Formulation::Displacement);
        };
        let Some(name) = &spanned.get_ref().formulation else {
            return Ok(Formulation::Displacement);
        };
        let error = |message: String| self.error("analysis.formulation", &spanned.span(), message);
        match name.as_str() {
            "displacement" => Ok(Formulation::Displacement),
            "mixed" => {
                // The physics' refusals are the library's ([`Combination::check`]); the scene
                // names its own key for the pair, and refuses what only its run lacks.
                let combination = Combination {
                    formulation: Formulation::Mixed,
                    ..self.combination()
                };
                let refusal = match combination.check() {
                    Err(Error::InvalidParameter { name, .. }) => {
                        Some(match name.trim_start_matches("formulation mixed with ") {
                            "analysis" => "method = \"explicit\"".to_string(),
                            "model" => format!("model = \"{}\"", self.model().name()),
                            "element order" => format!("[mesh] order = {}", self.order()),
                            "obstacles" => "[[obstacles]]".to_string(),
                            "moving supports" => {
                                "constraints that move (amplitude, linear_field or rigid_motion) \
                                 with a nonlinear model or in a dynamic or modal analysis"
                                    .to_string()
                            }
                            "loads that follow an amplitude" => {
                                "loads with an amplitude in a dynamic analysis".to_string()
                            }
                            other => other.to_string(),
                        })
                    }
                    Err(other) => return Err(other),
                    Ok(_) => None,
                };
                let refusal = refusal.or_else(|| {
                    if let Some(what) = self.mixed_dynamics_refusal() {
                        Some(what)
                    } else if self.accuracy().is_some() {
                        Some("analysis.accuracy".to_string())
                    } else if self.engine().kind != super::EngineKind::Tetfem {
                        // The distributed engine assembles the displacement element only.
                        Some("engine = \"petsc\"".to_string())
                    } else if self.spec.probes.iter().any(|p| p.get_ref().at.is_some()) {
                        // A point probe reports the displacement element's stress there.
                        Some("a point probe ([[probes]] at)".to_string())
                    } else {
                        None
                    }
                });
                match refusal {
                    Some(what) => Err(error(format!(
                        "\"mixed\" cannot be combined with {what}: {MIXED_NEEDS}"
                    ))),
                    None => Ok(Formulation::Mixed),
                }
            }
            other => Err(error(format!(
                "unknown formulation '{other}': use \"displacement\" (the default) or \"mixed\" \
                 ({MIXED_NEEDS})"
            ))),
        }
    }
}

/// A mixed static scene: build on the scene's tets (`[mesh] order`: 4-node stabilized P1–P1 or
/// 10-node Taylor–Hood), solve for displacement and pressure (the linear
/// model in one saddle solve, the Neo-Hookean and the corotational one by Newton's load steps of
/// `analysis.load_steps`/`newton_tolerance`), report as
/// a displacement run does (no self-estimated error: the ZZ estimate's stress is the
/// displacement element's), and write `<stem>.vtu` with the point field `pressure` (Pa),
/// `.pvd`, probes CSV, PNG and summary as asked.
pub(crate) fn run_mixed(
    scene: &Scene,
    options: &RunOptions,
    lock: Option<OutputLock>,
) -> Result<RunSummary> {
    if scene.order() == 1 {
        run_mixed_on::<Tet4>(scene, options, lock)
    } else {
        run_mixed_on::<Tet10>(scene, options, lock)
    }
}

/// [`run_mixed`] on element `E`.
fn run_mixed_on<E: SceneElement + MixedStaticElement>(
    scene: &Scene,
    options: &RunOptions,
    lock: Option<OutputLock>,
) -> Result<RunSummary> {
    let clock = Instant::now();
    let built = scene.build_as::<E>()?;
    let build_seconds = clock.elapsed().as_secs_f64();
    let clock = Instant::now();
    let loads = built.static_load()?;
    let newton = scene.static_newton();
    let outcome = solve_static_mixed_model(
        &built.mesh,
        &built.materials,
        scene.model(),
        (&built.constraints, scene.combination().moving_supports),
        &loads,
        newton,
    )?;
    let solution = outcome.solution;
    let solved = StaticSolve {
        displacement: solution.displacement.clone(),
        relative_residual: solution.relative_residual,
        free_dofs: outcome.free_dofs,
        phases: None,
        factor_len: outcome.factor_len,
        friction_forces: Vec::new(),
        barrier: None,
        newton: outcome.newton_iterations.map(|iterations| StaticNewton {
            load_steps: newton.load_steps,
            iterations,
            tolerance: newton.tolerance,
        }),
        reactions: solution.reactions.clone(),
    };
    let solve_seconds = clock.elapsed().as_secs_f64();
    // Von Mises depends on the deviatoric stress only, which the displacement gives: 2μ dev ε
    // (linear), μ·J^(−5/3)·dev(F·Fᵀ) (Neo-Hookean: the displacement model's μ/J·dev(F·Fᵀ)
    // differs by J^(2/3) = 1 + O(p/κ)), 2μ·R·dev ε·Rᵀ (corotational: the displacement
    // model's exactly, its λ·tr ε being the mean part).
    let model = ModelMap::new(scene.model(), &built.materials);
    let StaticReport {
        mut summary,
        von_mises,
        ..
    } = report_static(
        scene,
        &built,
        &model,
        &solved,
        None,
        [build_seconds, solve_seconds],
        lock.as_ref().and_then(OutputLock::warning),
    )?;
    summary.estimated_error = None;
    // The material's near-incompressibility warning is about the displacement element's
    // locking, which the mixed one does not have.
    let locking: Vec<String> = built
        .materials
        .material_list()
        .iter()
        .flat_map(|m| m.warnings())
        .filter(|w| matches!(w, Warning::NearlyIncompressible { .. }))
        .map(|w| w.to_string())
        .collect();
    summary.warnings.retain(|w| !locking.contains(w));
    // P2–P1's stability condition; the stabilized P1–P1 has none.
    summary.warnings.extend(
        tetfem::analysis::mixed_statics::mixed_mesh_warnings(&built.mesh)?
            .iter()
            .map(|w| w.to_string()),
    );
    if !options.no_files {
        let clock = Instant::now();
        summary.files = write_mixed_outputs(
            scene, &built, &model, &solution, &von_mises, options, &summary,
        )?;
        summary.output_seconds = clock.elapsed().as_secs_f64();
    }
    Ok(summary)
}

/// The mixed run's files (see [`run_mixed`]).
fn write_mixed_outputs<E: SceneElement>(
    scene: &Scene,
    built: &BuiltScene<E>,
    model: &ModelMap,
    solution: &MixedStaticSolution,
    von_mises: &[f64],
    options: &RunOptions,
    summary: &RunSummary,
) -> Result<Vec<PathBuf>> {
    let out = scene.output();
    let dir = &out.directory;
    let u = &solution.displacement;
    let mut files = Vec::new();
    if out.vtu {
        let vtu = dir.join(format!("{}.vtu", out.stem));
        let mut arrays = static_frame_arrays(
            scene,
            built,
            model,
            u,
            None,
            Some(&solution.reactions),
            None,
        )?;
        mixed_arrays(&mut arrays, built, &solution.pressure);
        arrays.writer(&built.mesh)?.write(&vtu)?;
        let mut pvd = PvdCollection::new(dir.join(format!("{}.pvd", out.stem)));
        pvd.push(0.0, &vtu)?;
        files.push(vtu);
        files.push(pvd.path().to_path_buf());
    }
    if out.csv && !built.probes.is_empty() {
        let path = dir.join(format!("{}_probes.csv", out.stem));
        files.push(write_static_probe_csv(path, built, summary)?);
    }
    if out.png || options.force_png {
        let path = dir.join(format!("{}.png", out.stem));
        let look = StaticLook {
            title: &summary.title,
            magnitude: &displacement_magnitude(u),
            von_mises,
            path: &path,
        };
        files.push(static_picture(scene, &built.mesh, u, &look)?);
    }
    crate::run::finish_with_summary(dir, &out.stem, summary, files)
}

/// The displacement element's arrays made the mixed solution's: the point field `pressure`
/// (Pa) added; the stress tensors' mean part replaced by −p (`stress`: each tet's mean corner
/// pressure, `stress_nodal`: the node's), since λ·tr ε is what locks; the arrays built from
/// that mean part (principal stresses, strain energy density) dropped rather than left wrong.
fn mixed_arrays<E: SceneElement>(
    arrays: &mut FrameArrays,
    built: &BuiltScene<E>,
    pressure: &[f64],
) {
    let tet_pressure: Vec<f64> = built
        .mesh
        .tets()
        .iter()
        .map(|tet| tet.corners().iter().map(|&n| pressure[n]).sum::<f64>() / 4.0)
        .collect();
    let replace_mean = |values: &mut [f64], pressures: &[f64]| {
        for (tensor, p) in values.chunks_exact_mut(6).zip(pressures) {
            let mean = (tensor[0] + tensor[1] + tensor[2]) / 3.0;
            for component in &mut tensor[..3] {
                *component += -mean - p;
            }
        }
    };
    for (name, _, values) in &mut arrays.point_fields {
        if name == "stress_nodal" {
            replace_mean(values, pressure);
        }
    }
    for (name, _, values) in &mut arrays.cell_fields {
        if name == "stress" {
            replace_mean(values, &tet_pressure);
        }
    }
    arrays.cell_fields.retain(|(name, _, _)| {
        !(name.starts_with("principal_stress") || name == "strain_energy_density")
    });
    arrays
        .point_fields
        .push(("pressure".to_string(), 1, pressure.to_vec()));
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;

    /// A 1 × 0.5 × 0.5 m rubber block (ν = 0.4999) on rollers at x = 0, y = 0, z = 0, pulled by
    /// a uniform traction of 1 kPa on x = 1: uniaxial stress, an affine displacement.
    const BLOCK: &str = r#"
[mesh]
order = 2
[mesh.box]
max = [1.0, 0.5, 0.5]
cells = [2, 1, 1]
[material]
youngs_modulus = 1e6
poisson_ratio = 0.4999
density = 1000.0
[[constraints]]
where = { plane = { axis = "x", at = 0.0 } }
fix = ["x"]
[[constraints]]
where = { plane = { axis = "y", at = 0.0 } }
fix = ["y"]
[[constraints]]
where = { plane = { axis = "z", at = 0.0 } }
fix = ["z"]
[[loads]]
where = { plane = { axis = "x", at = 1.0 } }
traction = [1000.0, 0.0, 0.0]
[analysis]
formulation = "mixed"
[output]
vtu_format = "ascii"
"#;

    fn parse(text: &str) -> Result<Scene> {
        Scene::parse(text, "block.toml", Path::new("."))
    }

    #[test]
    fn a_mixed_block_in_uniaxial_tension_is_exact_and_writes_its_pressure() {
        // Taylor–Hood on 10-node tets, then the stabilized P1–P1 on 4-node tets: both pass
        // the patch test (the stabilization vanishes for a constant pressure).
        for order in ["order = 2\n", "order = 1\n"] {
            mixed_block_in_uniaxial_tension(&BLOCK.replace("order = 2\n", order));
        }
    }

    fn mixed_block_in_uniaxial_tension(text: &str) {
        let directory = std::env::temp_dir().join(format!("tetfem_mixed_{}", std::process::id()));
        let mut scene = parse(text).unwrap();
        assert_eq!(scene.formulation(), Formulation::Mixed);
        scene.set_output_directory(directory.clone());
        let summary = super::super::run_static(&scene).unwrap();
        // u_x(1) = σL/E = 1e-3 m exactly (the field is affine; the lateral contraction
        // ν·σ/E·0.5 = 2.5e-4 m at the far corner adds to |u|): round-off only.
        let exact = (1e-3f64.powi(2) + 2.0 * (0.4999e-3 * 0.5f64).powi(2)).sqrt();
        assert!(
            (summary.max_displacement - exact).abs() < 1e-9 * exact,
            "{summary:?}"
        );
        // σ_vM = |σ_xx| = 1 kPa in every tet.
        assert!(
            (summary.max_von_mises - 1000.0).abs() < 1e-6 * 1000.0,
            "{summary:?}"
        );
        // The .vtu's pressure is −σ_xx/3 at every node.
        let path = summary
            .files
            .iter()
            .find(|f| f.extension().is_some_and(|e| e == "vtu"));
        let vtu = std::fs::read_to_string(path.expect("a .vtu among the files")).unwrap();
        let start = vtu.find("Name=\"pressure\"").expect("a pressure array");
        let body = &vtu[start..];
        let body = &body[body.find('>').unwrap() + 1..body.find("</DataArray>").unwrap()];
        let values: Vec<f64> = body
            .split_whitespace()
            .map(|v| v.parse().unwrap())
            .collect();
        assert_eq!(values.len(), summary.nodes);
        for p in values {
            // Round-off of a system with κ/μ = 5e3.
            assert!((p + 1000.0 / 3.0).abs() < 1e-6 * 1000.0, "pressure {p}");
        }
        let _ = std::fs::remove_dir_all(directory);
    }

    #[test]
    fn a_mixed_neo_hookean_block_in_small_tension_is_the_linear_one() {
        let text = BLOCK.replace(
            "formulation = \"mixed\"",
            "formulation = \"mixed\"\nmodel = \"neo-hookean\"\nload_steps = 2",
        );
        // Taylor–Hood (10-node), then the stabilized P1–P1 (4-node).
        mixed_neo_hookean_block(&text, true, "neo_hookean");
        let p1 = text.replace("order = 2\n", "order = 1\n");
        mixed_neo_hookean_block(&p1, false, "neo_hookean");
    }

    #[test]
    fn a_mixed_corotational_block_in_small_tension_is_the_linear_one() {
        let text = BLOCK.replace(
            "formulation = \"mixed\"",
            "formulation = \"mixed\"\nmodel = \"corotational\"\nload_steps = 2",
        );
        // The corotational stress is Hooke's in the rotated frame: at a stretch of 1e-3 the
        // same bound as the Neo-Hookean one's holds.
        mixed_neo_hookean_block(&text, true, "corotational");
        let p1 = text.replace("order = 2\n", "order = 1\n");
        mixed_neo_hookean_block(&p1, false, "corotational");
    }

    /// [`a_mixed_neo_hookean_block_in_small_tension_is_the_linear_one`] (and the corotational
    /// one) on `text`;
    /// `boffi_warning`: whether P2–P1's stability warning is expected; `model` names the output
    /// folder (the tests run in parallel in one process: each its own folder and lock).
    fn mixed_neo_hookean_block(text: &str, boffi_warning: bool, model: &str) {
        let mut scene = parse(text).unwrap();
        assert_eq!(scene.formulation(), Formulation::Mixed);
        let directory =
            std::env::temp_dir().join(format!("tetfem_mixed_{model}_{}", std::process::id()));
        scene.set_output_directory(directory.clone());
        let summary = super::super::run_static(&scene).unwrap();
        // The linear answer (the uniaxial test above) to the strain's order, 1e-3: the
        // Neo-Hookean stress at a stretch of 1e-3 differs from Hooke's by that fraction.
        let exact = (1e-3f64.powi(2) + 2.0 * (0.4999e-3 * 0.5f64).powi(2)).sqrt();
        assert!(
            (summary.max_displacement - exact).abs() < 3e-3 * exact,
            "{summary:?}"
        );
        assert!(
            (summary.max_von_mises - 1000.0).abs() < 3e-3 * 1000.0,
            "{summary:?}"
        );
        // The block is one cell thick: no tet has a corner inside it, which P2–P1 needs and
        // the stabilized P1–P1 does not.
        assert_eq!(
            summary.warnings.iter().any(|w| w.contains("Boffi")),
            boffi_warning,
            "{:?}",
            summary.warnings
        );
        let _ = std::fs::remove_dir_all(directory);
    }

    #[test]
    fn mixed_is_refused_where_it_does_not_apply_naming_the_key() {
        for (from, to, culprit) in [
            (
                "formulation = \"mixed\"",
                "formulation = \"mixed\"\nmodel = \"st-venant-kirchhoff\"",
                "model = \"st-venant-kirchhoff\"",
            ),
            (
                "formulation = \"mixed\"",
                "formulation = \"mixed\"\ntype = \"modal\"",
                "modal",
            ),
            ("\"mixed\"", "\"hybrid\"", "unknown formulation 'hybrid'"),
            ("[mesh]", "engine = \"petsc\"\n[mesh]", "engine = \"petsc\""),
        ] {
            let message = parse(&BLOCK.replace(from, to)).unwrap_err().to_string();
            assert!(
                message.contains("analysis.formulation") && message.contains(culprit),
                "{culprit}: {message}"
            );
        }
        let plain =
            parse(&BLOCK.replace("formulation = \"mixed\"", "formulation = \"displacement\""));
        assert_eq!(plain.unwrap().formulation(), Formulation::Displacement);
    }
}
