//! The stability map alone (the `validate` case "stability map" runs the same): writes
//! `<out>/report/stability_map.csv` and `.png` and prints the markdown and the checks.
//!
//! `cargo run --release --bin stability_map -- [--quick] [--out validation]`

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;
use tetfem_validation::stability_map::{Grid, draw, run_map};

/// Runs the stability map.
#[derive(Debug, Parser)]
struct Cli {
    /// The CI-sized grid (9 ratios × 3 dampings, 60 steps).
    #[arg(long)]
    quick: bool,
    /// Where `report/` goes.
    #[arg(long, default_value = "validation")]
    out: PathBuf,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let prefix = if cli.quick { "quick_" } else { "" };
    let map = match run_map(&Grid::new(cli.quick)) {
        Ok(map) => map,
        Err(e) => {
            eprintln!("stability_map: {e}");
            return ExitCode::FAILURE;
        }
    };
    let report = cli.out.join("report");
    let written = map
        .write_csv(&report.join(format!("{prefix}stability_map.csv")))
        .and_then(|()| draw(&map, &report.join(format!("{prefix}stability_map.png"))));
    if let Err(e) = written {
        eprintln!("stability_map: {e}");
        return ExitCode::FAILURE;
    }
    println!(
        "{} cells in {:.1} s; dt_crit {:e} s, ω_max {:e} rad/s\n{}",
        map.cells.len(),
        map.seconds,
        map.dt_crit,
        map.omega_max,
        map.markdown()
    );
    let mut pass = true;
    for check in map.checks() {
        println!(
            "[{}] {}: {} (bound {})",
            if check.pass { "pass" } else { "FAIL" },
            check.name,
            check.measured,
            check.bound
        );
        pass &= check.pass;
    }
    if pass {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}
