//! `tetfem.run_scene`: a TOML scene run by the command-line tool's own runner
//! (`tetfem_scene`), its summary handed back as a dict.

use std::ops::ControlFlow;
use std::path::PathBuf;

use pyo3::prelude::*;
use tetfem_scene::{
    Analysis, DynamicOverrides, RunOptions, Scene, run_dynamic_scene, run_modal_scene,
    run_static_with,
};

use crate::interrupt::detach_interruptible;

/// Runs a scene file (static, dynamic or modal) exactly as ``tetfem run PATH --json`` does and returns
/// its JSON summary as a dict (counts, timings in s, energies in J, each probe's mean
/// displacement in m, the files written, warnings). Outputs go to the scene's folder, or to
/// ``output_dir``; ``write_files=False`` writes nothing. GIL released while it runs. Raises
/// ``SceneError`` for an invalid scene (naming the line and key). Ctrl-C raises
/// ``KeyboardInterrupt``: a dynamic run stops at the next step boundary as the command-line
/// tool's does (the frames and CSV rows written so far complete, a checkpoint written if the
/// scene asks for them), a solve between two of its iterations.
#[pyfunction]
#[pyo3(signature = (path, output_dir = None, write_files = true))]
pub fn run_scene<'py>(
    py: Python<'py>,
    path: PathBuf,
    output_dir: Option<PathBuf>,
    write_files: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let json = detach_interruptible(py, || -> tetfem::Result<String> {
        let mut scene = Scene::load(&path)?;
        if let Some(dir) = output_dir {
            scene.set_output_directory(dir);
        }
        Ok(match scene.analysis() {
            Analysis::Static => {
                let options = RunOptions {
                    no_files: !write_files,
                    ..RunOptions::default()
                };
                run_static_with(&scene, &options)?.to_json()
            }
            Analysis::Dynamic(_) => run_dynamic_scene(
                &scene,
                &DynamicOverrides::default(),
                write_files,
                false,
                // The runner's own stop hook (the CLI's Ctrl-C), fed by the interrupt test
                // that `detach_interruptible` installs.
                &mut |_, _| match tetfem::linalg::interrupt::poll(String::new) {
                    Ok(()) => ControlFlow::Continue(()),
                    Err(_) => ControlFlow::Break(()),
                },
            )?
            .to_json(),
            Analysis::Modal(_) => run_modal_scene(&scene, !write_files)?.to_json(),
        })
    })?;
    py.import("json")?.call_method1("loads", (json,))
}
