//! Quadratic tets on a Gmsh mesh, and the solution's own estimate of its error.
//!
//! One idea: a static solution can say how good it is. [`Static::estimated_error`] recovers a
//! smooth stress from the element stresses (Zienkiewicz–Zhu, superconvergent patch recovery) and
//! measures the gap in the energy norm: an estimate of ‖u − u_h‖_E / ‖u‖_E without knowing u.
//! The mesh is `scenes/l_bracket_p2.msh` (Gmsh, 10-node tets, physical surfaces "clamp" and
//! "load"): a steel L-bracket clamped on "clamp", 2 kN pulling "load" along −y. It is solved
//! twice: with the file's 10-node tets, and with their corners only (4-node tets, the same
//! geometry and far fewer DOFs).
//!
//! Prints, per element: DOFs, the largest displacement and the estimated relative error; asserts
//! that the supports carry the load and that the quadratic solution estimates itself better.
//!
//! Run: `cargo run --release --example gmsh_p2_error`

use std::path::Path;

use tetfem::analysis::{Definition, Static, StaticOptions};
use tetfem::mesh::io::read_gmsh_as;
use tetfem::model::ModelElement;
use tetfem::nalgebra::Vector3;
use tetfem::post::estimate::PointwiseElement;
use tetfem::{Constraints, Error, Loads, Material, MaterialMap, Tet4, Tet10};

const LOAD: f64 = 2000.0; // N, along −y on the group "load"

/// The bracket on the file's cells read as `C`, solved: (DOFs, largest |u| in m, estimated
/// relative error, the supports' total y reaction in N).
fn solve<C: ModelElement + PointwiseElement>(
    file: &Path,
) -> tetfem::Result<(usize, f64, f64, f64)> {
    let imported = read_gmsh_as::<C>(file)?;
    let group = |name: &str| {
        imported
            .group(name)
            .ok_or_else(|| Error::invalid_parameter("physical group", name, "not in the file"))
    };
    let mesh = &imported.mesh;
    let mut constraints = Constraints::new(mesh);
    constraints.fix_nodes(&group("clamp")?.nodes)?;
    let faces = group("load")?.boundary_faces(&mesh.boundary_faces()?);
    let mut loads = Loads::new(mesh);
    loads.add_total_force_on_faces(mesh, &faces, Vector3::new(0.0, -LOAD, 0.0))?;
    let materials = MaterialMap::uniform(Material::steel(), mesh.tet_count());
    let bracket = Definition::builder(imported.mesh.clone(), materials)
        .constraints(constraints)?
        .loads(loads)?
        .build()?;
    let analysis = Static::new(&bracket, StaticOptions::default())?;
    let outcome = analysis.solve()?;
    let u = &outcome.displacement;
    let largest = u
        .chunks(3)
        .map(|d| Vector3::new(d[0], d[1], d[2]).norm())
        .fold(0.0, f64::max);
    let estimate = analysis.estimated_error(u)?;
    let reaction_y: f64 = outcome.reactions.iter().skip(1).step_by(3).sum();
    Ok((u.len(), largest, estimate.relative(), reaction_y))
}

fn main() -> tetfem::Result<()> {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/l_bracket_p2.msh");
    let p1 = solve::<Tet4>(&file)?;
    let p2 = solve::<Tet10>(&file)?;
    for (name, (dofs, largest, relative, reaction_y)) in [("4-node tets", p1), ("10-node tets", p2)]
    {
        println!(
            "{name:>12}: {dofs:>6} DOFs, largest |u| {largest:.4e} m, estimated error {:.2} %, \
             support reaction y {reaction_y:.1} N",
            100.0 * relative
        );
        // The supports hold the 2 kN: reactions + load = 0 along y, to the direct solve's
        // round-off (1e-6 of the load is far above it and far below any mistake in the load).
        assert!(
            (reaction_y - LOAD).abs() < 1e-6 * LOAD,
            "{name}: reaction {reaction_y} N"
        );
    }
    // Linear tets are stiff in bending: same corners, smaller displacement...
    assert!(p1.1 < p2.1, "P1 {} m against P2 {} m", p1.1, p2.1);
    // ...and the estimate sees it: the quadratic solution's estimated error is the smaller.
    assert!(
        p2.2 < p1.2,
        "estimated error P2 {} against P1 {}",
        p2.2,
        p1.2
    );
    Ok(())
}
