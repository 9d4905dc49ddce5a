//! The time-to-1 %-error chart of nearly incompressible elasticity: Lamé's thick-walled tube under
//! internal pressure in plane strain (`tetfem_fixtures::tube`, a = 1 m, b = 2 m) at ν = 0.4999,
//! solved on a sequence of meshes (r × 4r × 2 cells of the 6-tet split, r = 1, 2, 3, 4, 6, 8, 12,
//! 16, 24) by the linear tet (P1), the quadratic tet (P2), the stabilized P1–P1 mixed element on
//! the 4-node mesh and Taylor–Hood P2–P1 on its 10-node version. For each solve: the relative
//! error of the radial displacement at r = a against Lamé's, |1 − u_r(a)/exact|, and the wall
//! time from the mesh (constraints, loads, assembly, factorization and solve), side by side in
//! this one process, the best of `--repeats`. An element's sequence stops once its error is
//! below `--stop-below` or its unknowns exceed `--max-unknowns`. Writes `locking_cost.csv` and
//! `locking_cost.png` (time against error, log–log) into `--out`.
//!
//! `cargo run --release -p tetfem-validation --bin locking_cost`

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use clap::Parser;
use tetfem::{
    BoxSplit, ElementType, Material, MixedStaticSolver, Result, StaticSolver, Tet4, Tet10, TetMesh,
};
use tetfem_fixtures::tube::LameTube;
use tetfem_validation::chart::{Chart, Mark, Series};

/// The cost chart of the tube at ν = 0.4999.
#[derive(Debug, Parser)]
struct Cli {
    /// Timed repetitions of each solve (the fastest counts).
    #[arg(long, default_value_t = 3)]
    repeats: usize,
    /// An element's refinement stops once its relative error is below this.
    #[arg(long, default_value_t = 2e-3)]
    stop_below: f64,
    /// An element's refinement stops once its unknowns exceed this.
    #[arg(long, default_value_t = 150_000)]
    max_unknowns: usize,
    /// Where `locking_cost.csv` and `locking_cost.png` go.
    #[arg(long, default_value = "validation/report")]
    out: PathBuf,
}

const POISSON: f64 = 0.4999;
/// Radial cells r of the meshes r × 4r × 2.
const RADIAL: [usize; 9] = [1, 2, 3, 4, 6, 8, 12, 16, 24];
const ELEMENTS: [&str; 4] = [
    "P1 (4-node tet)",
    "P2 (10-node tet)",
    "mixed P1–P1 (stabilized, 4-node)",
    "mixed P2–P1 (Taylor–Hood, 10-node)",
];

/// One solve: u_r(a)/exact and its unknowns (free displacement DOFs, plus the pressures of a
/// mixed element).
fn solve(element: usize, tube: &LameTube, radial: usize, exact: f64) -> Result<(f64, usize)> {
    let material = Material::new(tube.youngs_modulus, POISSON, 1000.0)?;
    let linear = tube.mesh([radial, 4 * radial, 2], BoxSplit::Lecture6)?;
    match element {
        0 => displacement(tube, &linear, &material, exact),
        1 => displacement(
            tube,
            &TetMesh::<Tet10>::from_linear(&linear)?,
            &material,
            exact,
        ),
        2 => mixed::<Tet4>(tube, &linear, &material, exact),
        _ => mixed::<Tet10>(
            tube,
            &TetMesh::<Tet10>::from_linear(&linear)?,
            &material,
            exact,
        ),
    }
}

fn displacement<E: ElementType>(
    tube: &LameTube,
    mesh: &TetMesh<E>,
    material: &Material,
    exact: f64,
) -> Result<(f64, usize)> {
    let mut solver = StaticSolver::new(mesh, material, &tube.constraints(mesh)?)?;
    let solution = solver.solve(&tube.loads(mesh)?)?;
    Ok((
        tube.inner_radial_displacement(mesh, &solution.displacement) / exact,
        solver.dofs().free_count(),
    ))
}

fn mixed<E: tetfem::fe::element::MixedElement>(
    tube: &LameTube,
    mesh: &TetMesh<E>,
    material: &Material,
    exact: f64,
) -> Result<(f64, usize)> {
    let mut solver = MixedStaticSolver::<E>::new(mesh, material, &tube.constraints(mesh)?)?;
    let solution = solver.solve(&tube.loads(mesh)?)?;
    Ok((
        tube.inner_radial_displacement(mesh, &solution.displacement) / exact,
        solver.system().dim(),
    ))
}

fn run(cli: &Cli) -> Result<String> {
    let tube = LameTube::default();
    let exact = tube.radial_displacement(POISSON, tube.inner);
    let mut csv = String::from("element,radial_cells,unknowns,ratio,relative_error,seconds\n");
    let mut series = Vec::new();
    for (element, label) in ELEMENTS.iter().enumerate() {
        let mut points = Vec::new();
        for radial in RADIAL {
            let mut best = f64::INFINITY;
            let mut last = (f64::NAN, 0);
            for _ in 0..cli.repeats.max(1) {
                // The mesh is built inside the clock: each element from the same 4-node mesh.
                let clock = Instant::now();
                last = solve(element, &tube, radial, exact)?;
                best = best.min(clock.elapsed().as_secs_f64());
            }
            let (ratio, unknowns) = last;
            let error = (1.0 - ratio).abs();
            let _ = writeln!(
                csv,
                "{label},{radial},{unknowns},{ratio:.6},{error:.4e},{best:.5}"
            );
            eprintln!("{label} r = {radial}: {unknowns} unknowns, error {error:.3e}, {best:.4} s");
            points.push((best, error));
            if error < cli.stop_below || unknowns > cli.max_unknowns {
                break;
            }
        }
        series.push(Series::new(*label, points, Mark::LinePoints));
    }
    let (lo, hi) = series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.0))
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), t| {
            (lo.min(t), hi.max(t))
        });
    series.push(Series::new(
        "1 % error",
        vec![(lo, 0.01), (hi, 0.01)],
        Mark::Dashed,
    ));
    std::fs::create_dir_all(&cli.out).map_err(|source| tetfem::Error::Io {
        path: cli.out.clone(),
        source,
    })?;
    let path = cli.out.join("locking_cost.csv");
    std::fs::write(&path, &csv).map_err(|source| tetfem::Error::Io { path, source })?;
    let chart = Chart {
        title: "Lamé tube in plane strain at ν = 0.4999: wall time against the error of u_r(a), \
                meshes r × 4r × 2 cells"
            .into(),
        x_label: "wall time from the mesh, best of repeats (s)".into(),
        y_label: "|1 − u_r(a) / Lamé's| (–)".into(),
        log_x: true,
        log_y: true,
        series,
    };
    chart.write_png(&cli.out.join("locking_cost.png"), 1100, 700)?;
    Ok(csv)
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(&cli) {
        Ok(csv) => {
            print!("{csv}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("locking_cost: {e}");
            ExitCode::FAILURE
        }
    }
}
