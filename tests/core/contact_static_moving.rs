//! Moving obstacles in the static contact solve (issue 33): an obstacle follows its motion over
//! the static step's pseudo-time t ∈ [0, 1], load step k of n at t = k/n, staged within each
//! load step so that no Newton iterate has a node inside it.

use nalgebra::Vector3;
use tetfem::analysis::nonlinear::{
    NewtonOptions, NewtonReport, nonlinear_reactions, solve_nonlinear_static_with_contact,
};
use tetfem::bc::amplitude::Amplitude;
use tetfem::contact::{Contact, ContactParameters, Obstacle, ObstacleMotion};
use tetfem::model::ModelKind;
use tetfem::{BoxSplit, Constraints, Error, Loads, Material, TetMesh};

/// The column's cross-section side (m).
const SIDE: f64 = 0.1;
/// The column's height (m).
const HEIGHT: f64 = 0.4;
/// Its Young's modulus (Pa); ν = 0, so a uniform press is uniaxial and exact for the mesh.
const E: f64 = 1e6;

/// A 0.1 × 0.1 × 0.4 m column (2×2×8 cells), its base z = 0 held on every axis, under a rigid
/// plate (the half-space above z = HEIGHT + d̂/2) that moves down by `press` (m) over the
/// pseudo-time by a ramp, solved in `load_steps` with `model`. Returns the solve, the contact
/// (its obstacle at its final placement), the mesh, the constraints and the plate's start gap.
struct Pressed {
    report: tetfem::base::error::Result<NewtonReport>,
    contact: Contact,
    mesh: TetMesh,
    constraints: Constraints,
    material: Material,
    start_gap: f64,
}

fn press(press: f64, load_steps: usize, model: ModelKind) -> Pressed {
    let mesh = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(SIDE, SIDE, HEIGHT),
        [2, 2, 8],
        BoxSplit::Lecture6,
    )
    .unwrap();
    let material = Material::new(E, 0.0, 1000.0).unwrap();
    let mut constraints = Constraints::new(&mesh);
    constraints
        .fix_axes(&mesh.nodes_on_plane(2, 0.0, 1e-9), [true; 3])
        .unwrap();
    let parameters = ContactParameters::for_mesh(&mesh, E).unwrap();
    let start_gap = 0.5 * parameters.activation_distance;
    let plate = Obstacle::half_space(
        "plate",
        Vector3::new(0.0, 0.0, HEIGHT + start_gap),
        -Vector3::z(),
    )
    .unwrap()
    .with_motion(ObstacleMotion::Amplitude {
        displacement: Vector3::new(0.0, 0.0, -press),
        amplitude: Amplitude::ramp(0.0, 1.0).unwrap(),
    })
    .unwrap();
    let contact = Contact::new(&mesh, vec![plate], parameters).unwrap();
    let report = solve_nonlinear_static_with_contact(
        &mesh,
        model.build(&material).as_ref(),
        &constraints,
        &Loads::new(&mesh),
        &contact,
        NewtonOptions {
            load_steps,
            ..NewtonOptions::default()
        },
    );
    Pressed {
        report,
        contact,
        mesh,
        constraints,
        material,
        start_gap,
    }
}

/// The press's checks at its end, `press` (m) down: (a) the force on the plate is the base
/// reactions' resultant, (b) every top node is within d̂ of the plate (so the top moved by the
/// press less the start gap, to within d̂), (d) no node is inside the plate. Returns the plate's
/// force F_z (N, on the plate: up is positive) and the top nodes' mean, least and largest
/// displacement u_z (m).
fn check_pressed(p: &Pressed, model: ModelKind, press: f64) -> (f64, [f64; 3]) {
    let report = p.report.as_ref().unwrap();
    let u = &report.displacement;
    let d_hat = p.contact.parameters().activation_distance;
    // The plate ends where its motion ends: t = 1.
    assert_eq!(p.contact.offsets()[0], Vector3::new(0.0, 0.0, -press));
    // (a) Σ over each axis of the equilibrium equations: the element forces sum to zero (up to
    // round-off), so |F_plate − ΣR| ≤ Σ|r_i| ≤ √n_f·‖r_f‖ with ‖r_f‖ where Newton stopped;
    // 1e-12 of the force covers the round-off of the sums.
    let solved = report.solved_contact(&p.contact).unwrap();
    let force = solved.obstacle_forces(u).unwrap()[0];
    let reactions = nonlinear_reactions(
        &p.mesh,
        model.build(&p.material).as_ref(),
        &p.constraints,
        &Loads::new(&p.mesh),
        u,
    )
    .unwrap();
    let base = (0..3)
        .map(|a| {
            (0..p.mesh.node_count())
                .map(|n| reactions[3 * n + a])
                .sum::<f64>()
        })
        .collect::<Vec<_>>();
    let base = Vector3::new(base[0], base[1], base[2]);
    let last = *report.residuals.last().unwrap().last().unwrap();
    let bound = (u.len() as f64).sqrt() * last + 1e-12 * force.norm();
    println!(
        "press {press:.3e} m: plate force {force:?} N, base reactions {base:?} N, |difference| {:.3e} (bound {bound:.3e})",
        (force - base).norm()
    );
    assert!((force - base).abs().max() <= bound);
    assert!(force.z > 0.0, "the plate is pushed up: {force:?}");
    // (b) The plate is at HEIGHT + start gap − press; every top node lies below it, within d̂.
    let plate = HEIGHT + p.start_gap - press;
    let top: Vec<f64> = p
        .mesh
        .nodes_on_plane(2, HEIGHT, 1e-9)
        .iter()
        .map(|&n| u[3 * n + 2])
        .collect();
    for &uz in &top {
        let gap = plate - (HEIGHT + uz);
        assert!(gap > 0.0 && gap < d_hat, "top gap {gap:e} (d̂ {d_hat:e})");
        assert!((uz + press - p.start_gap).abs() < d_hat);
    }
    // (d) No node inside (or on) the plate at the end: every signed distance > 0.
    let (gaps, _) = solved.node_fields(p.mesh.nodes(), u).unwrap();
    let lowest = gaps.iter().copied().fold(f64::INFINITY, f64::min);
    assert!(lowest > 0.0, "a node inside the plate: {lowest:e}");
    let mean = top.iter().sum::<f64>() / top.len() as f64;
    let (min, max) = top
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    println!(
        "  top u_z mean {mean:.6e} m (least {min:.6e}, largest {max:.6e}); plate-to-top gaps up to {:.3e} m, d̂ {d_hat:.3e} m; lowest gap {lowest:.3e} m",
        plate - HEIGHT - min
    );
    (force.z, [mean, min, max])
}

#[test]
fn a_plate_pressed_down_over_load_steps_is_held_by_the_base_at_every_step() {
    // 4 mm down (1 % strain) over 4 load steps. Load step k of 4 is where a solve of k load
    // steps with the press k mm ends: the plate is at the same offsets −1 mm·j at its steps j.
    let (steps, total) = (4, 4e-3);
    for model in [ModelKind::Linear, ModelKind::Corotational] {
        for k in 1..=steps {
            let down = total * k as f64 / steps as f64;
            let p = press(down, k, model);
            let (force, [mean, min, max]) = check_pressed(&p, model, down);
            // (c) Uniaxial with ν = 0: a uniform top displacement u gives F = E·A·|u|/L exactly
            // for the mesh. The top nodes' gaps differ (their barrier areas differ), so their
            // u_z spread over [min, max], and F = Σ_j k_j·|u_j| with Σ k_j = E·A/L lies
            // between E·A·|max|/L and E·A·|min|/L (1e-9 for round-off). The corotational
            // model is the linear one in each element's rotated frame, and the uneven top
            // turns the elements by O(spread × strain) only: 1e-4 more.
            let stiffness = E * SIDE * SIDE / HEIGHT;
            let slack = match model {
                ModelKind::Linear => 1e-9,
                _ => 1e-4,
            };
            println!(
                "  {model:?} step {k}/{steps}: F = {force:.6e} N, E·A·|ū|/L = {:.6e} N (ratio {:.6}), E·A·|u|/L over the top in [{:.6e}, {:.6e}] N",
                stiffness * mean.abs(),
                force / (stiffness * mean.abs()),
                stiffness * max.abs(),
                stiffness * min.abs()
            );
            assert!(
                force >= stiffness * max.abs() * (1.0 - slack)
                    && force <= stiffness * min.abs() * (1.0 + slack),
                "{model:?} {k}: {force} outside [{}, {}]",
                stiffness * max.abs(),
                stiffness * min.abs()
            );
        }
    }
}

#[test]
fn a_press_of_ten_percent_in_one_load_step_is_carried_to_the_end() {
    // 40 mm (10 %) in one load step. Staged, it was an error: the gap the barrier holds at 10 %
    // strain is ~d̂/15, and each stage advanced the plate by 0.8 of it: ~2000 stages, beyond
    // the 100 a step takes. The load step now starts from the column's top carried with the
    // plate (`Contact::carried_start`) and Newton solves it at once.
    let one = press(0.04, 1, ModelKind::Linear);
    let (force, _) = check_pressed(&one, ModelKind::Linear, 0.04);
    // The same press in 40 load steps ends at the same state: a linear body on a frictionless
    // obstacle has one equilibrium (the potential is convex), so the forces agree to the
    // Newton tolerance (1e-10 of the load) and the barrier's round-off: 1e-6 relative.
    let forty = press(0.04, 40, ModelKind::Linear);
    let (staged, _) = check_pressed(&forty, ModelKind::Linear, 0.04);
    assert!(
        (force - staged).abs() <= 1e-6 * staged,
        "one load step {force} N, forty {staged} N"
    );
}

#[test]
fn the_same_press_in_enough_load_steps_is_staged_to_the_end() {
    // The 40 mm of the test above in 40 load steps of 1 mm: each is staged, and the column
    // ends pressed by 40 mm less the start gap, within d̂ (the checks of `check_pressed`).
    let p = press(0.04, 40, ModelKind::Linear);
    let (force, [mean, ..]) = check_pressed(&p, ModelKind::Linear, 0.04);
    let report = p.report.as_ref().unwrap();
    println!(
        "40 mm in 40 load steps: F = {force:.6e} N, top ū_z = {mean:.6e} m, {} Newton iterations",
        report.iterations
    );
}

/// A 0.1 m rubber cube (corotational, 3×3×3 cells) with no support, resting under gravity half
/// an activation distance above a frictional floor (μ = 0.5) that moves sideways by `shift`
/// (m, along x; 0: a fixed floor) over 10 load steps, friction's stick distance ε_d = `slip_distance` (m; `None`:
/// the default d̂/10). Returns the solve, the contact and the mesh.
fn carried(
    shift: f64,
    slip_distance: Option<f64>,
) -> (tetfem::base::error::Result<NewtonReport>, Contact, TetMesh) {
    let mesh = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::repeat(0.1),
        [3, 3, 3],
        BoxSplit::Lecture6,
    )
    .unwrap();
    let rubber = Material::new(1e5, 0.3, 1000.0).unwrap();
    let parameters = ContactParameters::for_mesh(&mesh, rubber.youngs_modulus()).unwrap();
    let floor = Obstacle::half_space(
        "floor",
        Vector3::new(0.0, 0.0, -0.5 * parameters.activation_distance),
        Vector3::z(),
    )
    .unwrap()
    .with_friction(0.5)
    .unwrap();
    // A zero shift: the floor fixed (no motion at all).
    let floor = match shift {
        0.0 => floor,
        _ => floor
            .with_motion(ObstacleMotion::Amplitude {
                displacement: Vector3::new(shift, 0.0, 0.0),
                amplitude: Amplitude::ramp(0.0, 1.0).unwrap(),
            })
            .unwrap(),
    };
    let mut contact = Contact::new(&mesh, vec![floor], parameters).unwrap();
    if let Some(epsilon) = slip_distance {
        contact = contact.with_slip_distance(epsilon).unwrap();
    }
    let mut loads = Loads::new(&mesh);
    loads
        .add_gravity(&mesh, &rubber, Vector3::new(0.0, 0.0, -9.81))
        .unwrap();
    let report = solve_nonlinear_static_with_contact(
        &mesh,
        ModelKind::Corotational.build(&rubber).as_ref(),
        &Constraints::new(&mesh),
        &loads,
        &contact,
        NewtonOptions::default(),
    );
    (report, contact, mesh)
}

#[test]
fn a_floor_moving_sideways_carries_a_block_by_friction() {
    // 1 cm in 10 load steps: 1 mm per load step, below ε_d = 2 mm, so the block's nodes start
    // each load step within ε_d of where the floor carries them (sticking, with stiffness).
    let (shift, epsilon) = (0.01, Some(2e-3));
    let (report, contact, mesh) = carried(shift, epsilon);
    let report = report.unwrap();
    let u = &report.displacement;
    let (fixed, fixed_contact, _) = carried(0.0, epsilon);
    let fixed = fixed.unwrap();
    // Friction's slip is relative to the floor, and everything else (elasticity, the barrier's
    // gaps along z, gravity) is unchanged by a translation along x: each load step's
    // equations are the fixed floor's moved by the floor's offset, so the block is the one
    // sagging on a fixed floor, carried by the shift (in the world frame, friction would have
    // held its base where it was). Both solves stop within Newton's tolerance of the same
    // root: 1e-9 m (1e-7 of the shift) bounds their difference.
    let difference = (0..mesh.node_count())
        .map(|n| {
            (Vector3::new(u[3 * n] - shift, u[3 * n + 1], u[3 * n + 2])
                - Vector3::new(
                    fixed.displacement[3 * n],
                    fixed.displacement[3 * n + 1],
                    fixed.displacement[3 * n + 2],
                ))
            .norm()
        })
        .fold(0.0f64, f64::max);
    let mean_x = (0..mesh.node_count()).map(|n| u[3 * n]).sum::<f64>() / mesh.node_count() as f64;
    let friction = report.obstacle_friction_forces[0];
    let fixed_friction = fixed.obstacle_friction_forces[0];
    let normal = (report.solved_contact(&contact).unwrap())
        .obstacle_forces(u)
        .unwrap()[0];
    let fixed_normal = (fixed.solved_contact(&fixed_contact).unwrap())
        .obstacle_forces(&fixed.displacement)
        .unwrap()[0];
    println!(
        "floor shifted {shift} m: block mean u_x {mean_x:.9e} m, largest |u − shift − u_fixed| {difference:.3e} m; on the floor: friction {friction:?} N (fixed floor {fixed_friction:?} N), normal {normal:?} N (fixed floor {fixed_normal:?} N)"
    );
    assert!(difference <= 1e-9, "{difference:e}");
    // The forces on the floor are the fixed floor's: the weight 9.81 N on its normal, no
    // net friction (nothing loads the block along it). Both to √n·‖r‖ of either solve.
    let last = |r: &NewtonReport| *r.residuals.last().unwrap().last().unwrap();
    let bound = (u.len() as f64).sqrt() * (last(&report) + last(&fixed)) + 1e-12;
    assert!(
        (normal - fixed_normal).norm() <= bound,
        "{normal:?} vs {fixed_normal:?}"
    );
    assert!(
        (friction - fixed_friction).norm() <= bound,
        "{friction:?} vs {fixed_friction:?}"
    );
    assert!(
        (normal.z + 9.81).abs() <= bound + 1e-12 * 9.81,
        "{normal:?}"
    );
}

#[test]
fn a_block_that_starts_load_steps_sliding_on_a_moving_floor_is_an_error_saying_what_helps() {
    // The default ε_d = d̂/10 = 1.7e-5 m against 1 mm per load step: the block starts each
    // load step sliding on the floor, where friction has no stiffness along the slip, and
    // nothing else holds it along x.
    let (report, contact, _) = carried(0.01, None);
    match report {
        Err(Error::Solver(message)) => {
            println!("{message}");
            assert!(message.contains("load step 1/10"), "{message}");
            assert!(message.contains("'floor'"), "{message}");
            assert!(
                message.contains("slip_distance above 1.000e-3"),
                "{message}"
            );
            let needed = (10.0 * 1e-3 / contact.slip_distance()).ceil();
            assert!(
                message.contains(&format!("At least {needed} load steps")),
                "{message}"
            );
        }
        other => panic!("expected the sliding error, got {other:?}"),
    }
}
