//! The cost of a backward-Euler step against the problem's size (issue 39, target 5): linear,
//! corotational, Neo-Hookean, and Neo-Hookean with the ground (IPC barrier, Coulomb friction)
//! at the defaults and on the tight path, on one rubber cube at each size, every run of one
//! size side by side in this one process.
//!
//! The cube: side 0.2 m, E = 100 kPa, ν = 0.3, ρ = 1000 kg/m³, n³ cells of the mirrored 6-tet
//! split, gravity, dt = 0.01 s, the solvers' defaults (`NonlinearSolve::Auto`, step tolerance
//! 1e-8, which `Auto` raises to 1e-3 without contact and to 1e-4 with the ground, where it takes
//! L-BFGS with the contact nodes' blocks in its rest factor; the case "neo-hookean + ground (CG
//! at 1e-8" on the preconditioned CG path named, which factors J once a contact step, at 1e-8).
//! Without contact its base (z = 0) is clamped and it starts thrown sideways at 0.3 m/s
//! (it sways under its weight); with contact it is a free body starting 1 mm above the ground
//! (μ = 0.5) at the same sideways speed: it lands within the first steps and slides, so
//! every step measured is a contact step. A point is the mean wall time of steps 2 to
//! `--steps` (the first holds the symbolic analysis and the rest factorization).
//!
//! Writes `cost_size.csv` (one row a run, with the load average at its start) and
//! `cost_size.png` into `--out`; `--replot` redraws the PNG from that CSV.
//!
//! `RAYON_NUM_THREADS=2 cargo run --release -p tetfem-validation --bin cost_size -- --threads 2`

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use clap::Parser;
use nalgebra::Vector3;
use tetfem::analysis::Definition;
use tetfem::analysis::dynamics::{Method, NonlinearSolve, State, StepNewtonOptions};
use tetfem::analysis::transient::{TimeStep, Transient, TransientOptions};
use tetfem::contact::{Contact, ContactParameters, Obstacle};
use tetfem::fe::materials::MaterialMap;
use tetfem::model::ModelKind;
use tetfem::{BoxSplit, Constraints, Material, Result, TetMesh};
use tetfem_validation::chart::{Chart, Mark, Series};

/// Time per backward-Euler step against DOFs.
#[derive(Debug, Parser)]
struct Cli {
    /// Cells per side of the cube, one run of each model per entry.
    #[arg(long, value_delimiter = ',', default_value = "6,9,14,23")]
    cells: Vec<usize>,
    /// Steps per run (the first is not timed).
    #[arg(long, default_value_t = 11)]
    steps: usize,
    /// Threads of the Cholesky factorization and solves (the assembly's: RAYON_NUM_THREADS).
    #[arg(long, default_value_t = 1)]
    threads: usize,
    /// Folder for the CSV and the PNG.
    #[arg(long, default_value = "validation/report")]
    out: PathBuf,
    /// Append to the CSV already in `--out` (another thread count) instead of starting it.
    #[arg(long)]
    append: bool,
    /// Redraw the PNG from the CSV already in `--out` instead of measuring.
    #[arg(long)]
    replot: bool,
}

const CSV: &str = "cost_size.csv";
const HEADER: &str =
    "case,cells,dofs,threads,steps_timed,seconds_per_step,newton_its_per_step,load_average";
const SIDE: f64 = 0.2;
const SPEED: f64 = 0.3;

/// What is charted: a model, with or without the ground, and the Newton settings.
const CASES: [(&str, ModelKind, bool, Tolerance); 5] = [
    ("linear", ModelKind::Linear, false, Tolerance::Default),
    (
        "corotational",
        ModelKind::Corotational,
        false,
        Tolerance::Default,
    ),
    (
        "neo-hookean",
        ModelKind::NeoHookean,
        false,
        Tolerance::Default,
    ),
    (
        "neo-hookean + ground",
        ModelKind::NeoHookean,
        true,
        Tolerance::Default,
    ),
    (
        "neo-hookean + ground (CG at 1e-8)",
        ModelKind::NeoHookean,
        true,
        Tolerance::TightCg,
    ),
];

/// A case's nonlinear solve and Newton settings.
#[derive(Debug, Clone, Copy)]
enum Tolerance {
    /// `NonlinearSolve::Auto` at `StepNewtonOptions::default()` (step tolerance 1e-8 asked).
    Default,
    /// The preconditioned CG path (`rest_preconditioned`) at 1e-8.
    TightCg,
}

impl Tolerance {
    fn settings(self) -> Result<(NonlinearSolve, StepNewtonOptions)> {
        let solve = match self {
            Tolerance::Default => NonlinearSolve::Auto,
            Tolerance::TightCg => "rest_preconditioned".parse()?,
        };
        Ok((solve, StepNewtonOptions::default()))
    }
}

/// The cube on `cells`³ cells: clamped at its base, or (`ground`) free 1 mm above the ground.
fn cube(cells: usize, model: ModelKind, ground: bool) -> Result<Definition> {
    let lift = if ground { 1e-3 } else { 0.0 };
    let mesh = TetMesh::box_grid(
        Vector3::new(0.0, 0.0, lift),
        Vector3::new(SIDE, SIDE, lift + SIDE),
        [cells; 3],
        BoxSplit::Mirrored6,
    )?;
    let rubber = Material::new(1e5, 0.3, 1000.0)?;
    let materials = MaterialMap::uniform(rubber, mesh.tet_count());
    let builder = |mesh| {
        Definition::builder(mesh, materials.clone())
            .model(model)
            .gravity(Vector3::new(0.0, 0.0, -9.81))
    };
    if ground {
        let floor =
            Obstacle::half_space("ground", Vector3::zeros(), Vector3::z())?.with_friction(0.5)?;
        let parameters = ContactParameters::for_mesh(&mesh, rubber.youngs_modulus())?;
        let contact = Contact::new(&mesh, vec![floor], parameters)?;
        return builder(mesh)?.contact(contact).build();
    }
    let mut constraints = Constraints::new(&mesh);
    constraints.fix_nodes(&mesh.nodes_on_plane(2, 0.0, 1e-9))?;
    builder(mesh)?.constraints(constraints)?.build()
}

/// One run: (free DOFs, mean seconds per step after the first, Newton iterations per step).
fn measure(
    definition: &Definition,
    (steps, threads): (usize, usize),
    (solve, newton): (NonlinearSolve, StepNewtonOptions),
) -> Result<(usize, f64, f64)> {
    let mut options = TransientOptions::new(Method::BackwardEuler, TimeStep::Seconds(0.01));
    options.solver.cholesky.threads = threads;
    options.solver.nonlinear_solve = solve;
    options.solver.newton = newton;
    let mut run = Transient::new(definition, options)?;
    let free = run.system().free_count();
    let velocity: Vec<f64> = (0..definition.mesh.dof_count())
        .map(|dof| if dof % 3 == 0 { SPEED } else { 0.0 })
        .collect();
    let mut state = State::at_rest(free);
    state.velocity = run.system().dofs().restrict(&velocity)?;
    *run.state_mut() = state;
    run.step()?;
    let before = run.integrator().newton_stats().unwrap_or_default();
    let clock = Instant::now();
    for _ in 1..steps {
        run.step()?;
    }
    let seconds = clock.elapsed().as_secs_f64() / (steps - 1) as f64;
    let after = run.integrator().newton_stats().unwrap_or_default();
    let iterations = (after.total_iterations - before.total_iterations) as f64 / (steps - 1) as f64;
    Ok((free, seconds, iterations))
}

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|s| s.split_whitespace().next().map(str::to_owned))
        .unwrap_or_else(|| "nan".into())
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(&cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("error: {error}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: &Cli) -> Result<()> {
    let path = cli.out.join(CSV);
    if !cli.replot {
        if cli.steps < 2 {
            return Err(tetfem::Error::invalid_parameter(
                "--steps",
                cli.steps,
                "must be at least 2 (the first step is not timed)",
            ));
        }
        let mut csv = match cli.append {
            true => read(&path)?,
            false => format!("{HEADER}\n"),
        };
        for &cells in &cli.cells {
            for (case, model, ground, tolerance) in CASES {
                let load = load_average();
                let definition = cube(cells, model, ground)?;
                let runs = (cli.steps, cli.threads);
                let (dofs, seconds, its) = measure(&definition, runs, tolerance.settings()?)?;
                let line = format!(
                    "{case},{cells},{dofs},{},{},{seconds:.6e},{its:.2},{load}",
                    cli.threads,
                    cli.steps - 1
                );
                println!("{line}");
                writeln!(csv, "{line}").expect("writing to a String");
                write(&path, &csv)?;
            }
        }
    }
    plot(&read(&path)?, &cli.out)
}

fn read(path: &Path) -> Result<String> {
    std::fs::read_to_string(path).map_err(|source| tetfem::Error::Io {
        path: path.to_path_buf(),
        source,
    })
}

fn write(path: &Path, text: &str) -> Result<()> {
    std::fs::create_dir_all(path.parent().unwrap_or(Path::new("."))).map_err(|source| {
        tetfem::Error::Io {
            path: path.to_path_buf(),
            source,
        }
    })?;
    std::fs::write(path, text).map_err(|source| tetfem::Error::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// One series per (case, threads) of the CSV: seconds per step against DOFs, log–log.
fn plot(csv: &str, out: &Path) -> Result<()> {
    let mut series: Vec<Series> = Vec::new();
    for line in csv.lines().skip(1) {
        let fields: Vec<&str> = line.split(',').collect();
        let [case, _, dofs, threads, _, seconds, ..] = fields[..] else {
            continue;
        };
        let (Ok(dofs), Ok(seconds)) = (dofs.parse::<f64>(), seconds.parse::<f64>()) else {
            continue;
        };
        let label = format!("{case}, {threads} thread(s)");
        match series.iter_mut().find(|s| s.label == label) {
            Some(s) => s.points.push((dofs, seconds)),
            None => series.push(Series::new(label, vec![(dofs, seconds)], Mark::LinePoints)),
        }
    }
    for s in &mut series {
        s.points.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
    let chart = Chart {
        title: "Backward-Euler step of a rubber cube, dt = 10 ms: time against size".into(),
        x_label: "free DOFs (–)".into(),
        y_label: "wall time per step (s)".into(),
        log_x: true,
        log_y: true,
        series,
    };
    chart.write_png(&out.join(CSV).with_extension("png"), 1100, 700)
}
