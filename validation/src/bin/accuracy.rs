//! One timed static cantilever solve on P1 or P2 tets, printed as one JSON line: the tetfem side
//! of `validation/side_by_side.py --accuracy` (each run in its own process, as the peers' are).
//!
//! `cargo run --release --bin accuracy -- --order 2 --cells 20,2,2 [--repeat 3]`

use std::process::ExitCode;

use clap::Parser;
use tetfem_validation::accuracy::static_cantilever;
use tetfem_validation::cells::parse_cells;

/// One static cantilever solve (the peers' problem) at element order 1 or 2.
#[derive(Debug, Parser)]
struct Cli {
    /// Element order: 1 (4-node tets) or 2 (10-node tets on the same mesh).
    #[arg(long, default_value_t = 1)]
    order: usize,
    /// Cells NX,NY,NZ of the box grid (the peers use n,n/10,n/10).
    #[arg(long, value_parser = parse_cells)]
    cells: [usize; 3],
    /// Solves in this process; the fastest is printed (noise on a shared machine only adds).
    #[arg(long, default_value_t = 1)]
    repeat: usize,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let cells = cli.cells;
    let mut best = None;
    for _ in 0..cli.repeat.max(1) {
        match static_cantilever(cli.order, cells) {
            Ok(run) => {
                if best
                    .is_none_or(|b: tetfem_validation::accuracy::StaticRun| run.seconds < b.seconds)
                {
                    best = Some(run);
                }
            }
            Err(e) => {
                eprintln!("accuracy: {e}");
                return ExitCode::FAILURE;
            }
        }
    }
    let Some(run) = best else {
        return ExitCode::FAILURE;
    };
    println!(
        "{{\"order\": {}, \"cells\": [{}, {}, {}], \"free_dofs\": {}, \"tip\": {:e}, \"seconds\": {:e}}}",
        run.order, cells[0], cells[1], cells[2], run.free_dofs, run.tip, run.seconds
    );
    ExitCode::SUCCESS
}
