//! Coulomb friction in the static Newton solve (issue 18, item 1): a block resting on the
//! ground under gravity with a lateral body load F holds for F < μ·N, with the ground's friction
//! force equal to F and at most μ·N, and the solve is an error naming the load step for F > μ·N.

use nalgebra::Vector3;
use tetfem::analysis::nonlinear::{
    NewtonOptions, NewtonReport, solve_nonlinear_static_with_contact,
};
use tetfem::contact::{Contact, ContactParameters, Obstacle};
use tetfem::model::ModelKind;
use tetfem::{BoxSplit, Constraints, Error, Loads, Material, TetMesh};

const SIDE: f64 = 0.1;
const G: f64 = 9.81;
const MU: f64 = 0.5;

/// A 0.1 m rubber cube (E = 100 kPa, ρ = 1000 kg/m³, 3×3×3 cells) with no support at all, its
/// bottom z = 0 half an activation distance above a frictional ground (so the barrier and the
/// friction act from the first load step), under gravity tilted to give a lateral body load
/// `lateral`·m·g along x. Returns the solve, the contact, the mesh and the weight W = m·g (N).
fn block_on_ground(
    lateral: f64,
) -> (
    tetfem::base::error::Result<NewtonReport>,
    Contact,
    TetMesh,
    f64,
) {
    let mesh = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::repeat(SIDE),
        [3, 3, 3],
        BoxSplit::Lecture6,
    )
    .unwrap();
    let rubber = Material::new(1e5, 0.3, 1000.0).unwrap();
    let parameters = ContactParameters::for_mesh(&mesh, rubber.youngs_modulus()).unwrap();
    let ground = Obstacle::half_space(
        "ground",
        Vector3::new(0.0, 0.0, -0.5 * parameters.activation_distance),
        Vector3::z(),
    )
    .unwrap()
    .with_friction(MU)
    .unwrap();
    let contact = Contact::new(&mesh, vec![ground], parameters).unwrap();
    let mut loads = Loads::new(&mesh);
    loads
        .add_gravity(&mesh, &rubber, G * Vector3::new(lateral, 0.0, -1.0))
        .unwrap();
    let report = solve_nonlinear_static_with_contact(
        &mesh,
        ModelKind::Corotational.build(&rubber).as_ref(),
        &Constraints::new(&mesh),
        &loads,
        &contact,
        NewtonOptions::default(),
    );
    let weight = rubber.density() * SIDE.powi(3) * G;
    (report, contact, mesh, weight)
}

#[test]
fn a_lateral_load_below_mu_n_is_held_by_friction() {
    // F = 0.3·W and 0.45·W, both below μ·N = 0.5·W (N = W: nothing else holds the block).
    for lateral in [0.3, 0.45] {
        held(lateral);
    }
}

fn held(lateral: f64) {
    let (report, contact, mesh, weight) = block_on_ground(lateral);
    let report = report.unwrap();
    let u = &report.displacement;
    let normal = report
        .solved_contact(&contact)
        .unwrap()
        .obstacle_forces(u)
        .unwrap()[0];
    let friction = report.obstacle_friction_forces[0];
    let total = normal + friction;
    // Σ over the nodes of each axis' equations: the element forces sum to zero exactly (up to
    // round-off), no DOF is fixed, so |F_obstacle − F_load| ≤ Σ|r_i| ≤ √n·‖r‖ with the residual
    // Newton stopped at (under the last friction lag, which the friction force above uses).
    let last = *report.residuals.last().unwrap().last().unwrap();
    let bound = (u.len() as f64).sqrt() * last + 1e-12 * weight;
    let load = Vector3::new(lateral * weight, 0.0, -weight);
    println!(
        "force on the ground {total:?} N against the load {load:?} N (bound {bound:.2e}), normal {:.6} N, friction {:.6} N, μ·N = {:.6} N",
        normal.z,
        friction.x,
        MU * normal.z.abs()
    );
    assert!((total - load).abs().max() <= bound, "{total:?} vs {load:?}");
    // The barrier pushes along the ground's normal only, friction along the ground only.
    assert!(normal.xy().norm() <= 1e-12 * weight && friction.z.abs() <= 1e-12 * weight);
    // Each node's friction is μ·λᵢ·f₁(y) ≤ μ·λᵢ, and Σλᵢ under the last lag is the barrier's
    // normal force at the solution (the lag is taken there): |F_t| ≤ μ·|F_n| up to round-off.
    assert!(friction.xy().norm() <= MU * normal.z.abs() * (1.0 + 1e-12));

    // Held, and sheared by the load: the top moves along it, further than the base.
    let top = (0..mesh.node_count())
        .filter(|&n| mesh.nodes()[n].z == SIDE)
        .map(|n| u[3 * n])
        .fold(0.0f64, f64::max);
    let creep = (0..mesh.node_count())
        .filter(|&n| mesh.nodes()[n].z == 0.0)
        .map(|n| Vector3::new(u[3 * n], u[3 * n + 1], 0.0).norm())
        .fold(0.0f64, f64::max);
    assert!(top > creep);
    if lateral > 0.3 {
        // Near the limit the edges slip beyond ε_d (partial slip): no creep bound there.
        println!("F = {lateral}·W: largest slip of a bottom node {creep:.3e} m, top {top:.3e} m");
        return;
    }
    // Stick: a node whose slip over a load step stays below ε_d sticks, so the bottom nodes
    // (the only ones in contact) move along the ground by less than load_steps·ε_d in all (the
    // block's elastic shear is above them: it moves the top, not the contact nodes).
    let steps = NewtonOptions::default().load_steps as f64;
    let creep_bound = steps * contact.slip_distance();
    println!(
        "largest slip of a bottom node {creep:.3e} m (bound {creep_bound:.3e} m, ε_d {:.3e} m); top moves {top:.3e} m",
        contact.slip_distance()
    );
    assert!(creep < creep_bound, "{creep:e} vs {creep_bound:e}");
}

#[test]
fn a_lateral_load_above_mu_n_is_an_error_naming_the_load_step() {
    let (report, _, _, _) = block_on_ground(0.55); // F = 0.55·W > μ·N = 0.5·W
    match report {
        Err(Error::Solver(message)) => {
            println!("{message}");
            assert!(message.contains("no static equilibrium with friction at load step"));
            assert!(message.contains("μ·Σλ"));
        }
        other => panic!("expected an error naming the load step, got {other:?}"),
    }
}
