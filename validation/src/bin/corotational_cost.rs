//! The large-deformation step's cost against its accuracy, charted: the swinging rubber
//! cantilever (`tetfem_fixtures::swing`, E = 1 MPa, the lecture's 6-tet split) released from
//! rest and run for `--steps` backward-Euler steps of `--dt`, by the linear step, the
//! refactoring Newton step (the reference trajectory), and, at each step tolerance from 1e-8 to
//! 1e-1, Newton with CG on the turned rest factor and tangent-free L-BFGS on it. Each run's
//! cost is its mean step time after the first (the first holds the factorization of dt) over
//! the linear step's, measured side by side in this one process; its error is the largest
//! distance of its displacements from the reference's over all steps and DOFs, over the
//! reference's largest displacement. Writes `corotational_cost.csv` and `corotational_cost.png`
//! into `--out`; `--replot` redraws the PNG from that CSV without measuring again.
//!
//! `cargo run --release -p tetfem-validation --bin corotational_cost -- --cells 100,20,20`
//! (threads: RAYON_NUM_THREADS; the Cholesky uses as many, at most two).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Instant;

use clap::Parser;
use nalgebra::Matrix3;
use tetfem::BoxSplit;
use tetfem::analysis::dynamics::{Integrator, InternalForce, NewtonStats, NonlinearSolve, State};
use tetfem::model::ModelKind;
use tetfem_fixtures::counting::{Call, Counting};
use tetfem_fixtures::swing::Swing;
use tetfem_validation::cells::parse_cells;
use tetfem_validation::chart::{Chart, Mark, Series};

/// Cost against accuracy of the corotational backward-Euler step.
#[derive(Debug, Parser)]
struct Cli {
    /// Cells NX,NY,NZ of the 0.5 × 0.05 × 0.05 m beam.
    #[arg(long, value_parser = parse_cells, default_value = "50,10,10")]
    cells: [usize; 3],
    /// Time step (s).
    #[arg(long, default_value_t = 0.01)]
    dt: f64,
    /// Steps from rest (20 steps of 10 ms turn the tip by 38°).
    #[arg(long, default_value_t = 20)]
    steps: usize,
    /// Folder for the CSV and the PNG.
    #[arg(long, default_value = "validation/report")]
    out: PathBuf,
    /// Redraw the PNG from the CSV already in `--out` instead of measuring.
    #[arg(long)]
    replot: bool,
    /// The large-deformation model: `corotational` or `neo_hookean`.
    #[arg(long, default_value = "corotational", value_parser = ["corotational", "neo_hookean"])]
    model: String,
    /// What to run after the linear and refactoring steps: `tolerances` (Newton-CG and L-BFGS at
    /// every charted tolerance) or `options` (the default settings, and L-BFGS at the
    /// tolerances around 1e-4 of the trajectory, side by side, then the cost of one force
    /// evaluation over the linear step's).
    /// `account` runs the linear and default steps only and counts, with a counting wrapper
    /// around the model, the force, energy and tangent passes the default takes a step, then
    /// times one of each (no refactoring reference: the trajectory is not charted).
    #[arg(long, default_value = "tolerances", value_parser = ["tolerances", "options", "account"])]
    set: String,
}

/// The step tolerances of `--set options`.
const OPTION_TOLERANCES: [f64; 4] = [1e-8, 1e-3, 3e-3, 1e-2];

/// The step tolerances charted, loosest last.
const TOLERANCES: [f64; 8] = [1e-8, 1e-6, 1e-4, 1e-3, 3e-3, 1e-2, 3e-2, 1e-1];

/// One run: its trajectory, mean step time after the first (s) and Newton counts.
struct Run {
    trajectory: Vec<Vec<f64>>,
    step_seconds: f64,
    /// The same mean in CPU time of the whole process (all threads, from
    /// [`process_cpu_seconds`]): on this shared machine the wall time swings 2–5× with the
    /// other jobs' load, the CPU time of a one-thread run much less.
    cpu_seconds: f64,
    stats: NewtonStats,
}

/// The CPU time (s) every thread of this process has run so far (`CLOCK_PROCESS_CPUTIME_ID`:
/// the scheduler's running time, the current slice included, to the nanosecond); NaN where
/// the clock is missing. `/proc/self/task/*/schedstat`, read before, moves only at the
/// scheduler's ticks and switches: a step under a tick (0.2 ms at 2,700 DOFs) read as 0 s,
/// and every ratio over it as ∞. NaN off Unix.
#[cfg(unix)]
fn process_cpu_seconds() -> f64 {
    let mut now = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `now` is a valid, writable timespec for the call's one output.
    let status = unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut now) };
    match status {
        0 => now.tv_sec as f64 + now.tv_nsec as f64 * 1e-9,
        _ => f64::NAN,
    }
}

#[cfg(not(unix))]
fn process_cpu_seconds() -> f64 {
    f64::NAN
}

fn run(
    swing: &Swing,
    force: InternalForce,
    solve: NonlinearSolve,
    tolerance: f64,
    cli: &Cli,
) -> tetfem::Result<Run> {
    let threads = rayon::current_num_threads().min(2);
    let mut integrator = swing.integrator(force, cli.dt, solve, tolerance, threads)?;
    let mut state = State::at_rest(swing.system.free_count());
    let mut trajectory = Vec::with_capacity(cli.steps);
    let mut later = 0.0;
    let mut later_cpu = 0.0;
    for step in 0..cli.steps {
        let (clock, cpu) = (Instant::now(), process_cpu_seconds());
        integrator.step(&mut state)?;
        if step > 0 {
            later += clock.elapsed().as_secs_f64();
            later_cpu += process_cpu_seconds() - cpu;
        }
        trajectory.push(state.displacement.clone());
    }
    Ok(Run {
        trajectory,
        step_seconds: later / (cli.steps - 1) as f64,
        cpu_seconds: later_cpu / (cli.steps - 1) as f64,
        stats: integrator.newton_stats().unwrap_or_default(),
    })
}

/// Prints the wall time of one evaluation of the model's force (with its energy, as a step's
/// iteration makes it) at the reference's final state over the linear step's: where a
/// tangent-free iteration's time goes besides its pair of triangular solves.
fn breakdown(force: &InternalForce, reference: &Run, linear_seconds: f64) -> tetfem::Result<()> {
    let InternalForce::Nonlinear(force) = force else {
        return Ok(());
    };
    let Some(u) = reference.trajectory.last() else {
        return Ok(());
    };
    let mut work = force.workspace()?;
    let mut f = vec![0.0; u.len()];
    let repeat = 10;
    let clock = Instant::now();
    for _ in 0..repeat {
        force.force_and_energy_into(u, &mut work, &mut f)?;
    }
    let seconds = clock.elapsed().as_secs_f64() / repeat as f64;
    println!(
        "force and energy: {seconds:.5} s per evaluation, {:.2}× a linear step",
        seconds / linear_seconds
    );
    Ok(())
}

/// A run's trajectory in one number (FNV-1a over the bits of every displacement of every
/// step): two binaries that print the same one computed the same trajectory to the bit.
fn trajectory_hash(run: &Run) -> u64 {
    (run.trajectory.iter().flatten()).fold(0xcbf2_9ce4_8422_2325_u64, |h, v| {
        (h ^ v.to_bits()).wrapping_mul(0x0100_0000_01b3)
    })
}

/// `--set account`: where the default's step goes. Runs the default once timed and once with
/// the counting model (the same iterations: the wrapper changes no bits), then prints per step
/// the passes over the tets of each kind and the L-BFGS iterations, and the wall time of one
/// force-and-energy pass, one energy pass and one nodal-rotation update (the L-BFGS H₀'s turn,
/// once a step) at the last state (each the fastest of 20), each over the linear step's CPU
/// time; what is left of the default step's CPU time is the iterations' triangular solves, the
/// two-loop recursion and the vector work. It also prints both steps' CPU times, the factor's
/// size and the f32 pair timed right after a force pass (as an iteration meets it: the pass
/// evicts the factor from the cache, 1.1–1.4× the back-to-back time at 9,720 DOFs). Meaningful
/// on one thread (`RAYON_NUM_THREADS=1`: on more, CPU time sums the threads).
fn account(swing: &Swing, model: ModelKind, linear: &Run, cli: &Cli) -> tetfem::Result<()> {
    let default_tolerance = tetfem::analysis::dynamics::StepNewtonOptions::default().tolerance;
    let plain = || {
        InternalForce::of_model(
            Arc::clone(&swing.mesh),
            model.build(&swing.problem.material),
            &swing.system,
        )
    };
    let timed = run(
        swing,
        plain()?,
        NonlinearSolve::Auto,
        default_tolerance,
        cli,
    )?;
    let (counting, calls) = Counting::wrap(model.build(&swing.problem.material));
    let counted_force = InternalForce::of_model(Arc::clone(&swing.mesh), counting, &swing.system)?;
    let counted = run(
        swing,
        counted_force,
        NonlinearSolve::Auto,
        default_tolerance,
        cli,
    )?;
    let same = counted.trajectory == timed.trajectory;
    println!(
        "default trajectory's bits (FNV-1a): {:016x}; the linear one's: {:016x}",
        trajectory_hash(&timed),
        trajectory_hash(linear)
    );
    println!(
        "CPU time a step: default {:.6} s, linear {:.6} s",
        timed.cpu_seconds, linear.cpu_seconds
    );
    let steps = cli.steps as f64;
    let per_step = |kind: Call| calls.passes(kind, swing.mesh.tet_count()) / steps;
    let iterations = timed.stats.total_iterations as f64 / steps;
    println!(
        "default: {:.5} s a step, {:.2}× linear ({:.5} s), CPU time {:.2}× linear's; per step: {iterations:.2} L-BFGS iterations, \
         {:.2} force+energy passes, {:.2} force passes, {:.2} energy passes, {:.2} tangent passes \
         (counted run repeats the timed one to the bit: {same})",
        timed.step_seconds,
        timed.step_seconds / linear.step_seconds,
        linear.step_seconds,
        timed.cpu_seconds / linear.cpu_seconds,
        per_step(Call::ForceAndEnergy),
        per_step(Call::Force),
        per_step(Call::Energy),
        per_step(Call::Tangent),
    );
    let InternalForce::Nonlinear(force) = plain()? else {
        return Ok(());
    };
    let u = timed.trajectory.last().cloned().unwrap_or_default();
    let mut work = force.workspace()?;
    let mut f = vec![0.0; u.len()];
    let repeat = 20;
    // The fastest of the repeats: the others met the machine's other jobs.
    let mut time = move |job: &mut dyn FnMut() -> tetfem::Result<()>| -> tetfem::Result<f64> {
        job()?;
        let mut fastest = f64::INFINITY;
        for _ in 0..repeat {
            let clock = Instant::now();
            job()?;
            fastest = fastest.min(clock.elapsed().as_secs_f64());
        }
        Ok(fastest)
    };
    let pass = time(&mut || {
        force
            .force_and_energy_into(&u, &mut work, &mut f)
            .map(|_| ())
    })?;
    let energy = time(&mut || force.elastic_energy(&u).map(|_| ()))?;
    let full = swing.system.dofs().expand(&u)?;
    let mut gradients = vec![Matrix3::zeros(); swing.mesh.node_count()];
    let mut rotations = gradients.clone();
    // As the step turns H₀: from the rest elements its force keeps, four nodes at a time in
    // the lanes (on one thread; the step spreads the nodes over the pool's).
    let kept = tetfem::model::assemble::corner_elements(swing.mesh.as_ref());
    let turn = time(&mut || {
        tetfem::model::assemble::nodal_deformation_gradients_kept(
            swing.mesh.as_ref(),
            &kept,
            &full,
            &mut gradients,
        )?;
        tetfem::model::rotations_into(&gradients, &mut rotations)?;
        std::hint::black_box(&rotations);
        Ok(())
    })?;
    // Against the CPU times of the steps (one thread: the load's pauses left out) where the
    // passes are the fastest of their repeats.
    let lin = linear.cpu_seconds;
    let step = timed.cpu_seconds;
    let passes = per_step(Call::ForceAndEnergy) * pass + per_step(Call::Energy) * energy;
    println!(
        "one force+energy pass {pass:.5} s ({:.2}× linear), energy pass {energy:.5} s ({:.2}×), \
         nodal rotations {turn:.5} s ({:.2}×); a step's passes {:.2}× linear, its rotations {:.2}×, \
         the rest (solves, recursion, vectors) {:.2}× linear, {:.2}× an iteration",
        pass / lin,
        energy / lin,
        turn / lin,
        passes / lin,
        turn / lin,
        (step - passes - turn) / lin,
        (step - passes - turn) / lin / iterations.max(1.0),
    );
    let mut evict = || {
        force
            .force_and_energy_into(&u, &mut work, &mut f)
            .map(|_| ())
    };
    let parts = linear_parts(swing, cli, &u, &mut time, &mut evict)?;
    let solves = iterations * parts.single;
    println!(
        "f64 solve pair {:.5} s ({:.2}× linear), f32 solve pair {:.5} s ({:.2}×), the linear step's \
         K·(u, v) {:.5} s ({:.2}×); a step's f32 solves {:.2}× linear, what is left (L-BFGS \
         recursion, residuals, line search, vectors) {:.2}× linear",
        parts.double,
        parts.double / lin,
        parts.single,
        parts.single / lin,
        parts.product,
        parts.product / lin,
        solves / lin,
        (step - passes - turn - solves) / lin,
    );
    let cold = iterations * parts.single_after_pass;
    println!(
        "factor {} values; f32 solve pair right after a force pass {:.5} s ({:.2}× linear): a \
         step's f32 solves so {:.2}× linear, what is left then {:.2}× linear",
        parts.factor_len,
        parts.single_after_pass,
        parts.single_after_pass / lin,
        cold / lin,
        (step - passes - turn - cold) / lin,
    );
    Ok(())
}

/// The fastest times (s) of the linear step's parts and of L-BFGS's solve.
struct LinearParts {
    /// One triangular solve pair on the f64 factor of M + dt²·K (the linear step's).
    double: f64,
    /// The same pair on the factor's f32 copy (what H₀ of an L-BFGS iteration solves with: its
    /// matrix M/dt² + K is this one over dt², the same pattern and ordering).
    single: f64,
    /// The linear step's product K·(u, v) (one pass over the symmetric blocks of K).
    product: f64,
    /// The f32 pair right after a force-and-energy pass, as an L-BFGS iteration meets it (the
    /// pass's own fastest time taken off): the factor no longer in the cache.
    single_after_pass: f64,
    /// Stored values of the factor (supernodal padding included).
    factor_len: usize,
}

/// The fastest time (s) of a job's repeats.
type Timer = dyn FnMut(&mut dyn FnMut() -> tetfem::Result<()>) -> tetfem::Result<f64>;

/// Times the linear step's parts at displacement `u` (and velocity `u`: the values do not
/// change the work) with `time` (the fastest of its repeats), on the solver the integrators
/// build: a direct one on `RAYON_NUM_THREADS` (at most two) threads.
fn linear_parts(
    swing: &Swing,
    cli: &Cli,
    u: &[f64],
    time: &mut Timer,
    pass: &mut dyn FnMut() -> tetfem::Result<()>,
) -> tetfem::Result<LinearParts> {
    let system = &swing.system;
    let mut matrix = system.stiffness().clone();
    system.combine_into(cli.dt * cli.dt, 1.0, &mut matrix)?;
    let options = tetfem::SolverOptions {
        method: tetfem::LinearMethod::Direct,
        cholesky: tetfem::CholeskyOptions {
            threads: rayon::current_num_threads().min(2),
            ..tetfem::CholeskyOptions::default()
        },
        ..tetfem::SolverOptions::default()
    };
    let mut solver = tetfem::LinearSolver::analyze(&matrix, options)?;
    solver.factorize(&matrix)?;
    let mut rhs = u.to_vec();
    let double = time(&mut || {
        rhs.copy_from_slice(u);
        solver.solve(&matrix, &mut rhs).map(|_| ())?;
        Ok(())
    })?;
    solver.make_single_precision_copy()?;
    let single = time(&mut || {
        rhs.copy_from_slice(u);
        solver.solve_approximate(&matrix, &mut rhs)?;
        Ok(())
    })?;
    let pass_alone = time(&mut || pass())?;
    let pass_and_single = time(&mut || {
        pass()?;
        rhs.copy_from_slice(u);
        solver.solve_approximate(&matrix, &mut rhs)?;
        Ok(())
    })?;
    let blocks = system.stiffness_blocks();
    let mut work = blocks.workspace();
    let (mut ku, mut kv) = (vec![0.0; u.len()], vec![0.0; u.len()]);
    let product = time(&mut || {
        std::hint::black_box(blocks.product2_into((u, u), (&mut ku, &mut kv), &mut work));
        Ok(())
    })?;
    Ok(LinearParts {
        double,
        single,
        product,
        single_after_pass: pass_and_single - pass_alone,
        factor_len: solver.factor_len(),
    })
}

/// The largest |u − u_ref| over all steps and DOFs over the largest |u_ref|.
fn distance(trajectory: &[Vec<f64>], reference: &[Vec<f64>]) -> f64 {
    let scale = reference
        .iter()
        .flatten()
        .fold(0.0f64, |m, v| m.max(v.abs()));
    let worst = (trajectory.iter().zip(reference))
        .flat_map(|(a, b)| a.iter().zip(b).map(|(x, y)| (x - y).abs()))
        .fold(0.0f64, f64::max);
    worst / scale
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = if cli.replot {
        read_csv(&cli.out.join(CSV)).and_then(|(setup, rows)| plot(&setup, &rows, &cli.out))
    } else {
        measure(&cli).and_then(|(setup, rows)| {
            // `--set account` prints its counts and charts nothing.
            if rows.is_empty() {
                return Ok(());
            }
            write_csv(&cli.out.join(CSV), &setup, &rows)?;
            plot(&setup, &rows, &cli.out)
        })
    };
    match result {
        Ok(()) => {
            println!(
                "wrote {}",
                cli.out.join(CSV).with_extension("png").display()
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("corotational_cost: {e}");
            ExitCode::FAILURE
        }
    }
}

/// The CSV's name in `--out`; the PNG takes the same stem.
const CSV: &str = "corotational_cost.csv";

/// What one measurement ran on: free DOFs, threads, time step (s) and steps.
struct Setup {
    free_dofs: usize,
    threads: usize,
    dt: f64,
    steps: usize,
}

/// One charted run: its method and step tolerance, mean step time (s), cost over the linear
/// step's, distance from the refactoring trajectory (relative) and Newton counts.
struct Row {
    method: String,
    tolerance: f64,
    step_seconds: f64,
    cost_over_linear: f64,
    distance: f64,
    iterations: usize,
    cg_iterations: usize,
    factorizations: usize,
}

const HEADER: &str = "method,tolerance,step_seconds,cost_over_linear,distance_from_refactoring,\
iterations,cg_iterations,factorizations,free_dofs,threads,dt,steps";

fn measure(cli: &Cli) -> tetfem::Result<(Setup, Vec<Row>)> {
    if cli.steps < 2 || !(cli.dt > 0.0 && cli.dt.is_finite()) {
        return Err(tetfem::Error::invalid_parameter(
            "--steps/--dt",
            format!("{}/{}", cli.steps, cli.dt),
            "at least 2 steps (the first is not timed) and a finite dt > 0",
        ));
    }
    // An unwritable folder is found before the minutes of measuring, not after.
    std::fs::create_dir_all(&cli.out).map_err(|source| tetfem::Error::Io {
        path: cli.out.clone(),
        source,
    })?;
    let swing = Swing::new(cli.cells, BoxSplit::Lecture6, 1e6)?;
    let setup = Setup {
        free_dofs: swing.system.free_count(),
        threads: rayon::current_num_threads().min(2),
        dt: cli.dt,
        steps: cli.steps,
    };
    println!(
        "{:?} cells, {} free DOFs, dt {} s, {} steps, {} thread(s)",
        cli.cells, setup.free_dofs, cli.dt, cli.steps, setup.threads
    );
    let linear = run(
        &swing,
        InternalForce::Linear,
        NonlinearSolve::Refactor,
        1e-8,
        cli,
    )?;
    let model = match cli.model.as_str() {
        "corotational" => ModelKind::Corotational,
        "neo_hookean" => ModelKind::NeoHookean,
        other => {
            return Err(tetfem::Error::invalid_parameter(
                "--model",
                other,
                "'corotational' or 'neo_hookean'",
            ));
        }
    };
    let force = || {
        InternalForce::of_model(
            Arc::clone(&swing.mesh),
            model.build(&swing.problem.material),
            &swing.system,
        )
    };
    if cli.set == "account" {
        return account(&swing, model, &linear, cli).map(|()| (setup, Vec::new()));
    }
    let reference = run(&swing, force()?, NonlinearSolve::Refactor, 1e-8, cli)?;
    let mut rows = Vec::new();
    let mut row = |method: &str, tolerance: f64, r: &Run, distance: f64| {
        let row = Row {
            method: method.into(),
            tolerance,
            step_seconds: r.step_seconds,
            cost_over_linear: r.step_seconds / linear.step_seconds,
            distance,
            iterations: r.stats.total_iterations,
            cg_iterations: r.stats.cg_iterations,
            factorizations: r.stats.factorizations,
        };
        println!(
            "{method:>12} tolerance {tolerance:.0e}: {:.4} s per step, {:.1}× linear, CPU time {:.2}× linear's, distance {distance:.2e}, {} its, {} CG its",
            row.step_seconds,
            row.cost_over_linear,
            r.cpu_seconds / linear.cpu_seconds,
            row.iterations,
            row.cg_iterations
        );
        rows.push(row);
    };
    row("linear", 0.0, &linear, f64::NAN);
    row("refactor", 1e-8, &reference, 0.0);
    if cli.set == "options" {
        let default_tolerance = tetfem::analysis::dynamics::StepNewtonOptions::default().tolerance;
        let r = run(
            &swing,
            force()?,
            NonlinearSolve::Auto,
            default_tolerance,
            cli,
        )?;
        let d = distance(&r.trajectory, &reference.trajectory);
        row("default", default_tolerance, &r, d);
        // The previous default (L-BFGS to the asked 1e-8) is the 1e-8 row.
        let lbfgs = NonlinearSolve::RestPreconditionedLbfgs { history: 5 };
        for tolerance in OPTION_TOLERANCES {
            let r = run(&swing, force()?, lbfgs, tolerance, cli)?;
            let d = distance(&r.trajectory, &reference.trajectory);
            row("lbfgs", tolerance, &r, d);
        }
        breakdown(&force()?, &reference, linear.step_seconds)?;
        return Ok((setup, rows));
    }
    for (method, solve) in [
        (
            "newton_cg",
            NonlinearSolve::RestPreconditionedCg {
                max_cg_iterations: 25,
                forcing: 1e-3,
            },
        ),
        (
            "lbfgs",
            NonlinearSolve::RestPreconditionedLbfgs { history: 5 },
        ),
    ] {
        for tolerance in TOLERANCES {
            let r = run(&swing, force()?, solve, tolerance, cli)?;
            let d = distance(&r.trajectory, &reference.trajectory);
            row(method, tolerance, &r, d);
        }
    }
    Ok((setup, rows))
}

fn write_csv(path: &Path, setup: &Setup, rows: &[Row]) -> tetfem::Result<()> {
    let mut csv = format!("{HEADER}\n");
    for r in rows {
        let _ = writeln!(
            csv,
            "{},{:e},{:e},{:.3},{:e},{},{},{},{},{},{},{}",
            r.method,
            r.tolerance,
            r.step_seconds,
            r.cost_over_linear,
            r.distance,
            r.iterations,
            r.cg_iterations,
            r.factorizations,
            setup.free_dofs,
            setup.threads,
            setup.dt,
            setup.steps
        );
    }
    std::fs::write(path, csv).map_err(|source| tetfem::Error::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Reads a CSV this program wrote, naming the line and column of anything it cannot parse.
fn read_csv(path: &Path) -> tetfem::Result<(Setup, Vec<Row>)> {
    let text = std::fs::read_to_string(path).map_err(|source| tetfem::Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let bad = |line: usize, what: &str, value: &str| {
        tetfem::Error::invalid_parameter(
            format!("{} line {line} {what}", path.display()),
            value,
            format!("a CSV with the header `{HEADER}` as this program writes it"),
        )
    };
    let mut lines = text.lines().enumerate();
    match lines.next() {
        Some((_, header)) if header == HEADER => {}
        other => return Err(bad(1, "header", other.map_or("", |(_, h)| h))),
    }
    let mut setup = None;
    let mut rows = Vec::new();
    for (index, line) in lines {
        let number = index + 1;
        let fields: Vec<&str> = line.split(',').collect();
        if fields.len() != 12 {
            return Err(bad(number, "field count", &fields.len().to_string()));
        }
        let float = |k: usize| {
            fields[k]
                .parse::<f64>()
                .map_err(|_| bad(number, HEADER.split(',').nth(k).unwrap_or(""), fields[k]))
        };
        let count = |k: usize| {
            fields[k]
                .parse::<usize>()
                .map_err(|_| bad(number, HEADER.split(',').nth(k).unwrap_or(""), fields[k]))
        };
        setup.get_or_insert(Setup {
            free_dofs: count(8)?,
            threads: count(9)?,
            dt: float(10)?,
            steps: count(11)?,
        });
        rows.push(Row {
            method: fields[0].to_string(),
            tolerance: float(1)?,
            step_seconds: float(2)?,
            cost_over_linear: float(3)?,
            distance: float(4)?,
            iterations: count(5)?,
            cg_iterations: count(6)?,
            factorizations: count(7)?,
        });
    }
    let setup = setup.ok_or_else(|| bad(2, "rows", "none"))?;
    Ok((setup, rows))
}

fn plot(setup: &Setup, rows: &[Row], out: &Path) -> tetfem::Result<()> {
    let cost_of = |method: &str| {
        rows.iter()
            .find(|r| r.method == method)
            .map(|r| r.cost_over_linear)
    };
    let refactor_cost = cost_of("refactor").ok_or_else(|| {
        tetfem::Error::invalid_parameter("rows", "no refactor row", "a refactor row")
    })?;
    let mut series: Vec<Series> = [
        ("newton_cg", "Newton, CG on the turned rest factor"),
        ("lbfgs", "L-BFGS on the turned rest factor (no tangent)"),
    ]
    .into_iter()
    .map(|(method, label)| {
        Series::new(
            format!("{label}, step tolerance 1e-8 (lowest point) … 1e-1"),
            rows.iter()
                .filter(|r| r.method == method)
                .map(|r| (r.cost_over_linear, r.distance))
                .collect(),
            Mark::LinePoints,
        )
    })
    .collect();
    let (low, high) = series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.1))
        .filter(|y| *y > 0.0)
        .fold((f64::INFINITY, 0.0f64), |(l, h), y| (l.min(y), h.max(y)));
    series.push(Series::new(
        format!("refactoring Newton (the reference), {refactor_cost:.0}× linear"),
        vec![(refactor_cost, low), (refactor_cost, high)],
        Mark::Dashed,
    ));
    series.push(Series::new(
        "the issue's target: 3× a linear step",
        vec![(3.0, low), (3.0, high)],
        Mark::Dashed,
    ));
    let (left, right) = series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.0))
        .fold((f64::INFINITY, 0.0f64), |(l, r), x| (l.min(x), r.max(x)));
    series.push(Series::new(
        "1e-4 of the largest displacement",
        vec![(left, 1e-4), (right, 1e-4)],
        Mark::Dashed,
    ));
    let chart = Chart {
        title: format!(
            "Corotational backward-Euler step, {} DOFs, {} steps of {} ms, {} thread(s)",
            setup.free_dofs,
            setup.steps,
            setup.dt * 1e3,
            setup.threads
        ),
        x_label: "cost of a step / cost of a linear step (–)".into(),
        y_label: "largest distance from the refactoring trajectory / largest displacement (–)"
            .into(),
        log_x: true,
        log_y: true,
        series,
    };
    chart.write_png(&out.join(CSV).with_extension("png"), 1100, 700)
}
