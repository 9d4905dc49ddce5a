//! The stability map measured by running (issue 37, item 2): each method × force model ×
//! {free, over a ground obstacle}, over a grid of dt/dt_crit (0.1 … 1000) against the
//! Rayleigh stiffness damping β, every cell a short run classified by what happened.
//!
//! The second axis is stiffness damping (given as ξ_max = β·ω_max/2, the damping ratio it puts
//! on the mesh's top mode) rather than Poisson's ratio: dt is plotted against the undamped
//! critical step 2/ω_max, which already absorbs how ν moves ω_max, whereas β moves the explicit
//! limit *relative* to 2/ω_max, to (√(1 + ξ²) − ξ)·2/ω_max (see
//! `tetfem::analysis::dynamics::damped_critical_step`): the map can be held against a formula.

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use nalgebra::Vector3;
use rayon::prelude::*;
use tetfem::analysis::Definition;
use tetfem::analysis::dynamics::{Method, Rayleigh, State, critical_time_step};
use tetfem::analysis::transient::{
    Flow, Observer, StepView, TimeStep, Transient, TransientOptions,
};
use tetfem::base::error::{Error, Result};
use tetfem::contact::{Contact, ContactParameters, Obstacle};
use tetfem::fe::materials::MaterialMap;
use tetfem::model::ModelKind;
use tetfem::{BoxSplit, Constraints, Material, TetMesh};

use crate::watch::EnergyRecord;

/// What a cell's run did, in the order the classification tests it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Class {
    /// Every step taken, the energy within the bound.
    Stable,
    /// Every step taken, but the total energy rose above its start by more than
    /// [`ENERGY_GROWTH_BOUND`] of the largest energy in motion.
    EnergyGrowth,
    /// The integrator's divergence guard stopped the run (energy 10× what the start and the
    /// loads supplied, or a non-finite value).
    Diverged,
    /// An implicit step's Newton iteration did not converge (or its line search found no step).
    NewtonFailure,
    /// A node ended a step on or inside the obstacle (the barrier must keep every gap > 0).
    Penetration,
    /// The library refused the combination (`Transient::new` failed; none does today: Newmark
    /// with obstacles runs, with a warning).
    Refused,
}

impl Class {
    /// Every class, in legend order.
    pub const ALL: [Class; 6] = [
        Class::Stable,
        Class::EnergyGrowth,
        Class::Diverged,
        Class::NewtonFailure,
        Class::Penetration,
        Class::Refused,
    ];

    /// The name the CSV and the legend use.
    pub fn name(self) -> &'static str {
        match self {
            Class::Stable => "stable",
            Class::EnergyGrowth => "energy growth",
            Class::Diverged => "diverged",
            Class::NewtonFailure => "Newton failure",
            Class::Penetration => "penetration",
            Class::Refused => "not supported",
        }
    }
}

/// Energy growth counted as a failure: (max_t H(t) − H(0)) / E_scale above 0.1, with H the
/// total energy (kinetic + elastic + gravity potential + barrier energy) and E_scale the largest
/// of H(0) and of kinetic + elastic over the run. Newmark conserves H, backward Euler and
/// damping lower it; 10 % leaves room for the explicit method's O((ω·dt)²) energy oscillation.
pub const ENERGY_GROWTH_BOUND: f64 = 0.1;

/// The grid of the map.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    /// dt / dt_crit values (dt_crit = 2/ω_max of the undamped linear system).
    pub ratios: Vec<f64>,
    /// Damping ratios ξ_max = β·ω_max/2 at the top mode (β = 2ξ_max/ω_max, s).
    pub xis: Vec<f64>,
    /// Steps per cell.
    pub steps: usize,
}

impl Grid {
    /// The full grid: 21 ratios, 5 per decade from 0.1 to 1000; ξ_max ∈ {0, 0.05, 0.13, 0.26,
    /// 0.5, 1, 2} (0.26 is the issue's β = 1e-4 s on the rubber scene); 200 steps. `quick`: 9
    /// ratios (2 per decade), ξ_max ∈ {0, 0.26, 1}, 60 steps.
    pub fn new(quick: bool) -> Self {
        let per_decade = if quick { 2 } else { 5 };
        let ratios = (-per_decade..=3 * per_decade)
            .map(|k| 10f64.powf(f64::from(k) / f64::from(per_decade)))
            .collect();
        let xis = if quick {
            vec![0.0, 0.26, 1.0]
        } else {
            vec![0.0, 0.05, 0.13, 0.26, 0.5, 1.0, 2.0]
        };
        Grid {
            ratios,
            xis,
            steps: if quick { 60 } else { 200 },
        }
    }
}

/// One panel of the map: a method, a force model, with or without the ground.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Panel {
    /// The integrator.
    pub method: Method,
    /// The force model.
    pub model: ModelKind,
    /// Whether the ground obstacle is there.
    pub ground: bool,
}

impl Panel {
    /// Every panel: backward Euler, Newmark, explicit × linear, corotational × free, ground.
    pub fn all() -> Vec<Panel> {
        let mut panels = Vec::new();
        for method in [Method::BackwardEuler, Method::Newmark, Method::Explicit] {
            for model in [ModelKind::Linear, ModelKind::Corotational] {
                for ground in [false, true] {
                    panels.push(Panel {
                        method,
                        model,
                        ground,
                    });
                }
            }
        }
        panels
    }

    /// "explicit · corotational · ground".
    pub fn label(&self) -> String {
        format!(
            "{} · {} · {}",
            method_name(self.method),
            self.model.name(),
            if self.ground { "ground" } else { "free" }
        )
    }
}

/// The method's name as the map writes it.
pub fn method_name(method: Method) -> &'static str {
    match method {
        Method::BackwardEuler => "backward Euler",
        Method::Newmark => "Newmark",
        Method::Explicit => "explicit",
    }
}

/// One cell's run.
#[derive(Debug, Clone, PartialEq)]
pub struct Cell {
    /// Its panel.
    pub panel: Panel,
    /// dt / dt_crit.
    pub ratio: f64,
    /// ξ_max = β·ω_max/2.
    pub xi: f64,
    /// The class.
    pub class: Class,
    /// Steps taken before the run ended.
    pub steps: usize,
    /// (max H − H(0)) / E_scale over the steps taken (see [`ENERGY_GROWTH_BOUND`]).
    pub growth: f64,
    /// The error that ended the run, if any.
    pub note: String,
}

/// The map: the body's critical step and the cells.
#[derive(Debug, Clone)]
pub struct Map {
    /// 2/ω_max of the undamped linear system (s), the unit of the ratios.
    pub dt_crit: f64,
    /// ω_max (rad/s).
    pub omega_max: f64,
    /// The grid.
    pub grid: Grid,
    /// Every cell, panel by panel.
    pub cells: Vec<Cell>,
    /// Wall time of the whole map (s).
    pub seconds: f64,
}

/// The body: a rubber beam 0.2 × 0.05 × 0.05 m (E = 0.5 MPa, ν = 0.45, ρ = 1100 kg/m³, the
/// material of `scenes/rubber_beam_swing.toml`) on 6 × 1 × 1 cells (five tets each), clamped at
/// x = 0, under gravity, started with 1 m/s downwards (so that it reaches the ground within the
/// smallest dt's run). The ground is a half-space 1 mm below the beam.
pub const GROUND_GAP: f64 = 1e-3;

fn definition(model: ModelKind, ground: bool) -> Result<Definition> {
    let mesh = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(0.2, 0.05, 0.05),
        [6, 1, 1],
        BoxSplit::Five,
    )?;
    let material = Material::new(5e5, 0.45, 1100.0)?;
    let materials = MaterialMap::uniform(material, mesh.tet_count());
    let mut constraints = Constraints::new(&mesh);
    constraints.fix_nodes(&mesh.nodes_on_plane(0, 0.0, 1e-9))?;
    let mut builder = Definition::builder(mesh.clone(), materials)
        .model(model)
        .constraints(constraints)?
        .gravity(Vector3::new(0.0, 0.0, -9.81))?;
    if ground {
        let floor =
            Obstacle::half_space("ground", Vector3::new(0.0, 0.0, -GROUND_GAP), Vector3::z())?;
        let parameters = ContactParameters::for_mesh(&mesh, material.youngs_modulus())?;
        builder = builder.contact(Contact::new(&mesh, vec![floor], parameters)?);
    }
    builder.build()
}

/// Watches a cell's run: the penetration test and the energy record.
struct Watch {
    energy: EnergyRecord,
    penetrated: bool,
}

impl Watch {
    /// The total energy H of `state` (kinetic + elastic + potentials + barrier), and kinetic +
    /// elastic.
    fn energy(view: &StepView<'_>, state: &State) -> Result<(f64, f64)> {
        let energy = view.force.energy(view.system, state)?;
        let barrier = match view.force.contact() {
            Some(contact) => {
                contact.energy(&view.system.expand_at(state.time, &state.displacement)?)?
            }
            None => 0.0,
        };
        Ok((energy.total() + barrier, energy.kinetic + energy.elastic))
    }
}

impl Observer for Watch {
    fn observe(&mut self, view: &StepView<'_>) -> Result<Flow> {
        if let Some(contact) = view.force.contact() {
            let full = view
                .system
                .expand_at(view.state.time, &view.state.displacement)?;
            if contact.nodes_inside(&full)?.is_some() {
                self.penetrated = true;
                return Ok(Flow::Stop);
            }
        }
        if let Some(state) = self.energy.measured(view.state) {
            let (total, motion) = Watch::energy(view, &state)?;
            self.energy.take(total, 0.0, motion);
        }
        Ok(Flow::Continue)
    }
}

/// Runs one cell.
fn run_cell(panel: Panel, ratio: f64, xi: f64, context: &CellContext) -> Cell {
    let mut cell = Cell {
        panel,
        ratio,
        xi,
        class: Class::Stable,
        steps: 0,
        growth: 0.0,
        note: String::new(),
    };
    let definition = match panel.ground {
        true => &context.ground[model_index(panel.model)],
        false => &context.free[model_index(panel.model)],
    };
    let beta = 2.0 * xi / context.omega_max;
    let options = match Rayleigh::new(0.0, beta) {
        Ok(damping) => TransientOptions {
            damping,
            ..TransientOptions::new(panel.method, TimeStep::Seconds(ratio * context.dt_crit))
        },
        Err(e) => {
            cell.class = Class::Refused;
            cell.note = e.to_string();
            return cell;
        }
    };
    let mut run = match Transient::new(definition, options) {
        Ok(run) => run,
        Err(e) => {
            cell.class = Class::Refused;
            cell.note = e.to_string();
            return cell;
        }
    };
    // The start: 1 m/s downwards on every free z DOF (the clamped nodes stay at rest).
    let free = run.system().dofs().free_dofs().to_vec();
    for (v, dof) in run.state_mut().velocity.iter_mut().zip(&free) {
        if dof % 3 == 2 {
            *v = -1.0;
        }
    }
    let initial = run.state().clone();
    let mut watch = Watch {
        energy: EnergyRecord::new(panel.method == Method::Explicit, initial),
        penetrated: false,
    };
    let end = run.run((0, context.steps), &mut watch);
    cell.steps = run.state().steps;
    if let Some(growth) = watch.energy.growth() {
        cell.growth = growth;
    }
    cell.class = match end {
        Err(Error::Diverged { .. }) => Class::Diverged,
        Err(e) => {
            cell.note = e.to_string();
            match e {
                Error::NotConverged { .. } => Class::NewtonFailure,
                // A step that left a node inside the obstacle fails in the barrier's force.
                _ if panel.ground && cell.note.contains("obstacle") => Class::Penetration,
                _ => Class::NewtonFailure,
            }
        }
        Ok(_) if watch.penetrated => Class::Penetration,
        Ok(_) if !cell.growth.is_finite() || cell.growth > ENERGY_GROWTH_BOUND => {
            Class::EnergyGrowth
        }
        Ok(_) => Class::Stable,
    };
    cell
}

fn model_index(model: ModelKind) -> usize {
    usize::from(model != ModelKind::Linear)
}

/// What every cell shares.
struct CellContext {
    free: [Definition; 2],
    ground: [Definition; 2],
    dt_crit: f64,
    omega_max: f64,
    steps: usize,
}

/// Runs every cell of `grid` on every [`Panel::all`] (in parallel on rayon's pool).
pub fn run_map(grid: &Grid) -> Result<Map> {
    let clock = Instant::now();
    let context = CellContext {
        free: [
            definition(ModelKind::Linear, false)?,
            definition(ModelKind::Corotational, false)?,
        ],
        ground: [
            definition(ModelKind::Linear, true)?,
            definition(ModelKind::Corotational, true)?,
        ],
        dt_crit: 0.0,
        omega_max: 0.0,
        steps: grid.steps,
    };
    let system = context.free[0].transient_system(
        tetfem::analysis::dynamics::MassKind::Lumped,
        Rayleigh::default(),
    )?;
    let critical = critical_time_step(&system)?;
    let context = CellContext {
        dt_crit: critical.dt,
        omega_max: critical.omega_max,
        ..context
    };
    let jobs: Vec<(Panel, f64, f64)> = Panel::all()
        .into_iter()
        .flat_map(|panel| {
            grid.xis
                .iter()
                .flat_map(move |&xi| grid.ratios.iter().map(move |&r| (panel, r, xi)))
        })
        .collect();
    let cells = jobs
        .into_par_iter()
        .map(|(panel, ratio, xi)| run_cell(panel, ratio, xi, &context))
        .collect();
    Ok(Map {
        dt_crit: context.dt_crit,
        omega_max: context.omega_max,
        grid: grid.clone(),
        cells,
        seconds: clock.elapsed().as_secs_f64(),
    })
}

impl Map {
    /// The cells as CSV: method, model, obstacle, ξ_max, β (s), dt/dt_crit, dt (s), class,
    /// steps, energy growth, note.
    pub fn csv(&self) -> String {
        let mut text = String::from(
            "method,model,obstacle,xi_max,beta_s,dt_over_dt_crit,dt_s,class,steps,energy_growth,note\n",
        );
        for c in &self.cells {
            let _ = writeln!(
                text,
                "{},{},{},{},{:e},{:.6},{:e},{},{},{:.3e},\"{}\"",
                method_name(c.panel.method),
                c.panel.model.name(),
                if c.panel.ground { "ground" } else { "none" },
                c.xi,
                2.0 * c.xi / self.omega_max,
                c.ratio,
                c.ratio * self.dt_crit,
                c.class.name(),
                c.steps,
                c.growth,
                c.note.replace('"', "'")
            );
        }
        text
    }

    /// Writes [`csv`](Self::csv) to `path`.
    pub fn write_csv(&self, path: &Path) -> Result<()> {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|source| Error::Io {
                path: dir.to_path_buf(),
                source,
            })?;
        }
        std::fs::write(path, self.csv()).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })
    }

    /// The cells of `panel` at ξ_max = `xi`, by ratio.
    pub fn row(&self, panel: Panel, xi: f64) -> Vec<&Cell> {
        self.cells
            .iter()
            .filter(|c| c.panel == panel && c.xi == xi)
            .collect()
    }
}

/// The explicit method's limit on dt/dt_crit at damping ratio ξ_max on the top mode:
/// √(1 + ξ²) − ξ (see `tetfem::analysis::dynamics::damped_critical_step`).
pub fn explicit_limit(xi: f64) -> f64 {
    1.0 / (1.0f64.hypot(xi) + xi)
}

/// The colour of each class on the map.
fn colour(class: Class) -> plotters::style::RGBColor {
    use plotters::style::RGBColor;
    match class {
        Class::Stable => RGBColor(120, 190, 120),
        Class::EnergyGrowth => RGBColor(245, 200, 60),
        Class::Diverged => RGBColor(215, 60, 50),
        Class::NewtonFailure => RGBColor(150, 90, 190),
        Class::Penetration => RGBColor(60, 130, 210),
        Class::Refused => RGBColor(200, 200, 200),
    }
}

/// Draws the map as a PNG: one panel per [`Panel::all`] (rows: methods; columns: linear free,
/// linear ground, corotational free, corotational ground), x = dt/dt_crit (log), y = ξ_max,
/// each cell a coloured box; on the explicit panels the dashed line is the formula's limit
/// √(1 + ξ²) − ξ; the legend of the classes below.
pub fn draw(map: &Map, path: &Path) -> Result<()> {
    use plotters::prelude::*;
    let fail = |e: String| Error::Io {
        path: path.to_path_buf(),
        source: std::io::Error::other(e),
    };
    crate::chart::register();
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| Error::Io {
            path: dir.to_path_buf(),
            source,
        })?;
    }
    let root = BitMapBackend::new(path, (1800, 1250)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| fail(e.to_string()))?;
    let title = format!(
        "Stability map: {} steps per cell, rubber beam 6×1×1 cells; dt_crit = 2/ω_max = {:.3e} s, \
         ω_max = {:.0} rad/s, stiffness damping β = 2·ξ_max/ω_max (s)",
        map.grid.steps, map.dt_crit, map.omega_max
    );
    let (top, rest) = root.split_vertically(50);
    top.titled(&title, ("sans-serif", 26))
        .map_err(|e| fail(e.to_string()))?;
    let (body, legend) = rest.split_vertically(1250 - 50 - 60);
    let panels = Panel::all();
    let areas = body.split_evenly((3, 4));
    let rows = map.grid.xis.len() as f64;
    let (lo, hi) = (
        map.grid.ratios.first().copied().unwrap_or(0.1),
        map.grid.ratios.last().copied().unwrap_or(1000.0),
    );
    let half = match map.grid.ratios.len() {
        0 | 1 => 1.5,
        n => (hi / lo).powf(0.5 / (n - 1) as f64),
    };
    let xis = map.grid.xis.clone();
    for (panel, area) in panels.iter().zip(&areas) {
        let mut chart = ChartBuilder::on(area)
            .caption(panel.label(), ("sans-serif", 18))
            .margin(8)
            .x_label_area_size(40)
            .y_label_area_size(55)
            .build_cartesian_2d(
                ((lo / half)..(hi * half))
                    .log_scale()
                    .with_key_points(vec![0.1, 1.0, 10.0, 100.0, 1000.0]),
                -0.5..rows - 0.5,
            )
            .map_err(|e| fail(e.to_string()))?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("dt / dt_crit (dt_crit = 2/ω_max)")
            .y_desc("ξ_max = β·ω_max/2")
            .label_style(("sans-serif", 13))
            .axis_desc_style(("sans-serif", 13))
            .x_label_formatter(&|v| format!("{v}"))
            .y_labels(xis.len())
            .y_label_formatter(&|v| {
                // Row i is centred on y = i: label the integer ticks with their ξ.
                let i = v.round();
                match (v - i).abs() < 1e-9 && i >= 0.0 {
                    true => xis
                        .get(i as usize)
                        .map_or(String::new(), |x| format!("{x}")),
                    false => String::new(),
                }
            })
            .draw()
            .map_err(|e| fail(e.to_string()))?;
        for (i, &xi) in map.grid.xis.iter().enumerate() {
            let y = i as f64;
            chart
                .draw_series(map.row(*panel, xi).into_iter().map(|c| {
                    Rectangle::new(
                        // 90 % of the cell's width: a white seam between neighbours.
                        [
                            (c.ratio / half.powf(0.9), y - 0.46),
                            (c.ratio * half.powf(0.9), y + 0.46),
                        ],
                        colour(c.class).filled(),
                    )
                }))
                .map_err(|e| fail(e.to_string()))?;
        }
        if panel.method == Method::Explicit {
            // The formula's limit, a vertical dash per ξ row.
            for (i, &xi) in map.grid.xis.iter().enumerate() {
                let x = explicit_limit(xi);
                chart
                    .draw_series(std::iter::once(PathElement::new(
                        vec![(x, i as f64 - 0.5), (x, i as f64 + 0.5)],
                        BLACK.stroke_width(3),
                    )))
                    .map_err(|e| fail(e.to_string()))?;
            }
        }
    }
    // The legend lists every class but "not supported" unless a cell is.
    let shown: Vec<Class> = Class::ALL
        .into_iter()
        .filter(|&c| c != Class::Refused || map.cells.iter().any(|cell| cell.class == c))
        .collect();
    draw_legend(&legend, &shown).map_err(fail)
}

/// The legend strip: a box and the name of each class, and the explicit limit's mark.
fn draw_legend(
    area: &plotters::drawing::DrawingArea<
        plotters::prelude::BitMapBackend<'_>,
        plotters::coord::Shift,
    >,
    classes: &[Class],
) -> std::result::Result<(), String> {
    use plotters::prelude::*;
    let style = ("sans-serif", 18).into_font();
    let mut x = 40;
    for &class in classes {
        area.draw(&Rectangle::new(
            [(x, 18), (x + 28, 42)],
            colour(class).filled(),
        ))
        .map_err(|e| e.to_string())?;
        area.draw(&Text::new(class.name(), (x + 36, 20), style.clone()))
            .map_err(|e| e.to_string())?;
        x += 60 + 11 * class.name().len() as i32;
    }
    area.draw(&PathElement::new(
        vec![(x, 14), (x, 46)],
        BLACK.stroke_width(3),
    ))
    .map_err(|e| e.to_string())?;
    area.draw(&Text::new(
        "explicit: the formula's limit (√(1+ξ²) − ξ)·dt_crit",
        (x + 10, 20),
        style,
    ))
    .map_err(|e| e.to_string())?;
    Ok(())
}

/// One claim the map is checked against: name, bound, measured, whether it holds.
#[derive(Debug, Clone, PartialEq)]
pub struct MapCheck {
    /// What is checked.
    pub name: String,
    /// The bound, in words.
    pub bound: String,
    /// The measured value, in words.
    pub measured: String,
    /// Whether the bound holds.
    pub pass: bool,
}

impl Map {
    /// The claims the map must bear out: the explicit method (linear, free and over the ground)
    /// stable at every ratio ≤ 0.95× its formula's limit and diverged at every ratio ≥ 1.05×
    /// it, on every ξ row;
    /// backward Euler and Newmark (linear, free) stable in every cell (unconditional stability
    /// with Rayleigh damping); Newmark with the ground never gaining energy; no cell with the
    /// ground penetrating it.
    pub fn checks(&self) -> Vec<MapCheck> {
        let mut checks = Vec::new();
        let free = |method| Panel {
            method,
            model: ModelKind::Linear,
            ground: false,
        };
        for ground in [false, true] {
            checks.push(self.explicit_limit_check(ground));
        }
        for method in [Method::BackwardEuler, Method::Newmark] {
            let cells: Vec<&Cell> = self
                .cells
                .iter()
                .filter(|c| c.panel == free(method))
                .collect();
            let unstable = cells.iter().filter(|c| c.class != Class::Stable).count();
            checks.push(MapCheck {
                name: format!(
                    "{}, linear, free: unconditionally stable",
                    method_name(method)
                ),
                bound: "every cell stable, dt/dt_crit up to 1000".into(),
                measured: format!("{unstable} of {} cells not stable", cells.len()),
                pass: unstable == 0 && !cells.is_empty(),
            });
        }
        // Newmark takes the contact force at the step's end and damps with the material's
        // stiffness alone: with the linear model and the ground no cell may gain energy.
        let newmark_ground: Vec<&Cell> = self
            .cells
            .iter()
            .filter(|c| {
                c.panel.method == Method::Newmark
                    && c.panel.ground
                    && c.panel.model == ModelKind::Linear
            })
            .collect();
        let unstable = newmark_ground
            .iter()
            .filter(|c| c.class != Class::Stable)
            .count();
        checks.push(MapCheck {
            name: "Newmark, linear, with the ground: contact never adds energy".into(),
            bound: "every cell stable, dt/dt_crit up to 1000".into(),
            measured: format!("{unstable} of {} cells not stable", newmark_ground.len()),
            pass: unstable == 0 && !newmark_ground.is_empty(),
        });
        // The explicit method's impulses keep every node d̂ off the ground at any dt, and the
        // implicit methods' line search keeps every gap > 0 (CCD): no cell may end inside.
        let inside = self
            .cells
            .iter()
            .filter(|c| c.class == Class::Penetration)
            .count();
        let grounded = self.cells.iter().filter(|c| c.panel.ground).count();
        checks.push(MapCheck {
            name: "with the ground: no node ends a step inside it, any method, any dt".into(),
            bound: "0 cells classified penetration".into(),
            measured: format!("{inside} of {grounded} cells with the ground"),
            pass: inside == 0 && grounded > 0,
        });
        checks
    }

    /// The explicit method (linear) free or over the ground against its formula's limit
    /// √(1 + ξ²) − ξ on every ξ row: stable at ≤ 0.95× it, diverged at ≥ 1.05×. Over the
    /// ground the limit is the body's: the explicit method's contact acts on the velocity
    /// (`tetfem::contact::velocity`) and keeps every node at least d̂ off the obstacle, where
    /// the barrier is not active, so contact adds no stiffness to the critical step.
    fn explicit_limit_check(&self, ground: bool) -> MapCheck {
        let panel = Panel {
            method: Method::Explicit,
            model: ModelKind::Linear,
            ground,
        };
        let (mut below, mut above, mut wrong) = (0, 0, Vec::new());
        for c in self.cells.iter().filter(|c| c.panel == panel) {
            let limit = explicit_limit(c.xi);
            if c.ratio <= 0.95 * limit {
                below += 1;
                if c.class != Class::Stable {
                    wrong.push(format!("ξ {} at {:.3}: {}", c.xi, c.ratio, c.class.name()));
                }
            } else if c.ratio >= 1.05 * limit {
                above += 1;
                if c.class != Class::Diverged {
                    wrong.push(format!("ξ {} at {:.3}: {}", c.xi, c.ratio, c.class.name()));
                }
            }
        }
        MapCheck {
            name: match ground {
                false => {
                    "explicit, linear, free: the measured limit is the formula's (√(1+ξ²) − ξ)"
                }
                true => {
                    "explicit, linear, with the ground: the limit is the body's (the impulses keep \
                     nodes d̂ off the ground, where the barrier adds no stiffness)"
                }
            }
            .into(),
            bound: "stable at ≤ 0.95× the limit, diverged at ≥ 1.05×, every ξ".into(),
            measured: match wrong.is_empty() {
                true => format!("{below} cells below, {above} above, all as predicted"),
                false => format!(
                    "{} of {} cells differ: {}",
                    wrong.len(),
                    below + above,
                    wrong.join("; ")
                ),
            },
            pass: wrong.is_empty() && below > 0 && above > 0,
        }
    }

    /// Markdown: per panel and ξ row, the largest ratio up to which every cell is stable and
    /// the class of the first cell that is not; the class counts of each panel.
    pub fn markdown(&self) -> String {
        let mut md = String::new();
        let _ = writeln!(
            md,
            "| panel | class counts | largest stable dt/dt_crit (then: first failure) per ξ_max = {} |\n|---|---|---|",
            self.grid
                .xis
                .iter()
                .map(|x| x.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
        for panel in Panel::all() {
            let counts: Vec<String> = Class::ALL
                .iter()
                .filter_map(|&class| {
                    let n = self
                        .cells
                        .iter()
                        .filter(|c| c.panel == panel && c.class == class)
                        .count();
                    (n > 0).then(|| format!("{} {n}", class.name()))
                })
                .collect();
            let rows: Vec<String> = self
                .grid
                .xis
                .iter()
                .map(|&xi| {
                    let row = self.row(panel, xi);
                    let first = row.iter().position(|c| c.class != Class::Stable);
                    match first {
                        None => "all ≤ 1000 stable".to_string(),
                        Some(0) => format!("none ({})", row[0].class.name()),
                        Some(k) => format!(
                            "{:.3} ({} at {:.3})",
                            row[k - 1].ratio,
                            row[k].class.name(),
                            row[k].ratio
                        ),
                    }
                })
                .collect();
            let _ = writeln!(
                md,
                "| {} | {} | {} |",
                panel.label(),
                counts.join(", "),
                rows.join("; ")
            );
        }
        md
    }
}

#[cfg(test)]
mod tests {
    use super::{Grid, explicit_limit};

    #[test]
    fn the_grid_spans_the_issue_range_log_spaced() {
        for quick in [false, true] {
            let grid = Grid::new(quick);
            let r = &grid.ratios;
            // 0.1 and 1000 to round-off (10^(k/n) by powf), at least 12 values outside quick.
            assert!((r[0] - 0.1).abs() < 1e-12 && (r[r.len() - 1] - 1000.0).abs() < 1e-9);
            assert!(quick || r.len() >= 12, "{} ratios", r.len());
            let step = r[1] / r[0];
            assert!(
                r.windows(2)
                    .all(|w| (w[1] / w[0] - step).abs() < 1e-9 * step)
            );
        }
    }

    #[test]
    fn the_explicit_limit_is_the_root_of_the_jury_condition() {
        // h = limit·2/ω solves (hω)² + 2·(2ξω)·h = 4, i.e. 4ℓ² + 8ξℓ = 4, for every ξ.
        for xi in [0.0, 0.05, 0.26, 1.0, 2.0, 50.0] {
            let l = explicit_limit(xi);
            assert!((l * l + 2.0 * xi * l - 1.0).abs() < 1e-12, "ξ = {xi}: {l}");
        }
        // The issue's 0.774× at ξ = 0.26.
        assert!((explicit_limit(0.26) - 0.7733).abs() < 1e-4);
    }
}
