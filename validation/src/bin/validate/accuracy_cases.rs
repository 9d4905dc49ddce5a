//! Accuracy per second on the static cantilever: linear (P1) and quadratic (P2) tets on the same
//! meshes, error against wall time, the Pareto front and the cheapest run to each error level.

use std::fmt::Write as _;

use tetfem::Result;
use tetfem::post::convergence::richardson;
use tetfem_fixtures::cantilever::Cantilever;
use tetfem_validation::accuracy::{StaticRun, static_cantilever};
use tetfem_validation::chart::{Chart, Mark, Series};

use super::{Check, Context, Section, chart_link, relative};

/// The P2 meshes of the Richardson reference: n × n/10 × n/10 at a refinement ratio of 2.
const REFERENCE_SIZES: [usize; 3] = [20, 40, 80];
/// The quick (CI) reference: one level coarser, seconds instead of a minute.
const QUICK_REFERENCE_SIZES: [usize; 3] = [10, 20, 40];

/// Fastest of `repeats` runs (noise on a shared machine only ever adds time).
fn fastest(order: usize, n: usize, repeats: usize) -> Result<StaticRun> {
    let mut best = static_cantilever(order, [n, n / 10, n / 10])?;
    for _ in 1..repeats {
        let run = static_cantilever(order, [n, n / 10, n / 10])?;
        if run.seconds < best.seconds {
            best = run;
        }
    }
    Ok(best)
}

/// One compared run with its error against the reference.
struct Point {
    run: StaticRun,
    error: f64,
}

impl Point {
    fn label(&self) -> String {
        let [x, y, z] = self.run.cells;
        format!("P{} {x}×{y}×{z}", self.run.order)
    }
}

pub fn accuracy_per_second(context: &Context) -> Result<Section> {
    let (reference_sizes, p1_sizes, p2_sizes): (_, &[usize], &[usize]) = if context.quick {
        (QUICK_REFERENCE_SIZES, &[10, 20, 40, 80], &[10, 20])
    } else {
        (REFERENCE_SIZES, &[10, 20, 40, 80, 160], &[10, 20, 40])
    };
    // The reference is extrapolated from P2 solves; the compared P2 runs are timed separately and
    // the extrapolated value is no run's own answer, so no point of the chart is its own reference.
    let mut tips = Vec::new();
    for n in reference_sizes {
        tips.push(static_cantilever(2, [n, n / 10, n / 10])?.tip);
    }
    let extrapolated = richardson(tips[0], tips[1], tips[2], 2.0)?;
    let reference = extrapolated.value;
    let (_, timoshenko) = Cantilever::peer_benchmark([10, 1, 1]).beam_theory_tip();
    let points = timed_points(p1_sizes, p2_sizes, reference)?;
    let mut body = accuracy_table(&points, reference_sizes, &extrapolated, timoshenko);
    body.push('\n');
    body.push_str(&accuracy_chart(context, &points)?);
    let checks = accuracy_checks(context, &mut body, &points, reference, timoshenko);
    Ok(Section {
        title: "Accuracy per second (static, P1 and P2)".into(),
        body,
        checks,
    })
}

/// The timed P1 and P2 runs on `p1_sizes` and `p2_sizes` (cells along the beam), each with its
/// tip error against `reference`.
fn timed_points(p1_sizes: &[usize], p2_sizes: &[usize], reference: f64) -> Result<Vec<Point>> {
    let mut points = Vec::new();
    for &n in p1_sizes {
        // 160×16×16 takes tens of seconds per solve: once is enough to place it on the chart.
        let repeats = if n >= 160 { 1 } else { 2 };
        let run = fastest(1, n, repeats)?;
        points.push(Point {
            error: relative(run.tip, reference),
            run,
        });
    }
    for &n in p2_sizes {
        let run = fastest(2, n, 2)?;
        points.push(Point {
            error: relative(run.tip, reference),
            run,
        });
    }
    Ok(points)
}

/// Whether `p` is on the Pareto front of `points` (no run both faster and more accurate).
fn on_front(points: &[Point], p: &Point) -> bool {
    !points
        .iter()
        .any(|q| q.run.seconds < p.run.seconds && q.error < p.error)
}

/// The fastest run of `points` within relative error `target`, of element order `order` (any
/// without one).
fn cheapest(points: &[Point], order: Option<usize>, target: f64) -> Option<&Point> {
    points
        .iter()
        .filter(|p| p.error <= target && order.is_none_or(|o| p.run.order == o))
        .min_by(|a, b| a.run.seconds.total_cmp(&b.run.seconds))
}

/// The section's text: the problem, the reference, every run's row (Pareto front marked) and
/// the cheapest run within 10 %, 1 %, 0.1 %.
fn accuracy_table(
    points: &[Point],
    reference_sizes: [usize; 3],
    extrapolated: &tetfem::post::convergence::Richardson,
    timoshenko: f64,
) -> String {
    let reference = extrapolated.value;
    let [r0, r1, r2] = reference_sizes;
    let mut body = format!(
        "The peers' cantilever (L = 10, W = H = 1, E = 1e5, ν = 0.3, end load 1, lecture split of n × n/10 × n/10 cells) \
         solved on linear tets (P1) and on quadratic tets of the same meshes (P2: a node at every edge's middle). Tip: \
         mean z-displacement of the vertices on x = L, for both orders. Reference: Richardson extrapolation of P2 tips at \
         {r0}, {r1} and {r2} cells along the beam: {reference:.9e} (observed order {:.2}; Timoshenko's beam value \
         {timoshenko:.6e} lies {:.2}% above it in magnitude). Wall time: mesh generation to displacement (mid-edge nodes, \
         constraints, loads, assembly, ordering, factorization, solve), fastest of 2 (one for 160×16×16), default \
         threads.\n\n\
         | elements | mesh | free DOFs | tip | error | wall time [s] | Pareto |\n|---|---|---|---|---|---|---|\n",
        extrapolated.order,
        100.0 * (timoshenko.abs() / reference.abs() - 1.0),
    );
    for p in points {
        let [x, y, z] = p.run.cells;
        let _ = writeln!(
            body,
            "| P{} | {x}×{y}×{z} | {} | {:.9e} | {:.2e} | {:.4} | {} |",
            p.run.order,
            p.run.free_dofs,
            p.run.tip,
            p.error,
            p.run.seconds,
            if on_front(points, p) { "◆" } else { "" }
        );
    }
    let _ = writeln!(body);
    for target in [0.1, 0.01, 0.001] {
        let _ = writeln!(
            body,
            "- Cheapest run within {:.1}% error: {}",
            100.0 * target,
            cheapest(points, None, target).map_or("none in this sweep".to_string(), |p| format!(
                "{} ({} free DOFs, {:.4} s, error {:.2e})",
                p.label(),
                p.run.free_dofs,
                p.run.seconds,
                p.error
            ))
        );
    }
    body
}

/// The accuracy-per-second chart (P1, P2 and the Pareto front), as the report's link to it.
fn accuracy_chart(context: &Context, points: &[Point]) -> Result<String> {
    let mut series: Vec<Series> = [1, 2]
        .iter()
        .map(|&order| {
            Series::new(
                if order == 1 {
                    "tetfem P1 (4-node tets)"
                } else {
                    "tetfem P2 (10-node tets)"
                },
                points
                    .iter()
                    .filter(|p| p.run.order == order)
                    .map(|p| (p.run.seconds, p.error))
                    .collect(),
                Mark::LinePoints,
            )
        })
        .collect();
    let mut front: Vec<(f64, f64)> = points
        .iter()
        .filter(|p| on_front(points, p))
        .map(|p| (p.run.seconds, p.error))
        .collect();
    front.sort_by(|a, b| a.0.total_cmp(&b.0));
    series.push(Series::new("Pareto front", front, Mark::Dashed));
    let chart = Chart {
        title: "Accuracy per second: static cantilever tip error against wall time".into(),
        x_label: "wall time per solve [s]".into(),
        y_label: "relative tip error".into(),
        log_x: true,
        log_y: true,
        series,
    };
    chart_link(context, &chart, "accuracy_static.png")
}

/// The checks: P2 within 1 % at ≤ 20k DOFs, the reference against Timoshenko, and (full report
/// only) P1's time to 1 % against P2's; the time ratio's line written into `body`.
fn accuracy_checks(
    context: &Context,
    body: &mut String,
    points: &[Point],
    reference: f64,
    timoshenko: f64,
) -> Vec<Check> {
    // Issue 19's bar for the element: 1 % of the converged answer at ≤ 20k DOFs.
    let small_p2 = points
        .iter()
        .filter(|p| p.run.order == 2 && p.run.free_dofs <= 20_000)
        .map(|p| p.error)
        .fold(f64::INFINITY, f64::min);
    // P1's time to 1 %: its cheapest run that gets there, or, when none does, its slowest run
    // (still above 1 %, so a lower bound on what P1 would need).
    let p2_one_percent = cheapest(points, Some(2), 0.01);
    let p1_one_percent = cheapest(points, Some(1), 0.01).or_else(|| {
        points
            .iter()
            .filter(|p| p.run.order == 1)
            .max_by(|a, b| a.run.seconds.total_cmp(&b.run.seconds))
    });
    let speedup = match (p1_one_percent, p2_one_percent) {
        (Some(p1), Some(p2)) => p1.run.seconds / p2.run.seconds,
        _ => 0.0,
    };
    let p1_reaches = cheapest(points, Some(1), 0.01).is_some();
    let speed_check = Check {
        name: format!(
            "time to 1 % error: P1 ({}) / P2",
            if p1_reaches {
                "its cheapest run within 1 %"
            } else {
                "none within 1 %: its slowest run, a lower bound"
            }
        ),
        bound: "≥ 10".into(),
        measured: format!("{speedup:.0}"),
        pass: speedup >= 10.0,
    };
    let _ = writeln!(
        body,
        "\n{}: {} (issue 19's goal ≥ 10).",
        speed_check.name, speed_check.measured
    );
    let mut checks = vec![
        Check {
            name: "P2 within 1 % of the reference at ≤ 20k free DOFs".into(),
            bound: "≤ 1 %".into(),
            measured: format!("{:.3}%", 100.0 * small_p2),
            pass: small_p2 <= 0.01,
        },
        // A sanity bound on the reference, not a convergence claim: the 3-D answer of this beam
        // lies below Timoshenko's beam theory by its end-constraint and shear-warping effects,
        // 0.75 % by the P1 extrapolation of issue 19; more than 2 % either way would mean the
        // reference (or the element) is wrong.
        Check {
            name: "reference vs Timoshenko's beam value".into(),
            bound: "within 2 %".into(),
            measured: format!("{:.2}%", 100.0 * relative(reference, timoshenko)),
            pass: relative(reference, timoshenko) <= 0.02,
        },
    ];
    // A wall-time ratio is a measurement, not a test: the full report checks it (its P1 sweep
    // reaches 139k DOFs, a lower bound well above the goal); the quick (CI) run, whose slowest
    // P1 run is 80×8×8 on a shared machine, only prints it above.
    if !context.quick {
        checks.insert(1, speed_check);
    }
    checks
}

/// A speed-against-accuracy comparison with the peers that a Python program of
/// `validation/` writes as a CSV and a chart under `report/` (it needs the peers' harness,
/// `validation/setup_peers.sh`, so `validate` reads its last result rather than running it).
pub struct PeerComparison {
    /// The section's title.
    pub title: &'static str,
    /// The CSV under `report/` (first line a `# ` comment: reference, BLAS, threads).
    pub csv: &'static str,
    /// The chart under `report/`.
    pub png: &'static str,
    /// The command that writes both.
    pub writer: &'static str,
    /// What is compared, and how.
    pub problem: &'static str,
    /// The table's columns: (heading, the CSV's column); a `pareto` column, when listed, is
    /// shown as ◆ on the front.
    pub columns: &'static [(&'static str, &'static str)],
}

/// The three comparisons of issue 37's item 1: (a) the static cantilever, (b) the plate with
/// a hole, (c) the swinging beam.
pub const PEER_COMPARISONS: [PeerComparison; 3] = [
    PeerComparison {
        title: "Speed against accuracy beside the peers (static cantilever)",
        csv: "speed_accuracy.csv",
        png: "speed_accuracy.png",
        writer: "python3 validation/side_by_side.py --accuracy",
        problem: "Static cantilever L × W × H = 10 × 1 × 1 (n × n/10 × n/10 cells of the lecture \
                  split, E = 1e5, ν = 0.3, end load 1), identical meshes in every code; time from \
                  mesh to displacement, one thread each; error of the tip deflection against the \
                  reference.",
        columns: &[
            ("code", "code"),
            ("order", "order"),
            ("mesh", "mesh"),
            ("free DOFs", "free_dofs"),
            ("relative error", "relative_error"),
            ("wall time (s)", "seconds"),
            ("Pareto front", "pareto"),
        ],
    },
    PeerComparison {
        title: "Speed against accuracy beside the peers (plate with a hole)",
        csv: "speed_accuracy_hole.csv",
        png: "speed_accuracy_hole.png",
        writer: "python3 validation/side_by_side.py --accuracy-hole",
        problem: "A 3-D plate with a central hole under tension (one eighth, symmetry rollers), \
                  σ_xx at the hole's edge by tetfem's nodal recovery in every code, identical \
                  meshes (MFEM curved: the same vertices with curved P2); time from mesh to \
                  recovered stress, one thread each (see `validation/SPEED_ACCURACY.md`).",
        columns: &[
            ("code", "code"),
            ("order", "order"),
            ("mesh", "mesh"),
            ("free DOFs", "free_dofs"),
            ("σ_xx", "sxx"),
            ("relative error", "relative_error"),
            ("wall time (s)", "seconds"),
            ("Pareto front", "pareto"),
        ],
    },
    PeerComparison {
        title: "Speed against accuracy beside the peers (swinging beam)",
        csv: "speed_accuracy_swing.csv",
        png: "speed_accuracy_swing.png",
        writer: "python3 validation/dynamic_speed_accuracy.py",
        problem: "The swinging beam over one period, backward Euler, Newmark and explicit \
                  central differences at 32–15 584 steps per period, identical meshes, M and K \
                  in tetfem, scikit-fem and MFEM; error of the tip trajectory against a \
                  converged reference (MFEM order 5, graded mesh, modal in time), one thread \
                  each (see `validation/SPEED_ACCURACY.md`).",
        columns: &[
            ("code", "code"),
            ("order", "order"),
            ("mesh", "mesh"),
            ("method", "method"),
            ("steps per period", "steps_per_period"),
            ("relative error", "relative_error"),
            ("wall time (s)", "seconds"),
            ("Pareto front", "pareto"),
        ],
    },
];

/// The section of `comparison`: its CSV as a table and its chart; `None` when the CSV is not
/// in the output folder.
pub fn peers_speed_accuracy(context: &Context, comparison: &PeerComparison) -> Option<Section> {
    let path = context.out.join("report").join(comparison.csv);
    let text = std::fs::read_to_string(&path).ok()?;
    let mut lines = text.lines();
    let header = lines.next()?.trim_start_matches("# ").to_string();
    let names: Vec<&str> = lines.next()?.split(',').collect();
    let index: Vec<usize> = comparison
        .columns
        .iter()
        .map(|(_, column)| names.iter().position(|n| n == column))
        .collect::<Option<_>>()?;
    let headings: Vec<&str> = comparison.columns.iter().map(|(h, _)| *h).collect();
    let mut body = format!(
        "Written by `{}` (needs the peers' harness, `validation/setup_peers.sh`; `validate` \
         reads its last result). {} {header}.\n\n| {} |\n|{}\n",
        comparison.writer,
        comparison.problem,
        headings.join(" | "),
        "---|".repeat(headings.len()),
    );
    for line in lines {
        let f: Vec<&str> = line.split(',').collect();
        let cells: Vec<&str> = index
            .iter()
            .zip(comparison.columns)
            .map(|(&i, (_, column))| match (*column, f.get(i).copied()) {
                ("pareto", Some("1")) => "◆",
                ("pareto", _) => "",
                (_, value) => value.unwrap_or(""),
            })
            .collect();
        let _ = writeln!(body, "| {} |", cells.join(" | "));
    }
    let _ = writeln!(body, "\n![{}](report/{})", comparison.title, comparison.png);
    Some(Section {
        title: comparison.title.into(),
        body,
        checks: vec![],
    })
}
