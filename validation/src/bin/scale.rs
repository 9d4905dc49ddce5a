//! Scale study: the static pipeline on cantilever box beams (5k × k × k cells of the lecture's
//! split) from ~300 to ~1M DOFs, each size in its own process so that its peak memory is its
//! own. Writes `validation/PERFORMANCE.md` and its charts.
//!
//! `cargo run --release --bin scale` (full, ~15 min, needs ~18 GB at 1M DOFs) or `-- --quick`.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::{Command, ExitCode};
use std::sync::Arc;
use std::time::Instant;

use clap::Parser;
use nalgebra::Vector3;
use tetfem::analysis::dynamics::{
    IntegratorOptions, LinearSystem, MassKind, Method, Rayleigh, State, critical_time_step,
};
use tetfem::{
    Assembler, CholeskyOptions, DofMap, FillOrdering, LinearMethod, LinearSolver, SolverOptions,
};
use tetfem_fixtures::cantilever::Cantilever;
use tetfem_validation::cells::parse_cells;
use tetfem_validation::chart::{Chart, Mark, Series};

/// Scale study of the static solve: time and peak memory per phase against the number of DOFs.
#[derive(Debug, Parser)]
struct Cli {
    /// Only sizes up to ~10k DOFs (seconds; for CI).
    #[arg(long)]
    quick: bool,
    /// Largest k of the 5k×k×k cell grids (default 40: 1.01M DOFs).
    #[arg(long, default_value_t = 40)]
    max_k: usize,
    /// Output directory of the report.
    #[arg(long, default_value = "validation")]
    out: PathBuf,
    /// Reuse the measurements already in `<out>/scale_results.txt` and run only the missing
    /// (size, method, threads) combinations; the raw lines of every run are kept there.
    #[arg(long)]
    resume: bool,
    /// Internal: run one size in this process and print its measurements.
    #[arg(long, hide = true)]
    one: Option<usize>,
    /// Internal: method of the single run (direct | iterative).
    #[arg(long, hide = true, default_value = "direct")]
    method: String,
    /// Internal: threads of the single run.
    #[arg(long, hide = true, default_value_t = 1)]
    threads: usize,
    /// Run one size given as cells NX,NY,NZ (the peers' n×n/10×n/10 beams) and print its
    /// measurements as one `RESULT` line (used by validation/side_by_side.py).
    #[arg(long, value_parser = parse_cells)]
    cells: Option<[usize; 3]>,
    /// Ordering of the single run: nested-dissection (default) or amd.
    #[arg(long, default_value = "nested-dissection")]
    ordering: String,
    /// Single run (`--one` or `--cells`): time only the time steps listed (comma-separated:
    /// backward-euler, explicit) and skip the static factorization and solve, whose phases
    /// then read 0. For measuring the steps at a large size without the static solve's minutes.
    #[arg(long, value_delimiter = ',')]
    steps_only: Option<Vec<String>>,
}

const PHASES: [&str; 7] = [
    "mesh",
    "pattern",
    "assembly",
    "constraints",
    "symbolic",
    "numeric",
    "solve",
];

/// One size's measurements.
#[derive(Debug, Clone, Default)]
struct Run {
    k: usize,
    method: String,
    threads: usize,
    dofs: usize,
    tets: usize,
    nnz_k: usize,
    factor_len: usize,
    seconds: [f64; 7],
    peak_mib: [f64; 7],
    tip: f64,
    residual: f64,
    cg_iterations: usize,
    /// Best-of-repeats wall time of one backward-Euler and one explicit step \[s\] (0: not run).
    step_seconds: [f64; 2],
    /// Bytes each step must move at least (see `time_steps`): backward Euler, explicit, and
    /// explicit counting each of K_ff's unique values (upper half) once.
    step_floor_bytes: [f64; 3],
    /// Triad bandwidth measured in the run's own process, with its thread count [B/s].
    bandwidth: f64,
    /// Iterative runs: backward-Euler steps at 100 critical steps solved by CG + SA-AMG: the
    /// first step (multigrid setup of M + dt²K included) (s), the best of the next three (s),
    /// and the process's peak memory after them (MiB) (zeros: not run).
    iterative_steps: [f64; 3],
    /// Best of three in-place refills of K's values on its pattern
    /// (`Assembler::refill_stiffness`) (s) (0: not run).
    refill_seconds: f64,
}

/// Largest k whose direct runs also time the time steps (the backward-Euler step needs a second
/// factorization, of M + dt²·K; at k = 40 that would add five minutes).
const MAX_STEP_K: usize = 30;

fn peak_rss_mib() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
        })
        .map_or(f64::NAN, |kib| kib / 1024.0)
}

/// Which parts of the pipeline a single run measures.
#[derive(Debug, Clone)]
struct Parts {
    /// The static factorization and solve.
    static_solve: bool,
    /// The integrators whose steps are timed (direct runs up to k = [`MAX_STEP_K`] only, unless
    /// the static solve is skipped).
    steps: Vec<Method>,
}

/// Runs the static pipeline on one beam and times the steps `parts` asks for.
fn run_one(
    cells: [usize; 3],
    method: &str,
    threads: usize,
    ordering: &str,
    parts: &Parts,
) -> tetfem::Result<Run> {
    let k = cells[1];
    let problem = Cantilever::peer_benchmark(cells);
    let mut run = Run {
        k,
        method: method.to_string(),
        threads,
        ..Default::default()
    };
    let mut phase = 0;
    let mut clock = Instant::now();
    let mut lap = |run: &mut Run| {
        run.seconds[phase] = clock.elapsed().as_secs_f64();
        run.peak_mib[phase] = peak_rss_mib();
        phase += 1;
        clock = Instant::now();
    };
    let mesh = problem.mesh()?;
    lap(&mut run);
    let assembler = Assembler::new(&mesh);
    lap(&mut run);
    let k_full = assembler.stiffness(&mesh, &problem.material)?;
    lap(&mut run);
    let constraints = problem.constraints(&mesh)?;
    let dofs = DofMap::new(&constraints);
    tetfem::bc::constraints::ensure_held(&mesh, &mesh.face_topology()?, &dofs)?;
    let k_ff = dofs.restriction(k_full.pattern())?.restrict(&k_full)?;
    let rhs = dofs.restrict(problem.loads(&mesh)?.as_slice())?;
    lap(&mut run);
    run.dofs = mesh.dof_count();
    run.tets = mesh.tet_count();
    run.nnz_k = k_full.nnz();
    if !parts.static_solve {
        drop((k_ff, k_full, assembler));
        run.bandwidth = triad_bandwidth();
        time_steps(&problem, &mesh, &parts.steps, &mut run)?;
        return Ok(run);
    }
    let options = SolverOptions {
        method: method.parse::<LinearMethod>()?,
        cholesky: CholeskyOptions {
            ordering: ordering.parse::<FillOrdering>()?,
            threads,
        },
        ..Default::default()
    };
    let geometry = dofs.geometry_for_method(options.method, &mesh)?;
    let mut solver = LinearSolver::analyze_with_geometry(&k_ff, options, geometry)?;
    lap(&mut run);
    solver.factorize(&k_ff)?;
    lap(&mut run);
    let mut x = rhs.clone();
    let info = solver.solve(&k_ff, &mut x)?;
    lap(&mut run);
    if let tetfem::linalg::linear_solver::SolveInfo::Iterative { iterations, .. } = info {
        run.cg_iterations = iterations;
    }
    let residual: f64 = k_ff
        .mul(&x)?
        .iter()
        .zip(&rhs)
        .map(|(a, b)| (a - b) * (a - b))
        .sum::<f64>()
        .sqrt();
    run.residual = residual / rhs.iter().map(|b| b * b).sum::<f64>().sqrt();
    run.tip = problem.tip_deflection(&mesh, &dofs.expand(&x)?)?;
    run.factor_len = solver.factor_len();
    // The refill a time stepper or a Newton loop pays per matrix: values only, into the
    // existing array (the assembly phase above also allocates and first-touches it).
    let mut k_full = k_full;
    run.refill_seconds = f64::INFINITY;
    for _ in 0..3 {
        let clock = Instant::now();
        assembler.refill_stiffness(&mesh, &problem.material, &mut k_full)?;
        run.refill_seconds = run.refill_seconds.min(clock.elapsed().as_secs_f64());
    }
    run.bandwidth = triad_bandwidth();
    if !parts.steps.is_empty() && method == "direct" && k <= MAX_STEP_K {
        drop((solver, k_ff, k_full, assembler));
        time_steps(&problem, &mesh, &parts.steps, &mut run)?;
    } else if parts.steps.contains(&Method::BackwardEuler) && method == "iterative" {
        drop((solver, k_ff, k_full, assembler));
        time_iterative_steps(&problem, &mesh, &mut run)?;
    }
    Ok(run)
}

/// The beam's linear dynamic system: lumped mass, gravity, its end load, no damping.
fn beam_system(problem: &Cantilever, mesh: &tetfem::TetMesh) -> tetfem::Result<Arc<LinearSystem>> {
    Ok(Arc::new(LinearSystem::new(
        mesh,
        &problem.material,
        &problem.constraints(mesh)?,
        &problem.loads(mesh)?,
        Vector3::new(0.0, 0.0, -9.81),
        MassKind::Lumped,
        Rayleigh::default(),
    )?))
}

/// Times backward-Euler steps whose systems are solved by CG with smoothed-aggregation
/// multigrid ([`LinearMethod::Iterative`]), at 100 critical time steps as in [`time_steps`]:
/// the time-stepping path for meshes whose factor would not fit in memory.
fn time_iterative_steps(
    problem: &Cantilever,
    mesh: &tetfem::TetMesh,
    run: &mut Run,
) -> tetfem::Result<()> {
    let system = beam_system(problem, mesh)?;
    let dt = 100.0 * critical_time_step(&system)?.dt;
    let options = IntegratorOptions {
        linear_method: LinearMethod::Iterative,
        ..Default::default()
    };
    let mut integrator = Method::BackwardEuler.integrator_with(Arc::clone(&system), dt, options)?;
    let mut state = State::at_rest(system.free_count());
    let clock = Instant::now();
    integrator.step(&mut state)?;
    run.iterative_steps[0] = clock.elapsed().as_secs_f64();
    let mut best = f64::INFINITY;
    for _ in 0..3 {
        let clock = Instant::now();
        integrator.step(&mut state)?;
        best = best.min(clock.elapsed().as_secs_f64());
    }
    run.iterative_steps[1] = best;
    run.iterative_steps[2] = peak_rss_mib();
    Ok(())
}

/// Times one backward-Euler step (after its factorization) and one explicit step on the beam,
/// best of several, and records the bytes each must move:
///
/// - explicit: K_ff's values once (8 B per stored entry, whatever the format) and six vectors
///   (u, v, f, M⁻¹ read; u, v written); and, stricter, the same with K_ff's unique values only
///   (its upper half with the diagonal, 8 B · (nnz + n)/2), the least any format can read and
///   what the integrators' upper node-block format stores;
/// - backward Euler: the same, plus the Cholesky factor's values read twice (forward and
///   backward substitution); its factorization and solves use the run's threads.
fn time_steps(
    problem: &Cantilever,
    mesh: &tetfem::TetMesh,
    methods: &[Method],
    run: &mut Run,
) -> tetfem::Result<()> {
    let system = beam_system(problem, mesh)?;
    let dt_critical = critical_time_step(&system)?.dt;
    let n = system.free_count() as f64;
    let vectors = 6.0 * 8.0 * n;
    let stiffness = 8.0 * system.stiffness().nnz() as f64;
    let unique = 8.0 * (system.stiffness().nnz() as f64 + n) / 2.0;
    for (slot, method, dt, repeats) in [
        (0, Method::BackwardEuler, 100.0 * dt_critical, 5),
        (1, Method::Explicit, 0.9 * dt_critical, 20),
    ] {
        if !methods.contains(&method) {
            continue;
        }
        // The implicit step's factorization and solves on the run's threads, like the static
        // solve's.
        let options = IntegratorOptions {
            cholesky: CholeskyOptions {
                threads: run.threads,
                ..Default::default()
            },
            ..Default::default()
        };
        let mut integrator = method.integrator_with(Arc::clone(&system), dt, options)?;
        let mut state = State::at_rest(system.free_count());
        integrator.step(&mut state)?; // the factorization, outside the timing
        let mut best = f64::INFINITY;
        for _ in 0..repeats {
            let clock = Instant::now();
            integrator.step(&mut state)?;
            best = best.min(clock.elapsed().as_secs_f64());
        }
        run.step_seconds[slot] = best;
        run.step_floor_bytes[slot] = stiffness + vectors;
        if method == Method::Explicit {
            run.step_floor_bytes[2] = unique + vectors;
        }
        if method == Method::BackwardEuler {
            let factor_len = integrator.factor_len().unwrap_or(0) as f64;
            run.step_floor_bytes[slot] += 2.0 * 8.0 * factor_len;
        }
    }
    run.bandwidth = run.bandwidth.max(triad_bandwidth());
    Ok(())
}

fn encode(run: &Run) -> String {
    let list = |v: &[f64]| {
        v.iter()
            .map(|x| format!("{x:e}"))
            .collect::<Vec<_>>()
            .join(",")
    };
    format!(
        "RESULT {} {} {} {} {} {} {} {} {} {:e} {:e} {} {} {} {:e} {} {:e}",
        run.k,
        run.method,
        run.threads,
        run.dofs,
        run.tets,
        run.nnz_k,
        run.factor_len,
        list(&run.seconds),
        list(&run.peak_mib),
        run.tip,
        run.residual,
        run.cg_iterations,
        list(&run.step_seconds),
        list(&run.step_floor_bytes),
        run.bandwidth,
        list(&run.iterative_steps),
        run.refill_seconds
    )
}

fn decode(line: &str) -> Option<Run> {
    let f: Vec<&str> = line.strip_prefix("RESULT ")?.split(' ').collect();
    fn list<const N: usize>(s: &str) -> Option<[f64; N]> {
        let v: Vec<f64> = s
            .split(',')
            .map(|x| x.parse().ok())
            .collect::<Option<_>>()?;
        v.try_into().ok()
    }
    Some(Run {
        k: f.first()?.parse().ok()?,
        method: f.get(1)?.to_string(),
        threads: f.get(2)?.parse().ok()?,
        dofs: f.get(3)?.parse().ok()?,
        tets: f.get(4)?.parse().ok()?,
        nnz_k: f.get(5)?.parse().ok()?,
        factor_len: f.get(6)?.parse().ok()?,
        seconds: list(f.get(7)?)?,
        peak_mib: list(f.get(8)?)?,
        tip: f.get(9)?.parse().ok()?,
        residual: f.get(10)?.parse().ok()?,
        cg_iterations: f.get(11)?.parse().ok()?,
        // Lines written before the steps were timed end here.
        step_seconds: f.get(12).and_then(|s| list(s)).unwrap_or_default(),
        step_floor_bytes: f.get(13).and_then(|s| list(s)).unwrap_or_default(),
        bandwidth: f.get(14).and_then(|s| s.parse().ok()).unwrap_or_default(),
        iterative_steps: f.get(15).and_then(|s| list(s)).unwrap_or_default(),
        refill_seconds: f.get(16).and_then(|s| s.parse().ok()).unwrap_or_default(),
    })
}

/// Least-squares slope of log(y) against log(x).
fn growth_exponent(points: &[(f64, f64)]) -> f64 {
    let logs: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, y)| *x > 0.0 && *y > 0.0)
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    let n = logs.len() as f64;
    let (sx, sy) = logs
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x, b + y));
    let (mx, my) = (sx / n, sy / n);
    let (sxy, sxx) = logs.iter().fold((0.0, 0.0), |(a, b), (x, y)| {
        (a + (x - mx) * (y - my), b + (x - mx) * (x - mx))
    });
    sxy / sxx
}

/// Streaming triad a = b + s·c over 3 × 64 MiB arrays on all cores, best of 5: the memory
/// bandwidth that bounds the solves (bytes moved / second).
fn triad_bandwidth() -> f64 {
    use rayon::prelude::*;
    let n = 8 << 20;
    let (b, c) = (vec![1.0f64; n], vec![2.0f64; n]);
    let mut a = vec![0.0f64; n];
    let mut best = f64::INFINITY;
    for _ in 0..5 {
        let t = Instant::now();
        a.par_chunks_mut(1 << 16)
            .zip(b.par_chunks(1 << 16).zip(c.par_chunks(1 << 16)))
            .for_each(|(a, (b, c))| {
                for i in 0..a.len() {
                    a[i] = b[i] + 3.0 * c[i];
                }
            });
        std::hint::black_box(&a);
        best = best.min(t.elapsed().as_secs_f64());
    }
    3.0 * 8.0 * n as f64 / best
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let single = cli.cells.or(cli.one.map(|k| [5 * k, k, k]));
    if let Some(cells) = single {
        // The study (`--one`) times the steps too; side_by_side.py's `--cells` runs need only
        // the static phases.
        let parts = match &cli.steps_only {
            Some(names) => match names.iter().map(|n| n.parse()).collect() {
                Ok(steps) => Parts {
                    static_solve: false,
                    steps,
                },
                Err(e) => {
                    eprintln!("error: --steps-only: {e}");
                    return ExitCode::FAILURE;
                }
            },
            None => Parts {
                static_solve: true,
                steps: if cli.one.is_some() {
                    vec![Method::BackwardEuler, Method::Explicit]
                } else {
                    Vec::new()
                },
            },
        };
        return match run_one(cells, &cli.method, cli.threads, &cli.ordering, &parts) {
            Ok(run) => {
                println!("{}", encode(&run));
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::FAILURE
            }
        };
    }
    match study(&cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn study(cli: &Cli) -> Result<(), Box<dyn std::error::Error>> {
    let ks: Vec<usize> = [2, 3, 4, 6, 8, 12, 16, 20, 24, 30, 40]
        .into_iter()
        .filter(|&k| k <= if cli.quick { 8 } else { cli.max_k })
        .collect();
    let exe = std::env::current_exe()?;
    let raw_path = cli.out.join(if cli.quick {
        "scale_results_quick.txt"
    } else {
        "scale_results.txt"
    });
    let previous = if cli.resume {
        std::fs::read_to_string(&raw_path).unwrap_or_default()
    } else {
        String::new()
    };
    let mut runs: Vec<Run> = previous.lines().filter_map(decode).collect();
    // Failed runs are kept as "FAILED k method threads: reason" lines: reported, not retried.
    let mut failures: Vec<String> = previous
        .lines()
        .filter(|l| l.starts_with("FAILED "))
        .map(String::from)
        .collect();
    let mut plan: Vec<(usize, &str, usize)> = ks.iter().map(|&k| (k, "direct", 1)).collect();
    // Two threads at a few sizes. CG with smoothed-aggregation AMG needs ~30 iterations at every
    // size (29 at 1.01M DOFs), so the iterative path runs up to the largest size.
    for &k in ks.iter().filter(|&&k| [8, 20, 30].contains(&k)) {
        plan.push((k, "direct", 2));
    }
    for &k in ks
        .iter()
        .filter(|&&k| [4, 8, 12, 16, 24, 30, 40].contains(&k))
    {
        plan.push((k, "iterative", 2));
    }
    for (k, method, threads) in plan {
        let key = format!("FAILED {k} {method} {threads}:");
        if runs
            .iter()
            .any(|r| r.k == k && r.method == method && r.threads == threads)
            || failures.iter().any(|f| f.starts_with(&key))
        {
            continue;
        }
        eprintln!("scale: 5k×k×k with k = {k}, {method}, {threads} thread(s) …");
        let out = Command::new(&exe)
            .args([
                "--one",
                &k.to_string(),
                "--method",
                method,
                "--threads",
                &threads.to_string(),
            ])
            .env("RAYON_NUM_THREADS", threads.to_string())
            .output()?;
        let text = String::from_utf8_lossy(&out.stdout);
        match text.lines().find_map(decode) {
            Some(run) => {
                eprintln!(
                    "  {} DOFs: numeric {:.3} s, solve {:.3} s, peak {:.0} MiB",
                    run.dofs, run.seconds[5], run.seconds[6], run.peak_mib[6]
                );
                runs.push(run);
            }
            None => {
                let reason = String::from_utf8_lossy(&out.stderr)
                    .trim()
                    .replace('\n', " ");
                eprintln!("  failed: {reason}");
                failures.push(format!("{key} {reason}"));
            }
        }
        let lines: String = runs
            .iter()
            .map(encode)
            .chain(failures.iter().cloned())
            .map(|l| l + "\n")
            .collect();
        tetfem::post::output::write_atomically(&raw_path, |w| w.write_all(lines.as_bytes()))?;
    }
    runs.sort_by_key(|r| (r.method != "direct", r.threads, r.k));
    report(cli, &runs, &failures)
}

fn report(cli: &Cli, runs: &[Run], failures: &[String]) -> Result<(), Box<dyn std::error::Error>> {
    // The triad on this process's pool (all cores) and on one thread, for each run's floors.
    let bandwidth = triad_bandwidth();
    let one_thread = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .map_or(bandwidth, |pool| pool.install(triad_bandwidth));
    let serial: Vec<&Run> = runs
        .iter()
        .filter(|r| r.method == "direct" && r.threads == 1)
        .collect();
    let mut md = String::new();
    write_header(&mut md, cli, bandwidth, one_thread)?;
    write_phase_table(&mut md, runs, failures)?;
    let phase_series = write_growth(&mut md, &serial)?;
    write_floors(&mut md, runs, bandwidth, one_thread)?;
    write_iterative_steps(&mut md, runs)?;
    side_by_side(&mut md, &cli.out)?;
    kept_by_hand(&mut md, &cli.out.join("PERFORMANCE.md"));
    write_charts(cli, runs, &serial, phase_series)?;
    writeln!(md, "![time per phase](performance_time.png)")?;
    writeln!(md)?;
    writeln!(md, "![peak memory](performance_memory.png)")?;
    let path = cli.out.join("PERFORMANCE.md");
    tetfem::post::output::write_atomically(&path, |w| w.write_all(md.as_bytes()))?;
    eprintln!("wrote {}", path.display());
    Ok(())
}

/// The report's title, provenance and the machine and problem it measured.
fn write_header(
    md: &mut String,
    cli: &Cli,
    bandwidth: f64,
    one_thread: f64,
) -> Result<(), Box<dyn std::error::Error>> {
    writeln!(md, "# tetfem performance: scale study")?;
    writeln!(md)?;
    writeln!(
        md,
        "Generated by `cargo run --release --bin scale{}` — do not edit by hand.",
        if cli.quick { " -- --quick" } else { "" }
    )?;
    writeln!(md)?;
    writeln!(
        md,
        "Machine: {} cores, measured memory bandwidth (triad) {:.1} GB/s on all cores, {:.1} GB/s on one. Commit: {}. Problem: cantilever \
         box beams 5k×k×k cells (lecture split), E = 1e5, ν = 0.3, clamped at x = 0, end load; static solve \
         K_ff·u = f with METIS nested-dissection ordering. Each size runs in its own process; peak memory is \
         that process's VmHWM at the end of each phase. Iterative runs: conjugate gradients preconditioned by \
         smoothed-aggregation AMG with the rigid-body modes (relative residual 1e-10, or the rounding floor \
         ε·‖|K|·|u|‖/‖f‖ where that is higher); their 'numeric' phase is the AMG setup and they store no factor. \
         Times are single runs on a shared 2-core machine: compare ratios within one run.",
        std::thread::available_parallelism().map_or(1, |n| n.get()),
        bandwidth / 1e9,
        one_thread / 1e9,
        commit()
    )?;
    writeln!(md)?;
    Ok(())
}

/// The table of every run's phase times and peak memory, and the runs that did not finish.
fn write_phase_table(
    md: &mut String,
    runs: &[Run],
    failures: &[String],
) -> Result<(), Box<dyn std::error::Error>> {
    writeln!(md, "## Time per phase [s], peak memory [MiB]")?;
    writeln!(md)?;
    writeln!(
        md,
        "| cells | DOFs | tets | method | threads | nnz(K) | factor values | mesh | pattern | assembly | constraints | symbolic | numeric | solve | CG its | peak MiB | rel. residual | tip |"
    )?;
    writeln!(md, "|{}", "---|".repeat(18))?;
    for r in runs {
        let s = &r.seconds;
        writeln!(
            md,
            "| {}×{}×{} | {} | {} | {} | {} | {} | {} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} | {} | {:.0} | {:.1e} | {:.9e} |",
            5 * r.k,
            r.k,
            r.k,
            r.dofs,
            r.tets,
            r.method,
            r.threads,
            r.nnz_k,
            r.factor_len,
            s[0],
            s[1],
            s[2],
            s[3],
            s[4],
            s[5],
            s[6],
            r.cg_iterations,
            r.peak_mib[6],
            r.residual,
            r.tip
        )?;
    }
    if !failures.is_empty() {
        writeln!(md)?;
        writeln!(
            md,
            "Runs that did not finish (kept in the raw results, not retried):"
        )?;
        writeln!(md)?;
        for f in failures {
            writeln!(md, "- k = {}", f.trim_start_matches("FAILED "))?;
        }
    }
    Ok(())
}

/// The growth exponents of each phase (and of memory and fill) over the serial direct runs
/// of ≥ 10k DOFs; returns each phase's time series for the chart.
fn write_growth(
    md: &mut String,
    serial: &[&Run],
) -> Result<Vec<Series>, Box<dyn std::error::Error>> {
    writeln!(md)?;
    writeln!(
        md,
        "## Growth exponents (time ∝ DOFs^p, least squares over sizes ≥ 10k DOFs, 1 thread, direct)"
    )?;
    writeln!(md)?;
    writeln!(md, "| phase | p |")?;
    writeln!(md, "|---|---|")?;
    let large: Vec<&&Run> = serial.iter().filter(|r| r.dofs >= 10_000).collect();
    let mut phase_series = Vec::new();
    for (p, name) in PHASES.iter().enumerate() {
        let points: Vec<(f64, f64)> = large
            .iter()
            .map(|r| (r.dofs as f64, r.seconds[p]))
            .collect();
        if points.len() >= 2 {
            writeln!(md, "| {name} | {:.2} |", growth_exponent(&points))?;
        }
        phase_series.push(Series::new(
            *name,
            serial
                .iter()
                .map(|r| (r.dofs as f64, r.seconds[p]))
                .collect(),
            Mark::LinePoints,
        ));
    }
    let memory: Vec<(f64, f64)> = large
        .iter()
        .map(|r| (r.dofs as f64, r.peak_mib[6]))
        .collect();
    let fill: Vec<(f64, f64)> = large
        .iter()
        .map(|r| (r.dofs as f64, r.factor_len as f64))
        .collect();
    if memory.len() >= 2 {
        writeln!(md, "| peak memory | {:.2} |", growth_exponent(&memory))?;
        writeln!(md, "| factor values | {:.2} |", growth_exponent(&fill))?;
    }
    Ok(phase_series)
}

/// The solve and the time steps against their memory-bandwidth floors.
fn write_floors(
    md: &mut String,
    runs: &[Run],
    bandwidth: f64,
    one_thread: f64,
) -> Result<(), Box<dyn std::error::Error>> {
    writeln!(md)?;
    writeln!(md, "## Solve and time steps against their bandwidth floors")?;
    writeln!(md)?;
    writeln!(
        md,
        "Each floor is the bytes that must move over the memory bandwidth bw, the higher of two triads with the \
         run's thread count: one in the run's own process, one in the process writing this report (so a triad \
         slowed by noise cannot flatter a ratio). The static solve reads the Cholesky factor's values \
         twice (2 · 8 B · factor values); an explicit step reads K_ff's values once (8 B per stored entry) and moves \
         six vectors (u, v, f, M⁻¹ read, u, v written); a backward-Euler step moves the same plus its own factor \
         (of M + dt²K, the same pattern) twice. The last column holds the explicit step to a stricter floor: K_ff's \
         unique values only (its upper half with the diagonal), the least any format can read, and what the \
         integrators' upper node-block format stores. Index bytes are not in the floors: they are the formats' overhead. \
         Steps are the best of 5 (backward Euler, after its factorization) or 20 (explicit) on sizes up to k = {MAX_STEP_K}."
    )?;
    writeln!(md)?;
    writeln!(
        md,
        "| DOFs | threads | bw [GB/s] | solve [s] | floor | ratio | BE step [s] | floor | ratio | explicit step [s] | floor | ratio | ratio, unique values |"
    )?;
    writeln!(md, "|{}", "---|".repeat(13))?;
    for r in runs
        .iter()
        .filter(|r| r.method == "direct" && r.dofs >= 10_000)
    {
        let reference = if r.threads == 1 {
            one_thread
        } else {
            bandwidth
        };
        let bw = r.bandwidth.max(reference);
        let solve_floor = 2.0 * 8.0 * r.factor_len as f64 / bw;
        let mut row = format!(
            "| {} | {} | {:.1} | {:.4} | {:.4} | {:.2} |",
            r.dofs,
            r.threads,
            bw / 1e9,
            r.seconds[6],
            solve_floor,
            r.seconds[6] / solve_floor
        );
        for slot in 0..2 {
            if r.step_seconds[slot] > 0.0 {
                let floor = r.step_floor_bytes[slot] / bw;
                write!(
                    row,
                    " {:.5} | {:.5} | {:.2} |",
                    r.step_seconds[slot],
                    floor,
                    r.step_seconds[slot] / floor
                )?;
            } else {
                row.push_str(" – | – | – |");
            }
        }
        if r.step_seconds[1] > 0.0 && r.step_floor_bytes[2] > 0.0 {
            write!(
                row,
                " {:.2} |",
                r.step_seconds[1] * bw / r.step_floor_bytes[2]
            )?;
        } else {
            row.push_str(" – |");
        }
        writeln!(md, "{row}")?;
    }
    writeln!(md)?;
    Ok(())
}

/// The iterative runs' backward-Euler steps, where they took some.
fn write_iterative_steps(md: &mut String, runs: &[Run]) -> Result<(), Box<dyn std::error::Error>> {
    let iterative_steps: Vec<&Run> = runs
        .iter()
        .filter(|r| r.method == "iterative" && r.iterative_steps[1] > 0.0)
        .collect();
    if !iterative_steps.is_empty() {
        writeln!(md, "## Backward-Euler steps on the iterative path")?;
        writeln!(md)?;
        writeln!(
            md,
            "The iterative runs also take backward-Euler steps at 100 critical time steps (lumped mass, \
             no damping) with `IntegratorOptions {{ linear_method: LinearMethod::Iterative, .. }}`: each step \
             solves (M + dt²K)·Δv = rhs by CG preconditioned by smoothed aggregation with the rigid-body modes, \
             to the default relative tolerance 1e-10; the hierarchy is built on the first step, once per time \
             step value. The time-stepping path for meshes whose factor does not fit in memory. Peak memory is \
             the run's process at the end, static solve included."
        )?;
        writeln!(md)?;
        writeln!(
            md,
            "| DOFs | threads | first step (with multigrid setup) [s] | step [s] | peak memory [GB] |"
        )?;
        writeln!(md, "|---|---|---|---|---|")?;
        for r in iterative_steps {
            writeln!(
                md,
                "| {} | {} | {:.3} | {:.3} | {:.2} |",
                r.dofs,
                r.threads,
                r.iterative_steps[0],
                r.iterative_steps[1],
                r.iterative_steps[2] * 1.048576e-3
            )?;
        }
        writeln!(md)?;
    }
    Ok(())
}

/// The time-per-phase and peak-memory charts next to the report.
fn write_charts(
    cli: &Cli,
    runs: &[Run],
    serial: &[&Run],
    phase_series: Vec<Series>,
) -> Result<(), Box<dyn std::error::Error>> {
    let time_chart = Chart {
        title: "Static pipeline: time per phase (1 thread, direct)".into(),
        x_label: "degrees of freedom".into(),
        y_label: "wall time [s]".into(),
        log_x: true,
        log_y: true,
        series: phase_series,
    };
    time_chart.write_png(&cli.out.join("performance_time.png"), 900, 620)?;
    let mut memory_series = vec![Series::new(
        "peak RSS, direct (1 thread)",
        serial
            .iter()
            .map(|r| (r.dofs as f64, r.peak_mib[6]))
            .collect(),
        Mark::LinePoints,
    )];
    let iterative: Vec<(f64, f64)> = runs
        .iter()
        .filter(|r| r.method == "iterative")
        .map(|r| (r.dofs as f64, r.peak_mib[6]))
        .collect();
    if !iterative.is_empty() {
        memory_series.push(Series::new(
            "peak RSS, iterative (CG)",
            iterative,
            Mark::LinePoints,
        ));
    }
    let memory_chart = Chart {
        title: "Static pipeline: peak memory".into(),
        x_label: "degrees of freedom".into(),
        y_label: "peak resident memory [MiB]".into(),
        log_x: true,
        log_y: true,
        series: memory_series,
    };
    memory_chart.write_png(&cli.out.join("performance_memory.png"), 900, 620)?;
    Ok(())
}

/// The marker lines around a section of `PERFORMANCE.md` that `scale` does not measure (the
/// corotational steps of `benches/corotational_step.rs`): copied from the old report into the
/// new one, so that regenerating the report keeps them.
const BY_HAND_BEGIN: &str = "<!-- measured by hand: kept by scale -->";
const BY_HAND_END: &str = "<!-- end of the part measured by hand -->";

/// Appends every section of the old report at `path` between [`BY_HAND_BEGIN`] and
/// [`BY_HAND_END`], markers included (nothing when there is no old report).
fn kept_by_hand(md: &mut String, path: &std::path::Path) {
    let Ok(old) = std::fs::read_to_string(path) else {
        return;
    };
    let mut rest = old.as_str();
    while let Some(start) = rest.find(BY_HAND_BEGIN) {
        let Some(length) = rest[start..].find(BY_HAND_END) else {
            break;
        };
        let end = start + length + BY_HAND_END.len();
        md.push_str(&rest[start..end]);
        md.push_str("\n\n");
        rest = &rest[end..];
    }
}

/// Copies the peers' comparison (written by `validation/side_by_side.py`, which runs scikit-fem,
/// MFEM and CHOLMOD in the same run as tetfem) into the report, so that one page holds both.
fn side_by_side(md: &mut String, out: &std::path::Path) -> std::fmt::Result {
    let Ok(text) = std::fs::read_to_string(out.join("SIDE_BY_SIDE.md")) else {
        return Ok(());
    };
    writeln!(md, "## Side by side with scikit-fem, MFEM and CHOLMOD")?;
    writeln!(md)?;
    writeln!(
        md,
        "Copied from `SIDE_BY_SIDE.md`, whose own header says how and when it was measured (the peers and \
         tetfem run in one session, interleaved, identical meshes):"
    )?;
    writeln!(md)?;
    for line in text.lines().skip_while(|l| !l.starts_with("Generated by")) {
        writeln!(md, "{line}")?;
    }
    writeln!(md)
}

fn commit() -> String {
    Command::new("git")
        .args(["rev-parse", "--short", "HEAD"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map_or_else(
            || "unknown".into(),
            |o| String::from_utf8_lossy(&o.stdout).trim().to_string(),
        )
}
