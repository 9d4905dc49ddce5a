//! A rigid sphere pressed into an elastic block (issue 18, item 2): contact force against
//! indentation compared with Hertz's law P = (4/3)·E*·R^{1/2}·δ^{3/2}, E* = E/(1 − ν²).

use nalgebra::Vector3;
use tetfem::contact::{Contact, ContactParameters, Obstacle};
use tetfem::model::ModelKind;
use tetfem::nonlinear::{NewtonOptions, solve_nonlinear_static_with_contact};
use tetfem::{BoxSplit, Constraints, Loads, Material, TetMesh};

const RADIUS: f64 = 10.0;
const CELLS: usize = 16;

/// Force (quarter model × 4) and indentation δ for the block's base pushed up by `lift`.
fn press(lift: f64) -> (f64, f64) {
    // A quarter of a 2 × 2 × 1 block (symmetry planes x = 0 and y = 0), the sphere above its
    // corner at the origin: the contact radius √(Rδ) spans 3–6 elements.
    let mesh = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(1.0, 1.0, 1.0),
        [CELLS, CELLS, CELLS],
        BoxSplit::Lecture6,
    )
    .unwrap();
    let material = Material::new(1e6, 0.3, 1000.0).unwrap();
    let mut constraints = Constraints::new(&mesh);
    constraints
        .fix_axes(&mesh.nodes_on_plane(0, 0.0, 1e-9), [true, false, false])
        .unwrap();
    constraints
        .fix_axes(&mesh.nodes_on_plane(1, 0.0, 1e-9), [false, true, false])
        .unwrap();
    let base = mesh.nodes_on_plane(2, 0.0, 1e-9);
    for &n in &base {
        constraints
            .prescribe(n, Vector3::new(0.0, 0.0, lift))
            .unwrap();
    }
    // d̂ well below the indentations measured (1e-4 against 5e-3 and more).
    let d_hat = 1e-4;
    let parameters = ContactParameters {
        activation_distance: d_hat,
        stiffness: ContactParameters::for_mesh(&mesh, material.youngs_modulus())
            .unwrap()
            .stiffness,
    };
    let start_gap = 0.5 * d_hat;
    let sphere = Obstacle::sphere(
        "sphere",
        Vector3::new(0.0, 0.0, 1.0 + start_gap + RADIUS),
        RADIUS,
    )
    .unwrap();
    let contact = Contact::new(&mesh, vec![sphere], parameters).unwrap();
    let report = solve_nonlinear_static_with_contact(
        &mesh,
        ModelKind::Linear.build(&material).as_ref(),
        &constraints,
        &Loads::new(&mesh),
        &contact,
        NewtonOptions {
            load_steps: 5,
            ..NewtonOptions::default()
        },
    )
    .unwrap();
    let u = &report.displacement;
    let top = mesh.nodes_where(|x| x.norm_squared() - 1.0 < 1e-12 && (x.z - 1.0).abs() < 1e-9)[0];
    // Approach of the base towards the sphere minus the rise of the surface under it.
    let indentation = lift - u[3 * top + 2];
    let force = contact.obstacle_forces(u).unwrap()[0].z;
    (4.0 * force, indentation)
}

#[test]
fn sphere_indentation_follows_hertz() {
    let material = Material::new(1e6, 0.3, 1000.0).unwrap();
    let e_star = material.youngs_modulus() / (1.0 - 0.3f64.powi(2));
    let mut points = Vec::new();
    for lift in [0.004, 0.008] {
        let (force, indentation) = press(lift);
        let hertz = 4.0 / 3.0 * e_star * RADIUS.sqrt() * indentation.powf(1.5);
        println!(
            "lift {lift}: δ = {indentation:.4e} m, P = {force:.4e} N, Hertz {hertz:.4e} N, ratio {:.4}",
            force / hertz
        );
        points.push((force, indentation, hertz));
    }
    let slope = (points[1].0 / points[0].0).ln() / (points[1].1 / points[0].1).ln();
    println!("log-log slope {slope:.4} (Hertz 1.5)");
}
