//! The cost of a large-deformation backward-Euler step, side by side in one run: the linear
//! step, the corotational step refactoring every Newton iteration, and the corotational step
//! whose Newton solves are CG preconditioned by the rest-state factor turned by the nodes'
//! rotations. A rubber cantilever
//! (0.5 × 0.05 × 0.05 m, E = 1 MPa, ν = 0.4, ρ = 1100 kg/m³, the lecture's 6-tet split)
//! released from rest under gravity; each method takes the same `steps` steps of `dt` from
//! rest, and the mean of their wall times is reported, with the Newton, CG and factorization
//! counts and the largest tip rotation reached; every corotational mode after the first also
//! prints its largest difference from the first one's trajectory over the run (put `refactor`
//! first to compare with it).
//!
//! `cargo bench --bench corotational_step -- NX NY NZ [dt] [steps] [modes]`,
//! modes a comma list of `linear`, `refactor`, `cg:MAX:FORCING[:TOLERANCE]`,
//! `lbfgs:HISTORY:-[:TOLERANCE]` (L-BFGS; the third field is unused), `default`
//! (`NonlinearSolve::Auto` at the default Newton options: from 1,000 DOFs L-BFGS stopping at
//! `AUTO_LBFGS_TOLERANCE`) and `breakdown` (times the force, tangent and energy at the last
//! mode's final state) (default: `linear,refactor,cg:25:1e-3,lbfgs:5,default`). Threads:
//! `RAYON_NUM_THREADS`; the Cholesky uses as many (≤ 2).

use std::sync::Arc;
use std::time::Instant;

use tetfem::BoxSplit;
use tetfem::analysis::dynamics::{Integrator, InternalForce, NonlinearSolve, State};
use tetfem::model::ModelKind;
use tetfem_fixtures::swing::Swing;

fn main() {
    // `cargo bench` appends `--bench` to a harness-less target's arguments: not one of ours.
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
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
        .map_or("linear,refactor,cg:25:1e-3,lbfgs:5,default", String::as_str)
        .split(',')
        .map(str::to_owned)
        .collect();
    let threads = rayon::current_num_threads().min(2);
    let swing = Swing::new(cells, BoxSplit::Lecture6, 1e6).unwrap();
    let (mesh, system) = (&swing.mesh, &swing.system);
    println!(
        "{}×{}×{}: {} free DOFs, {} tets, dt {dt} s, {steps} steps, {threads} thread(s)",
        cells[0],
        cells[1],
        cells[2],
        system.free_count(),
        mesh.tet_count()
    );
    let mut reference: Option<Vec<Vec<f64>>> = None;
    let mut last_state = None;
    for mode in modes.iter().filter(|m| *m != "breakdown") {
        let (force, solve) = match mode.as_str() {
            "linear" => (InternalForce::Linear, NonlinearSolve::Refactor),
            "refactor" => (swing.corotational().unwrap(), NonlinearSolve::Refactor),
            "default" => (swing.corotational().unwrap(), NonlinearSolve::Auto),
            lbfgs if lbfgs.starts_with("lbfgs") => (
                swing.corotational().unwrap(),
                NonlinearSolve::RestPreconditionedLbfgs {
                    history: lbfgs.split(':').nth(1).map_or(5, |h| h.parse().unwrap()),
                },
            ),
            cg => {
                let parts: Vec<&str> = cg.split(':').collect();
                let solve = NonlinearSolve::RestPreconditionedCg {
                    max_cg_iterations: parts[1].parse().unwrap(),
                    forcing: parts[2].parse().unwrap(),
                };
                (swing.corotational().unwrap(), solve)
            }
        };
        let tolerance = mode.split(':').nth(3).map_or(1e-8, |t| t.parse().unwrap());
        let clock = Instant::now();
        let mut integrator = swing
            .integrator(force, dt, solve, tolerance, threads)
            .unwrap();
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
            None if mode != "linear" => reference = Some(trajectory),
            None => {}
            Some(first) => {
                let scale = first.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
                let worst = first
                    .iter()
                    .zip(&trajectory)
                    .flat_map(|(a, b)| a.iter().zip(b).map(|(x, y)| (x - y).abs()))
                    .fold(0.0f64, f64::max);
                println!(
                    "{mode:>14}: largest difference from the first over the run {:.3e} m, {:.3e} of the largest displacement {scale:.3e} m",
                    worst,
                    worst / scale
                );
            }
        }
        let tip = swing.tip_rotation(&state).unwrap();
        last_state = Some(state.displacement.clone());
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
    if modes.iter().any(|m| m == "breakdown") {
        breakdown(&swing, last_state);
    }
}

/// Wall time of the corotational model's force, tangent and energy on the free DOFs at the
/// last mode's final state (the bent, turned beam), or at a uniform 1 mm shift (F = I) when
/// `breakdown` is the only mode.
fn breakdown(swing: &Swing, state: Option<Vec<f64>>) {
    let force = tetfem::analysis::dynamics::NonlinearForce::new(
        Arc::clone(&swing.mesh),
        ModelKind::Corotational.build(&swing.problem.material),
        &swing.system,
    )
    .unwrap();
    let system = &swing.system;
    let mut work = force.workspace().unwrap();
    let mut tangent = force.zero_tangent().unwrap();
    let u = state.unwrap_or_else(|| vec![1e-3; system.free_count()]);
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
