//! The quadratic 10-node tet through the element seam: its reference data against independent
//! quadrature, and the whole static path (assembly, constraints, loads, solve, output) on it.

use crate::common;

use nalgebra::{Matrix3, Vector3};
use tetfem::fe::element::tet10::{self, EDGES, REFERENCE_MASS};
use tetfem::fe::element::{ElementType, Tet};
use tetfem::fe::quadrature::tet_rule;
use tetfem::mesh::BoundaryFace;
use tetfem::post::output::fields::{cell_strain_energy_density, cell_stress};
use tetfem::post::output::{VtuFormat, VtuWriter};
use tetfem::{
    Assembler, BoxSplit, CellType, Constraints, Error, Loads, Material, Tet4, Tet10, TetMesh,
    lumped_mass, solve_static,
};

fn barycentric(b: &Vector3<f64>) -> [f64; 4] {
    [1.0 - b.x - b.y - b.z, b.x, b.y, b.z]
}

/// Round-off of sums of O(1) terms over 64 quadrature points.
const RULE_TOLERANCE: f64 = 1e-14;

#[test]
fn shape_functions_are_nodal_and_sum_to_one() {
    let mut nodes = vec![
        [1.0, 0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ];
    for (i, j) in EDGES {
        let mut l = [0.0; 4];
        l[i] = 0.5;
        l[j] = 0.5;
        nodes.push(l);
    }
    for (k, l) in nodes.iter().enumerate() {
        let n = tet10::shape_values(l);
        for (m, value) in n.iter().enumerate() {
            assert_eq!(*value, if m == k { 1.0 } else { 0.0 }, "N{m} at node {k}");
        }
    }
    for q in tet_rule() {
        let sum: f64 = tet10::shape_values(&barycentric(&q.barycentric))
            .iter()
            .sum();
        assert!((sum - 1.0).abs() < RULE_TOLERANCE, "ΣN = {sum}");
    }
}

#[test]
fn reference_mass_matches_the_degree_five_rule() {
    // ∫NᵢNⱼ is degree 4: the 64-point rule integrates it exactly, independently of the closed
    // form the element uses.
    let rule = tet_rule();
    for i in 0..10 {
        for j in 0..10 {
            let integral: f64 = rule
                .iter()
                .map(|q| {
                    let n = tet10::shape_values(&barycentric(&q.barycentric));
                    q.weight * n[i] * n[j]
                })
                .sum();
            assert!(
                (integral - REFERENCE_MASS[i][j]).abs() < RULE_TOLERANCE,
                "m̂[{i}][{j}] = {} but the rule gives {integral}",
                REFERENCE_MASS[i][j]
            );
        }
    }
    // Row sums are ∫Nᵢ dV / V, which the consistent body load uses.
    for i in 0..10 {
        let row: f64 = REFERENCE_MASS[i].iter().sum();
        let load = Tet10::VOLUME_LOAD.share(i, 1.0);
        assert!(
            (row - load).abs() < RULE_TOLERANCE,
            "row {i}: {row} vs {load}"
        );
    }
}

fn skewed_tet() -> [Vector3<f64>; 4] {
    [
        Vector3::new(0.1, -0.2, 0.05),
        Vector3::new(1.3, 0.1, -0.1),
        Vector3::new(0.2, 0.9, 0.3),
        Vector3::new(-0.1, 0.3, 1.1),
    ]
}

/// One element as a mesh (corners 0–3, edge nodes 4–9 at the midpoints).
fn one_element() -> TetMesh<Tet10> {
    let linear = TetMesh::new(skewed_tet().to_vec(), vec![[0, 1, 2, 3]]).unwrap();
    TetMesh::<Tet10>::from_linear(&linear).unwrap()
}

#[test]
fn stiffness_blocks_match_an_independent_quadrature_of_btdb() {
    // The element integrates with the 4-point degree-2 rule; the reference here uses the 64-point
    // degree-5 rule on Bᵀ D B with D = the material's engineering-shear matrix.
    let material = Material::new(70e9, 0.33, 2700.0).unwrap();
    let mesh = one_element();
    let tet = Tet::new(&skewed_tet()).unwrap();
    let rest = tet10::Tet10Rest::new(&tet);
    let d = material.engineering_stiffness();
    let dl = *tet.shape_gradients();
    let mut reference = vec![[[0.0; 3]; 3]; 100];
    for q in tet_rule() {
        let g = tet10::shape_gradients(&barycentric(&q.barycentric), &dl);
        let b = |i: usize| {
            let g = g[i];
            nalgebra::SMatrix::<f64, 6, 3>::new(
                g.x, 0.0, 0.0, 0.0, g.y, 0.0, 0.0, 0.0, g.z, g.y, g.x, 0.0, 0.0, g.z, g.y, g.z,
                0.0, g.x,
            )
        };
        for i in 0..10 {
            for j in 0..10 {
                let k = b(i).transpose() * d * b(j) * (q.weight * tet.volume());
                for a in 0..3 {
                    for c in 0..3 {
                        // block[a][b] = row 3i + b, column 3j + a
                        reference[10 * i + j][a][c] += k[(c, a)];
                    }
                }
            }
        }
    }
    let scale = material.youngs_modulus() * tet.volume().cbrt();
    // The assembled one-element matrix holds exactly the element's blocks (the scatter map at
    // n = 10), and those match the reference.
    let k = Assembler::new(&mesh).stiffness(&mesh, &material).unwrap();
    for i in 0..10 {
        for j in 0..10 {
            let block = Tet10::stiffness_block(
                &rest,
                material.lame_lambda(),
                material.shear_modulus(),
                i,
                j,
            );
            let (gi, gj) = (mesh.tets()[0][i], mesh.tets()[0][j]);
            for a in 0..3 {
                for c in 0..3 {
                    let diff = (block[a][c] - reference[10 * i + j][a][c]).abs();
                    // Round-off of sums of ~100 terms of size E·h relative to E·h.
                    assert!(diff < 1e-12 * scale, "K[{i}{j}][{a}][{c}] off by {diff:e}");
                    assert_eq!(k.get(3 * gi + c, 3 * gj + a), Some(block[a][c]));
                }
            }
        }
    }
}

#[test]
fn rigid_motions_cost_no_force_and_masses_add_up() {
    let material = Material::new(1e6, 0.3, 1100.0).unwrap();
    let linear = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(2.0, 1.0, 1.0),
        [2, 2, 2],
        BoxSplit::Mirrored6,
    )
    .unwrap();
    let mesh = TetMesh::<Tet10>::from_linear(&linear).unwrap();
    let k = tetfem::fe::assembly::stiffness_matrix(&mesh, &material).unwrap();
    let rotation = Matrix3::new(0.0, -0.3, 0.2, 0.3, 0.0, -0.1, -0.2, 0.1, 0.0);
    let u: Vec<f64> = mesh
        .nodes()
        .iter()
        .flat_map(|p| {
            let v = rotation * p + Vector3::new(0.5, -1.0, 2.0);
            [v.x, v.y, v.z]
        })
        .collect();
    let force = k.mul(&u).unwrap();
    let largest = k.values().iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let worst = force.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    // K·u of an infinitesimal rigid motion is zero up to round-off of the row sums (~1e-14 of
    // the largest entry times |u| ~ 2).
    assert!(worst < 1e-13 * largest, "rigid motion force {worst:e}");

    let volume = 2.0;
    let lumped = lumped_mass(&mesh, &material);
    assert!(lumped.iter().all(|&m| m > 0.0), "HRZ lumping is positive");
    let total: f64 = lumped.iter().step_by(3).sum();
    assert!((total - material.density() * volume).abs() < 1e-12 * total);
    // The consistent mass gives the same total: Σᵢⱼ Mᵢⱼ (one axis) = ρV.
    let m = Assembler::new(&mesh)
        .consistent_mass(&mesh, &material)
        .unwrap();
    let ones: Vec<f64> = (0..mesh.dof_count())
        .map(|d| if d % 3 == 0 { 1.0 } else { 0.0 })
        .collect();
    let consistent: f64 = m.mul(&ones).unwrap().iter().step_by(3).sum();
    assert!((consistent - material.density() * volume).abs() < 1e-12 * consistent);
    // Gravity: the consistent load sums to ρ·g·V although the corners carry negative shares.
    let mut loads = Loads::new(&mesh);
    loads
        .add_gravity(&mesh, &material, Vector3::new(0.0, 0.0, -9.81))
        .unwrap();
    let resultant = loads.resultant();
    let expected = -9.81 * material.density() * volume;
    assert!((resultant.z - expected).abs() < 1e-12 * expected.abs());
    assert!(
        loads.as_slice().iter().any(|&f| f > 0.0),
        "corner shares −ρgV/20 point up"
    );
}

/// A quadratic displacement field with its gradient at x.
fn quadratic(x: &Vector3<f64>) -> Vector3<f64> {
    Vector3::new(
        1e-3 * (x.x * x.x + 0.5 * x.y * x.z - 0.3 * x.z),
        1e-3 * (0.7 * x.x * x.y - 0.2 * x.z * x.z + 0.1),
        1e-3 * (0.4 * x.y * x.y + 0.6 * x.x * x.z + 0.2 * x.x),
    )
}

/// The body force b = −∇·σ of [`quadratic`] (constant: σ is linear).
fn body_force(material: &Material) -> Vector3<f64> {
    // ∂²u: u_x = x² + ½yz − 0.3z → ∂xx = 2, ∂yz = ½; u_y = 0.7xy − 0.2z² → ∂xy = 0.7, ∂zz = −0.4;
    // u_z = 0.4y² + 0.6xz + 0.2x → ∂yy = 0.8, ∂xz = 0.6 (all ×1e-3).
    let (l, m) = (material.lame_lambda(), material.shear_modulus());
    // div u = 2x + 0.7x + 0.6x (×1e-3): ∇(div u) = (3.3, 0, 0)·1e-3.
    let grad_div = Vector3::new(3.3e-3, 0.0, 0.0);
    // Δu = (2, −0.4, 0.8)·1e-3.
    let laplacian = Vector3::new(2e-3, -0.4e-3, 0.8e-3);
    // ∇·σ = (λ + μ)∇(∇·u) + μΔu.
    -((grad_div * (l + m)) + laplacian * m)
}

/// Solves the problem with `u = quadratic` on the boundary and the matching body force; returns
/// the largest nodal error relative to the largest displacement.
fn patch_error<E: ElementType>(mesh: &TetMesh<E>, material: &Material) -> f64 {
    let (lo, hi) = mesh.bounding_box();
    let on_boundary = |p: &Vector3<f64>| {
        (0..3).any(|a| (p[a] - lo[a]).abs() < 1e-12 || (p[a] - hi[a]).abs() < 1e-12)
    };
    let mut constraints = Constraints::new(mesh);
    for (n, p) in mesh.nodes().iter().enumerate() {
        if on_boundary(p) {
            constraints.prescribe(n, quadratic(p)).unwrap();
        }
    }
    let mut loads = Loads::new(mesh);
    loads.add_body_force(mesh, body_force(material)).unwrap();
    let solution = solve_static(mesh, material, &constraints, &loads).unwrap();
    let mut worst: f64 = 0.0;
    let mut largest: f64 = 0.0;
    for (n, p) in mesh.nodes().iter().enumerate() {
        let exact = quadratic(p);
        for a in 0..3 {
            worst = worst.max((solution.displacement[3 * n + a] - exact[a]).abs());
            largest = largest.max(exact[a].abs());
        }
    }
    worst / largest
}

#[test]
fn quadratic_fields_are_reproduced_exactly() {
    // The patch test one degree up: the P2 space holds the field and its body force is
    // integrated exactly, so the Galerkin solution is the field itself, to round-off (κ(K)·ε
    // with κ ~ 1e3 on these meshes). The linear tet cannot represent it: its error is the
    // discretization error, many orders above.
    let material = Material::new(200e9, 0.3, 7850.0).unwrap();
    for split in [BoxSplit::Mirrored6, BoxSplit::Lecture6, BoxSplit::Five] {
        let linear = TetMesh::box_grid(
            Vector3::new(-0.5, 0.0, 0.2),
            Vector3::new(1.0, 1.2, 1.0),
            [3, 3, 2],
            split,
        )
        .unwrap();
        // Interior nodes moved off the grid: on a uniform grid the linear tet can be exact at
        // the nodes (superconvergence), which would hide its error.
        let (lo, hi) = linear.bounding_box();
        let jittered: Vec<Vector3<f64>> = linear
            .nodes()
            .iter()
            .enumerate()
            .map(|(n, p)| {
                let inside = (0..3).all(|a| p[a] > lo[a] + 1e-12 && p[a] < hi[a] - 1e-12);
                let k = n as f64;
                let shift = Vector3::new((1.7 * k).sin(), (2.3 * k).cos(), (0.9 * k).sin());
                if inside { p + shift * 0.08 } else { *p }
            })
            .collect();
        let linear = linear.with_nodes(jittered).unwrap();
        let quadratic_mesh = TetMesh::<Tet10>::from_linear(&linear).unwrap();
        let p2 = patch_error(&quadratic_mesh, &material);
        let p1 = patch_error(&linear, &material);
        eprintln!(
            "{split:?}: largest nodal error / largest displacement: P2 {p2:.2e}, P1 {p1:.2e}"
        );
        assert!(p2 < 1e-10, "{split:?}: P2 error {p2:e}");
        assert!(
            p1 > 1e-4,
            "{split:?}: P1 error {p1:e} (the test must be able to fail)"
        );
    }
}

#[test]
fn traction_on_six_node_faces_gives_uniaxial_stress_exactly() {
    // A bar pulled by a traction on x = L, x held on x = 0 (plus three DOFs against rigid
    // motion): uniaxial stress σ = t, u_x = t·x/E exactly, in P2 as in P1.
    let material = Material::new(1e7, 0.25, 1000.0).unwrap();
    let (length, t) = (2.0, 1e4);
    let linear = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(length, 0.5, 0.5),
        [4, 1, 1],
        BoxSplit::Mirrored6,
    )
    .unwrap();
    let mesh = TetMesh::<Tet10>::from_linear(&linear).unwrap();
    let faces: Vec<BoundaryFace> = mesh
        .boundary_faces()
        .unwrap()
        .into_iter()
        .filter(|f| {
            f.nodes
                .iter()
                .all(|&n| (mesh.nodes()[n].x - length).abs() < 1e-12)
        })
        .collect();
    let mut loads = Loads::new(&mesh);
    loads
        .add_traction(&mesh, &faces, Vector3::new(t, 0.0, 0.0))
        .unwrap();
    let resultant = loads.resultant();
    assert!((resultant.x - t * 0.25).abs() < 1e-12 * t, "{resultant:?}");
    let mut constraints = Constraints::new(&mesh);
    for (n, p) in mesh.nodes().iter().enumerate() {
        if p.x.abs() < 1e-12 {
            constraints.prescribe_axis(n, 0, 0.0).unwrap();
            if p.y.abs() < 1e-12 {
                constraints.prescribe_axis(n, 1, 0.0).unwrap();
            }
            if p.z.abs() < 1e-12 {
                constraints.prescribe_axis(n, 2, 0.0).unwrap();
            }
        }
    }
    let u = solve_static(&mesh, &material, &constraints, &loads)
        .unwrap()
        .displacement;
    let nu = material.poisson_ratio();
    let e = material.youngs_modulus();
    // The cell fields through the seam: σ = t e_x ⊗ e_x, energy density t²/(2E), in every tet
    // (round-off of σ relative to t).
    let stress = cell_stress(&mesh, &material, &u).unwrap();
    let energy = cell_strain_energy_density(&mesh, &material, &u).unwrap();
    for (s, w) in stress.iter().zip(&energy) {
        let expected = Matrix3::new(t, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        assert!((s - expected).abs().max() < 1e-9 * t, "{s}");
        assert!((w - t * t / (2.0 * e)).abs() < 1e-9 * t * t / e, "{w}");
    }
    for (n, p) in mesh.nodes().iter().enumerate() {
        let exact = Vector3::new(t * p.x / e, -nu * t * p.y / e, -nu * t * p.z / e);
        for a in 0..3 {
            // Round-off relative to the largest displacement t·L/E = 2e-3.
            assert!(
                (u[3 * n + a] - exact[a]).abs() < 1e-12,
                "node {n} axis {a}: {} vs {}",
                u[3 * n + a],
                exact[a]
            );
        }
    }
}

#[test]
fn vtu_writes_quadratic_cells() {
    let mesh = one_element();
    // Both encodings: the reader decodes the appended block (checking its layout) or the text.
    for format in [VtuFormat::Binary, VtuFormat::Ascii] {
        let mut bytes = Vec::new();
        VtuWriter::new(&mesh)
            .format(format)
            .write_to(&mut bytes)
            .unwrap();
        let vtu = common::vtu::parse_vtu(&bytes);
        assert_eq!(vtu.binary, format == VtuFormat::Binary);
        let array =
            |name: &str| -> Vec<usize> { vtu.values(name).iter().map(|&v| v as usize).collect() };
        assert_eq!(array("types"), vec![usize::from(Tet10::VTK_CELL_TYPE)]);
        assert_eq!(array("offsets"), vec![10]);
        assert_eq!(array("connectivity"), mesh.tets()[0].to_vec());
        let points: Vec<f64> = mesh.nodes().iter().flat_map(|p| [p.x, p.y, p.z]).collect();
        assert_eq!(vtu.values("Points"), points.as_slice());
    }
    assert_eq!(Tet10::VTK_CELL_TYPE, 24);
    assert_eq!(Tet4::VTK_CELL_TYPE, 10);
}

#[test]
fn edge_nodes_off_their_midpoints_and_reversed_cells() {
    let mesh = one_element();
    let mut nodes = mesh.nodes().to_vec();
    // Node 7 is the node of edge (1, 2) (local 5). Moved a little it bends the tet (curved,
    // isoparametric: accepted); moved 0.3 edge lengths toward corner 1 along the edge, the map
    // runs backwards at corner 1 ((x₂ − x₁) + 4d = −0.2(x₂ − x₁)): folded, an error there.
    nodes[7] += Vector3::new(0.0, 0.01, 0.0);
    let bent = TetMesh::<Tet10>::from_cells(nodes.clone(), mesh.tets().to_vec()).unwrap();
    assert!(Tet10::rest(&bent, 0).is_curved());
    let (x1, x2) = (nodes[1], nodes[2]);
    nodes[7] = (x1 + x2) * 0.5 + (x1 - x2) * 0.3;
    let err = TetMesh::<Tet10>::from_cells(nodes, mesh.tets().to_vec()).unwrap_err();
    assert!(matches!(err, Error::InvalidParameter { .. }), "{err}");
    let text = err.to_string();
    assert!(
        text.contains("tet 0") && text.contains("at node 1 ") && text.contains("Jacobian"),
        "{text}"
    );

    // A cell given with its corners 1 and 2 swapped (negative orientation, edge nodes moved
    // with them) is reoriented to the same cell, so the same stiffness.
    let mut reversed = mesh.tets()[0];
    Tet10::swap_corners_1_2(&mut reversed);
    let flipped = TetMesh::<Tet10>::from_cells(mesh.nodes().to_vec(), vec![reversed]).unwrap();
    assert_eq!(flipped.reoriented_count(), 1);
    assert_eq!(flipped.tets(), mesh.tets());
}

/// The peer cantilever's dynamic system on `mesh` (clamped at x = 0, no load).
fn cantilever_system<E: ElementType>(
    mesh: &TetMesh<E>,
    mass: tetfem::analysis::dynamics::MassKind,
) -> tetfem::analysis::dynamics::LinearSystem {
    let problem = tetfem_fixtures::cantilever::Cantilever::peer_benchmark([1, 1, 1]);
    let constraints = problem.constraints(mesh).unwrap();
    tetfem::analysis::dynamics::LinearSystem::new(
        mesh,
        &problem.material,
        &constraints,
        &Loads::new(mesh),
        Vector3::zeros(),
        mass,
        tetfem::analysis::dynamics::Rayleigh::default(),
    )
    .unwrap()
}

#[test]
fn quadratic_tets_remove_the_bending_lock_from_the_first_frequency() {
    // The first bending frequency of the L/h = 10 cantilever: P2 on 10×1×1 cells is within
    // 2 % of P2 on 40×4×4 (converged to about 0.05 %, as its static tip), P1 on the same coarse
    // mesh is locked stiff, its frequency far above.
    use tetfem::analysis::dynamics::MassKind;
    let first = |cells: [usize; 3], quadratic: bool| {
        let linear = tetfem_fixtures::cantilever::Cantilever::peer_benchmark(cells)
            .mesh()
            .unwrap();
        let system = if quadratic {
            cantilever_system(
                &TetMesh::<Tet10>::from_linear(&linear).unwrap(),
                MassKind::Consistent,
            )
        } else {
            cantilever_system(&linear, MassKind::Consistent)
        };
        tetfem::analysis::modal::lowest_modes(&system, 1)
            .unwrap()
            .frequencies()[0]
    };
    let reference = first([40, 4, 4], true);
    let p2 = first([10, 1, 1], true);
    let p1 = first([10, 1, 1], false);
    println!(
        "first frequency (Hz): P2 40×4×4 {reference:.6e}, P2 10×1×1 {p2:.6e} ({:+.2} %), P1 10×1×1 {p1:.6e} ({:+.1} %)",
        100.0 * (p2 / reference - 1.0),
        100.0 * (p1 / reference - 1.0)
    );
    assert!((p2 / reference - 1.0).abs() < 0.02);
    assert!(p1 / reference > 1.5, "P1 should be locked");
}

#[test]
fn newmark_on_quadratic_tets_conserves_energy() {
    // Average acceleration conserves the discrete energy ½vᵀMv + ½uᵀKu exactly for a linear
    // system, whatever the mass matrix (HRZ-lumped or consistent): only the round-off of 200
    // solves remains.
    use tetfem::analysis::dynamics::{MassKind, Method, State};
    let linear = tetfem_fixtures::cantilever::Cantilever::peer_benchmark([8, 1, 1])
        .mesh()
        .unwrap();
    let mesh = TetMesh::<Tet10>::from_linear(&linear).unwrap();
    for mass in [MassKind::Lumped, MassKind::Consistent] {
        let system = std::sync::Arc::new(cantilever_system(&mesh, mass));
        let modes = tetfem::analysis::modal::lowest_modes(&system, 1).unwrap();
        let period = 2.0 * std::f64::consts::PI / modes.omega[0];
        let mut state = State::released_from(modes.shapes[0].clone());
        let mut integrator = Method::Newmark
            .integrator(std::sync::Arc::clone(&system), period / 20.0)
            .unwrap();
        let e0 = system.energy(&state).unwrap().total();
        let mut worst: f64 = 0.0;
        for _ in 0..200 {
            integrator.step(&mut state).unwrap();
            worst = worst.max((system.energy(&state).unwrap().total() - e0).abs() / e0);
        }
        println!("Newmark on Tet10 ({mass:?}): max relative energy change {worst:.2e}");
        assert!(worst < 1e-9, "{mass:?}: {worst:e}");
    }
}
