//! The contact stress suite's outputs ([`crate::contact_stress`]): its CSV, its markdown table
//! and its chart (one map per scene: method × dt multiple, coloured by outcome, annotated with
//! Newton's iterations and the worst gap).

use std::fmt::Write as _;
use std::path::Path;

use tetfem::base::error::{Error, Result};

use crate::contact_stress::{Cell, MULTIPLES, Outcome, Scene, Scheme, Suite};

/// Creates `path`'s folder and writes `text` there.
fn write(path: &Path, text: &str) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| Error::Io {
            path: dir.to_path_buf(),
            source,
        })?;
    }
    std::fs::write(path, text).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// "6.2 / 14" (mean / max Newton iterations per step) or "—" for the explicit method.
fn iterations(cell: &Cell) -> String {
    match cell.iterations {
        Some((mean, max)) => format!("{mean:.1} / {max}"),
        None => "—".into(),
    }
}

/// A gap in µm with its sign ("+12.3 µm", "−40 µm"), or "—" when none was measured.
fn micrometres(gap: f64) -> String {
    match gap.is_finite() {
        true => format!("{:+.3} µm", gap * 1e6).replace('-', "−"),
        false => "—".into(),
    }
}

/// A gap in µm to 0.1 µm, signed, for the chart's cells (the table keeps 1 nm: a cell is
/// 1/16 of a panel's width and the longer figure ran over its edges).
fn micrometres_short(gap: f64) -> String {
    match gap.is_finite() {
        true => format!("{:+.1} µm", gap * 1e6).replace('-', "−"),
        false => "—".into(),
    }
}

/// The worst gap of the accepted steps ([`micrometres`]).
fn gap(cell: &Cell) -> String {
    micrometres(cell.worst_gap)
}

impl Suite {
    /// The cells as CSV: scene, method (quoted: "backward Euler, linear"), dt multiple, dt (s), outcome, steps taken and planned,
    /// Newton iterations mean and max (empty for the explicit method), worst gap (m), worst gap
    /// at any iterate (m), energy growth, wall seconds, note.
    pub fn csv(&self) -> String {
        let mut text = String::from(
            "scene,method,dt_over_dt_crit,dt_s,outcome,steps,steps_planned,newton_mean,newton_max,worst_gap_m,worst_iterate_gap_m,energy_growth,wall_s,note\n",
        );
        for c in &self.cells {
            let (mean, max) = match c.iterations {
                Some((mean, max)) => (format!("{mean:.3}"), max.to_string()),
                None => (String::new(), String::new()),
            };
            let _ = writeln!(
                text,
                "{},\"{}\",{},{:e},{},{},{},{},{},{:e},{:e},{:.3e},{:.3},\"{}\"",
                c.scene.name(),
                c.scheme.name(),
                c.multiple,
                c.dt,
                c.outcome.name(),
                c.steps.0,
                c.steps.1,
                mean,
                max,
                c.worst_gap,
                c.worst_iterate_gap,
                c.growth,
                c.seconds,
                c.note.replace('"', "'")
            );
        }
        text
    }

    /// Writes [`csv`](Self::csv) to `path`.
    pub fn write_csv(&self, path: &Path) -> Result<()> {
        write(path, &self.csv())
    }

    /// The cell of `scene`, `scheme` at `multiple`.
    pub fn cell(&self, scene: Scene, scheme: Scheme, multiple: f64) -> Option<&Cell> {
        self.cells
            .iter()
            .find(|c| c.scene == scene && c.scheme == scheme && c.multiple == multiple)
    }

    /// The markdown table: scene × method × dt → outcome, steps, iterations mean/max, worst
    /// gap, energy growth, wall time, and the message of a cell that failed.
    pub fn markdown(&self) -> String {
        let mut md = String::from(
            "| scene | method | dt/dt_crit | dt (s) | outcome | steps | Newton mean / max | worst gap | worst gap at any iterate | energy growth | wall (s) | message |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n",
        );
        for scene in Scene::ALL {
            for scheme in Scheme::ALL {
                for multiple in MULTIPLES {
                    let Some(c) = self.cell(scene, scheme, multiple) else {
                        continue;
                    };
                    let note: String = c.note.chars().take(140).collect();
                    let _ = writeln!(
                        md,
                        "| {} | {} | {} | {:.2e} | {} | {}/{} | {} | {} | {} | {:.2e} | {:.2} | {} |",
                        scene.name(),
                        scheme.name(),
                        multiple,
                        c.dt,
                        c.outcome.name(),
                        c.steps.0,
                        c.steps.1,
                        iterations(c),
                        gap(c),
                        micrometres(c.worst_iterate_gap),
                        c.growth,
                        c.seconds,
                        note.replace('|', "/")
                    );
                }
            }
        }
        md
    }

    /// `validation/CONTACT_STRESS.md`: `header` (hand-written: what is measured, how to rerun),
    /// the critical steps, the table and the count of each outcome.
    pub fn report(&self, header: &str) -> String {
        let mut md = String::from(header);
        let _ = writeln!(
            md,
            "\n## Measured\n\n{} cells in {:.1} s wall (budget per cell: {} steps, {} s, {} of each scene's duration).\n",
            self.cells.len(),
            self.seconds,
            self.budget.steps,
            self.budget.wall,
            self.budget.duration_fraction
        );
        let criticals: Vec<String> = self
            .critical_steps
            .iter()
            .map(|(s, dt)| format!("{} {dt:.3e} s", s.name()))
            .collect();
        let _ = writeln!(
            md,
            "Explicit critical steps (dt_crit): {}.\n",
            criticals.join(", ")
        );
        let counts: Vec<String> = Outcome::ALL
            .iter()
            .filter_map(|&o| {
                let n = self.cells.iter().filter(|c| c.outcome == o).count();
                (n > 0).then(|| format!("{} {n}", o.name()))
            })
            .collect();
        let _ = writeln!(md, "Outcomes: {}.\n", counts.join(", "));
        md.push_str(&self.markdown());
        md
    }
}

/// Writes [`Suite::report`] to `path`.
pub fn write_report(suite: &Suite, header: &str, path: &Path) -> Result<()> {
    write(path, &suite.report(header))
}

/// The drawing area the chart draws on.
type Area<'a> =
    plotters::drawing::DrawingArea<plotters::prelude::BitMapBackend<'a>, plotters::coord::Shift>;

/// Draws the suite as a PNG: one map per scene (x: dt / dt_crit, y: method), each cell a box
/// coloured by its outcome with the mean / max Newton iterations per step and the worst gap
/// written in it; the legend of the outcomes that occur below.
pub fn draw(suite: &Suite, path: &Path) -> Result<()> {
    use plotters::prelude::*;
    let fail = |e: String| Error::Io {
        path: path.to_path_buf(),
        source: std::io::Error::other(e),
    };
    crate::chart::register();
    write(path, "")?;
    let (width, height) = (2100, 1500);
    let root = BitMapBackend::new(path, (width, height)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| fail(e.to_string()))?;
    let (top, rest) = root.split_vertically(80);
    for (k, line) in [
        "Contact stress suite: outcome per method (rows) and time step (columns: dt / dt_crit, dt_crit the explicit critical step of the scene's mesh)",
        "In each cell: Newton iterations per step, mean / max (implicit methods); the worst gap of any boundary node to any obstacle over the accepted steps and over every accepted Newton iterate (\"iter.\"; µm, < 0: inside); steps taken / planned",
    ]
    .iter()
    .enumerate()
    {
        top.draw(&Text::new(
            *line,
            (20, 10 + 32 * k as i32),
            ("sans-serif", if k == 0 { 24 } else { 19 }).into_font(),
        ))
        .map_err(|e| fail(e.to_string()))?;
    }
    let (body, legend) = rest.split_vertically(height - 80 - 80);
    let areas = body.split_evenly((2, 3));
    for (scene, area) in Scene::ALL.iter().zip(&areas) {
        draw_scene(suite, *scene, area).map_err(fail)?;
    }
    let shown: Vec<Outcome> = Outcome::ALL
        .into_iter()
        .filter(|&o| suite.cells.iter().any(|c| c.outcome == o))
        .collect();
    draw_legend(&legend, &shown).map_err(fail)
}

/// One scene's map on `area`.
fn draw_scene(suite: &Suite, scene: Scene, area: &Area<'_>) -> std::result::Result<(), String> {
    use plotters::prelude::*;
    use plotters::style::text_anchor::{HPos, Pos, VPos};
    let dt_crit = suite
        .critical_steps
        .iter()
        .find(|(s, _)| *s == scene)
        .map_or(0.0, |(_, dt)| *dt);
    let columns = MULTIPLES.len() as f64;
    let rows = Scheme::ALL.len() as f64;
    let mut chart = ChartBuilder::on(area)
        .caption(
            format!("{} (dt_crit = {:.2e} s)", scene.name(), dt_crit),
            ("sans-serif", 22),
        )
        .margin(10)
        .x_label_area_size(50)
        .y_label_area_size(190)
        .build_cartesian_2d(-0.5..columns - 0.5, -0.5..rows - 0.5)
        .map_err(|e| e.to_string())?;
    let label = |v: &f64, names: &[String]| {
        let i = v.round();
        match (v - i).abs() < 1e-9 && i >= 0.0 {
            true => names.get(i as usize).cloned().unwrap_or_default(),
            false => String::new(),
        }
    };
    let x_names: Vec<String> = MULTIPLES.iter().map(|m| format!("{m}×")).collect();
    // Rows top to bottom in Scheme::ALL's order: row i at y = rows − 1 − i.
    let y_names: Vec<String> = Scheme::ALL.iter().rev().map(|s| s.name().into()).collect();
    chart
        .configure_mesh()
        .disable_mesh()
        .x_labels(MULTIPLES.len())
        .y_labels(Scheme::ALL.len())
        .x_label_formatter(&|v| label(v, &x_names))
        .y_label_formatter(&|v| label(v, &y_names))
        .x_desc("dt / dt_crit (dt_crit in s above)")
        .y_desc("method (neo-Hookean unless linear)")
        .label_style(("sans-serif", 16))
        .axis_desc_style(("sans-serif", 16))
        .draw()
        .map_err(|e| e.to_string())?;
    let centre =
        TextStyle::from(("sans-serif", 15).into_font()).pos(Pos::new(HPos::Center, VPos::Center));
    for (i, scheme) in Scheme::ALL.iter().enumerate() {
        let y = rows - 1.0 - i as f64;
        for (j, &multiple) in MULTIPLES.iter().enumerate() {
            let Some(c) = suite.cell(scene, *scheme, multiple) else {
                continue;
            };
            let x = j as f64;
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(x - 0.47, y - 0.45), (x + 0.47, y + 0.45)],
                    c.outcome.colour().filled(),
                )))
                .map_err(|e| e.to_string())?;
            let lines = [
                match c.iterations {
                    Some((mean, max)) => format!("N {mean:.1} / {max}"),
                    None => "no Newton".into(),
                },
                format!("gap {}", micrometres_short(c.worst_gap)),
                format!("iter. {}", micrometres_short(c.worst_iterate_gap)),
                format!("{}/{} steps", c.steps.0, c.steps.1),
            ];
            for (k, line) in lines.iter().enumerate() {
                chart
                    .draw_series(std::iter::once(Text::new(
                        line.clone(),
                        (x, y + 0.3 - 0.2 * k as f64),
                        centre.clone(),
                    )))
                    .map_err(|e| e.to_string())?;
            }
        }
    }
    Ok(())
}

/// The legend strip: a box and the name of each outcome shown.
fn draw_legend(area: &Area<'_>, outcomes: &[Outcome]) -> std::result::Result<(), String> {
    use plotters::prelude::*;
    let style = ("sans-serif", 20).into_font();
    let mut x = 40;
    for &outcome in outcomes {
        area.draw(&Rectangle::new(
            [(x, 24), (x + 30, 50)],
            outcome.colour().filled(),
        ))
        .map_err(|e| e.to_string())?;
        area.draw(&Text::new(outcome.name(), (x + 38, 26), style.clone()))
            .map_err(|e| e.to_string())?;
        x += 70 + 12 * outcome.name().len() as i32;
    }
    Ok(())
}
