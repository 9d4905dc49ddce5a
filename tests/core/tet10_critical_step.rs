//! The explicit critical step on 10-node tets: the element bound of any element type
//! (`element_step_bound_of_type`, a dense lumped-mass eigenproblem per element) against the
//! linear tet's own bound and against the assembled system's step.

use nalgebra::{DMatrix, Vector3};
use tetfem::analysis::dynamics::{
    LinearSystem, Mass, MassKind, Rayleigh, critical_time_step, element_step_bound_of,
    element_step_bound_of_type,
};
use tetfem::{BoxSplit, Constraints, Loads, Material, Tet10, TetMesh};

fn box_mesh(cells: [usize; 3], split: BoxSplit) -> TetMesh {
    // A skewed box (unequal sides) so that the tets are not all alike.
    TetMesh::box_grid(Vector3::zeros(), Vector3::new(2.0, 0.7, 0.45), cells, split).expect("box")
}

/// On the linear tet the generic bound is the linear tet's own one: the same eigenvalue, once
/// of Kₑ/(ρV/4) and once of M^(−1/2)KₑM^(−1/2) with equal masses.
#[test]
fn generic_element_bound_equals_the_linear_tets_on_tet4() {
    let material = Material::new(70e9, 0.33, 2700.0).expect("material");
    for split in [BoxSplit::Lecture6, BoxSplit::Mirrored6, BoxSplit::Five] {
        let mesh = box_mesh([3, 2, 2], split);
        let own = element_step_bound_of(&mesh, &material).expect("own");
        let generic = element_step_bound_of_type(&mesh, &material).expect("generic");
        // Two eigensolves of matrices equal up to one rounding per entry: 1e-12 relative.
        let relative = (own.dt_element - generic.dt_element).abs() / own.dt_element;
        assert!(relative < 1e-12, "{split:?}: {relative:e}");
        assert_eq!(own.dt_geometric, generic.dt_geometric);
    }
}

/// The global 2/ω_max of a small P2 system from a dense symmetric eigensolve of
/// M^(−1/2)·K_ff·M^(−1/2), against `critical_time_step` (certified from above, so never
/// above the dense one by more than round-off) and the element bound (never above either).
#[test]
fn tet10_critical_step_matches_the_dense_eigenvalue_and_bounds_it_from_the_elements() {
    let material = Material::new(200e9, 0.3, 7850.0).expect("steel");
    for split in [BoxSplit::Lecture6, BoxSplit::Five] {
        let mesh = TetMesh::<Tet10>::from_linear(&box_mesh([2, 1, 1], split)).expect("P2");
        let mut constraints = Constraints::new(&mesh);
        let clamp = mesh.try_nodes_on_plane(0, 0.0, 1e-9).expect("clamp");
        constraints.fix_axes(&clamp, [true; 3]).expect("fix");
        let system = LinearSystem::new(
            &mesh,
            &material,
            &constraints,
            &Loads::new(&mesh),
            Vector3::zeros(),
            MassKind::Lumped,
            Rayleigh::default(),
        )
        .expect("system");
        let Mass::Lumped(mass) = system.mass() else {
            panic!("lumped mass asked for");
        };
        let n = system.free_count();
        let mut a = DMatrix::<f64>::zeros(n, n);
        let (mut e, mut column) = (vec![0.0; n], vec![0.0; n]);
        for j in 0..n {
            e[j] = 1.0;
            system.stiffness().mul_vec(&e, &mut column).expect("K e_j");
            e[j] = 0.0;
            for i in 0..n {
                a[(i, j)] = column[i] / (mass[i] * mass[j]).sqrt();
            }
        }
        let omega_max = a
            .symmetric_eigenvalues()
            .iter()
            .fold(0.0f64, |m, &v| m.max(v))
            .sqrt();
        let dense = 2.0 / omega_max;
        let step = critical_time_step(&system).expect("critical step").dt;
        let bound = element_step_bound_of_type(&mesh, &material)
            .expect("bound")
            .dt_element;
        println!(
            "{split:?} P2 2×1×1 ({n} DOFs): dense {dense:e}, certified {step:e}, element bound {bound:e}"
        );
        // Certified from above on ω_max (so ≤ the dense step), and within the power
        // iteration's bracket (1e-3 relative on ω², so at most 5e-4 on the step) below it.
        assert!(step <= dense * (1.0 + 1e-12), "{step:e} > {dense:e}");
        assert!(step >= dense * (1.0 - 1e-3), "{step:e} ≪ {dense:e}");
        // The element eigenvalue theorem: the element bound is never above the true step.
        assert!(bound <= dense * (1.0 + 1e-12), "{bound:e} > {dense:e}");
        assert!(bound <= step * (1.0 + 1e-12), "{bound:e} > {step:e}");
    }
}
