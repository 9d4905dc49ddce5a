//! The displacement elements' volumetric locking curve (`tetfem::fe::locking`), recomputed:
//! every point of [`VOLUMETRIC_LOCKING_CURVE`] is the loss 1 − r(ν)/r(0.3), r the bore's radial
//! displacement of Lamé's tube over the exact value at that ν, solved here with the 4-node and the 10-node tet on the curve's
//! mesh, and the interpolation between points is monotone and meets them.

use tetfem::fe::locking::{VOLUMETRIC_LOCKING_CURVE, expected_locking_loss};
use tetfem::{BoxSplit, Material, Tet10, TetMesh, solve_static};
use tetfem_fixtures::tube::LameTube;

/// The curve's mesh (`validation/src/bin/locking.rs`'s default).
const CELLS: [usize; 3] = [6, 24, 2];

/// u_r(a) of the displacement solve at ν on `mesh` (4- or 10-node) over Lamé's exact value.
fn bore_displacement<E: tetfem::ElementType>(tube: &LameTube, mesh: &TetMesh<E>, nu: f64) -> f64 {
    let material = Material::new(tube.youngs_modulus, nu, 1000.0).unwrap();
    let solution = solve_static(
        mesh,
        &material,
        &tube.constraints(mesh).unwrap(),
        &tube.loads(mesh).unwrap(),
    )
    .unwrap();
    tube.inner_radial_displacement(mesh, &solution.displacement)
        / tube.radial_displacement(nu, tube.inner)
}

#[test]
fn every_point_of_the_locking_curve_is_recomputed() {
    let tube = LameTube::default();
    let four = tube.mesh(CELLS, BoxSplit::Lecture6).unwrap();
    let ten = TetMesh::<Tet10>::from_linear(&four).unwrap();
    let reference = [
        bore_displacement(&tube, &four, 0.3),
        bore_displacement(&tube, &ten, 0.3),
    ];
    for (nu, p1, p2) in VOLUMETRIC_LOCKING_CURVE {
        let loss = [
            1.0 - bore_displacement(&tube, &four, nu) / reference[0],
            1.0 - bore_displacement(&tube, &ten, nu) / reference[1],
        ];
        println!(
            "ν = {nu}: loss 4-node {:.6}, 10-node {:.7}",
            loss[0], loss[1]
        );
        // The table keeps 4–5 significant digits of the measured losses: half a unit of the
        // last digit kept.
        assert!(
            (loss[0] - p1).abs() <= 5e-6,
            "ν = {nu}: 4-node {} vs {p1}",
            loss[0]
        );
        assert!(
            (loss[1] - p2).abs() <= 5e-7,
            "ν = {nu}: 10-node {} vs {p2}",
            loss[1]
        );
    }
}

#[test]
fn the_interpolated_loss_meets_the_points_and_grows_with_nu() {
    for (nu, p1, p2) in VOLUMETRIC_LOCKING_CURVE {
        assert_eq!(expected_locking_loss(nu, 1), Some(p1));
        assert_eq!(expected_locking_loss(nu, 2), Some(p2));
    }
    assert_eq!(expected_locking_loss(0.2, 1), Some(0.0));
    assert_eq!(expected_locking_loss(0.3, 2), Some(0.0));
    assert_eq!(expected_locking_loss(0.49999, 1), Some(0.51600));
    assert_eq!(expected_locking_loss(0.49, 3), None);
    assert_eq!(expected_locking_loss(f64::NAN, 1), None);
    let mut previous = [0.0; 2];
    for k in 0..=1000 {
        let nu = 0.3 + 0.2 * (1.0 - 10f64.powf(-4.0 * k as f64 / 1000.0));
        for (order, previous) in [1, 2].into_iter().zip(previous.iter_mut()) {
            let loss = expected_locking_loss(nu, order).unwrap();
            assert!(
                loss >= *previous,
                "ν = {nu}, order {order}: {loss} < {previous}"
            );
            *previous = loss;
        }
    }
}

/// The book's table of the curve (docs/src/incompressible.md) says what the constant says, to
/// the digits it prints (so that the table cannot drift from the warning's numbers).
#[test]
fn the_books_locking_table_is_the_curve() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/src/incompressible.md");
    let book = std::fs::read_to_string(path).unwrap();
    let percent = |cell: &str| {
        cell.trim()
            .trim_end_matches('%')
            .trim()
            .parse::<f64>()
            .unwrap()
    };
    for (nu, p1, p2) in VOLUMETRIC_LOCKING_CURVE {
        let row = book
            .lines()
            .find(|line| line.starts_with(&format!("| {nu} |")))
            .unwrap_or_else(|| panic!("no row for ν = {nu} in {path}"));
        let cells: Vec<&str> = row.split('|').collect();
        let (four, ten) = (percent(cells[2]), percent(cells[3]));
        // Printed to 3 significant digits or 0.1 %: half a unit of the last printed digit.
        assert!(
            (four - 100.0 * p1).abs() <= 0.05,
            "ν = {nu}: book {four} %, curve {p1}"
        );
        assert!(
            (ten - 100.0 * p2).abs() <= 0.005,
            "ν = {nu}: book {ten} %, curve {p2}"
        );
    }
}
