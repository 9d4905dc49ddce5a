//! Interactive soft bodies with contact (issue 39, target 2: "≥ 200 steps/s on a 10k-DOF
//! Neo-Hookean block falling onto the ground and sliding with friction (backward Euler,
//! dt = 1/100 s, 2 threads), no node through the ground; ≥ 60 steps/s with a moving sphere
//! pressing into it").
//!
//! - `drop`: a rubber cube (side 0.2 m, E = 100 kPa, ν = 0.3, ρ = 1000 kg/m³, `cells`³ cells
//!   of the mirrored 6-tet split; 14 cells: 15³ nodes, 10,125 DOFs) released 5 cm above the
//!   ground (a half-space, Coulomb friction μ = 0.5) under gravity, thrown sideways at
//!   0.3 m/s: it lands at t ≈ 0.1 s and slides (the scene `scenes/soft_block_drop.toml` on a
//!   finer mesh).
//! - `press`: the same cube, side 0.1 m, resting 0.1 mm above the frictional ground, and a
//!   rigid sphere of radius 5 cm starting 1 mm above its top and moving down at 3 cm/s (the
//!   scene `scenes/sphere_press.toml` on a finer mesh): 100 steps press it 2.9 cm in.
//!
//! Each run is `steps` backward-Euler steps of dt = 0.01 s with the Neo-Hookean model and the
//! IPC barrier, wall time of the stepping alone (the gap check after each step is not timed).
//! Printed: steps/s, Newton iterations per step (mean, most), factorizations, CG iterations,
//! fallbacks, and the smallest gap of a boundary node to an obstacle over the run (> 0: no
//! node through; `tests/core/interactive_contact.rs` asserts it on a 4³-cell block). Threads:
//! `RAYON_NUM_THREADS` for the assembly, `threads` for the Cholesky (the 2 threads:
//! `RAYON_NUM_THREADS=2` and `threads` 2). With `INTERACTIVE_CONTACT_DUMP=<file>` each step's
//! free displacements are written there (little-endian f64, one step after another, not timed):
//! the trajectory another tolerance or build is compared against.
//!
//! `cargo bench --bench interactive_contact -- [scenario] [cells] [steps] [threads] [solve]
//! [tolerance] [trace] [norelax]` (default `drop 14 100 2 auto 1e-8`; scenario `drop`, `press` or
//! `linear`: the drop's cube with the linear model, no ground, clamped at its base: the cost
//! of a linear step on the same mesh, the floor a nonlinear step with contact is measured
//! against; solve one of the names of `NonlinearSolve`: `auto`, `refactor`,
//! `rest_preconditioned`, `rest_lbfgs`; tolerance the Newton step tolerance,
//! `StepNewtonOptions::tolerance`; `trace` prints each step's iterations and wall time;
//! `norelax` turns `StepNewtonOptions::relax_contact_nodes` off).
//!
//! `tangent [cells] [repeats]`: the Neo-Hookean tangent of the drop's cube (at a displacement
//! of a few percent strain) assembled `repeats` times (default 20) each way, interleaved:
//! every tet's matrix computed in each node range that holds one of its nodes
//! (`Assembler::reassemble`), and each computed once (`Assembler::reassemble_computing_once`,
//! what the nonlinear force's tangent uses); prints the best and median times and whether the
//! two matrices are the same bits.

use std::time::Instant;

use nalgebra::Vector3;
use tetfem::analysis::Definition;
use tetfem::analysis::dynamics::{Method, NonlinearSolve, State};
use tetfem::analysis::transient::{Flow, StepView, TimeStep, Transient, TransientOptions};
use tetfem::contact::{Contact, ContactParameters, Obstacle, ObstacleMotion};
use tetfem::fe::materials::MaterialMap;
use tetfem::model::ModelKind;
use tetfem::{BoxSplit, Constraints, Material, Result, TetMesh};

const DT: f64 = 0.01;
const E: f64 = 1e5;

/// The block of `scenario` on `cells`³ cells, its ground and (press) sphere, and the initial
/// velocity (m/s).
fn scene(scenario: &str, cells: usize) -> Result<(Definition, Vector3<f64>)> {
    let (side, lift, velocity) = match scenario {
        "press" => (0.1, 1e-4, Vector3::zeros()),
        _ => (0.2, 0.05, Vector3::new(0.3, 0.0, 0.0)),
    };
    let mesh = TetMesh::box_grid(
        Vector3::new(0.0, 0.0, lift),
        Vector3::new(side, side, lift + side),
        [cells; 3],
        BoxSplit::Mirrored6,
    )?;
    let materials = MaterialMap::uniform(Material::new(E, 0.3, 1000.0)?, mesh.tet_count());
    let ground =
        Obstacle::half_space("ground", Vector3::zeros(), Vector3::z())?.with_friction(0.5)?;
    let mut obstacles = vec![ground];
    if scenario == "press" {
        let radius = 0.05;
        let center = Vector3::new(0.5 * side, 0.5 * side, lift + side + 1e-3 + radius);
        let sphere = Obstacle::sphere("sphere", center, radius)?
            .with_motion(ObstacleMotion::Velocity(Vector3::new(0.0, 0.0, -0.03)))?;
        obstacles.push(sphere);
    }
    let parameters = ContactParameters::for_mesh(&mesh, E)?;
    let contact = Contact::new(&mesh, obstacles, parameters)?;
    // The linear scenario's block is clamped at its base: without the ground a free body has no
    // stiffness against its rigid modes (and a linear step's cost does not depend on the motion).
    let mut base = Constraints::new(&mesh);
    base.fix_nodes(&mesh.nodes_on_plane(2, lift, 1e-9))?;
    let builder = Definition::builder(mesh, materials).gravity(Vector3::new(0.0, 0.0, -9.81))?;
    let definition = match scenario {
        "linear" => builder
            .model(ModelKind::Linear)
            .constraints(base)?
            .build()?,
        _ => builder
            .model(ModelKind::NeoHookean)
            .contact(contact)
            .build()?,
    };
    Ok((definition, velocity))
}

/// The `tangent` scenario: the two assemblies of the Neo-Hookean tangent side by side.
fn tangent_assembly(cells: usize, repeats: usize) -> Result<()> {
    let mesh = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(0.2, 0.2, 0.2),
        [cells; 3],
        BoxSplit::Mirrored6,
    )?;
    let model = ModelKind::NeoHookean.build(&Material::new(E, 0.3, 1000.0)?);
    // A smooth deformation of a few percent strain: shear, squash and a twist.
    let u: Vec<f64> = mesh
        .nodes()
        .iter()
        .flat_map(|p| {
            [
                0.05 * p.z + 0.02 * p.y * p.z,
                -0.02 * p.x * p.z,
                -0.04 * p.z,
            ]
        })
        .collect();
    let elements = mesh.elements();
    let calls = std::sync::atomic::AtomicUsize::new(0);
    let element_matrix = |t: usize| {
        calls.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let rest = mesh.tets()[t].map(|n| mesh.nodes()[n]);
        let x = mesh.tets()[t]
            .map(|n| mesh.nodes()[n] + Vector3::new(u[3 * n], u[3 * n + 1], u[3 * n + 2]));
        model.tangent(&elements[t], &rest, &x)
    };
    let assembler = tetfem::Assembler::new(&mesh);
    let mut every = tetfem::CscMatrix::zeros(std::sync::Arc::clone(assembler.pattern()))?;
    let mut once = every.clone();
    let (mut t_every, mut t_once) = (Vec::new(), Vec::new());
    for _ in 0..repeats {
        let clock = Instant::now();
        assembler.reassemble(&mesh, element_matrix, &mut every)?;
        t_every.push(clock.elapsed().as_secs_f64());
        let clock = Instant::now();
        assembler.reassemble_computing_once(&mesh, element_matrix, &mut once)?;
        t_once.push(clock.elapsed().as_secs_f64());
    }
    // Element matrices computed per assembly, each way (the last repeat's).
    calls.store(0, std::sync::atomic::Ordering::Relaxed);
    assembler.reassemble(&mesh, element_matrix, &mut every)?;
    let computed_every = calls.swap(0, std::sync::atomic::Ordering::Relaxed);
    assembler.reassemble_computing_once(&mesh, element_matrix, &mut once)?;
    let computed_once = calls.load(std::sync::atomic::Ordering::Relaxed);
    let same = every
        .values()
        .iter()
        .zip(once.values())
        .all(|(a, b)| a.to_bits() == b.to_bits());
    let summary = |times: &mut Vec<f64>| {
        times.sort_by(f64::total_cmp);
        (1e3 * times[0], 1e3 * times[times.len() / 2])
    };
    let ((best_e, median_e), (best_o, median_o)) = (summary(&mut t_every), summary(&mut t_once));
    println!(
        "tangent assembly, {} DOFs, {} tets, {} rayon threads, {repeats} each: every range {best_e:.2} ms best / {median_e:.2} median, once {best_o:.2} / {median_o:.2} ms; element matrices {computed_every} / {computed_once}; same bits: {same}",
        mesh.dof_count(),
        mesh.tet_count(),
        rayon::current_num_threads()
    );
    Ok(())
}

fn main() -> Result<()> {
    // `cargo bench` appends `--bench` to a harness-less target's arguments: not one of ours.
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let arg = |i: usize, default: &'static str| args.get(i).map_or(default, String::as_str);
    let scenario = arg(0, "drop");
    let number = |i: usize, default: usize| arg(i, "").parse().unwrap_or(default);
    let (cells, steps, threads) = (number(1, 14), number(2, 100), number(3, 2));
    let solve: NonlinearSolve = arg(4, "auto").parse()?;
    let tolerance: f64 = arg(5, "1e-8").parse().unwrap_or(1e-8);
    let trace = args.iter().any(|a| a == "trace");
    let relax = !args.iter().any(|a| a == "norelax");
    if scenario == "tangent" {
        return tangent_assembly(cells, number(2, 20));
    }

    let (definition, velocity) = scene(scenario, cells)?;
    let contact = definition.contact.clone();
    let mut options = TransientOptions::new(Method::BackwardEuler, TimeStep::Seconds(DT));
    options.solver.cholesky.threads = threads;
    options.solver.nonlinear_solve = solve;
    options.solver.newton.tolerance = tolerance;
    options.solver.newton.relax_contact_nodes = relax;
    let mut run = Transient::new(&definition, options)?;
    let free = run.system().free_count();
    let full: Vec<f64> = (0..definition.mesh.dof_count())
        .map(|dof| velocity[dof % 3])
        .collect();
    let mut state = State::at_rest(free);
    state.velocity = run.system().dofs().restrict(&full)?;
    *run.state_mut() = state;

    let mut smallest = f64::INFINITY;
    let mut checking = 0.0;
    let dump_path = std::env::var("INTERACTIVE_CONTACT_DUMP").ok();
    let mut dump: Vec<u8> = Vec::new();
    let clock = Instant::now();
    run.run((0, steps), &mut |view: &StepView<'_>| -> Result<Flow> {
        let watch = Instant::now();
        let u = view.system.dofs().expand(&view.state.displacement)?;
        let gap = match &contact {
            Some(contact) => {
                contact.set_time(view.state.time);
                contact.smallest_gap(&u)?
            }
            None => f64::INFINITY,
        };
        smallest = smallest.min(gap);
        if dump_path.is_some() {
            dump.extend(view.state.displacement.iter().flat_map(|x| x.to_le_bytes()));
        }
        if trace {
            let stats = view.integrator.newton_stats().unwrap_or_default();
            println!(
                "step {:>4} t {:.2} s: {:>3} its, {:>5} CG its, {:>3} factors, {:>3} fallbacks so far, wall {:.4} s, gap {gap:.3e} m",
                view.step,
                view.state.time,
                stats.last_step,
                stats.cg_iterations,
                stats.factorizations,
                stats.fallbacks,
                view.wall
            );
        }
        checking += watch.elapsed().as_secs_f64();
        Ok(Flow::Continue)
    })?;
    let wall = clock.elapsed().as_secs_f64() - checking;
    if let Some(path) = &dump_path {
        std::fs::write(path, &dump).map_err(|e| {
            tetfem::Error::invalid_parameter("INTERACTIVE_CONTACT_DUMP", path, e.to_string())
        })?;
    }
    // A fingerprint of the final state's bits: two builds that take the same steps print the
    // same one (a change of speed only must not move it).
    let fingerprint = run
        .state()
        .displacement
        .iter()
        .chain(&run.state().velocity)
        .fold(0xcbf2_9ce4_8422_2325_u64, |h, x| {
            (h ^ x.to_bits()).wrapping_mul(0x0100_0000_01b3)
        });
    let stats = run.integrator().newton_stats().unwrap_or_default();
    let per_step = stats.total_iterations as f64 / stats.steps.max(1) as f64;
    println!(
        "{:<8} {:>6} {:>6} {:>3} {:<20} {:>7} {:>9} {:>9} {:>6} {:>7} {:>8} {:>6} {:>11} {:>16}",
        "scenario",
        "DOFs",
        "steps",
        "thr",
        "solve",
        "tol",
        "steps/s",
        "its/step",
        "most",
        "factors",
        "CG its",
        "fallbk",
        "min gap (m)",
        "state bits"
    );
    println!(
        "{:<8} {:>6} {:>6} {:>3} {:<20} {:>7.0e} {:>9.2} {:>9.2} {:>6} {:>7} {:>8} {:>6} {:>11.3e} {:>16x}",
        scenario,
        free,
        steps,
        threads,
        solve.name(),
        tolerance,
        steps as f64 / wall,
        per_step,
        stats.max_per_step,
        stats.factorizations,
        stats.cg_iterations,
        stats.fallbacks,
        smallest,
        fingerprint
    );
    Ok(())
}
