//! The static scene's entry: a scene with `analysis.accuracy` goes to the accuracy search
//! (`accuracy.rs`, which solves through `run.rs`), any other to one solve (`run.rs`).

use tetfem::base::error::{Error, Result};
use tetfem::fe::element::Tet10;
use tetfem::mesh::Tet4;
use tetfem::post::output::OutputLock;

use super::run::{RunOptions, RunSummary, run_static_on};
use super::{Analysis, Scene};

/// [`run_static_with`] with default options.
pub fn run_static(scene: &Scene) -> Result<RunSummary> {
    run_static_with(scene, &RunOptions::default())
}

/// Builds and solves a static scene, then writes what its `[output]` asks for into its output
/// folder: `<stem>.vtu` (displacement, |u|, von Mises, strain energy density) with a one-frame
/// `<stem>.pvd`, `<stem>_probes.csv`, `<stem>.png`, and `<stem>_summary.json`.
///
/// Writing files, it first takes the folder's [`OutputLock`] (before building anything): another
/// run writing there is an [`Error::OutputLocked`]; a lock left by a killed run is taken over,
/// with a warning in the summary.
pub fn run_static_with(scene: &Scene, options: &RunOptions) -> Result<RunSummary> {
    scene.require_tetfem_engine()?;
    if !matches!(scene.analysis(), Analysis::Static) {
        return Err(Error::Scene {
            source_name: scene.source_name().to_string(),
            key: "analysis.type".into(),
            line: 0,
            message: "this scene is not static; run_static solves static scenes only".into(),
        });
    }
    let lock = match options.no_files {
        true => None,
        false => Some(OutputLock::acquire(&scene.output().directory)?),
    };
    if scene.formulation() == super::Formulation::Mixed {
        return super::formulation::run_mixed(scene, options, lock);
    }
    if let Some(target) = scene.accuracy() {
        return super::accuracy::run_accuracy(scene, options, lock, target);
    }
    match scene.order() {
        2 => run_static_on::<Tet10>(scene, options, lock),
        _ => run_static_on::<Tet4>(scene, options, lock),
    }
}
