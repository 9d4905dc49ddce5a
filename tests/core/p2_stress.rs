//! Stress outputs of the 10-node tet: each tet's stress at its own nodes, the recovered nodal
//! stress built from those values, the `.vtu` fields, and the point probe. A 10-node tet's
//! strain is linear in the tet, so a stress field linear in space is output exactly at the
//! nodes; the tet mean (the old nodal source) is not.

use crate::common;

use nalgebra::{Matrix3, Vector3};
use tetfem::post::output::fields::{
    cell_stress, nodal_stress, recovered_nodal_stress, tet_node_stress,
};
use tetfem::post::output::{
    FrameExtras, PointLocation, VtuFormat, evaluate_at_point, write_result_frame,
};
use tetfem::{
    BoxSplit, CellType, Constraints, Error, Loads, Material, Tet4, Tet10, TetMesh, solve_static,
};

/// A quadratic displacement field (m) with a linear stress.
fn quadratic(x: &Vector3<f64>) -> Vector3<f64> {
    Vector3::new(
        1e-3 * (x.x * x.x + 0.5 * x.y * x.z - 0.3 * x.z),
        1e-3 * (0.7 * x.x * x.y - 0.2 * x.z * x.z + 0.1),
        1e-3 * (0.4 * x.y * x.y + 0.6 * x.x * x.z + 0.2 * x.x),
    )
}

/// ∇u of [`quadratic`] (row i, column j: ∂uᵢ/∂xⱼ).
fn quadratic_gradient(x: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(
        2.0 * x.x,
        0.5 * x.z,
        0.5 * x.y - 0.3,
        0.7 * x.y,
        0.7 * x.x,
        -0.4 * x.z,
        0.6 * x.z + 0.2,
        0.8 * x.y,
        0.6 * x.x,
    ) * 1e-3
}

/// σ = λ tr(ε) I + 2με of a displacement gradient.
fn hooke(material: &Material, gradient: &Matrix3<f64>) -> Matrix3<f64> {
    let strain = (gradient + gradient.transpose()) * 0.5;
    Matrix3::identity() * (material.lame_lambda() * strain.trace())
        + strain * (2.0 * material.shear_modulus())
}

/// A jittered box mesh (interior nodes moved off the grid, so no tet is a copy of another).
fn jittered_box(split: BoxSplit) -> TetMesh {
    let linear = TetMesh::box_grid(
        Vector3::new(-0.5, 0.0, 0.2),
        Vector3::new(1.0, 1.2, 1.0),
        [3, 3, 2],
        split,
    )
    .unwrap();
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
    linear.with_nodes(jittered).unwrap()
}

/// The node-major values of `field` at the mesh's nodes: for the 10-node tet (edge nodes at
/// the midpoints, straight sides) the interpolant of a quadratic field is the field itself.
fn interpolate<C: CellType>(
    mesh: &TetMesh<C>,
    field: impl Fn(&Vector3<f64>) -> Vector3<f64>,
) -> Vec<f64> {
    mesh.nodes()
        .iter()
        .flat_map(|p| field(p).iter().copied().collect::<Vec<_>>())
        .collect()
}

/// The largest |aᵢⱼ − bᵢⱼ| over two lists of tensors.
fn largest_difference(a: &[Matrix3<f64>], b: &[Matrix3<f64>]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs().max())
        .fold(0.0, f64::max)
}

/// Round-off of the stress of [`quadratic`] on these meshes relative to its largest component:
/// ∇u sums ten O(1e-3) terms with O(1/h) = O(10) gradients, each rounded at 1e-16 relative;
/// measured ≤ 1.4e-15 (the 1e-13 bound leaves room for other platforms' rounding, and is
/// twelve orders below the tet mean's error, 0.24–0.26).
const ROUND_OFF: f64 = 1e-13;

#[test]
fn p2_node_stresses_and_recovered_nodal_stress_are_exact_for_a_linear_stress() {
    let material = Material::new(200e9, 0.3, 7850.0).unwrap();
    for split in [BoxSplit::Mirrored6, BoxSplit::Five] {
        let mesh = TetMesh::<Tet10>::from_linear(&jittered_box(split)).unwrap();
        let u = interpolate(&mesh, quadratic);
        let exact: Vec<Matrix3<f64>> = mesh
            .nodes()
            .iter()
            .map(|p| hooke(&material, &quadratic_gradient(p)))
            .collect();
        let scale = exact.iter().map(|s| s.abs().max()).fold(0.0, f64::max);

        // Each tet's value at each of its nodes is the exact stress there.
        let per_tet_node = tet_node_stress(&mesh, &material, &u).unwrap();
        assert_eq!(per_tet_node.len(), 10 * mesh.tet_count());
        let expected: Vec<Matrix3<f64>> = mesh
            .tets()
            .iter()
            .flat_map(|tet| tet.iter().map(|&n| exact[n]))
            .collect();
        let node_error = largest_difference(&per_tet_node, &expected) / scale;

        // Their volume-weighted average at each node: exact too (every tet agrees there).
        let recovered = recovered_nodal_stress(&mesh, &per_tet_node).unwrap();
        let recovered_error = largest_difference(&recovered, &exact) / scale;

        // The old rule: the average of the tet means, off by the stress gradient times the
        // distance from a node to the centroids around it.
        let cells = cell_stress(&mesh, &material, &u).unwrap();
        let mean_error = largest_difference(&nodal_stress(&mesh, &cells).unwrap(), &exact) / scale;

        // The cell value is the tet's mean, for a linear stress its value at the centroid.
        let centroid_error = mesh
            .tets()
            .iter()
            .zip(&cells)
            .map(|(tet, s)| {
                let c = tet[..4]
                    .iter()
                    .map(|&n| mesh.nodes()[n])
                    .sum::<Vector3<f64>>()
                    / 4.0;
                (s - hooke(&material, &quadratic_gradient(&c))).abs().max()
            })
            .fold(0.0, f64::max)
            / scale;
        eprintln!(
            "{split:?}: |σ| ≤ {scale:.3e} Pa; relative error at the nodes: per tet {node_error:.1e}, \
             recovered {recovered_error:.1e}, average of tet means {mean_error:.1e}; cell vs centroid {centroid_error:.1e}"
        );
        assert!(
            node_error < ROUND_OFF,
            "{split:?}: per-tet nodal stress off by {node_error:e}"
        );
        assert!(
            recovered_error < ROUND_OFF,
            "{split:?}: recovered stress off by {recovered_error:e}"
        );
        assert!(
            centroid_error < ROUND_OFF,
            "{split:?}: cell stress off its centroid value by {centroid_error:e}"
        );
        // The test can fail: the tet-mean average is off by percents of the largest stress.
        assert!(
            mean_error > 1e-3,
            "{split:?}: tet-mean nodal stress error {mean_error:e}"
        );
    }
}

/// The six components XX, YY, ZZ, XY, YZ, XZ of each tensor, as the `.vtu` writes them.
fn components(stresses: &[Matrix3<f64>]) -> Vec<f64> {
    stresses
        .iter()
        .flat_map(|s| {
            [
                s[(0, 0)],
                s[(1, 1)],
                s[(2, 2)],
                s[(0, 1)],
                s[(1, 2)],
                s[(0, 2)],
            ]
        })
        .collect()
}

#[test]
fn p2_vtu_stress_nodal_is_the_linear_stress_at_the_nodes() {
    // The regression of issue 33 item 10: the `.vtu`'s `stress_nodal` of a 10-node mesh was the
    // average of the tet means. Written in ASCII (17 significant digits) and read back.
    let material = Material::new(200e9, 0.3, 7850.0).unwrap();
    let mesh = TetMesh::<Tet10>::from_linear(&jittered_box(BoxSplit::Mirrored6)).unwrap();
    let u = interpolate(&mesh, quadratic);
    let dir = std::env::temp_dir().join(format!("tetfem_p2_stress_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("p2.vtu");
    let extras = FrameExtras {
        stress_tensors: true,
        format: VtuFormat::Ascii,
        ..FrameExtras::default()
    };
    write_result_frame(&path, &mesh, &material, &u, extras).unwrap();
    let vtu = common::vtu::read_vtu(&path);
    std::fs::remove_dir_all(&dir).unwrap();
    let exact: Vec<Matrix3<f64>> = mesh
        .nodes()
        .iter()
        .map(|p| hooke(&material, &quadratic_gradient(p)))
        .collect();
    let scale = exact.iter().map(|s| s.abs().max()).fold(0.0, f64::max);
    let written = vtu.values("stress_nodal");
    let expected = components(&exact);
    assert_eq!(written.len(), expected.len());
    let worst = written
        .iter()
        .zip(&expected)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max)
        / scale;
    assert!(
        worst < ROUND_OFF,
        "stress_nodal off the exact nodal stress by {worst:e} of |σ|max"
    );
}

#[test]
fn p1_node_stresses_are_the_cell_stress_bit_for_bit() {
    // A 4-node tet's stress is constant: its nodal values are its mean, and the recovered
    // nodal stress is the old average of the cell stresses, to the bit (P1 outputs unchanged).
    let material = Material::new(70e9, 0.33, 2700.0).unwrap();
    let mesh: TetMesh<Tet4> = jittered_box(BoxSplit::Lecture6);
    let u = interpolate(&mesh, quadratic);
    let cells = cell_stress(&mesh, &material, &u).unwrap();
    let per_tet_node = tet_node_stress(&mesh, &material, &u).unwrap();
    let replicated: Vec<Matrix3<f64>> = cells.iter().flat_map(|s| [*s; 4]).collect();
    assert_eq!(per_tet_node, replicated);
    assert_eq!(
        recovered_nodal_stress(&mesh, &per_tet_node).unwrap(),
        nodal_stress(&mesh, &cells).unwrap()
    );
    // One tensor per tet instead of one per tet node is a named length error.
    assert!(matches!(
        recovered_nodal_stress(&mesh, &cells),
        Err(Error::DimensionMismatch { .. })
    ));
}

/// ρ·g (Pa/m) and the rest of the bar hanging under gravity.
struct HangingBar {
    material: Material,
    g: f64,
    length: f64,
}

impl HangingBar {
    /// Timoshenko's exact solution of a prismatic bar z ∈ [0, L] held at z = L, under gravity
    /// −g ẑ: σ_zz = ρg z (zero at the free end), every other component zero; u is quadratic:
    /// u_x = −νρg xz/E, u_y = −νρg yz/E, u_z = ρg (z² + ν(x² + y²))/(2E).
    fn displacement(&self, p: &Vector3<f64>) -> Vector3<f64> {
        let m = &self.material;
        let (e, nu, rg) = (m.youngs_modulus(), m.poisson_ratio(), m.density() * self.g);
        Vector3::new(
            -nu * rg * p.x * p.z / e,
            -nu * rg * p.y * p.z / e,
            rg * (p.z * p.z + nu * (p.x * p.x + p.y * p.y)) / (2.0 * e),
        )
    }

    fn stress(&self, p: &Vector3<f64>) -> Matrix3<f64> {
        let mut s = Matrix3::zeros();
        s[(2, 2)] = self.material.density() * self.g * p.z;
        s
    }
}

#[test]
fn p2_bar_under_gravity_gives_its_linear_stress_at_the_nodes_and_at_points() {
    // Solved, not interpolated: the top face held at the exact displacement, gravity as the
    // consistent body load, the sides and the bottom free. The exact u is quadratic, so the P2
    // Galerkin solution is it, and the stress, linear in z, is exact at every node and point.
    let bar = HangingBar {
        material: Material::new(1e7, 0.3, 1000.0).unwrap(),
        g: 9.81,
        length: 2.0,
    };
    let linear = TetMesh::box_grid(
        Vector3::new(-0.2, -0.15, 0.0),
        Vector3::new(0.2, 0.15, bar.length),
        [2, 2, 6],
        BoxSplit::Mirrored6,
    )
    .unwrap();
    let mesh = TetMesh::<Tet10>::from_linear(&linear).unwrap();
    let mut constraints = Constraints::new(&mesh);
    for (n, p) in mesh.nodes().iter().enumerate() {
        if (p.z - bar.length).abs() < 1e-12 {
            constraints.prescribe(n, bar.displacement(p)).unwrap();
        }
    }
    let mut loads = Loads::new(&mesh);
    loads
        .add_gravity(&mesh, &bar.material, Vector3::new(0.0, 0.0, -bar.g))
        .unwrap();
    let u = solve_static(&mesh, &bar.material, &constraints, &loads)
        .unwrap()
        .displacement;
    let top = bar.material.density() * bar.g * bar.length;

    let recovered =
        recovered_nodal_stress(&mesh, &tet_node_stress(&mesh, &bar.material, &u).unwrap()).unwrap();
    let exact: Vec<Matrix3<f64>> = mesh.nodes().iter().map(|p| bar.stress(p)).collect();
    let nodal_error = largest_difference(&recovered, &exact) / top;
    let cells = cell_stress(&mesh, &bar.material, &u).unwrap();
    let mean_error = largest_difference(&nodal_stress(&mesh, &cells).unwrap(), &exact) / top;

    // Points inside tets (not nodes): the probe's u and σ against the exact fields.
    let mut worst_u: f64 = 0.0;
    let mut worst_s: f64 = 0.0;
    let scale_u = bar
        .displacement(&Vector3::new(0.2, 0.15, bar.length))
        .norm();
    let mut rng = common::Rng::new(33);
    for _ in 0..50 {
        let p = Vector3::new(
            rng.range(-0.2, 0.2),
            rng.range(-0.15, 0.15),
            rng.range(0.0, bar.length),
        );
        let (up, sp) = evaluate_at_point(&mesh, &u, &bar.material, &p).unwrap();
        worst_u = worst_u.max((up - bar.displacement(&p)).norm() / scale_u);
        worst_s = worst_s.max((sp - bar.stress(&p)).abs().max() / top);
    }
    eprintln!(
        "hanging bar: ρgL = {top:.4e} Pa; nodal σ error / ρgL: recovered {nodal_error:.1e}, \
         average of tet means {mean_error:.1e}; probes: u {worst_u:.1e}, σ {worst_s:.1e}"
    );
    // Solve round-off: κ(K)·ε, amplified by 1/h in the stress; measured 2.5e-14 (nodal σ),
    // 1.8e-14 (probe σ), 6.3e-14 (probe u): 1e-12 leaves a 16× margin and is ten orders below
    // the tet-mean error (8.3e-2: ρg·h/2 over ρgL with tets L/6 tall, at the end faces).
    assert!(
        nodal_error < 1e-12,
        "recovered nodal stress off by {nodal_error:e} of ρgL"
    );
    assert!(worst_s < 1e-12, "probe σ off by {worst_s:e} of ρgL");
    assert!(worst_u < 1e-12, "probe u off by {worst_u:e} of |u|max");
    assert!(
        mean_error > 1e-2,
        "tet-mean nodal error {mean_error:e}: the test must be able to fail"
    );
}

#[test]
fn point_probe_is_exact_for_linear_fields_on_p1_and_names_a_point_outside() {
    let material = Material::new(70e9, 0.33, 2700.0).unwrap();
    let mesh: TetMesh<Tet4> = jittered_box(BoxSplit::Five);
    let a = Matrix3::new(1.0, 0.2, -0.3, 0.4, -0.5, 0.6, 0.1, 0.7, 0.8) * 1e-4;
    let field = |p: &Vector3<f64>| a * p + Vector3::new(1e-5, 0.0, -2e-5);
    let u = interpolate(&mesh, field);
    let exact_stress = hooke(&material, &a);
    // A point on a node, one on a box face, one inside.
    for p in [
        mesh.nodes()[7],
        Vector3::new(-0.5, 0.3, 0.6),
        Vector3::new(0.1, 0.55, 0.61),
    ] {
        let (up, sp) = evaluate_at_point(&mesh, &u, &material, &p).unwrap();
        // Round-off relative to |u| ~ 1e-4 and |σ| ~ 1e7: sums of four O(1) products.
        assert!((up - field(&p)).norm() < 1e-15, "{p:?}: u {up:?}");
        assert!(
            (sp - exact_stress).abs().max() < 1e-8 * exact_stress.abs().max(),
            "{p:?}: σ {sp}"
        );
    }
    let location = PointLocation::find(&mesh, &Vector3::new(0.1, 0.55, 0.61)).unwrap();
    assert!(
        location
            .barycentric
            .iter()
            .all(|&l| (0.0..=1.0).contains(&l))
    );
    let sum: f64 = location.barycentric.iter().sum();
    assert!((sum - 1.0).abs() < 1e-15, "Σ L = {sum}");
    // Outside, or not a number: an error naming the point, not a value of some tet.
    for p in [
        Vector3::new(1.0 + 1e-3, 0.5, 0.5),
        Vector3::new(f64::NAN, 0.5, 0.5),
    ] {
        let error = evaluate_at_point(&mesh, &u, &material, &p).unwrap_err();
        assert!(
            matches!(&error, Error::InvalidParameter { name, .. } if name == "point"),
            "{error}"
        );
    }
    // A displacement of another mesh: a length error, not a panic.
    assert!(matches!(
        evaluate_at_point(&mesh, &u[3..], &material, &Vector3::new(0.1, 0.5, 0.6)),
        Err(Error::DimensionMismatch { .. })
    ));
}
