//! The mixed displacement–pressure form of the corotational model
//! (`solve_static_mixed_nonlinear_with(MixedLaw::Corotational, …)`) on Taylor–Hood P2–P1 and
//! the stabilized P1–P1: the element states against central differences of their energy and
//! residuals, a rotated homogeneous stretch's closed-form pressure, the linear mixed solution
//! in the small-load limit, frame invariance, and a nearly incompressible cantilever at large
//! rotation against the elastica, where the plain P1 corotational tet locks.

use nalgebra::{DMatrix, Matrix3, Rotation3, Vector3};
use tetfem::analysis::mixed_nonlinear::{MixedLaw, solve_static_mixed_nonlinear_with};
use tetfem::fe::element::stabilized_p1::pressure_block;
use tetfem::fe::element::stabilized_p1_corotational::{
    stabilized_corotational, stabilized_corotational_energy,
};
use tetfem::fe::element::taylor_hood::{PRESSURE_NODES, pressure_mass};
use tetfem::fe::element::taylor_hood_corotational::{
    mixed_corotational, mixed_corotational_energy,
};
use tetfem::fe::element::{MixedElement, Tet4};
use tetfem::model::rotation;
use tetfem::{
    BoxSplit, Constraints, ElementType, Loads, Material, MixedNewtonReport, Tet10, TetMesh,
    solve_static, solve_static_mixed,
};
use tetfem_fixtures::cantilever::Cantilever;
use tetfem_fixtures::cook::CookMembrane;

use super::mixed_neo_hookean::{options, relative_difference};

fn corotational<E: MixedElement>(
    mesh: &TetMesh<E>,
    material: &Material,
    constraints: &Constraints,
    loads: &Loads,
    load_steps: usize,
) -> MixedNewtonReport {
    solve_static_mixed_nonlinear_with(
        MixedLaw::Corotational,
        mesh,
        material,
        constraints,
        loads,
        options(load_steps),
    )
    .unwrap()
}

/// One element state, read into plain containers: R_u, R_p, K_uu, and G as G[dof][k].
struct Evaluated {
    force: Vec<f64>,
    pressure_residual: [f64; PRESSURE_NODES],
    stiffness: DMatrix<f64>,
    coupling: Vec<[f64; PRESSURE_NODES]>,
}

/// The largest deviation, relative to the size of K_uu, of the state `eval` at (`u`, `p`)
/// from central differences of `energy` (R_u = ∂Π/∂u, R_p = ∂Π/∂p) and of itself
/// (K_uu = ∂R_u/∂u, −G = ∂R_u/∂p = ∂R_p/∂u, ∂R_p/∂p = −C with C from `block`), and its
/// asymmetry.
fn derivative_error(
    u: &[f64],
    p: [f64; PRESSURE_NODES],
    eval: &dyn Fn(&[f64], &[f64; PRESSURE_NODES]) -> Evaluated,
    energy: &dyn Fn(&[f64], &[f64; PRESSURE_NODES]) -> f64,
    block: &dyn Fn(usize, usize) -> f64,
) -> (f64, f64) {
    let state = eval(u, &p);
    let n = u.len();
    let scale = state.stiffness.amax();
    let h = 1e-6;
    let mut worst: f64 = 0.0;
    for j in 0..n {
        let (mut plus, mut minus) = (u.to_vec(), u.to_vec());
        plus[j] += h;
        minus[j] -= h;
        let (a, b) = (eval(&plus, &p), eval(&minus, &p));
        for i in 0..n {
            let fd = (a.force[i] - b.force[i]) / (2.0 * h);
            worst = worst.max((fd - state.stiffness[(i, j)]).abs() / scale);
        }
        for k in 0..PRESSURE_NODES {
            let fd = (a.pressure_residual[k] - b.pressure_residual[k]) / (2.0 * h);
            worst = worst.max((fd + state.coupling[j][k]).abs() / scale);
        }
        let fd = (energy(&plus, &p) - energy(&minus, &p)) / (2.0 * h);
        worst = worst.max((fd - state.force[j]).abs() / scale);
    }
    for k in 0..PRESSURE_NODES {
        let (mut plus, mut minus) = (p, p);
        plus[k] += h;
        minus[k] -= h;
        let (a, b) = (eval(u, &plus), eval(u, &minus));
        for i in 0..n {
            let fd = (a.force[i] - b.force[i]) / (2.0 * h);
            worst = worst.max((fd + state.coupling[i][k]).abs() / scale);
        }
        for l in 0..PRESSURE_NODES {
            let fd = (a.pressure_residual[l] - b.pressure_residual[l]) / (2.0 * h);
            worst = worst.max((fd + block(l, k)).abs() / scale);
        }
        let fd = (energy(u, &plus) - energy(u, &minus)) / (2.0 * h);
        worst = worst.max((fd - state.pressure_residual[k]).abs() / scale);
    }
    let asymmetry = (&state.stiffness - state.stiffness.transpose()).amax() / scale;
    (worst, asymmetry)
}

/// A displacement of `nodes` that turns them by 60° about (1, 2, 3) after 5–10 % strains:
/// x = Q·(X + w(X)) − X, w a fixed pseudo-random field.
fn turned_displacement(nodes: &[Vector3<f64>]) -> Vec<f64> {
    let q = Rotation3::from_axis_angle(
        &nalgebra::Unit::new_normalize(Vector3::new(1.0, 2.0, 3.0)),
        60f64.to_radians(),
    );
    nodes
        .iter()
        .enumerate()
        .flat_map(|(i, x)| {
            let w = Vector3::from_fn(|a, _| 0.05 * ((3 * i + a) as f64 * 1.7).sin());
            let moved = q * (x + w) - x;
            [moved.x, moved.y, moved.z]
        })
        .collect()
}

fn unit_cube_tets() -> TetMesh {
    TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(1.0, 1.0, 1.0),
        [1, 1, 1],
        BoxSplit::Five,
    )
    .unwrap()
}

#[test]
fn the_taylor_hood_state_is_the_derivative_of_its_energy() {
    let mesh = TetMesh::<Tet10>::from_linear(&unit_cube_tets()).unwrap();
    let rest = Tet10::rest(&mesh, 0);
    let nodes: Vec<Vector3<f64>> = mesh.tets()[0].iter().map(|&n| mesh.nodes()[n]).collect();
    let u = turned_displacement(&nodes);
    let moduli = (1.0, 1.0 / 50.0);
    let eval = |u: &[f64], p: &[f64; PRESSURE_NODES]| {
        let s = mixed_corotational(&rest, u.try_into().unwrap(), p, moduli, rotation).unwrap();
        Evaluated {
            force: s.force.to_vec(),
            pressure_residual: s.pressure_residual,
            stiffness: DMatrix::from_column_slice(30, 30, s.stiffness.as_slice()),
            coupling: (0..30)
                .map(|d| std::array::from_fn(|k| s.coupling[k][d / 3][d % 3]))
                .collect(),
        }
    };
    let energy = |u: &[f64], p: &[f64; PRESSURE_NODES]| {
        mixed_corotational_energy(&rest, u.try_into().unwrap(), p, moduli, rotation)
    };
    let block = |k, l| pressure_mass(&rest, k, l) * moduli.1;
    let (worst, asymmetry) = derivative_error(&u, [0.3, -0.5, 0.8, 0.1], &eval, &energy, &block);
    println!("Taylor–Hood: state vs central differences {worst:.2e}, asymmetry {asymmetry:.2e}");
    // Central differences at h = 1e-6: truncation h²·|∂³Π| ~ 1e-12 and round-off
    // ε·|R|/h ~ 1e-10 of the tangent's size; 1e-7 leaves a margin and catches any wrong or
    // missing term (of the order of the tangent itself; without the dR terms the error is
    // ~1 at a 60° rotation).
    assert!(worst < 1e-7, "state vs FD: {worst}");
    // The Hessian of an energy: symmetric to round-off.
    assert!(asymmetry < 1e-12, "asymmetry {asymmetry}");
}

#[test]
fn the_stabilized_p1_state_is_the_derivative_of_its_energy() {
    let mesh = unit_cube_tets();
    let rest = Tet4::rest(&mesh, 0);
    let nodes: Vec<Vector3<f64>> = mesh.tets()[0].iter().map(|&n| mesh.nodes()[n]).collect();
    let u = turned_displacement(&nodes);
    let (mu, inverse_bulk) = (1.0, 1.0 / 50.0);
    let eval = |u: &[f64], p: &[f64; PRESSURE_NODES]| {
        let s = stabilized_corotational(&rest, u, p, (mu, inverse_bulk), rotation).unwrap();
        Evaluated {
            force: s.force.to_vec(),
            pressure_residual: s.pressure_residual,
            stiffness: DMatrix::from_column_slice(12, 12, s.stiffness.as_slice()),
            coupling: (0..12)
                .map(|d| std::array::from_fn(|k| s.coupling[k][d / 3][d % 3]))
                .collect(),
        }
    };
    let energy = |u: &[f64], p: &[f64; PRESSURE_NODES]| {
        stabilized_corotational_energy(&rest, u, p, (mu, inverse_bulk), rotation)
    };
    let block = |k, l| pressure_block(&rest, mu, inverse_bulk, k, l);
    let (worst, asymmetry) = derivative_error(&u, [0.3, -0.5, 0.8, 0.1], &eval, &energy, &block);
    println!("P1–P1: state vs central differences {worst:.2e}, asymmetry {asymmetry:.2e}");
    // As for Taylor–Hood above: truncation and round-off of h = 1e-6 are ≤ 1e-10.
    assert!(worst < 1e-7, "state vs FD: {worst}");
    assert!(asymmetry < 1e-12, "asymmetry {asymmetry}");
}

/// Every boundary node of a box moved by u = (Q·U − I)·X, U a symmetric stretch and Q a 20°
/// rotation: the exact solution is that affine field with p = −κ·tr(U − I) (R = Q, ε = U − I
/// at every point; the stabilization vanishes on a constant pressure).
fn rotated_stretch_is_exact<E: MixedElement>(mesh: &TetMesh<E>) {
    let stretch = Matrix3::new(1.06, 0.03, 0.0, 0.03, 0.97, -0.02, 0.0, -0.02, 0.99);
    let q = Rotation3::from_axis_angle(
        &nalgebra::Unit::new_normalize(Vector3::new(0.3, -1.0, 0.5)),
        20f64.to_radians(),
    );
    let f = q.matrix() * stretch;
    let boundary: std::collections::BTreeSet<usize> = mesh
        .boundary_faces()
        .unwrap()
        .iter()
        .flat_map(|face| face.element_nodes(mesh).unwrap())
        .collect();
    let mut constraints = Constraints::new(mesh);
    for &n in &boundary {
        let x = mesh.nodes()[n];
        constraints.prescribe(n, f * x - x).unwrap();
    }
    let material = Material::new(1e6, 0.49, 1000.0).unwrap();
    let report = corotational(mesh, &material, &constraints, &Loads::new(mesh), 8);
    let mut worst: f64 = 0.0;
    for (n, x) in mesh.nodes().iter().enumerate() {
        let u = Vector3::from_column_slice(&report.displacement[3 * n..3 * n + 3]);
        worst = worst.max((u - (f * x - x)).norm());
    }
    let exact = -material.bulk_modulus() * (stretch.trace() - 3.0);
    let pressure_error = report
        .pressure
        .iter()
        .fold(0.0_f64, |m, p| m.max((p - exact).abs()));
    println!(
        "{}: |u − exact| ≤ {worst:.2e}, p = {exact:.6e} Pa ± {pressure_error:.2e}, {} iterations",
        E::MIXED_NAME,
        report.iterations
    );
    // Round-off of Newton's converged iterate (tolerance 1e-10 of the first residual, in
    // a body of size 1).
    assert!(worst < 1e-9, "{worst}");
    // κ·tr ε to the iterate's round-off, amplified by κ/μ = 5e3.
    assert!(pressure_error < 1e-7 * exact.abs(), "{pressure_error}");
}

#[test]
fn a_rotated_homogeneous_stretch_has_the_closed_form_pressure() {
    let linear = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(1.0, 0.8, 0.6),
        [3, 3, 2],
        BoxSplit::Five,
    )
    .unwrap();
    rotated_stretch_is_exact(&linear);
    rotated_stretch_is_exact(&TetMesh::<Tet10>::from_linear(&linear).unwrap());
}

/// Cook's membrane of [`CookMembrane::default`] with traction `traction` on n × n cells, 2
/// layers.
fn cook(n: usize, traction: f64) -> (CookMembrane, TetMesh) {
    let cook = CookMembrane {
        traction,
        thickness: 2.0 * 48.0 / n as f64,
        ..CookMembrane::default()
    };
    let mesh = cook.mesh(n, 2, BoxSplit::Lecture6).unwrap();
    (cook, mesh)
}

/// The relative difference of the corotational mixed solution of Cook's membrane at
/// `scale` of its load from the linear mixed one ([`solve_static_mixed`]), on `mesh`.
fn small_load_difference<E: MixedElement>(cook: &CookMembrane, mesh: &TetMesh<E>) -> f64 {
    let material = cook.material().unwrap();
    let constraints = cook.constraints(mesh).unwrap();
    let loads = cook.loads(mesh).unwrap();
    let nonlinear = corotational(mesh, &material, &constraints, &loads, 1);
    let linear = solve_static_mixed(mesh, &material, &constraints, &loads).unwrap();
    relative_difference(&nonlinear.displacement, &linear.displacement)
}

#[test]
fn the_corotational_mixed_solution_is_the_linear_one_to_first_order() {
    // The corotational stress differs from Hooke's by O(strain²) (the rotation of a strain, the
    // stretch's second order): the difference of the solutions is ∝ load², relative to the
    // solution ∝ load.
    for order in [1, 2] {
        let mut differences = Vec::new();
        for scale in [1e-3, 1e-5] {
            let (cook, linear) = cook(4, 6.25 * scale);
            let d = if order == 1 {
                small_load_difference(&cook, &linear)
            } else {
                small_load_difference(&cook, &TetMesh::<Tet10>::from_linear(&linear).unwrap())
            };
            println!("order {order}, load × {scale:e}: relative difference u {d:.3e}");
            differences.push(d);
        }
        // 100× the load, 100× the relative difference (10⁴× the absolute): 30–300 allows
        // for the round-off floor of the smaller one (Newton's tolerance 1e-10).
        let ratio = differences[0] / differences[1];
        assert!(
            (30.0..300.0).contains(&ratio),
            "order {order}: ratio {ratio}"
        );
        // At 1e-5 of the load the strains are ~1e-6: their square is far below 1e-4.
        assert!(differences[1] < 1e-4, "{differences:?}");
    }
}

/// A cantilever of `cells` (L = 6, W = H = 1), ν = 0.45, under an end load turning its tip
/// by about 30°.
fn short_cantilever(cells: [usize; 3]) -> Cantilever {
    Cantilever {
        length: 6.0,
        cells,
        material: Material::new(1e5, 0.45, 1000.0).unwrap(),
        end_load: 0.8 * 1e5 / 12.0 / 36.0,
        ..Cantilever::peer_benchmark(cells)
    }
}

/// The cantilever's solution on `mesh`, then on `mesh` turned by Q (nodes Q·X, loads Q·f):
/// max |u_Q − Q·u| over max |u|, and the pressures' largest difference over their largest.
fn turned_difference<E: MixedElement>(beam: &Cantilever, mesh: &TetMesh<E>) -> (f64, f64) {
    let q = Rotation3::from_axis_angle(
        &nalgebra::Unit::new_normalize(Vector3::new(2.0, -1.0, 1.5)),
        110f64.to_radians(),
    );
    let constraints = beam.constraints(mesh).unwrap();
    let loads = beam.loads(mesh).unwrap();
    let plain = corotational(mesh, &beam.material, &constraints, &loads, 4);
    let turned_mesh = TetMesh::<E>::from_cells(
        mesh.nodes().iter().map(|x| q * x).collect(),
        mesh.tets().to_vec(),
    )
    .unwrap();
    let mut turned_loads = Loads::new(&turned_mesh);
    for (n, f) in loads.as_slice().chunks_exact(3).enumerate() {
        turned_loads
            .add_nodal_force(n, q * Vector3::from_column_slice(f))
            .unwrap();
    }
    let mut turned_constraints = Constraints::new(&turned_mesh);
    turned_constraints
        .fix_nodes(&mesh.nodes_on_plane(0, 0.0, 1e-9))
        .unwrap();
    let turned = corotational(
        &turned_mesh,
        &beam.material,
        &turned_constraints,
        &turned_loads,
        4,
    );
    let largest = plain
        .displacement
        .iter()
        .fold(0.0_f64, |m, u| m.max(u.abs()));
    let mut worst: f64 = 0.0;
    for n in 0..mesh.node_count() {
        let u = Vector3::from_column_slice(&plain.displacement[3 * n..3 * n + 3]);
        let v = Vector3::from_column_slice(&turned.displacement[3 * n..3 * n + 3]);
        worst = worst.max((v - q * u).norm());
    }
    let largest_p = plain.pressure.iter().fold(0.0_f64, |m, p| m.max(p.abs()));
    let pressure = plain
        .pressure
        .iter()
        .zip(&turned.pressure)
        .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
    let tip = beam.tip_deflection(mesh, &plain.displacement).unwrap();
    println!(
        "{}: tip {tip:.4} of L = {}, |u_Q − Q·u| {:.2e}, |p_Q − p| {:.2e} (relative)",
        E::MIXED_NAME,
        beam.length,
        worst / largest,
        pressure / largest_p
    );
    (worst / largest, pressure / largest_p)
}

#[test]
fn the_solution_of_a_turned_body_is_the_turned_solution() {
    let beam = short_cantilever([6, 2, 2]);
    let linear = beam.mesh().unwrap();
    let p1 = turned_difference(&beam, &linear);
    let p2 = turned_difference(&beam, &TetMesh::<Tet10>::from_linear(&linear).unwrap());
    for (u, p) in [p1, p2] {
        // Both runs converge to the same solution within Newton's tolerance (1e-10 of the
        // load's norm) times the tangent's conditioning (~1e3 on this beam): the rotation only
        // permutes round-off.
        assert!(u < 1e-7, "displacement {u}");
        assert!(p < 1e-7, "pressure {p}");
    }
}

/// The elastica of a slender cantilever under a dead end load P (inextensible, unshearable,
/// M = EI·θ'): θ'' = −α·cos θ on s ∈ [0, 1], θ(0) = 0, θ'(1) = 0, α = PL²/(EI), solved by
/// shooting on θ'(0) (bisection, RK4 with 4000 steps: error ~1e-13). Returns the tip's
/// (horizontal shortening, deflection) over L.
fn elastica(alpha: f64) -> (f64, f64) {
    let run = |slope: f64| {
        let n = 4000;
        let h = 1.0 / n as f64;
        // (θ, θ', x, z)
        let rate = |y: [f64; 4]| [y[1], -alpha * y[0].cos(), y[0].cos(), y[0].sin()];
        let mut y = [0.0, slope, 0.0, 0.0];
        for _ in 0..n {
            let add = |y: [f64; 4], k: [f64; 4], c: f64| std::array::from_fn(|i| y[i] + c * k[i]);
            let k1 = rate(y);
            let k2 = rate(add(y, k1, h / 2.0));
            let k3 = rate(add(y, k2, h / 2.0));
            let k4 = rate(add(y, k3, h));
            y = std::array::from_fn(|i| {
                y[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
            });
        }
        y
    };
    let (mut low, mut high) = (0.0, 2.0 * alpha);
    for _ in 0..100 {
        let mid = 0.5 * (low + high);
        if run(mid)[1] < 0.0 {
            low = mid;
        } else {
            high = mid;
        }
    }
    let y = run(0.5 * (low + high));
    (1.0 - y[2], y[3])
}

#[test]
fn the_elastica_of_the_reference_is_mattiassons() {
    // Mattiasson (1981, IJNME 17) tabulates the tip of this elastica to 5 digits: α = 1:
    // 0.05643, 0.30172; α = 2: 0.16064, 0.49346.
    for (alpha, shortening, deflection) in [(1.0, 0.05643, 0.30172), (2.0, 0.16064, 0.49346)] {
        let (u, w) = elastica(alpha);
        println!("α = {alpha}: {u:.6}, {w:.6}");
        // The table's last digit.
        assert!((u - shortening).abs() < 6e-6 && (w - deflection).abs() < 6e-6);
    }
}

/// A slender cantilever (L = 20, W = H = 1, E = 1e5, ν = 0.4999) of `cells` under the end load
/// P = α·EI/L².
fn slender(cells: [usize; 3], alpha: f64) -> Cantilever {
    Cantilever {
        length: 20.0,
        cells,
        material: Material::new(1e5, 0.4999, 1000.0).unwrap(),
        end_load: alpha * 1e5 / 12.0 / 400.0,
        ..Cantilever::peer_benchmark(cells)
    }
}

/// The tip's (mean x, mean z) displacement over L.
fn tip<E: ElementType>(beam: &Cantilever, mesh: &TetMesh<E>, u: &[f64]) -> (f64, f64) {
    let nodes = beam.tip_nodes(mesh);
    let mean = |a: usize| nodes.iter().map(|&n| u[3 * n + a]).sum::<f64>() / nodes.len() as f64;
    (mean(0) / beam.length, mean(2) / beam.length)
}

#[test]
fn a_nearly_incompressible_cantilever_at_large_rotation_does_not_lock() {
    // P = 2·EI/L²: the tip turns by 45° (the elastica's 0.782 rad) with strains ≤ 4 %.
    let alpha = 2.0;
    let (shortening, deflection) = elastica(alpha);
    // Taylor–Hood P2–P1, 2 cells through the height.
    let beam = slender([40, 2, 2], alpha);
    let mesh = TetMesh::<Tet10>::from_linear(&beam.mesh().unwrap()).unwrap();
    let constraints = beam.constraints(&mesh).unwrap();
    let loads = beam.loads(&mesh).unwrap();
    let report = corotational(&mesh, &beam.material, &constraints, &loads, 40);
    let (th_x, th_z) = tip(&beam, &mesh, &report.displacement);
    // The mesh's flexibility against Euler–Bernoulli's PL³/(3EI) (tip/L = α/3), measured by
    // the linear mixed solve: shear, the clamp's restraint and the discretisation together.
    let linear = solve_static_mixed(&mesh, &beam.material, &constraints, &loads).unwrap();
    let th_factor = -tip(&beam, &mesh, &linear.displacement).1 / (alpha / 3.0);
    // The elastica of a beam that flexible: α·f.
    let (th_short, th_deflect) = elastica(alpha * th_factor);
    println!(
        "elastica α = {alpha}: shortening {shortening:.5}, deflection {deflection:.5}; \
         Taylor–Hood: {:.5}, {:.5} ({} iterations), linear factor {th_factor:.5}, elastica at \
         α·f: {th_short:.5}, {th_deflect:.5}",
        -th_x, -th_z, report.iterations
    );
    // Stabilized P1–P1 and the plain P1 corotational tet, 4 cells through the height.
    let beam1 = slender([80, 4, 4], alpha);
    let mesh1 = beam1.mesh().unwrap();
    let constraints1 = beam1.constraints(&mesh1).unwrap();
    let loads1 = beam1.loads(&mesh1).unwrap();
    let mixed1 = corotational(&mesh1, &beam1.material, &constraints1, &loads1, 10);
    let (p1_x, p1_z) = tip(&beam1, &mesh1, &mixed1.displacement);
    let linear1 = solve_static_mixed(&mesh1, &beam1.material, &constraints1, &loads1).unwrap();
    let p1_factor = -tip(&beam1, &mesh1, &linear1.displacement).1 / (alpha / 3.0);
    let (p1_short, p1_deflect) = elastica(alpha * p1_factor);
    // The plain P1 corotational tet: its Newton does not converge here (measured: 30
    // iterations of the first of 10 load steps left the residual at 42× the load's norm), and
    // its linear solve at ν = 0.4999 is refused as inaccurate; its locking is measured on the
    // linear model (the corotational one to first order) at ν = 0.49, where it solves (0.499 is
    // refused too on this slender beam): locking only grows towards 0.4999.
    assert!(solve_static(&mesh1, &beam1.material, &constraints1, &loads1).is_err());
    let softer = Material::new(1e5, 0.49, 1000.0).unwrap();
    let plain = solve_static(&mesh1, &softer, &constraints1, &loads1).unwrap();
    let plain_factor = -tip(&beam1, &mesh1, &plain.displacement).1 / (alpha / 3.0);
    println!(
        "stabilized P1–P1: {:.5}, {:.5} ({} iterations), linear factor {p1_factor:.5}, elastica \
         at α·f: {p1_short:.5}, {p1_deflect:.5}; plain P1 linear factor at ν = 0.49 {plain_factor:.5}",
        -p1_x, -p1_z, mixed1.iterations,
    );
    // Against the elastica of the mesh's own flexibility: what is left is how shear and the
    // clamp change with the turn (a fraction of f − 1) and the elastica's inextensibility
    // (axial strain P/(EA) ~ 4e-4): for Taylor–Hood (f − 1 = −1.4 %) 1 % of the deflection,
    // 2 % of the shortening (a difference of two lengths, ×3 smaller). P1's own bending error
    // on 4 cells is larger and the effective-stiffness reference is only first order in it:
    // twice |1 − f| more.
    let p1_margin = 2.0 * (1.0 - p1_factor).abs();
    for (name, (x, z), (short, deflect), margin) in [
        ("Taylor–Hood", (th_x, th_z), (th_short, th_deflect), 0.0),
        ("P1–P1", (p1_x, p1_z), (p1_short, p1_deflect), p1_margin),
    ] {
        assert!(
            (-z / deflect - 1.0).abs() < 0.01 + margin,
            "{name}: {z} vs {deflect}"
        );
        assert!(
            (-x / short - 1.0).abs() < 0.02 + margin,
            "{name}: {x} vs {short}"
        );
    }
    // Locking: the plain P1 tet on the same mesh bends less than the stabilized one already
    // at ν = 0.49 (measured 0.521 against 0.812: 0.64 of it).
    assert!(
        plain_factor < 0.75 * p1_factor,
        "plain P1 {plain_factor} vs P1–P1 {p1_factor}"
    );
}
