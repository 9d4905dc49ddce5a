//! Cost of one Newton iteration per force model on a ~133k-DOF cantilever (100×20×20 cells):
//! tangent assembly, numeric refactorization and solve, against the linear model's reused
//! factorization. `cargo bench --bench model_cost`.

use std::time::Instant;

use tetfem::model::{ModelKind, assemble};
use tetfem::{Assembler, CscMatrix, DofMap, SparseCholesky};
use tetfem_fixtures::cantilever::Cantilever;

fn main() -> tetfem::Result<()> {
    let problem = Cantilever::peer_benchmark([100, 20, 20]);
    let mesh = problem.mesh()?;
    let dofs = DofMap::new(&problem.constraints(&mesh)?);
    let assembler = Assembler::new(&mesh);
    let restriction = dofs.restriction(assembler.pattern()).unwrap();
    let mut tangent = CscMatrix::zeros(std::sync::Arc::clone(assembler.pattern())).unwrap();
    let mut free = CscMatrix::zeros(std::sync::Arc::clone(restriction.pattern())).unwrap();
    let mut cholesky = SparseCholesky::analyze(&free)?;
    // A deformed state: the linear static solution under a large end load.
    let u = Cantilever {
        end_load: 100.0,
        ..problem
    }
    .solve()?
    .solution
    .displacement;
    println!("{} DOFs, {} tets", mesh.dof_count(), mesh.tet_count());
    for kind in [
        ModelKind::Linear,
        ModelKind::Corotational,
        ModelKind::NeoHookean,
    ] {
        let model = kind.build(&problem.material);
        let t = Instant::now();
        let force = assemble::internal_force(&mesh, model.as_ref(), &u).unwrap();
        let t_force = t.elapsed().as_secs_f64();
        let t = Instant::now();
        assemble::refill_tangent(&mesh, &assembler, model.as_ref(), &u, false, &mut tangent)
            .unwrap();
        restriction.restrict_into(&tangent, &mut free).unwrap();
        let t_assembly = t.elapsed().as_secs_f64();
        let t = Instant::now();
        cholesky.factorize(&free)?;
        let t_factor = t.elapsed().as_secs_f64();
        let mut rhs = dofs.restrict(&force).unwrap();
        let t = Instant::now();
        cholesky.solve_in_place(&mut rhs)?;
        let t_solve = t.elapsed().as_secs_f64();
        println!(
            "{:<13} force {t_force:.3} s, tangent assembly {t_assembly:.3} s, numeric refactor {t_factor:.3} s, solve {t_solve:.3} s, total {:.3} s",
            model.name(),
            t_force + t_assembly + t_factor + t_solve
        );
    }
    println!("(the linear model with a reused factorization needs only the solve per load case)");
    Ok(())
}
