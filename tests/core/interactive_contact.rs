//! Issue 39, target 2, on a small block: a Neo-Hookean cube dropped onto frictional ground and
//! thrown sideways (the scene of `benches/interactive_contact.rs`, 4³ cells instead of 14³),
//! backward Euler at dt = 10 ms. No node goes through the ground at any step, and the inexact
//! Newton path (in contact: J factored at a run's first iterate in contact, then modified
//! Newton on that factor while the residual halves, then CG preconditioned by it; in flight CG
//! on the rest factor) follows the refactoring Newton's trajectory.

use nalgebra::Vector3;
use tetfem::analysis::Definition;
use tetfem::analysis::dynamics::{Method, NewtonStats, NonlinearSolve, State};
use tetfem::analysis::transient::{Flow, StepView, TimeStep, Transient, TransientOptions};
use tetfem::contact::{Contact, ContactParameters, Obstacle};
use tetfem::fe::materials::MaterialMap;
use tetfem::model::ModelKind;
use tetfem::{BoxSplit, Material, TetMesh};

/// A 20 cm rubber cube (E = 100 kPa, ν = 0.3, ρ = 1000 kg/m³, 4³ cells) 1 cm above the
/// ground (μ = 0.5), under gravity.
fn block() -> Definition {
    let mesh = TetMesh::box_grid(
        Vector3::new(0.0, 0.0, 0.01),
        Vector3::new(0.2, 0.2, 0.21),
        [4, 4, 4],
        BoxSplit::Mirrored6,
    )
    .unwrap();
    let materials =
        MaterialMap::uniform(Material::new(1e5, 0.3, 1000.0).unwrap(), mesh.tet_count());
    let ground = Obstacle::half_space("ground", Vector3::zeros(), Vector3::z())
        .unwrap()
        .with_friction(0.5)
        .unwrap();
    let parameters = ContactParameters::for_mesh(&mesh, 1e5).unwrap();
    let contact = Contact::new(&mesh, vec![ground], parameters).unwrap();
    Definition::builder(mesh, materials)
        .model(ModelKind::NeoHookean)
        .gravity(Vector3::new(0.0, 0.0, -9.81))
        .unwrap()
        .contact(contact)
        .build()
        .unwrap()
}

/// 25 steps of the block thrown at 0.3 m/s along x with `solve`: the displacements of every
/// step, the smallest gap to the ground over the steps (m), and the Newton counts.
fn slide(solve: NonlinearSolve) -> (Vec<Vec<f64>>, f64, NewtonStats) {
    let definition = block();
    let contact = definition.contact.clone().unwrap();
    let mut options = TransientOptions::new(Method::BackwardEuler, TimeStep::Seconds(0.01));
    options.solver.nonlinear_solve = solve;
    let mut run = Transient::new(&definition, options).unwrap();
    let mut state = State::at_rest(run.system().free_count());
    state.velocity = (0..state.velocity.len())
        .map(|dof| if dof % 3 == 0 { 0.3 } else { 0.0 })
        .collect();
    *run.state_mut() = state;
    let (mut path, mut smallest) = (Vec::new(), f64::INFINITY);
    let mut watch = |view: &StepView<'_>| {
        // A free body: the free DOFs are all of them.
        smallest = smallest.min(contact.smallest_gap(&view.state.displacement)?);
        path.push(view.state.displacement.clone());
        Ok(Flow::Continue)
    };
    run.run((0, 25), &mut watch).unwrap();
    let stats = run.integrator().newton_stats().unwrap();
    (path, smallest, stats)
}

#[test]
fn a_block_thrown_onto_frictional_ground_stays_above_it_on_either_newton_path() {
    let d_hat = ContactParameters::for_mesh(&block().mesh, 1e5)
        .unwrap()
        .activation_distance;
    let (exact, exact_gap, exact_stats) = slide(NonlinearSolve::Refactor);
    let (inexact, inexact_gap, stats) = slide("rest_preconditioned".parse().unwrap());
    // The rest factor knows no barrier: each run of iterations in contact factors its own J
    // once, so the inexact path factors more than the rest matrix alone, and fewer times than
    // the refactoring one, which factors at every iteration.
    assert!(
        stats.factorizations > 1 && stats.factorizations < exact_stats.factorizations,
        "{stats:?} against {exact_stats:?}"
    );
    for gap in [exact_gap, inexact_gap] {
        // The barrier and the CCD line search keep every node strictly above the ground.
        assert!(gap > 0.0, "a node reached the ground: gap {gap:e} m");
        // It landed: the 1 cm fall takes 45 ms, and the block rests within d̂ after it.
        assert!(
            gap < d_hat,
            "the block never touched: gap {gap:e} m, d̂ {d_hat:e} m"
        );
    }
    let scale = exact.iter().flatten().fold(0.0f64, |m, u| m.max(u.abs()));
    let distance = exact
        .iter()
        .flatten()
        .zip(inexact.iter().flatten())
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    println!(
        "largest displacement {scale:e} m, distance {distance:e} m, gaps {exact_gap:e} \
         {inexact_gap:e} m, {stats:?} against {exact_stats:?}"
    );
    // Both paths stop each step at the same test, ‖r‖ ≤ 1e-8 of the step's reference force,
    // so each step's solutions differ by up to about 1e-8 of the step's motion (measured
    // 1.9e-10 of the largest displacement over the 25 steps: 4.7e-12 m of 2.45e-2 m; 36
    // factorizations against the refactoring path's 187).
    assert!(
        distance <= 1e-8 * scale,
        "the inexact path left the refactoring one by {distance:e} m of {scale:e} m"
    );
}
