//! Issue 35, item 1: moving obstacles at large time steps without staging. A sphere driven
//! into a soft block failed at every step size with "the moving obstacles did not reach their
//! placement … in 100 stages" (1,300 Newton iterations in one step); pressed on a block resting
//! on the ground at 0.75× the critical step it passed with 528 iterations per step on average.
//! The step now starts from the body carried with the obstacle ([`Contact::carried_start`]) and
//! the contact line search tries the whole Newton step where no obstacle is in its way.

use nalgebra::Vector3;
use tetfem::analysis::Definition;
use tetfem::analysis::dynamics::Method;
use tetfem::analysis::transient::{Flow, StepView, TimeStep, Transient, TransientOptions};
use tetfem::contact::{Contact, ContactParameters, Obstacle, ObstacleMotion};
use tetfem::fe::materials::MaterialMap;
use tetfem::model::ModelKind;
use tetfem::{BoxSplit, Material, TetMesh};

/// A 10 cm soft block (E = 100 kPa, ν = 0.3, ρ = 1000 kg/m³, 4³ cells) and a sphere of
/// radius 3 cm 1 mm above its top moving down at `speed` m/s; `ground`: the block rests on a
/// half-space 0.1 mm below it, under gravity.
fn press(model: ModelKind, speed: f64, ground: bool) -> Definition {
    let mesh = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(0.1, 0.1, 0.1),
        [4, 4, 4],
        BoxSplit::Mirrored6,
    )
    .unwrap();
    let materials =
        MaterialMap::uniform(Material::new(1e5, 0.3, 1000.0).unwrap(), mesh.tet_count());
    let sphere = Obstacle::sphere("ball", Vector3::new(0.05, 0.05, 0.131), 0.03)
        .unwrap()
        .with_motion(ObstacleMotion::Velocity(Vector3::new(0.0, 0.0, -speed)))
        .unwrap();
    let mut obstacles = vec![sphere];
    if ground {
        let ground = Obstacle::half_space("ground", Vector3::new(0.0, 0.0, -1e-4), Vector3::z());
        obstacles.push(ground.unwrap());
    }
    let parameters = ContactParameters::for_mesh(&mesh, 1e5).unwrap();
    let contact = Contact::new(&mesh, obstacles, parameters).unwrap();
    let builder = Definition::builder(mesh, materials)
        .model(model)
        .contact(contact);
    match ground {
        true => builder.gravity(Vector3::new(0.0, 0.0, -9.81)).unwrap(),
        false => builder,
    }
    .build()
    .unwrap()
}

/// What a run of [`press`] did: Newton iterations per step (mean, most), and Σ dt·F_z of the
/// sphere's force on the body over the steps (N·s).
struct Pressed {
    mean: f64,
    most: usize,
    impulse: f64,
    run: Transient,
}

/// Runs [`press`] with backward Euler at `multiple` × the explicit critical step until the
/// sphere has travelled `travel` m, checking after every step that no boundary node is inside
/// an obstacle.
fn run_press(model: ModelKind, speed: f64, ground: bool, multiple: f64, travel: f64) -> Pressed {
    let definition = press(model, speed, ground);
    let options =
        TransientOptions::new(Method::BackwardEuler, TimeStep::CriticalMultiple(multiple));
    let mut run = Transient::new(&definition, options).unwrap();
    let steps = (travel / speed / run.dt()).ceil() as usize;
    let contact = definition.contact.clone().unwrap();
    let mut impulse = 0.0;
    let dt = run.dt();
    let mut watch = |view: &StepView<'_>| {
        let u = &view.state.displacement;
        // The obstacles are at this step's end: where the step's solution was found.
        contact.set_time(view.state.time);
        if let Some(inside) = contact.nodes_inside(u)? {
            panic!("{model:?} {multiple}x step {}: {inside}", view.step);
        }
        impulse -= dt * contact.obstacle_forces(u)?[0].z;
        Ok(Flow::Continue)
    };
    run.run((0, steps), &mut watch)
        .unwrap_or_else(|e| panic!("{model:?} {multiple}x ground {ground}: {e}"));
    let stats = run.integrator().newton_stats().unwrap();
    println!(
        "{model:?} {multiple}x ground {ground}: {} steps, {:.2} Newton iterations per step, most {}",
        stats.steps,
        stats.total_iterations as f64 / stats.steps as f64,
        stats.max_per_step
    );
    Pressed {
        mean: stats.total_iterations as f64 / stats.steps as f64,
        most: stats.max_per_step,
        impulse,
        run,
    }
}

#[test]
fn a_sphere_driven_into_a_free_block_pushes_it_at_every_step_size() {
    for model in [
        ModelKind::Linear,
        ModelKind::Corotational,
        ModelKind::NeoHookean,
    ] {
        // The 0.75×, 1.5× and 7.5× the explicit critical step and its target 10×.
        for multiple in [0.75, 1.5, 7.5, 10.0] {
            let pressed = run_press(model, 0.5, false, multiple, 0.02);
            // The target: ≤ 8 Newton iterations per step on average, never above 40.
            assert!(
                pressed.mean <= 8.0 && pressed.most <= 40,
                "{model:?} {multiple}x: mean {} most {}",
                pressed.mean,
                pressed.most
            );
            // Momentum balance of backward Euler: with no other force on the free block,
            // Σᵢ(M·v)_z = Σ_steps dt·F_z of the sphere's force on it (an identity of the step
            // equation at its solution; Newton's tolerance 1e-8 of the step's forces leaves
            // ~1e-8 relative per step, so 1e-6 relative over ≤ 30 steps).
            let state = pressed.run.state();
            let mut momentum = vec![0.0; state.velocity.len()];
            pressed
                .run
                .system()
                .mass()
                .mul_vec(&state.velocity, &mut momentum)
                .unwrap();
            let p_z: f64 = momentum.iter().skip(2).step_by(3).sum();
            assert!(
                pressed.impulse < 0.0,
                "{model:?} {multiple}x: the sphere pushes down"
            );
            assert!(
                (p_z - pressed.impulse).abs() <= 1e-6 * pressed.impulse.abs(),
                "{model:?} {multiple}x: momentum {p_z:e} vs impulse {:e}",
                pressed.impulse
            );
        }
    }
}

#[test]
fn a_sphere_pressed_on_a_block_on_the_ground_takes_few_newton_iterations() {
    for model in [
        ModelKind::Linear,
        ModelKind::Corotational,
        ModelKind::NeoHookean,
    ] {
        // 1 cm of the sphere's travel into the block (10 % of its height).
        for multiple in [0.75, 1.5, 7.5, 10.0] {
            let pressed = run_press(model, 0.05, true, multiple, 0.01);
            assert!(
                pressed.mean <= 8.0 && pressed.most <= 40,
                "{model:?} {multiple}x: mean {} most {}",
                pressed.mean,
                pressed.most
            );
            // The block is held between sphere and ground: it ends at rest to within the
            // sphere's speed.
            let fastest = pressed
                .run
                .state()
                .velocity
                .iter()
                .fold(0.0f64, |m, v| m.max(v.abs()));
            assert!(
                fastest < 0.1,
                "{model:?} {multiple}x: a node at {fastest} m/s"
            );
        }
    }
}
