//! Manufactured-solution convergence rates of the linear (P1) and the quadratic (P2) tet under
//! uniform refinement of the unit cube: L2 error O(h^{p+1}), energy error O(h^p).

use crate::common;

use common::manufactured::Manufactured;
use nalgebra::Vector3;
use tetfem::post::convergence::{Level, Study};
use tetfem::post::error_norms::{energy_error, l2_error};
use tetfem::post::estimate::PointwiseElement;
use tetfem::{BoxSplit, Constraints, Loads, Material, Tet4, Tet10, TetMesh, solve_static};

/// The L2 and energy studies of one element over boxes of `cells`³ cubes.
fn study<E: PointwiseElement>(
    cells: &[usize],
    to_element: impl Fn(TetMesh) -> TetMesh<E>,
) -> (Study, Study) {
    let material = Material::new(1e3, 0.3, 1.0).unwrap();
    let exact = Manufactured::new();
    let (mut l2, mut energy) = (Vec::new(), Vec::new());
    for &n in cells {
        let linear = TetMesh::box_grid(
            Vector3::zeros(),
            Vector3::repeat(1.0),
            [n; 3],
            BoxSplit::Lecture6,
        )
        .unwrap();
        let mesh = to_element(linear);
        // Dirichlet data from u at every boundary node, corners and mid-edge nodes alike (their
        // coordinates are exactly 0 or 1 on the faces: midpoints of 0s or of 1s).
        let mut constraints = Constraints::new(&mesh);
        for node in mesh.nodes_where(|p| (0..3).any(|a| p[a] == 0.0 || p[a] == 1.0)) {
            constraints
                .prescribe(node, exact.displacement(&mesh.nodes()[node]))
                .unwrap();
        }
        let mut loads = Loads::new(&mesh);
        loads
            .add_body_force_field(&mesh, |p| exact.body_force(p, &material))
            .unwrap();
        let solution = solve_static(&mesh, &material, &constraints, &loads).unwrap();
        let e_l2 = l2_error(&mesh, &solution.displacement, |p| exact.displacement(p)).unwrap();
        let e_energy = energy_error(&mesh, &material, &solution.displacement, |p| {
            exact.gradient(p)
        })
        .unwrap();
        let h = 1.0 / n as f64;
        println!(
            "P{} n = {n:>2}: h = {h:.4}, DOFs {:>6}, L2 error {e_l2:.4e}, energy error {e_energy:.4e}",
            E::DEGREE,
            mesh.dof_count()
        );
        let level = |error| Level {
            h,
            dofs: mesh.dof_count(),
            error,
            seconds: 0.0,
        };
        l2.push(level(e_l2));
        energy.push(level(e_energy));
    }
    let (l2, energy) = (Study::new(l2).unwrap(), Study::new(energy).unwrap());
    println!(
        "P{}: L2 orders {:?} (fit {:.3}), energy orders {:?} (fit {:.3})",
        E::DEGREE,
        l2.observed_orders(),
        l2.fitted_order().unwrap(),
        energy.observed_orders(),
        energy.fitted_order().unwrap()
    );
    (l2, energy)
}

/// The order between the two finest levels: the asymptotic rate is what the a-priori estimate
/// predicts, and the coarsest level (3 cells per side for P2) is not yet in that range, so a
/// fit over all levels would mix in its pre-asymptotic slope.
fn finest_order(study: &Study) -> f64 {
    *study.observed_orders().last().unwrap()
}

#[test]
fn p1_converges_at_order_two_in_l2_and_one_in_energy() {
    let (l2, energy) = study::<Tet4>(&[6, 12, 24], |mesh| mesh);
    // ±0.15: the bound; the rate of a smooth solution on a uniformly refined mesh
    // approaches p + 1 and p from below, and a wrong load or norm shifts it by ≥ 0.5.
    assert!((finest_order(&l2) - 2.0).abs() < 0.15, "{l2:?}");
    assert!((finest_order(&energy) - 1.0).abs() < 0.15, "{energy:?}");
}

#[test]
fn p2_converges_at_order_three_in_l2_and_two_in_energy() {
    // Finest: 12³ cells, 25³ nodes = 46 875 DOFs (≤ 60k for the test's time).
    let (l2, energy) = study::<Tet10>(&[3, 6, 12], |linear| {
        TetMesh::<Tet10>::from_linear(&linear).unwrap()
    });
    // ±0.15 as for P1; an element that were only P1-accurate (e.g. a wrong mid-edge load or
    // mid-edge boundary value) would show orders 2 and 1.
    assert!((finest_order(&l2) - 3.0).abs() < 0.15, "{l2:?}");
    assert!((finest_order(&energy) - 2.0).abs() < 0.15, "{energy:?}");
}
