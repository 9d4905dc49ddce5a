//! Conjugate gradients on the cantilever stiffness K_ff (the peers' benchmark beam, 10×1×1,
//! clamped at x = 0, end load) with each preconditioner, against the direct solve:
//! iterations, setup and solve time, and the relative difference of the solution.
//! `cargo bench --bench preconditioners [-- [--tol T] NX,NY,NZ ...]` (default
//! tolerance 1e-8, sizes 40,8,8 and 80,16,16). SA-AMG is run with the rigid-body modes from
//! the mesh and, for comparison, with the translations only (no geometry).

use std::time::Instant;

use tetfem::SparseCholesky;
use tetfem::linalg::amg::SmoothedAggregation;
use tetfem::linalg::iterative::{
    BlockJacobi, CgOptions, IncompleteCholesky, Preconditioner, conjugate_gradient,
};
use tetfem_fixtures::cantilever::{Cantilever, FreeSystem};

fn main() -> tetfem::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let tolerance = args
        .iter()
        .position(|a| a == "--tol")
        .and_then(|i| args.get(i + 1))
        .and_then(|t| t.parse().ok())
        .unwrap_or(1e-8);
    let sizes: Vec<[usize; 3]> = {
        let given: Vec<[usize; 3]> = std::env::args()
            .skip(1)
            .filter_map(|a| {
                let v: Vec<usize> = a.split(',').filter_map(|x| x.parse().ok()).collect();
                (v.len() == 3).then(|| [v[0], v[1], v[2]])
            })
            .collect();
        if given.is_empty() {
            vec![[40, 8, 8], [80, 16, 16]]
        } else {
            given
        }
    };
    println!("CG relative tolerance {tolerance:e}\n");
    println!(
        "| cells | free DOFs | method | setup (s) | iterations | solve (s) | ‖x − x_direct‖/‖x_direct‖ |"
    );
    println!("|---|---|---|---|---|---|---|");
    for cells in sizes {
        let problem = Cantilever::peer_benchmark(cells);
        let mesh = problem.mesh()?;
        let FreeSystem {
            dofs,
            stiffness: k_ff,
            load: rhs,
        } = problem.free_system(&mesh)?;
        let label = format!("{}×{}×{}", cells[0], cells[1], cells[2]);

        let clock = Instant::now();
        let mut cholesky = SparseCholesky::analyze(&k_ff)?;
        cholesky.factorize(&k_ff)?;
        let setup = clock.elapsed().as_secs_f64();
        let clock = Instant::now();
        let mut direct = rhs.clone();
        cholesky.solve_in_place(&mut direct)?;
        let solve = clock.elapsed().as_secs_f64();
        println!(
            "| {label} | {} | Cholesky (METIS) | {setup:.2} | – | {solve:.3} | 0 |",
            k_ff.dim()
        );
        let norm = direct.iter().map(|x| x * x).sum::<f64>().sqrt();

        let options = CgOptions {
            relative_tolerance: tolerance,
            max_iterations: 20_000,
        };
        let run = |name: &str, preconditioner: &dyn Preconditioner, setup: f64| {
            let clock = Instant::now();
            let mut x = vec![0.0; rhs.len()];
            match conjugate_gradient(&k_ff, preconditioner, &rhs, &mut x, options) {
                Ok(report) => {
                    let error = x
                        .iter()
                        .zip(&direct)
                        .map(|(a, b)| (a - b) * (a - b))
                        .sum::<f64>()
                        .sqrt()
                        / norm;
                    println!(
                        "| {label} | {} | CG + {name} | {setup:.2} | {} | {:.2} | {error:.1e} |",
                        k_ff.dim(),
                        report.iterations,
                        clock.elapsed().as_secs_f64()
                    );
                }
                Err(e) => println!(
                    "| {label} | {} | CG + {name} | {setup:.2} | failed | {:.2} | {e} |",
                    k_ff.dim(),
                    clock.elapsed().as_secs_f64()
                ),
            }
        };
        let clock = Instant::now();
        let jacobi = BlockJacobi::new(&k_ff)?;
        run("block Jacobi", &jacobi, clock.elapsed().as_secs_f64());
        let clock = Instant::now();
        let ic = IncompleteCholesky::new(&k_ff)?;
        let setup = clock.elapsed().as_secs_f64();
        run(&format!("IC(0), shift {:.0e}", ic.shift()), &ic, setup);
        drop(ic);
        let clock = Instant::now();
        let amg = SmoothedAggregation::new(&k_ff, Some(&dofs.geometry(&mesh)?))?;
        let setup = clock.elapsed().as_secs_f64();
        let sizes: Vec<String> = amg
            .level_sizes()
            .iter()
            .map(|l| l.dim.to_string())
            .collect();
        let name = format!(
            "SA-AMG, rigid modes (levels {}, op. complexity {:.2})",
            sizes.join("/"),
            amg.operator_complexity()
        );
        run(&name, &amg, setup);
        drop(amg);
        let clock = Instant::now();
        let amg = SmoothedAggregation::new(&k_ff, None)?;
        run(
            "SA-AMG, translations only",
            &amg,
            clock.elapsed().as_secs_f64(),
        );
    }
    Ok(())
}
