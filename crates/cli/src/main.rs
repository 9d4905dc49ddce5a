//! `tetfem`: the command-line front of the library. It parses arguments, calls the library and
//! reports; no physics lives here.

use std::io::IsTerminal;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use clap::{Args, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use tetfem::analysis::dynamics::Method;
use tetfem::{Error, Material};
use tetfem_cli::handoff::PetscHandoff;
use tetfem_cli::info::mesh_info;
use tetfem_cli::scene::{
    Analysis, DynamicOutputs, DynamicOverrides, DynamicRun, DynamicSetup, DynamicSummary,
    EngineKind, ModalSummary, OutputSettings, RunLength, RunOptions, RunSummary, Scene, TimeStep,
    VtuEncoding, parse_petsc_options, resume_dynamic_scene, run_dynamic, run_dynamic_scene,
    run_modal_scene, run_static_with,
};
use tetfem_fixtures::cantilever::Cantilever;

/// Elastic solids on 4- and 10-node tetrahedra, linear and nonlinear: static, dynamic and modal
/// FEM runs from TOML scenes.
///
/// With no subcommand, runs the embedded default scene: a steel cantilever (1 m × 0.1 m × 0.1 m,
/// E = 200 GPa, ν = 0.3, ρ = 7850 kg/m³) clamped at x = 0 under gravity and a 10 kN end load.
///
/// The scene runs through the same runner as `tetfem run`, into one folder per part:
///
/// 1. Static: meshed with --cells (100×10×10 cubes of 6 tets, the lecture's split
///    mirrored in alternate cells so that the beam keeps its mirror planes), it prints the mesh size, the time
///    of each phase and the tip deflection beside beam theory, and writes to `<out>/cantilever/`
///    what a static scene writes: `cantilever.vtu` (displacement, its magnitude, von Mises
///    stress, strain energy density) with a one-frame `cantilever.pvd`, `cantilever_probes.csv`
///    (the tip's mean displacement), `cantilever_summary.json`, and with --png `cantilever.png`.
///
/// 2. Dynamic (unless --static-only): on a coarser mesh (--dynamic-cells, 40×4×4), the beam is
///    released from rest in its loaded static shape with the end load removed (gravity stays)
///    and swings for --periods periods of its first mode (from the modal solver) with --method
///    at --dt. It writes to `<out>/cantilever_swing/` what a dynamic scene writes:
///    `cantilever_swing.pvd` with its `.vtu` frames (open the `.pvd` in ParaView to play the
///    animation), `cantilever_swing.csv` (time, tip displacement, each energy term, wall time
///    per step, the clamp's reaction), `cantilever_swing_summary.json`, and with --png a `.png`
///    per frame; it reports the wall time per step and the explicit critical step.
///
/// Subcommands: `tetfem run SCENE.toml` runs a scene file (see scenes/), `tetfem info MESH`
/// prints mesh statistics and the explicit critical step.
#[derive(Debug, Parser)]
#[command(version, about, long_about, args_conflicts_with_subcommands = true)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    #[command(flatten)]
    default: DefaultScene,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run a scene file (static or dynamic) and write its outputs.
    ///
    /// Static scenes write `<stem>.vtu` (+ a one-frame `.pvd`), `<stem>_probes.csv` and
    /// `<stem>_summary.json`. Dynamic scenes write a `.vtu` frame every `output.every` steps
    /// with `<stem>.pvd` listing them with their times (open it in ParaView to play the run),
    /// `<stem>.csv` (time, step, wall time per step, each probe's mean displacement, each
    /// energy term, each constraint entry's reaction force and moment: one row per step) and `<stem>_summary.json`. With `--png` (or
    /// `output.png = true`), each frame is also rendered to `<stem>_<step>.png`.
    ///
    /// The outputs go to `output.directory`, else `out/<scene file stem>/`.
    Run(RunArgs),
    /// Print a mesh's statistics and the explicit critical time step.
    ///
    /// MESH is a Gmsh `.msh` (4.1 ASCII/binary, 2.2 ASCII), a TetGen `.node`/`.ele` (either
    /// file, or the common prefix) or a scene `.toml` (its mesh and material). Prints node and
    /// tet counts, volume, bounding box, edge lengths, the dihedral-angle and aspect-ratio
    /// statistics, physical groups, skipped elements and, when a material is known, the
    /// explicit critical step (element bound).
    Info(InfoArgs),
    /// Write a static scene's linear system for another solver, without solving it.
    ///
    /// `tetfem export --petsc SCENE DIR`: PETSc's binary format (K_ff in the engine's numbering with the
    /// constrained rows and columns zeroed, the right-hand side, the node coordinates and the
    /// DOF map; the book's chapter "PETSc and MPI"), written by the tetfem-petsc binary (run under `mpirun
    /// -n N` for N ranks).
    Export(ExportArgs),
}

#[derive(Debug, Args)]
struct ExportArgs {
    /// The format: PETSc's binary files (the only one so far, and required).
    #[arg(long, required = true)]
    petsc: bool,
    /// The scene file (static).
    scene: PathBuf,
    /// Folder for the files (`K.petsc`, `b.petsc`, `coordinates.petsc`, `dofs.txt`).
    directory: PathBuf,
}

/// The default scene's options.
#[derive(Debug, Args)]
struct DefaultScene {
    /// Cells along x, y, z of the static mesh (e.g. `200,20,20`).
    #[arg(long, value_parser = parse_cells, default_value = "100,10,10")]
    cells: [usize; 3],
    /// Cells along x, y, z of the dynamic run's mesh (coarser, so that it runs in seconds).
    #[arg(long, value_parser = parse_cells, default_value = "40,4,4")]
    dynamic_cells: [usize; 3],
    /// Directory for the output folders `cantilever/` (static) and `cantilever_swing/` (dynamic).
    #[arg(long, default_value = "out")]
    out: PathBuf,
    /// Integrator of the dynamic run.
    #[arg(long, value_parser = parse_method, default_value = "backward-euler")]
    method: Method,
    /// Time step: seconds (`2e-4`) or a multiple of the explicit critical step (`50crit`).
    /// Default: 50crit for backward-euler and newmark, 0.9crit for explicit.
    #[arg(long, value_parser = parse_time_step)]
    dt: Option<TimeStep>,
    /// Simulated time of the dynamic run (s); overrides --periods.
    #[arg(long, value_parser = parse_positive)]
    duration: Option<f64>,
    /// Length of the dynamic run in periods of the first bending mode.
    #[arg(long, value_parser = parse_positive, default_value = "3")]
    periods: f64,
    /// About this many `.vtu` frames over the dynamic run.
    #[arg(long, default_value = "60", value_parser = clap::value_parser!(u32).range(1..))]
    frames: u32,
    /// Also render the static solution and each dynamic frame to PNG.
    #[arg(long)]
    png: bool,
    /// Encoding of the `.vtu` files: `binary` (appended raw, the default) or `ascii`.
    #[arg(long, value_parser = parse_vtu_format, default_value = "binary")]
    vtu_format: VtuEncoding,
    /// Only the static solve (as before the dynamic part existed).
    #[arg(long)]
    static_only: bool,
    /// No progress bar.
    #[arg(long, short)]
    quiet: bool,
    /// Print one JSON object on stdout (and nothing else there): the static summary, beam
    /// theory's tip deflections (m), the dynamic summary and the first mode's period (s).
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Args)]
struct RunArgs {
    /// The scene file (TOML; see scenes/README.md and `tetfem_cli::scene::REFERENCE`).
    scene: PathBuf,
    /// Output directory (overrides the scene's `output.directory`).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Render PNG images (each frame of a dynamic run) even if the scene does not ask for them.
    #[arg(long)]
    png: bool,
    /// Encoding of the `.vtu` files, `binary` or `ascii` (overrides the scene's
    /// `output.vtu_format`).
    #[arg(long, value_parser = parse_vtu_format)]
    vtu_format: Option<VtuEncoding>,
    /// Print the run summary as one JSON object on stdout (and nothing else there).
    #[arg(long)]
    json: bool,
    /// No progress bar and no report on stdout (errors still go to stderr).
    #[arg(long, short)]
    quiet: bool,
    /// Dynamic scenes: another integrator than the scene's.
    #[arg(long, value_parser = parse_method)]
    method: Option<Method>,
    /// Dynamic scenes: another time step, seconds (`1e-5`) or a multiple of the explicit
    /// critical step (`0.5crit`).
    #[arg(long, value_parser = parse_time_step)]
    dt: Option<TimeStep>,
    /// Dynamic scenes: another simulated time (s).
    #[arg(long, value_parser = parse_positive, conflicts_with = "steps")]
    duration: Option<f64>,
    /// Dynamic scenes: run this many steps instead of the scene's duration.
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
    steps: Option<u64>,
    /// Dynamic scenes: continue from the checkpoint the last run wrote in the output folder
    /// (`[output] checkpoint_every`) to the scene's end, as one uninterrupted run would; the
    /// scene may differ only in `analysis.duration` and `output.checkpoint_every`.
    #[arg(long)]
    resume: bool,
    /// What solves the scene, `tetfem` or `petsc` (overrides the scene's `engine`). `petsc`
    /// hands the scene to the `tetfem-petsc` binary (run under `mpirun -n N` for N ranks).
    #[arg(long, value_parser = parse_engine)]
    engine: Option<EngineKind>,
    /// PETSc engine: PETSc options, e.g. `"-ksp_rtol 1e-10 -ksp_monitor"`; they win over the
    /// scene's `[petsc] options`.
    #[arg(long, value_parser = parse_petsc_option_text, allow_hyphen_values = true)]
    petsc_options: Option<String>,
}

fn parse_petsc_option_text(text: &str) -> Result<String, String> {
    parse_petsc_options(text).map(|_| text.to_string())
}

fn parse_engine(text: &str) -> Result<EngineKind, String> {
    match text {
        "tetfem" => Ok(EngineKind::Tetfem),
        "petsc" => Ok(EngineKind::Petsc),
        other => Err(format!("'{other}': must be \"tetfem\" or \"petsc\"")),
    }
}

#[derive(Debug, Args)]
struct InfoArgs {
    /// The mesh file (`.msh`, `.node`/`.ele`) or scene (`.toml`).
    mesh: PathBuf,
    /// Material for the critical step as `E,NU,RHO` (Pa, -, kg/m³), e.g. `200e9,0.3,7850`;
    /// overrides a scene's.
    #[arg(long, value_parser = parse_material)]
    material: Option<Material>,
    /// Print the statistics as one JSON object.
    #[arg(long)]
    json: bool,
}

fn parse_vtu_format(text: &str) -> Result<VtuEncoding, String> {
    match text {
        "binary" => Ok(VtuEncoding::Binary),
        "ascii" => Ok(VtuEncoding::Ascii),
        other => Err(format!("'{other}': must be \"binary\" or \"ascii\"")),
    }
}

fn parse_cells(text: &str) -> Result<[usize; 3], String> {
    let parts: Vec<&str> = text.split(',').collect();
    let parse = |s: &str| s.trim().parse::<usize>().map_err(|e| format!("'{s}': {e}"));
    match parts.as_slice() {
        [x, y, z] => Ok([parse(x)?, parse(y)?, parse(z)?]),
        _ => Err(format!(
            "expected three comma-separated counts like 100,10,10, got '{text}'"
        )),
    }
}

fn parse_method(text: &str) -> Result<Method, String> {
    text.parse().map_err(|e: Error| e.to_string())
}

fn parse_time_step(text: &str) -> Result<TimeStep, String> {
    text.parse().map_err(|e: Error| e.to_string())
}

fn parse_positive(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("expected a finite number > 0, got '{text}'")),
    }
}

fn parse_material(text: &str) -> Result<Material, String> {
    let values: Vec<f64> = text
        .split(',')
        .map(|s| s.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("'{text}': {e}"))?;
    match values.as_slice() {
        [e, nu, rho] => Material::new(*e, *nu, *rho).map_err(|e| e.to_string()),
        _ => Err(format!(
            "expected E,NU,RHO like 200e9,0.3,7850, got '{text}'"
        )),
    }
}

/// Set by the first Ctrl-C (or SIGTERM, SIGHUP); dynamic runs stop at the next step boundary.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// Set while a dynamic run steps (from the end of its set-up to its last step, see
/// [`Progress::update`]): then the first signal stops it cleanly at the next step boundary.
static STOP_AT_STEP: AtomicBool = AtomicBool::new(false);

/// Ctrl-C (SIGINT), SIGTERM and SIGHUP (what `timeout`, `kill` and batch schedulers send, and
/// a closed terminal): while a dynamic run steps the first one stops it at the next step
/// boundary (the frames written are kept, the .pvd lists exactly those, the CSV rows are written
/// out, the lock is released, exit status 130); otherwise (a static solve, a dynamic run's
/// set-up — assembly, factorization, critical step — or its end) and on a second signal, the
/// process exits at once with 130 after removing its output-folder lock files (files are
/// written atomically, so none is left half-written; the CSV holds whole rows up to its last
/// write, at least up to the last frame).
fn install_signal_handler() {
    let installed = ctrlc::set_handler(|| {
        let first = !INTERRUPTED.swap(true, Ordering::SeqCst);
        if !(first && STOP_AT_STEP.load(Ordering::SeqCst)) {
            tetfem::post::output::remove_held_lock_files();
            eprintln!(
                "tetfem: interrupted outside the time stepping (or a second signal): stopped at once"
            );
            std::process::exit(130);
        }
    });
    if let Err(error) = installed {
        eprintln!("warning: Ctrl-C will stop the run without a clean finish: {error}");
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    install_signal_handler();
    let result = match &cli.command {
        None => run_default(&cli.default),
        Some(Command::Run(args)) => run_scene(args),
        Some(Command::Info(args)) => info(args),
        Some(Command::Export(args)) => PetscHandoff {
            scene: args.scene.clone(),
            export: Some(args.directory.clone()),
            ..PetscHandoff::default()
        }
        .run(),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(error @ Error::Interrupted { .. }) => {
            eprintln!("tetfem: {error}");
            ExitCode::from(130)
        }
        Err(error) => {
            // The library's error names its remedy where it knows one (an explicit run above
            // its critical step: tetfem::analysis::dynamics::EXPLICIT_REMEDY); nothing is added
            // here, so an implicit step's Newton failure gets no explicit-method advice.
            eprintln!("error: {error}");
            ExitCode::FAILURE
        }
    }
}

/// A progress bar on stderr that appears once a run has taken a second, if stderr is a terminal
/// and `quiet` is off.
struct Progress {
    bar: ProgressBar,
    enabled: bool,
    shown: bool,
    start: Instant,
}

impl Progress {
    fn new(quiet: bool) -> Self {
        Progress {
            bar: ProgressBar::with_draw_target(None, ProgressDrawTarget::hidden()),
            enabled: !quiet && std::io::stderr().is_terminal(),
            shown: false,
            start: Instant::now(),
        }
    }

    /// Shows progress; `Break` once Ctrl-C was pressed, so that the run stops at this step.
    /// Called when the stepping begins and after each step: from the first call until the last
    /// step the first signal stops the run at a step boundary (set before `INTERRUPTED` is
    /// read: a signal the handler let through is seen here at the latest at the next step);
    /// before it (the set-up) and after the last step a signal exits at once.
    fn update(&mut self, done: usize, total: usize) -> ControlFlow<()> {
        STOP_AT_STEP.store(done < total, Ordering::SeqCst);
        if INTERRUPTED.load(Ordering::SeqCst) {
            return ControlFlow::Break(());
        }
        if !self.enabled {
            return ControlFlow::Continue(());
        }
        if !self.shown && self.start.elapsed() > Duration::from_secs(1) {
            self.bar.set_length(total as u64);
            if let Ok(style) = ProgressStyle::with_template(
                "  [{bar:40}] {pos}/{len} steps, {elapsed} elapsed, ETA {eta}",
            ) {
                self.bar.set_style(style.progress_chars("=> "));
            }
            self.bar.set_draw_target(ProgressDrawTarget::stderr());
            self.shown = true;
        }
        if self.shown {
            self.bar.set_position(done as u64);
        }
        ControlFlow::Continue(())
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.bar.finish_and_clear();
    }
}

/// How the cubes of both default meshes are split into tets (the scene key `mesh.box.split`).
const DEFAULT_SPLIT: &str = "mirrored6";

/// The embedded default scene: [`Cantilever::steel_default`] on `cells` as a static scene,
/// clamped on x = 0, with its end load and gravity and the probe `tip` on the end face x = L.
/// Its outputs are `<out>/<stem>/<stem>.*`, as `tetfem run` writes them for a scene file.
fn default_scene(
    beam: &Cantilever,
    cells: [usize; 3],
    title: &str,
    stem: &str,
    out: &Path,
    vtu_format: VtuEncoding,
) -> tetfem::Result<Scene> {
    let m = beam.material;
    let text = format!(
        r#"title = "{title}"

[mesh.box]
max = [{length:?}, {width:?}, {height:?}]
cells = [{cx}, {cy}, {cz}]
split = "{DEFAULT_SPLIT}"

[material]
youngs_modulus = {e:?}
poisson_ratio = {nu:?}
density = {rho:?}

[[constraints]]
where = {{ plane = {{ axis = "x", at = 0.0 }} }}

[[loads]]
where = {{ plane = {{ axis = "x", at = {length:?} }} }}
total_force = [0.0, 0.0, {load:?}]

[[loads]]
gravity = [0.0, 0.0, {gravity:?}]

[[probes]]
name = "tip"
where = {{ plane = {{ axis = "x", at = {length:?} }} }}
"#,
        length = beam.length,
        width = beam.width,
        height = beam.height,
        cx = cells[0],
        cy = cells[1],
        cz = cells[2],
        e = m.youngs_modulus(),
        nu = m.poisson_ratio(),
        rho = m.density(),
        load = -beam.end_load,
        gravity = -beam.gravity,
    );
    let mut scene = Scene::parse(&text, "default", Path::new("."))?;
    scene.set_stem(stem)?;
    scene.set_output_directory(out.join(stem));
    scene.set_vtu_format(vtu_format);
    Ok(scene)
}

/// Stem (and folder under `--out`) of the default run's static outputs.
const STATIC_STEM: &str = "cantilever";
/// Stem (and folder under `--out`) of the default run's dynamic outputs.
const DYNAMIC_STEM: &str = "cantilever_swing";

fn run_default(cli: &DefaultScene) -> tetfem::Result<()> {
    let beam = Cantilever::steel_default();
    let statics = run_default_static(cli, &beam)?;
    let dynamics = if cli.static_only {
        None
    } else {
        Some(run_default_dynamic(cli, &beam)?)
    };
    if cli.json {
        let (euler_bernoulli, timoshenko) = beam.beam_theory_tip();
        let report = serde_json::json!({
            "static": statics,
            "beam_theory_tip": {
                "euler_bernoulli": euler_bernoulli,
                "timoshenko": timoshenko,
            },
            "dynamic": dynamics.as_ref().map(|(summary, _)| summary),
            "first_mode_period": dynamics.as_ref().map(|(_, period)| period),
        });
        println!("{report}");
    }
    Ok(())
}

fn run_default_static(cli: &DefaultScene, beam: &Cantilever) -> tetfem::Result<RunSummary> {
    let scene = default_scene(
        beam,
        cli.cells,
        "Steel cantilever (default scene), static",
        STATIC_STEM,
        &cli.out,
        cli.vtu_format,
    )?;
    let summary = run_static_with(
        &scene,
        &RunOptions {
            force_png: cli.png,
            ..RunOptions::default()
        },
    )?;
    print_warnings(&summary.warnings);
    if !cli.json {
        print_default_static(cli, beam, &summary, &scene.output().directory);
    }
    Ok(summary)
}

fn print_default_static(cli: &DefaultScene, beam: &Cantilever, s: &RunSummary, directory: &Path) {
    let material = beam.material;
    println!("tetfem: static cantilever (default scene)");
    println!(
        "  beam {} m × {} m × {} m, E = {:.3e} Pa, ν = {}, ρ = {} kg/m³, end load {} N, g = {} m/s²",
        beam.length,
        beam.width,
        beam.height,
        material.youngs_modulus(),
        material.poisson_ratio(),
        material.density(),
        beam.end_load,
        beam.gravity
    );
    println!(
        "  mesh {}×{}×{} cells: {} nodes, {} tets, {} DOFs ({} free), nnz(L) = {}",
        cli.cells[0],
        cli.cells[1],
        cli.cells[2],
        s.nodes,
        s.tets,
        3 * s.nodes,
        s.free_dofs,
        s.factor_len
    );
    println!("  time per phase:");
    println!(
        "    {:<14} {} (mesh, node and face sets, loads)",
        "build",
        format_seconds(s.build_seconds)
    );
    if let Some(p) = &s.phases {
        for (phase, seconds) in [
            ("pattern", p.pattern),
            ("assembly", p.assembly),
            ("constraints", p.constraints),
            ("symbolic", p.symbolic),
            ("factorization", p.factorization),
            ("solve", p.solve),
        ] {
            println!("    {phase:<14} {}", format_seconds(seconds));
        }
    }
    println!("    {:<14} {}", "outputs", format_seconds(s.output_seconds));
    let (euler_bernoulli, timoshenko) = beam.beam_theory_tip();
    let tip = s
        .probes
        .iter()
        .find(|p| p.name == "tip")
        .map_or(f64::NAN, |p| p.displacement[2]);
    println!("  tip deflection (mean u_z on x = L):");
    println!("    tetfem           {tip:+.6e} m");
    println!(
        "    Euler–Bernoulli  {euler_bernoulli:+.6e} m  (tetfem / EB = {:.4})",
        tip / euler_bernoulli
    );
    println!(
        "    Timoshenko       {timoshenko:+.6e} m  (tetfem / Timoshenko = {:.4})",
        tip / timoshenko
    );
    println!(
        "    (linear tets are stiff in bending: at {} cells through the height they reach this ratio; refine with --cells)",
        cli.cells[2]
    );
    println!(
        "  relative residual ‖K_ff·u − f‖/‖f‖ = {:.2e}",
        s.relative_residual
    );
    println!(
        "  max |u| = {:.4e} m, max von Mises = {:.4e} Pa",
        s.max_displacement, s.max_von_mises
    );
    print_estimated_error(s.estimated_error.as_ref());
    print_files(&s.files, directory);
    println!(
        "    (.vtu: displacement [m], reaction_force [N], nodal stress per node; stress, von_mises [Pa], principal stresses, strain, error indicator per tet: every field in the book's Outputs)"
    );
}

/// The self-estimated error line of a summary.
fn print_estimated_error(e: Option<&tetfem_cli::scene::EstimatedError>) {
    if let Some(e) = e {
        let of = if e.definition == tetfem_cli::scene::MODEL_ESTIMATED_ERROR_DEFINITION {
            "Green strain in the relative energy norm, ZZ patch recovery of the model's S"
        } else {
            "relative energy norm, ZZ patch recovery"
        };
        println!(
            "  estimated error {:.2} % ({of}; per tet: error_indicator in the .vtu)",
            100.0 * e.relative
        );
    }
}

/// What `[analysis] accuracy` tried and chose.
fn print_accuracy(a: &tetfem_cli::scene::AccuracyReport) {
    println!(
        "  accuracy target {:.3} %: {} — order {}, cells {:?}, estimate {:.3} % ({})",
        100.0 * a.target,
        if a.met { "met" } else { "NOT met" },
        a.order,
        a.cells,
        100.0 * a.estimated_error,
        a.estimate_of
    );
    for t in &a.trials {
        println!(
            "    tried order {}, cells {:?}: {} DOFs, estimate {:.3} %, {}",
            t.order,
            t.cells,
            t.dofs,
            100.0 * t.estimate,
            format_seconds(t.seconds)
        );
    }
    println!("    why: {}", a.reason);
}

/// "wrote N files to DIR/: a, b, c" (the file names, frames summarized by their count).
fn print_files(files: &[PathBuf], directory: &Path) {
    let names: Vec<String> = files
        .iter()
        .filter_map(|f| f.file_name())
        .map(|n| n.to_string_lossy().into_owned())
        .collect();
    println!(
        "  wrote {} files to {}/: {}",
        names.len(),
        directory.display(),
        names.join(", ")
    );
}

/// The dynamic part's summary and the first mode's period (s).
fn run_default_dynamic(
    cli: &DefaultScene,
    beam: &Cantilever,
) -> tetfem::Result<(DynamicSummary, f64)> {
    let c = cli.dynamic_cells;
    let scene = default_scene(
        beam,
        c,
        "Steel cantilever released from its loaded shape",
        DYNAMIC_STEM,
        &cli.out,
        cli.vtu_format,
    )?;
    let text = !cli.json;
    if text {
        println!();
        println!(
            "tetfem: dynamic cantilever, released from its loaded static shape with the end load removed (gravity stays)"
        );
    }
    let setup = DynamicSetup::released(scene.build()?)?;
    let period = setup.first_mode_period()?;
    if text {
        println!(
            "  mesh {}×{}×{} cells (coarser than the static one, so that the run takes seconds; set --dynamic-cells): {} nodes, {} tets, {} free DOFs",
            c[0],
            c[1],
            c[2],
            setup.mesh.node_count(),
            setup.mesh.tet_count(),
            setup.system.free_count()
        );
        println!(
            "  first natural mode (modal solver): period {:.4e} s, f = {:.2} Hz",
            period,
            1.0 / period
        );
    }
    let dt = cli.dt.unwrap_or(match cli.method {
        Method::Explicit => TimeStep::CriticalMultiple(0.9),
        _ => TimeStep::CriticalMultiple(50.0),
    });
    let duration = cli.duration.unwrap_or(cli.periods * period);
    let run = DynamicRun {
        title: scene.title(),
        source: scene.source_name().to_string(),
        method: cli.method,
        dt,
        length: RunLength::Duration(duration),
    };
    // A frame interval giving about --frames frames (the critical step is computed once).
    let dt_seconds = setup.resolve(dt)?;
    let steps = (duration / dt_seconds).ceil().max(1.0) as usize;
    let outputs = DynamicOutputs {
        settings: OutputSettings {
            every: steps.div_ceil(cli.frames as usize).max(1),
            ..scene.output().clone()
        },
        force_png: cli.png,
    };
    let mut progress = Progress::new(cli.quiet || cli.json);
    let summary = run_dynamic(&setup, &run, Some(&outputs), &mut |done, total| {
        progress.update(done, total)
    });
    drop(progress);
    let summary = summary?;
    print_warnings(&summary.warnings);
    if text {
        print_dynamic(&summary, &outputs.settings.directory, false);
    }
    Ok((summary, period))
}

fn print_dynamic(s: &DynamicSummary, directory: &Path, header: bool) {
    if header {
        println!("tetfem: {} ({})", s.title, s.scene);
        println!(
            "  mesh: {} nodes, {} tets, {} free DOFs",
            s.nodes, s.tets, s.free_dofs
        );
    }
    println!(
        "  explicit critical step ({}): {:.4e} s",
        s.critical_step_source, s.critical_step
    );
    println!(
        "  {}: dt = {:.4e} s = {:.1} × the critical step, {} steps to t = {:.4e} s",
        s.method, s.dt, s.dt_over_critical, s.steps, s.end_time
    );
    if let Some(t) = &s.time_stepping {
        println!(
            "  time_tolerance {:.1e}: estimated trajectory error {:.2e}; {} steps accepted, {} rejected; dt {:.4e} to {:.4e} s (dt above is the first step)",
            t.tolerance, t.estimated_error, t.accepted_steps, t.rejected_steps, t.dt_min, t.dt_max
        );
    }
    if let Some(a) = &s.accuracy {
        println!(
            "  accuracy target {:.3} %: {} — estimated {:.3} % = space {:.3} % (static twin, target {:.3} %) + time {:.3} % (tolerance {:.3} %)",
            100.0 * a.target,
            if a.met { "met" } else { "NOT met" },
            100.0 * a.estimated_error,
            100.0 * a.space.estimated_error,
            100.0 * a.space.target,
            100.0 * a.time_estimate,
            100.0 * a.time_tolerance
        );
        print_accuracy(&a.space);
    }
    if let Some(n) = &s.newton {
        println!(
            "  {} model: {} Newton iterations in all, at most {} in one step",
            s.model, n.total_iterations, n.max_per_step
        );
    }
    if let Some(e) = &s.estimated_error {
        println!(
            "  estimated error at the end {:.2} % (relative energy norm, ZZ patch recovery; one estimate {:.2e} s, one per .vtu frame)",
            100.0 * e.relative,
            s.estimate_seconds
        );
    }
    println!(
        "  wall time: setup {}, first step {} (with factorization for implicit methods), then {} per step; steps {} in all, outputs {}",
        format_seconds(s.setup_seconds),
        format_seconds(s.first_step_seconds),
        format_seconds(s.mean_step_seconds),
        format_seconds(s.step_seconds),
        format_seconds(s.output_seconds)
    );
    for p in &s.probes {
        println!(
            "  probe {}: u_z from {:+.4e} to {:+.4e} m, last {:+.4e} m",
            p.name, p.min[2], p.max[2], p.last[2]
        );
    }
    for r in &s.reactions {
        let [fx, fy, fz] = r.force_n;
        let [mx, my, mz] = r.moment_nm;
        let [px, py, pz] = r.moment_point_m;
        println!(
            "  reaction at the end, {}: force ({fx:+.4e}, {fy:+.4e}, {fz:+.4e}) N, moment about ({px}, {py}, {pz}) m ({mx:+.4e}, {my:+.4e}, {mz:+.4e}) N·m",
            r.constraint
        );
    }
    for c in s.contact_forces.iter().flatten() {
        let [fx, fy, fz] = c.force_n;
        println!(
            "  contact force on obstacle {} at the end: ({fx:+.4e}, {fy:+.4e}, {fz:+.4e}) N; peak |F| {:.4e} N at t = {:.4e} s",
            c.obstacle, c.peak_n, c.peak_time_s
        );
    }
    let (a, b) = (&s.initial_energy, &s.final_energy);
    println!("  energy (J)  kinetic  elastic  gravity potential  load potential  total");
    println!(
        "    start    {:+.4e} {:+.4e} {:+.4e} {:+.4e} {:+.4e}",
        a.kinetic, a.elastic, a.gravity_potential, a.load_potential, a.total
    );
    println!(
        "    end      {:+.4e} {:+.4e} {:+.4e} {:+.4e} {:+.4e}",
        b.kinetic, b.elastic, b.gravity_potential, b.load_potential, b.total
    );
    println!(
        "  wrote {} frames (.vtu) and {} files in all to {}/: open the .pvd in ParaView to play the run",
        s.frames,
        s.files.len(),
        directory.display()
    );
}

fn print_static(s: &RunSummary, directory: &Path) {
    println!("tetfem: {} ({})", s.title, s.scene);
    println!(
        "  static: {} nodes, {} tets, {} free DOFs; relative residual {:.2e}",
        s.nodes, s.tets, s.free_dofs, s.relative_residual
    );
    if let Some(n) = &s.newton {
        println!(
            "  Newton: {} load steps, {} iterations in all (tolerance {:e} per step; \
             analysis.load_steps, newton_tolerance)",
            n.load_steps, n.iterations, n.tolerance
        );
    }
    println!(
        "  max |u| = {:.4e} m, max von Mises = {:.4e} Pa",
        s.max_displacement, s.max_von_mises
    );
    print_estimated_error(s.estimated_error.as_ref());
    if let Some(a) = &s.accuracy {
        print_accuracy(a);
    }
    for p in &s.probes {
        println!(
            "  probe {}: mean u = ({:+.4e}, {:+.4e}, {:+.4e}) m",
            p.name, p.displacement[0], p.displacement[1], p.displacement[2]
        );
    }
    if let Some(c) = &s.critical_step {
        println!(
            "  explicit critical step {:.4e} s ({})",
            c.seconds, c.source
        );
    }
    if let Some(reactions) = &s.reactions {
        let [x, y, z] = s.applied_load_n;
        println!("  applied load ({x:+.4e}, {y:+.4e}, {z:+.4e}) N; reactions:");
        for r in reactions {
            let [fx, fy, fz] = r.force_n;
            let [mx, my, mz] = r.moment_nm;
            let [px, py, pz] = r.moment_point_m;
            println!(
                "    {}: force ({fx:+.4e}, {fy:+.4e}, {fz:+.4e}) N, moment about ({px}, {py}, {pz}) m ({mx:+.4e}, {my:+.4e}, {mz:+.4e}) N·m",
                r.constraint
            );
        }
    }
    for c in s.contact_forces.iter().flatten() {
        let [fx, fy, fz] = c.force_n;
        println!(
            "  contact force on obstacle {}: ({fx:+.4e}, {fy:+.4e}, {fz:+.4e}) N",
            c.obstacle
        );
    }
    println!(
        "  wall time: build {}, solve {}, outputs {}",
        format_seconds(s.build_seconds),
        format_seconds(s.solve_seconds),
        format_seconds(s.output_seconds)
    );
    println!(
        "  wrote {} files to {}/",
        s.files.len(),
        directory.display()
    );
}

fn print_modal(s: &ModalSummary, directory: &Path) {
    println!("tetfem: {} ({})", s.title, s.scene);
    println!(
        "  modal: {} nodes, {} tets, {} free DOFs, {} mass; {} subspace iterations",
        s.nodes, s.tets, s.free_dofs, s.mass, s.iterations
    );
    println!("  mode  frequency (Hz)  period (s)    effective mass fraction x / y / z");
    for m in &s.modes {
        let [x, y, z] = m.effective_mass_fraction;
        println!(
            "  {:>4}  {:>14.6e}  {:>11.4e}  {x:>8.4} {y:>8.4} {z:>8.4}",
            m.mode, m.frequency_hz, m.period_s
        );
    }
    if let Some(c) = &s.critical_step {
        println!(
            "  explicit critical step {:.4e} s ({})",
            c.seconds, c.source
        );
    }
    let [x, y, z] = s.cumulative_mass_fraction;
    println!(
        "  {:>35}{x:>8.4} {y:>8.4} {z:>8.4}",
        "sum of the retained modes:"
    );
    println!(
        "  wall time: build {}, solve {}, outputs {}",
        format_seconds(s.build_seconds),
        format_seconds(s.solve_seconds),
        format_seconds(s.output_seconds)
    );
    println!(
        "  wrote {} files to {}/ (open the _modes.pvd in ParaView: one step per mode)",
        s.files.len(),
        directory.display()
    );
}

/// An error naming the dynamic-only options given (`--method`, `--dt`, `--duration`,
/// `--steps`, and `--png` when `png_refused`) for a scene that is not dynamic.
fn refuse_dynamic_options(args: &RunArgs, png_refused: bool, why: &str) -> tetfem::Result<()> {
    let given: Vec<&str> = [
        ("--method", args.method.is_some()),
        ("--dt", args.dt.is_some()),
        ("--duration", args.duration.is_some()),
        ("--steps", args.steps.is_some()),
        ("--resume", args.resume),
        ("--png", png_refused),
    ]
    .iter()
    .filter(|(_, set)| *set)
    .map(|(name, _)| *name)
    .collect();
    if given.is_empty() {
        return Ok(());
    }
    Err(Error::invalid_parameter(
        given.join(", "),
        args.scene.display(),
        why,
    ))
}

fn run_scene(args: &RunArgs) -> tetfem::Result<()> {
    let mut scene = Scene::load(&args.scene)?;
    if let Some(engine) = args.engine {
        scene.set_engine(engine);
    }
    if scene.engine().kind == EngineKind::Petsc {
        // The engine integrates with its own settings (backward Euler, the scene's dt).
        refuse_dynamic_options(
            args,
            args.png,
            "is not taken by the PETSc engine (engine = \"petsc\"): set it in the scene, or \
             run with --engine tetfem",
        )?;
        return PetscHandoff {
            scene: args.scene.clone(),
            out: args.out.clone(),
            json: args.json,
            quiet: args.quiet,
            vtu_format: args.vtu_format.map(|f| f.format().name()),
            petsc_options: args
                .petsc_options
                .as_deref()
                .map(|o| o.split_whitespace().map(str::to_string).collect())
                .unwrap_or_default(),
            export: None,
        }
        .run();
    }
    if args.petsc_options.is_some() {
        return Err(Error::invalid_parameter(
            "--petsc-options",
            args.scene.display(),
            "applies to the PETSc engine only (engine = \"petsc\" in the scene, or --engine petsc)",
        ));
    }
    if let Some(out) = &args.out {
        scene.set_output_directory(out.clone());
    }
    if let Some(format) = args.vtu_format {
        scene.set_vtu_format(format);
    }
    let directory = scene.output().directory.clone();
    match scene.analysis() {
        Analysis::Modal(_) => {
            refuse_dynamic_options(
                args,
                args.png,
                "does not apply to a modal scene (it writes mode shapes as .vtu)",
            )?;
            let summary = run_modal_scene(&scene, false)?;
            print_warnings(&summary.warnings);
            if args.json {
                println!("{}", summary.to_json());
            } else if !args.quiet {
                print_modal(&summary, &directory);
            }
        }
        Analysis::Static => {
            refuse_dynamic_options(
                args,
                false,
                "applies to dynamic scenes only; this scene is static",
            )?;
            let summary = run_static_with(
                &scene,
                &RunOptions {
                    force_png: args.png,
                    ..RunOptions::default()
                },
            )?;
            print_warnings(&summary.warnings);
            if args.json {
                println!("{}", summary.to_json());
            } else if !args.quiet {
                print_static(&summary, &directory);
            }
        }
        Analysis::Dynamic(_) => {
            let overrides = DynamicOverrides {
                method: args.method,
                dt: args.dt,
                length: match (args.steps, args.duration) {
                    (Some(n), _) => Some(RunLength::Steps(n as usize)),
                    (None, Some(d)) => Some(RunLength::Duration(d)),
                    (None, None) => None,
                },
            };
            let mut progress = Progress::new(args.quiet);
            let mut report = |d, t| progress.update(d, t);
            let summary = match args.resume {
                true => resume_dynamic_scene(&scene, &overrides, args.png, &mut report),
                false => run_dynamic_scene(&scene, &overrides, true, args.png, &mut report),
            };
            drop(progress);
            let summary = summary?;
            print_warnings(&summary.warnings);
            if args.json {
                println!("{}", summary.to_json());
            } else if !args.quiet {
                print_dynamic(&summary, &directory, true);
            }
        }
    }
    Ok(())
}

/// Warnings go to standard error, even with `--quiet` or `--json` (they may change the answer).
fn print_warnings(warnings: &[String]) {
    for warning in warnings {
        eprintln!("warning: {warning}");
    }
}

fn info(args: &InfoArgs) -> tetfem::Result<()> {
    let info = mesh_info(&args.mesh, args.material)?;
    if args.json {
        println!("{}", info.to_json());
    } else {
        print!("{info}");
    }
    Ok(())
}

fn format_duration(time: Duration) -> String {
    let seconds = time.as_secs_f64();
    if seconds >= 1.0 {
        format!("{seconds:.3} s")
    } else {
        format!("{:.3} ms", seconds * 1e3)
    }
}

fn format_seconds(seconds: f64) -> String {
    format_duration(Duration::from_secs_f64(seconds.max(0.0)))
}
