//! A beam released under gravity, stepped by each integrator, and what each does to its energy.
//!
//! One idea: a [`Transient`] analysis steps a [`Definition`] in time with the chosen
//! [`Method`], and an observer sees every step. The beam is the default run's (steel,
//! 1 m × 0.1 m × 0.1 m, clamped at x = 0, 20×2×2 cubes of 4-node tets), at rest and released
//! under its weight, run for 25 ms (about two periods of its first bending mode, 82 Hz). The
//! observer records the tip's deflection and the total energy E = kinetic + elastic + gravity's
//! potential, which is 0 at the start. Newmark's average acceleration keeps E at 0 at a step of
//! 100 × the explicit critical step; backward Euler at the same step loses a large part of the
//! swing to numerical damping (E < 0); the explicit method must step below the critical step and
//! keeps E near 0 only up to its O(dt²) error.
//!
//! Prints, per method: the step, the number of steps, the lowest tip deflection and the final E
//! against the largest elastic energy of the swing.
//!
//! Run: `cargo run --release --example swinging_beam`

use tetfem::analysis::Definition;
use tetfem::analysis::dynamics::Method;
use tetfem::analysis::transient::{Flow, StepView, TimeStep, Transient, TransientOptions};
use tetfem::nalgebra::Vector3;
use tetfem::{BoxSplit, Constraints, Material, MaterialMap, TetMesh};

const DURATION: f64 = 0.025; // s, about two periods of the first bending mode

/// One run of `method`: its step (s), its step count, the lowest tip deflection (m) and the
/// final total energy relative to the swing's largest elastic energy (0 when conserved, −1 when
/// all is gone).
fn swing(
    beam: &Definition,
    tip_z: usize,
    method: Method,
    dt: TimeStep,
) -> tetfem::Result<(f64, usize, f64, f64)> {
    let mut run = Transient::new(beam, TransientOptions::new(method, dt))?;
    let steps = (DURATION / run.dt()).ceil() as usize;
    let (mut lowest_tip, mut peak_elastic, mut final_energy) = (0.0f64, 0.0f64, 0.0);
    let mut watch = |view: &StepView<'_>| {
        // The tip's z is a free DOF: the clamp is at the other end.
        if let Some(free) = view.system.dofs().free_index(tip_z) {
            lowest_tip = lowest_tip.min(view.state.displacement[free]);
        }
        let energy = view.force.energy(view.system, view.state)?;
        peak_elastic = peak_elastic.max(energy.elastic);
        final_energy = energy.kinetic + energy.elastic + energy.gravity_potential;
        Ok(Flow::Continue)
    };
    run.run((0, steps), &mut watch)?;
    Ok((run.dt(), steps, lowest_tip, final_energy / peak_elastic))
}

fn main() -> tetfem::Result<()> {
    let mesh = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(1.0, 0.1, 0.1),
        [20, 2, 2],
        BoxSplit::default(),
    )?;
    let tip_z = 3 * mesh.nodes_on_plane(0, 1.0, 1e-9)[0] + 2;
    let steel = MaterialMap::uniform(Material::steel(), mesh.tet_count());
    let mut constraints = Constraints::new(&mesh);
    constraints.fix_nodes(&mesh.nodes_on_plane(0, 0.0, 1e-9))?;
    let beam = Definition::builder(mesh, steel)
        .constraints(constraints)?
        .gravity(Vector3::new(0.0, 0.0, -9.81))? // m/s²
        .build()?;

    let runs = [
        (
            "Newmark",
            Method::Newmark,
            TimeStep::CriticalMultiple(100.0),
        ),
        (
            "backward Euler",
            Method::BackwardEuler,
            TimeStep::CriticalMultiple(100.0),
        ),
        (
            "explicit",
            Method::Explicit,
            TimeStep::CriticalMultiple(0.5),
        ),
    ];
    let mut drift = Vec::new();
    for (name, method, dt) in runs {
        let (dt, steps, lowest_tip, relative) = swing(&beam, tip_z, method, dt)?;
        println!(
            "{name:>14}: dt = {dt:.2e} s, {steps:>5} steps, lowest tip {lowest_tip:.3e} m, \
             final E / peak elastic = {relative:+.2e}"
        );
        assert!(lowest_tip < 0.0, "{name}: the tip must fall");
        drift.push(relative);
    }
    // Newmark conserves E exactly for a linear system under constant loads; what is left is
    // the linear solves' round-off, far below 1e-6 of the swing's energy.
    assert!(
        drift[0].abs() < 1e-6,
        "Newmark's energy drifted: {:e}",
        drift[0]
    );
    // Backward Euler damps ω·dt ≈ 0.25 per step (about 3 % of the amplitude per step):
    // after two periods most of the swing's energy is gone, far more than 10 %.
    assert!(
        drift[1] < -0.1,
        "backward Euler kept its energy: {:e}",
        drift[1]
    );
    // Symplectic Euler's energy oscillates by O((ω·dt)²) but does not drift away (measured
    // 5e-5 of the swing's energy; 1e-3 leaves room for another machine's round-off).
    assert!(
        drift[2].abs() < 1e-3,
        "the explicit method's energy drifted: {:e}",
        drift[2]
    );
    Ok(())
}
