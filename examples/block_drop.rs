//! A soft block dropped on rigid ground: contact with an obstacle in a transient analysis.
//!
//! One idea: contact is part of the problem, not of the solver. A [`Contact`] (obstacles plus
//! [`ContactParameters`]) goes into the [`Definition`] like the constraints and gravity, and the
//! same [`Transient`] analysis as for any other problem steps it, through Newton with the IPC
//! barrier. The block is 0.2 m of rubber (E = 0.1 MPa, ν = 0.3, ρ = 1000 kg/m³, neo-Hookean),
//! 4×4×4 cubes of 4-node tets, released 2 cm above a frictionless ground (the half-space
//! z ≥ 0); backward Euler with 5 ms steps (about twice the explicit critical step: the fall of
//! √(2·0.02/9.81) = 64 ms takes 13 of them), for 0.3 s.
//!
//! Prints the lowest node's height every six steps; asserts that no node ever reaches the ground
//! (the barrier keeps every gap > 0), that the block falls into the barrier's reach (gap below
//! the activation distance d̂) and that it ends at rest on it.
//!
//! Run: `cargo run --release --example block_drop`

use tetfem::analysis::Definition;
use tetfem::analysis::dynamics::Method;
use tetfem::analysis::transient::{Flow, StepView, TimeStep, Transient, TransientOptions};
use tetfem::contact::{Contact, ContactParameters, Obstacle};
use tetfem::model::ModelKind;
use tetfem::nalgebra::Vector3;
use tetfem::{BoxSplit, Constraints, Material, MaterialMap, TetMesh};

const SIDE: f64 = 0.2; // m
const DROP: f64 = 0.02; // m, the block's bottom above the ground at the start
const STEPS: usize = 60; // of 5 ms

fn main() -> tetfem::Result<()> {
    let mesh = TetMesh::box_grid(
        Vector3::new(0.0, 0.0, DROP),
        Vector3::new(SIDE, SIDE, DROP + SIDE),
        [4, 4, 4],
        BoxSplit::default(),
    )?;
    let rubber = Material::new(1e5, 0.3, 1000.0)?; // Pa, -, kg/m³
    // Frictionless ground leaves x, y and the turn about z free: hold them on the block's two
    // mirror planes, where the symmetric motion has no x (resp. y) component anyway.
    let mut constraints = Constraints::new(&mesh);
    constraints.fix_axes(
        &mesh.nodes_on_plane(0, 0.5 * SIDE, 1e-9),
        [true, false, false],
    )?;
    constraints.fix_axes(
        &mesh.nodes_on_plane(1, 0.5 * SIDE, 1e-9),
        [false, true, false],
    )?;
    let ground = Obstacle::half_space("ground", Vector3::zeros(), Vector3::z())?;
    let parameters = ContactParameters::for_mesh(&mesh, rubber.youngs_modulus())?;
    let d_hat = parameters.activation_distance; // m
    let contact = Contact::new(&mesh, vec![ground], parameters)?;
    let rest_z: Vec<f64> = mesh.nodes().iter().map(|p| p.z).collect();
    let materials = MaterialMap::uniform(rubber, mesh.tet_count());
    let block = Definition::builder(mesh, materials)
        .model(ModelKind::NeoHookean)
        .constraints(constraints)?
        .gravity(Vector3::new(0.0, 0.0, -9.81))? // m/s²
        .contact(contact)
        .build()?;

    let options = TransientOptions::new(Method::BackwardEuler, TimeStep::Seconds(5e-3));
    let mut run = Transient::new(&block, options)?;
    let mut heights = Vec::new();
    let mut watch = |view: &StepView<'_>| {
        // The full displacement (the held components too) at the step's time.
        let u = view
            .system
            .expand_at(view.state.time, &view.state.displacement)?;
        let lowest = rest_z
            .iter()
            .enumerate()
            .map(|(n, z)| z + u[3 * n + 2])
            .fold(f64::INFINITY, f64::min);
        if view.step.is_multiple_of(6) {
            println!(
                "t = {:.3} s: lowest node at {lowest:.3e} m",
                view.state.time
            );
        }
        heights.push(lowest);
        Ok(Flow::Continue)
    };
    run.run((0, STEPS), &mut watch)?;
    println!("dt = {:.3e} s, d̂ = {d_hat:.3e} m", run.dt());

    // The barrier's promise: no node on or below the ground at any step, not merely at the end.
    let lowest = heights.iter().copied().fold(f64::INFINITY, f64::min);
    assert!(lowest > 0.0, "a node reached the ground: {lowest:e} m");
    // It fell the 2 cm into the barrier's reach, and rests there: the last height within d̂.
    assert!(
        lowest < d_hat,
        "the block never reached the ground ({lowest:e} m)"
    );
    let last = heights[STEPS - 1];
    assert!(
        last < d_hat,
        "the block did not come to rest on the ground ({last:e} m)"
    );
    Ok(())
}
