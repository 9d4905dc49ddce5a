//! The peer cantilever (L = 10, W = H = 1, E = 1e5, ν = 0.3, end load P = 1, clamped at x = 0)
//! on linear and quadratic tets of the same meshes: tip deflection, DOFs and wall time side by
//! side, and with `--write DIR` each quadratic solution as CSV for the scikit-fem comparison
//! (`validation/p2_peer.py`).
//!
//! Usage: `cargo bench --bench quadratic_cantilever -- [--write DIR] NX,NY,NZ ...`
//! (default 10,1,1 20,2,2 40,4,4).

use std::io::Write;
use std::time::Instant;

use tetfem::fe::element::ElementType;
use tetfem::{Tet10, TetMesh, solve_static};
use tetfem_fixtures::cantilever::Cantilever;

/// Tip deflection (mean u_z on x = L), free DOFs and seconds of one solve on `mesh`.
fn solve<E: ElementType>(
    problem: &Cantilever,
    mesh: &TetMesh<E>,
) -> tetfem::Result<(f64, usize, f64, Vec<f64>)> {
    let clock = Instant::now();
    let constraints = problem.constraints(mesh)?;
    let loads = problem.loads(mesh)?;
    let solution = solve_static(mesh, &problem.material, &constraints, &loads)?;
    let seconds = clock.elapsed().as_secs_f64();
    let tip = problem.tip_deflection(mesh, &solution.displacement)?;
    let free = mesh.dof_count() - constraints.count();
    Ok((tip, free, seconds, solution.displacement))
}

fn write_csv(path: &std::path::Path, header: &str, rows: impl Iterator<Item = String>) {
    let mut file = std::io::BufWriter::new(
        std::fs::File::create(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())),
    );
    writeln!(file, "{header}").expect("write");
    for row in rows {
        writeln!(file, "{row}").expect("write");
    }
}

fn main() -> tetfem::Result<()> {
    // `cargo bench` appends `--bench` to a harness-less target's arguments: not one of ours.
    let mut args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    let write = match args.iter().position(|a| a == "--write") {
        Some(i) => {
            let dir = std::path::PathBuf::from(args.get(i + 1).expect("--write takes a folder"));
            args.drain(i..i + 2);
            std::fs::create_dir_all(&dir).expect("create the --write folder");
            Some(dir)
        }
        None => None,
    };
    if args.is_empty() {
        args = vec!["10,1,1".into(), "20,2,2".into(), "40,4,4".into()];
    }
    println!("cells      P1 DOFs   P1 tip           P1 s     P2 DOFs   P2 tip           P2 s");
    for cells in &args {
        let c: Vec<usize> = cells
            .split(',')
            .map(|v| v.parse().expect("cells are NX,NY,NZ"))
            .collect();
        let problem = Cantilever::peer_benchmark([c[0], c[1], c[2]]);
        let linear = problem.mesh()?;
        let quadratic = TetMesh::<Tet10>::from_linear(&linear)?;
        let (tip1, dofs1, s1, _) = solve(&problem, &linear)?;
        let (tip2, dofs2, s2, u) = solve(&problem, &quadratic)?;
        println!(
            "{cells:<10} {dofs1:>7}   {tip1:+.9e}  {s1:.3}   {dofs2:>7}   {tip2:+.9e}  {s2:.3}"
        );
        if let Some(dir) = &write {
            let stem = cells.replace(',', "x");
            write_csv(
                &dir.join(format!("{stem}_nodes.csv")),
                "x,y,z",
                linear
                    .nodes()
                    .iter()
                    .map(|p| format!("{:e},{:e},{:e}", p.x, p.y, p.z)),
            );
            write_csv(
                &dir.join(format!("{stem}_tets.csv")),
                "a,b,c,d",
                linear
                    .tets()
                    .iter()
                    .map(|t| format!("{},{},{},{}", t[0], t[1], t[2], t[3])),
            );
            write_csv(
                &dir.join(format!("{stem}_p2.csv")),
                "x,y,z,ux,uy,uz",
                quadratic.nodes().iter().enumerate().map(|(n, p)| {
                    format!(
                        "{:e},{:e},{:e},{:e},{:e},{:e}",
                        p.x,
                        p.y,
                        p.z,
                        u[3 * n],
                        u[3 * n + 1],
                        u[3 * n + 2]
                    )
                }),
            );
        }
    }
    Ok(())
}
