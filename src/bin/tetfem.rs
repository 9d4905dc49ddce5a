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
use tetfem::cantilever::Cantilever;
use tetfem::dynamics::Method;
use tetfem::info::mesh_info;
use tetfem::output::VtuWriter;
use tetfem::scene::{
    Analysis, DynamicOutputs, DynamicOverrides, DynamicRun, DynamicSetup, DynamicSummary,
    OutputSettings, PngField, RunLength, RunOptions, RunSummary, Scene, TimeStep, run_dynamic,
    run_dynamic_scene, run_static_with,
};
use tetfem::{Error, Material};

/// Elastic solids on linear tetrahedra: static and dynamic FEM runs from TOML scenes.
///
/// With no subcommand, runs the embedded default scene: a steel cantilever (1 m × 0.1 m × 0.1 m,
/// E = 200 GPa, ν = 0.3, ρ = 7850 kg/m³) clamped at x = 0 under gravity and a 10 kN end load.
///
/// 1. Static: meshed with --cells (100×10×10 cubes of 6 tets), it prints the mesh size, the time
///    of each phase and the tip deflection beside beam theory, and writes `<out>/cantilever.vtu`.
///
/// 2. Dynamic (unless --static-only): on a coarser mesh (--dynamic-cells, 40×4×4), the beam is
///    released from rest in its loaded static shape with the end load removed (gravity stays)
///    and swings for --periods periods of its first mode (from the modal solver) with --method
///    at --dt. It writes `<out>/cantilever_dynamic.pvd` with its `.vtu` frames (open the `.pvd` in ParaView to play the animation), `cantilever_dynamic.csv`
///    (time, tip displacement, each energy term, wall time per step) and a JSON summary, and
///    reports the wall time per step and the explicit critical step.
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
    /// energy term: one row per step) and `<stem>_summary.json`. With `--png` (or
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
    /// Directory for the output files.
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
    /// Also render each dynamic frame to PNG.
    #[arg(long)]
    png: bool,
    /// Only the static solve (as before the dynamic part existed).
    #[arg(long)]
    static_only: bool,
    /// No progress bar.
    #[arg(long, short)]
    quiet: bool,
}

#[derive(Debug, Args)]
struct RunArgs {
    /// The scene file (TOML; see scenes/README.md and `tetfem::scene::REFERENCE`).
    scene: PathBuf,
    /// Output directory (overrides the scene's `output.directory`).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Render PNG images (each frame of a dynamic run) even if the scene does not ask for them.
    #[arg(long)]
    png: bool,
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

/// Set by the first Ctrl-C; dynamic runs stop at the next step boundary.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// Installed when a dynamic run starts (before that, Ctrl-C ends the process as usual; every
/// file is written atomically). First Ctrl-C: finish the current step, keep the frames written (the .pvd lists exactly
/// those) and exit with 130. A second Ctrl-C exits at once (every file is written atomically,
/// so none is left half-written).
fn handle_ctrl_c() {
    let installed = ctrlc::set_handler(|| {
        if INTERRUPTED.swap(true, Ordering::SeqCst) {
            std::process::exit(130);
        }
    });
    if let Err(error) = installed {
        eprintln!("warning: Ctrl-C will stop the run without a clean finish: {error}");
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        None => run_default(&cli.default),
        Some(Command::Run(args)) => run_scene(args),
        Some(Command::Info(args)) => info(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(error @ Error::Interrupted { .. }) => {
            eprintln!("tetfem: {error}");
            ExitCode::from(130)
        }
        Err(error) => {
            eprintln!("error: {error}");
            if let Error::Diverged { .. } = error {
                eprintln!(
                    "hint: the explicit method is stable only below its critical step; choose a smaller --dt (e.g. 0.9crit) or an implicit --method"
                );
            }
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
    fn update(&mut self, done: usize, total: usize) -> ControlFlow<()> {
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

fn run_default(cli: &DefaultScene) -> tetfem::Result<()> {
    run_default_static(cli)?;
    if cli.static_only {
        return Ok(());
    }
    run_default_dynamic(cli)
}

fn run_default_static(cli: &DefaultScene) -> tetfem::Result<()> {
    let scene = Cantilever {
        cells: cli.cells,
        ..Cantilever::steel_default()
    };
    let material = scene.material;
    // The whole run's estimate, before the mesh is allocated.
    tetfem::memory::check_box_run(scene.cells, scene.split.tets_per_cell(), false)?;
    println!("tetfem: static cantilever (default scene)");
    println!(
        "  beam {} m × {} m × {} m, E = {:.3e} Pa, ν = {}, ρ = {} kg/m³, end load {} N, g = {} m/s²",
        scene.length,
        scene.width,
        scene.height,
        material.youngs_modulus(),
        material.poisson_ratio(),
        material.density(),
        scene.end_load,
        scene.gravity
    );
    let solved = scene.solve()?;
    let mesh = &solved.mesh;
    println!(
        "  mesh {}×{}×{} cells: {} nodes, {} tets, {} DOFs ({} free), nnz(L) = {}",
        cli.cells[0],
        cli.cells[1],
        cli.cells[2],
        mesh.node_count(),
        mesh.tet_count(),
        mesh.dof_count(),
        solved.free_dofs,
        solved.factor_len
    );
    let t = solved.timings;
    println!("  time per phase:");
    for (phase, time) in [
        ("mesh", solved.mesh_time),
        ("pattern", t.pattern),
        ("assembly", t.assembly),
        ("constraints", t.constraints),
        ("symbolic", t.symbolic),
        ("factorization", t.factorization),
        ("solve", t.solve),
    ] {
        println!("    {phase:<14} {}", format_duration(time));
    }
    let (euler_bernoulli, timoshenko) = scene.beam_theory_tip();
    let tip = solved.tip_deflection;
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
        solved.solution.relative_residual
    );

    let displacement = &solved.solution.displacement;
    let stress = tetfem::output::fields::cell_von_mises(mesh, &material, displacement)?;
    let path = cli.out.join("cantilever.vtu");
    VtuWriter::new(mesh)
        .point_field("displacement", 3, displacement)?
        .cell_field("von_mises_stress", 1, &stress)?
        .write(&path)?;
    println!(
        "  wrote {} (displacement [m] per node, von Mises stress [Pa] per tet)",
        path.display()
    );
    Ok(())
}

fn run_default_dynamic(cli: &DefaultScene) -> tetfem::Result<()> {
    let beam = Cantilever {
        cells: cli.dynamic_cells,
        ..Cantilever::steel_default()
    };
    let c = cli.dynamic_cells;
    tetfem::memory::check_box_run(beam.cells, beam.split.tets_per_cell(), true)?;
    println!();
    println!(
        "tetfem: dynamic cantilever, released from its loaded static shape with the end load removed (gravity stays)"
    );
    let setup = DynamicSetup::released_cantilever(&beam)?;
    let period = setup.first_mode_period()?;
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
    let dt = cli.dt.unwrap_or(match cli.method {
        Method::Explicit => TimeStep::CriticalMultiple(0.9),
        _ => TimeStep::CriticalMultiple(50.0),
    });
    let duration = cli.duration.unwrap_or(cli.periods * period);
    let run = DynamicRun {
        title: "Steel cantilever released from its loaded shape".into(),
        source: "default".into(),
        method: cli.method,
        dt,
        length: RunLength::Duration(duration),
    };
    // A frame interval giving about --frames frames (the critical step is computed once).
    let dt_seconds = setup.resolve(dt)?;
    let steps = (duration / dt_seconds).ceil().max(1.0) as usize;
    let outputs = DynamicOutputs {
        settings: OutputSettings {
            directory: cli.out.clone(),
            stem: "cantilever_dynamic".into(),
            vtu: true,
            every: steps.div_ceil(cli.frames as usize).max(1),
            csv: true,
            png: cli.png,
            png_field: PngField::Displacement,
            png_size: [960, 600],
            deformation_scale: 0.0,
        },
        force_png: false,
    };
    handle_ctrl_c();
    let mut progress = Progress::new(cli.quiet);
    let summary = run_dynamic(&setup, &run, Some(&outputs), &mut |done, total| {
        progress.update(done, total)
    });
    drop(progress);
    let summary = summary?;
    print_dynamic(&summary, &outputs.settings.directory, false);
    Ok(())
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
    println!(
        "  max |u| = {:.4e} m, max von Mises = {:.4e} Pa",
        s.max_displacement, s.max_von_mises
    );
    for p in &s.probes {
        println!(
            "  probe {}: mean u = ({:+.4e}, {:+.4e}, {:+.4e}) m",
            p.name, p.displacement[0], p.displacement[1], p.displacement[2]
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

fn run_scene(args: &RunArgs) -> tetfem::Result<()> {
    let mut scene = Scene::load(&args.scene)?;
    if let Some(out) = &args.out {
        scene.set_output_directory(out.clone());
    }
    let directory = scene.output().directory.clone();
    match scene.analysis() {
        Analysis::Static => {
            let given: Vec<&str> = [
                ("--method", args.method.is_some()),
                ("--dt", args.dt.is_some()),
                ("--duration", args.duration.is_some()),
                ("--steps", args.steps.is_some()),
            ]
            .iter()
            .filter(|(_, set)| *set)
            .map(|(name, _)| *name)
            .collect();
            if !given.is_empty() {
                return Err(Error::invalid_parameter(
                    given.join(", "),
                    args.scene.display(),
                    "applies to dynamic scenes only; this scene is static",
                ));
            }
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
            handle_ctrl_c();
            let mut progress = Progress::new(args.quiet);
            let summary = run_dynamic_scene(&scene, &overrides, true, args.png, &mut |d, t| {
                progress.update(d, t)
            });
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
