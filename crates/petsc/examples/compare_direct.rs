//! Compares a displacement written by `tetfem-petsc --displacement FILE` with tetfem's
//! single-process direct solve (sparse Cholesky) of the same scene:
//!
//! ```text
//! cargo run --release -p tetfem-petsc --example compare_direct -- SCENE.toml FILE
//! ```
//!
//! Prints ‖u_petsc − u_direct‖₂ / ‖u_direct‖₂, the largest difference, and the direct solve's
//! wall time and peak memory. Needs no PETSc (it reads the file).

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use tetfem::linalg::linear_solver::SolverOptions;
use tetfem::{LinearMethod, StaticSolver};
use tetfem_scene::Scene;

fn run(scene: PathBuf, file: PathBuf) -> Result<(), String> {
    let text = std::fs::read_to_string(&file).map_err(|e| format!("{}: {e}", file.display()))?;
    let petsc: Vec<f64> = text
        .lines()
        .enumerate()
        .map(|(i, l)| {
            l.parse().map_err(|e| {
                format!(
                    "{} line {}: {l:?} is not a number ({e})",
                    file.display(),
                    i + 1
                )
            })
        })
        .collect::<Result<_, _>>()?;
    let built = Scene::load(&scene)
        .and_then(|s| s.build())
        .map_err(|e| e.to_string())?;
    let clock = Instant::now();
    let options = SolverOptions {
        method: LinearMethod::Direct,
        ..Default::default()
    };
    let direct =
        StaticSolver::with_options(&built.mesh, &built.materials, &built.constraints, options)
            .and_then(|mut s| s.solve(&built.loads))
            .map_err(|e| e.to_string())?
            .displacement;
    let seconds = clock.elapsed().as_secs_f64();
    if direct.len() != petsc.len() {
        return Err(format!(
            "{} holds {} values; the scene has {} DOFs",
            file.display(),
            petsc.len(),
            direct.len()
        ));
    }
    let diff: f64 = petsc
        .iter()
        .zip(&direct)
        .map(|(a, b)| (a - b).powi(2))
        .sum();
    let norm: f64 = direct.iter().map(|b| b * b).sum();
    let largest = petsc
        .iter()
        .zip(&direct)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    let peak = std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("VmHWM:"))
                .map(|v| v.trim().to_string())
        })
        .unwrap_or_else(|| "unknown".into());
    println!(
        "{} DOFs: relative difference {:.3e} (2-norm), largest {:.3e} m; direct solve {seconds:.3} s, peak memory {peak}",
        direct.len(),
        (diff / norm).sqrt(),
        largest
    );
    Ok(())
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().collect();
    let [_, scene, file] = args.as_slice() else {
        eprintln!("usage: compare_direct SCENE.toml DISPLACEMENT_FILE");
        return ExitCode::FAILURE;
    };
    match run(PathBuf::from(scene), PathBuf::from(file)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
