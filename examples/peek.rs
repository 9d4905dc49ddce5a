fn main() {
    for n in [10usize, 20, 40, 80] {
        let c = tetfem::cantilever::Cantilever::peer_benchmark([n, n / 10, n / 10]);
        let t = std::time::Instant::now();
        let s = c.solve().unwrap();
        println!(
            "{n} {:.10e} res {:.2e} {:?} {:?}",
            s.tip_deflection,
            s.solution.relative_residual,
            t.elapsed(),
            s.timings
        );
    }
}
