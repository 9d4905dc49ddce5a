//! The dynamic barrier's reach (issue 35): how far the barrier's contact force is from the
//! exact contact of the mesh as a function of its gap error, measured on the static lens of
//! `contact_exact` without the static continuation — the relation behind
//! `tetfem::contact::GAP_ERROR_WARNING`.

use nalgebra::Vector3;
use tetfem::analysis::nonlinear::{NewtonOptions, solve_nonlinear_static_with_contact};
use tetfem::contact::{Contact, ContactParameters, Obstacle};
use tetfem::model::ModelKind;

use super::contact_exact::{RADIUS, START_GAP, exact, lens, material, pressed_top};

/// The barrier's force on the lens pressed by `approach` under d̂ = `d_hat` with no
/// continuation (a gap tolerance it meets at once): (force on the body along +z, gap error).
fn barrier_at(mesh: &tetfem::TetMesh, approach: f64, d_hat: f64) -> (f64, f64) {
    let defaults = ContactParameters::for_mesh(mesh, material().youngs_modulus()).unwrap();
    let parameters = ContactParameters {
        activation_distance: d_hat,
        ..defaults
    };
    let plane =
        Obstacle::half_space("plane", Vector3::new(0.0, 0.0, -START_GAP), Vector3::z()).unwrap();
    let contact = Contact::new(mesh, vec![plane], parameters)
        .unwrap()
        .with_gap_tolerance(0.5)
        .unwrap();
    let report = solve_nonlinear_static_with_contact(
        mesh,
        ModelKind::Linear.build(&material()).as_ref(),
        &pressed_top(mesh, approach),
        &tetfem::Loads::new(mesh),
        &contact,
        NewtonOptions {
            load_steps: 1,
            ..NewtonOptions::default()
        },
    )
    .unwrap();
    let force = -contact.obstacle_forces(&report.displacement).unwrap()[0].z;
    (force, report.gap_error.unwrap())
}

#[test]
#[ignore]
fn measure_force_error_against_gap_error() {
    let mesh = lens();
    let default = ContactParameters::for_mesh(&mesh, material().youngs_modulus())
        .unwrap()
        .activation_distance;
    for fraction in [0.002, 0.005, 0.01] {
        let approach = fraction * RADIUS + START_GAP;
        let (exact_force, _) = exact(&mesh, approach);
        for factor in [1.0, 0.5, 0.25, 0.1] {
            let (force, gap_error) = barrier_at(&mesh, approach, factor * default);
            let error = force / exact_force - 1.0;
            println!(
                "dR {fraction} dhat {:.3e} gap_error {gap_error:.3e} force_error {error:+.3e} ratio {:.2}",
                factor * default,
                error / gap_error
            );
        }
    }
}
