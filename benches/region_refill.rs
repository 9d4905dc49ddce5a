//! Timing harness for materials per region: `Assembler::refill_stiffness` with one `Material`
//! (the uniform case, the code path of every single-material caller), with
//! `MaterialMap::uniform` (what a scene passes) and with a two-material map (left and right
//! halves), interleaved in one process so that machine noise hits all alike.
//!
//! Usage: `RAYON_NUM_THREADS=1 cargo bench --bench region_refill -- 100 10 10 [rounds]`.
//! Prints the best of `rounds` runs of each (ns per tet) and checks that the uniform map gives
//! the single material's values bit for bit.

use std::hint::black_box;
use std::sync::Arc;
use std::time::Instant;

use nalgebra::Vector3;
use tetfem::fe::assembly::Assembler;
use tetfem::linalg::sparse::CscMatrix;
use tetfem::{BoxSplit, Material, MaterialAssignment, MaterialMap, TetMaterials, TetMesh};

fn main() -> tetfem::Result<()> {
    // `cargo bench` appends `--bench` to a harness-less target's arguments: not one of ours.
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .map(|a| a.parse().expect("cell counts and rounds are integers"))
        .collect();
    let cells = [
        *args.first().unwrap_or(&100),
        *args.get(1).unwrap_or(&10),
        *args.get(2).unwrap_or(&10),
    ];
    let rounds = *args.get(3).unwrap_or(&15);
    let mesh = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(1.0, 0.1, 0.1),
        cells,
        BoxSplit::Mirrored6,
    )?;
    let steel = Material::steel();
    let uniform = MaterialMap::uniform(steel, mesh.tet_count());
    let mut halves = MaterialAssignment::new(mesh.tet_count());
    halves.assign_box(
        &mesh,
        "left",
        steel,
        Vector3::new(-1.0, -1.0, -1.0),
        Vector3::new(0.5, 1.0, 1.0),
    )?;
    let two = halves.finish(Some(Material::new(70e9, 0.33, 2700.0)?))?;
    let assembler = Assembler::new(&mesh);
    let mut matrix = CscMatrix::zeros(Arc::clone(assembler.pattern()))?;
    let mut time = |materials: &dyn Fn(&mut CscMatrix) -> tetfem::Result<()>| {
        let clock = Instant::now();
        materials(&mut matrix).map(|_| {
            black_box(matrix.values());
            clock.elapsed().as_secs_f64() * 1e9 / mesh.tet_count() as f64
        })
    };
    let (mut best_one, mut best_uniform, mut best_two) = (f64::MAX, f64::MAX, f64::MAX);
    for _ in 0..rounds {
        best_one = best_one.min(time(&|m| assembler.refill_stiffness(&mesh, &steel, m))?);
        best_uniform = best_uniform.min(time(&|m| assembler.refill_stiffness(&mesh, &uniform, m))?);
        best_two = best_two.min(time(&|m| assembler.refill_stiffness(&mesh, &two, m))?);
    }
    let a = assembler.stiffness(&mesh, &steel)?;
    let b = assembler.stiffness(&mesh, &uniform)?;
    assert_eq!(
        a.values(),
        b.values(),
        "uniform map differs from one material"
    );
    println!(
        "{} tets, {} materials in the split map, best of {rounds}:",
        mesh.tet_count(),
        two.material_list().len()
    );
    println!("  one Material          {best_one:7.1} ns/tet");
    println!(
        "  MaterialMap::uniform  {best_uniform:7.1} ns/tet  ({:.3}×)",
        best_uniform / best_one
    );
    println!(
        "  two-material map      {best_two:7.1} ns/tet  ({:.3}×)",
        best_two / best_one
    );
    Ok(())
}
