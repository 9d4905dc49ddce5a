//! The dynamic barrier's reach (issue 35): how far the barrier's contact force is from the
//! exact contact of the mesh as a function of its gap error, measured on the static lens of
//! `contact_exact` without the static continuation — the relation behind
//! `tetfem::contact::GAP_ERROR_WARNING` — and what a dynamic run records of it: the gap error
//! of each accepted step, the smallest gap of every accepted Newton iterate.

use nalgebra::Vector3;
use tetfem::analysis::Definition;
use tetfem::analysis::dynamics::{Method, critical_time_step};
use tetfem::analysis::nonlinear::{NewtonOptions, solve_nonlinear_static_with_contact};
use tetfem::analysis::transient::{Flow, StepView, TimeStep, Transient, TransientOptions};
use tetfem::contact::{Contact, ContactParameters, FORCE_ERROR_PER_GAP_ERROR, Obstacle};
use tetfem::fe::materials::MaterialMap;
use tetfem::model::ModelKind;
use tetfem::{BoxSplit, Constraints, Material, TetMesh};

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
fn the_force_error_is_a_bounded_multiple_of_the_gap_error() {
    // Measured (force error / gap error): δ/R = 0.2 %: 2.31, 2.39, 2.97 under d̂, d̂/2, d̂/4
    // (gap errors 0.14, 0.049, 0.016); 0.5 %: 2.34, 2.83, 3.73; 1 %: 2.17, 2.49, 2.93. At d̂/10
    // the ratio reached 4.55 (0.2 %) and 5.91 (0.5 %; at 1 % Newton does not converge there
    // from the start), hence FORCE_ERROR_PER_GAP_ERROR = 6. The force is always too large (the
    // barrier pushes from a distance), and the gap error never overstates the force error.
    let mesh = lens();
    let default = ContactParameters::for_mesh(&mesh, material().youngs_modulus())
        .unwrap()
        .activation_distance;
    for fraction in [0.002, 0.005, 0.01] {
        let approach = fraction * RADIUS + START_GAP;
        let (exact_force, _) = exact(&mesh, approach);
        for factor in [1.0, 0.5, 0.25] {
            let (force, gap_error) = barrier_at(&mesh, approach, factor * default);
            let ratio = (force / exact_force - 1.0) / gap_error;
            assert!(
                (1.0..=FORCE_ERROR_PER_GAP_ERROR).contains(&ratio),
                "δ/R = {fraction}, d̂ × {factor}: force error {ratio} × the gap error {gap_error}"
            );
        }
    }
}

/// The stress suite's drop: a 10 cm soft block (E = 100 kPa) 5 mm above frictional ground,
/// under gravity.
fn drop() -> Definition {
    let mesh = TetMesh::box_grid(
        Vector3::new(0.0, 0.0, 5e-3),
        Vector3::new(0.1, 0.1, 0.105),
        [3; 3],
        BoxSplit::Five,
    )
    .unwrap();
    let soft = Material::new(1e5, 0.3, 1000.0).unwrap();
    let ground = Obstacle::half_space("ground", Vector3::zeros(), Vector3::z())
        .unwrap()
        .with_friction(0.5)
        .unwrap();
    let parameters = ContactParameters::for_mesh(&mesh, soft.youngs_modulus()).unwrap();
    let contact = Contact::new(&mesh, vec![ground], parameters).unwrap();
    let materials = MaterialMap::uniform(soft, mesh.tet_count());
    let constraints = Constraints::new(&mesh);
    Definition::builder(mesh, materials)
        .model(ModelKind::NeoHookean)
        .constraints(constraints)
        .unwrap()
        .contact(contact)
        .gravity(Vector3::new(0.0, 0.0, -9.81))
        .unwrap()
        .build()
        .unwrap()
}

#[test]
fn every_newton_iterate_of_a_drop_at_10x_the_critical_step_stays_outside() {
    // Backward Euler at 10 × the explicit critical step, 0.1 s: the block lands (5 mm fall at
    // ~0.03 s) and bounces on the barrier. The smallest gap of the accepted iterates is
    // measured by the library inside Newton; the accepted steps' smallest gap here, from
    // the states the run returns. An iterate inside an obstacle would show a gap ≤ 0.
    let definition = drop();
    let contact = definition.contact.clone().unwrap();
    let options = TransientOptions::new(Method::BackwardEuler, TimeStep::CriticalMultiple(10.0));
    let mut run = Transient::new(&definition, options).unwrap();
    let critical = critical_time_step(run.system()).unwrap().dt;
    let steps = (0.1 / (10.0 * critical)).ceil() as usize;
    let mut step_gap = f64::INFINITY;
    let mut watch = |view: &StepView<'_>| {
        let full = view
            .system
            .expand_at(view.state.time, &view.state.displacement)?;
        contact.set_time(view.state.time);
        step_gap = step_gap.min(contact.smallest_gap(&full)?);
        Ok(Flow::Continue)
    };
    run.run((0, steps), &mut watch).unwrap();
    let record = run.barrier_record().unwrap();
    let d_hat = record.parameters.activation_distance;
    // It did land: some step's gap came within the barrier's reach.
    assert!(step_gap < d_hat, "{step_gap} against d̂ = {d_hat}");
    assert_eq!(record.smallest_step_gap, step_gap);
    assert!(
        record.smallest_iterate_gap <= step_gap,
        "iterates {} against steps {step_gap}",
        record.smallest_iterate_gap
    );
    assert!(record.smallest_iterate_gap > 0.0, "{record:?}");
    assert_eq!(record.steps, steps);
    // Every step's gap error is measured: the landed block's pushed nodes sit inside d̂.
    assert!(
        record.gap_error_max > 0.0 && record.gap_error_final > 0.0,
        "{record:?}"
    );
}

/// The impact-aware stiffness's estimate stores a node's kinetic energy in the barrier at
/// exactly f·d̂ (κ·A·b(f·d̂) = ½·m·v²), gives nothing for a receding or NaN speed, and a
/// node's next κᵢ is its own, unchanged, while it is within d̂ (it may hold barrier energy
/// there), and the estimate (at least κ₀) once it is outside.
#[test]
fn impact_stiffness_stores_the_kinetic_energy_at_the_fraction() {
    use tetfem::contact::barrier;
    use tetfem::contact::impact::{next_stiffness, node_estimate};
    let (m, v, a, d_hat, f) = (2.0, 0.5, 1e-4, 1e-3, 0.25);
    let kappa = node_estimate(m, v, a, d_hat, f);
    let stored = kappa * a * barrier::value(f * d_hat, d_hat);
    // A few roundings of the same products: 1e-14 relative.
    assert!((stored - 0.5 * m * v * v).abs() <= 1e-14 * stored);
    assert_eq!(node_estimate(m, -v, a, d_hat, f), 0.0);
    assert_eq!(node_estimate(m, f64::NAN, a, d_hat, f), 0.0);
    assert_eq!(next_stiffness(1.0, 5.0, 3.0, true), 5.0);
    assert_eq!(next_stiffness(1.0, 5.0, 7.0, true), 5.0);
    assert_eq!(next_stiffness(1.0, 5.0, 3.0, false), 3.0);
    assert_eq!(next_stiffness(4.0, 5.0, 3.0, false), 4.0);
}
