//! Nonlinear force models in every integrator: the linear model through the force seam is the
//! linear integrators bit for bit; corotational backward Euler settles to the Newton static
//! answer; Newmark and the explicit method keep the energy of a nonlinear swing; the shipped
//! rubber beam scene swings past 45°; a model per material (`ModelMap`) in every method, the
//! library and scenes; modal analysis refuses a nonlinear model.

use std::path::Path;
use std::sync::Arc;

use nalgebra::Vector3;
use tetfem::TetMesh;
use tetfem::analysis::dynamics::{
    BackwardEuler, Energy, Integrator, IntegratorOptions, InternalForce, LinearSystem, MassKind,
    Method, Newmark, NewtonStats, Rayleigh, State, SymplecticEuler, critical_time_step,
};
use tetfem::analysis::nonlinear::{NewtonOptions, solve_nonlinear_static};
use tetfem::bc::loads::Loads;
use tetfem::fe::materials::{MaterialAssignment, MaterialMap, TetMaterials};
use tetfem::mesh::BoxSplit;
use tetfem::model::ModelKind;
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
    let system = swing_system(&problem, &mesh, &problem.material, mass, damping);
    Swing {
        problem,
        mesh: Arc::new(mesh),
        system,
    }
}

/// The system of the swing's beam under gravity only, each tet with its material of `materials`.
fn swing_system(
    problem: &Cantilever,
    mesh: &TetMesh,
    materials: &impl TetMaterials,
    mass: MassKind,
    damping: Rayleigh,
) -> Arc<LinearSystem> {
    Arc::new(
        LinearSystem::new(
            mesh,
            materials,
            &problem.constraints(mesh).unwrap(),
            &Loads::new(mesh),
            Vector3::new(0.0, 0.0, -GRAVITY),
            mass,
            damping,
        )
        .unwrap(),
    )
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

/// Runs `scene` through the scene runner for `steps` steps, writing no files.
fn run_steps(scene: &tetfem_cli::scene::Scene, steps: usize) -> tetfem_cli::scene::DynamicSummary {
    tetfem_cli::scene::run_dynamic_scene(
        scene,
        &tetfem_cli::scene::DynamicOverrides {
            length: Some(tetfem_cli::scene::RunLength::Steps(steps)),
            ..Default::default()
        },
        false,
        false,
        &mut |_, _| std::ops::ControlFlow::Continue(()),
    )
    .unwrap()
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
fn rubber_beam_swing_scene_swings_past_100_degrees() {
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
    let summary = run_steps(&scene, steps);
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
    // The scene's descriptions (its comment, the scenes table, the large-deformation
    // chapter) say its tip swings past 100°: measured 105.4° in these 0.6 s.
    assert!(largest > 100.0, "{largest}°");
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
            let summary = run_steps(&scene, 5);
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

/// Errors name the culprit: Newton options out of range (the key), and a step whose Newton
/// iterations run out (`Diverged`, naming the step); a prescribed non-zero displacement is no
/// error (issue 34) and pulls as the linear model does at small strain.
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
    // Taken since issue 34 (it was refused naming the DOF): one backward-Euler step pulled by
    // the moved node is the linear model's to the nonlinearity's size (a 1 mm pull on a 0.5 m
    // beam: strains ~1e-2 near the node, so 5e-2 of the step's largest displacement).
    let prescribed = Arc::new(prescribed);
    let step = |kind: ModelKind| {
        let force = InternalForce::of_model(
            Arc::clone(&beam.mesh),
            kind.build(&beam.problem.material),
            &prescribed,
        )
        .unwrap();
        let mut integrator = Method::BackwardEuler
            .integrator_with_force(
                Arc::clone(&prescribed),
                force,
                1e-2,
                IntegratorOptions::default(),
            )
            .unwrap();
        let mut state = State::at_rest(prescribed.free_count());
        integrator.step(&mut state).unwrap();
        state.displacement
    };
    let (linear, corotational) = (step(ModelKind::Linear), step(ModelKind::Corotational));
    let size = linear.iter().fold(0.0f64, |m, u| m.max(u.abs()));
    let gap = linear
        .iter()
        .zip(&corotational)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(size > 0.0 && gap <= 5e-2 * size, "{gap:e} of {size:e}");
    let force = beam.force(ModelKind::NeoHookean);
    for (tolerance, max_iterations, key) in [
        (f64::NAN, 10, "newton.tolerance"),
        (0.0, 10, "newton.tolerance"),
        (1e-8, 0, "newton.max_iterations"),
    ] {
        let options = IntegratorOptions {
            newton: tetfem::analysis::dynamics::StepNewtonOptions {
                tolerance,
                max_iterations,
                relax_contact_nodes: true,
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
        newton: tetfem::analysis::dynamics::StepNewtonOptions {
            tolerance: 1e-12,
            max_iterations: 1,
            relax_contact_nodes: true,
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

/// The beam's material, with the right half (tets whose centroid has x > L/2) of `right`.
fn two_halves(beam: &Swing, right: tetfem::Material) -> MaterialMap {
    let half = 0.5 * beam.problem.length;
    let mut assignment = MaterialAssignment::new(beam.mesh.tet_count());
    assignment
        .assign_where(&beam.mesh, "right half", right, |c| c.x > half)
        .unwrap();
    assignment.finish(Some(beam.problem.material)).unwrap()
}

/// A model per material with the same material everywhere (the `ModelMap` of a uniform
/// `MaterialMap`) is the single model bit for bit (==): states, Newton counts and energies, for
/// every method, both nonlinear models, lumped and consistent mass, with Rayleigh damping (β > 0,
/// so that the tangent enters the damping too).
#[test]
fn a_uniform_model_map_is_the_single_model_bit_for_bit() {
    let damping = Rayleigh {
        alpha: 0.5,
        beta: 1e-4,
    };
    let mut compared = 0;
    for mass in [MassKind::Lumped, MassKind::Consistent] {
        let beam = swing(1e6, [6, 2, 2], mass, damping);
        let system = &beam.system;
        let n = system.free_count();
        let uniform = MaterialMap::uniform(beam.problem.material, beam.mesh.tet_count());
        for kind in [ModelKind::Corotational, ModelKind::NeoHookean] {
            let map =
                InternalForce::of_models(Arc::clone(&beam.mesh), kind.build_map(&uniform), system)
                    .unwrap();
            assert!(map.is_nonlinear());
            assert_eq!(map.name(), kind.name());
            let forces = [beam.force(kind), map];
            for method in [Method::BackwardEuler, Method::Newmark, Method::Explicit] {
                let dt = match (method, mass) {
                    (Method::Explicit, MassKind::Consistent) => continue,
                    (Method::Explicit, _) => 0.5 * critical_time_step(system).unwrap().dt,
                    _ => 2e-3,
                };
                let runs: Vec<(State, Option<NewtonStats>, Energy)> = forces
                    .iter()
                    .map(|force| {
                        let mut integrator = method
                            .integrator_with_force(
                                Arc::clone(system),
                                force.clone(),
                                dt,
                                IntegratorOptions::default(),
                            )
                            .unwrap();
                        let mut state = moving_state(n);
                        run(integrator.as_mut(), &mut state, 10);
                        let energy = force.energy(system, &state).unwrap();
                        (state, integrator.newton_stats(), energy)
                    })
                    .collect();
                assert_ne!(runs[0].0, moving_state(n), "the state should move");
                if method != Method::Explicit {
                    assert!(runs[0].1.unwrap().total_iterations >= 10, "{:?}", runs[0].1);
                }
                assert_eq!(runs[0], runs[1], "{kind:?} {method:?} {mass:?}");
                compared += 1;
            }
        }
    }
    assert_eq!(compared, 10);
}

/// Two materials, a model each: the beam of the one-material settling test (E = 0.25 MPa,
/// ρ = 1100 kg/m³ at the clamp) with a lighter, stiffer right half (E = 1 MPa, ρ = 500 kg/m³).
/// Corotational backward Euler with mass damping α = 10/s for 4 s at dt = 10 ms settles to
/// `solve_nonlinear_static` with the same `ModelMap`, and that answer is not the one-material
/// one.
#[test]
fn two_material_corotational_backward_euler_settles_to_the_newton_static_answer() {
    let damping = Rayleigh {
        alpha: 10.0,
        beta: 0.0,
    };
    let beam = swing(2.5e5, [10, 2, 2], MassKind::Lumped, damping);
    let map = two_halves(&beam, tetfem::Material::new(1e6, 0.4, 500.0).unwrap());
    assert_eq!(map.counts(), vec![100, 100]);
    let system = swing_system(&beam.problem, &beam.mesh, &map, MassKind::Lumped, damping);
    let models = || ModelKind::Corotational.build_map(&map);
    let force = InternalForce::of_models(Arc::clone(&beam.mesh), models(), &system).unwrap();
    let dt = 0.01;
    let mut integrator = Method::BackwardEuler
        .integrator_with_force(Arc::clone(&system), force, dt, IntegratorOptions::default())
        .unwrap();
    let mut state = State::at_rest(system.free_count());
    run(integrator.as_mut(), &mut state, 400);
    let stats = integrator.newton_stats().unwrap();
    let constraints = beam.problem.constraints(&beam.mesh).unwrap();
    let gravity_of = |materials: &dyn Fn(&mut Loads) -> tetfem::Result<()>| {
        let mut loads = Loads::new(&beam.mesh);
        materials(&mut loads).unwrap();
        loads
    };
    let g = Vector3::new(0.0, 0.0, -GRAVITY);
    let two = gravity_of(&|l| l.add_gravity(&beam.mesh, &map, g).map(|_| ()));
    let statics = solve_nonlinear_static(
        &beam.mesh,
        &models(),
        &constraints,
        &two,
        NewtonOptions::default(),
    )
    .unwrap();
    let material = beam.problem.material;
    let one = gravity_of(&|l| l.add_gravity(&beam.mesh, &material, g).map(|_| ()));
    let single = ModelKind::Corotational.build(&material);
    let one_material = solve_nonlinear_static(
        &beam.mesh,
        &single,
        &constraints,
        &one,
        NewtonOptions::default(),
    )
    .unwrap();
    let dynamic = system.dofs().expand(&state.displacement).unwrap();
    let (tip, static_tip) = (beam.tip(&dynamic), beam.tip(&statics.displacement));
    let one_tip = beam.tip(&one_material.displacement);
    let static_state = State::released_from(system.dofs().restrict(&statics.displacement).unwrap());
    let difference = (tip - static_tip).norm() / static_tip.norm();
    let regions_matter = (one_tip - static_tip).norm() / static_tip.norm();
    println!(
        "two materials: settled tip {tip:?} vs static {static_tip:?}: relative {difference:.2e}; static rotation {:.2}° (one material: tip differs by {regions_matter:.3}); Newton {} iterations over {} steps, at most {} in one; static Newton {} iterations",
        beam.tip_rotation(&static_state),
        stats.total_iterations,
        stats.steps,
        stats.max_per_step,
        statics.iterations,
    );
    assert_eq!(stats.steps, 400);
    assert!(
        stats.max_per_step >= 2,
        "a large rotation needs Newton: {stats:?}"
    );
    // A large rotation (measured 40.6°; the stiffer half bends less than the one-material beam's
    // 63°), far outside the linear model's range.
    assert!(beam.tip_rotation(&static_state) > 30.0);
    // The regions change the answer by far more than the tolerance below (measured 0.49).
    assert!(regions_matter > 0.05, "{regions_matter}");
    // Measured 1.0e-8. Tolerance 1e-6, as in the one-material test: what is left is the transient (α = 10/s
    // damps the first mode by e^(−αt/2) = e^(−20) ≈ 2e-9 in 4 s, backward Euler's own
    // dissipation the higher ones) plus the two Newton tolerances (1e-10 of the load static,
    // 1e-8 per step); 1e-6 leaves room for other platforms' round-off and still tells a settled
    // beam from any other shape (one material instead of two: 49 % off).
    assert!(difference < 1e-6, "{difference:e}");
}

/// The scene of `two_material_scene_runs_each_tets_model_through_the_runner`: a rubber beam with a
/// lighter, stiffer outer half (`[[materials]]` box), corotational backward Euler.
const TWO_MATERIAL_SWING: &str = r#"
title = "two-material rubber swing"

[mesh.box]
max = [0.5, 0.05, 0.05]
cells = [10, 2, 2]
split = "five"

[material]
youngs_modulus = 2.5e5
poisson_ratio = 0.4
density = 1100.0

[[materials]]
youngs_modulus = 1e6
poisson_ratio = 0.4
density = 500.0
where = { box = { min = [0.25, -1.0, -1.0], max = [1.0, 1.0, 1.0] } }

[[constraints]]
where = { plane = { axis = "x", at = 0.0 } }

[[loads]]
gravity = [0.0, 0.0, -9.81]

[[probes]]
name = "tip"
where = { plane = { axis = "x", at = 0.5 } }

[analysis]
type = "dynamic"
method = "backward_euler"
model = "corotational"
dt = 1e-2
duration = 0.2
damping = { mass = 10.0 }
linear_solver = "direct"
"#;

/// A dynamic scene with `[[materials]]` and a nonlinear model runs through the scene runner with
/// a model per region (it was an error before): the tip it reports is, bit for bit (==), the one
/// of the library's `InternalForce::of_models` on the same system, and not the one of the scene
/// without its `[[materials]]` entry.
#[test]
fn two_material_scene_runs_each_tets_model_through_the_runner() {
    let steps = 20;
    let run_scene = |text: &str| {
        let scene =
            tetfem_cli::scene::Scene::parse(text, "two_material_swing", Path::new(".")).unwrap();
        let summary = run_steps(&scene, steps);
        (scene, summary)
    };
    let (scene, summary) = run_scene(TWO_MATERIAL_SWING);
    assert_eq!(summary.model, "corotational");
    let newton = summary.newton.unwrap();
    assert_eq!(newton.steps, steps);
    assert!(newton.max_per_step >= 2, "{newton:?}");
    // The library, on the scene's own mesh, materials, constraints and loads.
    let built = scene.build().unwrap();
    assert_eq!(built.materials.materials().len(), 2);
    let damping = Rayleigh {
        alpha: 10.0,
        beta: 0.0,
    };
    let system = Arc::new(
        LinearSystem::new(
            &built.mesh,
            &built.materials,
            &built.constraints,
            &built.other_loads,
            built.gravity,
            MassKind::Lumped,
            damping,
        )
        .unwrap(),
    );
    let force = InternalForce::of_models(
        Arc::new(built.mesh.clone()),
        ModelKind::Corotational.build_map(&built.materials),
        &system,
    )
    .unwrap();
    let mut integrator = BackwardEuler::with_force(
        Arc::clone(&system),
        force,
        1e-2,
        IntegratorOptions::default(),
    )
    .unwrap();
    let mut state = State::at_rest(system.free_count());
    run(&mut integrator, &mut state, steps);
    let u = system.dofs().expand(&state.displacement).unwrap();
    let tip: [f64; 3] = built.probes[0].mean_displacement(&u).into();
    println!(
        "scene tip after {steps} steps {:?}, library {tip:?}; Newton {} iterations, at most {} per step",
        summary.probes[0].last, newton.total_iterations, newton.max_per_step
    );
    assert_eq!(summary.probes[0].last, tip);
    // Without the [[materials]] entry (one soft, heavy material) the tip is elsewhere: measured
    // 4.0 % of its displacement after these 20 steps; 1 % tells the two apart with margin.
    let start = TWO_MATERIAL_SWING.find("[[materials]]").unwrap();
    let end = TWO_MATERIAL_SWING.find("[[constraints]]").unwrap();
    let one_material = TWO_MATERIAL_SWING.replace(&TWO_MATERIAL_SWING[start..end], "");
    let (_, single) = run_scene(&one_material);
    let (a, b) = (
        Vector3::from(summary.probes[0].last),
        Vector3::from(single.probes[0].last),
    );
    assert!((a - b).norm() > 0.01 * b.norm(), "{a:?} vs {b:?}");
}

/// Modal analysis is linear only: `lowest_modes_with_force` with the linear force is
/// `lowest_modes` (==), with a nonlinear model an `InvalidParameter` naming the model; the scene
/// setup's `first_mode_period` says the same after `with_model`.
#[test]
fn modal_analysis_with_a_nonlinear_model_is_an_error_naming_it() {
    use tetfem::analysis::modal::{lowest_modes, lowest_modes_with_force};
    let beam = swing(1e6, [6, 2, 2], MassKind::Lumped, Rayleigh::default());
    let modes = lowest_modes(&beam.system, 3).unwrap();
    assert_eq!(
        lowest_modes_with_force(&beam.system, &InternalForce::Linear, 3).unwrap(),
        modes
    );
    let expect_model_error = |result: tetfem::Result<f64>, kind: ModelKind| {
        let requirement = invalid_parameter(result, "model", kind.name());
        assert!(
            requirement.contains("modal analysis is linear only"),
            "{requirement}"
        );
    };
    for kind in [ModelKind::Corotational, ModelKind::NeoHookean] {
        expect_model_error(
            lowest_modes_with_force(&beam.system, &beam.force(kind), 3).map(|m| m.omega[0]),
            kind,
        );
    }
    // The scene setup (the CLI's path to the modal solver).
    let scene =
        tetfem_cli::scene::Scene::parse(TWO_MATERIAL_SWING, "modal", Path::new(".")).unwrap();
    let tetfem_cli::scene::Analysis::Dynamic(settings) = *scene.analysis() else {
        panic!("the scene is dynamic");
    };
    let setup =
        tetfem_cli::scene::DynamicSetup::from_scene(scene.build().unwrap(), &settings).unwrap();
    let omega = lowest_modes(&setup.system, 1).unwrap().omega[0];
    let period = setup.clone().with_model(ModelKind::Linear).unwrap();
    assert_eq!(
        period.first_mode_period().unwrap(),
        2.0 * std::f64::consts::PI / omega
    );
    for kind in [ModelKind::Corotational, ModelKind::NeoHookean] {
        let nonlinear = setup.clone().with_model(kind).unwrap();
        expect_model_error(nonlinear.first_mode_period(), kind);
    }
}

/// A model map that is not of the mesh's tets is refused when the force is built, naming the
/// map and both counts.
#[test]
fn a_model_map_of_another_mesh_is_an_error() {
    let beam = swing(1e6, [6, 2, 2], MassKind::Lumped, Rayleigh::default());
    let tets = beam.mesh.tet_count();
    let other = MaterialMap::uniform(beam.problem.material, tets + 1);
    let result = InternalForce::of_models(
        Arc::clone(&beam.mesh),
        ModelKind::Corotational.build_map(&other),
        &beam.system,
    );
    let requirement = invalid_parameter(result, "material map", &format!("{} tets", tets + 1));
    assert!(requirement.contains(&tets.to_string()), "{requirement}");
}

/// The requirement of `result`'s error, which must be `InvalidParameter` on `name` = `value`.
fn invalid_parameter<T: std::fmt::Debug>(
    result: tetfem::Result<T>,
    name: &str,
    value: &str,
) -> String {
    match result {
        Err(tetfem::Error::InvalidParameter {
            name: named,
            value: valued,
            requirement,
        }) if named == name && valued == value => requirement,
        other => panic!("expected InvalidParameter on {name} = {value}, got {other:?}"),
    }
}

/// Backward Euler with a nonlinear model through the seam (what the removed
/// `NonlinearBackwardEuler` wrapper built: lumped mass, no damping, gravity): 20 steps of a
/// large swing for both nonlinear models, one Newton solve counted per step; and a non-zero
/// prescribed displacement is taken (issue 34): the tip node starts at it.
#[test]
fn nonlinear_backward_euler_through_the_seam_swings_and_takes_a_prescribed_displacement() {
    let beam = swing(1e6, [6, 2, 2], MassKind::Lumped, Rayleigh::default());
    let material = beam.problem.material;
    let dt = 5e-3;
    for kind in [ModelKind::Corotational, ModelKind::NeoHookean] {
        let mut seam = Method::BackwardEuler
            .integrator_with_force(
                Arc::clone(&beam.system),
                beam.force(kind),
                dt,
                IntegratorOptions::default(),
            )
            .unwrap();
        let mut state = State::at_rest(beam.system.free_count());
        run(seam.as_mut(), &mut state, 20);
        assert!(beam.tip_rotation(&state) > 1.0, "the beam should swing");
        let stats = seam.newton_stats().unwrap();
        assert_eq!(stats.steps, 20, "{kind:?}");
        assert!(stats.total_iterations >= 20, "{kind:?}");
    }
    let mut moved = beam.problem.constraints(&beam.mesh).unwrap();
    let node = beam.problem.tip_nodes(&beam.mesh)[0];
    moved.prescribe_axis(node, 2, 1e-3).unwrap();
    let system = Arc::new(
        LinearSystem::new(
            beam.mesh.as_ref(),
            &material,
            &moved,
            &Loads::new(&beam.mesh),
            Vector3::new(0.0, 0.0, -GRAVITY),
            MassKind::Lumped,
            Rayleigh::default(),
        )
        .unwrap(),
    );
    let force = InternalForce::of_model(
        Arc::clone(&beam.mesh),
        ModelKind::Corotational.build(&material),
        &system,
    )
    .unwrap();
    let mut moved_run =
        BackwardEuler::with_force(Arc::clone(&system), force, dt, IntegratorOptions::default())
            .unwrap();
    let mut state = State::at_rest(system.free_count());
    moved_run.step(&mut state).unwrap();
    assert!(state.displacement.iter().all(|u| u.is_finite()));
    // The prescribed value pulls the beam: the step moved it.
    assert!(state.displacement.iter().any(|&u| u != 0.0));
}
