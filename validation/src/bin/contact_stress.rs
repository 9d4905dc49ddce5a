//! The contact stress suite of issue 35 (see `tetfem_validation::contact_stress`): writes
//! `<out>/report/contact_stress.csv` and `.png` and `<out>/CONTACT_STRESS.md`, and prints the
//! table. `--quick` (the CI-sized run: 9 s measured on 2 cores, ≤ 60 s) writes `quick_contact_stress.*` in
//! `report/` and no markdown file.
//!
//! `cargo run --release -p tetfem-validation --bin contact_stress -- [--quick] [--out validation]`

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;
use tetfem_validation::contact_stress::{Budget, run_suite};
use tetfem_validation::contact_stress_report::{draw, write_report};

/// Runs the contact stress suite.
#[derive(Debug, Parser)]
struct Cli {
    /// The CI-sized suite (40 % of each scene's duration, 300 steps and 2 s per cell).
    #[arg(long)]
    quick: bool,
    /// Where `report/` and `CONTACT_STRESS.md` go.
    #[arg(long, default_value = "validation")]
    out: PathBuf,
}

/// The hand-written head of CONTACT_STRESS.md.
const HEADER: &str = "# Contact stress suite (issue 35)

Written by `cargo run --release -p tetfem-validation --bin contact_stress` (rerun it to
refresh this file, `validation/report/contact_stress.csv` and `contact_stress.png`; `--quick`
is the CI-sized run, ~10 s on 2 cores, writing `quick_contact_stress.*` only).

Six scenes against rigid obstacles (a block dropped on the ground; a sphere pressing into a
block resting on the ground; a block on a moving frictional floor; a block pinched between two
plates moving towards each other; a clamped rubber beam swung against a box; a block on a
turntable spinning below its slip radius), each run by four
methods (backward Euler, Newmark and explicit with the neo-Hookean model; backward Euler with
the linear model, where Newton meets only contact's nonlinearity) at dt = 0.5, 1, 10 and 100×
the explicit critical step of the scene's mesh.

What each column is:
- **outcome**: completed; energy growth (completed, but max_t [H − W] − H(0) above 10 % of the
  energy scale, H = kinetic + elastic + gravity + barrier energy, W the moving obstacles' work:
  each step's obstacle move times the force as the method applied it over the step — at the
  step's end for backward Euler and for Newmark's barrier, the mean of the step's ends for
  Newmark's friction and the explicit method);
  penetration (a node on or inside an obstacle at an accepted step); Newton failure; staging
  failure (the moving obstacles did not reach their placement); diverged (the integrator's
  guard); refused (the library refused the combination, its message quoted); over budget (the
  cell's step or wall budget ran out first).
- **Newton mean / max**: iterations per accepted step (the integrator's counts; — for the
  explicit method).
- **worst gap**: the smallest signed distance of any boundary node to any obstacle over every
  accepted step (negative: inside).
- **worst gap at any iterate**: the same over every accepted Newton iterate inside every step
  (measured by the library after each, `BarrierRecord::smallest_iterate_gap`) and every
  accepted step — the explicit method's only states, so its two gap columns agree.
- **energy growth**: (max_t [H(t) − W(t)] − H(0)) / E_scale (negative: dissipated).
- **wall**: the cell's wall time, setup included (cells run two at a time on 2 cores).
";

fn main() -> ExitCode {
    let cli = Cli::parse();
    let prefix = if cli.quick { "quick_" } else { "" };
    let suite = match run_suite(&Budget::new(cli.quick)) {
        Ok(suite) => suite,
        Err(e) => {
            eprintln!("contact_stress: {e}");
            return ExitCode::FAILURE;
        }
    };
    let report = cli.out.join("report");
    let mut written = suite
        .write_csv(&report.join(format!("{prefix}contact_stress.csv")))
        .and_then(|()| draw(&suite, &report.join(format!("{prefix}contact_stress.png"))));
    if !cli.quick {
        written =
            written.and_then(|()| write_report(&suite, HEADER, &cli.out.join("CONTACT_STRESS.md")));
    }
    if let Err(e) = written {
        eprintln!("contact_stress: {e}");
        return ExitCode::FAILURE;
    }
    println!("{}", suite.report(""));
    ExitCode::SUCCESS
}
