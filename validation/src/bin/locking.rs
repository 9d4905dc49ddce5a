//! The locking chart: Lamé's thick-walled tube under internal pressure in plane strain
//! (`tetfem_fixtures::tube`, a = 1 m, b = 2 m), its radial displacement at r = a over the exact
//! value against Poisson's ratio ν ∈ {0.3, 0.45, 0.49, 0.499, 0.4999}, for the linear tet (P1),
//! the quadratic tet (P2) and the mixed Taylor–Hood P2–P1 element, all on one mesh (`--cells`
//! of the 6-tet split; P2 and mixed on its 10-node version). Each solve is timed (assembly,
//! factorization and solve, from the mesh), side by side in this one process, the best of
//! `--repeats`. Writes `locking.csv`, `locking.png` and `locking_error.png` (the error on log axes) into
//! `--out`.
//!
//! `cargo run --release -p tetfem-validation --bin locking -- --cells 6,24,2`

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use clap::Parser;
use tetfem::{
    BoxSplit, Material, MixedStaticSolver, Result, StaticSolver, Tet10, TetMaterials, TetMesh,
};
use tetfem_fixtures::tube::LameTube;
use tetfem_validation::cells::parse_cells;
use tetfem_validation::chart::{Chart, Mark, Series};

/// The locking chart of the tube.
#[derive(Debug, Parser)]
struct Cli {
    /// Cells radial,circumferential,axial of the quarter tube.
    #[arg(long, default_value = "6,24,2", value_parser = parse_cells)]
    cells: [usize; 3],
    /// Timed repetitions of each solve (the fastest counts).
    #[arg(long, default_value_t = 3)]
    repeats: usize,
    /// Where `locking.csv`, `locking.png` and `locking_error.png` go.
    #[arg(long, default_value = "validation/report")]
    out: PathBuf,
}

const POISSON: [f64; 5] = [0.3, 0.45, 0.49, 0.499, 0.4999];

/// One element's answer at one ν: u_r(a)/exact, the best wall time (s) and the unknowns.
#[derive(Debug, Clone, Copy)]
struct Answer {
    ratio: f64,
    seconds: f64,
    unknowns: usize,
}

/// Runs `solve` `repeats` times; its ratio and unknowns from the last, the fastest time.
fn timed(repeats: usize, mut solve: impl FnMut() -> Result<(f64, usize)>) -> Result<Answer> {
    let mut best = f64::INFINITY;
    let mut last = (f64::NAN, 0);
    for _ in 0..repeats.max(1) {
        let clock = Instant::now();
        last = solve()?;
        best = best.min(clock.elapsed().as_secs_f64());
    }
    Ok(Answer {
        ratio: last.0,
        seconds: best,
        unknowns: last.1,
    })
}

fn run(cli: &Cli) -> Result<String> {
    let tube = LameTube::default();
    let linear = tube.mesh(cli.cells, BoxSplit::Lecture6)?;
    let quadratic = TetMesh::<Tet10>::from_linear(&linear)?;
    let mut csv = String::from(
        "poisson_ratio,p1_ratio,p2_ratio,mixed_ratio,p1_seconds,p2_seconds,mixed_seconds,\
         p1_unknowns,p2_unknowns,mixed_unknowns\n",
    );
    let mut series = [Vec::new(), Vec::new(), Vec::new()];
    for nu in POISSON {
        let material = Material::new(tube.youngs_modulus, nu, 1000.0)?;
        let exact = tube.radial_displacement(nu, tube.inner);
        let p1 = timed(cli.repeats, || {
            displacement_solve(&tube, &linear, &material, exact)
        })?;
        let p2 = timed(cli.repeats, || {
            displacement_solve(&tube, &quadratic, &material, exact)
        })?;
        let mixed = timed(cli.repeats, || {
            let mut solver =
                MixedStaticSolver::new(&quadratic, &material, &tube.constraints(&quadratic)?)?;
            let solution = solver.solve(&tube.loads(&quadratic)?)?;
            Ok((
                tube.inner_radial_displacement(&quadratic, &solution.displacement) / exact,
                solver.system().dim(),
            ))
        })?;
        let _ = writeln!(
            csv,
            "{nu},{},{},{},{:.4},{:.4},{:.4},{},{},{}",
            p1.ratio,
            p2.ratio,
            mixed.ratio,
            p1.seconds,
            p2.seconds,
            mixed.seconds,
            p1.unknowns,
            p2.unknowns,
            mixed.unknowns
        );
        for (points, answer) in series.iter_mut().zip([p1, p2, mixed]) {
            points.push((0.5 - nu, answer.ratio));
        }
    }
    std::fs::create_dir_all(&cli.out).map_err(|source| tetfem::Error::Io {
        path: cli.out.clone(),
        source,
    })?;
    let path = cli.out.join("locking.csv");
    std::fs::write(&path, &csv).map_err(|source| tetfem::Error::Io { path, source })?;
    let [p1, p2, mixed] = series;
    let chart = Chart {
        title: format!(
            "Lamé tube in plane strain, {}×{}×{} cells (6-tet split): locking as ν → 0.5",
            cli.cells[0], cli.cells[1], cli.cells[2]
        ),
        x_label: "0.5 − ν (–)".into(),
        y_label: "radial displacement at r = a / Lamé's (–)".into(),
        log_x: true,
        log_y: false,
        series: vec![
            Series::new("P1 (4-node tet)", p1, Mark::LinePoints),
            Series::new("P2 (10-node tet)", p2, Mark::LinePoints),
            Series::new("mixed P2–P1 (Taylor–Hood)", mixed, Mark::LinePoints),
            Series::new(
                "exact",
                POISSON.iter().map(|nu| (0.5 - nu, 1.0)).collect(),
                Mark::Dashed,
            ),
        ],
    };
    chart.write_png(&cli.out.join("locking.png"), 1100, 700)?;
    error_chart(cli, &chart.series[..3])?;
    Ok(csv)
}

/// The same three elements' error |1 − u_r/exact| on log axes (`locking_error.png`): on the
/// ratio chart the mixed element's line and the exact one lie within 7e-4 of each other and
/// P2's within 5e-3, so only a log scale shows the three apart.
fn error_chart(cli: &Cli, ratios: &[Series]) -> Result<()> {
    let series = ratios
        .iter()
        .map(|s| {
            let errors = s
                .points
                .iter()
                .map(|&(x, r)| (x, (1.0 - r).abs()))
                .collect();
            Series::new(s.label.clone(), errors, Mark::LinePoints)
        })
        .collect();
    let chart = Chart {
        title: format!(
            "Lamé tube, {}×{}×{} cells: error of the radial displacement at r = a",
            cli.cells[0], cli.cells[1], cli.cells[2]
        ),
        x_label: "0.5 − ν (–)".into(),
        y_label: "|1 − u_r(a) / Lamé's| (–)".into(),
        log_x: true,
        log_y: true,
        series,
    };
    chart.write_png(&cli.out.join("locking_error.png"), 1100, 700)
}

/// The displacement element's solve of the tube on `mesh`: u_r(a)/exact and the free DOFs.
fn displacement_solve<E: tetfem::ElementType>(
    tube: &LameTube,
    mesh: &TetMesh<E>,
    material: &(impl TetMaterials + Clone),
    exact: f64,
) -> Result<(f64, usize)> {
    let mut solver = StaticSolver::new(mesh, material, &tube.constraints(mesh)?)?;
    let solution = solver.solve(&tube.loads(mesh)?)?;
    Ok((
        tube.inner_radial_displacement(mesh, &solution.displacement) / exact,
        solver.dofs().free_count(),
    ))
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(&cli) {
        Ok(csv) => {
            print!("{csv}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("locking: {e}");
            ExitCode::FAILURE
        }
    }
}
