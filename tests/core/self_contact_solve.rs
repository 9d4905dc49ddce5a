//! Body–body contact inside the implicit solve (issue 36, phase 2): two blocks of one mesh
//! ([`Bodies`]) with the surface barrier as a term of the nonlinear force
//! ([`NonlinearForce::with_surface_contact`]), stepped by backward Euler.

use std::sync::Arc;

use nalgebra::Vector3;
use tetfem::analysis::dynamics::Method;
use tetfem::analysis::dynamics::{
    BackwardEuler, Integrator, IntegratorOptions, InternalForce, LinearSystem, MassKind,
    NonlinearForce, Rayleigh, State, StepNewtonOptions,
};
use tetfem::analysis::transient::{TimeStep, Transient, TransientOptions, Unobserved};
use tetfem::analysis::{Analysis, Definition};
use tetfem::base::warning::Warning;
use tetfem::contact::surface::{SurfaceBarrier, SurfaceContact};
use tetfem::fe::materials::MaterialMap;
use tetfem::mesh::bodies::{Bodies, Placement};
use tetfem::model::ModelElement;
use tetfem::model::ModelKind;
use tetfem::{BoxSplit, CellType, Constraints, Error, Loads, Material, Tet10, TetMesh};

pub(crate) const SIDE: f64 = 0.1;
/// d̂ (m): a tenth of the 1/3-cell edge (0.033 m), well below the shortest surface edge.
pub(crate) const D_HAT: f64 = 2e-3;
/// κ (J/m²): the barrier's force at d = d̂/10 over the ~50 pairs of two facing 3×3 faces is
/// ≈ 50·κ·0.025 m ≈ 1.2 kN, above the ≈ 0.3 kN an elastic impact at 1 m/s asks
/// (ρ·c·v·A with c = √(E/ρ) ≈ 32 m/s), so the blocks turn back well before d̂/10.
pub(crate) const KAPPA: f64 = 1e3;

pub(crate) fn block(cells: usize) -> TetMesh {
    TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::repeat(SIDE),
        [cells; 3],
        BoxSplit::Lecture6,
    )
    .unwrap()
}

/// Two equal blocks along x, B `gap` (m) beyond A's +x face.
pub(crate) fn two_blocks(cells: usize, gap: f64) -> Bodies {
    let b = Placement::translated(Vector3::new(SIDE + gap, 0.0, 0.0)).unwrap();
    Bodies::new(vec![
        (block(cells), Placement::identity()),
        (block(cells), b),
    ])
    .unwrap()
}

pub(crate) fn rubber() -> Material {
    Material::new(1e6, 0.3, 1000.0).unwrap()
}

/// A free body system (no supports, no gravity) and its force with surface contact.
pub(crate) fn setup<C: ModelElement>(
    bodies: &Bodies<C>,
    kind: ModelKind,
    barrier: SurfaceBarrier,
) -> (Arc<LinearSystem>, Arc<NonlinearForce>) {
    let mesh = bodies.mesh();
    let material = rubber();
    let system = LinearSystem::new_free_body(
        mesh,
        &material,
        &Constraints::new(mesh),
        &Loads::new(mesh),
        Vector3::zeros(),
        MassKind::Lumped,
        Rayleigh::default(),
    )
    .unwrap();
    let contact = SurfaceContact::new(mesh, &bodies.node_bodies(), barrier).unwrap();
    let force = NonlinearForce::new(Arc::new(mesh.clone()), kind.build(&material), &system)
        .unwrap()
        .with_surface_contact(contact)
        .unwrap();
    (Arc::new(system), Arc::new(force))
}

/// Per body: (mass, x-momentum) from the system's mass and the state's velocity.
pub(crate) fn body_momenta<C: CellType>(
    system: &LinearSystem,
    bodies: &Bodies<C>,
    velocity: &[f64],
) -> Vec<(f64, f64)> {
    let n = velocity.len();
    let mut mv = vec![0.0; n];
    let mut m1 = vec![0.0; n];
    system.mass().mul_vec(velocity, &mut mv).unwrap();
    system.mass().mul_vec(&vec![1.0; n], &mut m1).unwrap();
    (0..bodies.count())
        .map(|b| {
            let nodes = bodies.node_range(b).unwrap();
            nodes.fold((0.0, 0.0), |(m, p), k| (m + m1[3 * k], p + mv[3 * k]))
        })
        .collect()
}

struct Impact {
    /// |Σ momentum_x| over the run, over the bodies' Σ|m·v| at the start.
    momentum_drift: f64,
    /// The largest rise of the total energy from one step to the next (J).
    largest_rise: f64,
    start_energy: f64,
    relative_start: f64,
    relative_end: f64,
    smallest_distance: f64,
    iterations: usize,
    steps: usize,
    /// The largest (on-pattern, lumped) counts of the barrier's tangent entries in a step.
    fill: (usize, usize),
}

/// Two blocks at ±`speed` (m/s) along x, `steps` backward Euler steps of `dt` (s); after each
/// step the exact intersection test and the smallest distance.
fn head_on<C: ModelElement>(
    bodies: Bodies<C>,
    kind: ModelKind,
    speed: f64,
    dt: f64,
    steps: usize,
) -> Impact {
    let barrier = SurfaceBarrier::new(D_HAT, KAPPA).unwrap();
    let (system, force) = setup(&bodies, kind, barrier);
    let options = IntegratorOptions {
        // The momentum error of a step is dt·Σr over the x DOFs of its last residual r
        // (the internal forces sum to zero): a tolerance of 1e-11 of the inertial residual
        // keeps the run's drift far below the 1e-9 asked.
        newton: StepNewtonOptions {
            tolerance: 1e-11,
            max_iterations: 200,
            relax_contact_nodes: true,
        },
        ..IntegratorOptions::default()
    };
    let mut integrator = BackwardEuler::with_force(
        Arc::clone(&system),
        InternalForce::Nonlinear(Arc::clone(&force)),
        dt,
        options,
    )
    .unwrap();
    let mut state = State::at_rest(system.free_count());
    let v = [
        Vector3::new(speed, 0.0, 0.0),
        Vector3::new(-speed, 0.0, 0.0),
    ];
    state.velocity = bodies.velocity(&v).unwrap();
    let total = |state: &State| {
        force.energy(&system, state).unwrap().total()
            + force.surface_energy(&state.displacement).unwrap()
    };
    let relative = |state: &State| {
        let p = body_momenta(&system, &bodies, &state.velocity);
        p[1].1 / p[1].0 - p[0].1 / p[0].0
    };
    let start = body_momenta(&system, &bodies, &state.velocity);
    let scale: f64 = start.iter().map(|(_, p)| p.abs()).sum();
    let contact = force.surface_contact().unwrap();
    let mut out = Impact {
        momentum_drift: 0.0,
        largest_rise: f64::NEG_INFINITY,
        start_energy: total(&state),
        relative_start: relative(&state),
        relative_end: 0.0,
        smallest_distance: f64::INFINITY,
        iterations: 0,
        steps,
        fill: (0, 0),
    };
    let mut previous = out.start_energy;
    for _ in 0..steps {
        integrator.step(&mut state).unwrap();
        let u = &state.displacement;
        let crossing = contact.intersections(u).unwrap();
        assert!(
            crossing.is_empty(),
            "step {}: triangles {:?} intersect",
            state.steps,
            crossing.first()
        );
        let d = contact.smallest_distance(u).unwrap();
        assert!(d > 0.0, "step {}: smallest distance {d:e}", state.steps);
        out.smallest_distance = out.smallest_distance.min(d);
        let fill = contact.last_fill();
        out.fill = (out.fill.0.max(fill.on_pattern), out.fill.1.max(fill.lumped));
        let p: f64 = body_momenta(&system, &bodies, &state.velocity)
            .iter()
            .map(|(_, p)| p)
            .sum();
        out.momentum_drift = out.momentum_drift.max(p.abs() / scale);
        let energy = total(&state);
        out.largest_rise = out.largest_rise.max(energy - previous);
        previous = energy;
    }
    out.relative_end = relative(&state);
    out.iterations = integrator.newton_stats().unwrap().total_iterations;
    out
}

fn check_impact(name: &str, r: &Impact) {
    println!(
        "{name}: momentum drift {:.2e}, largest energy rise {:.2e} J of {:.3e} J, relative \
         velocity {:.4} → {:.4} m/s, smallest distance {:.3e} m (d̂ {D_HAT:e}), {} Newton \
         iterations over {} steps, largest tangent fill {} entries on the pattern, {} lumped",
        r.momentum_drift,
        r.largest_rise,
        r.start_energy,
        r.relative_start,
        r.relative_end,
        r.smallest_distance,
        r.iterations,
        r.steps,
        r.fill.0,
        r.fill.1
    );
    // Pairs across the bodies couple nodes that share no tet: their entries are off the
    // stiffness pattern (lumped, and restored by the CG on the exact Hessian).
    assert!(r.fill.1 > 0, "no off-pattern entries: {:?}", r.fill);
    // Barrier and elastic forces are internal: only the Newton residual's sum moves the
    // total momentum (see the tolerance in `head_on`).
    assert!(
        r.momentum_drift < 1e-9,
        "momentum drift {:e}",
        r.momentum_drift
    );
    // Backward Euler dissipates; the Newton tolerance leaves ~1e-11 relative noise in the
    // energy of a step, so a rise of 1e-9 of the start energy is allowed.
    assert!(
        r.largest_rise <= 1e-9 * r.start_energy,
        "energy rose by {:e} J",
        r.largest_rise
    );
    // The bodies met: the barrier was active (some pair came within d̂).
    assert!(
        r.smallest_distance < D_HAT,
        "no contact: {:e}",
        r.smallest_distance
    );
    // An elastic collision turns the approach (−2 m/s) into a separation.
    assert!(r.relative_start < 0.0 && r.relative_end > 0.0);
}

/// Gap 0.01 m closes at 2 m/s in 5 ms; the bar-impact contact lasts ≈ 2L/c ≈ 6 ms; 24 steps of
/// 1 ms see the blocks part.
#[test]
fn neo_hookean_blocks_collide_head_on_and_bounce() {
    let r = head_on(two_blocks(3, 0.01), ModelKind::NeoHookean, 1.0, 1e-3, 24);
    check_impact("neo-hookean", &r);
}

/// The linear model goes through the same nonlinear force (its fast paths cannot see contact).
#[test]
fn linear_blocks_collide_head_on_and_bounce() {
    let r = head_on(two_blocks(3, 0.01), ModelKind::Linear, 1.0, 1e-3, 24);
    check_impact("linear", &r);
}

/// 10-node tets: contact on the quadratic faces' linear sub-triangles (the mid-edge nodes are
/// surface vertices), the same run on 2×2×2-cell blocks of 10-node tets.
#[test]
fn quadratic_blocks_collide_head_on_and_bounce() {
    let b = Placement::translated(Vector3::new(SIDE + 0.01, 0.0, 0.0)).unwrap();
    let quadratic = || TetMesh::<Tet10>::from_linear(&block(2)).unwrap();
    let bodies = Bodies::new(vec![(quadratic(), Placement::identity()), (quadratic(), b)]).unwrap();
    let r = head_on(bodies, ModelKind::NeoHookean, 1.0, 1e-3, 24);
    check_impact("neo-hookean, 10-node tets", &r);
}

/// The force is −∂(E + B)/∂u: central differences of the potential energy agree with it near
/// contact, where the barrier dominates.
#[test]
fn surface_contact_force_is_the_potential_gradient() {
    let bodies = two_blocks(2, 0.5 * D_HAT);
    let barrier = SurfaceBarrier::new(D_HAT, KAPPA).unwrap();
    let (system, force) = setup(&bodies, ModelKind::NeoHookean, barrier);
    let n = system.free_count();
    let u: Vec<f64> = (0..n).map(|i| 1e-5 * ((i as f64) * 0.7).sin()).collect();
    let mut work = force.workspace().unwrap();
    let mut f = vec![0.0; n];
    force.force_into(&u, &mut work, &mut f).unwrap();
    let e = force.potential_energy(&u).unwrap();
    assert!(
        force.surface_energy(&u).unwrap() > 0.0,
        "the barrier is active at this state (E = {e:e} J)"
    );
    let largest = f.iter().map(|v| v.abs()).fold(0.0, f64::max);
    let h = 1e-8;
    let mut worst: f64 = 0.0;
    for i in (0..n).step_by(7) {
        let mut up = u.clone();
        up[i] += h;
        let mut down = u.clone();
        down[i] -= h;
        let fd = -(force.potential_energy(&up).unwrap() - force.potential_energy(&down).unwrap())
            / (2.0 * h);
        worst = worst.max((fd - f[i]).abs());
    }
    println!("largest |f − FD| {worst:.3e} N of max |f| {largest:.3e} N");
    // Central differences with h = 1e-8 m: truncation O(h²·f‴) and round-off O(ε·E/h) are
    // both below 1e-5 of the largest force here.
    assert!(worst < 1e-5 * largest, "{worst:e} vs {largest:e}");
}

/// Bodies that overlap at the start are refused, naming both bodies and a triangle pair.
#[test]
fn overlapping_bodies_are_an_error_naming_them() {
    let bodies = two_blocks(2, -0.01);
    let barrier = SurfaceBarrier::new(D_HAT, KAPPA).unwrap();
    let err = SurfaceContact::new(bodies.mesh(), &bodies.node_bodies(), barrier).unwrap_err();
    let text = err.to_string();
    println!("{text}");
    assert!(matches!(err, Error::InvalidParameter { .. }));
    assert!(text.contains("bodies 0 and 1"), "{text}");
    assert!(text.contains("triangle"), "{text}");
}

/// d̂ above the shortest surface edge warns with both numbers.
#[test]
fn reach_beyond_the_shortest_edge_warns() {
    let bodies = two_blocks(2, 0.01);
    let within = SurfaceBarrier::new(D_HAT, KAPPA).unwrap();
    let contact = SurfaceContact::new(bodies.mesh(), &bodies.node_bodies(), within).unwrap();
    assert!(contact.warnings().is_empty());
    let shortest = contact.surface().shortest_rest_edge();
    // Cells of 0.05 m: the shortest surface edge is the cell's side.
    assert!((shortest - 0.05).abs() < 1e-15, "{shortest}");
    let far = SurfaceBarrier::new(0.06, KAPPA).unwrap();
    let contact = SurfaceContact::new(bodies.mesh(), &bodies.node_bodies(), far).unwrap();
    let warnings = contact.warnings();
    assert_eq!(
        warnings,
        vec![Warning::SurfaceBarrierReach {
            activation_distance: 0.06,
            shortest_edge: shortest,
        }]
    );
    let text = warnings[0].to_string();
    assert!(text.contains("0.06") && text.contains("0.05"), "{text}");
}

/// The same run through the problem definition every front end builds
/// ([`Definition::surface_contact`], [`Transient`]): the library's rule admits static and every
/// integrator (Newmark and explicit: tests/core/surface_dynamics.rs) and refuses the modal
/// analysis, naming it.
#[test]
fn definition_runs_surface_contact_with_backward_euler() {
    let bodies = two_blocks(2, 0.004);
    let mesh = bodies.mesh().clone();
    let materials = MaterialMap::uniform(rubber(), mesh.tet_count());
    let barrier = SurfaceBarrier::new(D_HAT, KAPPA).unwrap();
    let definition = Definition::builder(mesh, materials)
        .model(ModelKind::NeoHookean)
        .surface_contact(barrier, bodies.node_bodies())
        .unwrap()
        .build()
        .unwrap();
    // Static carries it too (tests/core/self_contact_static.rs).
    assert!(definition.check(Analysis::Static).is_ok());
    for method in [Method::Newmark, Method::Explicit] {
        assert!(definition.check(Analysis::Transient(method)).is_ok());
    }
    let err = definition.check(Analysis::Modal).unwrap_err().to_string();
    assert!(
        err.contains("surface_contact") && err.contains("modal"),
        "{err}"
    );
    let options = TransientOptions::new(Method::BackwardEuler, TimeStep::Seconds(1e-3));
    let mut run = Transient::new(&definition, options).unwrap();
    let v = [Vector3::new(1.0, 0.0, 0.0), Vector3::new(-1.0, 0.0, 0.0)];
    run.state_mut().velocity = bodies.velocity(&v).unwrap();
    run.run((0, 6), &mut Unobserved).unwrap();
    let InternalForce::Nonlinear(force) = run.force() else {
        panic!("surface contact runs through the nonlinear force");
    };
    let contact = force.surface_contact().unwrap();
    let u = &run.state().displacement;
    let d = contact.smallest_distance(u).unwrap();
    println!("definition route: smallest distance after 6 steps {d:.3e} m");
    // The gap (4 mm) closes at 2 m/s in 2 ms: after 6 ms the blocks are in contact, apart.
    assert!(d > 0.0 && d < D_HAT, "{d:e}");
    assert!(contact.intersections(u).unwrap().is_empty());
}
