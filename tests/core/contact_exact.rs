//! Contact forces that do not depend on the barrier's reach (issue 35): an elastic lens — a
//! block whose base is the paraboloid z = (x² + y²)/(2R), a sphere of radius R near its tip —
//! pressed onto a rigid plane by 0.2 %, 0.5 % and 1 % of R, solved by the barrier at its
//! default scales and compared with the exact contact of the same mesh: node-to-plane, found
//! here by a primal–dual active-set loop of linear solves (independent of the barrier code).

use nalgebra::Vector3;
use tetfem::analysis::nonlinear::{NewtonOptions, solve_nonlinear_static_with_contact};
use tetfem::contact::{Contact, ContactParameters, Obstacle};
use tetfem::model::ModelKind;
use tetfem::{BoxSplit, Constraints, Loads, Material, TetMesh, solve_static};

/// The sphere's radius the base follows (m).
pub(crate) const RADIUS: f64 = 0.05;
/// Half the block's width (m) and its height (m).
const HALF_WIDTH: f64 = 0.01;
const HEIGHT: f64 = 0.01;
/// The start gap between the tip and the plane (m): inside the default d̂ (3e-5 m here).
pub(crate) const START_GAP: f64 = 1e-5;

pub(crate) fn material() -> Material {
    Material::new(1e6, 0.3, 1000.0).unwrap()
}

/// The lens: a 16 × 16 × 8 cell box over [−w, w]² × [0, H] whose base is bent to the
/// paraboloid, the top kept flat: z ↦ f + z·(H − f)/H with f = (x² + y²)/(2R).
pub(crate) fn lens() -> TetMesh {
    let block = TetMesh::box_grid(
        Vector3::new(-HALF_WIDTH, -HALF_WIDTH, 0.0),
        Vector3::new(HALF_WIDTH, HALF_WIDTH, HEIGHT),
        [16, 16, 8],
        BoxSplit::Lecture6,
    )
    .unwrap();
    let nodes = (block.nodes().iter())
        .map(|p| {
            let f = (p.x * p.x + p.y * p.y) / (2.0 * RADIUS);
            Vector3::new(p.x, p.y, f + p.z * (HEIGHT - f) / HEIGHT)
        })
        .collect();
    block.with_nodes(nodes).unwrap()
}

/// The top face moved down by `approach` (m) on every axis's value (0, 0, −approach).
pub(crate) fn pressed_top(mesh: &TetMesh, approach: f64) -> Constraints {
    let mut constraints = Constraints::new(mesh);
    for n in mesh.nodes_on_plane(2, HEIGHT, 1e-9) {
        constraints
            .prescribe(n, Vector3::new(0.0, 0.0, -approach))
            .unwrap();
    }
    constraints
}

/// The exact frictionless node-to-plane contact of the mesh's base nodes with the plane
/// z = −START_GAP, the top moved down by `approach`: a primal–dual active-set loop. The
/// active nodes are held on the plane (z only; x and y free), solved linearly; a held node
/// whose reaction pulls (λ < 0) is released, a free node below the plane is held; until the
/// set repeats. Returns the plane's force (N, along +z on the body) and the active nodes.
pub(crate) fn exact(mesh: &TetMesh, approach: f64) -> (f64, Vec<usize>) {
    let base: Vec<usize> = (0..mesh.node_count())
        .filter(|&n| mesh.nodes()[n].z < HEIGHT - 1e-9)
        .collect();
    let gap = |n: usize, u: &[f64]| mesh.nodes()[n].z + u[3 * n + 2] + START_GAP;
    // Start from the nodes a rigid move of the body would push through the plane.
    let mut active: Vec<usize> = (base.iter().copied())
        .filter(|&n| mesh.nodes()[n].z + START_GAP < approach)
        .collect();
    for _ in 0..50 {
        let mut constraints = pressed_top(mesh, approach);
        for &n in &active {
            constraints
                .prescribe_axis(n, 2, -(mesh.nodes()[n].z + START_GAP))
                .unwrap();
        }
        let solution = solve_static(mesh, &material(), &constraints, &Loads::new(mesh)).unwrap();
        let u = &solution.displacement;
        // The reaction K·u − f at a held node is the force the support puts on the body.
        let mut next: Vec<usize> = (active.iter().copied())
            .filter(|&n| solution.reactions[3 * n + 2] >= 0.0)
            .collect();
        next.extend(
            base.iter()
                .filter(|&&n| !active.contains(&n) && gap(n, u) < 0.0),
        );
        next.sort_unstable();
        if next == active {
            let force = active.iter().map(|&n| solution.reactions[3 * n + 2]).sum();
            return (force, active);
        }
        active = next;
    }
    panic!("the active set did not settle in 50 solves");
}

/// The barrier's solution of the same problem at its default scales, the static solve's
/// continuation driving its gap error to `gap_tolerance`: the plane's force on the body (N,
/// +z), the nodes it pushes (gap below the d̂ the solution ended under), and the gap error.
fn barrier(mesh: &TetMesh, approach: f64, gap_tolerance: f64) -> (f64, Vec<usize>, f64) {
    let parameters = ContactParameters::for_mesh(mesh, material().youngs_modulus()).unwrap();
    let plane =
        Obstacle::half_space("plane", Vector3::new(0.0, 0.0, -START_GAP), Vector3::z()).unwrap();
    let contact = Contact::new(mesh, vec![plane], parameters)
        .unwrap()
        .with_gap_tolerance(gap_tolerance)
        .unwrap();
    let report = solve_nonlinear_static_with_contact(
        mesh,
        ModelKind::Linear.build(&material()).as_ref(),
        &pressed_top(mesh, approach),
        &Loads::new(mesh),
        &contact,
        NewtonOptions {
            load_steps: 1,
            ..NewtonOptions::default()
        },
    )
    .unwrap();
    let u = &report.displacement;
    // Every accepted Newton iterate (load step and continuation stages) kept every node above
    // the plane — the barrier's guarantee, measured — and the solution is one of them.
    let (iterates, solution) = (
        report.smallest_iterate_gap.unwrap(),
        contact.smallest_gap(u).unwrap(),
    );
    assert!(
        iterates > 0.0 && iterates <= solution,
        "{iterates} m at an iterate, {solution} m at the solution"
    );
    // Forces and gaps under the barrier the solution is in equilibrium under.
    let solved = contact
        .with_parameters(report.contact_parameters.unwrap())
        .unwrap();
    let force = -solved.obstacle_forces(u).unwrap()[0].z;
    let (_, pressures) = solved.gaps_and_pressures(u).unwrap();
    let pushed = (solved.nodes().iter().zip(&pressures))
        .filter(|&(_, &p)| p > 0.0)
        .map(|(&n, _)| n)
        .collect();
    (force, pushed, report.gap_error.unwrap())
}

#[test]
fn the_contact_force_is_the_exact_contact_of_the_mesh_at_the_default_scales() {
    // Measured: +1.6e-7, +5.3e-8 and +1.5e-9 of the exact force, the active sets equal (11,
    // 37 and 69 nodes), the gap errors 2.4e-9, 7.8e-10 and 2.3e-10 (d̂ 3e-5 → 3e-9 in four
    // stages). 1e-6 is the target; what remains is Newton's tolerance (1e-10 of the
    // step's first residual) and the round-off of forces from gaps of ~1e-13 m, not the
    // barrier's reach (a further stage changes the force by < 2e-8).
    let mesh = lens();
    for fraction in [0.002, 0.005, 0.01] {
        let approach = fraction * RADIUS + START_GAP;
        let (exact_force, active) = exact(&mesh, approach);
        let (force, pushed, gap_error) = barrier(&mesh, approach, tetfem::contact::GAP_TOLERANCE);
        assert!(
            (force / exact_force - 1.0).abs() <= 1e-6,
            "δ/R = {fraction}: {force} N against the exact {exact_force} N"
        );
        assert_eq!(pushed, active, "δ/R = {fraction}: the contact area");
        assert!(gap_error <= tetfem::contact::GAP_TOLERANCE, "{gap_error}");
    }
}

#[test]
fn without_the_continuation_the_force_depends_on_the_reach() {
    // The barrier at the default d̂ alone (a tolerance it meets at once): measured +32 % of
    // the exact force at δ/R = 0.2 %, 21 nodes pushed against 11 touching — the issue's
    // reproduction (+185 % there, on another mesh), which the continuation removes. A bound
    // of 10 % leaves room for the mesh and still fails on any d̂-independent answer.
    let mesh = lens();
    let approach = 0.002 * RADIUS + START_GAP;
    let (exact_force, active) = exact(&mesh, approach);
    let (force, pushed, gap_error) = barrier(&mesh, approach, 0.5);
    assert!(force / exact_force - 1.0 > 0.1, "{force} vs {exact_force}");
    assert!(pushed.len() > active.len());
    // The gap error says so: the pushed nodes' weighted gap is a percent of the motion.
    assert!(gap_error > 1e-3, "{gap_error}");
}
