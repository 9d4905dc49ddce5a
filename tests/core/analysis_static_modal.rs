//! `tetfem::analysis::{Static, Modal}` (issue 34, item 1): the one static dispatch gives what
//! the entry points it replaces gave (the linear `StaticSolver`, Newton, Newton with contact),
//! bit for bit, and its reactions balance the loads and the obstacles' forces; the modal
//! analysis refuses a nonlinear model with the library's named error and finds the modes the
//! old `lowest_modes` call found.

use nalgebra::Vector3;
use tetfem::analysis::dynamics::{LinearSystem, MassKind, Rayleigh};
use tetfem::analysis::modal::lowest_modes;
use tetfem::analysis::nonlinear::{
    NewtonOptions, solve_nonlinear_static, solve_nonlinear_static_with_contact,
};
use tetfem::analysis::statics::StaticSolver;
use tetfem::analysis::{Definition, Modal, Static, StaticOptions};
use tetfem::contact::{Contact, ContactParameters, Obstacle};
use tetfem::fe::materials::MaterialMap;
use tetfem::model::ModelKind;
use tetfem::{BoxSplit, Constraints, Error, Loads, Material, TetMesh};

const LENGTH: f64 = 0.4;
/// The tip load (N, along −z): ~1 mm of tip deflection on the rubber block, enough to press
/// its tip on the ground below.
const TIP_LOAD: f64 = 0.5;
/// The ground's distance below the block (m): half the free tip's deflection on this mesh
/// (3.0e-4 m), so that an exact contact carries part of the load. (At 5e-4 m, beyond the free
/// tip but inside the barrier's reach d̂ = 4.2e-4 m, only the barrier's push from a distance
/// did, which the static solve's continuation of d̂ removes.)
const GROUND_GAP: f64 = 1.5e-4;

/// A rubber block 0.4 × 0.1 × 0.1 m (E = 1 MPa) clamped at x = 0, the tip load at x = L,
/// and, with `ground`, a frictionless ground under it.
fn definition(model: ModelKind, ground: bool) -> Definition {
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
    constraints
        .fix_nodes(&mesh.nodes_on_plane(0, 0.0, 1e-9))
        .unwrap();
    let tip = mesh.nodes_on_plane(0, LENGTH, 1e-9);
    let mut loads = Loads::new(&mesh);
    for &n in &tip {
        let share = Vector3::new(0.0, 0.0, -TIP_LOAD / tip.len() as f64);
        loads.add_nodal_force(n, share).unwrap();
    }
    let contact = ground.then(|| {
        let ground =
            Obstacle::half_space("ground", Vector3::new(0.0, 0.0, -GROUND_GAP), Vector3::z())
                .unwrap();
        let parameters = ContactParameters::for_mesh(&mesh, 2e6).unwrap();
        Contact::new(&mesh, vec![ground], parameters).unwrap()
    });
    let builder = Definition::builder(mesh, materials)
        .model(model)
        .constraints(constraints)
        .unwrap()
        .loads(loads)
        .unwrap();
    match contact {
        Some(contact) => builder.contact(contact).build().unwrap(),
        None => builder.build().unwrap(),
    }
}

/// The displacement the entry points before `Static` gave for `d`.
fn old_displacement(d: &Definition) -> Vec<f64> {
    let models = d.model.build_map(&d.materials);
    match (d.model, &d.contact) {
        (ModelKind::Linear, None) => {
            let mut solver = StaticSolver::with_options(
                &d.mesh,
                &d.materials,
                &d.constraints,
                Default::default(),
            )
            .unwrap();
            solver.solve(&d.loads).unwrap().displacement
        }
        (_, None) => {
            solve_nonlinear_static(
                &d.mesh,
                &models,
                &d.constraints,
                &d.loads,
                NewtonOptions::default(),
            )
            .unwrap()
            .displacement
        }
        (_, Some(contact)) => {
            solve_nonlinear_static_with_contact(
                &d.mesh,
                &models,
                &d.constraints,
                &d.loads,
                contact,
                NewtonOptions::default(),
            )
            .unwrap()
            .displacement
        }
    }
}

#[test]
fn static_matches_the_old_entry_points_and_its_reactions_balance() {
    for model in [ModelKind::Linear, ModelKind::Corotational] {
        for ground in [false, true] {
            let d = definition(model, ground);
            let analysis = Static::new(&d, StaticOptions::default()).unwrap();
            let outcome = analysis.solve().unwrap();
            // The same calls in the same order: bit-identical, not only close.
            assert_eq!(
                outcome.displacement,
                old_displacement(&d),
                "{model:?}, ground {ground}"
            );
            // Σ R + Σ f − Σ F_obstacle = 0 per axis (F the force on the obstacle, −F the one on
            // the body). The element forces sum to zero up to round-off, so what remains is
            // the free residual: ≤ √n·‖r_f‖ ≤ √243·1e-10·‖f‖ for Newton (its tolerance),
            // ~1e-12·‖f‖ for the linear solve; 1e-8 of the load leaves room for both.
            let mut balance = Vector3::zeros();
            for (dof, (r, f)) in outcome.reactions.iter().zip(d.loads.as_slice()).enumerate() {
                balance[dof % 3] += r + f;
            }
            for force in &outcome.obstacle_forces {
                balance -= force;
            }
            println!("{model:?}, ground {ground}: imbalance {balance:?} N");
            assert!(
                balance.norm() <= 1e-8 * TIP_LOAD,
                "{model:?}, ground {ground}: imbalance {balance:?} N"
            );
            // The ground must carry part of the load for the case to test the contact term.
            if ground {
                assert!(outcome.obstacle_forces[0].z < -1e-3 * TIP_LOAD);
            }
            assert_eq!(outcome.newton_counts().is_none(), analysis.is_linear_path());
        }
    }
}

#[test]
fn static_stresses_and_estimate_follow_the_model() {
    let linear = definition(ModelKind::Linear, false);
    let analysis = Static::new(&linear, StaticOptions::default()).unwrap();
    let outcome = analysis.solve().unwrap();
    let estimate = analysis.estimated_error(&outcome.displacement).unwrap();
    // A coarse 4-cell block under a tip load: a real, non-zero error below 100 %.
    assert!(estimate.relative() > 0.0 && estimate.relative() < 1.0);
    let von_mises = analysis.von_mises(&outcome.displacement).unwrap();
    assert_eq!(von_mises.len(), linear.mesh.tet_count());
    assert!(von_mises.iter().all(|s| *s > 0.0));
    let corotational = definition(ModelKind::Corotational, false);
    let analysis = Static::new(&corotational, StaticOptions::default()).unwrap();
    let outcome = analysis.solve().unwrap();
    match analysis.estimated_error(&outcome.displacement) {
        Err(Error::InvalidParameter { name, .. }) => assert!(name.contains("model"), "{name}"),
        other => panic!("expected the named refusal, got {other:?}"),
    }
}

#[test]
fn modal_refuses_a_nonlinear_model_by_name() {
    let d = definition(ModelKind::NeoHookean, false);
    match Modal::new(&d, MassKind::Lumped) {
        Err(Error::InvalidParameter { name, value, .. }) => {
            assert_eq!(name, "model with analysis modal");
            assert_eq!(value, "neo-hookean");
        }
        Err(other) => panic!("expected the named refusal, got {other}"),
        Ok(_) => panic!("a modal analysis with a nonlinear model must be refused"),
    }
}

#[test]
fn modal_matches_the_old_modal_path() {
    let d = definition(ModelKind::Linear, false);
    for mass in [MassKind::Lumped, MassKind::Consistent] {
        let analysis = Modal::new(&d, mass).unwrap();
        let outcome = analysis.solve(4).unwrap();
        let system = LinearSystem::new(
            &d.mesh,
            &d.materials,
            &d.constraints,
            &Loads::new(&d.mesh),
            Vector3::zeros(),
            mass,
            Rayleigh::default(),
        )
        .unwrap();
        let old = lowest_modes(&system, 4).unwrap();
        // The same K, M and subspace iteration: the same frequencies, bit for bit.
        assert_eq!(outcome.modes.omega, old.omega, "{mass:?}");
        assert_eq!(outcome.modes.shapes, old.shapes, "{mass:?}");
        let fractions = analysis.effective_mass_fractions(&outcome).unwrap();
        assert!(fractions.iter().flatten().all(|f| (0.0..=1.0).contains(f)));
    }
}
