//! Nonlinear force models in every integrator: the linear model through the force seam is the
//! linear integrators bit for bit; corotational backward Euler settles to the Newton static
//! answer; Newmark and the explicit method keep the energy of a nonlinear swing; the shipped
//! rubber beam scene swings past 45°.

use std::sync::Arc;

use nalgebra::Vector3;
use tetfem::TetMesh;
use tetfem::dynamics::{
    BackwardEuler, Energy, Integrator, IntegratorOptions, InternalForce, LinearSystem, MassKind,
    Method, Newmark, NewtonStats, Rayleigh, State, SymplecticEuler, critical_time_step,
};
use tetfem::loads::Loads;
use tetfem::mesh::BoxSplit;
use tetfem::model::ModelKind;
use tetfem::nonlinear::{NewtonOptions, solve_nonlinear_static};
use tetfem_fixtures::cantilever::Cantilever;

const GRAVITY: f64 = 9.81;

/// A soft rubber-like beam 0.5 × 0.05 × 0.05 m (Young's modulus `youngs` Pa, ν = 0.4,
/// ρ = 1100 kg/m³) clamped at x = 0, horizontal, under gravity (−z) only. Linear beam theory
/// puts its static tip slope at 2ρgL³/(E·h²) (1.08 rad at E = 1 MPa); these tets, two cells
/// through the height, are stiffer in bending: measured with the corotational model at
/// E = 1 MPa, 24.5° static and 49.6° at the bottom of the swing from horizontal.
struct Swing {
    problem: Cantilever,
    mesh: Arc<TetMesh>,
    system: Arc<LinearSystem>,
}

fn swing(youngs: f64, cells: [usize; 3], mass: MassKind, damping: Rayleigh) -> Swing {
    let problem = Cantilever {
        length: 0.5,
        width: 0.05,
        height: 0.05,
        cells,
        split: BoxSplit::Five,
        material: tetfem::Material::new(youngs, 0.4, 1100.0).unwrap(),
        end_load: 0.0,
        gravity: 0.0,
    };
    let mesh = problem.mesh().unwrap();
    let system = LinearSystem::new(
        &mesh,
        &problem.material,
        &problem.constraints(&mesh).unwrap(),
        &Loads::new(&mesh),
        Vector3::new(0.0, 0.0, -GRAVITY),
        mass,
        damping,
    )
    .unwrap();
    Swing {
        problem,
        mesh: Arc::new(mesh),
        system: Arc::new(system),
    }
}

impl Swing {
    fn force(&self, kind: ModelKind) -> InternalForce {
        InternalForce::of_model(
            Arc::clone(&self.mesh),
            kind.build(&self.problem.material),
            &self.system,
        )
        .unwrap()
    }

    /// The rotation (degrees) of the tip face: the angle between the reference vertical edge
    /// (bottom to top node at x = L, y = 0) and its deformed image.
    fn tip_rotation(&self, state: &State) -> f64 {
        let u = self.system.dofs().expand(&state.displacement).unwrap();
        let nodes = self.mesh.nodes();
        let tip = self.problem.tip_nodes(&self.mesh);
        let at = |z: f64| {
            *tip.iter()
                .find(|&&n| nodes[n].y.abs() < 1e-9 && (nodes[n].z - z).abs() < 1e-9)
                .unwrap()
        };
        let (bottom, top) = (at(0.0), at(self.problem.height));
        let x = |n: usize| nodes[n] + Vector3::new(u[3 * n], u[3 * n + 1], u[3 * n + 2]);
        let edge = x(top) - x(bottom);
        edge.angle(&Vector3::z()).to_degrees()
    }

    /// The mean tip displacement (x, z) of a full displacement vector.
    fn tip(&self, u: &[f64]) -> Vector3<f64> {
        let tip = self.problem.tip_nodes(&self.mesh);
        tip.iter()
            .map(|&n| Vector3::new(u[3 * n], u[3 * n + 1], u[3 * n + 2]))
            .sum::<Vector3<f64>>()
            / tip.len() as f64
    }
}

fn run(integrator: &mut dyn Integrator, state: &mut State, steps: usize) {
    for _ in 0..steps {
        integrator.step(state).unwrap();
    }
}

fn moving_state(n: usize) -> State {
    State {
        displacement: (0..n).map(|i| 1e-4 * ((i % 13) as f64 - 6.0)).collect(),
        velocity: (0..n).map(|i| 1e-3 * ((i % 7) as f64 - 3.0)).collect(),
        ..State::at_rest(n)
    }
}

/// The linear force through the seam — `InternalForce::Linear`, or the linear `ForceModel`
/// handed to `InternalForce::of_model` — runs the linear integrators' own code: the states are
/// equal bit for bit (==) to those of the constructors that existed before the seam, for every
/// method, mass kind and damping.
#[test]
fn the_linear_model_through_the_seam_is_bit_identical() {
    let dampings = [
        Rayleigh::default(),
        Rayleigh {
            alpha: 0.5,
            beta: 1e-4,
        },
    ];
    let mut compared = 0;
    for mass in [MassKind::Lumped, MassKind::Consistent] {
        for damping in dampings {
            let beam = swing(1e6, [6, 2, 2], mass, damping);
            let system = &beam.system;
            let dt = 2e-4;
            let n = system.free_count();
            let linear_model = beam.force(ModelKind::Linear);
            assert!(!linear_model.is_nonlinear());
            for method in [Method::BackwardEuler, Method::Newmark, Method::Explicit] {
                if method == Method::Explicit && mass == MassKind::Consistent {
                    continue;
                }
                let today: Box<dyn Integrator> = match method {
                    Method::BackwardEuler => {
                        Box::new(BackwardEuler::new(Arc::clone(system), dt).unwrap())
                    }
                    Method::Newmark => Box::new(Newmark::new(Arc::clone(system), dt).unwrap()),
                    Method::Explicit => {
                        Box::new(SymplecticEuler::new(Arc::clone(system), dt).unwrap())
                    }
                };
                let mut runs = vec![today];
                for force in [InternalForce::Linear, linear_model.clone()] {
                    runs.push(
                        method
                            .integrator_with_force(
                                Arc::clone(system),
                                force,
                                dt,
                                IntegratorOptions::default(),
                            )
                            .unwrap(),
                    );
                }
                let states: Vec<State> = runs
                    .iter_mut()
                    .map(|integrator| {
                        let mut state = moving_state(n);
                        run(integrator.as_mut(), &mut state, 25);
                        assert!(integrator.newton_stats().is_none());
                        state
                    })
                    .collect();
                assert_ne!(states[0], moving_state(n), "the state should move");
                assert_eq!(states[0], states[1], "{method:?} {mass:?} {damping:?}");
                assert_eq!(states[0], states[2], "{method:?} {mass:?} {damping:?}");
                assert_eq!(
                    InternalForce::Linear.energy(system, &states[0]).unwrap(),
                    system.energy(&states[0]).unwrap()
                );
                compared += 1;
            }
        }
    }
    assert_eq!(compared, 10);
}

/// Corotational backward Euler from rest, horizontal, under gravity with mass damping α = 10/s
/// (E = 0.25 MPa: a 63° static tip rotation) for 4 s at dt = 10 ms: the beam settles to the
/// static large-deflection answer of `solve_nonlinear_static`.
#[test]
fn corotational_backward_euler_settles_to_the_newton_static_answer() {
    let beam = swing(
        2.5e5,
        [10, 2, 2],
        MassKind::Lumped,
        Rayleigh {
            alpha: 10.0,
            beta: 0.0,
        },
    );
    let dt = 0.01;
    let mut integrator = Method::BackwardEuler
        .integrator_with_force(
            Arc::clone(&beam.system),
            beam.force(ModelKind::Corotational),
            dt,
            IntegratorOptions::default(),
        )
        .unwrap();
    let mut state = State::at_rest(beam.system.free_count());
    let mut largest: f64 = 0.0;
    for _ in 0..400 {
        integrator.step(&mut state).unwrap();
        largest = largest.max(beam.tip_rotation(&state));
    }
    let stats: NewtonStats = integrator.newton_stats().unwrap();
    let mut loads = Loads::new(&beam.mesh);
    loads
        .add_gravity(
            &beam.mesh,
            &beam.problem.material,
            Vector3::new(0.0, 0.0, -GRAVITY),
        )
        .unwrap();
    let statics = solve_nonlinear_static(
        &beam.mesh,
        ModelKind::Corotational
            .build(&beam.problem.material)
            .as_ref(),
        &beam.problem.constraints(&beam.mesh).unwrap(),
        &loads,
        NewtonOptions::default(),
    )
    .unwrap();
    let dynamic = beam.system.dofs().expand(&state.displacement).unwrap();
    let (tip, static_tip) = (beam.tip(&dynamic), beam.tip(&statics.displacement));
    let static_state =
        State::released_from(beam.system.dofs().restrict(&statics.displacement).unwrap());
    let difference = (tip - static_tip).norm() / static_tip.norm();
    println!(
        "settled tip {tip:?} vs static {static_tip:?}: relative {difference:.2e}; rotation {:.2}° (static {:.2}°, largest {largest:.2}°); Newton {} iterations over {} steps, at most {} in one",
        beam.tip_rotation(&state),
        beam.tip_rotation(&static_state),
        stats.total_iterations,
        stats.steps,
        stats.max_per_step
    );
    assert_eq!(stats.steps, 400);
    assert!(
        stats.max_per_step >= 2,
        "a large rotation needs Newton: {stats:?}"
    );
    // A large deflection (linear theory's 1.08 rad would be 62°).
    assert!(beam.tip_rotation(&static_state) > 45.0);
    // Measured 3.1e-9: the remaining transient (α damps the first mode, backward Euler's own
    // dissipation the rest) plus the two Newton tolerances (1e-10 static, 1e-8 per step, both
    // relative to the load). 1e-6 leaves room for other platforms' round-off and still tells
    // a settled beam from any other shape (the linear model's differs by tens of percent).
    assert!(difference < 1e-6, "{difference:e}");
}

/// Undamped Newmark (average acceleration) with the corotational model: kinetic + elastic
/// (the model's) − work of gravity over a 0.6 s swing through large rotation.
fn newmark_energy_drift(dt: f64) -> (f64, NewtonStats, f64) {
    let beam = swing(1e6, [10, 2, 2], MassKind::Lumped, Rayleigh::default());
    let force = beam.force(ModelKind::Corotational);
    let mut integrator = Method::Newmark
        .integrator_with_force(
            Arc::clone(&beam.system),
            force.clone(),
            dt,
            IntegratorOptions::default(),
        )
        .unwrap();
    let mut state = State::at_rest(beam.system.free_count());
    let start = force.energy(&beam.system, &state).unwrap();
    let (mut drift, mut scale, mut rotation): (f64, f64, f64) = (0.0, 0.0, 0.0);
    let steps = (0.6 / dt).round() as usize;
    for _ in 0..steps {
        integrator.step(&mut state).unwrap();
        let e: Energy = force.energy(&beam.system, &state).unwrap();
        drift = drift.max((e.total() - start.total()).abs());
        scale = scale.max(e.gravity_potential.abs());
        rotation = rotation.max(beam.tip_rotation(&state));
    }
    (drift / scale, integrator.newton_stats().unwrap(), rotation)
}

/// Newmark's energy balance with a nonlinear force is the trapezoidal rule on the work,
/// ΔK = ½(f(u) + f(u⁺))·(u⁺ − u), so besides the Newton tolerance it has an O(dt²) quadrature
/// error (exact only for a linear force): the drift is small, and falls about fourfold when dt
/// halves.
#[test]
fn newmark_with_a_nonlinear_model_conserves_energy() {
    let (coarse, stats, rotation) = newmark_energy_drift(4e-3);
    let (fine, fine_stats, _) = newmark_energy_drift(2e-3);
    println!(
        "Newmark corotational, largest tip rotation {rotation:.1}°: energy drift / |gravity potential| {coarse:.2e} at dt 4 ms ({} Newton its over {} steps, max {}), {fine:.2e} at 2 ms ({} its, max {}); ratio {:.2}",
        stats.total_iterations,
        stats.steps,
        stats.max_per_step,
        fine_stats.total_iterations,
        fine_stats.max_per_step,
        coarse / fine
    );
    assert!(rotation > 30.0, "a large swing: {rotation}°");
    assert!(coarse < 1e-2 && fine < 2.5e-3, "{coarse:e}, {fine:e}");
    // Second order: ×4 when dt halves; 2.5 leaves room for the Newton part and the
    // non-asymptotic start.
    assert!(coarse / fine > 2.5, "{coarse:e} vs {fine:e}");
}

/// Explicit symplectic Euler with the corotational force at half the critical step: the total
/// energy stays within 1 % of the largest energy term over a 0.4 s large swing.
#[test]
fn explicit_corotational_below_the_critical_step_conserves_energy() {
    let beam = swing(1e6, [10, 2, 2], MassKind::Lumped, Rayleigh::default());
    let dt = 0.5 * critical_time_step(&beam.system).unwrap().dt;
    let force = beam.force(ModelKind::Corotational);
    let mut integrator =
        SymplecticEuler::with_force(Arc::clone(&beam.system), force.clone(), dt).unwrap();
    let mut state = State::at_rest(beam.system.free_count());
    let start = force.energy(&beam.system, &state).unwrap().total();
    let (mut drift, mut scale, mut rotation): (f64, f64, f64) = (0.0, 0.0, 0.0);
    let steps = (0.4 / dt).round() as usize;
    for _ in 0..steps {
        integrator.step(&mut state).unwrap();
        let e = force.energy(&beam.system, &state).unwrap();
        drift = drift.max((e.total() - start).abs());
        scale = scale.max(e.gravity_potential.abs());
        rotation = rotation.max(beam.tip_rotation(&state));
    }
    println!(
        "explicit corotational at dt = {dt:.3e} (½ dt_crit), {steps} steps: largest tip rotation {rotation:.1}°, energy drift {:.3e} of |gravity potential| {scale:.3e}",
        drift / scale
    );
    assert!(rotation > 30.0, "a large swing: {rotation}°");
    assert!(drift < 0.01 * scale, "{drift:e} of {scale:e}");
}

/// The shipped scene runs through the scene API (fewer steps than its full duration) with the
/// corotational model, reports its Newton iterations, and its tip turns past 45°.
#[test]
fn rubber_beam_swing_scene_swings_past_45_degrees() {
    let path = std::path::Path::new(concat!(
        concat!(env!("CARGO_MANIFEST_DIR"), "/../.."),
        "/scenes/rubber_beam_swing.toml"
    ));
    let scene = tetfem_cli::scene::Scene::load(path).unwrap();
    assert_eq!(scene.model(), ModelKind::Corotational);
    let tetfem_cli::scene::Analysis::Dynamic(settings) = *scene.analysis() else {
        panic!("the scene is dynamic");
    };
    let steps = (0.6 / settings.dt).round() as usize;
    let summary = tetfem_cli::scene::run_dynamic_scene(
        &scene,
        &tetfem_cli::scene::DynamicOverrides {
            length: Some(tetfem_cli::scene::RunLength::Steps(steps)),
            ..Default::default()
        },
        false,
        false,
        &mut |_, _| std::ops::ControlFlow::Continue(()),
    )
    .unwrap();
    let newton = summary.newton.unwrap();
    println!(
        "scene: {} steps, Newton {} iterations (max {} per step), {:.3e} s per step",
        summary.steps, newton.total_iterations, newton.max_per_step, summary.mean_step_seconds
    );
    assert_eq!(summary.model, "corotational");
    assert_eq!(newton.steps, steps);
    // The rotation, from the same setup stepped here (the summary keeps probe ranges only).
    let setup = tetfem_cli::scene::DynamicSetup::from_scene(scene.build().unwrap(), &settings)
        .unwrap()
        .with_model(scene.model())
        .unwrap();
    let mut integrator = Method::BackwardEuler
        .integrator_with_force(
            Arc::clone(&setup.system),
            setup.force.clone(),
            settings.dt,
            IntegratorOptions::default(),
        )
        .unwrap();
    let mesh = &setup.mesh;
    let length = mesh.nodes().iter().map(|x| x.x).fold(0.0, f64::max);
    let height = mesh.nodes().iter().map(|x| x.z).fold(0.0, f64::max);
    let find = |z: f64| {
        mesh.nodes()
            .iter()
            .position(|x| (x.x - length).abs() < 1e-9 && x.y.abs() < 1e-9 && (x.z - z).abs() < 1e-9)
            .unwrap()
    };
    let (bottom, top) = (find(0.0), find(height));
    let mut state = setup.initial.clone();
    let mut largest: f64 = 0.0;
    for _ in 0..steps {
        integrator.step(&mut state).unwrap();
        let u = setup.system.dofs().expand(&state.displacement).unwrap();
        let x = |n: usize| mesh.nodes()[n] + Vector3::new(u[3 * n], u[3 * n + 1], u[3 * n + 2]);
        largest = largest.max((x(top) - x(bottom)).angle(&Vector3::z()).to_degrees());
    }
    println!("scene tip rotation: largest {largest:.1}° in {steps} steps");
    assert!(largest > 45.0, "{largest}°");
    // The probe's range says the same: the tip dropped by more than 0.6·L.
    assert!(
        summary.probes[0].min[2] < -0.6 * length,
        "{:?}",
        summary.probes[0]
    );
}

/// Dynamic scenes take both nonlinear models with every method: each runs, reports its model,
/// and Newton iterations exactly for the implicit methods.
#[test]
fn dynamic_scenes_take_every_model_with_every_method() {
    let path = std::path::Path::new(concat!(
        concat!(env!("CARGO_MANIFEST_DIR"), "/../.."),
        "/scenes/rubber_beam_swing.toml"
    ));
    let text = std::fs::read_to_string(path).unwrap();
    for model in ["corotational", "neo-hookean"] {
        for (method, dt) in [
            ("backward_euler", "5e-3"),
            ("newmark", "5e-3"),
            ("explicit", "1e-4"),
        ] {
            let variant = text
                .replace("model = \"corotational\"", &format!("model = \"{model}\""))
                .replace(
                    "method = \"backward_euler\"",
                    &format!("method = \"{method}\""),
                )
                .replace("dt = 5e-3", &format!("dt = {dt}"));
            let scene =
                tetfem_cli::scene::Scene::parse(&variant, "variant", path.parent().unwrap())
                    .unwrap();
            let summary = tetfem_cli::scene::run_dynamic_scene(
                &scene,
                &tetfem_cli::scene::DynamicOverrides {
                    length: Some(tetfem_cli::scene::RunLength::Steps(5)),
                    ..Default::default()
                },
                false,
                false,
                &mut |_, _| std::ops::ControlFlow::Continue(()),
            )
            .unwrap();
            assert_eq!(summary.model, model);
            assert_eq!(summary.steps, 5);
            // Released from rest, the beam starts to fall: the tip has moved down.
            assert!(summary.probes[0].min[2] < 0.0, "{model} {method}");
            match method {
                "explicit" => assert!(summary.newton.is_none()),
                _ => {
                    let newton = summary.newton.unwrap();
                    assert_eq!(newton.steps, 5);
                    assert!(newton.total_iterations >= 5, "{model} {method}: {newton:?}");
                }
            }
        }
    }
}

/// Errors name the culprit: a prescribed non-zero displacement (its DOF), Newton options out of
/// range (the key), and a step whose Newton iterations run out (`Diverged`, naming the step).
#[test]
fn nonlinear_dynamics_errors_name_the_culprit() {
    let beam = swing(1e6, [6, 2, 2], MassKind::Lumped, Rayleigh::default());
    // A prescribed displacement: the tip's first node moved by 1 mm in z.
    let mut constraints = beam.problem.constraints(&beam.mesh).unwrap();
    let node = beam.problem.tip_nodes(&beam.mesh)[0];
    constraints.prescribe_axis(node, 2, 1e-3).unwrap();
    let prescribed = LinearSystem::new(
        &beam.mesh,
        &beam.problem.material,
        &constraints,
        &Loads::new(&beam.mesh),
        Vector3::zeros(),
        MassKind::Lumped,
        Rayleigh::default(),
    )
    .unwrap();
    match InternalForce::of_model(
        Arc::clone(&beam.mesh),
        ModelKind::Corotational.build(&beam.problem.material),
        &prescribed,
    ) {
        Err(tetfem::Error::InvalidParameter { name, .. }) => {
            assert!(name.contains(&format!("DOF {}", 3 * node + 2)), "{name}")
        }
        other => panic!("expected InvalidParameter, got {other:?}"),
    }
    let force = beam.force(ModelKind::NeoHookean);
    for (tolerance, max_iterations, key) in [
        (f64::NAN, 10, "newton.tolerance"),
        (0.0, 10, "newton.tolerance"),
        (1e-8, 0, "newton.max_iterations"),
    ] {
        let options = IntegratorOptions {
            newton: tetfem::dynamics::StepNewtonOptions {
                tolerance,
                max_iterations,
            },
            ..IntegratorOptions::default()
        };
        match Method::Newmark.integrator_with_force(
            Arc::clone(&beam.system),
            force.clone(),
            1e-2,
            options,
        ) {
            Err(tetfem::Error::InvalidParameter { name, .. }) => assert_eq!(name, key),
            other => panic!(
                "expected InvalidParameter on {key}, got {:?}",
                other.map(|i| i.name())
            ),
        }
    }
    // One iteration allowed at a large step of a large swing: not enough.
    let options = IntegratorOptions {
        newton: tetfem::dynamics::StepNewtonOptions {
            tolerance: 1e-12,
            max_iterations: 1,
        },
        ..IntegratorOptions::default()
    };
    let mut integrator = Method::BackwardEuler
        .integrator_with_force(Arc::clone(&beam.system), force, 0.05, options)
        .unwrap();
    let mut state = State::at_rest(beam.system.free_count());
    match integrator.step(&mut state) {
        Err(tetfem::Error::Diverged { step, reason, .. }) => {
            assert_eq!(step, 0);
            assert!(reason.contains("Newton did not converge"), "{reason}");
        }
        other => panic!("expected Diverged, got {other:?}"),
    }
}
