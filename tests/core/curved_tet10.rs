//! Curved (isoparametric) 10-node tets: an edge node off its edge's midpoint bends the tet, its
//! geometry the quadratic map of its ten nodes.
//!
//! - the patch test: an affine displacement is reproduced exactly on tets bent inside the body
//!   (the isoparametric element holds every linear field; a straight-sided element on the same
//!   nodes would not, its nodes no longer where its map puts them);
//! - the volume of the plate with a hole converging at O(h⁴) curved, O(h²) straight;
//! - the curved stiffness rule exact to degree 6 and not 7, its closed-form orbit to the last bit;
//! - the plate with a hole: σ_xx at (0, a, 0) on curved P2 equal to MFEM's default curved P2
//!   (the same degree-6 rule) on the same meshes;
//! - a folded tet is an error naming the tet and the point, wherever in the tet it folds (a
//!   fold between the checked points too), and a strongly curved tet that does not fold is read.

use nalgebra::{Matrix3, Vector3};
use tetfem::fe::element::ElementType;
use tetfem::fe::element::isoparametric::stiffness_rule;
use tetfem::post::output::fields::{recovered_nodal_stress, tet_node_stress};
use tetfem::{BoxSplit, Constraints, Error, Loads, Material, Tet10, TetMesh, solve_static};
use tetfem_fixtures::hole::{self, Hole};

/// The unit cube's 10-node mesh with every edge node strictly inside the cube moved off its
/// midpoint by up to 0.02 per coordinate (0.06 h, h = 1/3 the cell size) in a fixed
/// pseudo-random direction.
fn bent_cube() -> TetMesh<Tet10> {
    let linear = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(1.0, 1.0, 1.0),
        [3, 3, 3],
        BoxSplit::Mirrored6,
    )
    .unwrap();
    let straight = TetMesh::<Tet10>::from_linear(&linear).unwrap();
    let corner_count = linear.node_count();
    let mut nodes = straight.nodes().to_vec();
    let mut state = 12345_u64;
    let mut next = || {
        // A 64-bit LCG (Knuth's MMIX constants): deterministic, in [−1, 1).
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    };
    for p in nodes.iter_mut().skip(corner_count) {
        if p.iter().all(|&c| c > 1e-9 && c < 1.0 - 1e-9) {
            *p += Vector3::new(next(), next(), next()) * 0.02;
        }
    }
    TetMesh::<Tet10>::from_cells(nodes, straight.tets().to_vec()).unwrap()
}

#[test]
fn an_affine_field_is_reproduced_on_bent_tets() {
    let mesh = bent_cube();
    let curved = (0..mesh.tet_count())
        .filter(|&t| Tet10::rest(&mesh, t).is_curved())
        .count();
    assert!(curved > 50, "{curved} curved tets of {}", mesh.tet_count());
    let material = Material::new(2e11, 0.3, 7800.0).unwrap();
    let gradient = Matrix3::new(1.0, 0.4, -0.3, 0.2, -0.5, 0.7, -0.6, 0.1, 0.8) * 1e-3;
    let offset = Vector3::new(1e-3, -2e-3, 0.5e-3);
    let exact = |x: &Vector3<f64>| offset + gradient * x;
    let mut constraints = Constraints::new(&mesh);
    for (n, p) in mesh.nodes().iter().enumerate() {
        if p.iter()
            .any(|&c| c.abs() < 1e-12 || (c - 1.0).abs() < 1e-12)
        {
            constraints.prescribe(n, exact(p)).unwrap();
        }
    }
    let u = solve_static(&mesh, &material, &constraints, &Loads::new(&mesh))
        .unwrap()
        .displacement;
    let scale = mesh
        .nodes()
        .iter()
        .map(|p| exact(p).norm())
        .fold(0.0, f64::max);
    let worst = mesh
        .nodes()
        .iter()
        .enumerate()
        .map(|(n, p)| (Vector3::new(u[3 * n], u[3 * n + 1], u[3 * n + 2]) - exact(p)).norm())
        .fold(0.0, f64::max);
    // A direct solve of a well-conditioned 3000-DOF system: round-off, 1e-10 of |u| with room.
    assert!(worst < 1e-10 * scale, "{worst:e} vs {scale:e}");
    // The stress at every tet's every node (G⁻ᵀ∇_X N there) is the field's constant stress.
    let strain = (gradient + gradient.transpose()) * 0.5;
    let sigma = Matrix3::identity() * (material.lame_lambda() * strain.trace())
        + strain * (2.0 * material.shear_modulus());
    let stresses = tet_node_stress(&mesh, &material, &u).unwrap();
    let worst = stresses
        .iter()
        .map(|s| (s - sigma).norm())
        .fold(0.0, f64::max);
    // The same round-off amplified by ∇N ~ 1/h and E: 1e-8 of |σ|.
    assert!(
        worst < 1e-8 * sigma.norm(),
        "{worst:e} vs {:e}",
        sigma.norm()
    );
}

#[test]
fn curved_mass_and_shape_integrals_sum_to_the_curved_volume() {
    let mesh = bent_cube();
    let density = 7800.0;
    let mut volume = 0.0;
    for t in 0..mesh.tet_count() {
        let rest = Tet10::rest(&mesh, t);
        let v = Tet10::volume(&rest);
        volume += v;
        let mass: f64 = (0..10)
            .flat_map(|i| (0..10).map(move |j| (i, j)))
            .map(|(i, j)| Tet10::mass_coefficient(&rest, density, i, j))
            .sum();
        let shape: f64 = (0..10).map(|i| Tet10::shape_integral(&rest, i)).sum();
        // ΣNᵢ = 1 pointwise: Σᵢⱼ∫NᵢNⱼ = ∫1 = V by the same rule, to round-off.
        assert!((mass - density * v).abs() < 1e-12 * density * v, "tet {t}");
        assert!((shape - v).abs() < 1e-12 * v, "tet {t}");
    }
    // Moving interior edge nodes reshapes tets but not the cube: Σ V = 1 (det G's integrals
    // over the shared curved faces cancel), to round-off.
    assert!((volume - 1.0).abs() < 1e-12, "{volume}");
}

/// The 10-node mesh's volume Σ V.
fn volume(mesh: &TetMesh<Tet10>) -> f64 {
    (0..mesh.tet_count())
        .map(|t| Tet10::volume(&Tet10::rest(mesh, t)))
        .sum()
}

#[test]
fn the_holes_volume_converges_at_h4_curved_and_h2_straight() {
    let exact = (hole::L * hole::W - std::f64::consts::PI * hole::A * hole::A / 4.0) * hole::T;
    // n = 1 (2 × 1 × 1 cells) folds: one cell spans the graded map's whole width.
    let sizes = [2, 4, 8, 16];
    let mut errors = Vec::new();
    for &n in &sizes {
        let h = Hole::new(n).unwrap();
        let straight = (volume(&h.straight_mesh().unwrap()) - exact).abs() / exact;
        let curved = (volume(&h.curved_mesh().unwrap()) - exact).abs() / exact;
        eprintln!("volume n={n}: straight {straight:.3e}, curved {curved:.3e}");
        errors.push((straight, curved));
    }
    for k in 1..sizes.len() {
        let (s0, c0) = errors[k - 1];
        let (s1, c1) = errors[k];
        let (straight_rate, curved_rate) = ((s0 / s1).log2(), (c0 / c1).log2());
        eprintln!(
            "rates to n={}: straight {straight_rate:.3}, curved {curved_rate:.3}",
            sizes[k]
        );
        // Halving the arc's chords: the polygon's lost area falls as h² (rate 2), the
        // quadratic interpolant's as h⁴ (rate 4); ±0.3 for the first levels' higher terms.
        assert!((straight_rate - 2.0).abs() < 0.3, "{straight_rate}");
        assert!((curved_rate - 4.0).abs() < 0.3, "{curved_rate}");
    }
}

/// σ_xx at (0, a, 0): the recovered nodal stress (Σₑ Vₑ σₑ(xₙ) / Σₑ Vₑ) at vertex 0.
fn hole_stress(mesh: &TetMesh<Tet10>) -> f64 {
    let material = Material::new(1e5, 0.3, 1.0).unwrap();
    let mut constraints = Constraints::new(mesh);
    for (n, p) in mesh.nodes().iter().enumerate() {
        for axis in 0..3 {
            if p[axis].abs() < 1e-9 {
                constraints.prescribe_axis(n, axis, 0.0).unwrap();
            }
        }
    }
    let faces = mesh.faces_on_plane(&mesh.boundary_faces().unwrap(), 0, hole::L, 1e-9);
    let mut loads = Loads::new(mesh);
    loads
        .add_traction(mesh, &faces, Vector3::new(1.0, 0.0, 0.0))
        .unwrap();
    let u = solve_static(mesh, &material, &constraints, &loads)
        .unwrap()
        .displacement;
    let node_stress = tet_node_stress(mesh, &material, &u).unwrap();
    recovered_nodal_stress(mesh, &node_stress).unwrap()[Hole::TARGET][(0, 0)]
}

/// ∫ L₀^a L₁^b L₂^c L₃^d dV / V = 3!·a!·b!·c!·d! / (a + b + c + d + 3)! on any tet.
fn barycentric_monomial_mean(powers: [u32; 4]) -> f64 {
    let factorial = |n: u32| (1..=n).map(f64::from).product::<f64>();
    6.0 * powers.iter().map(|&p| factorial(p)).product::<f64>()
        / factorial(powers.iter().sum::<u32>() + 3)
}

/// The rule's mean of the barycentric monomial L₀^a L₁^b L₂^c L₃^d.
fn rule_mean(rule: &[([f64; 4], f64)], powers: [u32; 4]) -> f64 {
    rule.iter()
        .map(|(l, w)| w * (0..4).map(|i| l[i].powi(powers[i] as i32)).product::<f64>())
        .sum()
}

/// The worst relative error of the rule over every barycentric monomial of total degree `n`.
fn worst_monomial_error(rule: &[([f64; 4], f64)], n: u32) -> f64 {
    let mut worst: f64 = 0.0;
    for a in 0..=n {
        for b in 0..=n - a {
            for c in 0..=n - a - b {
                let powers = [a, b, c, n - a - b - c];
                let exact = barycentric_monomial_mean(powers);
                worst = worst.max((rule_mean(rule, powers) - exact).abs() / exact);
            }
        }
    }
    worst
}

#[test]
fn the_curved_stiffness_rule_is_exact_to_degree_six() {
    let rule = stiffness_rule();
    for n in 0..=6 {
        let worst = worst_monomial_error(&rule, n);
        // Weights and points rounded to f64 from 33 digits: a sum of 24 positive products each
        // within a few ulps of its exact value, so a few 1e-16 relative; 1e-14 leaves room.
        assert!(worst < 1e-14, "degree {n}: {worst:e}");
    }
    assert!(rule.iter().all(|(_, w)| *w > 0.0));
    assert!(
        rule.iter()
            .all(|(l, _)| l.iter().all(|&c| c > 0.0) && (l.iter().sum::<f64>() - 1.0).abs() < 1e-15),
        "points inside the tet, barycentric summing to 1"
    );
    // Degree 6, not 7: some monomial of degree 7 is missed by far more than round-off
    // (measured 1.75e-2 relative in 50-digit arithmetic, e.g. L₀⁷ by 2.3e-3).
    let seventh = worst_monomial_error(&rule, 7);
    assert!(seventh > 1e-6, "degree 7: {seventh:e}");
    // The twelve-point orbit (a, a, b, c) in closed form: a = (3 − √5)/12, b = (1 + √5)/12,
    // c = (5 + √5)/12, weight 27/560 — each rounded to f64 (c as 1 − 2a − b), so within two
    // ulps of 1 of the same expressions evaluated in f64 (√5, the sums and the division each
    // round once); a wrong digit anywhere in the first 15 would be caught.
    let s5 = 5.0_f64.sqrt();
    let closed = [(3.0 - s5) / 12.0, (1.0 + s5) / 12.0, (5.0 + s5) / 12.0];
    let pair = rule
        .iter()
        .filter(|(_, w)| *w == 27.0 / 560.0)
        .collect::<Vec<_>>();
    assert_eq!(pair.len(), 12);
    for (l, _) in pair {
        let mut sorted = *l;
        sorted.sort_by(f64::total_cmp);
        for (got, want) in [sorted[0], sorted[2], sorted[3]].iter().zip(closed) {
            assert!((got - want).abs() <= 2.0 * f64::EPSILON, "{l:?}");
        }
    }
}

#[test]
fn the_hole_stress_on_curved_p2_matches_mfems_curved_p2() {
    // MFEM 4.10 (PyMFEM, /work/peers-venv) curved P2 with its default stiffness rule for this
    // integrand, `IntRules.Get(TETRAHEDRON, 6)` — Keast's 24 points, tetfem's — on the same
    // meshes and geometry (the O-grid curved by SetCurvature(2) and its nodes put on the exact
    // blending map), same recovery at the node (volumes exact: `curved_volume`); n = 2, 4, 6.
    // Printed to 17 digits by `python validation/hole_speed_accuracy.py --worker MFEM-curved 2
    // n out.json` (`solve_mfem`, which sets no rule).
    let mfem = [
        (2, 3.824_083_648_678_699_5),
        (4, 3.663_609_020_354_363_6),
        (6, 3.676_075_924_815_707_6),
    ];
    // MFEM curved order 4 on 16 × 8 × 4 cells (validation/SPEED_ACCURACY.md's reference).
    let reference = 3.686_591_998;
    let mut errors = Vec::new();
    for (n, theirs) in mfem {
        let h = Hole::new(n).unwrap();
        let mesh = h.curved_mesh().unwrap();
        let p = mesh.nodes()[Hole::TARGET];
        assert!(
            (p - Vector3::new(0.0, hole::A, 0.0)).norm() < 1e-15,
            "{p:?}"
        );
        let ours = hole_stress(&mesh);
        let straight = hole_stress(&h.straight_mesh().unwrap());
        let error = |v: f64| (v - reference).abs() / reference;
        eprintln!(
            "hole n={n}: curved {ours:.15} (error {:.4e}), MFEM {theirs:.15} (rel. difference \
             {:.2e}), straight {straight:.9} (error {:.3e})",
            error(ours),
            (ours - theirs).abs() / theirs,
            error(straight)
        );
        // Same geometry (the quadratic interpolant of the same map at the same nodes), same
        // space, same rule, same recovery: the same discrete problem, so the two codes agree
        // to the solvers' round-off (both direct, condition ~1e6; measured 2.5e-14 to 5.0e-14):
        // 12 digits, 20× above it.
        assert!(
            (ours - theirs).abs() < 1e-12 * theirs,
            "n={n}: {ours} vs MFEM {theirs}"
        );
        errors.push((n, error(ours), error(straight)));
    }
    for &(n, ours, straight) in &errors[1..] {
        // Curving the hole is what the straight P2 lacked: its error is ≥ 5× the curved one.
        assert!(
            straight > 5.0 * ours,
            "n={n}: straight {straight:e}, curved {ours:e}"
        );
    }
    // P2's point stress converges as h² (h ∝ 1/n): from n = 4 to 6 the error falls by about
    // (6/4)² = 2.25; rate within [1.5, 3.5] allows the reference's own ~1e-4 error.
    let rate = (errors[1].1 / errors[2].1).ln() / 1.5_f64.ln();
    assert!((1.5..=3.5).contains(&rate), "rate {rate}");
}

#[test]
fn a_folded_curved_tet_is_an_error_naming_the_tet_and_the_point() {
    let corners = [Vector3::zeros(), Vector3::x(), Vector3::y(), Vector3::z()];
    let linear = TetMesh::new(corners.to_vec(), vec![[0, 1, 2, 3]]).unwrap();
    let straight = TetMesh::<Tet10>::from_linear(&linear).unwrap();
    let edge_12 = straight.tets()[0][5];
    let mut nodes = straight.nodes().to_vec();
    // 0.2 edge lengths along edge (1, 2): dx/dt at corner 1 is (x₂ − x₁) + 4d, still forward.
    nodes[edge_12] = Vector3::new(0.7, 0.3, 0.0);
    let bent = TetMesh::<Tet10>::from_cells(nodes.clone(), straight.tets().to_vec()).unwrap();
    assert!(Tet10::rest(&bent, 0).is_curved());
    // 0.3 edge lengths: (x₂ − x₁) + 4d = (0.2, −0.2, 0) points backwards, the map folds at
    // corner 1: det G = −0.2 there.
    nodes[edge_12] = Vector3::new(0.8, 0.2, 0.0);
    let err = TetMesh::<Tet10>::from_cells(nodes, straight.tets().to_vec()).unwrap_err();
    assert!(matches!(err, Error::InvalidParameter { .. }), "{err}");
    let text = err.to_string();
    assert!(
        text.contains("tet 0") && text.contains("at node 1") && text.contains("Jacobian"),
        "{text}"
    );
}

/// ∂x/∂ξ of the quadratic map of the ten nodes `x` (tetfem's local order: corners, then the
/// edges (0,1), (1,2), (0,2), (0,3), (1,3), (2,3)) at barycentric `l`, from the shape functions
/// Nᵢ = Lᵢ(2Lᵢ − 1) and N₍ᵢⱼ₎ = 4LᵢLⱼ differentiated by hand, ξ = (L₁, L₂, L₃).
fn jacobian_determinant(x: &[Vector3<f64>; 10], l: [f64; 4]) -> f64 {
    const EDGES: [(usize, usize); 6] = [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)];
    let grad = |i: usize| -> Vector3<f64> {
        if i == 0 {
            Vector3::new(-1.0, -1.0, -1.0)
        } else {
            Vector3::ith(i - 1, 1.0)
        }
    };
    let mut g = Matrix3::zeros();
    for i in 0..4 {
        g += x[i] * (grad(i) * (4.0 * l[i] - 1.0)).transpose();
    }
    for (k, &(i, j)) in EDGES.iter().enumerate() {
        g += x[4 + k] * ((grad(i) * l[j] + grad(j) * l[i]) * 4.0).transpose();
    }
    g.determinant()
}

/// One 10-node tet on the unit corners with the edge nodes `edge` (local 4–9).
fn one_curved_tet(edge: [[f64; 3]; 6]) -> (Vec<Vector3<f64>>, [Vector3<f64>; 10]) {
    let corners = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
    ];
    let nodes: Vec<Vector3<f64>> = corners
        .iter()
        .chain(&edge)
        .map(|p| Vector3::from(*p))
        .collect();
    let x = std::array::from_fn(|a| nodes[a]);
    (nodes, x)
}

#[test]
fn a_fold_between_the_checked_points_is_found() {
    // Edge nodes found by a random search: det G is positive (≥ 0.239) at the ten nodes and
    // at the four points of the degree-2 rule, the points a check by sampling read, but
    // negative at 3/4 of the way along edge (2, 3).
    let (nodes, x) = one_curved_tet([
        [0.453, 0.261, -0.053],
        [0.629, 0.381, -0.163],
        [-0.27, 0.676, -0.017],
        [0.278, -0.215, 0.453],
        [0.506, 0.241, 0.812],
        [-0.122, 0.292, 0.186],
    ]);
    let (alpha, beta) = (0.585_410_196_624_968_5, 0.138_196_601_125_010_5);
    let mut sampled: Vec<[f64; 4]> = (0..4)
        .map(|q| std::array::from_fn(|i| if i == q { alpha } else { beta }))
        .collect();
    sampled.extend((0..4).map(|c| std::array::from_fn(|i| f64::from(i == c))));
    for i in 0..4 {
        for j in i + 1..4 {
            sampled.push(std::array::from_fn(|m| {
                if m == i || m == j { 0.5 } else { 0.0 }
            }));
        }
    }
    for l in &sampled {
        assert!(jacobian_determinant(&x, *l) > 0.2, "{l:?}");
    }
    let inside = jacobian_determinant(&x, [0.0, 0.0, 0.75, 0.25]);
    assert!(inside < -0.1, "{inside}");
    let err = TetMesh::<Tet10>::from_cells(nodes, vec![std::array::from_fn(|a| a)]).unwrap_err();
    let text = err.to_string();
    assert!(
        text.contains("tet 0") && text.contains("barycentric") && text.contains("Jacobian"),
        "{text}"
    );
}

#[test]
fn a_strongly_curved_tet_that_does_not_fold_is_read() {
    // Edge nodes moved up to 0.56 edge lengths off their midpoints (a random search's): det G
    // stays above 0.25 on a lattice of degree 24 over the tet (2,925 points), while the
    // Bernstein coefficients of the whole tet reach −0.57 — the certificate must bisect to
    // accept it, which a bound without subdivision would refuse.
    let (nodes, x) = one_curved_tet([
        [0.676, 0.243, 0.212],
        [0.628, 0.261, 0.354],
        [0.088, 0.482, 0.004],
        [-0.058, 0.072, 0.553],
        [0.439, -0.437, 0.494],
        [0.081, 0.59, 0.474],
    ]);
    let n = 24;
    let mut least = f64::INFINITY;
    for i in 0..=n {
        for j in 0..=n - i {
            for k in 0..=n - i - j {
                let l = [i, j, k, n - i - j - k].map(|c| c as f64 / n as f64);
                least = least.min(jacobian_determinant(&x, l));
            }
        }
    }
    assert!(least > 0.25, "{least}");
    let mesh = TetMesh::<Tet10>::from_cells(nodes, vec![std::array::from_fn(|a| a)]).unwrap();
    assert!(Tet10::rest(&mesh, 0).is_curved());
}

/// The x-resultant of a unit traction (1, 0, 0) on the faces of the hole (corners at r = a):
/// their total area Σ∫ΣNᵢ dA.
fn hole_area(mesh: &TetMesh<Tet10>) -> f64 {
    let faces: Vec<_> = mesh
        .boundary_faces()
        .unwrap()
        .into_iter()
        .filter(|f| {
            f.nodes.iter().all(|&n| {
                let p = mesh.nodes()[n];
                (p.x.hypot(p.y) - hole::A).abs() < 1e-9
            })
        })
        .collect();
    let mut loads = Loads::new(mesh);
    loads
        .add_traction(mesh, &faces, Vector3::new(1.0, 0.0, 0.0))
        .unwrap();
    loads.resultant().x
}

#[test]
fn a_traction_on_the_curved_hole_loads_its_curved_area() {
    // The quarter hole's lateral area (π/2)·a·T; a traction on the curved faces integrates
    // over the quadratic surface (the degree-4 face rule), on straight faces over the polygon.
    let exact = std::f64::consts::FRAC_PI_2 * hole::A * hole::T;
    let mut previous: Option<(f64, f64)> = None;
    for n in [2, 4, 8, 16] {
        let h = Hole::new(n).unwrap();
        let straight = (hole_area(&h.straight_mesh().unwrap()) - exact).abs() / exact;
        let curved = (hole_area(&h.curved_mesh().unwrap()) - exact).abs() / exact;
        eprintln!("hole area n={n}: straight {straight:.3e}, curved {curved:.3e}");
        if let Some((s0, c0)) = previous {
            let (straight_rate, curved_rate) = ((s0 / straight).log2(), (c0 / curved).log2());
            eprintln!("  rates: straight {straight_rate:.3}, curved {curved_rate:.3}");
            // Chords lose O(h²) of an arc's length; the quadratic interpolant O(h⁴) (±0.3 for
            // the coarse levels' higher terms).
            assert!((straight_rate - 2.0).abs() < 0.3, "{straight_rate}");
            assert!((curved_rate - 4.0).abs() < 0.3, "{curved_rate}");
        }
        previous = Some((straight, curved));
    }
}

/// The estimator's squared stress norm Σ_K ∫_K σ_h:C⁻¹:σ_h dV of the linear model
/// (`estimate_model_error`'s `energy_norm²`) is ∫ ε_h:C:ε_h dV = uᵀKu, which the linear
/// estimate computes from the element's own strain energy (`estimate_error`'s `energy_norm²`,
/// the stiffness's rule with det G): on bent tets the two agree only when the estimator
/// weighs its points by det G as well (the volume element dV = det G dV_X), not by the tet's
/// mean volume.
#[test]
fn the_estimators_stress_norm_on_bent_tets_is_the_strain_energy() {
    use tetfem::model::{ModelKind, ModelMap};
    use tetfem::post::estimate::{Recovery, estimate_error, estimate_model_error};
    let mesh = bent_cube();
    let material = Material::new(1e5, 0.3, 1000.0).unwrap();
    let materials = tetfem::fe::materials::MaterialMap::uniform(material, mesh.tet_count());
    // A field whose strain varies across each tet (quadratic in x, y, z): its energy density
    // is not constant, so the weight of each point matters. Strains of 1e-6: the linear
    // model's S = F⁻¹σ is σ to 1e-6.
    let mut u = vec![0.0; mesh.dof_count()];
    for (n, p) in mesh.nodes().iter().enumerate() {
        u[3 * n] = 1e-6 * (p.x * p.x + 0.4 * p.y * p.z);
        u[3 * n + 1] = -0.6e-6 * p.x * p.y;
        u[3 * n + 2] = 1e-6 * (0.8 * p.z * p.z - 0.3 * p.x * p.y);
    }
    let linear = estimate_error(&mesh, &materials, &u).unwrap();
    let models = ModelMap::new(ModelKind::Linear, &materials);
    let model =
        estimate_model_error(&mesh, &models, &materials, &u, Recovery::PatchRecovery).unwrap();
    let (a, b) = (linear.energy_norm.powi(2), model.energy_norm.powi(2));
    eprintln!(
        "uᵀKu {a:.12e}, estimator's Σ∫σ:C⁻¹:σ {b:.12e}, rel {:.3e}",
        (a - b).abs() / a
    );
    // The two are different rules on a rational integrand (det G·|G⁻ᵀ∇N|² on bends of
    // 0.06 h): measured 3.1e-6 apart (3.7e-5 with the 14-point degree-5 stiffness rule);
    // weighing the points by the tet's mean volume instead of det G put them 1.7e-3 apart.
    // 2e-4 lies between: 65× above the first, 8× below the second.
    assert!((a - b).abs() < 2e-4 * a);
}
