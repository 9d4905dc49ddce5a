//! The cost of a large-deformation backward-Euler step, side by side in one run: the linear
//! step, the corotational step refactoring every Newton iteration, and the corotational step
//! whose Newton solves are CG preconditioned by the rest-state factor turned by the nodes'
//! rotations. A rubber cantilever
//! (0.5 × 0.05 × 0.05 m, E = 1 MPa, ν = 0.4, ρ = 1100 kg/m³, the lecture's 6-tet split)
//! released from rest under gravity; each method takes the same `steps` steps of `dt` from
//! rest, and the mean of their wall times is reported, with the Newton, CG and factorization
//! counts and the largest tip rotation reached; every mode after `refactor` also prints its
//! largest difference from the refactoring trajectory over the run.
//!
//! `cargo run --release --example corotational_step -- NX NY NZ [dt] [steps] [modes]`,
//! modes a comma list of `linear`, `refactor`, `cg:MAX:FORCING[:TOLERANCE]` (default: all three, the CG
//! one with the defaults). Threads: `RAYON_NUM_THREADS`; the Cholesky uses as many (≤ 2).

use std::sync::Arc;
use std::time::Instant;

use nalgebra::Vector3;
use tetfem::dynamics::{
    BackwardEuler, Integrator, IntegratorOptions, InternalForce, LinearSystem, MassKind,
    NonlinearSolve, Rayleigh, State,
};
use tetfem::model::ModelKind;
use tetfem::{BoxSplit, CholeskyOptions, Loads, Material};
use tetfem_fixtures::cantilever::Cantilever;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let number = |i: usize, default: f64| -> f64 {
        args.get(i)
            .map(|a| a.parse().expect("a number"))
            .unwrap_or(default)
    };
    let cells = [
        number(0, 50.0) as usize,
        number(1, 10.0) as usize,
        number(2, 10.0) as usize,
    ];
    let dt = number(3, 1e-2);
    let steps = number(4, 5.0) as usize;
    let modes: Vec<String> = args
        .get(5)
        .map_or("linear,refactor,cg:25:1e-3", String::as_str)
        .split(',')
        .map(str::to_owned)
        .collect();
    let threads = rayon::current_num_threads().min(2);
    let problem = Cantilever {
        length: 0.5,
        width: 0.05,
        height: 0.05,
        cells,
        split: BoxSplit::Lecture6,
        material: Material::new(1e6, 0.4, 1100.0).unwrap(),
        end_load: 0.0,
        gravity: 0.0,
    };
    let mesh = Arc::new(problem.mesh().unwrap());
    let system = Arc::new(
        LinearSystem::new(
            &mesh,
            &problem.material,
            &problem.constraints(mesh.as_ref()).unwrap(),
            &Loads::new(mesh.as_ref()),
            Vector3::new(0.0, 0.0, -9.81),
            MassKind::Lumped,
            Rayleigh::default(),
        )
        .unwrap(),
    );
    println!(
        "{}×{}×{}: {} free DOFs, {} tets, dt {dt} s, {steps} steps, {threads} thread(s)",
        cells[0],
        cells[1],
        cells[2],
        system.free_count(),
        mesh.tet_count()
    );
    if modes.iter().any(|m| m == "breakdown") {
        breakdown(&mesh, &problem, &system);
    }
    let mut reference: Option<Vec<Vec<f64>>> = None;
    for mode in modes.iter().filter(|m| *m != "breakdown") {
        let (force, solve) = match mode.as_str() {
            "linear" => (InternalForce::Linear, NonlinearSolve::Refactor),
            other => {
                let solve = match other {
                    "refactor" => NonlinearSolve::Refactor,
                    cg => {
                        let parts: Vec<&str> = cg.split(':').collect();
                        NonlinearSolve::RestPreconditionedCg {
                            max_cg_iterations: parts[1].parse().unwrap(),
                            forcing: parts[2].parse().unwrap(),
                        }
                    }
                };
                let force = InternalForce::of_model(
                    Arc::clone(&mesh),
                    ModelKind::Corotational.build(&problem.material),
                    &system,
                )
                .unwrap();
                (force, solve)
            }
        };
        let options = IntegratorOptions {
            cholesky: CholeskyOptions {
                threads,
                ..CholeskyOptions::default()
            },
            nonlinear_solve: solve,
            newton: tetfem::dynamics::StepNewtonOptions {
                tolerance: mode.split(':').nth(3).map_or(1e-8, |t| t.parse().unwrap()),
                ..Default::default()
            },
            ..IntegratorOptions::default()
        };
        let clock = Instant::now();
        let mut integrator =
            BackwardEuler::with_force(Arc::clone(&system), force, dt, options).unwrap();
        let setup = clock.elapsed().as_secs_f64();
        let mut state = State::at_rest(system.free_count());
        let mut times = Vec::new();
        let mut trajectory = Vec::new();
        for _ in 0..steps {
            let clock = Instant::now();
            integrator.step(&mut state).unwrap();
            times.push(clock.elapsed().as_secs_f64());
            trajectory.push(state.displacement.clone());
        }
        match &reference {
            None if mode == "refactor" => reference = Some(trajectory),
            None => {}
            Some(first) => {
                let scale = first.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
                let worst = first
                    .iter()
                    .zip(&trajectory)
                    .flat_map(|(a, b)| a.iter().zip(b).map(|(x, y)| (x - y).abs()))
                    .fold(0.0f64, f64::max);
                println!(
                    "{mode:>14}: largest difference from refactor over the run {:.3e} m, {:.3e} of the largest displacement {scale:.3e} m",
                    worst,
                    worst / scale
                );
            }
        }
        let tip = tip_rotation(&problem, &mesh, &system, &state);
        let stats = integrator.newton_stats().unwrap_or_default();
        let mean = times.iter().sum::<f64>() / times.len() as f64;
        let later = times[1..].iter().sum::<f64>() / (times.len() - 1).max(1) as f64;
        println!(
            "{mode:>14}: setup {setup:.3} s, first step {:.4} s, mean step {mean:.4} s, mean after the first {later:.4} s; Newton {} its (max {}), CG {} its, {} factorizations, {} fallbacks; tip rotation {tip:.1}°",
            times[0],
            stats.total_iterations,
            stats.max_per_step,
            stats.cg_iterations,
            stats.factorizations,
            stats.fallbacks
        );
    }
}

/// The angle (degrees) between the tip face's vertical edge at y = 0 and the z axis.
fn tip_rotation(
    problem: &Cantilever,
    mesh: &tetfem::TetMesh,
    system: &LinearSystem,
    state: &State,
) -> f64 {
    let u = system.dofs().expand(&state.displacement).unwrap();
    let nodes = mesh.nodes();
    let tip = problem.tip_nodes(mesh);
    let at = |z: f64| {
        *tip.iter()
            .find(|&&n| nodes[n].y.abs() < 1e-9 && (nodes[n].z - z).abs() < 1e-9)
            .unwrap()
    };
    let (bottom, top) = (at(0.0), at(problem.height));
    let x = |n: usize| nodes[n] + Vector3::new(u[3 * n], u[3 * n + 1], u[3 * n + 2]);
    (x(top) - x(bottom)).angle(&Vector3::z()).to_degrees()
}

/// Wall time of the corotational model's force and tangent assembly on the free DOFs at rest.
fn breakdown(mesh: &Arc<tetfem::TetMesh>, problem: &Cantilever, system: &LinearSystem) {
    let force = tetfem::dynamics::NonlinearForce::new(
        Arc::clone(mesh),
        ModelKind::Corotational.build(&problem.material),
        system,
    )
    .unwrap();
    let mut work = force.workspace().unwrap();
    let mut tangent = force.zero_tangent().unwrap();
    let u = vec![1e-3; system.free_count()];
    let mut f = vec![0.0; u.len()];
    let repeat = 5;
    let clock = Instant::now();
    for _ in 0..repeat {
        force.force_into(&u, &mut work, &mut f).unwrap();
    }
    let force_time = clock.elapsed().as_secs_f64() / repeat as f64;
    let clock = Instant::now();
    for _ in 0..repeat {
        force
            .tangent_into(&u, false, &mut work, &mut tangent)
            .unwrap();
    }
    let tangent_time = clock.elapsed().as_secs_f64() / repeat as f64;
    let clock = Instant::now();
    for _ in 0..repeat {
        force.potential_energy(&u).unwrap();
    }
    let energy_time = clock.elapsed().as_secs_f64() / repeat as f64;
    println!(
        "corotational force {force_time:.4} s, tangent {tangent_time:.4} s, energy {energy_time:.4} s per evaluation"
    );
}
