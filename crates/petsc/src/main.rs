//! `tetfem-petsc`: a static linear scene solved, or a dynamic one integrated by backward Euler or
//! Newmark, by PETSc on every rank of `mpirun`.
//!
//! ```text
//! mpirun -n N tetfem-petsc SCENE.toml [--solver gamg|hypre|mumps] [--out DIR]
//!        [--displacement FILE] [--export DIR] [--json] [--quiet] [--no-files]
//!        [--vtu-format binary|ascii] [-petsc_option value ...]
//! ```
//!
//! The scene comes first; `--` options are tetfem-petsc's; every other argument goes to
//! PETSc's options database (e.g. `-ksp_monitor`, `-ksp_rtol 1e-10`, `-pc_gamg_threshold 0.05`)
//! and wins over the scene's `[petsc] options`, which win over the preset's (`--solver`, else
//! the scene's `[petsc] solver`, else GAMG). `tetfem run` hands a scene with
//! `engine = "petsc"` (or `--engine petsc`) to this binary. Unless `--no-files`: each rank writes its piece of the
//! parallel VTK output and rank 0 the `.pvtu`, the `.pvd` and `<out>/<stem>_petsc_summary.json`
//! (the scene's `output.directory` unless `--out`). With `--displacement FILE` rank 0 writes
//! every DOF's displacement in the mesh's numbering (3·node + axis), one value per line.
//! `--export DIR` writes the static system in PETSc's binary format instead of solving it
//! (`K.petsc`, `b.petsc`, `coordinates.petsc`, `dofs.txt`: see `engine::export_scene`).

use std::io::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use tetfem_petsc::engine::{
    EngineOptions, PetscSummary, SolverPreset, export_scene, solve_scene, summary_path,
};
use tetfem_petsc::ffi::Petsc;
use tetfem_petsc::pvtu::write_file;
use tetfem_petsc::{Error, Result};
use tetfem_scene::{Scene, VtuEncoding};

const USAGE: &str = "usage: mpirun -n N tetfem-petsc SCENE.toml [--solver gamg|hypre|mumps] \
[--out DIR] [--displacement FILE] [--export DIR] [--json] [--quiet] [--no-files] \
[--vtu-format binary|ascii] [PETSc options, e.g. -ksp_monitor]";

struct Arguments {
    scene: PathBuf,
    solver: Option<SolverPreset>,
    out: Option<PathBuf>,
    displacement: Option<PathBuf>,
    export: Option<PathBuf>,
    json: bool,
    quiet: bool,
    no_files: bool,
    vtu_format: Option<VtuEncoding>,
    petsc: Vec<String>,
}

fn parse(args: &[String]) -> Result<Arguments> {
    let program = args
        .first()
        .cloned()
        .unwrap_or_else(|| "tetfem-petsc".into());
    let scene = match args.get(1) {
        Some(s) if !s.starts_with('-') => PathBuf::from(s),
        other => {
            return Err(Error::invalid(
                "first argument",
                other.map_or("nothing", String::as_str),
                format!("must be the scene file; {USAGE}"),
            ));
        }
    };
    let mut parsed = Arguments {
        scene,
        solver: None,
        out: None,
        displacement: None,
        export: None,
        json: false,
        quiet: false,
        no_files: false,
        vtu_format: None,
        petsc: vec![program],
    };
    let mut rest = args[2..].iter();
    while let Some(arg) = rest.next() {
        let mut value = |name: &str| {
            rest.next()
                .cloned()
                .ok_or_else(|| Error::invalid(name, "nothing", format!("needs a value; {USAGE}")))
        };
        match arg.as_str() {
            "--solver" => parsed.solver = Some(value("--solver")?.parse()?),
            "--out" => parsed.out = Some(PathBuf::from(value("--out")?)),
            "--displacement" => parsed.displacement = Some(PathBuf::from(value("--displacement")?)),
            "--export" => parsed.export = Some(PathBuf::from(value("--export")?)),
            "--json" => parsed.json = true,
            "--quiet" => parsed.quiet = true,
            "--no-files" => parsed.no_files = true,
            "--vtu-format" => {
                parsed.vtu_format = Some(match value("--vtu-format")?.as_str() {
                    "binary" => VtuEncoding::Binary,
                    "ascii" => VtuEncoding::Ascii,
                    other => {
                        return Err(Error::invalid(
                            "--vtu-format",
                            other,
                            "must be binary (the default) or ascii",
                        ));
                    }
                })
            }
            other if other.starts_with("--") => {
                return Err(Error::invalid(
                    "option",
                    other,
                    format!("is not one of tetfem-petsc's; {USAGE}"),
                ));
            }
            other => parsed.petsc.push(other.to_string()),
        }
    }
    Ok(parsed)
}

fn run(petsc: &Petsc, args: &Arguments) -> Result<()> {
    let mut scene = petsc.agree(Scene::load(&args.scene).map_err(Error::from))?;
    if let Some(out) = &args.out {
        scene.set_output_directory(out.clone());
    }
    if let Some(format) = args.vtu_format {
        scene.set_vtu_format(format);
    }
    if let Some(directory) = &args.export {
        let files = export_scene(petsc, &scene, directory)?;
        if petsc.rank() == 0 {
            for file in files {
                println!("wrote {}", file.display());
            }
        }
        return Ok(());
    }
    let solver = match (args.solver, scene.engine().petsc_solver) {
        (Some(solver), _) => solver,
        (None, Some(named)) => named.name().parse()?,
        (None, None) => SolverPreset::default(),
    };
    let options = EngineOptions {
        solver,
        gather_displacement: args.displacement.is_some(),
        write_vtu: !args.no_files,
    };
    let result = solve_scene(petsc, &scene, options)?;
    if petsc.rank() != 0 {
        return Ok(());
    }
    let Some(report) = &result.report else {
        return Ok(());
    };
    let json = serde_json::to_string_pretty(report)
        .map_err(|e| Error::invalid("summary", e, "must serialize to JSON"))?;
    if !args.no_files {
        write_file(&summary_path(&scene), &json)?;
    }
    if let (Some(path), Some(u)) = (&args.displacement, &result.displacement) {
        let text: String = u.iter().map(|v| format!("{v:e}\n")).collect();
        write_file(path, &text)?;
    }
    if args.json {
        println!("{json}");
    } else if !args.quiet {
        print_summary(report, &result.summary);
    }
    Ok(())
}

/// The human-readable lines of a run: the in-process keys of `report` and the engine's `s`.
fn print_summary(report: &serde_json::Value, s: &PetscSummary) {
    println!(
        "{}: {} DOFs ({} free) on {} ranks, {} + {} ({}): {} iterations, {}, relative residual {:.2e}",
        report["title"].as_str().unwrap_or_default(),
        s.dofs,
        report["free_dofs"],
        s.ranks,
        s.ksp_type,
        s.pc_type,
        s.solver.name(),
        s.iterations,
        s.converged_reason,
        s.relative_residual
    );
    if s.steps > 0 {
        println!(
            "  {} steps of {} s ({}), at most {} iterations per step",
            s.steps, s.dt, s.analysis, s.max_step_iterations
        );
    }
    println!(
        "  seconds: build {:.3}, partition {:.3}, assembly {:.3}, constraints {:.3}, set-up {:.3}, solve {:.3}",
        s.seconds.build,
        s.seconds.partition,
        s.seconds.assembly,
        s.seconds.constraints,
        s.seconds.setup,
        s.seconds.solve
    );
    let empty = Vec::new();
    for row in report["reactions"].as_array().unwrap_or(&empty) {
        println!(
            "  reaction of {}: {} N",
            row["constraint"].as_str().unwrap_or_default(),
            row["force_n"]
        );
    }
    for file in report["files"].as_array().unwrap_or(&empty) {
        println!("  wrote {}", file.as_str().unwrap_or_default());
    }
    for p in report["probes"].as_array().unwrap_or(&empty) {
        let value = match p.get("displacement") {
            Some(u) => u,
            None => &p["last"],
        };
        println!(
            "  probe {}: u = {value} m",
            p["name"].as_str().unwrap_or_default()
        );
    }
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().collect();
    if args.iter().any(|a| a == "--help" || a == "-h") {
        println!("{USAGE}");
        return ExitCode::SUCCESS;
    }
    let parsed = match parse(&args) {
        Ok(parsed) => parsed,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let petsc = match Petsc::initialize(&parsed.petsc) {
        Ok(petsc) => petsc,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    // An error of one rank before a collective call reaches every rank (`Petsc::agree`);
    // PETSc's collective calls fail on every rank alike; so every rank reports and finalizes.
    let outcome = run(&petsc, &parsed);
    let rank = petsc.rank();
    let size = petsc.size();
    drop(petsc);
    match outcome {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let line = if size > 1 {
                format!("error (rank {rank} of {size}): {e}\n")
            } else {
                format!("error: {e}\n")
            };
            // One write per message: under mpirun the ranks' stderr is merged, and the pieces
            // of a formatted eprintln! from two ranks would interleave.
            let _ = std::io::stderr().write_all(line.as_bytes());
            ExitCode::FAILURE
        }
    }
}
