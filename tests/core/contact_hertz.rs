//! A rigid sphere pressed into an elastic block (issue 18, item 2): contact force against
//! indentation compared with Hertz's law P = (4/3)·E*·R^{1/2}·δ^{3/2}, E* = E/(1 − ν²).

use nalgebra::Vector3;
use tetfem::analysis::nonlinear::{NewtonOptions, solve_nonlinear_static_with_contact};
use tetfem::contact::{Contact, ContactParameters, Obstacle};
use tetfem::model::ModelKind;
use tetfem::{BoxSplit, Constraints, Loads, Material, TetMesh};

const RADIUS: f64 = 10.0;
const CELLS: usize = 12;

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
        impact_fraction: None,
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
            load_steps: 2,
            ..NewtonOptions::default()
        },
    )
    .unwrap();
    let u = &report.displacement;
    let top = mesh.nodes_where(|x| x.norm_squared() - 1.0 < 1e-12 && (x.z - 1.0).abs() < 1e-9)[0];
    // Approach of the base towards the sphere minus the rise of the surface under it.
    let indentation = lift - u[3 * top + 2];
    let force = report
        .solved_contact(&contact)
        .unwrap()
        .obstacle_forces(u)
        .unwrap()[0]
        .z;
    (4.0 * force, indentation)
}

#[test]
fn sphere_indentation_follows_hertz() {
    let material = Material::new(1e6, 0.3, 1000.0).unwrap();
    let e_star = material.youngs_modulus() / (1.0 - 0.3f64.powi(2));
    let (e, nu) = (material.youngs_modulus(), 0.3);
    for lift in [0.004, 0.008] {
        let (force, indentation) = press(lift);
        // Hertz's δ is the approach of points at infinite depth; the block's base at depth
        // H = 1 is held, and in a half-space it would have moved by Boussinesq's
        // u_z(0, H) = P(1 + ν)(3 − 2ν)/(2πE·H) towards the sphere's far side. Add it back.
        let base_motion = force * (1.0 + nu) * (3.0 - 2.0 * nu) / (2.0 * std::f64::consts::PI * e);
        let approach = indentation + base_motion;
        let hertz = 4.0 / 3.0 * e_star * RADIUS.sqrt() * approach.powf(1.5);
        println!(
            "lift {lift}: δ = {indentation:.4e} m (+ {base_motion:.3e} m at the base), P = {force:.4e} N, Hertz {hertz:.4e} N, ratio {:.4}",
            force / hertz
        );
        // Mesh-dependent: the contact radius √(Rδ) ≈ 0.2–0.3 spans only 2.4–3.4 elements
        // (h = 1/12) and the pressure acts at nodes; the block's free sides and the point
        // correction for the held base add a few per cent. 15 % covers these.
        assert!(
            (force / hertz - 1.0).abs() < 0.15,
            "lift {lift}: ratio {}",
            force / hertz
        );
    }
}
