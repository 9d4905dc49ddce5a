use tetfem::cantilever::Cantilever;
use tetfem::{CholeskyOptions, FillOrdering, LinearMethod, SolverOptions, StaticSolver};
fn main() {
    let n: usize = std::env::args().nth(1).unwrap().parse().unwrap();
    let c = Cantilever::peer_benchmark([n, n / 10, n / 10]);
    let mesh = c.mesh().unwrap();
    let cons = c.constraints(&mesh).unwrap();
    let loads = c.loads(&mesh).unwrap();
    for ordering in [FillOrdering::NestedDissection, FillOrdering::Amd] {
        for threads in [1, 2] {
            let t = std::time::Instant::now();
            let mut s = StaticSolver::with_options(
                &mesh,
                &c.material,
                &cons,
                SolverOptions {
                    method: LinearMethod::Direct,
                    cholesky: CholeskyOptions { ordering, threads },
                    ..Default::default()
                },
            )
            .unwrap();
            let sol = s.solve(&loads).unwrap();
            let tip = c.tip_deflection(&mesh, &sol.displacement);
            println!(
                "{n} {ordering:?} thr{threads} L={} tip={tip:.10e} res={:.1e} total {:?} sym {:?} num {:?} solve {:?}",
                s.factor_len(),
                sol.relative_residual,
                t.elapsed(),
                s.timings().symbolic,
                s.timings().factorization,
                s.timings().solve
            );
        }
    }
}
