//! `tetfem::analysis::Transient` (issue 34, item 1): a definition steps with the bits of the
//! system and integrator it replaces, its one time loop stops where an observer says and
//! continues as one run, a step given as a multiple of the critical step is that multiple of
//! the library's one policy, a failed step reaches the observer before the run returns, and a
//! body held by obstacles alone is well posed in time.

use std::sync::Arc;

use nalgebra::Vector3;
use tetfem::analysis::Definition;
use tetfem::analysis::dynamics::{
    IntegratorOptions, InternalForce, LinearSystem, MassKind, Method, Rayleigh, State,
    element_step_bound_of, element_step_bound_of_type,
};
use tetfem::analysis::transient::{
    Flow, Observer, RunEnd, StepView, TimeStep, Transient, TransientOptions, Unobserved,
    critical_step,
};
use tetfem::contact::{Contact, ContactParameters, Obstacle};
use tetfem::fe::element::Tet10;
use tetfem::fe::materials::MaterialMap;
use tetfem::model::ModelKind;
use tetfem::{BoxSplit, Constraints, Error, Loads, Material, TetMesh};

const LENGTH: f64 = 0.4;

/// A rubber bar 0.4 × 0.1 × 0.1 m (E = 1 MPa, ρ = 1000 kg/m³), with `clamped` its end x = 0
/// fixed, a 0.5 N tip load along −z and gravity; without, free in space.
fn bar(clamped: bool) -> (TetMesh, MaterialMap, Constraints, Loads) {
    let mesh = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(LENGTH, 0.1, 0.1),
        [4, 1, 1],
        BoxSplit::Mirrored6,
    )
    .unwrap();
    let materials =
        MaterialMap::uniform(Material::new(1e6, 0.3, 1000.0).unwrap(), mesh.tet_count());
    let mut constraints = Constraints::new(&mesh);
    if clamped {
        constraints
            .fix_nodes(&mesh.nodes_on_plane(0, 0.0, 1e-9))
            .unwrap();
    }
    let tip = mesh.nodes_on_plane(0, LENGTH, 1e-9);
    let mut loads = Loads::new(&mesh);
    for &n in &tip {
        let share = Vector3::new(0.0, 0.0, -0.5 / tip.len() as f64);
        loads.add_nodal_force(n, share).unwrap();
    }
    (mesh, materials, constraints, loads)
}

const GRAVITY: Vector3<f64> = Vector3::new(0.0, 0.0, -9.81);

fn definition(model: ModelKind) -> Definition {
    let (mesh, materials, constraints, loads) = bar(true);
    Definition::builder(mesh, materials)
        .model(model)
        .constraints(constraints)
        .unwrap()
        .loads(loads)
        .unwrap()
        .gravity(GRAVITY)
        .unwrap()
        .build()
        .unwrap()
}

/// `steps` steps of the system and integrator a front end built by hand before `Transient`.
fn by_hand(model: ModelKind, method: Method, dt: f64, steps: usize) -> State {
    let (mesh, materials, constraints, loads) = bar(true);
    let system = LinearSystem::new(
        &mesh,
        &materials,
        &constraints,
        &loads,
        GRAVITY,
        MassKind::Lumped,
        Rayleigh::default(),
    )
    .unwrap();
    let force = InternalForce::of_kind(model, &mesh, &materials, &system).unwrap();
    let free = system.free_count();
    let system = Arc::new(system);
    let mut integrator = method
        .integrator_with_force(system, force, dt, IntegratorOptions::default())
        .unwrap();
    let mut state = State::at_rest(free);
    for _ in 0..steps {
        integrator.step(&mut state).unwrap();
    }
    state
}

#[test]
fn a_definition_steps_with_the_bits_of_the_hand_built_system() {
    // Exact: the same assembly, force law and integrator, so the same floating-point sums.
    for (model, method) in [
        (ModelKind::Linear, Method::BackwardEuler),
        (ModelKind::Linear, Method::Newmark),
        (ModelKind::Linear, Method::Explicit),
        (ModelKind::Corotational, Method::BackwardEuler),
        (ModelKind::NeoHookean, Method::Newmark),
    ] {
        let dt = if method == Method::Explicit {
            1e-5
        } else {
            2e-4
        };
        let options = TransientOptions::new(method, TimeStep::Seconds(dt));
        let mut run = Transient::new(&definition(model), options).unwrap();
        assert_eq!(run.run((0, 12), &mut Unobserved).unwrap(), RunEnd::Finished);
        let expected = by_hand(model, method, dt, 12);
        assert_eq!(run.state(), &expected, "{model:?} {method:?}");
        assert_eq!(run.force().name(), model.name());
    }
}

/// Records the steps it sees and stops after `stop_after`.
struct Watch {
    seen: Vec<(usize, usize)>,
    stop_after: usize,
}

impl Observer for Watch {
    fn observe(&mut self, view: &StepView<'_>) -> tetfem::Result<Flow> {
        assert_eq!(
            view.state.steps, view.step,
            "the view's state is the step's"
        );
        assert!(view.wall >= 0.0);
        self.seen.push((view.step, view.last));
        Ok(match view.step == self.stop_after {
            true => Flow::Stop,
            false => Flow::Continue,
        })
    }
}

#[test]
fn an_observer_stops_the_loop_and_the_rest_continues_as_one_run() {
    let options = TransientOptions::new(Method::Newmark, TimeStep::Seconds(2e-4));
    let d = definition(ModelKind::Corotational);
    let mut whole = Transient::new(&d, options.clone()).unwrap();
    whole.run((0, 10), &mut Unobserved).unwrap();
    let mut parts = Transient::new(&d, options).unwrap();
    let mut watch = Watch {
        seen: Vec::new(),
        stop_after: 4,
    };
    assert_eq!(
        parts.run((0, 10), &mut watch).unwrap(),
        RunEnd::Stopped { step: 4 }
    );
    assert_eq!(parts.state().steps, 4);
    assert_eq!(parts.run((4, 10), &mut watch).unwrap(), RunEnd::Finished);
    let steps: Vec<usize> = watch.seen.iter().map(|s| s.0).collect();
    assert_eq!(steps, (1..=10).collect::<Vec<_>>());
    assert!(watch.seen.iter().all(|s| s.1 == 10));
    // Exact: a stop at a step boundary changes no arithmetic.
    assert_eq!(parts.state(), whole.state());
}

#[test]
fn a_step_in_critical_multiples_is_that_multiple_of_the_one_policy() {
    let d = definition(ModelKind::Linear);
    // Lumped mass: the Lanczos iteration's step, proven by the inertia check on this small mesh.
    let run = Transient::new(
        &d,
        TransientOptions::new(Method::Explicit, TimeStep::CriticalMultiple(0.5)),
    )
    .unwrap();
    let limit = critical_step(run.system(), &d.mesh, &d.materials).unwrap();
    assert_eq!(limit.source, "Lanczos iteration");
    assert_eq!(run.dt(), 0.5 * limit.dt);
    assert_eq!(run.step_limit(), Some(limit));
    // Consistent mass: the element bound, of each element type its own.
    let mut options = TransientOptions::new(Method::Newmark, TimeStep::CriticalMultiple(3.0));
    options.mass = MassKind::Consistent;
    let run = Transient::new(&d, options.clone()).unwrap();
    let bound = element_step_bound_of(&d.mesh, &d.materials).unwrap();
    assert_eq!(run.step_limit().unwrap().source, "element bound");
    assert_eq!(run.dt(), 3.0 * bound.dt_element);
    let quadratic = TetMesh::<Tet10>::from_linear(&d.mesh).unwrap();
    let mut clamped = Constraints::new(&quadratic);
    clamped
        .fix_nodes(&quadratic.nodes_on_plane(0, 0.0, 1e-9))
        .unwrap();
    let d10 = Definition::builder(quadratic, d.materials.clone())
        .constraints(clamped)
        .unwrap()
        .build()
        .unwrap();
    // (Newmark: the explicit method refuses a consistent mass.)
    let run = Transient::new(&d10, options).unwrap();
    let bound10 = element_step_bound_of_type(&d10.mesh, &d10.materials).unwrap();
    assert_eq!(run.dt(), 3.0 * bound10.dt_element);
}

/// Counts the failed steps it is told of.
#[derive(Default)]
struct Failures {
    told: usize,
}

impl Observer for Failures {
    fn observe(&mut self, _view: &StepView<'_>) -> tetfem::Result<Flow> {
        Ok(Flow::Continue)
    }

    fn step_failed(&mut self, error: &Error) -> tetfem::Result<()> {
        assert!(matches!(error, Error::Diverged { .. }), "{error}");
        self.told += 1;
        Ok(())
    }
}

#[test]
fn a_failed_step_reaches_the_observer_before_the_run_returns_it() {
    // The explicit method at 3 × its critical step: the highest mode grows by a factor of
    // about 8 per step, so the divergence guard fires within a few dozen steps.
    let options = TransientOptions::new(Method::Explicit, TimeStep::CriticalMultiple(3.0));
    let mut run = Transient::new(&definition(ModelKind::Linear), options).unwrap();
    let mut failures = Failures::default();
    let error = run.run((0, 10_000), &mut failures).unwrap_err();
    assert!(matches!(error, Error::Diverged { .. }), "{error}");
    assert_eq!(failures.told, 1);
    assert!(run.state().steps < 10_000);
}

#[test]
fn a_body_held_by_an_obstacle_alone_is_well_posed_in_time() {
    let (mesh, materials, constraints, _) = bar(false);
    let ground =
        Obstacle::half_space("ground", Vector3::new(0.0, 0.0, -1e-3), Vector3::z()).unwrap();
    let parameters = ContactParameters::for_mesh(&mesh, 1e6).unwrap();
    let contact = Contact::new(&mesh, vec![ground], parameters).unwrap();
    let builder = Definition::builder(mesh, materials)
        .constraints(constraints)
        .unwrap()
        .gravity(GRAVITY)
        .unwrap();
    // Without the obstacle the unconstrained body has six rigid modes: the system's error.
    let alone = builder.clone().build().unwrap();
    let options = TransientOptions::new(Method::BackwardEuler, TimeStep::Seconds(1e-3));
    assert!(Transient::new(&alone, options.clone()).is_err());
    let held = builder.contact(contact).build().unwrap();
    let mut run = Transient::new(&held, options).unwrap();
    // The linear model steps through Newton with the barrier.
    assert!(run.force().contact().is_some());
    run.run((0, 30), &mut Unobserved).unwrap();
    // Falling 1 mm under gravity takes √(2·1e-3/9.81) = 14 ms: by 30 ms the ground holds the
    // body, which has not passed through it (the barrier keeps every gap > 0).
    let u = run
        .system()
        .expand_at(run.state().time, &run.state().displacement)
        .unwrap();
    let lowest = (0..u.len() / 3)
        .map(|n| u[3 * n + 2])
        .fold(f64::INFINITY, f64::min);
    assert!(
        lowest > -1e-3,
        "lowest node moved {lowest} m, the ground is at -1e-3 m"
    );
    assert!(lowest < -0.5e-3, "the body fell ({lowest} m)");
}
