//! The combination matrix (issue 34, item 4): {linear, corotational, Neo-Hookean, StVK} ×
//! {4-node, 10-node} × {static, backward Euler, Newmark, explicit, modal} × {constant loads,
//! loads on an amplitude, a moving support} × {no obstacle, a ground with friction} × {one
//! material, two regions}. Each cell asks the library's rule (`analysis::Combination::check`)
//! first: a refused cell must be one the physics cannot compute (modal with a nonlinear model
//! or with obstacles) and its error must name the pair; every other cell runs a small case (a
//! rubber block 0.4 × 0.1 × 0.1 m on 4 × 1 × 1 cells, clamped at x = 0, ≤ 243 DOFs) and checks
//! something that could be false:
//!
//! - static: the supports, the loads and the obstacles balance (Σ R + Σ f − Σ F_obstacle = 0);
//!   a nonlinear model agrees with the linear one at this small load (without obstacles); a
//!   clamp moved rigidly carries the block without strain (u = d at every node);
//! - dynamic: mechanical energy against the loads' work W = Σ ½(fₙ + fₙ₊₁)·Δu (backward Euler
//!   never above it, Newmark and explicit close to it); a clamp moving at constant velocity
//!   carries the block without strain; with obstacles no node ends inside one;
//! - modal: the Rayleigh quotient of each mode is its ω².
//!
//! The counts of green and refused cells are printed (`-- --nocapture`).

use std::sync::Arc;

use nalgebra::Vector3;
use tetfem::analysis::dynamics::{
    IntegratorOptions, InternalForce, LinearSystem, MassKind, Method, NonlinearForce, Rayleigh,
    State, TimeData,
};
use tetfem::analysis::nonlinear::{NewtonOptions, nonlinear_reactions};
use tetfem::analysis::{Analysis, Combination};
use tetfem::base::warning::Warning;
use tetfem::bc::amplitude::{Amplitude, STATIC_TIME};
use tetfem::bc::boundary_motion::{BoundaryMotion, Motion};
use tetfem::contact::{Contact, ContactParameters, Obstacle};
use tetfem::fe::materials::MaterialMap;
use tetfem::mesh::NodeList;
use tetfem::model::{ModelElement, ModelKind};
use tetfem::{BoxSplit, Constraints, Error, Loads, Material, Tet10, TetMesh};

/// Loads and supports of a cell.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Data {
    /// A constant tip load.
    Constant,
    /// The tip load on a ramp (full at `STATIC_TIME` and at the end of a dynamic run).
    Amplitude,
    /// No load; the clamp translates along y (a ramp: constant velocity).
    Moving,
}

#[derive(Debug, Clone, Copy)]
struct Cell {
    model: ModelKind,
    order: usize,
    analysis: Analysis,
    data: Data,
    obstacles: bool,
    regions: bool,
}

const LENGTH: f64 = 0.4;
/// The tip load (N, along −z): a static tip deflection of ~1 mm (2.5e-3 of the length: the
/// models differ from the linear one by about that), enough to press the tip on the ground.
const TIP_LOAD: f64 = 0.5;
/// The ground's distance below the block (m): just beyond the barrier's default reach d̂ =
/// 1e-3 of the diagonal (4.2e-4 m), so contact starts when the tip has come down.
const GROUND_GAP: f64 = 5e-4;
/// The clamp's travel per second along y (m) in the moving cells.
const TRAVEL: f64 = 1e-2;
/// The dynamic runs' duration (s): 0.17 of the first bending period; the tip reaches the
/// ground's barrier after about 0.02 s.
const DURATION: f64 = 0.05;

fn rubber(youngs_modulus: f64) -> Material {
    Material::new(youngs_modulus, 0.3, 1000.0).unwrap()
}

fn block() -> TetMesh {
    TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(LENGTH, 0.1, 0.1),
        [4, 1, 1],
        BoxSplit::Mirrored6,
    )
    .unwrap()
}

/// One material, or two regions (the half x > L/2 twice as stiff).
fn materials<E: ModelElement>(mesh: &TetMesh<E>, regions: bool) -> MaterialMap {
    if !regions {
        return MaterialMap::uniform(rubber(1e6), mesh.tet_count());
    }
    let of_tet = (0..mesh.tet_count())
        .map(|t| {
            let corners = mesh.tets()[t].corners();
            let x = corners.iter().map(|&n| mesh.nodes()[n].x).sum::<f64>() / 4.0;
            u32::from(x > 0.5 * LENGTH)
        })
        .collect();
    MaterialMap::new(
        vec![rubber(1e6), rubber(2e6)],
        vec!["soft".into(), "stiff".into()],
        of_tet,
    )
    .unwrap()
}

/// Everything a cell's run needs on its mesh.
struct Case<E: ModelElement> {
    mesh: Arc<TetMesh<E>>,
    materials: MaterialMap,
    constraints: Constraints,
    /// Constant loads (the tip load of `Data::Constant`).
    loads: Loads,
    data: TimeData,
    contact: Option<Contact>,
}

fn case<E: ModelElement>(mesh: TetMesh<E>, cell: &Cell) -> Case<E> {
    let materials = materials(&mesh, cell.regions);
    let clamp = mesh.nodes_on_plane(0, 0.0, 1e-9);
    let mut constraints = Constraints::new(&mesh);
    constraints.fix_nodes(&clamp).unwrap();
    let tip_nodes = mesh.nodes_on_plane(0, LENGTH, 1e-9);
    let mut tip = Loads::new(&mesh);
    for &n in &tip_nodes {
        let share = Vector3::new(0.0, 0.0, -TIP_LOAD / tip_nodes.len() as f64);
        tip.add_nodal_force(n, share).unwrap();
    }
    let mut data = TimeData::default();
    let loads = match cell.data {
        Data::Constant => tip.clone(),
        Data::Amplitude => {
            let ramp = Amplitude::ramp(0.0, STATIC_TIME.min(DURATION)).unwrap();
            data.loads.push((tip.clone(), ramp));
            Loads::new(&mesh)
        }
        Data::Moving => {
            let motion = Motion::Uniform {
                displacement: Vector3::new(0.0, TRAVEL, 0.0),
                amplitude: Amplitude::ramp(0.0, 1.0).unwrap(),
            };
            data.motion.add(&clamp, [true; 3], motion).unwrap();
            Loads::new(&mesh)
        }
    };
    let contact = cell.obstacles.then(|| {
        // The moving cells keep the ground out of reach (the translation is along it).
        let gap = match cell.data {
            Data::Moving => 5.0 * GROUND_GAP,
            _ => GROUND_GAP,
        };
        let ground = Obstacle::half_space(
            "ground",
            Vector3::new(0.0, 0.0, -gap),
            Vector3::new(0.0, 0.0, 1.0),
        )
        .unwrap()
        .with_friction(0.3)
        .unwrap();
        let parameters = ContactParameters::for_mesh(&mesh, 2e6).unwrap();
        Contact::new(&mesh, vec![ground], parameters).unwrap()
    });
    Case {
        mesh: Arc::new(mesh),
        materials,
        constraints,
        loads,
        data,
        contact,
    }
}

/// max over nodes of |u − d|.
fn off_translation(u: &[f64], d: Vector3<f64>) -> f64 {
    u.chunks(3)
        .map(|n| (Vector3::new(n[0], n[1], n[2]) - d).norm())
        .fold(0.0, f64::max)
}

fn sum_axes(v: &[f64]) -> Vector3<f64> {
    let mut s = Vector3::zeros();
    for (i, x) in v.iter().enumerate() {
        s[i % 3] += x;
    }
    s
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

/// A static cell: Newton (or the linear solve) on the case; the checks of the module docs.
fn run_static<E: ModelElement>(cell: &Cell, c: &Case<E>) -> Result<String, String> {
    let models = cell.model.build_map(&c.materials);
    let mut constraints = c.constraints.clone();
    let mut motion = BoundaryMotion::new();
    if cell.data == Data::Moving {
        // The motion prescribes the clamp (its values at STATIC_TIME), nothing else.
        constraints = Constraints::new(c.mesh.as_ref());
    }
    let mut loads = c.loads.clone();
    for (l, a) in &c.data.loads {
        loads
            .add_scaled(l, a.value(STATIC_TIME))
            .map_err(|e| format!("open: {e}"))?;
    }
    if cell.data == Data::Moving {
        motion = c.data.motion.clone();
        motion
            .prescribe_at(c.mesh.nodes(), STATIC_TIME, &mut constraints)
            .map_err(|e| format!("open: {e}"))?;
    }
    let report = tetfem::analysis::nonlinear::solve_nonlinear_static_with_motion_and_contact(
        c.mesh.as_ref(),
        &models,
        &constraints,
        &loads,
        &motion,
        c.contact.as_ref(),
        NewtonOptions::default(),
    )
    .map_err(|e| format!("open: {e}"))?;
    let u = &report.displacement;
    if let Some(inside) = c.contact.as_ref().and_then(|k| k.nodes_inside(u).unwrap()) {
        return Err(format!("nodes inside: {inside}"));
    }
    if cell.data == Data::Moving {
        // Round-off: the translated block's element forces cancel to ~1e-16·E·h²; Newton
        // stops there. 1e-9 of the travel is far above that, far below any strain. With
        // contact Newton may stop at its round-off floor, 1e-6 of the clamp's pull (measured
        // 1.6e-9 of the travel): 1e-7.
        let bound = match c.contact {
            Some(_) => 1e-7,
            None => 1e-9,
        };
        let off = off_translation(u, Vector3::new(0.0, TRAVEL, 0.0));
        return match off <= bound * TRAVEL {
            true => Ok(format!("rigid to {:.1e}", off / TRAVEL)),
            false => Err(format!("off the translation by {off:e}")),
        };
    }
    let reactions = nonlinear_reactions(c.mesh.as_ref(), &models, &constraints, &loads, u)
        .map_err(|e| format!("open: {e}"))?;
    // The barrier's force on the free nodes (on a clamped node it goes into the support, which
    // the reactions −(Σ fₑ + f) do not see), and friction's (zero on a clamped node: no slip).
    let mut on_body = Vector3::zeros();
    if let Some(k) = &c.contact {
        // Under the barrier the solution ended under (the solve's continuation of d̂).
        let k = report.solved_contact(k).map_err(|e| format!("open: {e}"))?;
        let mut barrier = vec![0.0; u.len()];
        k.add_force(u, &mut barrier)
            .map_err(|e| format!("open: {e}"))?;
        let dofs = tetfem::bc::constraints::DofMap::new(&constraints);
        for &d in dofs.free_dofs() {
            on_body[d % 3] += barrier[d];
        }
        on_body -= report
            .obstacle_friction_forces
            .first()
            .copied()
            .unwrap_or_default();
    }
    let balance = sum_axes(&reactions) + sum_axes(loads.as_slice()) + on_body;
    // Newton stops at ‖r_f‖ ≤ 1e-10·‖f_f‖ (its default); the sum over ≤ 243 free rows is at
    // most √n·‖r_f‖ ≤ 16·1e-10 of the load: 1e-8 of it leaves room.
    if balance.norm() > 1e-8 * TIP_LOAD {
        return Err(format!("Σ R + Σ f − F_obstacle = {balance:?}"));
    }
    let mut note = format!("balance {:.1e}", balance.norm() / TIP_LOAD);
    if cell.model != ModelKind::Linear && !cell.obstacles {
        let linear = tetfem::analysis::statics::solve_static(
            c.mesh.as_ref(),
            &c.materials,
            &constraints,
            &loads,
        )
        .map_err(|e| format!("open: {e}"))?;
        let size = max_abs(&linear.displacement);
        let gap = max_abs(
            &u.iter()
                .zip(&linear.displacement)
                .map(|(a, b)| a - b)
                .collect::<Vec<_>>(),
        );
        // The models differ from the linear one by the rotation and strain, ~1e-3 here.
        if gap > 1e-2 * size {
            return Err(format!("{gap:e} from the linear model's {size:e}"));
        }
        note += &format!(", {:.1e} from linear", gap / size);
    }
    Ok(note)
}

/// A dynamic cell with `method`.
fn run_dynamic<E: ModelElement>(
    cell: &Cell,
    c: &Case<E>,
    method: Method,
) -> Result<String, String> {
    let err = |e: Error| format!("open: {e}");
    let system = Arc::new(
        LinearSystem::with_time_data(
            c.mesh.as_ref(),
            &c.materials,
            &c.constraints,
            &c.loads,
            Vector3::zeros(),
            MassKind::Lumped,
            Rayleigh::default(),
            &c.data,
        )
        .map_err(err)?,
    );
    let models = cell.model.build_map(&c.materials);
    let force = match &c.contact {
        Some(contact) => InternalForce::Nonlinear(Arc::new(
            NonlinearForce::with_models(Arc::clone(&c.mesh), models, &system)
                .and_then(|f| f.with_contact(contact.clone()))
                .map_err(err)?,
        )),
        None => InternalForce::of_models(Arc::clone(&c.mesh), models, &system).map_err(err)?,
    };
    // Half the explicit critical step, for every method (the explicit one needs it; contact's
    // barrier stiffens near the ground, hence the half).
    let dt = 0.5
        * tetfem::analysis::dynamics::critical_time_step(&system)
            .map_err(err)?
            .dt;
    let steps = (DURATION / dt).ceil() as usize;
    let mut integrator = method
        .integrator_with_force(
            Arc::clone(&system),
            force.clone(),
            dt,
            IntegratorOptions::default(),
        )
        .map_err(err)?;
    let mut state = State::at_rest(system.free_count());
    if cell.data == Data::Moving {
        let v: Vec<f64> = (0..c.mesh.dof_count())
            .map(|i| if i % 3 == 1 { TRAVEL } else { 0.0 })
            .collect();
        state.velocity = system.dofs().restrict(&v).map_err(err)?;
    }
    let nonlinear = force.is_nonlinear();
    let mut buffer = system.model_load_buffer(nonlinear);
    let mut f_before = system
        .model_load_at(0.0, nonlinear, &mut buffer)
        .map_err(err)?
        .to_vec();
    let (mut work, mut worst) = (0.0, 0.0f64);
    for _ in 0..steps {
        let before = state.displacement.clone();
        integrator.step(&mut state).map_err(err)?;
        let f_after = system
            .model_load_at(state.time, nonlinear, &mut buffer)
            .map_err(err)?
            .to_vec();
        for i in 0..before.len() {
            work += 0.5 * (f_before[i] + f_after[i]) * (state.displacement[i] - before[i]);
        }
        f_before = f_after;
        if cell.data == Data::Moving {
            let u = system
                .expand_at(state.time, &state.displacement)
                .map_err(err)?;
            worst = worst.max(off_translation(
                &u,
                Vector3::new(0.0, TRAVEL * state.time, 0.0),
            ));
        }
    }
    let full = system
        .expand_at(state.time, &state.displacement)
        .map_err(err)?;
    if let Some(inside) = c
        .contact
        .as_ref()
        .and_then(|k| k.nodes_inside(&full).unwrap())
    {
        return Err(format!("nodes inside: {inside}"));
    }
    if cell.data == Data::Moving {
        let travel = TRAVEL * state.time;
        // Newton's 1e-8 per step of the clamp's pull, amplified by the step matrix: 1e-6 of
        // the travel (tests/nonlinear_time_varying.rs measured ≤ 3.6e-8). With contact Newton
        // converges relative to the step's inertia ‖M·(u − ũ)‖/dt² too (the force that would
        // stop the body within the step), large for a translating body: 1e-5.
        let bound = match c.contact {
            Some(_) => 1e-5,
            None => 1e-6,
        };
        return match worst <= bound * travel {
            true => Ok(format!("rigid to {:.1e}", worst / travel)),
            false => Err(format!("off the translation by {worst:e} of {travel:e}")),
        };
    }
    let energy = force.energy(&system, &state).map_err(err)?;
    let contact_energy = match &c.contact {
        Some(k) => k.energy(&full).map_err(err)?,
        None => 0.0,
    };
    let stored = energy.kinetic + energy.elastic + contact_energy;
    let ratio = stored / work;
    // Backward Euler dissipates: the stored energy never exceeds the work (up to Newton's
    // 1e-8). Newmark conserves it up to Newton's tolerance (the load's work by the trapezoid
    // rule is its own); explicit (symplectic Euler) oscillates about it by O(ω·dt) ≈ 10 %
    // at half the critical step. With obstacles Newmark has no bound (the library warns); it
    // must only keep every node outside (checked above). Explicit contact is enforced on the
    // velocity (an inelastic impulse: the normal speed at impact is lost), so with obstacles
    // the stored energy may fall below the work but never rise above its oscillation.
    let ok = match (method, cell.obstacles) {
        (_, _) if work.is_nan() || work <= 0.0 => false,
        (Method::BackwardEuler, _) => ratio <= 1.0 + 1e-6,
        (Method::Newmark, false) => (ratio - 1.0).abs() <= 1e-6,
        (Method::Newmark, true) => ratio.is_finite(),
        (Method::Explicit, false) => (ratio - 1.0).abs() <= 0.2,
        (Method::Explicit, true) => ratio > 0.0 && ratio <= 1.2,
    };
    match ok {
        true => Ok(format!("E/W {ratio:.6}")),
        false => Err(format!(
            "stored {stored:e} against work {work:e} (ratio {ratio})"
        )),
    }
}

/// A modal cell: each of the two lowest modes' Rayleigh quotient φᵀKφ/φᵀMφ is its ω².
fn run_modal<E: ModelElement>(c: &Case<E>) -> Result<String, String> {
    let err = |e: Error| format!("open: {e}");
    let system = LinearSystem::new(
        c.mesh.as_ref(),
        &c.materials,
        &c.constraints,
        &c.loads,
        Vector3::zeros(),
        MassKind::Lumped,
        Rayleigh::default(),
    )
    .map_err(err)?;
    let modes = tetfem::analysis::modal::lowest_modes(&system, 2).map_err(err)?;
    let mut worst = 0.0f64;
    for (omega, phi) in modes.omega.iter().zip(&modes.shapes) {
        let k = system
            .stiffness()
            .quadratic_form(phi)
            .map_err(|e| format!("open: {e}"))?;
        let m = system.mass().quadratic_form(phi).map_err(err)?;
        worst = worst.max((k / m / (omega * omega) - 1.0).abs());
    }
    // The subspace iteration converges its eigenvalues to ~1e-10; 1e-8 leaves room.
    match worst <= 1e-8 {
        true => Ok(format!("Rayleigh quotients to {worst:.1e}")),
        false => Err(format!("Rayleigh quotient off by {worst:e}")),
    }
}

fn run_cell<E: ModelElement>(mesh: TetMesh<E>, cell: &Cell) -> Result<String, String> {
    let c = case(mesh, cell);
    match cell.analysis {
        Analysis::Static => run_static(cell, &c),
        Analysis::Transient(method) => run_dynamic(cell, &c, method),
        Analysis::Modal => run_modal(&c),
    }
}

#[test]
fn every_combination_runs_or_is_a_named_physics_refusal() {
    let analyses = [
        Analysis::Static,
        Analysis::Transient(Method::BackwardEuler),
        Analysis::Transient(Method::Newmark),
        Analysis::Transient(Method::Explicit),
        Analysis::Modal,
    ];
    let (mut green, mut refused, mut open, mut failed) = (0, 0, Vec::new(), Vec::new());
    for model in ModelKind::ALL {
        for order in [1, 2] {
            for analysis in analyses {
                for data in [Data::Constant, Data::Amplitude, Data::Moving] {
                    for obstacles in [false, true] {
                        for regions in [false, true] {
                            let cell = Cell {
                                model,
                                order,
                                analysis,
                                data,
                                obstacles,
                                regions,
                            };
                            let combination = Combination {
                                model,
                                region_models: Vec::new(),
                                order,
                                analysis,
                                time_varying_loads: data == Data::Amplitude,
                                moving_supports: data == Data::Moving,
                                obstacles,
                                friction: obstacles,
                                regions,
                                formulation: Default::default(),
                                surface_contact: false,
                                surface_friction: false,
                            };
                            let physics_refuses = analysis == Analysis::Modal
                                && (model != ModelKind::Linear || obstacles);
                            match (combination.check(), physics_refuses) {
                                (Err(Error::InvalidParameter { name, .. }), true) => {
                                    // The error names the pair: the analysis and what clashes.
                                    let pair = name.contains("modal")
                                        && (name.contains("model") || name.contains("obstacles"));
                                    assert!(pair, "{cell:?}: {name}");
                                    refused += 1;
                                    continue;
                                }
                                (Ok(warnings), false) => {
                                    let warned = warnings
                                        .iter()
                                        .any(|w| matches!(w, Warning::ImpactLosesEnergy { .. }));
                                    let newmark_contact = obstacles
                                        && analysis == Analysis::Transient(Method::Newmark);
                                    assert_eq!(warned, newmark_contact, "{cell:?}");
                                }
                                (other, _) => panic!("{cell:?}: {other:?}"),
                            }
                            let outcome = match cell.order {
                                1 => run_cell(block(), &cell),
                                _ => run_cell(
                                    TetMesh::<Tet10>::from_linear(&block()).unwrap(),
                                    &cell,
                                ),
                            };
                            match outcome {
                                Ok(note) => {
                                    println!("green   {cell:?}: {note}");
                                    green += 1;
                                }
                                // A library error of the solve (Newton's convergence): the
                                // combination runs but this case did not converge; listed.
                                Err(why) if why.starts_with("open: ") => {
                                    println!("open    {cell:?}: {why}");
                                    open.push(format!("{cell:?}: {why}"));
                                }
                                Err(why) => {
                                    println!("FAILED  {cell:?}: {why}");
                                    failed.push(format!("{cell:?}: {why}"));
                                }
                            }
                        }
                    }
                }
            }
        }
    }
    println!(
        "combination matrix: {green} green, {refused} refused by the library (named), {} open \
         (a solver error on this case), {} wrong",
        open.len(),
        failed.len()
    );
    // No cell gives a wrong answer, and none stops with a solver error: every cell the
    // physics allows runs (the last open ones, Neo-Hookean with obstacles, stopped where the
    // contact line search judged converging Newton steps by the round-off of Φ).
    assert!(
        failed.is_empty(),
        "{} cells failed:\n{}",
        failed.len(),
        failed.join("\n")
    );
    assert!(
        open.is_empty(),
        "{} cells stopped with a solver error:\n{}",
        open.len(),
        open.join("\n")
    );
    assert_eq!(green + refused, 4 * 2 * 5 * 3 * 2 * 2);
}
