//! The validation suite: every case against an exact or independent answer, with its bound;
//! writes `validation/REPORT.md` and its charts, and exits non-zero if a case misses its bound.
//!
//! `cargo run --release --bin validate` (full, a few minutes) or `-- --quick` (CI-sized).

mod accuracy_cases;
mod cases;
mod dynamics_cases;

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use clap::Parser;

/// Runs the validation suite and writes its report.
#[derive(Debug, Parser)]
struct Cli {
    /// Smaller meshes and sweeps (about a minute), for CI.
    #[arg(long)]
    quick: bool,
    /// Where the report and charts go.
    #[arg(long, default_value = "validation")]
    out: PathBuf,
}

/// One checked claim.
pub struct Check {
    /// What is checked.
    pub name: String,
    /// The bound, in words.
    pub bound: String,
    /// The measured value, in words.
    pub measured: String,
    /// Whether the bound holds.
    pub pass: bool,
}

/// A case's contribution to the report: checks, a markdown body, charts written.
pub struct Section {
    /// Heading.
    pub title: String,
    /// Markdown body (tables, text, chart links).
    pub body: String,
    /// The checks.
    pub checks: Vec<Check>,
}

/// A check that could not run on this machine (a missing optional tool), with why: reported as
/// skipped, never counted as passed.
pub struct Skipped {
    /// What would have been checked.
    pub name: String,
    /// Why it did not run.
    pub reason: String,
}

/// What a case returns: its section and the checks it had to skip.
type Outcome = (Section, Vec<Skipped>);

/// Options shared by the cases.
pub struct Context {
    pub quick: bool,
    pub out: PathBuf,
}

/// A comparison with the peers as a case: its section, or a skip naming the program that
/// writes its CSV when the CSV is not in the output folder.
fn peers_case(context: &Context, comparison: &accuracy_cases::PeerComparison) -> Outcome {
    match accuracy_cases::peers_speed_accuracy(context, comparison) {
        Some(section) => (section, vec![]),
        None => (
            Section {
                title: comparison.title.into(),
                body: format!(
                    "No `report/{}` in the output folder: run `{}` first.\n",
                    comparison.csv, comparison.writer
                ),
                checks: vec![],
            },
            vec![Skipped {
                name: comparison.title.to_lowercase(),
                reason: format!(
                    "report/{} not written ({})",
                    comparison.csv, comparison.writer
                ),
            }],
        ),
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let context = Context {
        quick: cli.quick,
        out: cli.out.clone(),
    };
    let clock = Instant::now();
    type CaseFn = fn(&Context) -> tetfem::Result<Outcome>;
    // Non-capturing closures: the cases that never skip, lifted to an `Outcome`.
    let cases: Vec<(&str, CaseFn)> = vec![
        ("patch tests", |c| Ok((cases::patch_tests(c)?, vec![]))),
        ("manufactured solution", |c| {
            Ok((cases::manufactured(c)?, vec![]))
        }),
        ("cantilever", |c| Ok((cases::cantilever(c)?, vec![]))),
        ("cross-check", cases::cross_check),
        ("accuracy per second", |c| {
            Ok((accuracy_cases::accuracy_per_second(c)?, vec![]))
        }),
        ("speed vs accuracy beside the peers: cantilever", |c| {
            Ok(peers_case(c, &accuracy_cases::PEER_COMPARISONS[0]))
        }),
        (
            "speed vs accuracy beside the peers: plate with a hole",
            |c| Ok(peers_case(c, &accuracy_cases::PEER_COMPARISONS[1])),
        ),
        ("speed vs accuracy beside the peers: swinging beam", |c| {
            Ok(peers_case(c, &accuracy_cases::PEER_COMPARISONS[2]))
        }),
        ("modal", |c| Ok((dynamics_cases::modal(c)?, vec![]))),
        ("speed vs accuracy", |c| {
            Ok((dynamics_cases::speed_accuracy(c)?, vec![]))
        }),
        ("stability map", |c| {
            Ok((dynamics_cases::stability_map(c)?, vec![]))
        }),
        ("explicit limit against element size", |c| {
            Ok((dynamics_cases::explicit_limit_vs_size(c)?, vec![]))
        }),
        ("energy", |c| {
            Ok((dynamics_cases::energy_history(c)?, vec![]))
        }),
        ("model choice", |c| Ok((cases::model_choice(c)?, vec![]))),
    ];
    let mut sections = Vec::new();
    for (name, case) in cases {
        let start = Instant::now();
        eprintln!("validate: {name} …");
        match case(&context) {
            Ok((mut section, skipped)) => {
                for check in &section.checks {
                    eprintln!(
                        "  [{}] {}: {} (bound {})",
                        if check.pass { "pass" } else { "FAIL" },
                        check.name,
                        check.measured,
                        check.bound
                    );
                }
                for skip in &skipped {
                    eprintln!("  [skipped] {}: {}", skip.name, skip.reason);
                }
                let _ = writeln!(
                    section.body,
                    "\n_Wall time of this case: {:.1} s._",
                    start.elapsed().as_secs_f64()
                );
                sections.push((section, skipped));
            }
            Err(e) => {
                eprintln!("  [FAIL] {name}: {e}");
                sections.push((
                    Section {
                        title: name.to_string(),
                        body: format!("The case failed to run: {e}\n"),
                        checks: vec![Check {
                            name: name.into(),
                            bound: "runs".into(),
                            measured: e.to_string(),
                            pass: false,
                        }],
                    },
                    vec![],
                ));
            }
        }
    }
    match write_report(&context, &sections, clock.elapsed().as_secs_f64()) {
        Ok(path) => eprintln!("validate: wrote {}", path.display()),
        Err(e) => {
            eprintln!("validate: could not write the report: {e}");
            return ExitCode::FAILURE;
        }
    }
    let count = |f: fn(&Check) -> bool| -> usize {
        sections
            .iter()
            .map(|(s, _)| s.checks.iter().filter(|c| f(c)).count())
            .sum()
    };
    let (passed, failed) = (count(|c| c.pass), count(|c| !c.pass));
    let skipped: usize = sections.iter().map(|(_, k)| k.len()).sum();
    // The closing line alone, in this exact form: CI logs and scripts read it.
    println!("{passed} passed, {failed} failed, {skipped} skipped");
    if failed > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}

fn write_report(
    context: &Context,
    sections: &[(Section, Vec<Skipped>)],
    seconds: f64,
) -> tetfem::Result<PathBuf> {
    let mut md = String::new();
    let commit = std::process::Command::new("git")
        .args(["rev-parse", "--short", "HEAD"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map_or_else(
            || "unknown".into(),
            |o| String::from_utf8_lossy(&o.stdout).trim().to_string(),
        );
    let _ = writeln!(md, "# tetfem validation report\n");
    let _ = writeln!(
        md,
        "Generated by `cargo run --release --bin validate{}` — regenerated, never hand-edited. Commit {commit}, \
         {} cores, total wall time {seconds:.0} s. Each case states its bound; the suite exits non-zero if any is missed. A check that needs an optional tool not installed here is listed as skipped, never as passed.\n",
        if context.quick { " -- --quick" } else { "" },
        std::thread::available_parallelism().map_or(1, |n| n.get())
    );
    let _ = writeln!(
        md,
        "## Summary\n\n| case | check | bound | measured | result |\n|---|---|---|---|---|"
    );
    for (s, skipped) in sections {
        for c in &s.checks {
            let _ = writeln!(
                md,
                "| {} | {} | {} | {} | {} |",
                s.title,
                c.name,
                c.bound,
                c.measured,
                if c.pass { "pass" } else { "**FAIL**" }
            );
        }
        for k in skipped {
            let _ = writeln!(
                md,
                "| {} | {} | – | {} | skipped |",
                s.title, k.name, k.reason
            );
        }
    }
    for (s, _) in sections {
        let _ = writeln!(md, "\n## {}\n\n{}", s.title, s.body);
    }
    let name = if context.quick {
        "REPORT_QUICK.md"
    } else {
        "REPORT.md"
    };
    let path = context.out.join(name);
    tetfem::post::output::write_atomically(&path, |w| w.write_all(md.as_bytes()))?;
    Ok(path)
}

/// Relative difference |a − b| / |b|.
pub fn relative(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// Markdown link to a chart written into the output directory.
pub fn chart_link(
    context: &Context,
    chart: &tetfem_validation::chart::Chart,
    file: &str,
) -> tetfem::Result<String> {
    let name = if context.quick {
        format!("quick_{file}")
    } else {
        file.to_string()
    };
    chart.write_png(&context.out.join("report").join(&name), 900, 600)?;
    Ok(format!("![{}](report/{name})\n", chart.title))
}
