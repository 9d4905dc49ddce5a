//! Factor size study (issue 39, target 3): the size of tetfem's Cholesky factor and the cost of
//! its numeric factorization on the peers' box beams, under several symbolic settings (supernode
//! relaxation tables, METIS options), and the matrices exported as Matrix Market for
//! `validation/factor_peers.py` (PARDISO and CHOLMOD on the same K).
//!
//! `cargo run --release -p tetfem-validation --bin factor_size -- --cells 160,16,16 --export DIR`
//!
//! Prints one CSV row per (size, variant, threads): nnz(L) stored as faer stores it (dense
//! diagonal blocks, upper triangles included), stored on and below the diagonal (the count PARDISO
//! and CHOLMOD report), the exact nnz(L) (no padding), the flops of one factorization, and the
//! best-of-`--reps` symbolic, numeric and one-right-hand-side solve times with the residual.

use std::io::Write;
use std::time::Instant;

use clap::Parser;
use tetfem::linalg::linsolve::DEFAULT_RELAXATION;
use tetfem::linalg::ordering::NestedDissectionOptions;
use tetfem::{CholeskyOptions, CscMatrix, SparseCholesky};
use tetfem_fixtures::cantilever::{Cantilever, FreeSystem};
use tetfem_validation::cells::parse_cells;

#[derive(Parser)]
struct Cli {
    /// Box beams as cells NX,NY,NZ (repeatable).
    #[arg(long, value_parser = parse_cells, required = true)]
    cells: Vec<[usize; 3]>,
    /// Variants to run (names of `variants()`); default all.
    #[arg(long, value_delimiter = ',')]
    variants: Vec<String>,
    /// Numeric factorizations per variant and thread count (best kept); 0 = symbolic only.
    #[arg(long, default_value_t = 2)]
    reps: usize,
    /// Thread counts of the numeric factorization.
    #[arg(long, value_delimiter = ',', default_value = "1,2")]
    threads: Vec<usize>,
    /// Write K_ff (lower triangle, Matrix Market) and f to this directory.
    #[arg(long)]
    export: Option<std::path::PathBuf>,
}

/// One symbolic setting: a name, METIS options and a relaxation table.
struct Variant {
    name: &'static str,
    dissection: NestedDissectionOptions,
    relaxation: &'static [(usize, f64)],
}

fn variants() -> Vec<Variant> {
    let metis = NestedDissectionOptions::default();
    let with = |name, dissection, relaxation| Variant {
        name,
        dissection,
        relaxation,
    };
    vec![
        with("default", metis, DEFAULT_RELAXATION),
        with("exact", metis, &[]),
        with(
            "relax-half",
            metis,
            &[(4, 1.0), (16, 0.4), (48, 0.05), (usize::MAX, 0.025)],
        ),
        with(
            "relax-small",
            metis,
            &[(4, 1.0), (16, 0.2), (48, 0.02), (usize::MAX, 0.01)],
        ),
        with(
            "relax-wide",
            metis,
            &[(8, 1.0), (32, 0.5), (96, 0.1), (usize::MAX, 0.02)],
        ),
        with(
            "nseps2",
            NestedDissectionOptions {
                separators: Some(2),
                ..metis
            },
            DEFAULT_RELAXATION,
        ),
        with(
            "nseps3-niter20",
            NestedDissectionOptions {
                separators: Some(3),
                refinement_iterations: Some(20),
                ..metis
            },
            DEFAULT_RELAXATION,
        ),
        with(
            "ufactor30",
            NestedDissectionOptions {
                imbalance: Some(30),
                ..metis
            },
            DEFAULT_RELAXATION,
        ),
        with(
            "ufactor400",
            NestedDissectionOptions {
                imbalance: Some(400),
                ..metis
            },
            DEFAULT_RELAXATION,
        ),
        with(
            "ccorder-nocompress",
            NestedDissectionOptions {
                connected_components: Some(true),
                compress: Some(false),
                ..metis
            },
            DEFAULT_RELAXATION,
        ),
    ]
}

/// Writes the lower triangle of the symmetric `k` as Matrix Market (1-based, 17 significant
/// digits: float64 round-trips exactly) and `f` as a dense array.
fn export(
    dir: &std::path::Path,
    cells: [usize; 3],
    k: &CscMatrix,
    f: &[f64],
) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    let stem = format!("beam_{}x{}x{}", cells[0], cells[1], cells[2]);
    let (ptr, rows, vals) = (k.col_ptr(), k.row_idx(), k.values());
    let lower = (0..k.dim())
        .map(|j| rows[ptr[j]..ptr[j + 1]].iter().filter(|&&i| i >= j).count())
        .sum::<usize>();
    let mut w = std::io::BufWriter::new(std::fs::File::create(dir.join(format!("{stem}_K.mtx")))?);
    writeln!(w, "%%MatrixMarket matrix coordinate real symmetric")?;
    writeln!(w, "{} {} {}", k.dim(), k.dim(), lower)?;
    for j in 0..k.dim() {
        for p in ptr[j]..ptr[j + 1] {
            if rows[p] >= j {
                writeln!(w, "{} {} {:.16e}", rows[p] + 1, j + 1, vals[p])?;
            }
        }
    }
    let mut w = std::io::BufWriter::new(std::fs::File::create(dir.join(format!("{stem}_f.mtx")))?);
    writeln!(w, "%%MatrixMarket matrix array real general")?;
    writeln!(w, "{} 1", f.len())?;
    for v in f {
        writeln!(w, "{v:.16e}")?;
    }
    Ok(())
}

fn best_of(reps: usize, mut run: impl FnMut() -> tetfem::Result<()>) -> tetfem::Result<f64> {
    let mut best = f64::INFINITY;
    for _ in 0..reps {
        let start = Instant::now();
        run()?;
        best = best.min(start.elapsed().as_secs_f64());
    }
    Ok(best)
}

fn run(
    cli: &Cli,
    cells: [usize; 3],
    variant: &Variant,
    k: &CscMatrix,
    f: &[f64],
) -> tetfem::Result<()> {
    let label = format!("{}x{}x{}", cells[0], cells[1], cells[2]);
    let options = CholeskyOptions::default();
    let analyze =
        || SparseCholesky::analyze_tuned(k, options, variant.dissection, variant.relaxation);
    let start = Instant::now();
    let solver = analyze()?;
    let symbolic = start.elapsed().as_secs_f64();
    let exact =
        SparseCholesky::analyze_tuned(k, options, variant.dissection, &[])?.factor_nnz_lower();
    let head = format!(
        "{label},{},{},{},{},{},{:.6e},{symbolic:.4}",
        k.dim(),
        variant.name,
        solver.factor_len(),
        solver.factor_nnz_lower(),
        exact,
        solver.factor_flops()
    );
    drop(solver);
    if cli.reps == 0 {
        println!("{head},0,,,");
        return Ok(());
    }
    for &threads in &cli.threads {
        let mut solver = SparseCholesky::analyze_tuned(
            k,
            CholeskyOptions { threads, ..options },
            variant.dissection,
            variant.relaxation,
        )?;
        // The first factorization touches the factor's fresh pages (slow here): not timed.
        solver.factorize(k)?;
        let numeric = best_of(cli.reps, || Ok(solver.factorize(k)?))?;
        let mut x = f.to_vec();
        let solve = best_of(cli.reps.max(3), || {
            x.copy_from_slice(f);
            Ok(solver.solve_in_place(&mut x)?)
        })?;
        let kx = k.mul(&x)?;
        let norm = |v: &[f64]| v.iter().map(|a| a * a).sum::<f64>().sqrt();
        let r: Vec<f64> = kx.iter().zip(f).map(|(a, b)| a - b).collect();
        println!(
            "{head},{threads},{numeric:.4},{solve:.5},{:.2e}",
            norm(&r) / norm(f)
        );
    }
    Ok(())
}

fn main() -> tetfem::Result<()> {
    let cli = Cli::parse();
    println!(
        "beam,dofs,variant,stored_len,nnz_lower,nnz_exact,flops,symbolic_s,threads,numeric_s,solve_s,residual"
    );
    for &cells in &cli.cells {
        let cantilever = Cantilever::peer_benchmark(cells);
        let mesh = cantilever.mesh()?;
        let FreeSystem {
            stiffness, load, ..
        } = cantilever.free_system(&mesh)?;
        if let Some(dir) = &cli.export {
            export(dir, cells, &stiffness, &load).map_err(|source| tetfem::Error::Io {
                path: dir.clone(),
                source,
            })?;
        }
        for variant in variants()
            .iter()
            .filter(|v| cli.variants.is_empty() || cli.variants.iter().any(|n| n == v.name))
        {
            run(&cli, cells, variant, &stiffness, &load)?;
        }
    }
    Ok(())
}
