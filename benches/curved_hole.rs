//! The plate with a hole on curved (isoparametric) P2 (`tetfem_fixtures::hole`, the mesh of
//! `validation/hole_speed_accuracy.py`): per size, the hole-edge stress σ_xx at (0, a, 0) and
//! its error against MFEM's order-4 curved reference, and the wall time of the stiffness
//! assembly alone and of the whole solve (assembly + factorization + solve), best of the
//! repeats. The curved stiffness rule is what moves both: compare two builds of this bench.
//!
//! Usage: `cargo bench --bench curved_hole -- [--repeat K] N ...` (sizes n: 2n × n × n/2
//! cells; default `--repeat 3 4 8 12`). `RAYON_NUM_THREADS=1` for the peers' one thread.

use std::time::Instant;

use nalgebra::Vector3;
use tetfem::fe::assembly::stiffness_matrix;
use tetfem::post::output::fields::{recovered_nodal_stress, tet_node_stress};
use tetfem::{Constraints, Loads, Material, Tet10, TetMesh, solve_static};
use tetfem_fixtures::hole::{self, Hole};

/// MFEM curved order 4 on 16 × 8 × 4 cells (validation/SPEED_ACCURACY.md's reference).
const REFERENCE: f64 = 3.686_591_998;

/// Rollers on the three symmetry planes, unit traction along x on x = L.
fn problem(mesh: &TetMesh<Tet10>) -> tetfem::Result<(Constraints, Loads)> {
    let mut constraints = Constraints::new(mesh);
    for (n, p) in mesh.nodes().iter().enumerate() {
        for axis in 0..3 {
            if p[axis].abs() < 1e-9 {
                constraints.prescribe_axis(n, axis, 0.0)?;
            }
        }
    }
    let faces = mesh.faces_on_plane(&mesh.boundary_faces()?, 0, hole::L, 1e-9);
    let mut loads = Loads::new(mesh);
    loads.add_traction(mesh, &faces, Vector3::new(1.0, 0.0, 0.0))?;
    Ok((constraints, loads))
}

/// σ_xx at (0, a, 0) and the seconds of the assembly alone and of the solve.
fn run(mesh: &TetMesh<Tet10>, material: &Material) -> tetfem::Result<(f64, f64, f64)> {
    let (constraints, loads) = problem(mesh)?;
    let clock = Instant::now();
    std::hint::black_box(stiffness_matrix(mesh, material)?);
    let assembly = clock.elapsed().as_secs_f64();
    let clock = Instant::now();
    let u = solve_static(mesh, material, &constraints, &loads)?.displacement;
    let solve = clock.elapsed().as_secs_f64();
    let node_stress = tet_node_stress(mesh, material, &u)?;
    let sxx = recovered_nodal_stress(mesh, &node_stress)?[Hole::TARGET][(0, 0)];
    Ok((sxx, assembly, solve))
}

fn main() -> tetfem::Result<()> {
    // `cargo bench` appends `--bench` to a harness-less target's arguments: not one of ours.
    let mut args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    let mut repeat = 3;
    if let Some(i) = args.iter().position(|a| a == "--repeat") {
        repeat = args
            .get(i + 1)
            .and_then(|v| v.parse().ok())
            .expect("--repeat takes a count");
        args.drain(i..i + 2);
    }
    if args.is_empty() {
        args = vec!["4".into(), "8".into(), "12".into()];
    }
    let material = Material::new(1e5, 0.3, 1.0)?;
    println!("cells      DOFs     sigma_xx            error       assembly s  solve s");
    for n in &args {
        let n: usize = n.parse().expect("sizes are integers n");
        let mesh = Hole::new(n)?.curved_mesh()?;
        let (mut sxx, mut assembly, mut solve) = (0.0, f64::INFINITY, f64::INFINITY);
        for _ in 0..repeat.max(1) {
            let (s, a, t) = run(&mesh, &material)?;
            (sxx, assembly, solve) = (s, assembly.min(a), solve.min(t));
        }
        let [ni, nj, nk] = Hole::cells(n);
        println!(
            "{:<10} {:>7}  {sxx:.15}  {:.4e}  {assembly:.4}      {solve:.4}",
            format!("{ni}x{nj}x{nk}"),
            mesh.dof_count(),
            (sxx - REFERENCE).abs() / REFERENCE,
        );
    }
    Ok(())
}
