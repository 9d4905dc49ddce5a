//! Gravity: the load's resultant is exactly ρ·g·V, and a body far from its supports falls as
//! backward Euler's discrete free fall −g·dt²·n(n+1)/2 (`shared/peers/RESULTS.md`, "Backward
//! Euler dynamics").

use std::sync::Arc;

use nalgebra::Vector3;
use tetfem::analysis::dynamics::{LinearSystem, MassKind, Method, Rayleigh, State};
use tetfem::{BoxSplit, Loads, Material, TetMesh};
use tetfem_fixtures::cantilever::Cantilever;

const G: f64 = 9.81;

#[test]
fn gravity_resultant_is_rho_g_v() {
    let material = Material::new(1e5, 0.3, 1000.0).unwrap();
    for (size, cells, split) in [
        (Vector3::new(10.0, 1.0, 1.0), [20, 2, 2], BoxSplit::Lecture6),
        (Vector3::new(2.0, 0.7, 0.3), [5, 3, 2], BoxSplit::Five),
    ] {
        let mesh = TetMesh::box_grid(Vector3::zeros(), size, cells, split).unwrap();
        let mut loads = Loads::new(&mesh);
        loads
            .add_gravity(&mesh, &material, Vector3::new(0.0, 0.0, -G))
            .unwrap();
        let resultant = loads.resultant();
        let exact = -material.density() * G * size.x * size.y * size.z;
        // Each tet gives ρ·g·V_tet/4 to each of its nodes and the tets tile the box: only the
        // summation's round-off (a few ulps per term, 1e-16 × a few hundred terms) remains.
        let error = ((resultant.z - exact) / exact).abs();
        println!(
            "{cells:?} {split:?}: resultant {:.15e}, ρgV {exact:.15e}, {error:.1e}",
            resultant.z
        );
        assert!(error <= 1e-12, "{cells:?}: {} vs {exact}", resultant.z);
        assert!(
            resultant.x.abs() <= 1e-12 * exact.abs() && resultant.y.abs() <= 1e-12 * exact.abs()
        );
    }
}

/// Mean z-displacement of the tip nodes after each of `steps` backward-Euler steps of the
/// peer benchmark beam under gravity alone, from rest.
fn tip_history(cells: [usize; 3], mass: MassKind, dt: f64, steps: usize) -> Vec<f64> {
    let problem = Cantilever {
        end_load: 0.0,
        ..Cantilever::peer_benchmark(cells)
    };
    let mesh = problem.mesh().unwrap();
    let constraints = problem.constraints(&mesh).unwrap();
    let system = Arc::new(
        LinearSystem::new(
            &mesh,
            &problem.material,
            &constraints,
            &Loads::new(&mesh),
            Vector3::new(0.0, 0.0, -G),
            mass,
            Rayleigh::default(),
        )
        .unwrap(),
    );
    let tip: Vec<usize> = problem
        .tip_nodes(&mesh)
        .iter()
        .map(|&n| system.dofs().free_index(3 * n + 2).unwrap())
        .collect();
    let mut integrator = Method::BackwardEuler
        .integrator(Arc::clone(&system), dt)
        .unwrap();
    let mut state = State::at_rest(system.free_count());
    (0..steps)
        .map(|_| {
            integrator.step(&mut state).unwrap();
            tip.iter().map(|&i| state.displacement[i]).sum::<f64>() / tip.len() as f64
        })
        .collect()
}

#[test]
fn backward_euler_tip_falls_as_the_discrete_free_fall() {
    // ρ = 1000, E = 1e5: the first bending period is about 62 s, so over 0.1 s the free end is
    // in free fall. Backward Euler on a free mass: v_n = n·g·dt, u_n = dt·Σv_k = −g·dt²·n(n+1)/2
    // (downward). The peers (80×8×8 and 160×16×16) match it to their 10 printed digits.
    let dt = 1e-3;
    let steps = 100;
    for cells in [[20, 2, 2], [40, 4, 4]] {
        for mass in [MassKind::Lumped, MassKind::Consistent] {
            let history = tip_history(cells, mass, dt, steps);
            let mut worst: f64 = 0.0;
            for (k, tip) in history.iter().enumerate() {
                let n = (k + 1) as f64;
                let exact = -G * dt * dt * n * (n + 1.0) / 2.0;
                worst = worst.max(((tip - exact) / exact).abs());
            }
            println!(
                "{cells:?} {mass:?}: tip at step {steps} {:.12e}, max relative deviation {worst:.1e}",
                history[steps - 1]
            );
            // The clamp's influence reaches the tip, 10 m away, only through the implicit
            // solve's exponentially decaying coupling, far below round-off; what remains is the
            // solves' round-off: measured ≤ 1.8e-14 (consistent mass, 20×2×2), ≤ 1e-15 lumped.
            // 1e-12 leaves room for other kernels (scalar vs AVX2) and orderings; a gravity
            // off by 1 % or a step off by one misses it by ten orders of magnitude.
            assert!(worst <= 1e-12, "{cells:?} {mass:?}: deviation {worst:e}");
        }
    }
    // The peers' value at step 100: −4.954050000e-02 (80×8×8, 160×16×16, 200×20×20), printed to
    // 10 digits: half a unit of the last digit is 1e-10 relative.
    let history = tip_history([20, 2, 2], MassKind::Lumped, dt, steps);
    assert!(((history[steps - 1] + 4.954050000e-02) / 4.954050000e-02).abs() <= 2e-10);
}
