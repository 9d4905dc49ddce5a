//! Issue 35, item 3: Newton's convergence test holds at zero load. A body at rest with no load
//! has a step residual at round-off (the corotational force's polar decompositions of F = I
//! leave ~1e-14 of E·h²), which a test relative to that residual alone can never pass: it
//! failed with "Newton did not converge in 25 iterations (residual 7.357e-14 of 7.357e-14)".

use nalgebra::Vector3;
use tetfem::analysis::Definition;
use tetfem::analysis::dynamics::Method;
use tetfem::analysis::transient::{TimeStep, Transient, TransientOptions, Unobserved};
use tetfem::contact::{Contact, ContactParameters, Obstacle, ObstacleMotion};
use tetfem::fe::materials::MaterialMap;
use tetfem::model::ModelKind;
use tetfem::{BoxSplit, Material, TetMesh};

/// A free 10 cm soft block (E = 100 kPa) at rest, no load, and a sphere of radius 3 cm moving
/// toward its top at `speed` m/s from 1 cm above it (`speed` NaN: no sphere, no contact).
fn block_and_sphere(model: ModelKind, speed: f64) -> Definition {
    // Placed off the origin, so that the edge vectors (differences of the nodes' coordinates)
    // carry round-off and F = I only to it.
    let origin = Vector3::new(0.0123, 0.0456, 0.0789);
    let mesh = TetMesh::box_grid(
        origin,
        origin + Vector3::new(0.1, 0.1, 0.1),
        [3, 3, 3],
        BoxSplit::Mirrored6,
    )
    .unwrap();
    let materials =
        MaterialMap::uniform(Material::new(1e5, 0.3, 1000.0).unwrap(), mesh.tet_count());
    let sphere = Obstacle::sphere("ball", origin + Vector3::new(0.05, 0.05, 0.14), 0.03)
        .unwrap()
        .with_motion(ObstacleMotion::Velocity(Vector3::new(
            0.0,
            0.0,
            -speed.max(0.0),
        )))
        .unwrap();
    let parameters = ContactParameters::for_mesh(&mesh, 1e5).unwrap();
    let contact = Contact::new(&mesh, vec![sphere], parameters).unwrap();
    let builder = Definition::builder(mesh, materials).model(model);
    match speed.is_nan() {
        true => builder.build().unwrap(),
        false => builder.contact(contact).build().unwrap(),
    }
}

/// The largest displacement magnitude of any DOF (m).
fn largest(u: &[f64]) -> f64 {
    u.iter().fold(0.0f64, |m, u| m.max(u.abs()))
}

#[test]
fn a_body_at_rest_with_no_load_converges_while_an_obstacle_approaches() {
    for model in [
        ModelKind::Linear,
        ModelKind::Corotational,
        ModelKind::NeoHookean,
    ] {
        let definition = block_and_sphere(model, 0.05);
        let options = TransientOptions::new(Method::BackwardEuler, TimeStep::Seconds(0.01));
        let mut run = Transient::new(&definition, options).unwrap();
        // 10 steps of 0.01 s: the sphere comes 5 mm nearer, still 5 mm away (beyond the
        // barrier's reach d̂ = 1.7e-4 m): nothing acts on the block, which stays at rest.
        run.run((0, 10), &mut Unobserved)
            .unwrap_or_else(|e| panic!("{model:?}: {e}"));
        let moved = largest(&run.state().displacement);
        // Round-off only: the block's forces are ~1e-14 N of noise on 1e-3 kg nodes.
        assert!(moved < 1e-12, "{model:?}: moved {moved:e} m");
    }
}

#[test]
fn a_clamped_body_at_rest_with_no_load_converges_without_contact() {
    // The same block clamped at its base, nothing acting on it: the step residual is the
    // forces' round-off, which the guess and the round-off floor must accept.
    for model in [ModelKind::Corotational, ModelKind::NeoHookean] {
        for method in [Method::BackwardEuler, Method::Newmark] {
            let mut definition = block_and_sphere(model, f64::NAN);
            let base = definition
                .mesh
                .nodes_on_plane(2, definition.mesh.bounding_box().0.z, 1e-9);
            definition.constraints.fix_nodes(&base).unwrap();
            let options = TransientOptions::new(method, TimeStep::Seconds(0.01));
            let mut run = Transient::new(&definition, options).unwrap();
            run.run((0, 5), &mut Unobserved)
                .unwrap_or_else(|e| panic!("{model:?} {method:?}: {e}"));
            let moved = largest(&run.state().displacement);
            assert!(moved < 1e-12, "{model:?} {method:?}: moved {moved:e} m");
        }
    }
}

#[test]
fn a_static_solve_with_no_load_is_the_rest_state() {
    for model in [ModelKind::Corotational, ModelKind::NeoHookean] {
        let mut definition = block_and_sphere(model, f64::NAN);
        let base = definition
            .mesh
            .nodes_on_plane(2, definition.mesh.bounding_box().0.z, 1e-9);
        definition.constraints.fix_nodes(&base).unwrap();
        let analysis = tetfem::analysis::Static::new(&definition, Default::default()).unwrap();
        let outcome = analysis
            .solve()
            .unwrap_or_else(|e| panic!("{model:?}: {e}"));
        let moved = largest(&outcome.displacement);
        // Round-off only (see above).
        assert!(moved < 1e-12, "{model:?}: moved {moved:e} m");
    }
}
